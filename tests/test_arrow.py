"""pyarrow without pandas in rotlab's own processes (``rotlab.arrow``)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

pytest.importorskip("pandas")  # what is withheld must be installed for the test to mean anything


def _python(code: str) -> str:
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_without_withholding_rerun_imports_pandas():
    """The cost being avoided is real: Rerun's first column conversion imports pandas."""
    out = _python("""
        import sys, numpy as np, rerun as rr
        rr.Scalars.columns(scalars=np.zeros((3, 1)))
        print("pandas" in sys.modules)
    """)
    assert out.split() == ["True"]


def test_withheld_pandas_stays_out_and_pyarrow_still_converts_pandas_objects():
    """After ``withhold_pandas`` Rerun's conversions import no pandas; pyarrow's pandas APIs
    still work when called (they import pandas themselves), categoricals included."""
    out = _python("""
        import sys, numpy as np
        from rotlab.arrow import withhold_pandas
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
    out = _python("""
        import pandas, pyarrow as pa
        from rotlab.arrow import withhold_pandas
        print(withhold_pandas(), pa.array(pandas.Series([1, 2]).astype("category")).type)
    """)
    assert out.split("\n")[0] == "False dictionary<values=int64, indices=int8, ordered=0>"


def test_rotlab_run_imports_no_pandas(tmp_path):
    """The executable's run: the whole recording written, pandas never imported."""
    out = _python(f"""
        import sys
        sys.argv = ["rotlab", "run", {str(_config())!r}, "--duration", "1", "-o", {str(tmp_path / "r.rrd")!r}, "-q"]
        from rotlab.cli import main
        try:
            main()
        except SystemExit as done:
            assert not done.code, done.code
        print("pandas" in sys.modules)
    """)
    assert out.split() == ["False"]
    assert (tmp_path / "r.rrd").stat().st_size > 10_000


def test_rotlab_sweep_imports_no_pandas(tmp_path):
    """The sweep command writes results.parquet and the comparison recording without pandas."""
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
