"""The simulated bus's faults, as ``--faults`` and fault files give them: a servo that falls
silent or overloads at a time, and wire-wide rates of dropped and corrupted replies.  The dry
run checks them before anything starts; the simulated bus (:mod:`.service`) plays them.  No MuJoCo."""

from __future__ import annotations

import math
from pathlib import Path

from sim2real.errors import ConfigError
from sim2real.input_files import check_regular_file
from sim2real.robot import RobotSpec
from sim2real.robot.validation import Node, load_yaml

FAULT_KINDS = ("silent", "overload", "drop", "corrupt")
END_OF_RUN = "end of run"  # a line to the simulated bus's standard input: the loop has ended


def parse_faults(spec: str | None, robot: RobotSpec | None = None) -> list[tuple[str, int, float]]:
    """``silent:ID@SECONDS,overload:ID@SECONDS,drop:RATE,corrupt:RATE``, or a YAML file of the
    same (``silent: [{id: 4, at_s: 3}]``, ``overload: [...]``, ``drop: 0.02``, ``corrupt: 0.01``)
    -> [(kind, id, value)] (id 0 for the wire-wide rates).  With ``robot``, every ID must be a
    device on its bus (an overload, a servo's)."""
    if spec and spec.endswith((".yaml", ".yml")):
        return _faults_file(Path(spec), robot)
    faults = []
    for item in (part.strip() for part in (spec or "").split(",")):
        if not item:
            continue
        kind, _, rest = item.partition(":")
        kind = kind.strip()
        if not rest:
            raise ConfigError("--faults", item, "expected KIND:ID@SECONDS (silent:5@3.0, overload:7@2) "
                              "or KIND:RATE (drop:0.02, corrupt:0.01)")
        if kind not in FAULT_KINDS:
            raise ConfigError("--faults", item, "kind must be silent or overload (KIND:ID@SECONDS), "
                              "or drop or corrupt (KIND:RATE)")
        if kind in ("drop", "corrupt"):
            value = _number(rest)
            if not 0.0 <= value <= 1.0:
                raise ConfigError("--faults", item, "a rate must be a number within [0, 1]")
            if any(f[0] == kind for f in faults):
                raise ConfigError("--faults", item, f"{kind} is given twice")
            faults.append((kind, 0, value))
            continue
        ident, at, when = rest.partition("@")
        if not at or not ident.strip().isdigit():
            raise ConfigError("--faults", item, f"expected {kind}:ID@SECONDS, e.g. {kind}:5@3.0")
        at_s = _number(when)
        if not (math.isfinite(at_s) and at_s >= 0.0):
            raise ConfigError("--faults", item, "the time must be a finite number of seconds >= 0")
        _check_device(int(ident), kind, robot, "--faults", item)
        faults.append((kind, int(ident), at_s))
    return faults


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return float("nan")


def _check_device(dxl_id: int, kind: str, robot: RobotSpec | None, source: str, key: str) -> None:
    if robot is None:
        return
    devices = robot.devices
    if kind == "overload" and robot.sensor_board is not None:
        devices.pop(robot.sensor_board.id, None)  # only a servo overloads
    if dxl_id not in devices:
        board = f"; sensor board {robot.sensor_board.id}" if robot.sensor_board and kind != "overload" else ""
        servos = sorted(j.servo.id for j in robot.joints if j.servo)
        raise ConfigError(source, key, f"ID {dxl_id} is not a {'servo' if kind == 'overload' else 'device'} "
                          f"of {robot.name} (servos {', '.join(map(str, servos))}{board})")


def _faults_file(path: Path, robot: RobotSpec | None = None) -> list[tuple[str, int, float]]:
    check_regular_file(path)  # before load_yaml opens it: a FIFO would block, a device never end
    node = Node(load_yaml(path) or {}, str(path)).mapping(optional=FAULT_KINDS)
    faults = []
    for kind in ("silent", "overload"):
        for item in node[kind].list() if node.has(kind) else []:
            item.mapping(required=("id", "at_s"))
            dxl_id = item["id"].integer(0, 252)
            _check_device(dxl_id, kind, robot, str(path), item["id"].path)
            faults.append((kind, dxl_id, item["at_s"].number(lo=0.0)))
    for kind in ("drop", "corrupt"):
        if node.has(kind):
            faults.append((kind, 0, node[kind].number(0.0, 1.0)))
    return faults


def check_fault_times(faults: list[tuple[str, int, float]], duration_s: float) -> None:
    """Refuse a silent servo or an overload timed after the run's end: it would never happen."""
    for kind, dxl_id, at in faults:
        if kind in ("silent", "overload") and at >= duration_s:
            raise ConfigError("--faults", f"{kind}:{dxl_id}@{at:g}",
                              f"at {at:g} s, after the run's end (--duration {duration_s:g})")
