"""The JSON Schema states every plain bound the validator enforces: for a value alone in an
otherwise valid scenario, the schema accepts it exactly when the loader does (Hypothesis draws
values across and at the bounds)."""

from __future__ import annotations

import copy
import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rotlab.config.loader import parse_scenario
from rotlab.config.schema import schema_text
from rotlab.errors import InputError

jsonschema = pytest.importorskip("jsonschema")
VALIDATOR = jsonschema.Draft202012Validator(json.loads(schema_text()))

BASE = {"body": {"principal_moments": [1.0, 2.0, 2.5], "mass": 1.0}, "initial": {"omega": [0.1, 0.2, 0.3]},
        "loads": [{"type": "damping", "coefficient": 0.1}, {"type": "pd_control", "kp": 1.0, "kd": 1.0}],
        "time": {"end": 1.0, "sample_rate": 10}, "solver": {"rtol": 1e-10, "atol": 1e-12}}
# where a value goes: a path of keys and indices, with every copy that must hold it (three equal
# moments keep the triangle inequality out of the question)
FIELDS = {
    "body.mass": [("body", "mass")],
    "body.principal_moments": [("body", "principal_moments", i) for i in range(3)],
    "initial.omega[0]": [("initial", "omega", 0)],
    "loads[0].coefficient": [("loads", 0, "coefficient")],
    "loads[1].kp": [("loads", 1, "kp")],
    "solver.rtol": [("solver", "rtol")],
    "solver.atol": [("solver", "atol")],
    "time.start": [("time", "start")],
}
EDGES = [0.0, -0.0, 1e-30, 9.9e-31, -1e-30, 1e-16, 9.9e-17, 1.0, 1.0000001, 1e30, 1.01e30, -1e30, -1.01e30,
         9e9, 9.01e9, -9e9, -9.01e9, -1.0, 0.5]
VALUES = st.one_of(st.sampled_from(EDGES), st.floats(allow_nan=False, allow_infinity=False),
                   st.floats(min_value=-1e-12, max_value=1e-12), st.integers(min_value=-10**40, max_value=10**40))


def _with(field: str, value: float) -> dict:
    data = copy.deepcopy(BASE)
    for path in FIELDS[field]:
        node = data
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    if field == "time.start":
        data["time"]["end"] = value + 1.0 if abs(value) < 1e9 else value  # end > start where the span can be held
    return data


@pytest.mark.parametrize("field", FIELDS)
@settings(max_examples=150, deadline=None)
@given(value=VALUES)
def test_the_schema_accepts_a_value_exactly_when_the_loader_does(field, value):
    data = _with(field, value)
    try:
        parse_scenario(copy.deepcopy(data))
        loader_ok = True
    except InputError:
        loader_ok = False
    schema_ok = VALIDATOR.is_valid(data)
    if field == "time.start" and abs(value) >= 1e9:
        assert not loader_ok  # end = start: refused by the loader for the span, a bound the schema cannot state
    else:
        assert schema_ok == loader_ok, (field, value, loader_ok, schema_ok)
