"""A dry run: the real runtime (``drive`` over ``DynamixelBus`` and the official SDK) against
the simulated bus on a pseudo-terminal, with ground truth from the simulator.

Nothing in the loop knows it is not talking to hardware.  Faults end the way they would on
hardware: retried, or a safe stop with torque off.
"""

from __future__ import annotations

import math
import threading
from pathlib import Path
from typing import Any, Callable

import numpy as np

from sim2real.bus.dynamixel import DynamixelBus
from sim2real.controller import load_controller
from sim2real.deploy import drive
from sim2real.errors import ConfigError
from sim2real.reality import load_reality
from sim2real.robot import RobotSpec, load_robot
from sim2real.simbus.physics import PhysicsChain
from sim2real.simbus.server import EmulatedChain, PtyServer
from sim2real.validation import Node, load_yaml

FALL_HEIGHT = 0.7  # as in evolution: pelvis below 70 % of its start height
FALL_TILT_DEG = 60.0
FAULT_KINDS = ("silent", "overload", "drop", "corrupt")


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


def arm_faults(spec: str | None, chain: EmulatedChain, physics: PhysicsChain,
               delay_s: float = 0.0) -> tuple[list[threading.Timer], dict[str, float]]:
    """Timers for silent servos and overload times (``delay_s`` after start), and the wire's
    drop/corrupt rates as :class:`PtyServer` keyword arguments.  IDs are checked against
    ``physics.robot``."""
    timers, rates = [], {}
    for kind, dxl_id, at in parse_faults(spec, physics.robot):
        if kind == "silent":
            timers.append(threading.Timer(delay_s + at, chain.silent.add, (dxl_id,)))
        elif kind == "overload":
            physics.overload_at[dxl_id] = delay_s + at
        else:
            rates[f"{kind}_rate"] = at
    return timers, rates


def dry_run(controller_path: Path | str, robot_name: str | None = None, duration_s: float = 10.0,
            trace_path: Path | str | None = None, faults: str | None = None,
            log: Callable[[str], None] = print, ramp_s: float = 2.0,
            disabled_modules: tuple[str, ...] = (), reality: str | None = None, seed: int = 0) -> dict[str, Any]:
    """Run a controller through the real runtime on the simulated bus, the robot behind it
    perturbed by the reality profile ``reality`` (None: nominal); see ``biped dry-run``."""
    data = load_controller(controller_path)
    robot = load_robot(robot_name or data["robot"]["name"])
    data = load_controller(controller_path, robot)
    profile = load_reality(reality)
    physics = PhysicsChain(robot, reality=profile, seed=seed)
    start_soles, start_height = physics.sole_x(), physics.pelvis_height()
    chain = EmulatedChain(physics.devices, advance=physics.advance)
    timers, rates = arm_faults(faults, chain, physics, delay_s=ramp_s)
    with PtyServer(chain, **rates) as server:
        for timer in timers:
            timer.start()
        try:
            report = drive(DynamixelBus(server.port, robot.bus.baud, robot), robot, data, duration_s=duration_s,
                           trace_path=trace_path, log=log, ramp_s=ramp_s, disabled_modules=disabled_modules)
        finally:
            for timer in timers:
                timer.cancel()
    distance = float(np.min(physics.sole_x() - start_soles))
    fell = (physics.pelvis_height() < FALL_HEIGHT * start_height
            or physics.upright() < np.cos(np.radians(FALL_TILT_DEG)))
    return {"distance_m": distance, "fell": bool(fell), "ticks": report.ticks, "overruns": report.overruns,
            "bus_errors": report.bus_errors, "stop_reason": report.stop_reason, "reality": profile.name,
            "trace": str(trace_path) if trace_path else None, "simulated_s": float(physics.data.time),
            **{k: v for k, v in report.summary().items() if k.startswith(("compute", "jitter"))}}
