"""Right-hand side of the rigid body about a fixed point, principal body frame.

State y = (Λ, ω, W), 8 components:
    Λ̇ = ½ Λ ∘ (0, ω)                                   (Poisson, scalar-first quaternion)
    A ṗ = (B − C) q r + M1,  B q̇ = (C − A) r p + M2,  C ṙ = (A − B) p q + M3   (Euler)
    (a gyrostat adds h × ω to M: I ω̇ + ω × (I ω + h) = M − ḣ, h the rotors' momentum, body frame;
    a driven rotor's momentum J Ω is a state column after W, d(J Ω)/dt = u its drive's torque)
    Ẇ = M_nc · ω                                        (work of the non-conservative loads)
The state layout is ``rotlab.core.state``; the loads reach ``rhs`` as one value, the scene's
``Model`` (``rotlab.scene.loads``), and only ``rotlab.core.torques`` reads its load fields (a
scene pays only for the loads it has).  Λ is not renormalised: |Λ| − 1 is reported as drift.

Inlining.  numba types an inlined function anew at every call site, and typing dominates a
kernel's compile time, so code is typed once and inlined by LLVM wherever it can be: ``rhs`` is
typed once per model type and process as ``rhs_llvm_inlined`` (numba's ``forceinline``, LLVM's
``alwaysinline``) and shared by the stages of ``rk4``, ``rkmk4`` and ``dop853`` and by
``rhs_called`` (the cold sites of ``dop853``: its start and restarts); the load groups' torques
(``torques.forces_torque`` …) have fixed argument types, so they are typed once per process and
cached on disk, whatever the scene.  Only the per-group overloads that skip an absent group
(None) are inlined by numba: a kernel specialises on the model's load groups and pays nothing for
the groups a scene lacks.  ``dop853`` calls ``rhs_llvm_inlined`` right in its stage loops: a
``forceinline`` stage function around it costs a step more.  Helpers off the hot path (the
helpers below, ``torques._in_body``, the formula loads' torque, ``quaternion.rotate_quadratic``)
are plain compiled functions, called.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from rotlab.core.targets import next_toward, overload
from rotlab.core.state import P0, Q0, STATE_SIZE, WORK
from rotlab.core.torques import conservative_torque, drive_rotors, nonconservative_torque, plus_torque, power, with_gyrostatic

__all__ = ["STATE_SIZE", "all_finite", "euler_coefficients", "next_piece", "rhs", "rhs_called", "rhs_llvm_inlined", "state_size"]


def euler_coefficients(moments: np.ndarray) -> np.ndarray:
    """[(B − C)/A, (C − A)/B, (A − B)/C, 1/A, 1/B, 1/C]: Euler's equations without divisions,
    ṗ = (B − C)/A · q r + M1/A, ..."""
    a, b, c = (float(x) for x in moments)
    return np.array([(b - c) / a, (c - a) / b, (a - b) / c, 1.0 / a, 1.0 / b, 1.0 / c])


@njit(cache=True, inline="always")
def rhs(t, y, dy, model):
    """dy ← f(t, y) for the state of ``rotlab.core.state`` (module docstring); ``model`` is
    ``rotlab.scene.loads.Model`` (its Euler coefficients and loads)."""
    q0, q1, q2, q3 = y[Q0], y[Q0 + 1], y[Q0 + 2], y[Q0 + 3]
    p, q, r = y[P0], y[P0 + 1], y[P0 + 2]
    euler = model.euler
    c = with_gyrostatic(conservative_torque(y, model), p, q, r, model.rotors)
    n = nonconservative_torque(t, y, model)  # None: the scene has no load that does work
    c, n = drive_rotors(t, y, dy, c, n, model.drives)
    mx, my, mz = plus_torque(c, n)
    dy[Q0] = -0.5 * (q1 * p + q2 * q + q3 * r)
    dy[Q0 + 1] = 0.5 * (q0 * p + q2 * r - q3 * q)
    dy[Q0 + 2] = 0.5 * (q0 * q + q3 * p - q1 * r)
    dy[Q0 + 3] = 0.5 * (q0 * r + q1 * q - q2 * p)
    dy[P0] = euler[0] * q * r + mx * euler[3]
    dy[P0 + 1] = euler[1] * r * p + my * euler[4]
    dy[P0 + 2] = euler[2] * p * q + mz * euler[5]
    dy[WORK] = power(n, p, q, r)


def state_size(model):
    """The state's length for ``model``: ``STATE_SIZE``, plus one column per driven rotor (a
    compile-time constant without them)."""
    raise NotImplementedError("compiled only")


@overload(state_size, inline="always")
def _state_size(model):
    if isinstance(model.types[model.fields.index("drives")], types.NoneType):
        return lambda model: STATE_SIZE
    return lambda model: STATE_SIZE + model.drives.axes.shape[0]


@njit(cache=True, forceinline=True)
def rhs_llvm_inlined(t, y, dy, model):
    """``rhs`` typed and lowered once per model type and process, then inlined by LLVM at every
    call site (numba's ``forceinline``: the LLVM ``alwaysinline`` attribute)."""
    rhs(t, y, dy, model)


@njit(cache=True)
def rhs_called(t, y, dy, model):
    """``rhs``, called instead of inlined, for call sites off a kernel's hot path: numba would type
    an inlined ``rhs`` again at every site; this one is ``rhs_llvm_inlined``'s, typed once per
    model type and process."""
    rhs_llvm_inlined(t, y, dy, model)


@njit(cache=True)
def next_piece(t, t_end, breaks, b):
    """(end, t_last, b) of the step piece starting at t: it ends at the next load breakpoint
    (``rotlab.scene.loads.breakpoints``) in (t, t_end] or at t_end; its last stage samples the
    loads at ``t_last`` (the left limit at a breakpoint); ``b`` indexes the next breakpoint."""
    nb = breaks.shape[0]
    while b < nb and breaks[b] <= t:
        b += 1
    if b < nb and breaks[b] <= t_end:
        return breaks[b], next_toward(breaks[b], -np.inf), b
    return t_end, t_end, b


@njit(cache=True)
def count_at_or_below(values, x):
    """How many of the sorted ``values`` are ≤ x: ``np.searchsorted(values, x, side="right")``
    by bisection (numba's searchsorted compiles a sizeable set of helpers into a kernel)."""
    lo, hi = 0, values.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if values[mid] <= x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def store_row(out, i, y):
    """out[i, :] = y, element by element: numba's slice assignment from an array compiles a
    formatted shape-mismatch message with it (string and unicode helpers, costly to compile)."""
    for m in range(y.shape[0]):
        out[i, m] = y[m]


@njit(cache=True)
def store_vector(out, y):
    """out[:] = y, element by element (as ``store_row``)."""
    for m in range(y.shape[0]):
        out[m] = y[m]


@njit(cache=True)
def all_finite(y):
    for k in range(y.shape[0]):
        if not math.isfinite(y[k]):
            return False
    return True
