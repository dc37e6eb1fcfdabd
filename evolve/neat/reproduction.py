"""Reproduction: offspring shares by explicit fitness sharing, then breeding within species.

Each species' share of the next generation is proportional to the sum of its members'
shared fitness (fitness / species size), i.e. its mean fitness, times +20 % while the
species is young.  Species that have not improved for ``stagnation_generations`` get no
offspring, unless they hold the best genome.  Within a species the best
``survival_threshold`` may be parents; the champion of a species with more than five
members is copied unchanged; a share of children come from mutation alone, the rest from
crossover (rarely with another species' champion), most of them mutated afterwards.
"""

from __future__ import annotations

import math

import numpy as np

from evolve.neat.config import NeatConfig
from evolve.neat.genome import Genome, InnovationTracker
from evolve.neat.species import Species, SpeciesSet
from evolve.neat.variation import crossover, mutate


def _rank(genome: Genome) -> tuple[float, int]:
    return (-genome.fitness, genome.key)


def offspring_counts(species: list[Species], config: NeatConfig, generation: int) -> dict[int, int]:
    """How many children each species gets; the counts add up to the population size."""
    best = min((g for s in species for g in s.members), key=_rank)
    eligible = [s for s in species
                if generation - s.last_improved < config.stagnation_generations or best in s.members]
    shares = {s.key: 0.0 for s in species}
    for s in eligible:
        bonus = config.young_species_bonus if s.age(generation) < config.young_species_age else 1.0
        shares[s.key] = bonus * sum(g.fitness for g in s.members) / len(s.members)
    if sum(shares.values()) <= 0:  # every fitness zero: the eligible species share equally
        shares.update({s.key: 1.0 for s in eligible})
    total = sum(shares.values())
    exact = {k: config.population_size * v / total for k, v in shares.items()}
    counts = {k: int(math.floor(v)) for k, v in exact.items()}
    left = config.population_size - sum(counts.values())
    # largest remainders first, ties to the older species: deterministic
    for k in sorted(exact, key=lambda k: (-(exact[k] - counts[k]), k))[:left]:
        counts[k] += 1
    return counts


def reproduce(species_set: SpeciesSet, config: NeatConfig, tracker: InnovationTracker,
              rng: np.random.Generator, generation: int, next_key: int,
              silent: frozenset[int] = frozenset()) -> tuple[list[Genome], int]:
    """The next population (unevaluated) and the next free genome key; no new link from the
    ``silent`` inputs."""
    species = [species_set.species[k] for k in sorted(species_set.species)]
    counts = offspring_counts(species, config, generation)
    champions = [min(s.members, key=_rank) for s in species]
    children: list[Genome] = []
    for s in species:
        n = counts[s.key]
        if n == 0:
            continue
        members = sorted(s.members, key=_rank)
        parents = members[: max(1, int(math.ceil(config.survival_threshold * len(members))))]
        made = 0
        if len(members) >= config.elitism_min_size:
            children.append(members[0].copy(next_key))
            next_key += 1
            made += 1
        while made < n:
            if rng.random() < config.mutate_only_prob or len(parents) == 1:
                parent = parents[int(rng.integers(len(parents)))]
                child = parent.copy(next_key)
                mutate(child, config, tracker, rng, silent)
            else:
                mom = parents[int(rng.integers(len(parents)))]
                if rng.random() < config.interspecies_mate_rate and len(champions) > 1:
                    dad = champions[int(rng.integers(len(champions)))]
                else:
                    dad = parents[int(rng.integers(len(parents)))]
                fitter, other = (mom, dad) if _rank(mom) <= _rank(dad) else (dad, mom)
                child = crossover(next_key, fitter, other, config, rng)
                if rng.random() >= config.mate_only_prob or mom is dad:
                    mutate(child, config, tracker, rng, silent)
            children.append(child)
            next_key += 1
            made += 1
    return children, next_key
