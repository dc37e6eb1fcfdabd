"""Whole-population evaluation of locomotion tasks with ``mujoco.batch``.

Every genome of a generation gets its own simulation in one :class:`mujoco.batch.Batch`.
One batch call advances every living simulation by one control tick (``nstep``
substeps, on all threads); between calls, one vectorized step reads every robot's
sensors, activates both networks of every genome (:class:`PopulationNetwork`), maps
outputs to rate-limited joint goals, and lets the objective (walk, pose, stand:
:mod:`evolve.locomotion.objectives`) check termination.  Terminated simulations
leave the ids and their networks leave the population network, so nothing is spent on
them; there is no Python loop over individuals.  MuJoCo's batch is bit-identical at any
thread count, and so are the results.

A simulation may carry a perturbation (:mod:`sim2real.simulation.reality.file`): its own masses, friction,
gains, latency and backlash in the batch's per-simulation model fields, sensor noise on what
the networks read.  A reality that can draw backlash gets a model with backlash joints;
joint angles are read from ``qpos`` by the model's :class:`JointAngles` either way.

Sensor readings are the batch's derived fields, one physics substep (2 ms) older than
the state - the robot, too, reads its servos a little before it writes.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from mujoco.batch import Batch, SimulationError

from evolve.locomotion.objectives import Episodes, Objective, WalkObjective
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome, Layout, PopulationNetwork
from sim2real.controller.kinematics import ArmChain
from sim2real.controller.reach import ReachControl
from sim2real.controller.channels import InputWiring, Readings
from sim2real.controller.mapping import hold_pose, max_steps, output_to_angle, quantize, rate_limit
from sim2real.controller.symmetry import SymmetricLayout, bias_values, joint_outputs, symmetric_layout
from sim2real.robot import RobotSpec
from sim2real.robot.spec import GRAVITY
from sim2real.robot.timing import control_timing
from sim2real.simulation.model.builder import build_model
from sim2real.simulation.model.robot_model import Arm, RobotModel, arm_chain, imu_between
from sim2real.simulation.reality.file import NOMINAL, Reality
from sim2real.simulation.reality.randomize import (
    PERTURBED_FIELDS,
    Perturbation,
    apply,
    latency_capacity_s,
    needs_backlash_joints,
    sample,
)

MAX_JOINT_SPEED = 1e3  # [rad/s] beyond this a simulation is numerically unstable


def neat_layout(layout: SymmetricLayout) -> Layout:
    """The NEAT genome interface of a symmetric controller."""
    return Layout(layout.n_inputs, layout.n_bias, layout.n_outputs)


class LocomotionEvaluator:
    """Episodes of many controllers at once on one robot; see the module docstring.

    ``reality`` (randomization ranges or a fixed profile) sizes the model for its longest
    control latency and gives it backlash joints if it can draw backlash; each call's
    ``perturbation`` then gives every simulation its draw.
    """

    def __init__(self, robot: RobotSpec, task: TaskConfig, max_population: int, threads: int = 0,
                 reality: Reality = NOMINAL):
        if task.control_set not in robot.control_sets:
            raise ValueError(f"task.control_set: robot {robot.name} has no control set "
                             f"{task.control_set!r} (has {', '.join(robot.control_sets)})")
        reality.check_batchable()
        self.robot, self.task, self.reality = robot, task, reality
        timing = control_timing(robot)
        self.tick_s, self.substeps = timing.tick_s, timing.substeps
        self.model = model = build_model(robot, latency_capacity_s(reality, self.tick_s),
                                         backlash=needs_backlash_joints(reality))
        self.n_ticks = int(round(task.episode_s / self.tick_s))
        self.layout = symmetric_layout(robot, robot.control_sets[task.control_set], task.inputs)
        self.driven = np.array([robot.joint_names.index(n) for n in self.layout.driven], dtype=np.intp)
        self.low = np.array([j.range_rad[0] for j in robot.joints])
        self.high = np.array([j.range_rad[1] for j in robot.joints])
        self.resolution = np.array([j.servo.profile.position.rad_per_tick if (j.servo and task.quantize)
                                    else 0.0 for j in robot.joints])
        self.max_step = max_steps(robot, self.tick_s)
        self.hold = hold_pose(robot, self.layout.driven)
        self.wiring = InputWiring(self.layout, self.low, self.high)
        self.parts = parts = RobotModel.of(model, robot)
        self.angles, self.root = parts.angles, parts.root
        self.leg = robot.leg_length
        self.mass = robot.mass

        self.batch = Batch(model, max_population, threads)
        self.qpos, self.qvel = self.batch.bind("qpos"), self.batch.bind("qvel")
        self.ctrl, self.xfrc = self.batch.bind("ctrl"), self.batch.bind("xfrc_applied")
        self.sensordata = self.batch.bind("sensordata")
        self.site_xpos, self.xipos = self.batch.bind("site_xpos"), self.batch.bind("xipos")
        self.subtree_com = self.batch.bind("subtree_com")
        if self.layout.reach:  # what reaching reads: bound only then, as every bound output is copied each step
            self.xpos, self.xmat = self.batch.bind("xpos"), self.batch.bind("xmat")
            self.actuator_force = self.batch.bind("actuator_force")
        self._perturbed = np.zeros(max_population, dtype=bool)
        self.turns: np.ndarray | None = None  # the episode's heading commands (evaluate's turns)
        self.objective: Objective | None = None  # the episode's
        self.reach: ReachControl | None = None  # the episode's reach state machine, if its objective runs one
        self._arm: Arm | None = None
        self._arm_chain: ArmChain | None = None
        self._imu_history: np.ndarray | None = None  # a delayed IMU's readings, (n, ticks + 1, 7), from tick 0

    @property
    def output_centres(self) -> np.ndarray | None:
        """The driven joints' angles for an output of 0.5 under the task's home rule (None:
        the middles of their ranges)."""
        if self.task.output_centre == "range":
            return None
        return np.array([self.robot.joints[i].home_rad for i in self.driven])

    @property
    def arm(self) -> Arm:
        """The right arm's parts (reaching needs them; refused, naming the robot, without)."""
        if self._arm is None:
            self._arm = Arm.of(self.model, self.robot)
        return self._arm

    @property
    def arm_chain(self) -> ArmChain:
        """The right arm's chain, as a reaching controller's file carries it (its runtime's
        forward kinematics, which the state machine runs here too)."""
        if self._arm_chain is None:
            self._arm_chain = ArmChain.from_dict(arm_chain(self.model, self.robot, self.arm), self.robot.joint_names)
        return self._arm_chain

    def heading(self, ids: np.ndarray, tick: int, p: Perturbation | None,
                sensors: np.ndarray | None = None, yaw: np.ndarray | None = None) -> np.ndarray:
        """The heading the boards of simulations ``ids`` report at ``tick`` [rad]: the torso's
        yaw (``yaw``, if a delayed IMU's; else from ``sensors``, their sensordata if read
        already), plus the gyro's drift since the start."""
        if yaw is None:
            yaw = self.parts.heading(self.sensordata[ids] if sensors is None else sensors)
        return yaw if p is None else yaw + p.heading_drift_rad_s[ids] * (tick * self.tick_s)

    def readings(self, alive: np.ndarray, t: int, p: Perturbation | None, goal: np.ndarray,
                 start_heading: np.ndarray | None, turns: np.ndarray | None = None) -> Readings:
        """What the boards and servos of simulations ``alive`` report at tick ``t``: the
        encoders quantized, every reading with this simulation's noise, what the layout's
        inputs need (``goal``: every simulation's last driven goals; ``start_heading``: each
        board's heading at the first tick, which ``turns`` (n, ticks) [rad] turn the heading to
        hold by).  Called once a tick: a reaching objective's state machine steps here, on the
        angles just read, as the runtime's steps on each tick's readings."""
        sensors = self.sensordata[alive]
        q = self.joint_angles(alive)
        touch = self.parts.feet_touching(sensors)
        up = self.parts.up(sensors)
        gyro = self.parts.gyro(sensors) if self.layout.gyro else None
        yaw = None
        if p is not None and p.imu_delay_s.any():
            imu = self._delayed_imu(alive, t, p, sensors)
            up, gyro, yaw = imu[:, :3], (imu[:, 3:6] if self.layout.gyro else None), imu[:, 6]
        if p is not None:
            q = q + p.joint_noise_rad[alive, t]
            touch = touch ^ p.foot_flip[alive, t]
            up = up + p.up_noise[alive, t]
            if gyro is not None:
                gyro = gyro + p.gyro_noise_rad_s[alive, t] + p.gyro_bias_rad_s[alive]
        sent = None
        if self.layout.efference:  # the goals of last tick, every joint (undriven ones hold)
            sent = np.broadcast_to(self.hold, (len(alive), len(self.hold))).copy()
            sent[:, self.driven] = goal[alive]
        heading = self.heading(alive, t, p, sensors, yaw) if self.layout.heading else None
        angles = quantize(q, self.resolution)
        reach_state = reach_target = None
        if self.layout.reach:  # the state machine, on the angles the networks read, tells them when to reach
            if self.reach is not None:
                self.reach.step(alive, angles, self.tick_s if t else 0.0)
                reach_state, reach_target = self.reach.inputs(alive)
            else:  # a stage below reaching: never told to reach
                reach_state, reach_target = np.zeros(len(alive)), np.zeros((len(alive), 3))
        return Readings(angles=angles, feet=touch, up=up, time_s=t * self.tick_s,
                        previous_goal=sent, heading=heading,
                        target_heading=None if start_heading is None else
                        start_heading[alive] + (0.0 if turns is None else turns[alive, t]), gyro=gyro,
                        reach_state=reach_state, reach_target=reach_target)

    def _delayed_imu(self, alive: np.ndarray, t: int, p: Perturbation, sensors: np.ndarray) -> np.ndarray:
        """The IMU readings (packed as :meth:`RobotModel.imu`) the boards of ``alive`` report at
        tick ``t``: each ``p.imu_delay_s`` old, between the ticks' own readings, which a history
        from tick 0 keeps (a reading older than the episode is its first)."""
        if t == 0:
            self._imu_history = np.zeros((len(p), self.n_ticks + 1, 7))
        history = self._imu_history
        history[alive, t] = self.parts.imu(sensors)
        lag = p.imu_delay_s[alive] / self.tick_s  # [ticks]
        whole = np.floor(lag).astype(np.intp)
        newer = history[alive, np.maximum(t - whole, 0)]
        older = history[alive, np.maximum(t - whole - 1, 0)]
        return imu_between(newer, older, lag - whole)

    def joint_angles(self, ids: np.ndarray) -> np.ndarray:
        """Joint angles of simulations ``ids`` (len(ids), joints) [rad], unquantized and
        noise-free: what their encoders see."""
        return self.angles.read(self.qpos[ids])

    @property
    def episode_s(self) -> float:
        """An episode's simulated length: whole control ticks, so up to a tick short of the
        task's ``episode_s`` [s] (a robot upright to the end is upright this long)."""
        return self.n_ticks * self.tick_s

    @property
    def neat_layout(self) -> Layout:
        return neat_layout(self.layout)

    @property
    def max_population(self) -> int:
        return self.batch.nsim

    def sample(self, keys: np.ndarray, intensity: float = 1.0) -> Perturbation:
        """This evaluator's reality, its ranges scaled toward nominal by ``intensity``
        (:meth:`Reality.scaled`), drawn once per row of ``keys`` (see :func:`reality.sample`)."""
        return sample(self.reality.scaled(intensity), keys, self.model, self.n_ticks, self.tick_s)

    def evaluate(self, genomes: list[Genome], steepness: float, harness: float = 0.0,
                 disabled_modules: tuple[str, ...] = (),
                 on_tick: Callable[["LocomotionEvaluator", np.ndarray], None] | None = None,
                 perturbation: Perturbation | None = None,
                 objective: Callable[["LocomotionEvaluator", int], Objective] | None = None,
                 pushes: np.ndarray | None = None, turns: np.ndarray | None = None) -> Episodes:
        """Run one episode per genome, with the support harness at ``harness`` strength
        (0: none, 1: full), each simulation perturbed by its row of ``perturbation`` (None:
        the nominal robot) and pushed by its row of ``pushes`` (n, ticks, 2): the whole robot's
        velocity change [m/s] at each tick, as :func:`evolve.locomotion.pushes.push_schedule`
        draws them; commanded to turn by its row of ``turns`` (n, ticks): the heading to hold
        at each tick, from the start's [rad] (:func:`evolve.locomotion.heading_commands.turn_schedule`;
        None: hold the start's); scored by ``objective(self, n)`` (default :class:`WalkObjective`);
        ``on_tick(self, alive_ids)`` is called after every tick (to record frames of a replay)."""
        n = len(genomes)
        if n > self.max_population:
            raise ValueError(f"{n} genomes but the batch holds {self.max_population} simulations")
        if perturbation is not None and len(perturbation) != n:
            raise ValueError(f"{len(perturbation)} perturbations for {n} genomes")
        if pushes is not None and pushes.shape != (n, self.n_ticks, 2):
            raise ValueError(f"pushes of shape {pushes.shape} for {n} genomes of {self.n_ticks} ticks")
        if turns is not None and turns.shape != (n, self.n_ticks):
            raise ValueError(f"turns of shape {turns.shape} for {n} genomes of {self.n_ticks} ticks")
        self.turns = turns  # the objective scores the walk along the heading to hold
        task, tick = self.task, self.tick_s
        ids = np.arange(n)
        self._perturb(ids, perturbation)
        self.batch.reset(ids, keyframe=0)
        self.ctrl[:n] = self.hold
        self.xfrc[:n] = 0.0
        net = PopulationNetwork([g for g in genomes for _ in range(2)], steepness, disabled_modules,
                                bias_values(n))
        self.reach = None  # a reaching objective installs its state machine
        score = self.objective = (objective or WalkObjective)(self, n)
        start_root = self.parts.root_com(self.xipos[:n]).copy()
        goal = self.hold[self.driven][None, :].repeat(n, axis=0)
        elapsed = np.zeros(n)
        unstable = np.zeros(n, dtype=bool)
        alive = ids
        steps = 0
        k = harness * task.harness_stiffness * self.mass * GRAVITY / self.leg
        c = 2.0 * task.harness_damping * np.sqrt(k * self.mass)
        cap = harness * task.harness_max_force * self.mass * GRAVITY
        p = perturbation

        d_low, d_high, d_step = self.low[self.driven], self.high[self.driven], self.max_step[self.driven]
        centre = self.output_centres
        start_heading = self.heading(ids, 0, p) if self.layout.heading else None
        for t in range(self.n_ticks):
            readings = self.readings(alive, t, p, goal, start_heading, turns)
            inputs = self.wiring.inputs(readings)
            outputs = joint_outputs(self.layout, net.activate(inputs), len(self.low))[:, self.driven]
            goal_alive = rate_limit(output_to_angle(outputs, d_low, d_high, centre), goal[alive], d_step)
            goal[alive] = goal_alive
            self.ctrl[alive[:, None], self.driven] = goal_alive
            if harness or pushes is not None:
                force = self._harness(alive, start_root, k, c, cap) if harness else np.zeros((len(alive), 3))
                if pushes is not None:  # an impulse of mass x speed change, spread over the tick
                    force[:, :2] += pushes[alive, t] * (self.mass / tick)
                self.xfrc[alive, self.root, :3] = force
            failed = np.zeros(len(alive), dtype=bool)
            try:
                self.batch.step(alive, self.substeps)
            except SimulationError as exc:
                failed = np.isin(alive, exc.ids)
            steps += len(alive) * self.substeps
            elapsed[alive] += tick
            if on_tick is not None:
                on_tick(self, alive)

            # a NaN fails the comparison, so "not all below the limit" also catches NaN
            bad = failed | ~(np.abs(self.qvel[alive]) <= MAX_JOINT_SPEED).all(axis=1) | \
                ~np.isfinite(self.qpos[alive, 2])
            unstable[alive[bad]] = True
            done = score.tick(alive, elapsed, bad)
            if done.any():
                keep = np.flatnonzero(~done)
                alive = alive[keep]
                if not len(alive):
                    break
                net.keep(np.stack([2 * keep, 2 * keep + 1], axis=1).ravel())

        upright = np.where(score.fell, elapsed - tick, elapsed)  # fell during its last tick
        return score.result(upright, unstable, steps)

    def _perturb(self, ids: np.ndarray, p: Perturbation | None) -> None:
        """Give simulations ``ids`` their perturbation, or back their nominal model."""
        if p is None and not self._perturbed[ids].any():
            return
        fields = {name: self.batch.expand(name) for name in PERTURBED_FIELDS}
        nominal = sample(NOMINAL, np.zeros((len(ids), 1)), self.model, 0, self.tick_s) if p is None else None
        apply(fields, self.model, p if p is not None else nominal, ids)
        self.batch.set_const(ids)  # masses and armatures feed derived constants
        self._perturbed[ids] = p is not None

    def _harness(self, alive, start, k, c, cap) -> np.ndarray:
        """Support from the sides, from behind and from below, never against going forward or
        up (seed 000 section 8.2): forces on the pelvis [N], held for one tick.

        Sideways it is a spring-damper to the start line (times ``harness_sideways``).  From behind it catches the robot
        only behind its start, and from below only once the pelvis sinks under
        ``harness_height`` of its start height: a one-sided support that acted everywhere
        would turn any vibration into forward drift (a ratchet), which evolution finds.  Each
        axis is capped at ``harness_max_force`` of the weight, so the legs must carry the rest:
        a robot that can hang in its harness swings its legs and drifts forward unopposed.
        """
        # the root's centre of mass, as its start was taken: its frame's origin (qpos) can lie
        # well below it (OP3's 67 mm), and the catch from below would then hold from the start
        pos = self.parts.root_com(self.xipos)[alive]
        vel = self.qvel[alive][:, :3]
        behind = np.maximum(start[alive, 0] - pos[:, 0], 0.0)
        below = np.maximum(self.task.harness_height * start[alive, 2] - pos[:, 2], 0.0)
        force = np.empty((len(alive), 3))
        force[:, 0] = (k * behind - c * np.minimum(vel[:, 0], 0.0)) * (behind > 0)
        force[:, 1] = self.task.harness_sideways * (-k * (pos[:, 1] - start[alive, 1]) - c * vel[:, 1])
        force[:, 2] = (k * below - c * np.minimum(vel[:, 2], 0.0)) * (below > 0)
        return np.clip(force, -cap, cap)
