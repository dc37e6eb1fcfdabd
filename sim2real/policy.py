"""A controller file as a policy: robot readings in, joint goals out (no MuJoCo).

The same wiring as in evolution (:mod:`sim2real.symmetry`, :mod:`sim2real.mapping`):
present joint angles, foot switches and the torso's up-vector become both networks'
inputs; their outputs become joint goals by the central-0.8 rule, rate-limited to the
servos' no-load speed per tick; joints the controller does not drive hold the centre of
their range.
"""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np

from sim2real.mapping import normalized_angle, output_to_angle, rate_limit
from sim2real.network_runtime import ControllerNetworks
from sim2real.robot import RobotSpec
from sim2real.symmetry import joint_outputs, network_inputs, symmetric_layout


class Policy:
    def __init__(self, controller: dict[str, Any], robot: RobotSpec, disabled_modules: Iterable[str] = ()):
        self.robot = robot
        self.layout = symmetric_layout(robot, tuple(controller["joints"]["driven"]))
        if list(self.layout.input_names) != controller["inputs"]:
            raise ValueError(f"controller inputs {controller['inputs']} do not match robot {robot.name}'s "
                             f"{list(self.layout.input_names)}")
        self.networks = ControllerNetworks(controller, disabled_modules)
        names = list(robot.joint_names)
        self.driven = np.array([names.index(n) for n in self.layout.driven], dtype=np.intp)
        self.low = np.array([j.range_rad[0] for j in robot.joints])
        self.high = np.array([j.range_rad[1] for j in robot.joints])
        self.tick_s = float(controller["tick_s"])
        self.max_step = np.array([j.servo.profile.motor.no_load_speed_rad_s * self.tick_s if j.servo else np.inf
                                  for j in robot.joints])
        self.hold = np.array([j.home_rad if j.name in self.layout.driven else j.center_rad for j in robot.joints])

    def reset(self) -> np.ndarray:
        """Zero the networks' state; returns the start pose (home for driven joints) [rad]."""
        self.networks.reset()
        return self.hold.copy()

    def step(self, angles: np.ndarray, feet_touching: np.ndarray, up: np.ndarray,
             previous_goal: np.ndarray) -> np.ndarray:
        """One tick: joint angles [rad] (robot order), feet (left, right: touching), up-vector
        (torso frame) and the last goals -> the next goals [rad] for every joint."""
        feet = np.where(np.asarray(feet_touching, dtype=bool), -1.0, 1.0)[None, :]
        x = network_inputs(self.layout, normalized_angle(angles, self.low, self.high)[None, :], feet,
                           np.asarray(up, dtype=float)[None, :])
        out = joint_outputs(self.layout, self.networks.activate(x), len(self.low))[0]
        goal = previous_goal.copy()
        d = self.driven
        wanted = output_to_angle(out[d], self.low[d], self.high[d])
        goal[d] = rate_limit(wanted, previous_goal[d], self.max_step[d])
        return goal
