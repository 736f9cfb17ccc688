"""Bad-input fuzzing: hypothesis mutates the shipped scenarios (deleted lines, values replaced by
wrong types, NaN/inf, extreme magnitudes at and beyond the accepted ranges, unknown keys, broken
syntax, raw bytes; and byte-level flips, insertions and deletions).  Every outcome is clean:
exit 0, 1 (run failure) or 2 (bad input); on failure exactly one line on stderr, never a
traceback; no temporary file left; an existing output file is replaced only by a successful run.
The examples are derandomised (a fixed seed: CI sees the same inputs every run) and bounded in
number, so the campaign has a fixed time budget.
"""

from __future__ import annotations

import re

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.conftest import CONFIGS

TEXTS = {p.name: p.read_text(encoding="utf-8") for p in sorted(CONFIGS.glob("*.toml"))}
ASSIGNMENT = re.compile(r"^(\s*[A-Za-z_\"][^=]*=\s*)(.+)$")
BAD_VALUES = ["nan", "inf", "-inf", "1e308", "-1e308", "1e-320", "0", "-1", '"text"', "true", "[]", "[1, 2]",
              "[nan, 0, 0]", "[1e308, 1e308, 1e308]", "{}", "{ x = 1 }", "[[1, 2], [3]]", "1979-05-27", '"\\u00e9"',
              "[0, 0, 0, 0]", "123456789012345678901234567890", "[1, \"a\", 3]",
              # extreme magnitudes, each side of the accepted ranges (|x| <= 1e30, |t| <= 9e9 s, 1 ns)
              "1e30", "-1e30", "1.0000001e30", "1e-30", "9.9e-31", "5e-324", "-5e-324", "9e9", "9.000001e9", "1e15",
              "[1e30, 1e30, 1e30]", "[1e-30, 1e-30, 1e-30]", "[5e-324, 0, 0]", "9" * 40, "-" + "9" * 400,
              "{ on = 0, off = 1e-10 }", "{ on = 0.5, off = 0.5000000000001 }", "[0, 1e-10, 1]"]


@st.composite
def mutated_configs(draw) -> bytes:
    name = draw(st.sampled_from(sorted(TEXTS)))
    lines = TEXTS[name].splitlines()
    for _ in range(draw(st.integers(1, 3))):
        k = draw(st.integers(0, len(lines) - 1))
        action = draw(st.sampled_from(["replace", "delete", "unknown_key", "duplicate", "truncate", "garble"]))
        match = ASSIGNMENT.match(lines[k])
        if action == "replace" and match:
            lines[k] = match.group(1) + draw(st.sampled_from(BAD_VALUES))
        elif action == "delete":
            del lines[k]
        elif action == "unknown_key":
            lines.insert(k, f"{draw(st.sampled_from(['colour', 'omgea', 'principal_moment', 'frame']))} = 1")
        elif action == "duplicate":
            lines.insert(k, lines[k])
        elif action == "truncate":
            lines[k] = lines[k][: draw(st.integers(0, max(0, len(lines[k]) - 1)))]
        elif action == "garble":
            lines[k] = draw(st.text(max_size=20))
        if not lines:
            lines = [""]
    data = "\n".join(lines).encode("utf-8", errors="surrogatepass")
    if draw(st.booleans()) and draw(st.integers(0, 9)) == 0:
        data += draw(st.binary(min_size=1, max_size=8))  # raw bytes: maybe not UTF-8
    return data


@st.composite
def byte_mutated_configs(draw) -> bytes:
    """A shipped config with 1–8 bytes flipped, inserted or deleted anywhere (UTF-8 may break)."""
    data = bytearray(TEXTS[draw(st.sampled_from(sorted(TEXTS)))].encode("utf-8"))
    for _ in range(draw(st.integers(1, 8))):
        k = draw(st.integers(0, len(data) - 1))
        action = draw(st.sampled_from(["flip", "insert", "delete"]))
        if action == "flip":
            data[k] ^= 1 << draw(st.integers(0, 7))
        elif action == "insert":
            data[k:k] = draw(st.binary(min_size=1, max_size=4))
        else:
            del data[k]
    return bytes(data)


FUZZ = settings(max_examples=120, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


@FUZZ
@given(content=st.one_of(mutated_configs(), byte_mutated_configs()))
def test_mutated_scenarios_fail_cleanly(content, cli, tmp_path):
    for leftover in tmp_path.iterdir():
        leftover.unlink()
    (tmp_path / "out.rrd").write_bytes(b"previous")
    (tmp_path / "fuzz.toml").write_bytes(content)
    result = cli("run", "fuzz.toml", "-o", "out.rrd", "--duration", "0.05", "-q")
    assert result.exit_code in (0, 1, 2), result.output
    assert "Traceback" not in result.output
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp") or p.name.endswith(".probe")]
    if result.exit_code != 0:
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("rotlab: error: "), result.stderr
        assert (tmp_path / "out.rrd").read_bytes() == b"previous"
    if result.exit_code == 2:
        assert sorted(p.name for p in tmp_path.iterdir()) == ["fuzz.toml", "out.rrd"]


@settings(max_examples=30, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(content=st.binary(max_size=200))
def test_random_bytes_are_bad_input(content, cli, tmp_path):
    (tmp_path / "noise.toml").write_bytes(content)
    result = cli("validate", "noise.toml")
    assert result.exit_code in (0, 2) and "Traceback" not in result.output
    if result.exit_code:
        assert len(result.stderr.strip().splitlines()) == 1
