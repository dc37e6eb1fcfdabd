"""An evolution run: a population evolved generation by generation, stage by stage.

``Run.create(config, out).evolve()`` evolves a new run in the folder ``out``;
``Run.resume(out).evolve()`` continues one from its latest checkpoint, and reruns the
generations after it exactly: every simulation's randomness comes from its key
``(seed, stage, generation, genome, episode)`` (:mod:`evolve.evaluation`), whatever the backend
(``local``, or ``ray`` over a cluster) or the point it resumed from.

Each generation the population is scored, its top scorer offered as champion (and, on the
generations that validate, the best of its top candidates on the validation draws:
:mod:`evolve.champion`), a row written to stats.csv and a progress line logged.  A run without
stages evolves ``generations`` generations; a staged run (a hierarchy, :mod:`evolve.stages`)
evolves each stage until its budget or its threshold, files its champion, and starts the next
stage's population on top of it.  ``evolve(stop=...)`` asks ``stop(run, row)`` after every
generation whether to end early; an ``open_ended`` run is one such a stop ends (``biped
train``'s budget), shown without a generation total or ETA.  The folder's files are
:mod:`evolve.run_folder`'s; the folder is locked (:mod:`sim2real.run_lock`) from ``create``
or ``resume`` until ``evolve`` returns or :meth:`Run.close`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import time
from pathlib import Path
from typing import Callable

import numpy as np

from evolve.champion import Best, judged, validate
from evolve.config import EvolveConfig
from evolve.evaluation import Backend, EvaluatorSpec, LocalBackend, build_evaluator, score_population
from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.export import controller_from_genome
from evolve.locomotion.objectives import DEFAULT_OBJECTIVE, OBJECTIVES, ObjectiveType
from evolve.neat import Population
from evolve.run_folder import RunFolder, holds_run, read_config, read_population, write_config
from evolve.run_stats import VALIDATION_COLUMNS, stats_columns, term_columns
from evolve.stages import Stage, check_stage_joints
from sim2real.controller.channels import REACH
from sim2real.controller.file import Controller
from sim2real.controller.symmetry import SIDE_BIAS
from sim2real.errors import UsageError
from sim2real.run_lock import RunLock
from sim2real.simulation.model.physique import load_measured


class Run:
    """One evolution: ``Run(config, out).evolve()``; ``Run.resume(out)`` continues it."""

    def __init__(self, config: EvolveConfig, out: Path, *, population: Population | None = None,
                 log: Callable[[str], None] = print, backend: str = "local", address: str | None = None):
        self.config, self.out, self.log = config, Path(out), log
        self.robot = load_measured(config.robot)
        r = config.randomize
        spec = EvaluatorSpec(config.robot, config.task.to_dict(), r.profile,
                             config.neat.population_size * r.episodes, config.threads)
        self.backend, self.evaluator = _open_backend(spec, backend, address)
        self.randomized = not self.evaluator.reality.is_nominal
        self.capacity = spec.capacity
        # validation episodes longer than training's (validation.episode_s): their own evaluator
        self.validation_backend, self.validation_episode_s = self.backend, self.evaluator.episode_s
        v = config.randomize.validation
        if v.active and v.episode_s and v.episode_s != config.task.episode_s:
            longer = dataclasses.replace(spec, task=dataclasses.replace(config.task, episode_s=v.episode_s).to_dict(),
                                         capacity=max(1, v.candidates) * v.draws)
            self.validation_backend, evaluator = _open_backend(longer, backend, address)
            self.validation_episode_s = evaluator.episode_s
        check_stage_joints(config.stages, self.evaluator.layout.driven, str(self.out / "config.yaml"))
        self.folder = RunFolder(self.out, stats_columns(config))
        self.finished: list[dict] = self.folder.read_stages()
        first_module = (config.stages[0].name,) if config.stages else ("main",)
        self.population = population or Population(config.neat, self.evaluator.neat_layout, seed=config.seed,
                                                   modules=first_module, silent_inputs=self._silent_inputs(0))
        self.best: Best | None = None  # the run's champion (of the stage running)
        self.champion: Best | None = None  # the last generation's top scorer
        self.wall_s = 0.0  # [s] of evolution, across resumes
        self.lock: RunLock | None = None  # the folder's, while this run works in it
        self.open_ended = False  # True: the caller's stop ends the run (no generation total or ETA shown)
        self.lock_borrowed = False  # the lock is its caller's, who releases it

    def _silent_inputs(self, stage_index: int) -> frozenset[int]:
        """The inputs stage ``stage_index``'s networks may not link from: the reach inputs below
        a reach stage, which its networks read as 0 (a weight that never mattered there would,
        frozen, disturb it once a later stage makes those inputs speak), and the side bias
        node with ``neat.side_bias: false`` (the two networks then differ only by what they sense)."""
        layout = self.evaluator.layout
        stages = self.config.stages
        silent = set() if self.config.neat.side_bias else {self.evaluator.neat_layout.bias_ids[SIDE_BIAS]}
        if layout.reach and stages and stages[stage_index].objective != "reach":
            silent.update(layout.input_names.index(name) for name in REACH.names([]))
        return frozenset(silent)

    @property
    def stage(self) -> Stage | None:
        """The stage running (None in a run without stages)."""
        stages = self.config.stages
        return stages[min(len(self.finished), len(stages) - 1)] if stages else None

    @property
    def objective(self) -> ObjectiveType:
        """The objective of the stage running."""
        return self.stage.kind if self.stage else OBJECTIVES[DEFAULT_OBJECTIVE]

    @property
    def generation_offset(self) -> int:
        """Generations of the stages before the one running (or the last one)."""
        before = self.finished[:len(self.config.stages) - 1]
        return sum(s["generations"] for s in before)

    @property
    def checkpoint_generation(self) -> int | None:
        """The population's generation in the folder's latest checkpoint (None before this
        run wrote one): where a resume continues from."""
        return self.folder.checkpoint_generation

    # -- starting, resuming, closing -----------------------------------------------------------
    @classmethod
    def create(cls, config: EvolveConfig, out: Path, log: Callable[[str], None] = print,
               lock: RunLock | None = None, **backend) -> "Run":
        """A new run in ``out`` (created), locked for this process (:class:`RunFolderBusy`
        if another works there); ``lock``: the caller's, already held on ``out`` (``adapt``
        holds it over its whole command), which the run uses and leaves to its holder."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        def create() -> "Run":
            if holds_run(out):
                raise FileExistsError(f"{out} already holds a run; use --resume to continue it or another --out")
            write_config(out, config)
            run = cls(config, out, log=log, **backend)
            run.folder.stats.start()
            return run

        return cls._locked(out, create, lock)

    @classmethod
    def resume(cls, out: Path, generations: int | None = None, threads: int | None = None,
               log: Callable[[str], None] = print, robot: str | None = None, **backend) -> "Run":
        """The run in ``out``, from its checkpoint, locked for this process.  ``robot``: the
        robot file the run evolves for, given again on the command line (its config.yaml may
        name a project robot only: a path read from a file is never opened on its own)."""
        out = Path(out)
        if not holds_run(out):
            raise FileNotFoundError(f"{out} has no checkpoint.json.gz to resume")
        return cls._locked(out, lambda: cls._resume(out, generations, threads, log, robot, **backend))

    @staticmethod
    def _locked(out: Path, build: Callable[[], "Run"], held: RunLock | None = None) -> "Run":
        """``build()``'s run, holding the folder's lock (released again if building fails),
        or the caller's ``held`` one (left to the caller)."""
        lock = held or RunLock.acquire(out)
        try:
            run = build()
        except BaseException:
            if held is None:
                lock.release()
            raise
        run.lock, run.lock_borrowed = lock, held is not None
        return run

    @classmethod
    def _resume(cls, out: Path, generations: int | None, threads: int | None, log: Callable[[str], None],
                robot: str | None = None, **backend) -> "Run":
        config = read_config(out, robot)
        population = read_population(out)
        if generations is not None and config.stages:
            raise UsageError(f"--generations: {out} is a staged run; each stage has its own budget "
                             "(stages[].generations in its config.yaml)")
        if generations is not None and generations <= population.generation:
            raise UsageError(f"--generations {generations}: {out} is already at generation {population.generation}")
        changes = {k: v for k, v in (("generations", generations), ("threads", threads)) if v is not None}
        if changes:
            config = config.replace(**changes)
            write_config(out, config)
        run = cls(config, out, population=population, log=log, **backend)
        run.best = run.folder.read_best(population.layout)
        # the generations after the checkpoint are evolved again: their rows go
        run.wall_s = run.folder.stats.keep_below(run.generation_offset + population.generation)
        return run

    def close(self) -> None:
        """Unlock the folder (idempotent); :meth:`evolve` does it when it returns."""
        if self.lock is not None:
            if not self.lock_borrowed:
                self.lock.release()
            self.lock = None

    # -- the loop ------------------------------------------------------------------------------
    def evolve(self, stop: Callable[["Run", dict], bool] | None = None) -> Best | None:
        """Run every stage to its end (or the configured generation count), or until
        ``stop(run, stats_row)`` says so; the folder stays locked until it returns (locked
        again here if this run was closed, or made without :meth:`create`/:meth:`resume`)."""
        if self.lock is None:
            self.lock, self.lock_borrowed = RunLock.acquire(self.out), False
        try:
            stages = self.config.stages
            while not stages or len(self.finished) < len(stages):
                if self._evolve_stage(stop) or not stages:
                    break
                self._file_stage()
                if len(self.finished) < len(stages):
                    self._next_stage()
            self.folder.checkpoint(self.population, self.config.checkpoint_every, force=True)
            self.folder.plot()
            return self.best
        finally:
            self.close()

    def _evolve_stage(self, stop: Callable[["Run", dict], bool] | None) -> bool:
        """The stage running, to its budget or threshold (False), or until ``stop`` (True)."""
        pop, config, stage = self.population, self.config, self.stage
        budget = stage.generations if stage else config.generations
        index = len(self.finished)
        harnessed = self.objective.harness
        recent: list[float] = []
        while pop.generation < budget:
            self.folder.checkpoint(pop, config.checkpoint_every)
            harness = config.task.harness_strength(pop.generation) if harnessed else 0.0
            intensity = config.randomize.intensity(pop.generation) if self.randomized else 0.0
            t0 = time.perf_counter()
            episodes = {}

            def evaluate(genomes):
                episodes["e"] = score_population(
                    self.backend, genomes, steepness=config.neat.sigmoid_steepness, harness=harness, stage=stage,
                    episodes=config.randomize.episodes, score=config.randomize.score, intensity=intensity,
                    key=(config.seed, index, pop.generation), shared=config.randomize.shared,
                    pushes=config.randomize.push)
                return episodes["e"].selection

            stats = pop.evaluate(evaluate)
            e = episodes["e"]
            eval_s = time.perf_counter() - t0
            i = int(np.argmax(e.fitness))
            candidate = Best(float(e.fitness[i]), float(e.distance_m[i]), float(e.upright_s[i]),
                             self.generation_offset + pop.generation, harness, pop.genomes[i].copy(pop.genomes[i].key))
            self.champion = candidate  # this generation's
            validated = None
            if harness == 0 and config.randomize.validation.due(pop.generation, budget - 1):
                validated = self._validate(e.selection, index, harness)
            for better in (candidate, validated):
                if better is not None and better.better_than(self.best):
                    self.best = better
                    self.folder.save_best(better, self.controller())
            pop.reproduce()
            gen_s = time.perf_counter() - t0
            self.wall_s += gen_s
            recent = (recent + [gen_s])[-10:]
            terms = {**dict.fromkeys(term_columns(config), ""),
                     **{name: float(values[i]) for name, values in e.terms.items()}}
            row = dict(generation=self.generation_offset + stats.generation, stage=stage.name if stage else "",
                       best_fitness=float(e.fitness.max()),
                       mean_fitness=float(e.fitness.mean()), best_distance_m=float(e.distance_m.max()),
                       best_upright_s=float(e.upright_s.max()), species=stats.species,
                       mean_connections=stats.mean_connections, mean_hidden=stats.mean_hidden,
                       evaluations=stats.evaluations, evaluations_per_s=len(e.fitness) * config.randomize.episodes / eval_s,
                       steps_per_s=e.steps / eval_s, wall_s=self.wall_s, harness=harness,
                       threshold=stats.threshold, **terms, **self._validation_row(validated))
            self.folder.stats.append(row)
            # a run that its caller stops (biped train's budget) has no generation count to reach
            eta = math.nan if self.open_ended else (budget - pop.generation) * float(np.mean(recent))
            self.log(_progress_line(row, pop.generation, None if self.open_ended else budget, eta, stage, intensity))
            if pop.generation % 10 == 0 or pop.generation >= budget:
                self.folder.plot()
            judge = judged(candidate, self.best, config.randomize.validation)
            if stage is not None and judge is not None and stage.solved(judge.fitness):
                self.log(f"stage {stage.name}: threshold reached ({judge.fitness:.1f} >= "
                         f"{stage.threshold:.0%} of {stage.max_fitness:.0f}) at its generation {stats.generation + 1}")
                return False
            if stop is not None and stop(self, row):
                return True
        return False

    def _validate(self, selection: np.ndarray, stage_index: int, harness: float) -> Best:
        """The best of this generation's top candidates on the validation draws
        (:func:`evolve.champion.validate`)."""
        own = self.validation_backend is not self.backend  # sized for one validation: all in one job
        return validate(self.population, selection, self.config.randomize.validation,
                        backend=self.validation_backend, capacity=None if own else self.capacity,
                        steepness=self.config.neat.sigmoid_steepness, stage=self.stage, seed=self.config.seed,
                        stage_index=stage_index, generation=self.generation_offset + self.population.generation,
                        harness=harness, leg_length=self.robot.leg_length, episode_s=self.validation_episode_s)

    def _validation_row(self, validated: Best | None) -> dict:
        """stats.csv's validation columns: the champion validated this generation, if any."""
        if not self.config.randomize.validation.active:
            return {}
        if validated is None:
            return dict.fromkeys(VALIDATION_COLUMNS, "")
        return {"validation_walked": validated.validation["walked"], "validation_fitness": validated.fitness}

    # -- stages --------------------------------------------------------------------------------
    def _file_stage(self) -> None:
        """Keep the finished stage's best in stages/<name>/ and note it in stages.json."""
        stage, best = self.stage, self.best
        entry = {"name": stage.name, "objective": stage.objective,
                 "generations": self.population.generation, "solved": stage.solved(best.fitness),
                 "best_fitness": best.fitness, "max_fitness": stage.max_fitness, "wall_s": self.wall_s}
        self.folder.file_stage(stage.name, [*self.finished, entry])
        self.finished.append(entry)

    def _next_stage(self) -> None:
        """Start the next stage on top of the champion of the one just filed."""
        best, nxt = self.best, self.stage
        self.log(f"stage {nxt.name} ({nxt.objective}) starts on top of {', '.join(best.genome.modules)}")
        below, silent = self._silent_inputs(len(self.finished) - 1), self._silent_inputs(len(self.finished))
        self.population = Population.on_top_of(self.config.neat, best.genome, nxt.name, silent_inputs=silent,
                                               connect=below - silent,  # inputs that speak from this stage on
                                               seed=self.config.seed + 1_000_003 * len(self.finished))
        self.best = None
        self.folder.drop_best()

    # -- export --------------------------------------------------------------------------------
    def controller(self, best: Best | None = None) -> Controller:
        """The controller of ``best`` (default: the run's best so far)."""
        b = best or self.best
        config_yaml = self.config.to_yaml()
        provenance = {"seed": self.config.seed, "generation": b.generation, "fitness": b.fitness,
                      "distance_m": b.distance_m, "upright_s": b.upright_s, "harness": b.harness,
                      "config_hash": hashlib.sha256(config_yaml.encode()).hexdigest()[:16],
                      "code_version": code_version(), "run": str(self.out.resolve()),
                      "config": self.config.to_dict(),
                      **({"validation": b.validation} if b.validation else {})}
        return controller_from_genome(b.genome, self.robot, self.evaluator.layout, self.config.task,
                                      self.config.neat.sigmoid_steepness, provenance)


def _open_backend(spec: EvaluatorSpec, backend: str, address: str | None) -> tuple[Backend, LocomotionEvaluator]:
    """The backend that runs ``spec``'s simulations (``local``, or ``ray`` at ``address``) and
    an evaluator for the layout, timing and model: the local backend's own, or for Ray one of
    its own (one simulation, one thread)."""
    if backend == "ray":
        from evolve.ray_backend import RayBackend

        ray = RayBackend(spec, address)
        return ray, build_evaluator(dataclasses.replace(spec, capacity=1, threads=1))
    if backend == "local":
        local = LocalBackend(spec)
        return local, local.evaluator
    raise ValueError(f"unknown backend {backend!r} (local or ray)")


def code_version() -> str:
    """The installed package's version ("unknown" when run from a checkout)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("servo-biped-evolve")
    except PackageNotFoundError:
        return "unknown"


def _progress_line(row: dict, done: int, generations: int | None, eta_s: float, stage: Stage | None = None,
                   intensity: float = 0.0) -> str:
    """The line logged after a generation: ``done`` of ``generations`` (None: open-ended),
    its best and mean, and the time left ``eta_s`` [s] (NaN: not shown)."""
    eta = f" | ETA {time.strftime('%H:%M:%S', time.gmtime(eta_s))}" if math.isfinite(eta_s) else ""
    total = f"/{generations}" if generations is not None else ""
    harness = f"harness {row['harness']:.2f} | " if row["harness"] else ""
    if 0.0 < intensity < 1.0:  # narrower ranges: a ramp under way, or one stopped at randomize.strength
        harness += f"randomize x{intensity:.2f} | "
    where = f"{stage.name} " if stage else ""
    return (f"{where}gen {done:>4}{total} | best {row['best_fitness']:.3f} "
            f"({row['best_distance_m']:+.3f} m) | mean {row['mean_fitness']:.3f} | species {row['species']:>3} "
            f"| conns {row['mean_connections']:.1f} | {row['evaluations_per_s']:.0f} eval/s "
            f"| {row['steps_per_s'] / 1e3:.0f}k steps/s | {harness}{eta}").rstrip(" |")
