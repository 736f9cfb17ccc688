"""numba's on-disk cache follows every kernel source (rotlab.core.kernel_cache)."""

from __future__ import annotations

import os
import re
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
    edited = text.replace("(-damping * y[P0], -damping * y[P0 + 1], -damping * y[P0 + 2])",
                          "(-2.0 * damping * y[P0], -2.0 * damping * y[P0 + 1], -2.0 * damping * y[P0 + 2])")
    assert edited != text
    torques.write_text(edited)
    assert _run(copy, cache) == -7.0


def test_every_module_with_numba_code_is_a_kernel_source():
    """A module that defines numba code outside KERNEL_SOURCES would be cached on its own file only."""
    numba_code = re.compile(r"@(njit|overload|intrinsic|cfunc|generated_jit)\b")
    covered = {path for pattern in kernel_cache.KERNEL_SOURCES for path in PACKAGE.glob(pattern)}
    defining = {path for path in PACKAGE.rglob("*.py") if numba_code.search(path.read_text())}
    assert defining and defining <= covered, sorted(str(p.relative_to(PACKAGE)) for p in defining - covered)
