"""Imports withheld in rotlab's own processes (``rotlab.withheld``): pandas from pyarrow's probe,
SciPy's linear algebra from numba's BLAS probe."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest



def _python(code: str) -> str:
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_without_withholding_rerun_imports_pandas():
    """The cost being avoided is real: Rerun's first column conversion imports pandas."""
    pytest.importorskip("pandas")  # what is withheld must be installed for the test to mean anything
    out = _python("""
        import sys, numpy as np, rerun as rr
        rr.Scalars.columns(scalars=np.zeros((3, 1)))
        print("pandas" in sys.modules)
    """)
    assert out.split() == ["True"]


def test_withheld_pandas_stays_out_and_pyarrow_still_converts_pandas_objects():
    """After ``withhold_pandas`` Rerun's conversions import no pandas; pyarrow's pandas APIs
    still work when called (they import pandas themselves), categoricals included."""
    pytest.importorskip("pandas")
    out = _python("""
        import sys, numpy as np
        from rotlab.withheld import withhold_pandas
        print(withhold_pandas())
        import rerun as rr
        rr.Scalars.columns(scalars=np.zeros((3, 1)))
        rr.TimeColumn("t", duration=np.arange(3).astype("timedelta64[ns]"))
        print("pandas" in sys.modules)
        import pyarrow as pa
        frame = pa.table({"x": np.arange(3)}).to_pandas()
        print(type(frame).__name__, pa.array(frame["x"].astype("category")).type)
    """)
    assert out.split("\n")[:3] == ["True", "False", "DataFrame dictionary<values=int64, indices=int8, ordered=0>"]


def test_withholding_after_pandas_is_in_use_changes_nothing():
    pytest.importorskip("pandas")  # (in use: imported first)
    out = _python("""
        import pandas, pyarrow as pa
        from rotlab.withheld import withhold_pandas
        print(withhold_pandas(), pa.array(pandas.Series([1, 2]).astype("category")).type)
    """)
    assert out.split("\n")[0] == "False dictionary<values=int64, indices=int8, ordered=0>"


def test_rotlab_run_imports_neither_pandas_nor_scipy_linalg(tmp_path):
    """The executable's run: the whole recording written, its kernels loaded or compiled by numba,
    and neither pandas nor SciPy's linear algebra imported."""
    out = _python(f"""
        import sys
        sys.argv = ["rotlab", "run", {str(_config())!r}, "--duration", "1", "-o", {str(tmp_path / "r.rrd")!r}, "-q"]
        from rotlab.cli import main
        try:
            main()
        except SystemExit as done:
            assert not done.code, done.code
        print("pandas" in sys.modules, "scipy.linalg" in sys.modules, "numba.np.arraymath" in sys.modules)
    """)
    assert out.split() == ["False", "False", "True"]
    assert (tmp_path / "r.rrd").stat().st_size > 10_000


def test_without_withholding_numba_imports_scipy_linalg():
    """The cost being avoided is real: numba's first kernel imports SciPy's linear algebra."""
    out = _python("""
        import sys, numba
        numba.njit(lambda x: x + 1.0)(1.0)
        print("scipy.linalg" in sys.modules)
    """)
    assert out.split() == ["True"]


def test_numba_without_its_blas_probe_still_does_linear_algebra():
    """With the probe refused, numba's np.convolve takes its own loop, np.dot imports SciPy's BLAS
    when it is compiled, and the finder has left ``sys.meta_path``; the values are exact."""
    out = _python("""
        import sys, numpy as np
        from rotlab.withheld import withhold_scipy_linalg, _NoBlasProbe
        print(withhold_scipy_linalg())
        import numba

        @numba.njit
        def convolve(a, b):
            return np.convolve(a, b)

        @numba.njit
        def dot(a, b):
            return np.dot(a, b)

        print(convolve(np.array([1.0, 2.0, 3.0]), np.array([1.0, -1.0])).tolist(), "scipy.linalg" in sys.modules)
        print(dot(np.array([[1.0, 2.0], [3.0, 4.0]]), np.array([1.0, -1.0])).tolist(), "scipy.linalg" in sys.modules)
        print(any(isinstance(finder, _NoBlasProbe) for finder in sys.meta_path), withhold_scipy_linalg())
    """)
    assert out.split("\n")[:4] == ["True", "[1.0, 1.0, 1.0, -3.0] False", "[-1.0, -1.0] True", "False False"]


def test_scipy_linalg_imported_first_is_not_withheld():
    """An import of ``scipy.linalg`` before numba's probe proceeds, and the finder leaves without
    hiding that import from the finders after it."""
    out = _python("""
        import sys
        from rotlab.withheld import withhold_scipy_linalg, _NoBlasProbe
        print(withhold_scipy_linalg())

        class Seen:
            names = []

            def find_spec(self, name, path=None, target=None):
                self.names.append(name)

        sys.meta_path.insert(1, Seen())
        import scipy.linalg
        print(scipy.linalg.det([[2.0, 0.0], [0.0, 3.0]]), any(isinstance(f, _NoBlasProbe) for f in sys.meta_path))
        print("scipy.linalg" in Seen.names)
    """)
    assert out.split("\n")[:3] == ["True", "6.0 False", "True"]


def test_rotlab_sweep_imports_no_pandas(tmp_path):
    """The sweep command writes results.parquet and the comparison recording without pandas."""
    pytest.importorskip("pandas")
    out = _python(f"""
        import sys
        sys.argv = ["rotlab", "sweep", {str(_config("sweep_flip.toml"))!r}, "-o", {str(tmp_path / "out")!r}, "-j", "1"]
        from rotlab.cli import main
        try:
            main()
        except SystemExit as done:
            assert not done.code, done.code
        print("pandas" in sys.modules)
    """)
    assert out.split()[-1] == "False"
    assert (tmp_path / "out" / "results.parquet").stat().st_size > 1_000


def _config(name: str = "lagrange.toml"):
    from pathlib import Path

    return Path(__file__).resolve().parents[1] / "configs" / name
