"""The controller format's keys and bounds, read from its published JSON schema.

``schemas/controller-v1.schema.json`` is the one statement of what a controller file may
hold; this module reads it once and names what the code needs of it, so that a bound is
written in one place.  :mod:`sim2real.controller.checks` checks files against these (with
messages that name the field), :mod:`sim2real.controller.file` writes them.  Ranges are
``(low, high)`` pairs; units in brackets.
"""

from __future__ import annotations

import json
from importlib import resources
from typing import Any

SCHEMA: dict[str, Any] = json.loads((resources.files("sim2real.controller") / "schemas"
                                     / "controller-v1.schema.json").read_text(encoding="utf-8"))
FIELDS: dict[str, Any] = SCHEMA["properties"]  # the top-level keys' schemas
DEFS: dict[str, Any] = SCHEMA["$defs"]

FORMAT: str = FIELDS["format"]["const"]
VERSION: int = FIELDS["version"]["const"]
REQUIRED: tuple[str, ...] = tuple(SCHEMA["required"])
OPTIONAL: tuple[str, ...] = tuple(k for k in FIELDS if k not in REQUIRED)  # the inputs' options, the reach arm
MAX_WEIGHT = float(FIELDS["connections"]["items"]["prefixItems"][2]["maximum"])  # NeatConfig clips to 20
MAX_STEEPNESS = float(FIELDS["sigmoid_steepness"]["maximum"])  # seed 000 uses 1, classic NEAT 4.9
TICK_RANGE_S = (float(FIELDS["tick_s"]["minimum"]), float(FIELDS["tick_s"]["maximum"]))  # [s]; robots: 10-70 ms
_BIAS = FIELDS["bias"]["items"]["items"]
BIAS_RANGE = (float(_BIAS["minimum"]), float(_BIAS["maximum"]))  # bias nodes are inputs (seed 000 7.3)
BIAS_SHAPE = (FIELDS["bias"]["minItems"], FIELDS["bias"]["items"]["minItems"])  # (networks, values per network)
MAX_NODE_ID: int = DEFS["node_id"]["maximum"]
ANGLE_LIMIT_RAD = float(DEFS["angle"]["maximum"])  # joint ranges and hold angles [rad]
NETWORKS: list[str] = list(FIELDS["symmetry"]["properties"]["networks"]["const"])  # symmetry.SIDES
MIRROR_SIGNS: list[int] = FIELDS["symmetry"]["properties"]["center_mirror_for_left"]["items"]["enum"]
JOINT_MAP_HASH_PATTERN: str = FIELDS["robot"]["properties"]["joint_map_hash"]["pattern"]


def object_keys(schema: dict[str, Any]) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(required, optional) keys of an object's schema, each in the schema's order."""
    required = tuple(schema.get("required", ()))
    return required, tuple(k for k in schema.get("properties", {}) if k not in required)


ROBOT_KEYS = object_keys(FIELDS["robot"])
SYMMETRY_KEYS = object_keys(FIELDS["symmetry"])
LEG_JOINTS_KEYS = object_keys(FIELDS["symmetry"]["properties"]["leg_joints"])
MODULE_KEYS = object_keys(FIELDS["modules"]["items"])
JOINTS_KEYS = object_keys(FIELDS["joints"])
