"""One compiled source, two targets: the CPU (numba) and NVIDIA GPUs (numba-cuda).

The kernels are written once, as ``@njit`` functions; a CUDA kernel (``rotlab.ensemble.gpu``)
calls them as device functions, and numba-cuda compiles them again for the GPU.  What the two
targets do differently is declared here, once:

* ``overload``: numba's ``overload`` for the CPU, registered for CUDA as well once
  ``enable_cuda`` has run (numba-cuda keeps its own registry of overloads);
* ``work_vector(n)``, ``work_matrix(rows, n)``: ``np.empty`` on the CPU; on a GPU a thread's own
  local array (``n`` and ``rows`` compile-time constants there: the state's size, a method's
  stage count);
* ``next_toward(x, y)``: ``np.nextafter(x, y)`` (libdevice's ``nextafter`` on a GPU);
* ``on_gpu()``: a compile-time False, or True on a GPU, for code shaped for the device (the same
  arithmetic); ``gpu_overload``: a function's implementation on a GPU alone.

Nothing here imports numba-cuda until ``enable_cuda`` is called.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numba import types
from numba.extending import overload as cpu_overload

_FOR_CUDA: list[tuple[Callable, dict, Callable]] = []  # (function, overload options, implementation) to register for CUDA
_GPU_ONLY: list[tuple[Callable, dict, Callable]] = []  # CUDA implementations of the functions declared below
_cuda_enabled = False  # the overloads are registered for numba-cuda (never under the simulator)


def overload(func: Callable, **options) -> Callable[[Callable], Callable]:
    """``numba.extending.overload(func, **options)`` for the CPU, and for CUDA once ``enable_cuda`` runs."""
    def register(impl: Callable) -> Callable:
        cpu_overload(func, **options)(impl)
        _FOR_CUDA.append((func, options, impl))
        if _cuda_enabled:
            _register_cuda(func, options, impl)
        return impl
    return register


def gpu_overload(func: Callable, **options) -> Callable[[Callable], Callable]:
    """``func``'s implementation on a GPU (registered by ``enable_cuda``, or at once where it has
    run: a module imported after it must not leave the GPU the CPU's implementation)."""
    def register(impl: Callable) -> Callable:
        _GPU_ONLY.append((func, options, impl))
        if _cuda_enabled:
            _register_cuda(func, options, impl)
        return impl
    return register


def _register_cuda(func: Callable, options: dict, impl: Callable) -> None:
    from numba.cuda.extending import overload as cuda_overload

    cuda_overload(func, **options)(impl)


def enable_cuda() -> None:
    """Register every overload for numba-cuda (once per process).  Under numba's CUDA simulator
    (``NUMBA_ENABLE_CUDASIM=1``) kernels run as Python calling the CPU's compiled functions: nothing to register."""
    global _cuda_enabled
    if not hasattr(np, "row_stack"):  # NumPy ≥ 2.4 removed it; some numba-cuda releases still call it
        np.row_stack = np.vstack
    from numba import config

    if _cuda_enabled or config.ENABLE_CUDASIM:
        return
    for func, options, impl in _GPU_ONLY + _FOR_CUDA:
        _register_cuda(func, options, impl)
    _cuda_enabled = True


def work_vector(n):
    """An uninitialised float64 vector of ``n`` (a compiled function's scratch)."""
    raise NotImplementedError("compiled code only")


def work_matrix(rows, n):
    """An uninitialised float64 (rows, n) matrix (a compiled function's scratch)."""
    raise NotImplementedError("compiled code only")


def on_gpu():
    """Whether the code is being compiled for a GPU (a compile-time constant)."""
    raise NotImplementedError("compiled code only")


def next_toward(x, y):
    """The float64 next to ``x`` in the direction of ``y`` (``np.nextafter``)."""
    raise NotImplementedError("compiled code only")


@cpu_overload(work_vector, inline="always")
def _work_vector_cpu(n):
    return lambda n: np.empty(n)


@cpu_overload(work_matrix, inline="always")
def _work_matrix_cpu(rows, n):
    return lambda rows, n: np.empty((rows, n))


@cpu_overload(on_gpu, inline="always")
def _on_gpu_cpu():
    return lambda: False


@cpu_overload(next_toward, inline="always")
def _next_toward_cpu(x, y):
    return lambda x, y: np.nextafter(x, y)


@gpu_overload(work_vector, inline="always")
def _work_vector_gpu(n):
    if not isinstance(n, types.IntegerLiteral):  # numba retries with the literal
        return None
    from numba import cuda

    size = n.literal_value
    return lambda n: cuda.local.array(size, types.float64)


@gpu_overload(work_matrix, inline="always")
def _work_matrix_gpu(rows, n):
    if not (isinstance(rows, types.IntegerLiteral) and isinstance(n, types.IntegerLiteral)):
        return None
    from numba import cuda

    shape = (rows.literal_value, n.literal_value)
    return lambda rows, n: cuda.local.array(shape, types.float64)


@gpu_overload(on_gpu, inline="always")
def _on_gpu_gpu():
    return lambda: True


@gpu_overload(next_toward, inline="always")
def _next_toward_gpu(x, y):
    from numba.cuda import libdevice

    return lambda x, y: libdevice.nextafter(x, y)
