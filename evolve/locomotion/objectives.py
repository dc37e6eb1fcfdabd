"""What an episode is scored on: walking (seed 000 eq. 3) or posing and standing (seed 002
eq. 4.1).  The evaluator runs the simulations; an objective watches them after every tick,
says which are done, and scores them at the end.

Distances are in leg lengths, so that one setting serves every robot.  Seed 002's
thresholds for a 1.8 m human (20 cm, 50 cm) become shares of its 0.9 m leg.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


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


class Objective(Protocol):
    """Watches ``n`` simulations of an evaluator from their reset on."""

    fell: np.ndarray  # (n,) bool: ended by a failure rule (instability aside)

    def tick(self, alive: np.ndarray, elapsed: np.ndarray, bad: np.ndarray) -> np.ndarray:
        """After a tick: update the scores of simulations ``alive`` (``bad``: numerically
        unstable) and return which of them are done."""

    def result(self, upright: np.ndarray, unstable: np.ndarray, steps: int) -> Episodes: ...


class WalkObjective:
    """Seed 000 eq. 3, ``f = c_d max(proj_j d, eps) + c_t t``, with its early termination:
    the pelvis below ``fall_height`` of its start height or the torso tilted past
    ``fall_tilt_deg`` (the previous tick's fitness is kept), instability (fitness eps),
    no progress of eps within ``stagnation_s``."""

    def __init__(self, ev, n: int):
        task = ev.task
        self.ev, self.task = ev, task
        self.start_x = ev.site_xpos[:n, ev.soles, 0].mean(axis=1)
        self.start_pelvis = ev.xipos[:n, ev.pelvis].copy()
        self.fitness = np.full(n, task.epsilon * task.distance_coeff)
        self.progress_best = np.zeros(n)  # hindmost foot [leg lengths], for stagnation
        self.pelvis_best = np.zeros(n)
        self.last_gain = np.zeros(n)
        self.distance = np.zeros(n)
        self.fell = np.zeros(n, dtype=bool)
        self.min_up_z = np.cos(np.radians(task.fall_tilt_deg))

    def tick(self, alive: np.ndarray, elapsed: np.ndarray, bad: np.ndarray) -> np.ndarray:
        ev, task = self.ev, self.task
        hind = ev.site_xpos[alive[:, None], ev.soles, 0].min(axis=1) - self.start_x[alive]
        progress = hind / ev.leg
        pelvis_z = ev.xipos[alive, ev.pelvis, 2]
        up_z = ev.sensordata[alive, ev.up_adr + 2]
        down = (pelvis_z < task.fall_height * self.start_pelvis[alive, 2]) | (up_z < self.min_up_z)
        ok = ~down & ~bad
        live = alive[ok]
        # eq. 3 at this tick; a fall keeps the previous tick's value
        self.fitness[live] = (task.distance_coeff * np.maximum(progress[ok], task.epsilon)
                              + task.time_coeff * elapsed[live])
        self.distance[live] = hind[ok]
        self.pelvis_best[live] = np.maximum(
            self.pelvis_best[live], (ev.xipos[live, ev.pelvis, 0] - self.start_pelvis[live, 0]) / ev.leg)
        gained = progress > self.progress_best[alive] + task.epsilon
        self.progress_best[alive[gained]] = progress[gained]
        self.last_gain[alive[gained]] = elapsed[alive[gained]]
        self.fell[alive[down & ~bad]] = True
        self.fitness[alive[bad]] = task.epsilon * task.distance_coeff
        stagnant = elapsed[alive] - self.last_gain[alive] > task.stagnation_s
        return down | bad | stagnant

    def result(self, upright: np.ndarray, unstable: np.ndarray, steps: int) -> Episodes:
        selection = self.fitness + self.task.progress_coeff * np.where(unstable, 0.0, self.pelvis_best)
        return Episodes(self.fitness, selection, self.distance, upright, self.fell, unstable, steps)


@dataclass(frozen=True)
class PoseWeights:
    """Error weights of seed 002 eq. 4.1 (table 4.1); 0 leaves a term out."""

    rest_pose: float = 3.0  # E_restPose: squared joint errors summed over every tick [rad^2]
    rest_pose_end: float = 1.0  # E_restPoseEnd: squared joint errors at the end [rad^2]
    com: float = 0.0  # E_COM: squared distance of the CoM to its target at the end [leg lengths^2]
    feet: float = 0.0  # E_feet: squared altitudes of both feet at the end [leg lengths^2]

    def max_fitness(self) -> float:
        """Eq. 4.1's theoretical maximum: no failure, every error 0."""
        return 100.0 * float(np.prod([1.0 + w for w in (self.rest_pose, self.rest_pose_end, self.com, self.feet)]))


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
    (driven joints, default their home angles); the CoM target is its start position."""

    def __init__(self, ev, n: int, weights: PoseWeights, limits: PoseLimits, target_rad: np.ndarray):
        self.ev, self.weights, self.limits = ev, weights, limits
        self.target = target_rad
        self.com_target = ev.subtree_com[:n, ev.pelvis].copy()
        self.sole_z0 = ev.site_xpos[:n, ev.soles, 2].copy()
        self.pose_error = np.zeros(n)
        self.ticks = np.zeros(n)
        self.fell = np.zeros(n, dtype=bool)  # failed a rule (instability aside)
        self.end_pose = np.zeros(n)
        self.end_com = np.zeros(n)
        self.end_feet = np.zeros(n)

    def tick(self, alive: np.ndarray, elapsed: np.ndarray, bad: np.ndarray) -> np.ndarray:
        ev, limits = self.ev, self.limits
        q = ev.qpos[alive[:, None], ev.qadr[ev.driven]]
        squared = ((q - self.target) ** 2).sum(axis=1)
        self.pose_error[alive] += squared
        fail = bad | ~(self.pose_error[alive] <= limits.rest_pose)
        com = ev.subtree_com[alive, ev.pelvis]
        com_err = ((com - self.com_target[alive]) ** 2).sum(axis=1) / ev.leg ** 2
        height = (ev.site_xpos[alive[:, None], ev.soles, 2] - self.sole_z0[alive]) / ev.leg
        feet_err = (height ** 2).sum(axis=1)
        if limits.standing:
            soles = ev.site_xpos[alive[:, None], ev.soles, :2]
            apart = np.linalg.norm(soles[:, 0] - soles[:, 1], axis=1) / ev.leg
            fail |= ((com[:, 2] - self.com_target[alive, 2]) / ev.leg < -limits.com_drop) \
                | (height.max(axis=1) > limits.foot_height) | (apart > limits.feet_apart)
        ok = alive[~fail]
        self.ticks[ok] += 1
        # the end state is the last one before a failure
        self.end_pose[ok], self.end_com[ok], self.end_feet[ok] = squared[~fail], com_err[~fail], feet_err[~fail]
        self.fell[alive[fail & ~bad]] = True
        return fail

    def result(self, upright: np.ndarray, unstable: np.ndarray, steps: int) -> Episodes:
        w = self.weights
        fitness = 100.0 * self.ticks / self.ev.n_ticks
        for weight, error in ((w.rest_pose, self.pose_error), (w.rest_pose_end, self.end_pose),
                              (w.com, self.end_com), (w.feet, self.end_feet)):
            fitness = fitness * (1.0 + weight / (1.0 + error))
        fitness = np.where(unstable, 0.0, fitness)
        distance = np.zeros(len(fitness))
        return Episodes(fitness, fitness.copy(), distance, upright, self.fell, unstable, steps)
