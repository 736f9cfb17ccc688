"""The scenario file's JSON Schema, from the pydantic models (``rotlab schema``).

Editors that read TOML with a schema (Taplo, VS Code's Even Better TOML) complete and check keys
from it; the shipped configs name it in their first line: ``#:schema ./scenario.schema.json``.
"""

from __future__ import annotations

import json
import math
from typing import Any

from rotlab.config.models import Scenario

SCHEMA_FILE = "scenario.schema.json"


def scenario_schema() -> dict[str, Any]:
    """JSON Schema of a scenario file (strict JSON: defaults of ±inf, such as an open window's
    ends, are left out)."""
    schema = Scenario.model_json_schema()
    schema["title"] = "rotlab scenario"
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    return _finite(schema)


def schema_text() -> str:
    return json.dumps(scenario_schema(), indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def _finite(node: Any) -> Any:
    if isinstance(node, dict):
        return {k: _finite(v) for k, v in node.items() if not (isinstance(v, float) and not math.isfinite(v))}
    if isinstance(node, list):
        return [_finite(v) for v in node]
    return node
