"""A dry run: the real runtime (``drive`` over ``DynamixelBus`` and the official SDK) against
the simulated bus on a pseudo-terminal, with ground truth from the simulator.

Nothing in the loop knows it is not talking to hardware.  Faults end the way they would on
hardware: retried, or a safe stop with torque off.
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any, Callable

import numpy as np

from sim2real.bus.dynamixel import DynamixelBus
from sim2real.controller import load_controller
from sim2real.deploy import drive
from sim2real.errors import ConfigError
from sim2real.reality import load_reality
from sim2real.robot import load_robot
from sim2real.simbus.physics import PhysicsChain
from sim2real.simbus.server import EmulatedChain, PtyServer
from sim2real.validation import Node, load_yaml

FALL_HEIGHT = 0.7  # as in evolution: pelvis below 70 % of its start height
FALL_TILT_DEG = 60.0


def parse_faults(spec: str | None) -> list[tuple[str, int, float]]:
    """``silent:ID@SECONDS,overload:ID@SECONDS,drop:RATE,corrupt:RATE``, or a YAML file of the
    same (``silent: [{id: 4, at_s: 3}]``, ``overload: [...]``, ``drop: 0.02``, ``corrupt: 0.01``)
    -> [(kind, id, value)] (id 0 for the wire-wide rates)."""
    if spec and spec.endswith((".yaml", ".yml")):
        return _faults_file(Path(spec))
    faults = []
    for item in filter(None, (spec or "").split(",")):
        if item.startswith(("drop:", "corrupt:")):
            kind, rate = item.split(":", 1)
            try:
                value = float(rate)
            except ValueError:
                value = -1.0
            if not 0.0 <= value <= 1.0:
                raise ConfigError("--faults", item, "a rate must be a number within [0, 1]")
            faults.append((kind, 0, value))
            continue
        try:
            kind, rest = item.split(":")
            dxl_id, at = rest.split("@")
            faults.append((kind.strip(), int(dxl_id), float(at)))
        except ValueError:
            raise ConfigError("--faults", item, "expected KIND:ID@SECONDS (silent:5@3.0, overload:7@2) "
                              "or KIND:RATE (drop:0.02, corrupt:0.01)") from None
        if faults[-1][0] not in ("silent", "overload"):
            raise ConfigError("--faults", item, "kind must be silent or overload")
    return faults


def _faults_file(path: Path) -> list[tuple[str, int, float]]:
    node = Node(load_yaml(path) or {}, str(path)).mapping(optional=("silent", "overload", "drop", "corrupt"))
    faults = []
    for kind in ("silent", "overload"):
        for item in node[kind].list() if node.has(kind) else []:
            item.mapping(required=("id", "at_s"))
            faults.append((kind, item["id"].integer(0, 252), item["at_s"].number(lo=0.0)))
    for kind in ("drop", "corrupt"):
        if node.has(kind):
            faults.append((kind, 0, node[kind].number(0.0, 1.0)))
    return faults


def arm_faults(spec: str | None, chain: EmulatedChain, physics: PhysicsChain,
               delay_s: float = 0.0) -> tuple[list[threading.Timer], dict[str, float]]:
    """Timers for silent servos and overload times (``delay_s`` after start), and the wire's
    drop/corrupt rates as :class:`PtyServer` keyword arguments."""
    timers, rates = [], {}
    for kind, dxl_id, at in parse_faults(spec):
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
