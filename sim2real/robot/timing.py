"""The control tick of a robot and the bus time it has to fit in.

Seed 000 updates its networks every 0.07 s for a human-sized character.  A smaller
robot moves faster: by dynamic similarity (Froude scaling, time ~ sqrt(length / g)) its
tick is ``0.07 * sqrt(L_robot / L_human)`` with L the leg length (hip joint to sole).
The tick can never be shorter than one tick's bus time - the reads of every present
position, the read of the sensor board and the writes of every goal, grouped by protocol and
control table (:mod:`sim2real.robot.bus_plan`), at the configured baud (10 bits a byte,
Return Delay Time 0), plus the host's turnaround for each exchange that waits for replies -
and it is rounded to a whole number of physics steps.  Within one tick a goal may move at most the servo's no-load speed times
the tick.

The tick is bounded from above by the Bus Watchdog that start-up
(:mod:`sim2real.hardware.dynamixel.startup`) sets on every servo that has one
(:func:`watchdog_ms`): a servo that hears no instruction for that long stops and refuses goals,
so a tick may last at most half of it (:func:`sim2real.controller.robot_checks.tick_bounds`).
This module owns that setting; start-up writes it from here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

from sim2real.robot import RobotSpec, load_robot
from sim2real.robot.bus_plan import BITS_PER_BYTE, bus_time, tick_exchanges

HUMAN_TICK_S = 0.07  # seed 000 section 8: spinal reflex delay
REFERENCE_HUMAN = "human:male_50"  # whose leg length the 0.07 s belongs to
PHYSICS_DT_S = 0.002  # MuJoCo timestep [s], unless the robot config sets physics_dt_s
# The Bus Watchdog (ROBOTIS e-manual, X series control table, "Bus Watchdog(98)"; MX with
# protocol 2.0 too): its entry's name in firmware_profiles/, the setting start-up writes, and the
# entry's unit.
BUS_WATCHDOG = "bus_watchdog"
WATCHDOG_MS = 100  # servos stop if the host is silent this long [ms]
WATCHDOG_UNIT_MS = 20  # the entry counts in 20 ms [ms]


@dataclass(frozen=True)
class ControlTiming:
    tick_s: float  # the control tick used, a multiple of physics_dt_s [s]
    scaled_tick_s: float  # 0.07 * sqrt(leg / human_leg) before bounds and rounding [s]
    human_tick_s: float
    leg_length_m: float
    human_leg_length_m: float
    bus_cycle_s: float  # wire time of one tick's packets [s]
    bus_bytes: int
    bus_time_s: float  # the wire time plus the host's turnaround per exchange awaiting replies [s]
    bus_packets: int  # instruction packets a tick
    physics_dt_s: float
    substeps: int  # physics steps a tick
    rule: str  # how tick_s was chosen, in words


def bus_cycle_bytes(robot: RobotSpec) -> int:
    """Bytes on the wire for one control cycle (instructions and status packets)."""
    return sum(e.out_bytes() + e.in_bytes() for e in tick_exchanges(robot))


def bus_cycle_s(robot: RobotSpec) -> float:
    """Wire time of one control cycle at the robot's baud rate [s] (0 without a bus)."""
    if robot.bus is None:
        return 0.0
    return bus_cycle_bytes(robot) * BITS_PER_BYTE / robot.bus.baud


def tick_bus_s(robot: RobotSpec) -> float:
    """One control tick's whole bus time [s]: its wire time and the host's turnaround for each
    exchange that waits for replies (:class:`sim2real.robot.bus_plan.BusTime`); 0 without a bus."""
    time = bus_time(robot)
    return 0.0 if time is None else time.total_s


def watchdog_ms(robot: RobotSpec) -> int | None:
    """The Bus Watchdog start-up sets on ``robot``'s servos [ms]: :data:`WATCHDOG_MS`, or None
    for a robot without a bus or none of whose servos has the entry."""
    watched = robot.bus is not None and any(
        j.servo is not None and BUS_WATCHDOG in j.servo.profile.control_table for j in robot.joints)
    return WATCHDOG_MS if watched else None


@lru_cache(maxsize=1)
def human_leg_length_m() -> float:
    """Leg length of seed 000's 50th-percentile man, the 0.07 s tick's reference [m]."""
    return load_robot(REFERENCE_HUMAN).body.leg_length


def control_timing(robot: RobotSpec, physics_dt_s: float | None = None) -> ControlTiming:
    physics_dt_s = physics_dt_s or robot.physics_dt_s or PHYSICS_DT_S
    leg = robot.leg_length
    human_leg = human_leg_length_m()
    scaled = HUMAN_TICK_S * math.sqrt(leg / human_leg)
    cycle = tick_bus_s(robot)
    if robot.control_tick_s is not None:
        wanted, rule = robot.control_tick_s, "fixed by the robot config (control_tick_s)"
    elif scaled < cycle:
        wanted, rule = cycle, "raised to the bus cycle time (the tick's reads and writes)"
    else:
        wanted, rule = scaled, "0.07 s * sqrt(leg length / human leg length)"
    substeps = max(1, round(wanted / physics_dt_s))
    if substeps * physics_dt_s < cycle:
        substeps = math.ceil(cycle / physics_dt_s)
        if robot.control_tick_s is not None:
            rule += f", raised to the bus cycle time ({cycle * 1e3:.2f} ms)"
    return ControlTiming(
        tick_s=substeps * physics_dt_s,
        scaled_tick_s=scaled,
        human_tick_s=HUMAN_TICK_S,
        leg_length_m=leg,
        human_leg_length_m=human_leg,
        bus_cycle_s=bus_cycle_s(robot),
        bus_bytes=bus_cycle_bytes(robot),
        bus_time_s=cycle,
        bus_packets=len(tick_exchanges(robot)),
        physics_dt_s=physics_dt_s,
        substeps=substeps,
        rule=rule + f", rounded to {substeps} physics steps of {physics_dt_s * 1e3:g} ms",
    )
