"""numba's on-disk cache follows every kernel source (rotlab.core.kernel_cache)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import rotlab
from rotlab.core import kernel_cache

PACKAGE = Path(rotlab.__file__).resolve().parent

RHS_WITH_DAMPING = """
import numpy as np
from rotlab.core.dynamics import euler_coefficients, rhs
from rotlab.scene.loads import Model

model = Model(euler=euler_coefficients(np.array([1.0, 2.0, 3.0])), breaks=np.empty(0), forces=None, terms=None,
              tables=None, table_t=None, table_v=None, damping=0.5, expressions=None, user=None)
y = np.array([1.0, 0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 0.0])
dy = np.empty(8)
rhs(0.0, y, dy, model)
print(repr(float(dy[4])))
"""


def _run(package_parent: Path, cache: Path) -> float:
    """dy[4] of the package copy's rhs (run from its folder: `python -c` puts the working
    directory first on the path, and the checkout's rotlab/ would win)."""
    env = {**os.environ, "PYTHONPATH": str(package_parent), "NUMBA_CACHE_DIR": str(cache)}
    done = subprocess.run([sys.executable, "-c", RHS_WITH_DAMPING + "\nimport rotlab\nprint(rotlab.__file__)\n"], env=env, cwd=package_parent,
                          capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    value, origin = done.stdout.split()
    assert Path(origin).is_relative_to(package_parent), origin
    return float(value)


def test_an_edit_to_an_inlined_module_recompiles_the_kernels_that_use_it(tmp_path):
    """rhs (dynamics.py) inlines the damping torque (torques.py).  numba alone keys the cache on
    dynamics.py, so after an edit to torques.py the cached rhs kept the old damping: the edit
    did nothing.  With a copy of the package, one cache, and the damping doubled in between:
    ṗ = (B − C)/A q r − k p/A changes from −6 − 0.5 to −6 − 1.0."""
    copy = tmp_path / "pkg"
    shutil.copytree(PACKAGE, copy / "rotlab", symlinks=True, ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    cache = tmp_path / "numba-cache"
    assert _run(copy, cache) == -6.5
    torques = copy / "rotlab" / "core" / "torques.py"
    text = torques.read_text()
    edited = text.replace("return -damping * y[P0], -damping * y[P0 + 1], -damping * y[P0 + 2]",
                          "return -2.0 * damping * y[P0], -2.0 * damping * y[P0 + 1], -2.0 * damping * y[P0 + 2]")
    assert edited != text
    torques.write_text(edited)
    assert _run(copy, cache) == -7.0


def test_every_module_with_numba_code_is_a_kernel_source(tmp_path):
    """A module that defines numba code, in any folder, stamps every kernel's cache (a new method
    module next to the others included); one without does not."""
    (tmp_path / "methods").mkdir()
    (tmp_path / "methods" / "new_method.py").write_text("from numba import njit\n\n@njit(cache=True)\ndef step(y):\n    return y\n")
    (tmp_path / "methods" / "plain.py").write_text("import numba  # typeof only\nX = 1\n")
    (tmp_path / "scene.py").write_text("@numba.cfunc(SIG)\ndef f(x):\n    return x\n")
    found = {p.relative_to(tmp_path).as_posix() for p in kernel_cache.kernel_sources(tmp_path)}
    assert found == {"methods/new_method.py", "scene.py"}
    shipped = {p.relative_to(PACKAGE).as_posix() for p in kernel_cache.kernel_sources()}
    assert {"core/rk4.py", "core/torques.py", "scene/formulas.py"} <= shipped
