"""The NEAT loop: evaluate, speciate, reproduce - resumable from any generation.

    pop = Population(NeatConfig(population_size=150), Layout(2, 1, 1), seed=3)
    while pop.best is None or pop.best.fitness < 15.9:
        pop.step(evaluate)            # evaluate(genomes) -> fitness per genome, each >= 0

All randomness comes from one ``numpy.random.Generator`` seeded once; its state is part
of the checkpoint, so a run resumed from any checkpoint continues exactly as the
uninterrupted run would.  A checkpoint is taken between generations: the unevaluated
population with its species, the innovation counters, the best genome so far.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from evolve.neat.config import NeatConfig
from evolve.neat.genome import ConnectionGene, Genome, InnovationTracker, Layout
from evolve.neat.reproduction import reproduce
from evolve.neat.species import SpeciesSet
from evolve.neat.variation import initial_genome, mutate_weights
from sim2real.atomic_json import read_json, write_json_atomic
from sim2real.errors import ConfigError

CHECKPOINT_FORMAT = "biped-neat-checkpoint"
CHECKPOINT_VERSION = 1

Evaluator = Callable[[list[Genome]], Sequence[float]]


@dataclass(frozen=True)
class GenerationStats:
    generation: int
    best_fitness: float
    mean_fitness: float
    best_ever_fitness: float
    species: int
    threshold: float
    mean_connections: float  # enabled connections per genome
    mean_hidden: float
    evaluations: int  # cumulative

    def to_dict(self) -> dict:
        return asdict(self)


class Population:
    """A generation of genomes with its species, innovation counters and random state.

    ``Population(config, layout, seed)`` starts a run from minimal genomes;
    :meth:`on_top_of` starts a stage of a hierarchy, :meth:`from_dict` / :meth:`load` restore
    a checkpoint.  Each lays down the whole state at once (:meth:`_set_state`).
    """

    def __init__(self, config: NeatConfig, layout: Layout, seed: int, modules: tuple[str, ...] = ("main",),
                 silent_inputs: frozenset[int] = frozenset()):
        if seed is None:
            raise ValueError("seed: a Population needs a seed (a run must be reproducible)")
        rng = np.random.default_rng(seed)
        tracker = InnovationTracker(next_innovation=0, next_node=layout.n_interface)
        genomes = [initial_genome(k, layout, config, tracker, rng, modules, silent_inputs)
                   for k in range(config.population_size)]
        self._set_state(config, layout, seed, rng, tracker, genomes, silent_inputs=silent_inputs)

    @classmethod
    def from_genome(cls, config: NeatConfig, layout: Layout, seed: int, genome: Genome) -> "Population":
        """A population grown from one genome (a walker to adapt): the genome itself, and
        ``population_size - 1`` copies with their weights mutated once (structure comes later,
        by evolution); new innovations and nodes numbered after the genome's."""
        rng = np.random.default_rng(seed)
        tracker = InnovationTracker(next_innovation=max(genome.conns, default=-1) + 1,
                                    next_node=max(genome.node_ids()) + 1)
        genomes = [genome.copy(0)]
        for k in range(1, config.population_size):
            child = genome.copy(k)
            mutate_weights(child, config, rng)
            genomes.append(child)
        population = cls.__new__(cls)
        population._set_state(config, layout, seed, rng, tracker, genomes)
        return population

    def _set_state(self, config: NeatConfig, layout: Layout, seed: int, rng: np.random.Generator,
                   tracker: InnovationTracker, genomes: list[Genome], species: SpeciesSet | None = None,
                   generation: int = 0, next_key: int | None = None, evaluations: int = 0,
                   best: Genome | None = None, silent_inputs: frozenset[int] = frozenset()) -> None:
        """Every attribute of a population; ``species`` None: the genomes speciated afresh,
        ``next_key`` None: the key after the genomes' count; ``silent_inputs``: input ids no
        link may start from (inputs this stage's networks read as 0, so that a module evolved
        without them is not disturbed once a later stage makes them speak)."""
        self.config, self.layout, self.seed, self.rng, self.tracker = config, layout, seed, rng, tracker
        self.silent_inputs = frozenset(silent_inputs)
        self.genomes = genomes
        self.generation, self.evaluations, self.best = generation, evaluations, best
        self.next_key = len(genomes) if next_key is None else next_key
        if species is None:
            species = SpeciesSet(config)
            species.speciate(genomes, generation)
        self.species = species

    # -- the loop ---------------------------------------------------------------------------
    def evaluate(self, evaluate: Evaluator) -> GenerationStats:
        """Score the current population (sets ``fitness``) and record the best."""
        fitness = np.asarray(evaluate(self.genomes), dtype=float)
        if fitness.shape != (len(self.genomes),):
            raise ValueError(f"evaluate returned shape {fitness.shape}, expected ({len(self.genomes)},)")
        if not np.all(np.isfinite(fitness)) or np.any(fitness < 0):
            bad = int(np.flatnonzero(~np.isfinite(fitness) | (fitness < 0))[0])
            raise ValueError(f"fitness must be finite and >= 0; genome {self.genomes[bad].key} got {fitness[bad]}")
        for genome, f in zip(self.genomes, fitness):
            genome.fitness = float(f)
        self.evaluations += len(self.genomes)
        champion = min(self.genomes, key=lambda g: (-g.fitness, g.key))
        if self.best is None or champion.fitness > self.best.fitness:
            self.best = champion.copy(champion.key)
            self.best.fitness = champion.fitness
        self.species.update_after_evaluation(self.generation)
        return GenerationStats(
            generation=self.generation,
            best_fitness=champion.fitness,
            mean_fitness=float(fitness.mean()),
            best_ever_fitness=self.best.fitness,
            species=len(self.species.species),
            threshold=self.species.threshold,
            mean_connections=float(np.mean([g.n_enabled for g in self.genomes])),
            mean_hidden=float(np.mean([len(g.hidden) for g in self.genomes])),
            evaluations=self.evaluations,
        )

    def reproduce(self) -> None:
        """Breed the next generation from the evaluated one and speciate it."""
        self.tracker.new_generation()
        self.genomes, self.next_key = reproduce(self.species, self.config, self.tracker, self.rng,
                                                self.generation, self.next_key, self.silent_inputs)
        self.generation += 1
        self.species.speciate(self.genomes, self.generation)

    def step(self, evaluate: Evaluator) -> GenerationStats:
        """Evaluate this generation, then breed the next."""
        stats = self.evaluate(evaluate)
        self.reproduce()
        return stats

    def add_module(self, name: str) -> None:
        """Freeze every genome's current modules and make ``name`` the active one (seed 002)."""
        for genome in self.genomes:
            if name in genome.modules:
                raise ValueError(f"module {name!r} already exists")
            genome.modules = genome.modules + (name,)
        for s in self.species.species.values():
            s.representative.modules = s.representative.modules + (name,)

    @classmethod
    def on_top_of(cls, config: NeatConfig, ancestor: Genome, module: str, seed: int,
                  silent_inputs: frozenset[int] = frozenset(), connect: frozenset[int] = frozenset()) -> "Population":
        """A population that evolves a new ``module`` on top of a frozen ``ancestor`` (seed 002:
        each stage of a hierarchy starts from the previous stage's champion).  The module starts
        empty, or - with ``connect``, inputs this stage makes speak - with each of them linked
        to every output at weight 0: the links a single module evolved alone starts with (seed
        002: "the initial structures of the control modules are similar to the initial baseline
        modules"), there for weight mutation to grow, while the stage starts from exactly the
        behaviour below it (random weights on inputs that now read 1 would shake every joint)."""
        if module in ancestor.modules:
            raise ValueError(f"module {module!r} already exists in {list(ancestor.modules)}")
        tracker = InnovationTracker(
            next_innovation=max(ancestor.conns, default=-1) + 1,
            next_node=max([ancestor.layout.n_interface - 1, *ancestor.hidden]) + 1,
        )
        rng = np.random.default_rng(seed)
        genomes = []
        for key in range(config.population_size):
            genome = ancestor.copy(key)
            genome.modules = ancestor.modules + (module,)
            linked = {(g.src, g.dst) for g in ancestor.conns.values()}
            for src in sorted(connect):
                for dst in ancestor.layout.output_ids:
                    if (src, dst) in linked:
                        continue
                    genome.add_connection(ConnectionGene(tracker.link(src, dst), src, dst, 0.0, True,
                                                         genome.active_module))
            genomes.append(genome)
        pop = cls.__new__(cls)
        pop._set_state(config, ancestor.layout, seed, rng, tracker, genomes, silent_inputs=silent_inputs)
        return pop

    # -- checkpoints ------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {
            "format": CHECKPOINT_FORMAT,
            "version": CHECKPOINT_VERSION,
            "seed": self.seed,
            "config": self.config.to_dict(),
            "layout": [self.layout.n_inputs, self.layout.n_bias, self.layout.n_outputs],
            "generation": self.generation,
            "next_key": self.next_key,
            "evaluations": self.evaluations,
            "rng": self.rng.bit_generator.state,
            "tracker": self.tracker.to_dict(),
            "genomes": [g.to_dict() for g in self.genomes],
            "species": self.species.to_dict(),
            "best": None if self.best is None else self.best.to_dict(),
            **({"silent_inputs": sorted(self.silent_inputs)} if self.silent_inputs else {}),
        }

    def save(self, path: Path | str) -> None:
        """Write a checkpoint atomically (JSON, gzip if the name ends in .gz)."""
        write_json_atomic(path, self.to_dict())

    @classmethod
    def from_dict(cls, data: dict, source: str = "<checkpoint>") -> "Population":
        if not isinstance(data, dict) or data.get("format") != CHECKPOINT_FORMAT:
            raise ConfigError(source, "format", "not a NEAT checkpoint")
        if data.get("version") != CHECKPOINT_VERSION:
            raise ConfigError(source, "version", f"checkpoint version {data.get('version')} is not supported "
                              f"(this code reads version {CHECKPOINT_VERSION})")
        config = NeatConfig.from_mapping(data["config"], source, "config.")
        layout = Layout(*data["layout"])
        rng = np.random.default_rng()
        rng.bit_generator.state = data["rng"]
        genomes = [Genome.from_dict(g, layout) for g in data["genomes"]]
        species = SpeciesSet.from_dict(data["species"], config, layout, {g.key: g for g in genomes})
        best = None if data["best"] is None else Genome.from_dict(data["best"], layout)
        pop = cls.__new__(cls)
        pop._set_state(config, layout, data["seed"], rng, InnovationTracker.from_dict(data["tracker"]), genomes,
                       species, int(data["generation"]), int(data["next_key"]), int(data["evaluations"]), best,
                       frozenset(int(i) for i in data.get("silent_inputs", ())))
        return pop

    @classmethod
    def load(cls, path: Path | str) -> "Population":
        try:
            data = read_json(path)
        except (OSError, ValueError, EOFError) as exc:
            raise ConfigError(str(path), "", f"cannot read checkpoint: {exc}") from exc
        return cls.from_dict(data, str(path))
