"""Developmental hierarchies (seed 002): an evolution in stages, each a new control module
with its own objective, evolved on top of the frozen modules of the stages before it.

    stages:
      - {name: pose, objective: pose, generations: 100, threshold: 0.95}
      - {name: stand, objective: stand, generations: 200, threshold: 0.94}
      - {name: walk, objective: walk, generations: 400}

A stage ends at its threshold (a share of eq. 4.1's theoretical maximum; walking has no
maximum, so a walk stage runs its budget) or after ``generations``.  The next stage starts
from the champion of this one: every genome a copy of it with a new, empty module
(:meth:`Population.on_top_of`), lower modules frozen but active.  Objectives are those of
:data:`evolve.locomotion.objectives.OBJECTIVES`; their weights default to table 4.1: pose
(3, 1), stand (1, 1, 1, 1); the single-module baseline of standing uses (2, 1, 1, 1)
(``configs/evolve/stand_baseline.yaml``).
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass, field
from typing import Any

from evolve.locomotion.objectives import OBJECTIVES, Objective, ObjectiveType, PoseWeights, reach_bonus
from sim2real.controller.reach import ReachCycle
from sim2real.errors import ConfigError
from sim2real.robot.spec import ARM_LOCATIONS
from sim2real.robot.timing import control_timing
from sim2real.robot.validation import Node, dataclass_from_mapping, show, show_key


@dataclass(frozen=True)
class Stage:
    name: str  # the module this stage evolves
    objective: str  # a name in OBJECTIVES: pose | stand | walk
    generations: int  # budget
    threshold: float = 0.0  # share of the theoretical maximum that ends the stage (0: run the budget)
    weights: PoseWeights | None = None  # eq. 4.1 error weights (pose and stand)
    target_pose_deg: dict[str, float] = field(default_factory=dict)  # joint -> target; others: home
    bonus_max: float = 0.0  # the objective's largest bonus (reaching's: a bonus for every goal), from the task

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"name": self.name, "objective": self.objective, "generations": self.generations}
        if self.threshold:
            out["threshold"] = self.threshold
        if self.weights is not None:  # the terms its objective scores
            out["weights"] = {k: v for k, v in dataclasses.asdict(self.weights).items() if k in self.kind.terms}
        if self.target_pose_deg:
            out["target_pose_deg"] = dict(self.target_pose_deg)
        return out

    @property
    def kind(self) -> ObjectiveType:
        return OBJECTIVES[self.objective]

    @property
    def max_fitness(self) -> float:
        return math.inf if self.weights is None else self.weights.max_fitness() + self.bonus_max

    def solved(self, fitness: float) -> bool:
        return bool(self.threshold) and fitness >= self.threshold * self.max_fitness

    def make_objective(self, ev, n: int) -> Objective:
        """This stage's objective for ``n`` simulations of evaluator ``ev``
        (the ``objective`` argument of :meth:`LocomotionEvaluator.evaluate`)."""
        return self.kind.make(ev, n, self.weights, self.target_pose_deg)


def parse_stages(doc: Any, source: str) -> tuple[Stage, ...]:
    if doc is None:
        return ()
    stages, names = [], set()
    for i, item in enumerate(Node(doc, source, "stages").list(min_len=1)):
        item.mapping(required=("name", "objective", "generations"),
                     optional=("threshold", "weights", "target_pose_deg"))
        name = item["name"].string()
        if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_-]*", name):
            raise item["name"].error(f"must be letters, digits, _ or - (it names a module and a folder), got {show(name)}")
        if name in names:
            raise item["name"].error(f"stage name {show(name)} is used twice")
        names.add(name)
        objective = item["objective"].string(tuple(OBJECTIVES))
        generations = item["generations"].integer(lo=1)
        threshold = item["threshold"].number(lo=0.0, hi=1.0) if item.has("threshold") else 0.0
        weights = OBJECTIVES[objective].weights
        if weights is not None:
            if item.has("weights"):  # over the objective's own defaults (table 4.1), its terms only
                given = dataclass_from_mapping(PoseWeights, item["weights"].value, source,
                                               f"stages[{i}].weights.", "weight")
                scored = set(OBJECTIVES[objective].terms)
                for key in item["weights"].value:
                    if key not in scored and getattr(given, key) != 0:  # 0 leaves a term out
                        raise item["weights"].error(f"a {objective} stage does not score {key} (its terms: "
                                                    f"{', '.join(t for t in OBJECTIVES[objective].terms if hasattr(given, t))})",
                                                    key=key)
                    if getattr(given, key) < 0:
                        raise item["weights"].error(f"must not be negative, got {getattr(given, key)}", key=key)
                weights = dataclasses.replace(weights, **{k: getattr(given, k) for k in item["weights"].value})
        elif item.has("weights") or threshold:
            raise item.error(f"a {objective} stage has no weights or threshold (eq. 3 has no maximum; "
                             "its weights are the task's coefficients)")
        target = {}
        if item.has("target_pose_deg"):
            target = {k: v.number() for k, v in item["target_pose_deg"].items()}
        stages.append(Stage(name, objective, generations, threshold, weights, target))
    return tuple(stages)


def with_task(stages: tuple[Stage, ...], task, robot, source: str) -> tuple[Stage, ...]:
    """The stages with what they take from the task and robot: a reach stage needs the reach
    input (the state machine's state reaches the networks through it) and a right hand, and
    its theoretical maximum adds the largest bonus (:func:`reach_bonus`; seed 002's 100 T / i):
    a goal every ``reach_phase_s`` of the episode, in whole control ticks."""
    out = []
    for i, stage in enumerate(stages):
        if stage.objective == "reach":
            if not task.reach_input:
                raise ConfigError(source, f"stages[{i}].objective", "a reach stage needs task.reach_input: true "
                                  "(the networks read the reach state through it)")
            hands = robot.model.hands if robot.model is not None else {}
            if "right" not in hands:
                raise ConfigError(source, f"stages[{i}].objective", f"robot {robot.name} has no right hand "
                                  "(model.hands.right in its config): nothing to reach with")
            arm = [j.name for j in robot.joints if j.side == "right" and j.location in ARM_LOCATIONS]
            if not set(arm) & set(robot.control_sets[task.control_set]):
                raise ConfigError(source, "task.control_set", f"{task.control_set!r} drives none of the right "
                                  f"arm's joints ({', '.join(arm) or 'none'}): a reach stage cannot reach")
            tick_s = control_timing(robot).tick_s
            goals = ReachCycle.max_goals(int(round(task.episode_s / tick_s)), tick_s, task.reach_phase_s)
            stage = dataclasses.replace(stage, bonus_max=reach_bonus(stage.weights, goals) * goals)
        out.append(stage)
    return tuple(out)


def check_stage_joints(stages: tuple[Stage, ...], driven: tuple[str, ...], source: str) -> None:
    for i, stage in enumerate(stages):
        for joint in stage.target_pose_deg:
            if joint not in driven:
                raise ConfigError(source, f"stages[{i}].target_pose_deg.{show_key(joint)}",
                                  f"not a driven joint (driven: {', '.join(driven)})")
