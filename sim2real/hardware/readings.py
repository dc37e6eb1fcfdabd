"""What a trace can record beyond joint angles: each servo's present velocity and its load
(or its current, on servos that sense current instead), read every tick when the goal
source asks for them (an excitation program, for system identification).

Values are converted to the joint's frame and SI-like units: velocity [rad/s]; load as a
share of the servo's maximum torque [1] (Present Load, 0.1 % a unit); current [A].  A
register is read only if every servo has it (at whatever address: the chain groups the read
by protocol and layout); a mixed chain without one records what it can and says what it left
out.  No MuJoCo here.
"""

from __future__ import annotations

import math

import numpy as np

from sim2real.hardware.dynamixel.chain import ServoChain
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.hardware.trace import Channel
from sim2real.robot import RobotSpec


class MotionReadings:
    """The extra registers to read, with each joint's factor into its channel's unit."""

    def __init__(self, chain: ServoChain | None, robot: RobotSpec):
        self.chain = chain  # None: only to ask what it would read (:func:`traced_registers`)
        profiles = [j.servo.profile for j in robot.joints]
        direction = np.array([float(j.servo.direction) for j in robot.joints])
        self.reads: list[tuple[Reg, np.ndarray]] = []
        self.channels: list[Channel] = []
        self.left_out: list[str] = []
        self.spanned = True  # read in one sync read of their span, while that works

        def common(reg: Reg) -> bool:
            return all(reg in p.control_table for p in profiles)

        def add(reg: Reg, factor: np.ndarray, suffix: str, unit: str) -> None:
            self.reads.append((reg, direction * factor))
            self.channels += [Channel(f"{name}_{suffix}", unit) for name in robot.joint_names]

        if common(Reg.PRESENT_VELOCITY) and all(p.units.get("velocity_unit_rpm") for p in profiles):
            add(Reg.PRESENT_VELOCITY, np.array([p.units["velocity_unit_rpm"] * 2 * math.pi / 60 for p in profiles]),
                "velocity_rad_s", "rad/s")
        else:
            self.left_out.append("velocity")
        if common(Reg.PRESENT_LOAD):
            add(Reg.PRESENT_LOAD, np.full(len(profiles), 0.001), "load", "1")
        elif common(Reg.PRESENT_CURRENT):
            amps = [float(p.control_table[Reg.PRESENT_CURRENT].unit.split()[0]) / 1e3 for p in profiles]  # "2.69 mA"
            add(Reg.PRESENT_CURRENT, np.array(amps), "current_a", "A")
        else:
            self.left_out.append("load or current")

    def read(self, attempts: int | None = None) -> np.ndarray:
        """This tick's values, in :attr:`channels` order: one sync read of the registers'
        span where they lie next to each other (X series: load 126, velocity 128), else one
        each."""
        names = [reg for reg, _ in self.reads]
        if not names:
            return np.zeros(0)
        if self.spanned:
            try:
                values = self.chain.sync_read_span(names, attempts=attempts)
            except ValueError:  # not next to each other on these servos: one read each from now on
                self.spanned = False
        if not self.spanned:
            values = {reg: self.chain.sync_read(reg, attempts=attempts) for reg in names}
        return np.concatenate([values[reg] * factor for reg, factor in self.reads])


def traced_registers(robot: RobotSpec) -> tuple[Reg, ...]:
    """The registers :class:`MotionReadings` reads every tick on ``robot``: what a traced
    excitation adds to the tick's bus time (:func:`sim2real.robot.bus_plan.bus_time`)."""
    return tuple(reg for reg, _ in MotionReadings(None, robot).reads)
