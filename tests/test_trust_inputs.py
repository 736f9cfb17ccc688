"""Refusals in one line (exit 2, nothing written) for inputs that used to end in a traceback, a
misleading message or a run that never ends; and the physical sense of a body's mass."""

from __future__ import annotations

import subprocess
import sys

import pytest

from rotlab import inertia
from tests.conftest import VALID_BODY

FREE = VALID_BODY + "[initial]\nomega = [0.1, 0.2, 0.3]\n[time]\nend = 1.0\nsample_rate = 20\n"
TOP = "[body]\nprincipal_moments = [{a}, {a}, {c}]\nmass = {m}\ncenter_of_mass = [0, 0, {z}]\n" \
      "[initial]\nomega = [0, 0, 100]\n[[loads]]\ntype = \"gravity\"\n[time]\nend = 1.0\n"


def _refused(cli, write, name: str, text: str | bytes) -> str:
    """The one line ``rotlab validate`` refuses ``text`` with."""
    path = write(name, text)
    result = cli("validate", str(path))
    assert result.exit_code == 2, (result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    return lines[0]


def test_a_top_whose_mass_is_in_grams_is_refused_with_the_likely_cause(cli, write):
    """A = B = 4e-5, C = 2.5e-5 kg·m² with 0.05 kg at 0.025 m: about the centre of mass the
    second moment along z is 2.75e-5 − 0.05·0.025² = −3.75e-6 kg·m² < 0."""
    line = _refused(cli, write, "grams.toml", TOP.format(a=4e-5, c=2.5e-5, m=0.05, z=0.025))
    assert "body.center_of_mass" in line and "-3.75e-06 kg·m² < 0" in line and "not grams" in line


def test_a_lever_arm_far_beyond_the_body_is_refused_not_run_forever(cli, write):
    line = _refused(cli, write, "far.toml", TOP.format(a=0.002, c=0.001, m=0.5, z="1e20"))
    assert "body.center_of_mass" in line and "1e+20 m" in line


def test_the_shipped_tops_and_a_point_mass_on_a_massless_rod_are_realisable():
    m, z = 0.5, 0.04
    assert inertia.centre_of_mass_violation([[m * z * z, 0, 0], [0, m * z * z, 0], [0, 0, 0.0]], m, [0, 0, z]) is None
    assert inertia.centre_of_mass_violation([[m * z * z * (1 - 1e-6), 0, 0], [0, m * z * z, 0], [0, 0, 0.0]], m, [0, 0, z]) is not None


def test_moments_1e30_apart_are_refused(cli, write):
    line = _refused(cli, write, "needle.toml", "[body]\nprincipal_moments = [1e-20, 1e10, 1e10]\n[time]\nend = 1.0\n")
    assert "body.principal_moments" in line and "1e+30 times the smallest" in line


@pytest.mark.parametrize("text, words", [
    ("[initial]\nomega = [0.0, 120.0]\n", "initial.omega: needs 3 components, got 2"),
    ("[initial]\nomega = [0.0, 1.0, 2.0, 3.0]\n", "initial.omega: needs 3 components, got 4"),
    ("[initial]\nquaternion = [1.0]\n", "initial.quaternion: needs 4 components, got 1"),
    ('[[loads]]\ntype = "gravity"\ng = -9.81\n', "loads[0].g: must be a list of numbers in brackets"),
])
def test_a_vector_of_the_wrong_length_says_how_many_components(cli, write, text, words):
    assert words in _refused(cli, write, "v.toml", VALID_BODY + "[time]\nend = 1.0\n" + text)


def test_a_long_token_is_read_in_linear_time():
    """The dotted-key guard backtracked into long tokens: 4,000 digits took 0.28 s, 20,000 took
    7 s and ran into the 10 s parse limit under load."""
    import time

    from rotlab.config.loader import _LONG_DOTTED_KEY

    started = time.perf_counter()
    assert _LONG_DOTTED_KEY.search("end = " + "9" * 200_000) is None
    assert time.perf_counter() - started < 0.5
    assert _LONG_DOTTED_KEY.search("a" + ".a" * 64 + " = 1") and not _LONG_DOTTED_KEY.search("a" + ".a" * 62 + " = 1")


def test_an_integer_of_5000_digits_is_refused_in_the_file_and_in_set(cli, write):
    digits = "1" * 5000
    assert "a number too long to read" in _refused(cli, write, "big.toml", VALID_BODY + f"[time]\nend = {digits}\n")
    path = write("ok.toml", FREE)
    result = cli("run", str(path), "--set", f"time.end={digits}")
    assert result.exit_code == 2 and result.stderr.strip().endswith("a number too long to read: write it with an exponent, e.g. 1e30")


@pytest.mark.parametrize("draw", ["{ uniform = [1, 0] }", "{ log_uniform = [2.0, 1.0] }", "{ uniform = [1, 1] }"])
def test_a_reversed_sweep_range_is_refused_by_validate(cli, write, draw):
    text = FREE + f'[sweep]\nsamples = 2\n[sweep.parameters]\n"initial.omega[0]" = {draw}\n'
    assert "needs low < high" in _refused(cli, write, "sweep.toml", text)


@pytest.mark.parametrize("parameters, line_ends", [
    ('"initial.omega[0]" = [0.001, nan]', 'sweep.parameters."initial.omega[0]"[1]: must be a finite number, found nan'),
    ('"initial.omega[0]" = [0.001, 1e200]', 'sweep.parameters."initial.omega[0]"[1]: must be at most 1e30 in magnitude (found 1e+200): use SI units of a real body'),
    ('"initial.omega[0]" = [0.001, "a"]', "sweep.parameters.\"initial.omega[0]\"[1]: must be a number, or a list of numbers for a vector key, found 'a'"),
    ('"initial.omega" = [[1, 2, 3], "x"]', "sweep.parameters.\"initial.omega\"[1]: must be a number, or a list of numbers for a vector key, found 'x'"),
    ('"initial.omega" = [[0.1, 0.2, 0.3], [0.1, "x", 0.3]]', "sweep.parameters.\"initial.omega\"[1][1]: must be a number, found 'x'"),
    ('"initial.omega[1]" = []', 'sweep.parameters."initial.omega[1]": a grid needs at least one value'),
    ('"initial.omega[0]" = [0.1, []]', 'sweep.parameters."initial.omega[0]"[1]: must be a number, as the key holds, found []'),
    ('"solver.order" = [8, 12.5]', 'sweep.parameters."solver.order"[1]: must be an integer, as the key holds, found 12.5'),
    ('"solver.order" = { uniform = [8, 12] }', 'sweep.parameters."solver.order": draws a number, but the key holds an integer: give a grid of integers'),
    ('"initial.omega[0]" = [0.001, [1, 2]]', 'sweep.parameters."initial.omega[0]"[1]: must be a number, as the key holds, found [1.0, 2.0]'),
    ('"initial.omega" = [[0.1, 0.2, 0.3], [0.1, 0.2]]', 'sweep.parameters."initial.omega"[1]: must be a list of 3 numbers, as the key holds, found [0.1, 0.2]'),
    ('"initial.omega[0]" = { sphere = 1.0 }', 'sweep.parameters."initial.omega[0]": draws a 3-vector, but the key holds a number: use uniform, log_uniform or normal'),
    ('"initial.omega" = { normal = [0.0, 1.0] }', 'sweep.parameters."initial.omega": draws a number, but the key holds a list of 3 numbers: '
                                                  'sweep its components one by one, or use { sphere = r }'),
])
@pytest.mark.parametrize("command", ["validate", "sweep"])
def test_a_bad_sweep_value_is_refused_naming_its_key_and_position(cli, write, tmp_path, parameters, line_ends, command):
    """A bad grid value or a value of the wrong shape: one line naming the parameter and the
    value's position, the fix where there is one, exit 2 and nothing written.  A bad grid value
    was named by pydantic's inner name for the first variant of the union it failed ("function-
    after[_range(), Uniform]": must be a table …); a value of the wrong shape for its key made
    every case that drew it an error, with results written and exit 1."""
    samples = "samples = 2\n" if "{" in parameters else ""
    path = write("sweep.toml", FREE + f"[sweep]\n{samples}[sweep.parameters]\n{parameters}\n")
    out = tmp_path / "out"
    result = cli(command, str(path), *(["--outdir", str(out)] if command == "sweep" else []))
    assert result.exit_code == 2, (result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0] == f"rotlab: error: {path}: {line_ends}", result.stderr
    assert not out.exists()


def test_sweep_values_of_every_shape_a_key_takes_are_accepted(cli, write):
    """The shape check follows the key's type: a list of any length for a list (a table's times),
    a number for a component, a 3-vector drawn on a sphere for a 3-vector."""
    table = ('[[loads]]\ntype = "torque_table"\nframe = "body"\ntimes = [0.0, 0.5, 1.0]\n'
             'values = [[0, 0, 0], [0, 0, 1e-6], [0, 0, 0]]\n')
    parameters = ('"loads[0].times" = [[0.0, 0.5, 1.0], [0.0, 0.25, 1.0], [0.0, 0.2, 0.6, 1.0]]\n'
                  '"loads[0].values[1][2]" = [1e-6, 2e-6]\n"initial.omega" = { sphere = 0.3 }\n')
    path = write("ok.toml", FREE + table + "[sweep]\nsamples = 2\n[sweep.parameters]\n" + parameters)
    result = cli("validate", str(path))
    assert result.exit_code == 0 and result.stdout.startswith(f"{path}: ok"), (result.stdout, result.stderr)


def test_an_integer_key_is_swept_with_integers(cli, write, tmp_path):
    """A grid's integers stay integers: solver.order = [8, 12] ran no case before (each value became
    a float, which the integer key refuses: every case an error)."""
    text = FREE + '[solver]\nmethod = "taylor"\norder = 10\n[sweep.parameters]\n"solver.order" = [8, 12]\n'
    path = write("order.toml", text)
    assert cli("validate", str(path)).exit_code == 0
    result = cli("sweep", str(path), "--outdir", str(tmp_path / "out"))
    assert result.exit_code == 0 and "2 passed, 0 failed" in result.stdout, (result.stdout, result.stderr)


def test_a_recording_name_without_rrd_is_refused(cli, write, tmp_path):
    path = write("ok.toml", FREE)
    result = cli("run", str(path), "-o", "out.png")
    assert result.exit_code == 2 and "give a name ending in .rrd" in result.stderr
    assert not (tmp_path / "out.png").exists()


def test_a_run_with_120_torques_writes_its_recording(cli, write, tmp_path):
    loads = '[[loads]]\ntype = "torque"\nframe = "body"\nvalue = [0.0, 0.0, 1e-4]\n' * 120
    path = write("many.toml", FREE + loads)
    result = cli("run", str(path), "-o", "many.rrd", "-q")
    assert result.exit_code == 0, result.stderr
    assert (tmp_path / "many.rrd").stat().st_size > 0


def test_the_pytest_plugin_runs_the_good_scenarios_beside_unreadable_files(tmp_path):
    good = FREE + "[checks]\nmax_drift = { energy = 1e-6 }\n"
    (tmp_path / "good.toml").write_text(good)
    (tmp_path / "binary.toml").write_bytes(b"\xff\xfe\x00garbage" * 10)
    (tmp_path / "latin1.toml").write_bytes("title = 'caf\xe9'\n".encode("latin-1"))
    (tmp_path / "huge.toml").write_text(VALID_BODY + "[time]\nend = " + "1" * 5000 + "\n")
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tmp_path)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert "3 failed, 1 passed" in proc.stdout, proc.stdout[-2000:]
    assert "not UTF-8 text" in proc.stdout and "a number too long to read" in proc.stdout
