"""Every bad input: exit code 2, one line on stderr naming the key (or line) and the fix,
no traceback, no output file."""

from __future__ import annotations

import pytest

from tests.conftest import VALID_BODY, VALID_TIME

CASES = {
    # name: (file content, expected fragments of the message)
    "nan": (VALID_BODY + '[initial]\nomega = [nan, 0, 1]\n' + VALID_TIME, ["initial.omega[0]", "finite"]),
    "inf": ('[body]\nprincipal_moments = [1.0, inf, 2.5]\n' + VALID_TIME, ["body.principal_moments[1]", "finite"]),
    "negative inertia": ('[body]\nprincipal_moments = [-1.0, 2.0, 2.5]\n' + VALID_TIME, ["body.principal_moments", "> 0"]),
    "not positive definite": (
        '[body]\ninertia_tensor = [[1, 2, 0], [2, 1, 0], [0, 0, 1]]\n' + VALID_TIME,
        ["body.inertia_tensor", "positive definite"],
    ),
    "non-symmetric tensor": (
        '[body]\ninertia_tensor = [[1, 0.1, 0], [0, 2, 0], [0, 0, 2.5]]\n' + VALID_TIME,
        ["body.inertia_tensor", "symmetric", "I[i][j] must equal I[j][i]"],
    ),
    "triangle inequality": (
        '[body]\nprincipal_moments = [0.5, 2.0, 3.0]\n' + VALID_TIME,
        ["body.principal_moments", "triangle inequality", "allow_triangle_violation = true"],
    ),
    "zero quaternion": (VALID_BODY + '[initial]\nquaternion = [0, 0, 0, 0]\n' + VALID_TIME, ["initial.quaternion", "zero quaternion"]),
    "non-unit quaternion": (VALID_BODY + '[initial]\nquaternion = [1, 0, 0, 1]\n' + VALID_TIME, ["initial.quaternion", "unit quaternion"]),
    "two orientations": (
        VALID_BODY + '[initial]\nquaternion = [1, 0, 0, 0]\neuler_313 = [0, 0, 0]\n' + VALID_TIME,
        ["initial.euler_313", "only one orientation"],
    ),
    "end before start": (VALID_BODY + '[time]\nstart = 2.0\nend = 1.0\n', ["time.end", "must be after start"]),
    "end equals start": (VALID_BODY + '[time]\nstart = 1.0\nend = 1.0\n', ["time.end", "must be after start"]),
    "too many samples": (VALID_BODY + '[time]\nend = 1e9\nsample_rate = 1000\n', ["time.sample_rate", "beyond the limit"]),
    "span near the float range": (VALID_BODY + '[time]\nend = 1e308\nsample_rate = 100\n', ["time.end", "at most 1e30"]),
    # extreme magnitudes: refused by range before any kernel sees them (each once gave a traceback)
    "huge omega": (VALID_BODY + '[initial]\nomega = [1e200, 1e200, 1e200]\n' + VALID_TIME, ["initial.omega[0]", "at most 1e30"]),
    "huge integer": (VALID_BODY + '[initial]\nomega = [0, 0, ' + '9' * 400 + ']\n' + VALID_TIME, ["initial.omega[2]", "finite"]),
    "huge mass": (
        '[body]\nprincipal_moments = [1.0, 1.0, 0.5]\nmass = 1e300\ncenter_of_mass = [0, 0, 1]\n[[loads]]\ntype = "gravity"\n' + VALID_TIME,
        ["body.mass", "at most 1e30"],
    ),
    "huge centre of mass": (
        '[body]\nprincipal_moments = [1.0, 1.0, 0.5]\nmass = 1\ncenter_of_mass = [0, 0, 1e300]\n' + VALID_TIME,
        ["body.center_of_mass[2]", "at most 1e30"],
    ),
    "tiny moment": ('[body]\nprincipal_moments = [5e-324, 1.0, 1.0]\n' + VALID_TIME, ["body.principal_moments", "at least 1e-30"]),
    "huge damping": (VALID_BODY + VALID_TIME + '[[loads]]\ntype = "damping"\ncoefficient = 1e300\n', ["loads[0].coefficient", "at most 1e30"]),
    "huge rotation vector": (VALID_BODY + '[initial]\naxis_angle = [1e300, 0, 0]\n' + VALID_TIME, ["initial.axis_angle[0]", "at most 1e30"]),
    "rtol below double precision": (VALID_BODY + VALID_TIME + '[solver]\nmethod = "rk4"\nrtol = 1e-300\n', ["solver.rtol", "1e-16"]),
    "start beyond the time axis": (VALID_BODY + '[time]\nstart = 1e15\nend = 1000000000000001.0\n', ["time.start", "int64 nanoseconds"]),
    "span shorter than a sample": (VALID_BODY + '[time]\nend = 1e-300\n', ["time.end", "shorter than one sample interval"]),
    "samples closer than 1 ns": (VALID_BODY + '[time]\nend = 1e-6\nsamples = 10000\n', ["time.samples", "1 ns"]),
    "table knots 5e-324 apart": (
        VALID_BODY + VALID_TIME + '[[loads]]\ntype = "torque_table"\nframe = "body"\ntimes = [0, 5e-324]\nvalues = [[1,0,0],[1,0,0]]\n',
        ["loads[0].times", "1 ns"],
    ),
    "window 5e-324 long": (
        VALID_BODY + VALID_TIME + '[[loads]]\ntype = "torque"\nframe = "body"\nvalue = [0,0,1]\nwindow = { on = 0, off = 5e-324 }\n',
        ["loads[0].window.off", "1 ns"],
    ),
    "fixed steps beyond the step budget": (VALID_BODY + VALID_TIME + '[solver]\nmethod = "rk4"\nstep = 1e-15\n', ["solver.max_steps", "steps of 1e-15 s"]),
    "stiff damping beyond the step budget": (
        VALID_BODY + VALID_TIME + '[[loads]]\ntype = "damping"\ncoefficient = 1e29\n[solver]\nmethod = "rk4"\n', ["solver.max_steps", "raise solver.max_steps"]
    ),
    "dotted key 100,000 parts deep": ("a" + ".a" * 100_000 + " = 1\n", ["line 1", "dotted key"]),
    "arrays nested 1,000 deep": ("a = " + "[" * 1000 + "]" * 1000 + "\n", ["nested too deeply"]),
    "toml syntax": (VALID_BODY + '[time\nend = 1.0\n', ["TOML syntax error", "line 3"]),
    "empty file": ("", ["file is empty", "rotlab new"]),
    "whitespace only": ("  \n\n", ["file is empty"]),
    "binary": (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", ["binary file"]),
    "not utf-8": (b"[body]\nprincipal_moments = [1, 2, 2.5] # \xff\xfe\n", ["not UTF-8"]),
    "unknown key": (VALID_BODY.replace("principal_moments", "principal_moment") + VALID_TIME, ["body.principal_moment", "did you mean 'principal_moments'"]),
    "unknown section": (VALID_BODY + VALID_TIME + "[solvr]\nmethod = 'rk4'\n", ["solvr", "did you mean 'solver'"]),
    "unknown load type": (VALID_BODY + VALID_TIME + '[[loads]]\ntype = "magnet"\n', ["loads[0].type", "gravity"]),
    "load without frame": (VALID_BODY + VALID_TIME + '[[loads]]\ntype = "torque"\nvalue = [0, 0, 1]\n', ["loads[0].frame", "missing"]),
    "wrong frame": (VALID_BODY + VALID_TIME + '[[loads]]\ntype = "torque"\nframe = "world"\nvalue = [0, 0, 1]\n', ["loads[0].frame", "'body' or 'space'"]),
    "string for number": (VALID_BODY + '[time]\nend = "10"\n', ["time.end", "must be a number"]),
    "bool for number": (VALID_BODY + '[time]\nend = true\n', ["time.end", "must be a number"]),
    "vector too short": (VALID_BODY + '[initial]\nomega = [1, 2]\n' + VALID_TIME, ["initial.omega"]),
    "missing body": (VALID_TIME, ["body", "missing"]),
    "missing end": (VALID_BODY + '[time]\nstart = 0\n', ["time.end", "missing"]),
    "gravity without mass": (VALID_BODY + VALID_TIME + '[[loads]]\ntype = "gravity"\n', ["body.mass", "gravity"]),
    "unknown method": (VALID_BODY + VALID_TIME + '[solver]\nmethod = "euler_forward"\n', ["solver.method", "unknown method", "dop853"]),
    "table not increasing": (
        VALID_BODY + VALID_TIME + '[[loads]]\ntype = "torque_table"\nframe = "body"\ntimes = [0, 2, 1]\nvalues = [[0,0,0],[1,0,0],[0,0,0]]\n',
        ["loads[0].times", "strictly increasing"],
    ),
    "window reversed": (
        VALID_BODY + VALID_TIME + '[[loads]]\ntype = "torque"\nframe = "body"\nvalue = [0,0,1]\nwindow = { on = 2, off = 1 }\n',
        ["loads[0].window.off", "on < off"],
    ),
    "negative damping": (VALID_BODY + VALID_TIME + '[[loads]]\ntype = "damping"\ncoefficient = -1\n', ["loads[0].coefficient"]),
}


def _assert_clean_failure(result, fragments, tmp_path):
    assert result.exit_code == 2, result.output
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("rotlab: error: ")
    assert "Traceback" not in result.output
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    assert not list(tmp_path.glob("*.rrd")) and not list(tmp_path.glob(".*.tmp"))


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_input_run(name, cli, write, tmp_path):
    content, fragments = CASES[name]
    path = write("scenario.toml", content)
    _assert_clean_failure(cli("run", str(path)), fragments, tmp_path)


@pytest.mark.parametrize("name", ["nan", "triangle inequality", "toml syntax", "unknown key"])
def test_bad_input_validate(name, cli, write, tmp_path):
    content, fragments = CASES[name]
    path = write("scenario.toml", content)
    _assert_clean_failure(cli("validate", str(path)), fragments, tmp_path)


def test_triangle_violation_opt_in_runs(cli, write):
    path = write("gni.toml", '[body]\nprincipal_moments = [2.0, 1.0, 0.6666666666666666]\nallow_triangle_violation = true\n'
                 '[initial]\nomega = [0.2, 0, 0.4]\n' + VALID_TIME)
    assert cli("run", str(path), "-q").exit_code == 0


def test_missing_file_and_directory(cli, tmp_path):
    _assert_clean_failure(cli("run", "nope.toml"), ["nope.toml", "no such file"], tmp_path)
    (tmp_path / "adir").mkdir()
    _assert_clean_failure(cli("run", "adir"), ["adir", "is a directory"], tmp_path)


@pytest.mark.parametrize("special", ["/dev/zero", "/dev/urandom", "fifo"])
def test_special_files_are_refused_without_reading(special, cli, tmp_path):
    """A device never ends and a FIFO blocks: only regular files are read."""
    import os

    if special == "fifo":
        special = str(tmp_path / "fifo")
        os.mkfifo(special)
    _assert_clean_failure(cli("run", special), ["not a regular file"], tmp_path)


def test_span_shorter_than_a_sample_from_the_command_line(cli, write, tmp_path):
    path = write("ok.toml", VALID_BODY + VALID_TIME)
    _assert_clean_failure(cli("run", str(path), "--duration", "0.001", "--method", "rk4"), ["time.end", "shorter than one sample"], tmp_path)


def test_bad_command_line_overrides(cli, write, tmp_path):
    path = write("ok.toml", VALID_BODY + VALID_TIME)
    _assert_clean_failure(cli("run", str(path), "--method", "leapfrog"), ["--method", "'leapfrog' is not one of 'auto'"], tmp_path)
    _assert_clean_failure(cli("run", str(path), "--duration", "-1"), ["--duration", "positive"], tmp_path)


def test_unwritable_output_is_refused_before_running(cli, write, tmp_path):
    path = write("ok.toml", VALID_BODY + VALID_TIME)
    _assert_clean_failure(cli("run", str(path), "-o", str(tmp_path / "missing" / "x.rrd")), ["does not exist"], tmp_path)
    (tmp_path / "out.rrd").mkdir()
    result = cli("run", str(path), "-o", str(tmp_path / "out.rrd"))
    assert result.exit_code == 2 and "is a directory" in result.stderr
