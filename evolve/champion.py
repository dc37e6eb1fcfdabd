"""Choosing a run's champion: the genome a run keeps, exports and builds the next stage on.

Every generation offers its top scorer by training fitness (a :class:`Best`).  With validation
draws (``randomize.validation``), the generations it names also put their top ``candidates``
(by selection score) on robots that selection never saw (:func:`validate`), and the one that
walks on most of them, then by mean fitness there, is offered too.  :meth:`Best.better_than`
ranks the offers against the champion so far:

1. a validated champion beats any that was not (a lucky draw is not a walker);
2. between validated ones, the larger share of walks, then the higher mean fitness;
3. otherwise one measured without the support harness beats any measured with it, and
   then the higher fitness wins.

:func:`judged` names the champion a stage's threshold is measured on.  The run folder keeps
the champion in ``best.json`` (:meth:`Best.to_dict`, :meth:`Best.from_dict`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from evolve.config import ValidationConfig
from evolve.evaluation import Backend, validation_episodes
from evolve.neat import Genome, Layout, Population
from evolve.stages import Stage


@dataclass
class Best:
    """A champion and what it was measured at: fitness, distance [m] and time upright [s]
    (means over its validation draws if it was validated)."""

    fitness: float
    distance_m: float
    upright_s: float
    generation: int
    harness: float  # strength of the harness it was measured with
    genome: Genome
    # its outcome on the run's validation draws: draws, walked (how many), fitness and
    # distance_m (means), model_distance_m with consistency; None if it was never validated
    validation: dict | None = None

    def better_than(self, other: "Best | None") -> bool:
        if other is None:
            return True
        if (self.validation is None) != (other.validation is None):
            return self.validation is not None  # a validated champion beats any that was not
        if self.validation is not None:
            mine, theirs = self.validation, other.validation  # shares: a resumed run may validate on more robots
            return (mine["walked"] / mine["draws"], mine["fitness"]) > (theirs["walked"] / theirs["draws"],
                                                                        theirs["fitness"])
        if (self.harness > 0) != (other.harness > 0):
            return self.harness == 0  # a champion without the harness beats any with it
        return self.fitness > other.fitness

    def to_dict(self) -> dict[str, Any]:
        """``best.json``'s content: the scores, the genome, and the validation if there was one."""
        return {"fitness": self.fitness, "distance_m": self.distance_m, "upright_s": self.upright_s,
                "generation": self.generation, "harness": self.harness, "genome": self.genome.to_dict(),
                **({"validation": self.validation} if self.validation else {})}

    @classmethod
    def from_dict(cls, data: dict[str, Any], layout: Layout) -> "Best":
        """The champion :meth:`to_dict` wrote, its genome read for ``layout`` (the population's)."""
        return cls(data["fitness"], data["distance_m"], data["upright_s"], data["generation"], data["harness"],
                   Genome.from_dict(data["genome"], layout), data.get("validation"))


def validate(population: Population, selection: np.ndarray, settings: ValidationConfig, *, backend: Backend,
             capacity: int | None, steepness: float, stage: Stage | None, seed: int, stage_index: int,
             generation: int, harness: float, leg_length: float, episode_s: float) -> Best:
    """The best of this generation's top candidates on the validation draws.

    ``selection``: the population's selection scores, shape ``(population,)``, whose top
    ``settings.candidates`` are validated; ``backend`` runs at most ``capacity`` simulations a
    job (None: all of them in one, on a backend of validation's own sized for them);
    ``generation``: the run's generation count (across stages) that the champion gets;
    ``leg_length`` [m] and ``episode_s`` [s] (the validation episodes') decide what walked.
    """
    v, pop = settings, population
    top = np.argsort(-selection, kind="stable")[:v.candidates]
    genomes = [pop.genomes[i] for i in top]
    if capacity is None:
        capacity = len(top) * v.draws
    episodes = functools.partial(validation_episodes, backend, genomes, steepness=steepness, stage=stage,
                                 draws=v.draws, seed=seed, stage_index=stage_index, capacity=capacity)
    e = episodes()
    walked = e.walked(leg_length, episode_s).reshape(len(top), v.draws)
    if v.heading_deg and "turn" in e.terms:  # a walker that turns away is no walker
        walked &= e.terms["turn"].reshape(len(top), v.draws) <= v.heading_deg
    if v.consistency:
        model = episodes(on_model=True)
        kept = e.distance_m.reshape(len(top), v.draws) >= v.consistency * model.distance_m[:, None]
        walked &= kept & model.walked(leg_length, episode_s)[:, None]
    fitness = e.fitness.reshape(len(top), v.draws).mean(axis=1)
    j = int(np.lexsort((fitness, walked.sum(axis=1)))[-1])  # most walks, then mean fitness
    rows = slice(j * v.draws, (j + 1) * v.draws)
    i = int(top[j])
    outcome = {"draws": v.draws, "walked": int(walked[j].sum()), "fitness": float(fitness[j]),
               "distance_m": float(e.distance_m[rows].mean())}
    if v.consistency:
        outcome["model_distance_m"] = float(model.distance_m[j])
    return Best(float(e.fitness[rows].mean()), float(e.distance_m[rows].mean()), float(e.upright_s[rows].mean()),
                generation, harness, pop.genomes[i].copy(pop.genomes[i].key), validation=outcome)


def judged(candidate: Best, best: Best | None, settings: ValidationConfig) -> Best | None:
    """The champion a stage's threshold is measured on: with validation draws the validated
    champion so far (the module that is filed and built on), not one generation's lucky
    ``candidate``; None while there is none."""
    if settings.active:
        return best if best is not None and best.validation is not None else None
    return candidate
