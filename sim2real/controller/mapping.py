"""Network outputs to joint goals, and joint angles to what the robot sees (no MuJoCo).

Seed 000 section 7.2: an output in [0, 1] drives its joint through the central 0.8 of its
range - 0.1 maps to the low end, 0.9 to the high end, beyond that it clamps.  A goal may
move at most the servo's no-load speed times the tick in one tick.  Angles are read
quantized to the encoder's resolution, as the servo reports them.

All functions take numpy arrays and broadcast; angles in [rad].
"""

from __future__ import annotations

from collections.abc import Collection

import numpy as np

from sim2real.robot import RobotSpec
from sim2real.robot.servo_model import max_step_per_tick

OUTPUT_MARGIN = 0.1  # output range clamped at each end
OUTPUT_RULE = (f"central {1.0 - 2.0 * OUTPUT_MARGIN:g} of the range: {OUTPUT_MARGIN:g} -> low, "
               f"{1.0 - OUTPUT_MARGIN:g} -> high")  # as a controller file states it
# the same, its middle at each joint's home angle instead of its range's: a network at rest
# (outputs 0.5) holds home even where home lies near an end of the range (a straight knee or
# elbow, an arm at the side), as a human's anatomical ranges have it
OUTPUT_RULE_HOME = (f"central {1.0 - 2.0 * OUTPUT_MARGIN:g} about home: {OUTPUT_MARGIN:g} -> low, 0.5 -> home, "
                    f"{1.0 - OUTPUT_MARGIN:g} -> high")
OUTPUT_RULES = {"range": OUTPUT_RULE, "home": OUTPUT_RULE_HOME}  # a task's output_centre -> the file's rule


def output_to_angle(output: np.ndarray, low: np.ndarray, high: np.ndarray,
                    centre: np.ndarray | None = None) -> np.ndarray:
    """Central-0.8 rule: output 0.1 -> low, 0.9 -> high, clamped outside [rad]; with
    ``centre`` (home angles inside the ranges) 0.5 -> centre, linear on each side of it."""
    fraction = np.clip((output - OUTPUT_MARGIN) / (1.0 - 2.0 * OUTPUT_MARGIN), 0.0, 1.0)
    if centre is None:
        return low + fraction * (high - low)
    side = 2.0 * fraction - 1.0
    return centre + side * np.where(side >= 0.0, high - centre, centre - low)


def angle_to_output(angle: np.ndarray, low: np.ndarray, high: np.ndarray,
                    centre: np.ndarray | None = None) -> np.ndarray:
    """Inverse of :func:`output_to_angle` inside the range."""
    if centre is None:
        fraction = (angle - low) / (high - low)
    else:
        above = angle >= centre
        span = np.where(above, high - centre, centre - low)
        fraction = 0.5 + 0.5 * np.divide(angle - centre, span, out=np.zeros_like(np.asarray(angle, float)),
                                         where=span > 0)
    return OUTPUT_MARGIN + (1.0 - 2.0 * OUTPUT_MARGIN) * fraction


def rate_limit(goal: np.ndarray, previous: np.ndarray, max_step: np.ndarray) -> np.ndarray:
    """Move from ``previous`` toward ``goal`` by at most ``max_step`` [rad]."""
    return previous + np.clip(goal - previous, -max_step, max_step)


def max_steps(robot: RobotSpec, tick_s: float) -> np.ndarray:
    """(n_joints,) how far each joint's goal may move in one tick [rad]: its servo's
    :func:`~sim2real.robot.servo_model.max_step_per_tick`; a PD joint's no-load speed times
    the tick (no limit for a PD robot without one)."""
    pd_step = robot.pd_no_load_speed_rad_s * tick_s if robot.pd is not None else np.inf
    return np.array([max_step_per_tick(j.servo.profile, tick_s) if j.servo else pd_step for j in robot.joints])


def hold_pose(robot: RobotSpec, driven: Collection[str]) -> np.ndarray:
    """(n_joints,) the goals before the first tick [rad]: driven joints start at home, the
    others hold the centre of their range throughout (seed 000 section 7.2) - on a box robot,
    whose ranges are centred on a standing pose.  A robot from a model file has its
    mechanism's ranges, centred on nothing: its undriven joints (arms, head) hold home."""
    from_model = robot.model is not None
    return np.array([j.home_rad if j.name in driven or from_model else j.center_rad for j in robot.joints])


def quantize(angle: np.ndarray, resolution: np.ndarray) -> np.ndarray:
    """Round to the encoder's resolution [rad a tick] (0 leaves the angle as is)."""
    resolution = np.asarray(resolution, dtype=float)
    safe = np.where(resolution > 0, resolution, 1.0)
    return np.where(resolution > 0, np.round(angle / safe) * safe, angle)


def normalized_angle(angle: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """A joint angle as a network input: -1 at the low end of the range, +1 at the high end."""
    return 2.0 * (angle - low) / (high - low) - 1.0


class ServoMapping:
    """Joint angles <-> servo ticks for a robot's servos, with every limit applied.

    ``servo angle = direction * joint angle + zero_offset`` (from the servo's centre tick),
    ``tick = centre + servo angle / rad_per_tick``.  Goals are clamped inside the joint's
    range *and* the servo's position range before they become ticks, so no caller can write
    a goal outside the limits.
    """

    def __init__(self, robot: RobotSpec) -> None:
        joints = [j for j in robot.joints if j.servo is not None]
        if len(joints) != len(robot.joints):
            raise ValueError(f"robot {robot.name} has joints without servos")
        self.names = tuple(j.name for j in joints)
        self.ids = np.array([j.servo.id for j in joints])
        self.direction = np.array([float(j.servo.direction) for j in joints])
        self.offset = np.array([j.servo.zero_offset_rad for j in joints])
        self.rad_per_tick = np.array([j.servo.profile.position.rad_per_tick for j in joints])
        self.center = np.array([j.servo.profile.position.center_tick for j in joints], dtype=float)
        self.min_tick = np.array([j.servo.profile.position.min_tick for j in joints])
        self.max_tick = np.array([j.servo.profile.position.max_tick for j in joints])
        low = np.array([j.range_rad[0] for j in joints])
        high = np.array([j.range_rad[1] for j in joints])
        # the servo's own range, seen as joint angles
        servo_a = self.angles(self.min_tick.astype(float))
        servo_b = self.angles(self.max_tick.astype(float))
        self.low = np.maximum(low, np.minimum(servo_a, servo_b))
        self.high = np.minimum(high, np.maximum(servo_a, servo_b))
        # the same limits in ticks, rounded inward: a rounded goal cannot step outside them
        a = self.center + (self.direction * self.low + self.offset) / self.rad_per_tick
        b = self.center + (self.direction * self.high + self.offset) / self.rad_per_tick
        self.tick_low = np.ceil(np.minimum(a, b) - 1e-9).astype(np.int64)
        self.tick_high = np.floor(np.maximum(a, b) + 1e-9).astype(np.int64)

    def clamp(self, angles: np.ndarray) -> np.ndarray:
        """Inside the joint's and the servo's limits [rad]."""
        return np.clip(angles, self.low, self.high)

    def ticks(self, angles: np.ndarray) -> np.ndarray:
        """Goal ticks (int64) for joint angles, clamped to every limit first."""
        servo = self.direction * self.clamp(angles) + self.offset
        ticks = np.rint(self.center + servo / self.rad_per_tick).astype(np.int64)
        return np.clip(ticks, self.tick_low, self.tick_high)

    def angles(self, ticks: np.ndarray) -> np.ndarray:
        """Joint angles [rad] for present ticks."""
        servo = (np.asarray(ticks, dtype=float) - self.center) * self.rad_per_tick
        return (servo - self.offset) * self.direction
