"""The command line in the ecosystem's habits: choices from the registry, plain help text,
completion, directories for validate, --set overrides, a JSON Schema for editors, and every
usage error on one line."""

from __future__ import annotations

import json
import tomllib

import pytest

from rotlab.config.schema import SCHEMA_FILE, schema_text
from rotlab.method_names import METHOD_NAMES
from rotlab.recording import layout
from rotlab.recording.reader import read_series
from tests.conftest import CONFIGS, VALID_BODY, VALID_TIME


def test_method_choices_come_from_the_registry(cli):
    result = cli("run", "--help")
    assert result.exit_code == 0
    assert "<" + "|".join(METHOD_NAMES) + ">" in result.stdout.replace("\n", "").replace(" ", "")


def test_help_text_keeps_toml_table_names(cli):
    """Rich markup once swallowed "[checks]" ("breaks a  bound.")."""
    assert "[checks]" in cli("batch", "--help").stdout
    assert "[sweep]" in cli("sweep", "--help").stdout


def test_shell_completion_is_offered(cli):
    assert "--install-completion" in cli("--help").stdout


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["run"], "Missing argument 'config'"),
        (["run", "x.toml", "--bogus"], "No such option: --bogus"),
        (["nonsense"], "No such command 'nonsense'"),
        (["run", "x.toml", "--duration", "abc"], "Invalid value for '--duration'"),
        (["new", "kovalevskaya"], "'kovalevskaya' is not one of"),
    ],
)
def test_usage_errors_are_one_line(cli, args, fragment):
    result = cli(*args)
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rotlab: error: ") and fragment in lines[0], result.stderr
    assert "--help" in lines[0] and "Traceback" not in result.output


def test_validate_accepts_directories_like_batch(cli):
    result = cli("validate", str(CONFIGS))
    assert result.exit_code == 0, result.output
    assert result.stdout.count(": ok") == len(list(CONFIGS.glob("*.toml")))


def test_set_overrides_a_key_with_validation(cli, write, tmp_path):
    path = write("s.toml", VALID_BODY + VALID_TIME)
    result = cli("run", str(path), "-q", "-o", "s.rrd", "--set", "initial.omega[2]=3.5", "--set", "solver.method=rk4")
    assert result.exit_code == 0, result.output
    _, omega = read_series(tmp_path / "s.rrd", layout.OMEGA)
    assert omega[0].tolist() == [0.0, 0.0, 3.5]  # indexed into the default ω = 0 (body frame)
    for bad, fragment in [("initial.omega[2]=fast", "must be a number"), ("body.mass=-1", "body.mass"),
                          ("initial.omegga=[0,0,1]", "did you mean 'omega'"), ("omega", "write KEY=VALUE"),
                          ("body.principal_moments[5]=1", "out of range")]:
        result = cli("run", str(path), "-q", "--set", bad)
        assert result.exit_code == 2 and len(result.stderr.strip().splitlines()) == 1, (bad, result.stderr)
        assert fragment in result.stderr, (bad, result.stderr)
    assert not list(tmp_path.glob("s.partial.rrd"))


def test_schema_is_strict_json_and_shipped_beside_the_configs(cli):
    result = cli("schema")
    assert result.exit_code == 0
    schema = json.loads(result.stdout, parse_constant=lambda name: pytest.fail(f"non-standard JSON constant {name}"))
    assert set(schema["properties"]) >= {"body", "initial", "loads", "time", "solver", "output", "checks", "sweep"}
    assert (CONFIGS / SCHEMA_FILE).read_text(encoding="utf-8") == schema_text(), "regenerate: rotlab schema > configs/scenario.schema.json"


def test_every_shipped_config_names_the_schema_and_satisfies_it():
    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads((CONFIGS / SCHEMA_FILE).read_text(encoding="utf-8"))
    for path in sorted(CONFIGS.glob("*.toml")):
        assert path.read_text(encoding="utf-8").splitlines()[0] == f"#:schema ./{SCHEMA_FILE}", path
        jsonschema.validate(tomllib.loads(path.read_text(encoding="utf-8")), schema)
    with pytest.raises(jsonschema.ValidationError):  # the schema refuses what the loader refuses
        jsonschema.validate({"body": {"principal_moments": [1, 2, 3]}, "time": {"end": 1}, "solver": {"methd": "rk4"}}, schema)


def test_the_executable_ignores_a_late_ctrl_c_while_it_shuts_down():
    """Once ``main`` has finished (files complete, exit code known), a Ctrl-C while the process
    ends must not end it by the signal (exit −2, no message: found by the fault campaign): stop
    signals are ignored when ``leave`` is called, with main's exit code."""
    import subprocess
    import sys

    code = ("import signal, sys\nimport rotlab.__main__ as executable, rotlab.ending as ending\nsys.argv = ['rotlab', 'validate', 'missing.toml']\n"
            "ending.leave = lambda code: print(signal.getsignal(signal.SIGINT) == signal.SIG_IGN, code)\n"
            "executable.entry()\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip().splitlines()[-1] == "True 2", done.stdout + done.stderr


def test_the_executable_ends_without_teardown_and_keeps_its_output_and_code(tmp_path):
    """``leave``: atexit handlers run, buffered output to a pipe is flushed, the exit code is
    main's, and the interpreter's teardown is skipped (a finaliser does not run)."""
    import subprocess
    import sys

    code = ("import atexit, sys\nimport rotlab.__main__ as executable\n"
            "class Held:\n    def __del__(self):\n        print('teardown ran')\nheld = Held()\n"
            "atexit.register(print, 'atexit ran')\nsys.stdout.write('buffered ')\n"
            "sys.argv = ['rotlab', 'validate', 'missing.toml']\nexecutable.entry()\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "missing.toml" in done.stderr
    assert done.stdout.split() == ["buffered", "atexit", "ran"], done.stdout
