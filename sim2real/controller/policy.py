"""A controller as a policy: robot readings in, joint goals out (no MuJoCo).

Evolution's wiring, tick for tick: present joint angles, foot switches, the torso's
up-vector (and its heading or angular rate, for a controller that reads them) become both
networks' inputs through the same :class:`~sim2real.controller.channels.InputWiring` that
evolution runs; their outputs become joint goals by the central-0.8 rule, rate-limited to the
servos' no-load speed per tick (:mod:`sim2real.controller.mapping`); joints the controller does
not drive hold the centre of their range.  The outputs' wiring is fused into a gather derived
from :func:`~sim2real.controller.symmetry.joint_outputs` (its test oracle); every number is
computed as in evolution, bit for bit.

A run's commands from its user - a heading to hold, a point to reach - reach the policy through
:meth:`Policy.apply_commands` before any servo moves, and :meth:`Policy.task_report` gives what
the run reports of its task; the loop that drives it (:mod:`sim2real.hardware.deploy`) knows
neither steering nor reaching.
"""

from __future__ import annotations

from typing import Any, Callable, Container, Iterable

import numpy as np

from sim2real.controller.activation import ControllerNetworks
from sim2real.controller.channels import InputWiring, Reach, Readings
from sim2real.controller.file import Controller
from sim2real.controller.kinematics import ArmChain
from sim2real.controller.mapping import hold_pose, max_steps, output_to_angle, rate_limit
from sim2real.controller.reach import NO_REACH, ReachControl, aim_reach
from sim2real.controller.symmetry import joint_outputs
from sim2real.errors import UsageError
from sim2real.robot import RobotSpec


def refuse_commands(inputs: Container[str], *, heading: object = None, reach_target: object = None) -> None:
    """Refuse (:class:`UsageError`) a user's command that a controller with these input channels
    cannot take: a heading to hold without the heading input, a reach target without the reach
    input.  The dry run asks before it starts the simulated bus, :meth:`Policy.apply_commands`
    before any servo moves."""
    if heading is not None and "heading" not in inputs:
        raise UsageError("a heading to hold was given, but the controller has no heading input "
                         "(heading_input): it cannot be steered")
    if reach_target is not None and "reach" not in inputs:
        raise UsageError(NO_REACH)


class Policy:
    def __init__(self, controller: Controller, robot: RobotSpec, disabled_modules: Iterable[str] = ()):
        self.robot = robot
        self.layout = controller.layout(robot)
        self.networks = ControllerNetworks(controller, disabled_modules)
        self.driven = np.array([robot.joint_names.index(n) for n in self.layout.driven], dtype=np.intp)
        self.low = np.array([j.range_rad[0] for j in robot.joints])
        self.high = np.array([j.range_rad[1] for j in robot.joints])
        self.tick_s = float(controller.tick_s)
        self.wiring = InputWiring(self.layout, self.low, self.high)
        self.ticks = 0  # since reset: the clock's time
        self.start_heading: float | None = None  # [rad] the board's heading at the first tick since reset
        # [rad] the heading to hold, from the start's, at a time since the start [s]: a user's command
        self.heading_command: Callable[[float], float] = lambda t_s: 0.0
        self.max_step = max_steps(robot, self.tick_s)
        self.hold = hold_pose(robot, self.layout.driven)
        self._first, self._second = self._output_gather()
        d = self.driven
        self._d_low, self._d_high, self._d_step = self.low[d], self.high[d], self.max_step[d]
        self._centre = controller.joints.centres()  # the home rule's middles (None: the range's)
        # a reaching controller runs seed 002's state machine on the angles it reads
        self.reach: ReachControl | None = None
        self._reach_tick: int | None = None  # the tick of its last step
        if self.layout.reach:
            settings = self.layout.inputs["reach"]
            self.reach = ReachControl(ArmChain.from_dict(controller.reach_arm, robot.joint_names),
                                      np.array([j.home_rad for j in robot.joints]), 1, Reach.target(settings),
                                      settings["reach_phase_s"], settings["reach_tolerance"])

    @property
    def sensors(self) -> tuple[str, ...]:
        """What this controller reads beyond joint angles, feet and up-vector (a
        :class:`~sim2real.controller.channels.Readings` field each: ``heading``, ``gyro``)."""
        return self.wiring.sensors

    @property
    def trace_channels(self) -> tuple[tuple[str, str], ...]:
        """(name, unit) of what a trace records of this policy beyond the robot's readings:
        a reaching controller's state and its hand's distance to the goal."""
        return (("reach_state", "1 reaching"), ("hand_error", "arm lengths")) if self.reach is not None else ()

    def trace_values(self) -> tuple[float, ...]:
        """The :attr:`trace_channels`' values at the last step: the state the networks read."""
        if self.reach is None:
            return ()
        return float(self.reach.cycle.state[0]), float(self.reach.error[0])

    def apply_commands(self, *, heading: Callable[[float], float] | None = None,
                       reach_target: tuple[float, float, float] | None = None,
                       log: Callable[[str], None] = print) -> None:
        """A user's commands for the run, each refused (:class:`UsageError`) if this controller
        cannot take it: ``heading``, the heading to hold [rad, from the start's] at a time since
        the start [s] (a controller with a heading input, :mod:`sim2real.controller.steering`);
        ``reach_target``, where the right hand reaches in the root body's frame [m] (a reaching
        controller, :func:`~sim2real.controller.reach.aim_reach`).  None: not commanded."""
        refuse_commands(self.layout.inputs, heading=heading, reach_target=reach_target)
        if heading is not None:
            self.heading_command = heading
        if reach_target is not None:
            aim_reach(self.reach, reach_target, log)

    def task_report(self) -> dict[str, Any]:
        """What a run reports of this controller's task beyond the loop's counts: a reaching
        controller's goals reached, target and arm (``{"reach": ...}``); empty for others."""
        return {} if self.reach is None else {"reach": self.reach.report()}

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
        if self.reach is not None:  # from reaching again, toward the same target
            self.reach.restart()
            self._reach_tick = None
        return self.hold.copy()

    def step(self, angles: np.ndarray, feet_touching: np.ndarray, up: np.ndarray,
             previous_goal: np.ndarray, tick: int | None = None, heading: float | None = None,
             gyro: np.ndarray | None = None) -> np.ndarray:
        """One tick: joint angles [rad] (robot order), feet (left, right: touching), up-vector
        (torso frame) and the last goals -> the next goals [rad] for every joint.  ``tick``:
        this tick's number since the start, for the clock (default: the steps since reset; a
        real-time loop that skips ticks gives its own, so the clock keeps to the wall).
        ``heading``: the board's heading [rad] (yaw, counter-clockwise seen from above), which
        a controller with a heading input needs; the first since reset is its start.
        ``gyro``: the board's angular rates about the torso's x, y, z axes [rad/s], which a
        controller with a gyro input needs."""
        tick = self.ticks if tick is None else tick
        self.ticks = tick + 1
        for sensor, value in (("heading", heading), ("gyro", gyro)):
            if sensor in self.sensors and (value is None or not np.all(np.isfinite(value))):
                raise ValueError(f"this controller reads the torso's {sensor}: got {value!r} (does the sensor "
                                 "board report one?)")
        start = None
        if "heading" in self.sensors:
            if self.start_heading is None:
                self.start_heading = float(heading)
            start = np.array([self.start_heading + self.heading_command(tick * self.tick_s)])
        reach_state = reach_target = None
        if self.reach is not None:
            one = np.zeros(1, dtype=np.intp)
            since = 0.0 if self._reach_tick is None else (tick - self._reach_tick) * self.tick_s
            self._reach_tick = tick
            self.reach.step(one, angles[None], since)
            reach_state, reach_target = self.reach.inputs(one)
        readings = Readings(angles=angles[None], feet=np.asarray(feet_touching)[None], up=np.asarray(up)[None],
                            time_s=tick * self.tick_s, previous_goal=previous_goal[None],
                            heading=None if heading is None else np.array([float(heading)]), target_heading=start,
                            gyro=None if gyro is None else np.asarray(gyro, dtype=float)[None],
                            reach_state=reach_state, reach_target=reach_target)
        out = self.networks.activate(self.wiring.inputs(readings)).reshape(-1)
        wanted = output_to_angle(0.5 * (out[self._first] + out[self._second]), self._d_low, self._d_high,
                                 self._centre)
        goal = previous_goal.copy()
        goal[self.driven] = rate_limit(wanted, previous_goal[self.driven], self._d_step)
        return goal
