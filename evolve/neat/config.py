"""NEAT parameters as a typed, immutable configuration.

Defaults follow the seeds: population 512 clustered into 30 species, compatibility
``delta = G / N^k + c W`` with k = 1 (seed 000 section 5.3), weight steps of variance 0.1
with occasional replacement (seed 000 section 5.1), and the thesis' table A.3 (seed 002)
for the rest (add-node 0.03, add-link 0.05, survival 0.2, mutate-only 0.25, mate-only 0.2,
interspecies 0.005, dropoff age 32 ...).  ``NeatConfig.from_mapping`` reads a YAML
mapping and refuses unknown keys, naming them.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

from sim2real.controller.schema import MAX_STEEPNESS, MAX_WEIGHT
from sim2real.errors import ConfigError
from sim2real.robot.validation import dataclass_from_mapping

INITIAL_TOPOLOGIES = ("full", "none")


@dataclass(frozen=True)
class NeatConfig:
    # population and speciation
    population_size: int = 512
    target_species: int = 30  # the compatibility threshold adapts to hold this many
    compat_threshold: float = 3.0  # starting threshold (table A.3)
    compat_threshold_adjust: float = 0.1  # relative change a generation while off target
    compat_threshold_min: float = 0.1
    compat_exponent: float = 1.0  # k in G / N^k (seed 000 uses 1; classic NEAT 0)
    compat_gene_coeff: float = 1.0  # weight of G, the unmatched genes
    compat_weight_coeff: float = 0.4  # c, on the mean weight difference of matching genes
    # network
    sigmoid_steepness: float = 1.0  # sigma(x) = 1 / (1 + exp(-steepness x)); seed 000: 1
    initial_connection: str = "full"  # inputs and biases to every output, or "none"
    initial_weight_range: float = 1.0  # initial weights uniform in (-r, r)
    weight_limit: float = 20.0  # weights are clipped to +-this
    # weight mutation (seed 000 section 5.1)
    weight_mutate_prob: float = 0.9  # chance a child's weights are mutated at all
    weight_sigma: float = math.sqrt(0.1)  # Gaussian step, variance 0.1
    weight_replace_prob: float = 0.1  # chance a gene's weight is replaced instead
    weight_replace_prob_new: float = 0.3  # ... for the newest genes of the genome
    new_gene_fraction: float = 0.2  # the newest share of genes counts as "new"
    weight_replace_range: float = 0.1  # replacements uniform in (-r, r)
    new_link_weight_range: float = 1.0  # a new connection's weight, uniform in (-r, r)
    # structural mutation
    add_node_prob: float = 0.03
    add_link_prob: float = 0.05
    allow_recurrent: bool = True  # connections may close cycles and self-loops
    side_bias: bool = True  # links may leave the side bias node (+1 right, -1 left); False: none do in this run
    new_link_tries: int = 20
    toggle_enable_prob: float = 0.001
    reenable_prob: float = 0.0001
    # reproduction
    survival_threshold: float = 0.2  # the best share of each species may be a parent
    mutate_only_prob: float = 0.25  # share of offspring from mutation alone
    mate_only_prob: float = 0.2  # share of crossover offspring left unmutated
    mate_average_prob: float = 0.4  # matching genes averaged rather than picked
    interspecies_mate_rate: float = 0.005
    disable_inherit_prob: float = 0.75  # disabled in either parent -> disabled in child
    elitism_min_size: int = 6  # champions of species with more than five members survive
    young_species_age: int = 10  # generations a new species gets the bonus
    young_species_bonus: float = 1.2  # +20 % fitness
    stagnation_generations: int = 32  # no improvement for this long -> no offspring

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any] | None, source: str = "<config>",
                     prefix: str = "") -> "NeatConfig":
        """Build from a YAML mapping; unknown keys and wrong types are refused."""
        config = dataclass_from_mapping(cls, values, source, prefix, "NEAT")
        config.validate(source, prefix)
        return config

    def validate(self, source: str = "<config>", prefix: str = "") -> None:
        def bad(key: str, problem: str) -> ConfigError:
            return ConfigError(source, prefix + key, problem)

        if self.population_size < 2:
            raise bad("population_size", "must be at least 2")
        if not 1 <= self.target_species <= self.population_size:
            raise bad("target_species", "must be between 1 and population_size")
        if self.initial_connection not in INITIAL_TOPOLOGIES:
            raise bad("initial_connection", f"must be one of {', '.join(INITIAL_TOPOLOGIES)}")
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name.endswith(("_prob", "_rate", "_fraction", "survival_threshold")) and not 0 <= value <= 1:
                raise bad(f.name, f"must be within [0, 1], got {value}")
            if isinstance(value, float) and not math.isfinite(value):
                raise bad(f.name, f"must be finite, got {value}")
            if isinstance(value, (int, float)) and not isinstance(value, bool) and value < 0:
                raise bad(f.name, f"must not be negative, got {value}")
        if self.sigmoid_steepness <= 0:
            raise bad("sigmoid_steepness", "must be > 0")
        # what a controller file may hold (sim2real.controller.schema), so that every champion saves
        if self.sigmoid_steepness > MAX_STEEPNESS:
            raise bad("sigmoid_steepness", f"must be <= {MAX_STEEPNESS:g} (the controller format's bound)")
        for name in ("weight_limit", "initial_weight_range", "new_link_weight_range", "weight_replace_range"):
            if getattr(self, name) > MAX_WEIGHT:
                raise bad(name, f"must be <= {MAX_WEIGHT:g} (the controller format's weight bound)")

    def replace(self, **changes: Any) -> "NeatConfig":
        config = dataclasses.replace(self, **changes)
        config.validate()
        return config

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)
