"""Servos whose motion is simulated by MuJoCo: the physics behind the simulated bus.

The robot's model advances in real time, lazily: whenever an instruction arrives, the
simulation catches up with the wall clock, each servo driven toward its Goal Position
(torque on) or limp (torque off).  Then the control tables get what the servos would
report - Present Position quantized to the encoder, Present Velocity, Present Load (or
Present Current on servos that sense it) - and
the sensor board its foot switches (closed above the robot's ``foot_contact_n``) and the
torso's up-vector (in its profile's ``up_vector_unit``) and, if its profile has the register, its
heading (``heading_unit``).  A servo that holds its stall torque for ``overload_s`` latches an
overload: alert bit, Hardware Error Status, torque off until REBOOT.

A reality profile (:mod:`sim2real.simulation.reality.file`) perturbs the robot behind the bus: masses,
friction and servo gains in the model, latency as actuator delay, backlash as the gears'
free play (backlash joints, whose angle the encoders see and the motor does not), noise on
what the servos and the board report; and, only here, effects the model leaves out
(:class:`ServoEffects`).  ``suspended`` hangs the robot by its root (a box robot's pelvis), feet off the floor,
for ``biped excite``.

Injected faults (:mod:`.faults`) are timed from the first Torque Enable of any servo - the
moment a runtime starts its run - not from this process's start: how long a runtime takes to
open the port and check the bus must not decide whether a fault lands before or after it.
"""

from __future__ import annotations

import collections
import math
import threading
import time
from typing import Callable

import mujoco
import numpy as np

from sim2real.controller.mapping import ServoMapping
from sim2real.controller.channels import turn_rad
from sim2real.hardware.dynamixel.chain import board_reports, decode, encode
from sim2real.hardware.dynamixel.errors import OVERLOAD_BIT
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.hardware.mock import MockBus
from sim2real.robot import RobotSpec
from sim2real.simulation.model.builder import instability
from sim2real.simulation.model.robot_model import RobotModel, imu_between
from sim2real.simulation.reality.file import EFFECTS, NOMINAL, Reality
from sim2real.simulation.reality.randomize import perturbed_model

MAX_CATCH_UP_S = 0.25  # never simulate more than this in one go (a stalled host)
# The simulated bus steps at most this much simulated time [s] between two looks at the
# wire (5 steps of 2 ms, 0.2-0.6 ms of compute): after a stall it catches up in such chunks
# between instructions, and a late reply is not made later still by the physics it missed
# (up to MAX_CATCH_UP_S, 5-10 ms of compute, before issue 47)
REPLY_CATCH_UP_S = 0.01
FALL_HEIGHT = 0.7  # as in evolution: the root (pelvis) below 70 % of its start height
FALL_TILT_DEG = 60.0


class ServoEffects:
    """What the simulated bus's servos do that the model cannot express (reality
    :data:`~sim2real.simulation.reality.EFFECTS`), applied before every physics step: Coulomb
    friction that rises toward rest (Stribeck) and with the torque the gears carry, and torque
    limits that sag with the current all servos draw together."""

    def __init__(self, model: mujoco.MjModel, reality: Reality, seed: int, dofs: np.ndarray, stall_nm: np.ndarray):
        rng = np.random.default_rng([seed, 1])  # its own stream: the perturbation's draws stay as they were
        value = {}
        for key in EFFECTS:
            lo, hi = reality.range(key)
            value[key] = lo if lo == hi else float(rng.uniform(lo, hi))
        self.stribeck_nm, self.stribeck_rad_s = value["stribeck_nm"], value["stribeck_rad_s"]
        self.load_friction, self.supply_sag = value["load_friction"], value["supply_sag"]
        self.dofs, self.stall_total = dofs, float(np.sum(stall_nm))
        self.friction = model.dof_frictionloss[dofs].copy()
        self.limit = model.actuator_forcerange[:, 1].copy()

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        carried = np.abs(data.actuator_force)
        speed = data.qvel[self.dofs]
        model.dof_frictionloss[self.dofs] = (self.friction + self.load_friction * carried
                                             + self.stribeck_nm * np.exp(-(speed / self.stribeck_rad_s) ** 2))
        limit = self.limit * (1.0 - self.supply_sag * min(1.0, carried.sum() / self.stall_total))
        model.actuator_forcerange[:, 0], model.actuator_forcerange[:, 1] = -limit, limit


class PhysicsChain:
    def __init__(self, robot: RobotSpec, clock: Callable[[], float] = time.monotonic, overload_s: float = 2.0,
                 reality: Reality = NOMINAL, seed: int = 0, suspended: bool = False):
        self.robot, self.clock, self.overload_s = robot, clock, overload_s
        self.model, self.perturbation = perturbed_model(robot, reality, seed, suspended)
        self.rng = np.random.default_rng(seed)
        self.data = mujoco.MjData(self.model)
        mujoco.mj_resetDataKeyframe(self.model, self.data, self.model.key("home").id)
        mujoco.mj_forward(self.model, self.data)
        self.devices = MockBus(robot).devices
        self.mapping = ServoMapping(robot)
        self.ids = [int(i) for i in self.mapping.ids]
        names = list(robot.joint_names)
        self.parts = RobotModel.of(self.model, robot)
        self.angles = self.parts.angles
        self.kp = self.model.actuator_gainprm[:, 0].copy()
        self.kv = -self.model.actuator_biasprm[:, 2].copy()  # the D term, if the reality draws one
        self.stall = np.array([j.servo.profile.motor.stall_torque_nm for j in robot.joints])  # datasheet
        self.torque_limit = self.model.actuator_forcerange[:, 1].copy()  # this robot's
        self.effects = (ServoEffects(self.model, reality, seed, self.angles.servo_dof, self.stall)
                        if reality.effects else None)
        self.board = robot.sensor_board.id if robot.sensor_board else None
        self.saturated = np.zeros(len(names))
        # fault injection: servo id -> seconds after the first torque on (see the module docstring)
        self.overload_at: dict[int, float] = {}
        self.silent_at: dict[int, float] = {}
        self.on_silent: Callable[[int], None] = lambda dxl_id: None  # the serving chain's
        self.torque_on_at: float | None = None  # simulated time [s] of the first torque on
        self.end_of_run: dict[str, float | bool] | None = None  # ground truth when the loop ended
        self.lock = threading.Lock()
        # a delayed IMU: its readings after each physics step, as long back as the delay reaches
        delay_steps = int(math.ceil(self.perturbation.imu_delay_s[0] / self.model.opt.timestep))
        self._imu_history: collections.deque | None = (collections.deque(maxlen=delay_steps + 2)
                                                        if delay_steps else None)
        self._started = clock()
        self._publish()
        self._start_soles, self._start_height = self.sole_x(), self.root_height()
        self._start_heading = self.heading()
        for k, dxl_id in enumerate(self.ids):
            self.devices[dxl_id].set_named(Reg.GOAL_POSITION, int(self.devices[dxl_id].get_named(Reg.PRESENT_POSITION)))

    # -- angles and ticks, unclamped: what the encoder sees -----------------------------------
    def _ticks(self, angles: np.ndarray) -> np.ndarray:
        m = self.mapping
        return np.rint(m.center + (m.direction * angles + m.offset) / m.rad_per_tick).astype(np.int64)

    def _goals(self) -> tuple[np.ndarray, np.ndarray]:
        goal, on = np.zeros(len(self.ids)), np.zeros(len(self.ids), dtype=bool)
        for k, dxl_id in enumerate(self.ids):
            device = self.devices[dxl_id]
            reg = device.profile.register(Reg.GOAL_POSITION)
            goal[k] = decode(reg, device.get(reg.address, reg.size))
            on[k] = bool(device.get_named(Reg.TORQUE_ENABLE))
        return self.mapping.angles(goal), on

    def advance(self, max_s: float = MAX_CATCH_UP_S) -> bool:
        """Catch the simulation up with the wall clock, by at most ``max_s`` of simulated time
        [s] (called before every instruction, and between them); True while it is still behind."""
        with self.lock:
            target = self.clock() - self._started
            # the small epsilon: a sum of 2 ms steps lands a hair short of a whole number of them
            behind = int((target - self.data.time) / self.model.opt.timestep + 1e-6)
            steps = min(behind, max(1, int(max_s / self.model.opt.timestep + 1e-6)))
            if steps <= 0:
                return False
            goal, on = self._goals()
            if self.torque_on_at is None and on.any():
                self.torque_on_at = self.data.time
            # torque off: limp (kp 0 below), the goal at the motor's own angle (no stale goal
            # waits in the latency history for torque on)
            self.data.ctrl[:] = np.where(on, goal, self.angles.servo(self.data.qpos))
            self.model.actuator_gainprm[:, 0] = np.where(on, self.kp, 0.0)  # torque off: limp
            self.model.actuator_biasprm[:, 1] = -self.model.actuator_gainprm[:, 0]
            self.model.actuator_biasprm[:, 2] = -np.where(on, self.kv, 0.0)
            for _ in range(steps):
                if self.effects is not None:
                    self.effects.apply(self.model, self.data)
                mujoco.mj_step(self.model, self.data)
                self._check_overload(on)
                if self._imu_history is not None:
                    self._imu_history.append((self.data.time, self.parts.imu(self.data.sensordata)))
            self._silence_due()
            self._publish()
            return steps < behind

    def _check_overload(self, on: np.ndarray) -> None:
        force = np.abs(self.data.actuator_force)
        self.saturated = np.where(on & (force >= 0.99 * self.torque_limit), self.saturated + self.model.opt.timestep, 0.0)
        if not self.overload_at and not np.any(self.saturated >= self.overload_s):
            return  # the common case, without a Python loop over the servos every step
        for k, dxl_id in enumerate(self.ids):
            if self.saturated[k] >= self.overload_s or self._due(self.overload_at.get(dxl_id)):
                self.overload_at.pop(dxl_id, None)
                self.saturated[k] = 0.0
                self.devices[dxl_id].raise_hardware_error(OVERLOAD_BIT)

    def _due(self, after_torque_on_s: float | None) -> bool:
        return (after_torque_on_s is not None and self.torque_on_at is not None
                and self.data.time >= self.torque_on_at + after_torque_on_s)

    def _silence_due(self) -> None:
        for dxl_id in [i for i, at in self.silent_at.items() if self._due(at)]:
            del self.silent_at[dxl_id]
            self.on_silent(dxl_id)

    def _publish(self) -> None:
        p = self.perturbation
        q = self.angles.read(self.data.qpos)
        q = q + self.rng.normal(0.0, 1.0, len(q)) * p.joint_noise_sd_rad[0]
        ticks = self._ticks(q)
        qdot = self.angles.speeds(self.data.qvel)
        for k, dxl_id in enumerate(self.ids):
            device = self.devices[dxl_id]
            device.set_named(Reg.PRESENT_POSITION, int(ticks[k]))
            device.position = float(ticks[k])
            unit = device.profile.units.get("velocity_unit_rpm")
            if unit and Reg.PRESENT_VELOCITY in device.profile.control_table:
                rpm = self.mapping.direction[k] * qdot[k] * 60 / (2 * math.pi)
                device.set_named(Reg.PRESENT_VELOCITY, int(round(rpm / unit)))
            table = device.profile.control_table
            if Reg.PRESENT_LOAD in table:
                load = int(round(self.mapping.direction[k] * self.data.actuator_force[k] / self.stall[k] * 1000.0))
                reg = table[Reg.PRESENT_LOAD]
                if reg.encoding == "sign_magnitude_bit10":  # protocol 1.0 (AX, MX): bit 10 is the sign
                    device.set_named(Reg.PRESENT_LOAD, encode(reg, max(-0x3FF, min(0x3FF, load))))
                else:
                    device.set_named(Reg.PRESENT_LOAD, load)
            elif Reg.PRESENT_CURRENT in table:  # current-sensing servos (XM430): torque / K_t
                motor = device.profile.motor
                amps = self.data.actuator_force[k] * motor.stall_current_a / motor.stall_torque_nm
                lsb_ma = float(table[Reg.PRESENT_CURRENT].unit.split()[0])  # e.g. "2.69 mA"
                device.set_named(Reg.PRESENT_CURRENT, int(round(self.mapping.direction[k] * amps * 1000 / lsb_ma)))
        if self.board is not None:
            board = self.devices[self.board]
            touching = [bool(closed) != (self.rng.random() < p.foot_flip_p[0])
                        for closed in self.parts.feet_touching(self.data.sensordata)]
            board.set_named(Reg.FOOT_SWITCH_LEFT, int(touching[0]))
            board.set_named(Reg.FOOT_SWITCH_RIGHT, int(touching[1]))
            imu = self._imu()
            up = imu[:3] + self.rng.normal(0.0, 1.0, 3) * p.up_noise_sd[0]
            for reg, value in zip((Reg.UP_VECTOR_X, Reg.UP_VECTOR_Y, Reg.UP_VECTOR_Z), up):
                board.set_named(reg, int(round(float(value) / board.profile.units["up_vector_unit"])))
            if board_reports(self.robot, "heading"):  # the IMU's yaw, drifting as this robot's gyro does
                yaw = float(turn_rad(imu[6] + p.heading_drift_rad_s[0] * self.data.time, 0.0))
                board.set_named(Reg.HEADING, int(round(yaw / board.profile.units["heading_unit"])))
            if board_reports(self.robot, "gyro"):  # the torso's angular rates, with this gyro's bias and noise
                rates = imu[3:6] + p.gyro_bias_rad_s[0]
                if p.gyro_noise_sd_rad_s[0]:  # drawn only then: a reality without it draws as before the gyro
                    rates = rates + self.rng.normal(0.0, 1.0, 3) * p.gyro_noise_sd_rad_s[0]
                for reg, value in zip((Reg.GYRO_X, Reg.GYRO_Y, Reg.GYRO_Z), rates):
                    board.set_named(reg, int(round(float(value) / board.profile.units["gyro_unit"])))

    def _imu(self) -> np.ndarray:
        """What the board's IMU reports now (packed as :meth:`RobotModel.imu`): this robot's
        ``imu_delay_s`` old, between the physics steps' readings (before the first, the oldest)."""
        now = self.parts.imu(self.data.sensordata)
        if self._imu_history is None or not self._imu_history:
            return now
        when = self.data.time - self.perturbation.imu_delay_s[0]
        newer_t, newer = self.data.time, now
        for older_t, older in reversed(self._imu_history):
            if older_t <= when:
                share = (newer_t - when) / (newer_t - older_t) if newer_t > older_t else 0.0
                return imu_between(newer, older, share)
            newer_t, newer = older_t, older
        return newer

    # -- ground truth, for dry-run reports ---------------------------------------------------------
    def sole_x(self) -> np.ndarray:
        return self.parts.sole_positions(self.data.site_xpos)[:, 0].copy()

    def root_height(self) -> float:
        return float(self.parts.root_com(self.data.xipos)[2])

    def upright(self) -> float:
        return float(self.parts.up(self.data.sensordata)[2])

    def heading(self) -> float:
        """The torso's true yaw [rad] (no drift)."""
        return float(self.parts.heading(self.data.sensordata))

    def ground_truth(self) -> dict[str, float | bool]:
        """Distance of the hindmost sole since the start [m], whether the robot fell (as in
        evolution: the root body (pelvis) below 70 % of its start height, or torso tilted past 60 deg) and how
        far it faces from its start heading (wrapped to +-180 deg, left positive) - at the
        end of the run's loop if :meth:`mark_end_of_run` was called (the stop's ramp to rest
        and torque off come after it: a runner braked to rest, or a limp robot, may topple
        then, and that is not the controller's walk), else now."""
        if self.end_of_run is not None:
            after = self._now()
            return {**self.end_of_run, "fell_after_stop": after["fell"], "simulated_s_after_stop": after["simulated_s"]}
        return self._now()

    def mark_end_of_run(self) -> None:
        """Keep the ground truth as it is now: the loop has just ended."""
        self.advance()
        self.end_of_run = self._now()

    def _now(self) -> dict[str, float | bool]:
        with self.lock:
            fell = (self.root_height() < FALL_HEIGHT * self._start_height
                    or self.upright() < math.cos(math.radians(FALL_TILT_DEG)))
            turn = math.degrees(turn_rad(self.heading(), self._start_heading))
            return {"distance_m": float(np.min(self.sole_x() - self._start_soles)), "fell": bool(fell),
                    "heading_deg": turn, "simulated_s": float(self.data.time),
                    "unstable": instability(self.data)}  # then the rest is no result (MuJoCo reset it)
