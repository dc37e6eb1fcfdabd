"""Gait measures of many episodes at once, fed from an evaluator tick by tick: the one
reading of hip angles and foot contacts that ``biped eval`` and selection's gait term share;
and the smoothness of the goals, selection's smooth term."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from sim2real.gait_measures import GaitMeter, hip_pitch_joints, is_a_walk
from sim2real.robot.spec import RobotSpec

if TYPE_CHECKING:  # pragma: no cover - the evaluator imports the objectives, which use this
    from evolve.locomotion.evaluator import LocomotionEvaluator


class GaitTracker:
    """Every episode's gait measures (:mod:`sim2real.gait_measures`), fed once a tick with the
    episodes still running, at the times :func:`evolve.replay.gait` records (tick index x tick):
    ``biped eval``'s ``on_tick`` hook, and selection's gait term (:class:`WalkObjective`)."""

    def __init__(self, robot: RobotSpec, n: int, tick_s: float):
        self.hips = [robot.joint_names.index(name) for name in hip_pitch_joints(robot)]
        self.meter = GaitMeter(n, tick_s)
        self.tick = 0

    def __call__(self, evaluator: "LocomotionEvaluator", alive: np.ndarray) -> None:
        hips = evaluator.joint_angles(alive)[:, self.hips]
        feet = evaluator.parts.feet_touching(evaluator.sensordata[alive])
        self.meter.add(alive, self.tick * evaluator.tick_s, hips, feet)
        self.tick += 1

    def report(self) -> dict[str, Any]:
        """How many episodes walk a walk, and each one's measures (JSON-ready)."""
        measures = self.meter.measures()
        return {"walks": sum(map(is_a_walk, measures)), "per_episode": [m.to_dict() for m in measures]}


class GoalSmoothness:
    """Selection's smooth term (:class:`~evolve.locomotion.objectives.WalkObjective`), summed
    tick by tick: ``exp(-(r / sigma)^2)`` of the RMS r over the driven joints of the goals'
    second difference [rad], for the episodes still up.  ``start``: (n, driven) the goals
    before the first tick [rad]; ``sigma_deg``: the kernel's width [deg]."""

    def __init__(self, start: np.ndarray, sigma_deg: float):
        self.before, self.last = start.copy(), start.copy()  # the last two ticks' goals
        self.sigma = np.radians(sigma_deg)
        self.total = np.zeros(len(start))  # each episode's sum of kernels

    def __call__(self, alive: np.ndarray, up: np.ndarray, goals: np.ndarray) -> None:
        """This tick's goals (k, driven) of episodes ``alive`` (k,), of which ``up`` are paid."""
        rms = np.sqrt(np.mean((goals - 2.0 * self.last[alive] + self.before[alive]) ** 2, axis=1))
        self.total[alive[up]] += np.exp(-(rms / self.sigma) ** 2)[up]
        self.before[alive], self.last[alive] = self.last[alive], goals
