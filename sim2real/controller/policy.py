"""A controller file as a policy: robot readings in, joint goals out (no MuJoCo).

The same wiring as in evolution (:mod:`sim2real.controller.symmetry`, :mod:`sim2real.controller.mapping`, which
the tests use as the oracle of this faster, fused form):
present joint angles, foot switches and the torso's up-vector become both networks'
inputs; their outputs become joint goals by the central-0.8 rule, rate-limited to the
servos' no-load speed per tick; joints the controller does not drive hold the centre of
their range.
"""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np

from sim2real.controller.activation import ControllerNetworks
from sim2real.controller.mapping import OUTPUT_MARGIN
from sim2real.controller.symmetry import network_inputs, symmetric_layout
from sim2real.robot import RobotSpec


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
        self._gather, self._sign = self._input_gather()
        self._right_out = self.layout.leg_index["right"]
        self._left_out = self.layout.leg_index["left"]
        self._center_out = self.layout.center_index
        self._k = self.layout.n_leg
        # the central-0.8 rule as one affine map, clipped to the range afterwards
        d = self.driven
        self._scale = (self.high[d] - self.low[d]) / (1.0 - 2.0 * OUTPUT_MARGIN)
        self._offset = self.low[d] - OUTPUT_MARGIN * self._scale
        self._span = 2.0 / (self.high - self.low)

    def _input_gather(self) -> tuple[np.ndarray, np.ndarray]:
        """Both networks' inputs as one gather from [angles, feet, up] and a sign: the same
        numbers as :func:`network_inputs` (its test oracle), in two numpy calls."""
        n = len(self.low)
        probe = np.arange(n + 5, dtype=float) + 1.0  # distinct values reveal the wiring
        rows = network_inputs(self.layout, probe[None, :n], probe[None, n:n + 2], probe[None, n + 2:])
        index = np.abs(rows).astype(np.intp) - 1
        sign = np.sign(rows)
        return index, sign
    def reset(self) -> np.ndarray:
        """Zero the networks' state; returns the start pose (home for driven joints) [rad]."""
        self.networks.reset()
        return self.hold.copy()

    def step(self, angles: np.ndarray, feet_touching: np.ndarray, up: np.ndarray,
             previous_goal: np.ndarray) -> np.ndarray:
        """One tick: joint angles [rad] (robot order), feet (left, right: touching), up-vector
        (torso frame) and the last goals -> the next goals [rad] for every joint."""
        readings = np.concatenate([(angles - self.low) * self._span - 1.0,
                                   np.where(feet_touching, -1.0, 1.0), up])
        out = self.networks.activate(readings[self._gather] * self._sign)
        joint_out = np.empty(len(self.low))
        joint_out[self._right_out] = out[0, :self._k]
        joint_out[self._left_out] = out[1, :self._k]
        joint_out[self._center_out] = 0.5 * (out[0, self._k:] + out[1, self._k:])
        d = self.driven
        wanted = np.clip(joint_out[d] * self._scale + self._offset, self.low[d], self.high[d])
        goal = previous_goal.copy()
        goal[d] = previous_goal[d] + np.clip(wanted - previous_goal[d], -self.max_step[d], self.max_step[d])
        return goal
