"""A controller against a robot: the joints it was made for, and the ticks the robot's bus can run.

:func:`check_robot` is the last step of :func:`sim2real.controller.checks.check_controller`
when it is given a robot: the file's joint-map hash (:func:`joint_map_hash`), and inputs,
outputs, symmetry and joint ranges exactly those the robot gives for the driven joints (its
control set); every hold angle inside its joint's range; and ``tick_s`` within
:func:`tick_bounds` - no shorter than one bus cycle (the loop could not read and write every
servo in it), no longer than half the Bus Watchdog start-up sets (one late tick would trip it
and the servos would stop taking goals).  A tick other than the robot's own is allowed within
these bounds.  Both bounds are the robot's: its bus plan (:mod:`sim2real.robot.bus_plan`) and
its servos' watchdog (:func:`sim2real.robot.timing.watchdog_ms`); only a robot with neither
falls back on the format's bounds.

:func:`bus_problems` says why a robot's bus cannot run a tick at all (``biped robot show``,
and a run before it opens its port).
"""

from __future__ import annotations

import hashlib
import json
import math
from typing import Any

from sim2real.controller.channels import selection
from sim2real.controller.field_checker import FieldChecker, difference, join_key
from sim2real.controller.schema import NETWORKS, TICK_RANGE_S
from sim2real.controller.symmetry import symmetric_layout
from sim2real.robot import RobotSpec
from sim2real.robot.bus_plan import baud_problem, bus_devices, bus_time, tick_problem
from sim2real.robot.timing import PHYSICS_DT_S, control_timing, watchdog_ms
from sim2real.robot.validation import show

RANGE_TOLERANCE_RAD = 1e-9  # [rad] a file's joint range may differ from the robot's by rounding


def joint_map_hash(robot: RobotSpec) -> str:
    """A short hash of what a controller relies on: joint names, order, ranges and servos."""
    parts = []
    for j in robot.joints:
        servo = (j.servo.id, j.servo.profile.model, j.servo.direction, round(j.servo.zero_offset_rad, 9)) if j.servo else None
        # a model joint turned over (sign -1) adds its sign: older robots' hashes stay as they were
        parts.append([j.name, j.side, j.location, j.axis, [round(a, 9) for a in j.range_rad], servo]
                     + ([j.sign] if j.sign != 1 else []) + ([{"index": j.index}] if j.index else []))
    return hashlib.sha256(json.dumps(parts).encode()).hexdigest()[:16]


def check_robot(c: FieldChecker, data: dict[str, Any], robot: RobotSpec) -> None:
    """``data``, a controller whose fields passed the format's checks, against ``robot`` (see
    the module docstring); raises the first problem through ``c``."""
    want = joint_map_hash(robot)
    if data["robot"]["joint_map_hash"] != want:
        raise c.error("robot.joint_map_hash", f"made for robot {show(data['robot']['name'])} with joint map "
                      f"{data['robot']['joint_map_hash']}, but {robot.name} has {want}")
    driven = data["joints"]["driven"]
    control_set = data["task"].get("control_set")
    if control_set is not None:
        if control_set not in robot.control_sets:
            raise c.error("task.control_set", f"robot {robot.name} has no control set {show(control_set)} "
                          f"(has {', '.join(robot.control_sets)})")
        members = set(robot.control_sets[control_set])
        if set(driven) != members:
            raise c.error("joints.driven", difference(f"robot {robot.name}'s {control_set!r} control set "
                                                       "(task.control_set)", sorted(set(driven) - members),
                                                       sorted(members - set(driven))))
    try:
        layout = symmetric_layout(robot, tuple(driven), selection(data))
    except (ValueError, KeyError) as exc:
        raise c.error("joints.driven", str(exc)) from None
    why = f"robot {robot.name} driving {show(list(layout.driven))}"
    c.same_names("outputs", data["outputs"], list(layout.output_names), why)
    c.same_names("inputs", data["inputs"], list(layout.input_names), why)
    names = robot.joint_names
    sym = data["symmetry"]
    for side in NETWORKS:
        c.same_names(f"symmetry.leg_joints.{side}", sym["leg_joints"][side],
                     [names[i] for i in layout.leg_index[side]], why)
    c.same_names("symmetry.center_joints", sym["center_joints"], [names[i] for i in layout.center_index], why)
    if [float(m) for m in sym["center_mirror_for_left"]] != layout.center_mirror.tolist():
        raise c.error("symmetry.center_mirror_for_left", f"must be {layout.center_mirror.tolist()} for {why}")
    for block in ("range_rad", "hold_rad"):
        for name, value in data["joints"].get(block, {}).items():
            if name not in names:
                raise c.error(join_key(f"joints.{block}", name), f"robot {robot.name} has no such joint")
            actual = robot.joint(name).range_rad
            if block == "range_rad":
                if any(abs(a - b) > RANGE_TOLERANCE_RAD for a, b in zip(value, actual)):
                    raise c.error(join_key("joints.range_rad", name), f"{show(value)} differs from robot "
                                  f"{robot.name}'s {list(actual)}")
            elif not actual[0] - RANGE_TOLERANCE_RAD <= value <= actual[1] + RANGE_TOLERANCE_RAD:
                raise c.error(join_key("joints.hold_rad", name), f"{show(value)} rad ({math.degrees(value):.1f} deg) "
                              f"is outside the joint's range [{actual[0]:.6g}, {actual[1]:.6g}] rad "
                              f"([{math.degrees(actual[0]):.1f}, {math.degrees(actual[1]):.1f}] deg, robot "
                              f"{robot.name}'s range_deg): a held joint must hold an angle it can reach")
    low, high, why = tick_bounds(robot)
    tick = data["tick_s"]
    if not low - 1e-12 <= tick <= high + 1e-12:
        try:  # a robot from a model file measures its leg on the model: MuJoCo, which a robot computer may lack
            own = f"; its own tick is {control_timing(robot).tick_s * 1e3:.3g} ms"
        except RuntimeError:
            own = ""
        raise c.error("tick_s", f"{show(tick)} s is outside the ticks robot {robot.name} can run at, "
                      f"[{low * 1e3:.3g}, {high * 1e3:.3g}] ms: {why}{own}")


def tick_bounds(robot: RobotSpec) -> tuple[float, float, str]:
    """The control ticks a controller may run at on ``robot``: (shortest, longest [s], where
    both come from, in words).  Shortest: one bus cycle - the reads of every position and of
    the sensor board and the writes of every goal, grouped by protocol and control table, at
    the robot's baud, with the host's turnaround per exchange
    (:func:`sim2real.robot.bus_plan.bus_time`) - or one physics step for a robot without a
    bus.  Longest: half the Bus Watchdog that start-up sets on servos that have one
    (:func:`sim2real.robot.timing.watchdog_ms`: goals must keep coming though one tick runs
    late), else the format's bound."""
    time, step = bus_time(robot), robot.physics_dt_s or PHYSICS_DT_S
    if time is not None and time.total_s >= step:
        low = time.total_s
        why = (f"the shortest is one bus cycle ({time.packets} packets, {time.bytes} bytes at {robot.bus.baud} baud "
               "with the host's turnaround, sim2real/robot/bus_plan.py)")
    else:
        low, why = step, f"the shortest is one physics step ({step * 1e3:g} ms, longer than a bus cycle)"
    watchdog = watchdog_ms(robot)
    if watchdog is not None:
        high = watchdog / 2e3
        why += (f"; the longest half the {watchdog} ms Bus Watchdog that start-up sets on its servos "
                "(one late tick must not trip it)")
    else:
        high = TICK_RANGE_S[1]
        why += "; the longest the format's"
    return low, high, why


def bus_problems(robot: RobotSpec, tick_s: float, *, baud: int | None = None, motion: tuple[str, ...] = ()) -> list[str]:
    """Why ``robot``'s bus cannot run a tick of ``tick_s`` [s] at ``baud`` (default: the
    robot's), every reason at once: a device that cannot be set to the baud rate (servos of
    both protocols that need different ones), a tick's reads and writes (and ``motion``'s
    extra reads) that take longer than the tick, or a bus that no tick the Bus Watchdog
    allows can serve.  Empty when it can; checked by ``biped robot show`` and before a run
    opens its port."""
    if robot.bus is None:
        return []
    baud = baud or robot.bus.baud
    problems = [p for p in (baud_problem(bus_devices(robot), baud),) if p]
    time = bus_time(robot, baud, motion)
    _, high, why = tick_bounds(robot)
    if time.total_s > high + 1e-12:
        problems.append(f"one control tick's bus traffic takes {time.total_s * 1e3:.2f} ms, longer than the longest "
                        f"tick the robot can run at ({high * 1e3:.3g} ms: {why.split('; ')[-1]}): {time.describe()}")
    else:
        problem = tick_problem(robot, tick_s, baud, motion)
        if problem:
            problems.append(problem)
    return problems
