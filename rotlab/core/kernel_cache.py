"""numba's on-disk cache, made stale by a change to any kernel source, not only the function's own file.

numba keys a cached function on the contents of the file that defines it.  rotlab's kernels
inline code from other modules (every stepper inlines ``dynamics.rhs``, which inlines the load
torques of ``torques``) and link compiled helpers from others (``quaternion``): after an edit to
``torques.py`` alone, ``rk4_advance`` kept loading its old machine code from the cache, and the
edit had no effect on any run (seen with the damping torque: the same numbers before and after).
A wheel rewrites every file, so installed users were safe; a checkout with ``pip install -e``
was not.

So the source stamp of every rotlab kernel, and of the generated load formulas (which call
``rotlab.core.expressions``), is numba's own stamp plus one digest of the contents of every
kernel source (``kernel_sources``: every module that defines compiled code): editing any of them recompiles every kernel once.  Installed
by ``rotlab.core`` before any kernel is defined.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1]
NUMBA_CODE = re.compile(rb"@(?:numba\.)?(?:\w+_)?(?:njit|overload|intrinsic|cfunc|generated_jit)\b")  # a definition of compiled code
OURS = ("rotlab.", "rotlab_formulas_")  # module names of the functions stamped here


def kernel_sources(package: Path = PACKAGE) -> dict[Path, bytes]:
    """Every module of ``package`` that defines numba code, wherever it lives (``scene/formulas.py``
    is the generated formula modules' template): path → contents, each file read once."""
    contents = {path: path.read_bytes() for path in sorted(package.rglob("*.py"))}
    return {path: text for path, text in contents.items() if NUMBA_CODE.search(text)}


def sources_digest() -> str:
    """sha256 of the kernel sources' relative paths and contents."""
    digest = hashlib.sha256()
    for path, text in kernel_sources(PACKAGE).items():
        digest.update(path.relative_to(PACKAGE).as_posix().encode())
        digest.update(text)
    return digest.hexdigest()


def install() -> None:
    """Put a stamped twin of each of numba's cache locators first in its list (idempotent)."""
    from numba.core import caching

    locators = caching.CacheImpl._locator_classes
    if any(getattr(cls, "rotlab_stamped", False) for cls in locators):
        return
    digest = sources_digest()
    locators[:0] = [_stamped(cls, digest) for cls in list(locators)]


def _stamped(base: type, digest: str) -> type:
    class Stamped(base):  # type: ignore[misc, valid-type]
        rotlab_stamped = True

        @classmethod
        def from_function(cls, py_func, py_file):
            if not getattr(py_func, "__module__", "").startswith(OURS):
                return None  # not ours: numba's own locators take it
            return super().from_function(py_func, py_file)

        def get_source_stamp(self):
            return (super().get_source_stamp(), digest)

    Stamped.__name__ = Stamped.__qualname__ = f"Stamped{base.__name__}"
    return Stamped
