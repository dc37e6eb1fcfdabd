"""A robot's physique where the simulation measures it: mass, height and leg length of a robot
from a model file, on its compiled model.

:class:`~sim2real.robot.spec.RobotSpec` describes a robot without MuJoCo.  A box robot's
physique follows from its box tree; a robot from an MJCF or URDF has none until it is measured
(:func:`~sim2real.simulation.model.file_robot.measure_physique`), and asked for one before, it
says so, naming the robot and MuJoCo.  So whatever loads a robot to simulate it, or to derive
from its size what evolution needs (the control tick, the gait period, the torque cap of a PD
character), loads it measured, once:

    robot = load_measured("op3")      # load_robot, then measured
    robot.leg_length                  # [m], measured on the compiled model at its zero pose
    robot = measured(robot)           # the same for a spec in hand (a box robot as it is)

The robot computer's ``biped run`` reads no physique, so it needs neither MuJoCo nor this module.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from sim2real.robot import DEFAULT_ROBOT, RobotSpec, load_robot
from sim2real.simulation.model.file_robot import measure_physique


def measured(robot: RobotSpec) -> RobotSpec:
    """``robot`` with its physique known: a box robot, or one measured already, as it is; a
    robot from a model file with :attr:`~sim2real.robot.spec.RobotSpec.measured` set from its
    compiled model (a :class:`~sim2real.errors.ConfigError` naming its config if the model
    has no hips above its soles)."""
    if robot.model is None or robot.measured is not None:
        return robot
    return dataclasses.replace(robot, measured=measure_physique(robot))


def load_measured(name_or_path: str | Path = DEFAULT_ROBOT) -> RobotSpec:
    """:func:`~sim2real.robot.loading.load_robot` (a project robot's name, a preset such as
    ``human:female_50``, or a path), then :func:`measured`."""
    return measured(load_robot(name_or_path))
