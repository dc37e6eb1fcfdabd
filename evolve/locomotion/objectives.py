"""What an episode is scored on: walking (seed 000 eq. 3) or posing and standing (seed 002
eq. 4.1).  The evaluator runs the simulations; an objective watches them after every tick,
says which are done, and scores them at the end.

An objective's score is a dict of named terms (:attr:`Episodes.terms`, each an unweighted
measure with its unit) and their combination with the weights from the config: eq. 3 sums
them, eq. 4.1 multiplies.  :data:`OBJECTIVES` is the registry of objectives by the name a
stage gives (``objective: stand``); a new objective is a class here and an entry there.

Distances are in leg lengths, so that one setting serves every robot.  Seed 002's
thresholds for a 1.8 m human (20 cm, 50 cm) become shares of its 0.9 m leg.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Protocol

import numpy as np

from evolve.locomotion.gait_tracking import GaitTracker, GoalSmoothness
from sim2real.controller.channels import Reach, turn_rad
from sim2real.controller.reach import REACHING, ReachControl, ReachCycle
from sim2real.robot.spec import ARM_LOCATIONS


# "walked": 2.2 leg lengths forward, upright to the end (seed 000's 2 m for a 0.9 m human leg)
WALK_LEG_LENGTHS = 2.2


@dataclass(frozen=True)
class Episodes:
    """Per-simulation outcome of one evaluation, arrays of shape (n,)."""

    fitness: np.ndarray  # the objective's reported fitness (seed 000 eq. 3 or seed 002 eq. 4.1)
    selection: np.ndarray  # what selection sees: fitness plus any tie-breaker
    distance_m: np.ndarray  # hindmost foot's progress along the facing direction [m]
    upright_s: np.ndarray  # simulated time before failing or the end [s]
    fell: np.ndarray  # bool: ended by a fall or another failure rule
    unstable: np.ndarray  # bool: numerical instability
    steps: int  # physics steps simulated in all
    terms: Mapping[str, np.ndarray]  # the objective's fitness terms by name, unweighted, each (n,)

    def walked(self, leg_length_m: float, episode_s: float) -> np.ndarray:
        """Which episodes walked: upright for all ``episode_s`` [s] (the evaluator's
        ``episode_s``: whole ticks) and at least :data:`WALK_LEG_LENGTHS` leg lengths forward,
        bool (n,)."""
        full = self.upright_s >= episode_s - 1e-9
        return full & ~self.fell & (self.distance_m >= WALK_LEG_LENGTHS * leg_length_m)


class Objective(Protocol):
    """Watches ``n`` simulations of an evaluator from their reset on."""

    TERMS: tuple[str, ...]  # names of its fitness terms (keys of Episodes.terms)
    fell: np.ndarray  # (n,) bool: ended by a failure rule (instability aside)

    def tick(self, alive: np.ndarray, elapsed: np.ndarray, bad: np.ndarray) -> np.ndarray:
        """After a tick: update the scores of simulations ``alive`` (``bad``: numerically
        unstable) and return which of them are done."""

    def result(self, upright: np.ndarray, unstable: np.ndarray, steps: int) -> Episodes: ...


class WalkObjective:
    """Seed 000 eq. 3, ``f = c_d max(proj_j d, eps) + c_t t``, with its early termination:
    the pelvis below ``fall_height`` of its start height or the torso tilted past
    ``fall_tilt_deg`` (the previous tick's terms are kept), instability (fitness eps),
    no progress of eps (or the task's ``stagnation_progress_leg``) within ``stagnation_s``.
    With the task's ``flight_stop_share`` > 0, a flight rule too (issue 51): both feet up in
    more than that share of the episode's ticks ends it as a fall does - a walk always has a
    foot down, a run or a hop does not.

    Terms: ``distance`` = max(proj_j d, eps) [leg lengths] and ``time`` = t [s], weighted
    by the task's ``distance_coeff`` (c_d) and ``time_coeff`` (c_t); ``progress``, the
    pelvis' best forward progress [leg lengths] (0 if unstable), a tie-breaker weighted by
    ``progress_coeff`` that selection sees and the reported fitness does not.  With the
    task's ``selection_distance_cap`` > 0, selection counts distance only up to that many leg
    lengths, so that beyond a walk a faster gait gains nothing over a steadier one; with its
    ``selection_walk_bonus`` > 0, selection adds that much for an episode that walked
    (:meth:`Episodes.walked`), so that a steady walk beats a longer run that falls; with
    ``selection_heading_deg`` > 0 only for a walk whose heading (the torso's yaw) never turned
    further than that from the start's: seed 000's sensors give no heading, and a walker
    that turns may end up walking back on a robot a little off the model.

    Two per-tick terms pay a steady, straight walk in selection (the reported fitness stays
    eq. 3), each the mean over the episode's ticks of a kernel (0 after a fall), weighted by
    the task's ``selection_velocity_coeff`` and ``selection_yaw_coeff``: ``velocity``,
    ``exp(-((v - v*) / (v* / 2))^2)`` of the root's speed v along the heading to hold against
    the target ``selection_speed_leg_s`` [leg lengths/s] (ToddlerBot's and Open Duck's velocity
    tracking); ``yaw_rate``, ``exp(-((w - w*) / sigma)^2)`` of the torso's yaw rate w against
    w* = 0.5/s x the turn to the heading to hold (Berkeley Humanoid Lite's heading P-loop),
    sigma ``selection_yaw_sigma_deg_s``; ``straight``, the velocity kernel times
    ``exp(-(e / sigma_h)^2)`` of the heading error e (ToddlerBot's torso-orientation term against
    the commanded path's yaw), sigma_h ``selection_heading_sigma_deg``, weighted by
    ``selection_straight_coeff``: standing still earns the yaw-rate kernel in full and this
    product almost nothing (the velocity kernel at rest, e^-4), and a walker that circles earns it only while it faces the heading.
    The heading to hold is the start's, turned by the
    episode's command (``evaluator.turns``).  ``turn`` [deg], weighted by nothing, is the
    largest turn from the start's heading while upright (validation can refuse walks that turn).

    With the task's ``selection_gait_coeff`` > 0, a ``gait`` term pays a two-legged walk over a
    hop or a run (:mod:`sim2real.gait_measures`, after their start-up): the share of the
    episode upright x the hips' swing symmetry (smaller / larger) x ``exp(-(f / sigma_f)^2)`` of
    the share f of ticks with both feet up, sigma_f ``selection_gait_flight_sigma``; 0..1, and 0
    for an episode that fell before its start-up was over.  Left out (not computed) otherwise.

    With the task's ``selection_smooth_coeff`` > 0, a ``smooth`` term pays goals that do not
    chatter (issue 51: a recurrent network updated once a tick can flip its outputs every tick,
    and the human walkers' stance legs pumped so, hopping): the mean over the episode's ticks
    (0 after a fall) of ``exp(-(r / sigma_s)^2)``, r the RMS over the driven joints of the
    goals' second difference from tick to tick [rad], sigma_s ``selection_smooth_sigma_deg``.
    A 1 Hz swing of +-15 deg changes its goal's step by about 3 deg a tick at 0.07 s; a goal
    flipping by 12 deg every tick, by 24 (the servo biped's shipped walker: a median RMS of
    7.6 deg at its 0.034 s tick).  Left out (not computed) otherwise.
    """

    TERMS = ("distance", "time", "progress", "velocity", "yaw_rate", "straight", "turn")
    GAIT_TERM = "gait"  # with selection_gait_coeff > 0 only
    SMOOTH_TERM = "smooth"  # with selection_smooth_coeff > 0 only
    HEADING_GAIN = 0.5  # [1/s] the yaw rate asked for per radian of turn still to go

    def __init__(self, ev, n: int):
        task = ev.task
        self.ev, self.task = ev, task
        self.start_x = ev.parts.sole_positions(ev.site_xpos)[:n][..., 0].mean(axis=1)
        self.start_pelvis = ev.parts.root_com(ev.xipos)[:n].copy()
        self.distance_term = np.full(n, task.epsilon)  # [leg lengths]
        self.time_term = np.zeros(n)  # [s]
        self.progress_best = np.zeros(n)  # hindmost foot [leg lengths], for stagnation
        self.pelvis_best = np.zeros(n)
        self.last_gain = np.zeros(n)
        self.distance = np.zeros(n)
        self.fell = np.zeros(n, dtype=bool)
        self.min_up_z = np.cos(np.radians(task.fall_tilt_deg))
        self.start_yaw = ev.heading(np.arange(n), 0, None)  # the true yaw, as the board's IMU would read it
        self.turned = np.zeros(n)  # [rad] the largest turn from the start's heading while upright
        self.ticks = 0
        self.last_xy = self.start_pelvis[:, :2].copy()
        self.last_yaw = self.start_yaw.copy()
        self.velocity_sum = np.zeros(n)  # sums of the kernels over live ticks
        self.yaw_sum = np.zeros(n)
        self.straight_sum = np.zeros(n)
        self.gait = GaitTracker(ev.robot, n, ev.tick_s) if task.selection_gait_coeff > 0 else None
        self.flight_ticks = np.zeros(n, dtype=int)  # ticks with both feet up, for the flight rule
        self.smooth = (GoalSmoothness(ev.ctrl[:n][:, ev.driven], task.selection_smooth_sigma_deg)
                       if task.selection_smooth_coeff > 0 else None)

    def tick(self, alive: np.ndarray, elapsed: np.ndarray, bad: np.ndarray) -> np.ndarray:
        ev, task = self.ev, self.task
        hind = ev.parts.sole_positions(ev.site_xpos)[alive][..., 0].min(axis=1) - self.start_x[alive]
        progress = hind / ev.leg
        pelvis_z = ev.parts.root_com(ev.xipos)[alive][:, 2]
        up_z = ev.parts.up(ev.sensordata)[alive][:, 2]
        down = (pelvis_z < task.fall_height * self.start_pelvis[alive, 2]) | (up_z < self.min_up_z)
        if task.flight_stop_share > 0:
            self.flight_ticks[alive] += ~ev.parts.feet_touching(ev.sensordata[alive]).any(axis=1)
            down |= self.flight_ticks[alive] > task.flight_stop_share * ev.n_ticks
        ok = ~down & ~bad
        live = alive[ok]
        # eq. 3's terms at this tick; a fall keeps the previous tick's
        self.distance_term[live] = np.maximum(progress[ok], task.epsilon)
        self.time_term[live] = elapsed[live]
        self.distance[live] = hind[ok]
        self.pelvis_best[live] = np.maximum(
            self.pelvis_best[live], (ev.parts.root_com(ev.xipos)[live][:, 0] - self.start_pelvis[live, 0]) / ev.leg)
        gained = progress > self.progress_best[alive] + max(task.epsilon, task.stagnation_progress_leg)
        self.progress_best[alive[gained]] = progress[gained]
        self.last_gain[alive[gained]] = elapsed[alive[gained]]
        self.fell[alive[down & ~bad]] = True
        yaw = ev.parts.heading(ev.sensordata)[alive]  # the true yaw, as the board's IMU would read it
        self.turned[live] = np.maximum(self.turned[live], np.abs(turn_rad(yaw[ok], self.start_yaw[live])))
        if self.gait is not None:  # every episode still running, as biped eval measures it
            self.gait(ev, alive)
        self._steady(alive, ok, yaw)
        if self.smooth is not None:
            self.smooth(alive, ok, ev.ctrl[alive][:, ev.driven])
        self.distance_term[alive[bad]] = task.epsilon  # eq. 3's floor, fitness c_d eps
        self.time_term[alive[bad]] = 0.0
        stagnant = elapsed[alive] - self.last_gain[alive] > task.stagnation_s
        return down | bad | stagnant

    def _steady(self, alive: np.ndarray, ok: np.ndarray, yaw: np.ndarray) -> None:
        """This tick's velocity, yaw-rate and straight kernels (``yaw``: the torso's yaw of ``alive``
        [rad]), added up for the simulations still up."""
        ev, task = self.ev, self.task
        t, self.ticks = self.ticks, self.ticks + 1
        xy = ev.parts.root_com(ev.xipos)[alive][:, :2]
        target = self.start_yaw[alive] + (0.0 if ev.turns is None else ev.turns[alive, t])
        step = xy - self.last_xy[alive]
        along = (step[:, 0] * np.cos(target) + step[:, 1] * np.sin(target)) / (ev.tick_s * ev.leg)
        rate = turn_rad(yaw, self.last_yaw[alive]) / ev.tick_s
        wanted = self.HEADING_GAIN * turn_rad(target, yaw)
        speed = task.selection_speed_leg_s
        velocity = np.exp(-((along - speed) / (0.5 * speed)) ** 2)
        steady = np.exp(-((rate - wanted) / np.radians(task.selection_yaw_sigma_deg_s)) ** 2)
        facing = np.exp(-(turn_rad(yaw, target) / np.radians(task.selection_heading_sigma_deg)) ** 2)
        live = alive[ok]
        self.velocity_sum[live] += velocity[ok]
        self.yaw_sum[live] += steady[ok]
        self.straight_sum[live] += (velocity * facing)[ok]
        self.last_xy[alive], self.last_yaw[alive] = xy, yaw

    def result(self, upright: np.ndarray, unstable: np.ndarray, steps: int) -> Episodes:
        task = self.task
        ticks = self.ev.n_ticks
        terms = {"distance": self.distance_term, "time": self.time_term,
                 "progress": np.where(unstable, 0.0, self.pelvis_best),
                 "velocity": np.where(unstable, 0.0, self.velocity_sum / ticks),
                 "yaw_rate": np.where(unstable, 0.0, self.yaw_sum / ticks),
                 "straight": np.where(unstable, 0.0, self.straight_sum / ticks),
                 "turn": np.degrees(self.turned)}
        if self.gait is not None:
            terms[self.GAIT_TERM] = np.where(unstable, 0.0, self._gait_term())
        if self.smooth is not None:
            terms[self.SMOOTH_TERM] = np.where(unstable, 0.0, self.smooth.total / ticks)
        fitness = task.distance_coeff * terms["distance"] + task.time_coeff * terms["time"]
        selection = fitness + task.progress_coeff * terms["progress"]
        if self.gait is not None:
            selection = selection + task.selection_gait_coeff * terms[self.GAIT_TERM]
        if self.smooth is not None:
            selection = selection + task.selection_smooth_coeff * terms[self.SMOOTH_TERM]
        if task.selection_velocity_coeff or task.selection_yaw_coeff or task.selection_straight_coeff:
            selection = (selection + task.selection_velocity_coeff * terms["velocity"]
                         + task.selection_yaw_coeff * terms["yaw_rate"]
                         + task.selection_straight_coeff * terms["straight"])
        if task.selection_distance_cap > 0:
            selection = selection - task.distance_coeff * np.maximum(terms["distance"] - task.selection_distance_cap, 0.0)
        episodes = Episodes(fitness, selection, self.distance, upright, self.fell, unstable, steps, terms)
        if task.selection_walk_bonus > 0:
            walked = episodes.walked(self.ev.leg, self.ev.episode_s)
            if task.selection_heading_deg:
                walked &= self.turned <= np.radians(task.selection_heading_deg)
            episodes = dataclasses.replace(episodes, selection=selection + task.selection_walk_bonus * walked)
        return episodes

    def _gait_term(self) -> np.ndarray:
        """Each episode's gait term, 0..1 (see the class docstring)."""
        measures = self.gait.meter.measures()
        symmetry = np.array([0.0 if m.empty or not math.isfinite(m.symmetry) else m.symmetry for m in measures])
        flight = np.array([1.0 if m.empty else m.flight_share for m in measures])
        upright = np.minimum(self.time_term / self.ev.episode_s, 1.0)
        return upright * symmetry * np.exp(-(flight / self.task.selection_gait_flight_sigma) ** 2)


@dataclass(frozen=True)
class PoseWeights:
    """Error weights of seed 002 eq. 4.1 (table 4.1); 0 leaves a term out."""

    rest_pose: float = 3.0  # E_restPose: squared joint errors summed over every tick [rad^2]
    rest_pose_end: float = 1.0  # E_restPoseEnd: squared joint errors at the end [rad^2]
    com: float = 0.0  # E_COM: squared distance of the CoM to its target at the end [leg lengths^2]
    feet: float = 0.0  # E_feet: squared altitudes of both feet at the end [leg lengths^2]
    reaching: float = 0.0  # E_reaching (eq. 4.6): the hand's distance to its goal summed over ticks [arm lengths]
    torque: float = 0.0  # E_torque (eq. 4.7): squared torques over joints and ticks [shares of each limit^2]

    def max_fitness(self) -> float:
        """Eq. 4.1's theoretical maximum: no failure, every error 0."""
        return 100.0 * float(np.prod([1.0 + w for w in dataclasses.astuple(self)]))


@dataclass(frozen=True)
class PoseLimits:
    """Seed 002's early termination, distances in leg lengths (its 20 cm and 50 cm for a
    0.9 m human leg); ``standing`` adds the CoM and feet rules to the pose rule."""

    rest_pose: float = 200 * np.pi  # E_restPose above this fails [rad^2]
    standing: bool = False
    com_drop: float = 0.22  # CoM this far below its target height fails
    foot_height: float = 0.22  # a foot this high fails
    feet_apart: float = 0.55  # soles this far apart fail


class PoseObjective:
    """Seed 002 eq. 4.1: ``f = 100 (dt / T) prod (1 + w / (1 + x))`` over the error terms of
    :class:`PoseWeights`, dt the ticks survived of T.  The target pose is ``target_rad``
    (driven joints, default their home angles); the CoM target is its start position.

    Terms: ``survival`` = 100 dt / T [%], the unweighted base factor, and the errors x named
    as the fields of :class:`PoseWeights` (``rest_pose``, ``rest_pose_end``, ``com``,
    ``feet``), in their units there.  An unstable simulation scores 0.
    """

    TERMS = ("survival", "rest_pose", "rest_pose_end", "com", "feet")

    def __init__(self, ev, n: int, weights: PoseWeights, limits: PoseLimits, target_rad: np.ndarray):
        self.ev, self.weights, self.limits = ev, weights, limits
        self.target = target_rad
        self.com_target = ev.subtree_com[:n, ev.root].copy()
        self.sole_z0 = ev.parts.sole_positions(ev.site_xpos)[:n][..., 2].copy()
        self.pose_error = np.zeros(n)
        self.ticks = np.zeros(n)
        self.fell = np.zeros(n, dtype=bool)  # failed a rule (instability aside)
        self.end_pose = np.zeros(n)
        self.end_com = np.zeros(n)
        self.end_feet = np.zeros(n)

    def tick(self, alive: np.ndarray, elapsed: np.ndarray, bad: np.ndarray) -> np.ndarray:
        ev, limits = self.ev, self.limits
        q = ev.joint_angles(alive)[:, ev.driven]
        squared = (((q - self.target) ** 2) * self._counted(alive)).sum(axis=1)
        self.pose_error[alive] += squared
        fail = bad | ~(self.pose_error[alive] <= limits.rest_pose) | self._failed(alive)
        com = ev.subtree_com[alive, ev.root]
        com_err = ((com - self.com_target[alive]) ** 2).sum(axis=1) / ev.leg ** 2
        height = (ev.parts.sole_positions(ev.site_xpos)[alive][..., 2] - self.sole_z0[alive]) / ev.leg
        feet_err = (height ** 2).sum(axis=1)
        if limits.standing:
            soles = ev.parts.sole_positions(ev.site_xpos)[alive][..., :2]
            apart = np.linalg.norm(soles[:, 0] - soles[:, 1], axis=1) / ev.leg
            fail |= ((com[:, 2] - self.com_target[alive, 2]) / ev.leg < -limits.com_drop) \
                | (height.max(axis=1) > limits.foot_height) | (apart > limits.feet_apart)
        ok = alive[~fail]
        self.ticks[ok] += 1
        # the end state is the last one before a failure
        self.end_pose[ok], self.end_com[ok], self.end_feet[ok] = squared[~fail], com_err[~fail], feet_err[~fail]
        self.fell[alive[fail & ~bad]] = True
        self._went_on(ok)
        return fail

    def _counted(self, alive: np.ndarray) -> np.ndarray | float:
        """Which driven joints the rest-pose errors count, (len(alive), driven) or 1: all."""
        return 1.0

    def _failed(self, alive: np.ndarray) -> np.ndarray | bool:
        """A failure rule beyond the pose's and standing's (bool per ``alive``)."""
        return False

    def _went_on(self, ok: np.ndarray) -> None:
        """After a tick's rules, for the simulations ``ok`` that passed them."""

    def result(self, upright: np.ndarray, unstable: np.ndarray, steps: int) -> Episodes:
        terms = {"survival": 100.0 * self.ticks / self.ev.n_ticks, "rest_pose": self.pose_error,
                 "rest_pose_end": self.end_pose, "com": self.end_com, "feet": self.end_feet}
        fitness = terms["survival"]
        for name in PoseObjective.TERMS[1:]:
            fitness = fitness * (1.0 + getattr(self.weights, name) / (1.0 + terms[name]))
        fitness = np.where(unstable, 0.0, fitness)
        distance = np.zeros(len(fitness))
        return Episodes(fitness, fitness.copy(), distance, upright, self.fell, unstable, steps, terms)


def reach_bonus(weights: "PoseWeights", goals: int) -> float:
    """Fitness for each goal reached, when an episode holds at most ``goals``: the base's
    theoretical maximum shared among them, so that a hand at every goal doubles the maximum.

    Seed 002 gives 100 a goal (100 T / i at most), beside eq. 4.1's 100 x a product whose
    error terms, summed over frames, leave it near 1: there the bonus is about as large as
    everything else.  Here the errors are means (see :class:`ReachObjective`) and the product
    reaches thousands: 100 a goal would be 4 % of the maximum, and a human that holds its hand
    beside the target without ever reaching it scored 72 % (measured), above any threshold.
    """
    return weights.max_fitness() / goals if goals > 0 else 0.0


class ReachObjective(PoseObjective):
    """Seed 002's reaching (section 4.1.1): standing's terms with the right arm left out of the
    rest pose, plus eq. 4.6 (``reaching``: the hand's distance to its goal - the target while
    reaching, its rest while returning [arm lengths]) and eq. 4.7 (``torque``: squared actuator
    forces as shares of their limits, summed over joints: one setting for every robot), and
    :func:`reach_bonus` for each goal reached (``reaches``).  An elbow inside the torso's box
    (the upper arm through the thorax) fails the trial, unless it is inside at home already.
    ``other_arm`` [deg], weighted by nothing, is the left arm's mean distance from its rest
    while the right hand reaches: what the one-handed task (the reach input told to the right
    network only) costs the other arm.

    Two departures from the thesis's letter, measured on OP3 with a hand-made reacher that
    reaches every goal of a 5 s episode against a network that stands still: summed over our
    ticks, eq. 4.6 and 4.7 make ``1 + w / (1 + E)`` indistinguishable from 1 for any motion, and
    the right arm's way back counted in the rest pose as well as in eq. 4.6 cost it so much that
    standing still won (0.127 against 0.158 of the maximum).  Here they are means over the
    ticks, and the right arm's place is eq. 4.6's alone, in both states (the reacher then
    scored 0.646, standing still 0.506); with :func:`reach_bonus`, 0.816 against 0.293.

    It installs the episode's state machine (:class:`sim2real.controller.reach.ReachControl`,
    ``ev.reach``), which the evaluator steps on the encoder readings the networks get, as the
    runtime does on a robot.  Positions are in the root body's frame, so that the target moves
    with the robot as on a real one; the target is the task's ``reach_forward``/``reach_left``/
    ``reach_up`` from the right shoulder, fixed as in the thesis.  Eq. 4.6 measures the hand's
    centre of mass itself.
    """

    TERMS = PoseObjective.TERMS + ("reaching", "torque", "reaches", "other_arm")

    def __init__(self, ev, n: int, weights: PoseWeights, limits: PoseLimits, target_rad: np.ndarray):
        super().__init__(ev, n, weights, limits, target_rad)
        task, arm = ev.task, ev.arm
        self.arm = arm
        self.xpos, self.xmat, self.force = ev.xpos, ev.xmat, ev.actuator_force
        self.force_limit = np.abs(ev.model.actuator_forcerange).max(axis=1)  # the nominal robot's
        if not np.all(self.force_limit > 0):
            unlimited = [ev.model.actuator(i).name for i in np.flatnonzero(~(self.force_limit > 0))]
            raise ValueError(f"actuators {', '.join(unlimited)} have no force limit: eq. 4.7 weighs torques "
                             "as shares of it")
        self.arm_joints = np.isin(np.array(ev.layout.driven), arm.joints)
        self.rest_counted = np.where(self.arm_joints, 0.0, 1.0)
        other = [j.name for j in ev.robot.joints if j.side == "left" and j.location in ARM_LOCATIONS]
        self.other_arm = np.isin(np.array(ev.layout.driven), other)
        self.other_sum = np.zeros(n)  # the left arm's mean |error| summed over the ticks spent reaching [rad]
        self.reaching_ticks = np.zeros(n)
        home = np.array([j.home_rad for j in ev.robot.joints])
        self.control = ev.reach = ReachControl(ev.arm_chain, home, n, Reach.target(task.to_dict()),
                                               task.reach_phase_s, task.reach_tolerance)
        self.bonus = reach_bonus(weights, ReachCycle.max_goals(ev.n_ticks, ev.tick_s, task.reach_phase_s))
        self.reaching = np.zeros(n)
        self.torque = np.zeros(n)
        self.thorax_rule = ~self._elbow_in_torso(np.arange(n))

    def _in_root(self, ids: np.ndarray, points: np.ndarray) -> np.ndarray:
        root = self.ev.root
        rotation = self.xmat[ids, root].reshape(-1, 3, 3)
        return np.einsum("ni,nij->nj", points - self.xpos[ids, root], rotation)

    def hand(self, ids: np.ndarray) -> np.ndarray:
        """(len(ids), 3) the hands' centres of mass in their root's frame [m], as simulated."""
        return self._in_root(ids, self.ev.xipos[ids, self.arm.hand])

    def _elbow_in_torso(self, ids: np.ndarray) -> np.ndarray:
        arm = self.arm
        rotation = self.xmat[ids, arm.torso].reshape(-1, 3, 3)
        local = np.einsum("ni,nij->nj", self.xpos[ids, arm.elbow] - self.xpos[ids, arm.torso], rotation)
        return np.all((local > arm.torso_box[0]) & (local < arm.torso_box[1]), axis=1)

    def _counted(self, alive):  # the right arm's place is eq. 4.6's
        return self.rest_counted

    def _failed(self, alive):
        return self.thorax_rule[alive] & self._elbow_in_torso(alive)

    def _went_on(self, ok):
        error = np.linalg.norm(self.hand(ok) - self.control.goals(ok), axis=1) / self.control.arm_length
        self.reaching[ok] += error
        self.torque[ok] += ((self.force[ok] / self.force_limit) ** 2).sum(axis=1)
        if self.other_arm.any():  # the one-handed task's cost to the other arm, while the hand reaches
            reaching = self.control.cycle.state[ok] == REACHING
            q = self.ev.joint_angles(ok)[:, self.ev.driven]
            off = np.abs(q - self.target)[:, self.other_arm].mean(axis=1)
            self.other_sum[ok] += np.where(reaching, off, 0.0)
            self.reaching_ticks[ok] += reaching

    def result(self, upright: np.ndarray, unstable: np.ndarray, steps: int) -> Episodes:
        e = super().result(upright, unstable, steps)
        ticks = np.maximum(self.ticks, 1)  # means over the ticks survived
        terms = dict(e.terms, reaching=self.reaching / ticks, torque=self.torque / ticks,
                     reaches=self.control.cycle.reached.astype(float),
                     other_arm=np.degrees(self.other_sum / np.maximum(self.reaching_ticks, 1)))
        fitness = e.fitness * (1.0 + self.weights.reaching / (1.0 + terms["reaching"])) \
            * (1.0 + self.weights.torque / (1.0 + terms["torque"])) + self.bonus * terms["reaches"]
        fitness = np.where(unstable, 0.0, fitness)
        return dataclasses.replace(e, fitness=fitness, selection=fitness.copy(), terms=terms)


def pose_target(ev, target_pose_deg: Mapping[str, float]) -> np.ndarray:
    """Target angles of the driven joints of evaluator ``ev`` [rad]: ``target_pose_deg``
    (joint -> [deg]) where given, else the joint's home angle."""
    targets = {j.name: j.home_rad for j in ev.robot.joints}
    targets.update({k: math.radians(v) for k, v in target_pose_deg.items()})
    return np.array([targets[name] for name in ev.layout.driven])


@dataclass(frozen=True)
class ObjectiveType:
    """An entry of :data:`OBJECTIVES`: what a stage with this objective evolves on."""

    terms: tuple[str, ...]  # its fitness terms, in the order they combine (stats.csv columns)
    weights: PoseWeights | None  # eq. 4.1's default weights; None: eq. 3, weighted by the task's coefficients
    harness: bool  # the support harness holds the robot (its generations count from the stage's start)
    # (evaluator, n, weights, target_pose_deg) -> the objective watching n simulations
    make: Callable[[Any, int, "PoseWeights | None", Mapping[str, float]], Objective]


def _posing(standing: bool) -> Callable[[Any, int, "PoseWeights | None", Mapping[str, float]], Objective]:
    def make(ev, n: int, weights: PoseWeights | None, target_pose_deg: Mapping[str, float]) -> Objective:
        return PoseObjective(ev, n, weights, PoseLimits(standing=standing), pose_target(ev, target_pose_deg))
    return make


def _reaching(ev, n: int, weights: PoseWeights | None, target_pose_deg: Mapping[str, float]) -> Objective:
    return ReachObjective(ev, n, weights, PoseLimits(standing=True), pose_target(ev, target_pose_deg))


# every objective a stage can name; weights default to table 4.1 (pose 3, 1; stand 1, 1, 1, 1;
# reach 1, 1, 1, 1, 2, 1)
OBJECTIVES: dict[str, ObjectiveType] = {
    "pose": ObjectiveType(PoseObjective.TERMS, PoseWeights(3.0, 1.0, 0.0, 0.0), False, _posing(False)),
    "stand": ObjectiveType(PoseObjective.TERMS, PoseWeights(1.0, 1.0, 1.0, 1.0), False, _posing(True)),
    "reach": ObjectiveType(ReachObjective.TERMS, PoseWeights(1.0, 1.0, 1.0, 1.0, 2.0, 1.0), False, _reaching),
    "walk": ObjectiveType(WalkObjective.TERMS, None, True, lambda ev, n, weights, target: WalkObjective(ev, n)),
}
DEFAULT_OBJECTIVE = "walk"  # what a run without stages evolves on (the evaluator's default)
