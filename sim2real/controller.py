"""Controller files: versioned, self-describing JSON of an evolved network (data only).

A controller names its robot (and a hash of the robot's joint map, so that a file for
another robot is refused), its control tick, the network's inputs and outputs in order,
the bilateral-symmetry wiring, its modules, its nodes and enabled connections, how outputs
map onto joints, and where it came from.  ``load_controller`` checks all of it and says
what is wrong and where.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from sim2real.atomic_json import write_text_atomic
from sim2real.errors import ConfigError
from sim2real.robot import RobotSpec

FORMAT = "biped-controller"
VERSION = 1
REQUIRED = ("format", "version", "robot", "tick_s", "inputs", "outputs", "bias", "symmetry",
            "sigmoid_steepness", "modules", "hidden", "connections", "joints", "task", "provenance")


def joint_map_hash(robot: RobotSpec) -> str:
    """A short hash of what a controller relies on: joint names, order, ranges and servos."""
    parts = []
    for j in robot.joints:
        servo = (j.servo.id, j.servo.profile.model, j.servo.direction, round(j.servo.zero_offset_rad, 9)) if j.servo else None
        parts.append([j.name, j.side, j.location, j.axis, [round(a, 9) for a in j.range_rad], servo])
    return hashlib.sha256(json.dumps(parts).encode()).hexdigest()[:16]


def dumps(data: dict[str, Any]) -> str:
    """One top-level key a line, each value compact: readable, and a 300-connection
    controller stays well under 20 KB."""
    lines = [f" {json.dumps(k)}: {json.dumps(v, separators=(',', ':'))}" for k, v in data.items()]
    return "{\n" + ",\n".join(lines) + "\n}\n"


def save_controller(path: Path | str, data: dict[str, Any]) -> None:
    """Validate and write atomically."""
    _check(data, str(path))
    write_text_atomic(path, dumps(data))


def _check(data: Any, source: str) -> dict[str, Any]:
    if not isinstance(data, dict):
        raise ConfigError(source, "", "a controller file must hold a JSON object")
    if data.get("format") != FORMAT:
        raise ConfigError(source, "format", f"not a controller file (format {data.get('format')!r}, expected {FORMAT!r})")
    if data.get("version") != VERSION:
        raise ConfigError(source, "version", f"version {data.get('version')!r} is not supported (this code reads {VERSION})")
    for key in REQUIRED:
        if key not in data:
            raise ConfigError(source, key, "missing")
    n_in, n_bias, n_out = len(data["inputs"]), len(data["bias"][0]), len(data["outputs"])
    n_interface = n_in + n_bias + n_out
    hidden = {int(h[0]) for h in data["hidden"]}
    if any(h < n_interface for h in hidden):
        raise ConfigError(source, "hidden", f"hidden node ids must be >= {n_interface}")
    n_modules = len(data["modules"])
    for i, conn in enumerate(data["connections"]):
        if not (isinstance(conn, list) and len(conn) == 4):
            raise ConfigError(source, f"connections[{i}]", "must be [src, dst, weight, module]")
        src, dst, weight, module = conn
        for end, node in (("src", src), ("dst", dst)):
            if not isinstance(node, int) or not (0 <= node < n_interface or node in hidden):
                raise ConfigError(source, f"connections[{i}]", f"{end} {node!r} is not a node of this network")
        if isinstance(dst, int) and dst < n_in + n_bias:
            raise ConfigError(source, f"connections[{i}]", f"dst {dst} is an input or bias node")
        if not isinstance(weight, (int, float)) or weight != weight:
            raise ConfigError(source, f"connections[{i}]", f"weight {weight!r} is not a number")
        if not isinstance(module, int) or not 0 <= module < n_modules:
            raise ConfigError(source, f"connections[{i}]", f"module {module!r} out of range")
    return data


def load_controller(path: Path | str, robot: RobotSpec | None = None) -> dict[str, Any]:
    """Read and validate a controller; with ``robot``, refuse one made for another robot."""
    source = str(path)
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise ConfigError(source, "", f"cannot read: {exc.strerror}") from exc
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ConfigError(source, "", f"not valid JSON (truncated?): {exc.msg} at line {exc.lineno} column {exc.colno}") from exc
    data = _check(data, source)
    if robot is not None:
        want = joint_map_hash(robot)
        if data["robot"].get("joint_map_hash") != want:
            raise ConfigError(source, "robot.joint_map_hash",
                              f"made for robot {data['robot'].get('name')!r} with joint map "
                              f"{data['robot'].get('joint_map_hash')}, but {robot.name} has {want}")
    return data
