"""Scoring a population: episodes per genome, randomization, and where they run.

A generation's genomes become simulations (``episodes`` each); each simulation is keyed
``(seed, stage, generation, genome, episode)``, and its randomization is drawn from that
key alone, so a result never depends on how the simulations are split across threads,
processes or machines.  :class:`LocalBackend` runs them in its own evaluator's
``mujoco.batch``; :class:`evolve.ray_backend.RayBackend` splits them over Ray workers.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.objectives import Episodes
from evolve.locomotion.heading_commands import turn_schedule
from evolve.locomotion.pushes import Pushes, push_schedule
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome
from evolve.stages import Stage
from sim2real.simulation.model.physique import load_measured
from sim2real.simulation.reality.file import load_reality

# The generation field of a validation draw's key: no training generation ever has it, so the
# validation robots are never among the ones selection saw.
VALIDATION_GENERATION = 2**32 - 1


@dataclass(frozen=True)
class EvaluatorSpec:
    """What a worker needs to build its evaluator: names and plain data, never a model."""

    robot: str
    task: dict[str, Any]
    reality: str | dict
    capacity: int  # simulations
    threads: int = 0


def build_evaluator(spec: EvaluatorSpec) -> LocomotionEvaluator:
    """A new evaluator of ``spec``: the model is compiled and its batch allocated here, so
    its owner builds it once and keeps it."""
    return LocomotionEvaluator(load_measured(spec.robot), TaskConfig.from_mapping(spec.task), spec.capacity,
                               spec.threads, load_reality(spec.reality))


@dataclass(frozen=True)
class Job:
    """One generation's simulations: a genome and a key per simulation."""

    genomes: list[Genome]
    keys: np.ndarray  # (n, 5) int: seed, stage, generation, genome, episode
    steepness: float
    harness: float
    stage: Stage | None  # None: the walk objective
    intensity: float  # randomization strength: 0 nominal, 1 the evaluator's reality in full
    pushes: Pushes | None = None  # training's pushes (selection only), their speeds times intensity
    selection: bool = False  # selection's episodes: the task's heading commands too (heading_commands.py)

    def rows(self, lo: int, hi: int) -> "Job":
        return Job(self.genomes[lo:hi], self.keys[lo:hi], self.steepness, self.harness, self.stage, self.intensity,
                   self.pushes, self.selection)


def run_job(evaluator: LocomotionEvaluator, job: Job) -> Episodes:
    """Simulate every simulation of ``job`` on ``evaluator`` (the reference for every backend)."""
    perturbation = evaluator.sample(job.keys, job.intensity) if job.intensity > 0 else None
    pushes = None
    if job.pushes is not None and job.intensity > 0:
        pushes = push_schedule(job.pushes, job.keys, evaluator.n_ticks, evaluator.tick_s, job.intensity)
    task = evaluator.task
    turns = None
    if job.selection and task.heading_turn_share > 0:
        turns = turn_schedule(job.keys, evaluator.n_ticks, evaluator.tick_s, task.heading_turn_share,
                              task.heading_turn_max_deg)
    objective = job.stage.make_objective if job.stage is not None else None
    return evaluator.evaluate(job.genomes, job.steepness, job.harness, perturbation=perturbation,
                              objective=objective, pushes=pushes, turns=turns)


class Backend(Protocol):
    def run(self, job: Job) -> Episodes: ...


class LocalBackend:
    """Runs every job in this process, on an evaluator it owns."""

    def __init__(self, spec: EvaluatorSpec):
        self.evaluator = build_evaluator(spec)

    def run(self, job: Job) -> Episodes:
        return run_job(self.evaluator, job)


PER_SIMULATION = ("fitness", "selection", "distance_m", "upright_s", "fell", "unstable")  # Episodes' arrays


def concatenate(parts: list[Episodes]) -> Episodes:
    arrays = {name: np.concatenate([getattr(p, name) for p in parts]) for name in PER_SIMULATION}
    terms = {name: np.concatenate([p.terms[name] for p in parts]) for name in parts[0].terms}
    return Episodes(**arrays, steps=sum(p.steps for p in parts), terms=terms)


def repeated(e: Episodes, times: int) -> Episodes:
    """Each simulation's outcome ``times`` times in a row (its physics steps once)."""
    arrays = {name: np.repeat(getattr(e, name), times) for name in PER_SIMULATION}
    return Episodes(**arrays, steps=e.steps, terms={name: np.repeat(v, times) for name, v in e.terms.items()})


def score_population(backend: Backend, genomes: list[Genome], *, steepness: float, harness: float,
                     stage: Stage | None, episodes: int, score: str, intensity: float,
                     key: tuple[int, int, int], shared: bool = False, pushes: Pushes | None = None) -> Episodes:
    """Every genome on ``episodes`` episodes; the outcome per genome.

    Per genome, fitness and the other measures are the ``score`` (mean or worst) of its
    episodes; it fell if it fell in any.  Its fitness terms are their mean over its episodes
    (score mean) or its worst episode's (score worst: the one of lowest fitness).
    ``intensity`` scales the randomization (0: none; then every episode of a genome would be
    the same simulation, so one is run and counted ``episodes`` times - the same numbers).
    ``shared``: every genome's episode e is drawn from one key, so all meet the same robots.
    ``pushes``: training's pushes, drawn per episode with its robot (none while ``intensity`` is 0).
    """
    n = len(genomes)
    runs = episodes if intensity > 0 else 1
    sims = [g for g in genomes for _ in range(runs)]
    keys = np.array([[*key, 0 if shared else i, e] for i in range(n) for e in range(runs)], dtype=np.int64)
    per_sim = backend.run(Job(sims, keys, steepness, harness, stage, intensity, pushes, selection=True))
    if episodes == 1:
        return per_sim
    if runs == 1:
        per_sim = repeated(per_sim, episodes)
    combine = np.mean if score == "mean" else np.min

    worst = np.argmin(per_sim.fitness.reshape(n, episodes), axis=1)

    def by_genome(values):
        return combine(values.reshape(n, episodes), axis=1)

    def terms_by_genome(values):
        grid = values.reshape(n, episodes)
        return grid.mean(axis=1) if score == "mean" else grid[np.arange(n), worst]

    return Episodes(
        fitness=by_genome(per_sim.fitness), selection=by_genome(per_sim.selection),
        distance_m=by_genome(per_sim.distance_m), upright_s=by_genome(per_sim.upright_s),
        fell=per_sim.fell.reshape(n, episodes).any(axis=1),
        unstable=per_sim.unstable.reshape(n, episodes).any(axis=1), steps=per_sim.steps,
        terms={name: terms_by_genome(values) for name, values in per_sim.terms.items()})


def validation_episodes(backend: Backend, genomes: list[Genome], *, steepness: float, stage: Stage | None,
                        draws: int, seed: int, stage_index: int, capacity: int, on_model: bool = False) -> Episodes:
    """Every genome on the same ``draws`` robots, drawn at full strength from keys that no
    training episode uses; per simulation, genome-major (genome i's draws at ``i * draws``).
    ``on_model``: instead, one episode each on the model (intensity 0: the robot the ranges are
    around), under keys of its own."""
    if on_model:
        draws = 1
    sims = [g for g in genomes for _ in range(draws)]
    keys = np.array([[seed, stage_index, VALIDATION_GENERATION, int(on_model), d] for _ in genomes
                     for d in range(draws)], dtype=np.int64)
    intensity = 0.0 if on_model else 1.0
    return concatenate([backend.run(Job(sims[lo:lo + capacity], keys[lo:lo + capacity], steepness, 0.0, stage,
                                        intensity))
                        for lo in range(0, len(sims), capacity)])
