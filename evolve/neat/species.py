"""Speciation: genomes grouped by compatibility distance, the threshold adapted to a target count.

Genomes are assigned in population order to the first species (in id order) whose
representative - its best member of the previous generation - is within the threshold, so
the assignment is deterministic.  After each assignment the threshold moves by a relative
step toward the target species count (seed 000: 30 species for 512 genomes).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from evolve.neat.config import NeatConfig
from evolve.neat.genome import Genome, Layout, distance


@dataclass
class Species:
    key: int
    created: int  # generation it appeared
    representative: Genome
    members: list[Genome] = field(default_factory=list)
    best_fitness: float = float("-inf")  # best raw fitness it ever had
    last_improved: int = 0  # generation of that best

    def age(self, generation: int) -> int:
        return generation - self.created

    def to_dict(self) -> dict[str, Any]:
        return {
            "key": self.key, "created": self.created, "representative": self.representative.to_dict(),
            "members": [g.key for g in self.members],
            "best_fitness": self.best_fitness if self.best_fitness != float("-inf") else None,
            "last_improved": self.last_improved,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any], layout: Layout, genomes: dict[int, Genome]) -> "Species":
        best = data["best_fitness"]
        return cls(key=int(data["key"]), created=int(data["created"]),
                   representative=Genome.from_dict(data["representative"], layout),
                   members=[genomes[int(k)] for k in data["members"]],
                   best_fitness=float("-inf") if best is None else float(best),
                   last_improved=int(data["last_improved"]))


class SpeciesSet:
    def __init__(self, config: NeatConfig):
        self.config = config
        self.species: dict[int, Species] = {}
        self.threshold = config.compat_threshold
        self.next_key = 0

    def distance(self, a: Genome, b: Genome) -> float:
        c = self.config
        return distance(a, b, c.compat_gene_coeff, c.compat_weight_coeff, c.compat_exponent)

    def speciate(self, population: list[Genome], generation: int) -> None:
        """Assign every genome to a species; species left empty die."""
        for s in self.species.values():
            s.members = []
        ordered = [self.species[k] for k in sorted(self.species)]
        for genome in population:
            for s in ordered:
                if self.distance(genome, s.representative) < self.threshold:
                    s.members.append(genome)
                    break
            else:
                s = Species(self.next_key, generation, representative=genome, members=[genome],
                            last_improved=generation)
                self.next_key += 1
                self.species[s.key] = s
                ordered.append(s)
        self.species = {k: s for k, s in self.species.items() if s.members}
        self._adapt_threshold()

    def _adapt_threshold(self) -> None:
        c = self.config
        # relative steps: the distance's scale depends on k and on the genomes' size
        if len(self.species) > c.target_species:
            self.threshold *= 1.0 + c.compat_threshold_adjust
        elif len(self.species) < c.target_species:
            self.threshold = max(c.compat_threshold_min, self.threshold / (1.0 + c.compat_threshold_adjust))

    def update_after_evaluation(self, generation: int) -> None:
        """Record each species' best fitness and make its champion the next representative."""
        for s in self.species.values():
            champion = max(s.members, key=lambda g: (g.fitness, -g.key))
            if champion.fitness > s.best_fitness:
                s.best_fitness = champion.fitness
                s.last_improved = generation
            s.representative = champion

    def to_dict(self) -> dict[str, Any]:
        return {"threshold": self.threshold, "next_key": self.next_key,
                "species": [s.to_dict() for s in self.species.values()]}

    @classmethod
    def from_dict(cls, data: dict[str, Any], config: NeatConfig, layout: Layout,
                  genomes: dict[int, Genome]) -> "SpeciesSet":
        ss = cls(config)
        ss.threshold = float(data["threshold"])
        ss.next_key = int(data["next_key"])
        ss.species = {s.key: s for s in (Species.from_dict(d, layout, genomes) for d in data["species"])}
        return ss
