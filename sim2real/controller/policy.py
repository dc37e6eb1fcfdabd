"""A controller as a policy: robot readings in, joint goals out (no MuJoCo).

Evolution's wiring, tick for tick: present joint angles, foot switches, the torso's
up-vector (and its heading, for a controller with a heading input) become both networks'
inputs (:mod:`sim2real.controller.symmetry`); their outputs become joint goals by the
central-0.8 rule, rate-limited to the servos' no-load speed per tick
(:mod:`sim2real.controller.mapping`); joints the controller does not drive hold the centre
of their range.  Only the wiring is fused, into gathers derived from
:func:`~sim2real.controller.symmetry.network_inputs` and
:func:`~sim2real.controller.symmetry.joint_outputs` (their test oracles); every number is
computed as in evolution, bit for bit.
"""

from __future__ import annotations

from typing import Iterable

import numpy as np

from sim2real.controller.activation import ControllerNetworks
from sim2real.controller.file import Controller
from sim2real.controller.mapping import (
    hold_pose,
    max_steps,
    normalized_angle,
    output_to_angle,
    rate_limit,
)
from sim2real.controller.symmetry import foot_inputs, heading_input, joint_outputs, network_inputs, phase_inputs
from sim2real.robot import RobotSpec


class Policy:
    def __init__(self, controller: Controller, robot: RobotSpec, disabled_modules: Iterable[str] = ()):
        self.robot = robot
        self.layout = controller.layout(robot)
        self.networks = ControllerNetworks(controller, disabled_modules)
        self.driven = np.array([robot.joint_names.index(n) for n in self.layout.driven], dtype=np.intp)
        self.low = np.array([j.range_rad[0] for j in robot.joints])
        self.high = np.array([j.range_rad[1] for j in robot.joints])
        self.tick_s = float(controller.tick_s)
        self.phase_period_s = controller.phase_period_s  # None: no clock
        self.heading_scale_deg = controller.heading_scale_deg  # [deg] the turn the heading input reads as 1
        self.ticks = 0  # since reset: the clock's time
        self.start_heading: float | None = None  # [rad] the board's heading at the first tick since reset
        self.max_step = max_steps(robot, self.tick_s)
        self.hold = hold_pose(robot, self.layout.driven)
        self._gather, self._sign = self._input_gather()
        self._first, self._second = self._output_gather()
        d = self.driven
        self._d_low, self._d_high, self._d_step = self.low[d], self.high[d], self.max_step[d]

    def _input_gather(self) -> tuple[np.ndarray, np.ndarray]:
        """Both networks' inputs as one gather from [angles, feet, up, heading, clock, goals]
        and a sign: the same numbers as :func:`network_inputs` (its test oracle), in two numpy
        calls."""
        n = len(self.low)
        heading = 1 if self.layout.heading else 0
        clock = 2 if self.layout.phase else 0
        goals = n if self.layout.efference else 0
        probe = np.arange(n + 5 + heading + clock + goals, dtype=float) + 1.0  # distinct values reveal the wiring
        h, c = n + 5, n + 5 + heading  # where the heading and the clock start
        rows = network_inputs(self.layout, probe[None, :n], probe[None, n:n + 2], probe[None, n + 2:n + 5],
                              probe[None, c:c + clock] if clock else None,
                              probe[None, c + clock:] if goals else None,
                              probe[None, h] if heading else None)
        index = np.abs(rows).astype(np.intp) - 1
        sign = np.sign(rows)
        return index, sign

    def _output_gather(self) -> tuple[np.ndarray, np.ndarray]:
        """Each driven joint's output as the mean of two entries of the networks' flat outputs
        (one entry twice for a leg joint, one of each network for a centre joint): the same
        numbers as :func:`joint_outputs` (its test oracle), whose mean of two is the same exact
        halving."""
        entries = self.networks.n_networks * self.layout.n_outputs
        weight = np.array([joint_outputs(self.layout, one_hot.reshape(self.networks.n_networks, -1),
                                         len(self.low))[0, self.driven] for one_hot in np.eye(entries)])
        return weight.argmax(axis=0), entries - 1 - weight[::-1].argmax(axis=0)  # first and last entry read

    def reset(self) -> np.ndarray:
        """Zero the networks' state and the clock; returns the start pose (home for driven
        joints) [rad]."""
        self.networks.reset()
        self.ticks = 0
        self.start_heading = None
        return self.hold.copy()

    def step(self, angles: np.ndarray, feet_touching: np.ndarray, up: np.ndarray,
             previous_goal: np.ndarray, tick: int | None = None, heading: float | None = None) -> np.ndarray:
        """One tick: joint angles [rad] (robot order), feet (left, right: touching), up-vector
        (torso frame) and the last goals -> the next goals [rad] for every joint.  ``tick``:
        this tick's number since the start, for the clock (default: the steps since reset; a
        real-time loop that skips ticks gives its own, so the clock keeps to the wall).
        ``heading``: the board's heading [rad] (yaw, counter-clockwise seen from above), which
        a controller with a heading input needs; the first since reset is its start."""
        tick = self.ticks if tick is None else tick
        self.ticks = tick + 1
        parts = [normalized_angle(angles, self.low, self.high), foot_inputs(feet_touching), up]
        if self.layout.heading:
            if heading is None or not np.isfinite(heading):
                raise ValueError(f"this controller reads the torso's heading: got {heading!r} (does the sensor "
                                 "board report one?)")
            if self.start_heading is None:
                self.start_heading = float(heading)
            parts.append(np.atleast_1d(heading_input(heading, self.start_heading, self.heading_scale_deg)))
        if self.phase_period_s is not None:
            parts.append(phase_inputs(tick * self.tick_s, self.phase_period_s))
        if self.layout.efference:
            parts.append(normalized_angle(previous_goal, self.low, self.high))
        readings = np.concatenate(parts)
        out = self.networks.activate(readings[self._gather] * self._sign).reshape(-1)
        wanted = output_to_angle(0.5 * (out[self._first] + out[self._second]), self._d_low, self._d_high)
        goal = previous_goal.copy()
        goal[self.driven] = rate_limit(wanted, previous_goal[self.driven], self._d_step)
        return goal
