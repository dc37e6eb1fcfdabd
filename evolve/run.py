"""An evolution run and its folder.

    run/
      config.yaml          the resolved configuration (every default written out)
      checkpoint.json.gz   the latest generation, resumable (atomic; at most CHECKPOINT_INTERVAL_S
                           old, and written at every numbered snapshot, stage start and stop)
      checkpoints/         numbered snapshots every ``checkpoint_every`` generations
      stats.csv            one row per generation, flushed as it goes (see STATS_COLUMNS)
      fitness.png          best / mean fitness and best distance over generations
      controller.json      the best controller so far (of the stage running)
      best.json            its genome and scores (what --resume needs to keep it)
      stages.json          a staged run's finished stages (evolve.stages)
      stages/<name>/       each finished stage's controller.json and best.json
      .lock                the id of the process working in the folder, there while it does

One process works in a folder at a time: :meth:`Run.create` and :meth:`Run.resume` lock it
(:mod:`sim2real.run_lock`; a second process is refused naming the first's id), :meth:`Run.evolve`
keeps it locked until it returns, and a process that dies frees it.  Every file but
``stats.csv`` is replaced whole (written beside, then renamed: a full disk leaves the previous
file); a row of ``stats.csv`` that the disk refuses is taken back out.

The best controller is the one with the highest fitness measured without the harness;
harness-era champions stand in only until a generation runs without it.  In a staged run,
``generation`` in stats.csv counts across stages and the population's own count restarts
with every stage.  After the fixed columns, stats.csv has one column per fitness term of the
run's objectives (:data:`evolve.locomotion.objectives.OBJECTIVES`), named for the term: the
generation champion's value, unweighted (the genome of ``best_fitness``; empty in the rows
of a stage whose objective has no such term).
"""

from __future__ import annotations

import csv
import dataclasses
import functools
import hashlib
import io
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from evolve.config import EvolveConfig, parse_evolve_config
from evolve.evaluation import (
    Backend,
    EvaluatorSpec,
    LocalBackend,
    build_evaluator,
    score_population,
    validation_episodes,
)
from evolve.locomotion.export import controller_from_genome
from evolve.locomotion.objectives import DEFAULT_OBJECTIVE, OBJECTIVES, ObjectiveType
from evolve.neat import Genome, Population
from sim2real.run_lock import RunLock
from evolve.stages import Stage, check_stage_joints
from sim2real.atomic_json import OutputError, copy_file_atomic, read_json, write_json_atomic, write_text_atomic
from sim2real.controller.channels import REACH
from sim2real.controller.file import Controller
from sim2real.errors import BipedError, UsageError
from sim2real.figures import pyplot, save_figure
from sim2real.input_files import check_regular_file
from sim2real.simulation.model.physique import load_measured
from sim2real.robot.validation import load_yaml

STATS_COLUMNS = ("generation", "stage", "best_fitness", "mean_fitness", "best_distance_m", "best_upright_s",
                 "species", "mean_connections", "mean_hidden", "evaluations", "evaluations_per_s",
                 "steps_per_s", "wall_s", "harness", "threshold")  # then the fitness terms (term_columns)
# with validation draws: the validated champion's walks and mean fitness there (empty between validations)
VALIDATION_COLUMNS = ("validation_walked", "validation_fitness")
# Writing the latest checkpoint costs about 0.35 s for 128 genomes of 600 links (JSON, gzip,
# fsync): 13 % of a 2.6 s generation when it was written every generation (measured on
# reach_baseline seed 1).  A kill loses at most this much evolution; a resume from an older
# checkpoint reruns the same generations exactly.
CHECKPOINT_INTERVAL_S = 15.0


@dataclass
class Best:
    fitness: float
    distance_m: float
    upright_s: float
    generation: int
    harness: float  # strength of the harness it was measured with
    genome: Genome
    # its outcome on the run's validation draws: draws, walked (how many), fitness and
    # distance_m (means); None if it was never validated
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


class Run:
    """One evolution: ``Run(config, out).evolve()``; ``Run.resume(out)`` continues it."""

    def __init__(self, config: EvolveConfig, out: Path, *, population: Population | None = None,
                 log: Callable[[str], None] = print, backend: str = "local", address: str | None = None):
        self.config, self.out, self.log = config, Path(out), log
        self.robot = load_measured(config.robot)
        r = config.randomize
        spec = EvaluatorSpec(config.robot, config.task.to_dict(), r.profile,
                             config.neat.population_size * r.episodes, config.threads)
        if backend == "ray":
            from evolve.ray_backend import RayBackend

            self.backend: Backend = RayBackend(spec, address)
            # here only for the layout, timing and model: one simulation, one thread
            self.evaluator = build_evaluator(dataclasses.replace(spec, capacity=1, threads=1))
        elif backend == "local":
            self.backend = LocalBackend(spec)
            self.evaluator = self.backend.evaluator
        else:
            raise ValueError(f"unknown backend {backend!r} (local or ray)")
        self.randomized = not self.evaluator.reality.is_nominal
        self.capacity = spec.capacity
        # validation episodes longer than training's (validation.episode_s): their own evaluator
        self.validation_backend, self.validation_episode_s = self.backend, self.evaluator.episode_s
        v = config.randomize.validation
        if v.active and v.episode_s and v.episode_s != config.task.episode_s:
            longer = dataclasses.replace(spec, task=dataclasses.replace(config.task, episode_s=v.episode_s).to_dict(),
                                         capacity=max(1, v.candidates) * v.draws)
            if backend == "ray":
                from evolve.ray_backend import RayBackend

                self.validation_backend = RayBackend(longer, address)
                self.validation_episode_s = build_evaluator(dataclasses.replace(longer, capacity=1,
                                                                                threads=1)).episode_s
            else:
                self.validation_backend = LocalBackend(longer)
                self.validation_episode_s = self.validation_backend.evaluator.episode_s
        check_stage_joints(config.stages, self.evaluator.layout.driven, str(self.out / "config.yaml"))
        self.finished: list[dict] = read_json(self.out / "stages.json") if (self.out / "stages.json").exists() else []
        first_module = (config.stages[0].name,) if config.stages else ("main",)
        self.population = population or Population(config.neat, self.evaluator.neat_layout, seed=config.seed,
                                                   modules=first_module, silent_inputs=self._silent_inputs(0))
        self.best: Best | None = None
        self.champion: Best | None = None
        self.wall_s = 0.0
        self.checkpoint_generation: int | None = None  # the population's generation on disk
        self._checkpoint_at = -math.inf  # [s, time.monotonic] when it was written
        self.lock: RunLock | None = None  # the folder's, while this run works in it
        self.open_ended = False  # True: the caller's stop ends the run (no generation total or ETA shown)
        self.lock_borrowed = False  # the lock is its caller's, who releases it

    def _silent_inputs(self, stage_index: int) -> frozenset[int]:
        """The inputs stage ``stage_index``'s networks read as 0 - the reach inputs below a
        reach stage - from which its module may not link: a weight that never mattered there
        would, frozen, disturb it once a later stage makes those inputs speak."""
        layout = self.evaluator.layout
        stages = self.config.stages
        if not layout.reach or (stages and stages[stage_index].objective == "reach") or not stages:
            return frozenset()
        return frozenset(layout.input_names.index(name) for name in REACH.names([]))

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
    def columns(self) -> tuple[str, ...]:
        """stats.csv's columns: :data:`STATS_COLUMNS`, then :func:`term_columns`, then the
        validation's (with validation draws)."""
        validation = VALIDATION_COLUMNS if self.config.randomize.validation.active else ()
        return STATS_COLUMNS + term_columns(self.config) + validation

    @property
    def generation_offset(self) -> int:
        """Generations of the stages before the one running (or the last one)."""
        before = self.finished[:len(self.config.stages) - 1]
        return sum(s["generations"] for s in before)

    # -- folder -------------------------------------------------------------------------------
    @classmethod
    def create(cls, config: EvolveConfig, out: Path, log: Callable[[str], None] = print,
               lock: RunLock | None = None, **backend) -> "Run":
        """A new run in ``out`` (created), locked for this process (:class:`RunFolderBusy`
        if another works there); ``lock``: the caller's, already held on ``out`` (``adapt``
        holds it over its whole command), which the run uses and leaves to its holder."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        def create() -> "Run":
            if (out / "checkpoint.json.gz").exists():
                raise FileExistsError(f"{out} already holds a run; use --resume to continue it or another --out")
            write_text_atomic(out / "config.yaml", config.to_yaml())
            run = cls(config, out, log=log, **backend)
            write_text_atomic(out / "stats.csv", _csv_text([run.columns]))
            return run

        return cls._locked(out, create, lock)

    @classmethod
    def resume(cls, out: Path, generations: int | None = None, threads: int | None = None,
               log: Callable[[str], None] = print, robot: str | None = None, **backend) -> "Run":
        """The run in ``out``, from its checkpoint, locked for this process.  ``robot``: the
        robot file the run evolves for, given again on the command line (its config.yaml may
        name a project robot only: a path read from a file is never opened on its own)."""
        out = Path(out)
        if not (out / "checkpoint.json.gz").exists():
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
        config = parse_evolve_config(load_yaml(check_regular_file(out / "config.yaml")), str(out / "config.yaml"),
                                     robot_file=robot)
        population = Population.load(out / "checkpoint.json.gz")
        if generations is not None and config.stages:
            raise UsageError(f"--generations: {out} is a staged run; each stage has its own budget "
                             "(stages[].generations in its config.yaml)")
        if generations is not None and generations <= population.generation:
            raise UsageError(f"--generations {generations}: {out} is already at generation {population.generation}")
        changes = {k: v for k, v in (("generations", generations), ("threads", threads)) if v is not None}
        if changes:
            config = config.replace(**changes)
            write_text_atomic(out / "config.yaml", config.to_yaml())
        run = cls(config, out, population=population, log=log, **backend)
        if (out / "best.json").exists():
            data = read_json(out / "best.json")
            run.best = Best(data["fitness"], data["distance_m"], data["upright_s"], data["generation"],
                            data["harness"], Genome.from_dict(data["genome"], population.layout),
                            data.get("validation"))
        rows = read_stats(out / "stats.csv")
        kept = [r for r in rows if int(r["generation"]) < run.generation_offset + population.generation]
        # a run from before the term columns gets them; written whole: a full disk keeps the old file
        write_text_atomic(out / "stats.csv", _csv_text([run.columns] + [[r.get(c) or "" for c in run.columns]
                                                                        for r in kept]))
        run.wall_s = float(kept[-1]["wall_s"]) if kept else 0.0
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
            self._checkpoint(force=True)
            self.plot()
            return self.best
        finally:
            self.close()

    def _evolve_stage(self, stop) -> bool:
        pop, config, stage = self.population, self.config, self.stage
        budget = stage.generations if stage else config.generations
        index = len(self.finished)
        harnessed = self.objective.harness
        recent: list[float] = []
        while pop.generation < budget:
            self._checkpoint()
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
                    self._save_best()
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
            self._append_stats(row)
            # a run that its caller stops (biped train's budget) has no generation count to reach
            eta = math.nan if self.open_ended else (budget - pop.generation) * float(np.mean(recent))
            self.log(_progress_line(row, pop.generation, None if self.open_ended else budget, eta, stage, intensity))
            if pop.generation % 10 == 0 or pop.generation >= budget:
                self.plot()
            # with validation draws the stage is solved by its champion there (the module that is
            # filed and built on), not by one generation's lucky score
            judged = candidate
            if config.randomize.validation.active:
                judged = self.best if self.best is not None and self.best.validation is not None else None
            if stage is not None and judged is not None and stage.solved(judged.fitness):
                self.log(f"stage {stage.name}: threshold reached ({judged.fitness:.1f} >= "
                         f"{stage.threshold:.0%} of {stage.max_fitness:.0f}) at its generation {stats.generation + 1}")
                return False
            if stop is not None and stop(self, row):
                return True
        return False

    def _validate(self, selection: np.ndarray, stage_index: int, harness: float) -> Best:
        """The best of this generation's top candidates on the validation draws."""
        v, pop = self.config.randomize.validation, self.population
        top = np.argsort(-selection, kind="stable")[:v.candidates]
        genomes = [pop.genomes[i] for i in top]
        backend = self.validation_backend
        capacity = self.capacity if backend is self.backend else len(top) * v.draws
        episodes = functools.partial(validation_episodes, backend, genomes,
                                     steepness=self.config.neat.sigmoid_steepness, stage=self.stage, draws=v.draws,
                                     seed=self.config.seed, stage_index=stage_index, capacity=capacity)
        e = episodes()
        leg, episode_s = self.robot.leg_length, self.validation_episode_s
        walked = e.walked(leg, episode_s).reshape(len(top), v.draws)
        if v.heading_deg and "turn" in e.terms:  # a walker that turns away is no walker
            walked &= e.terms["turn"].reshape(len(top), v.draws) <= v.heading_deg
        if v.consistency:
            model = episodes(on_model=True)
            kept = e.distance_m.reshape(len(top), v.draws) >= v.consistency * model.distance_m[:, None]
            walked &= kept & model.walked(leg, episode_s)[:, None]
        fitness = e.fitness.reshape(len(top), v.draws).mean(axis=1)
        j = int(np.lexsort((fitness, walked.sum(axis=1)))[-1])  # most walks, then mean fitness
        rows = slice(j * v.draws, (j + 1) * v.draws)
        i = int(top[j])
        outcome = {"draws": v.draws, "walked": int(walked[j].sum()), "fitness": float(fitness[j]),
                   "distance_m": float(e.distance_m[rows].mean())}
        if v.consistency:
            outcome["model_distance_m"] = float(model.distance_m[j])
        return Best(float(e.fitness[rows].mean()), float(e.distance_m[rows].mean()), float(e.upright_s[rows].mean()),
                    self.generation_offset + pop.generation, harness, pop.genomes[i].copy(pop.genomes[i].key),
                    validation=outcome)

    def _validation_row(self, validated: Best | None) -> dict:
        if not self.config.randomize.validation.active:
            return {}
        if validated is None:
            return dict.fromkeys(VALIDATION_COLUMNS, "")
        return {"validation_walked": validated.validation["walked"], "validation_fitness": validated.fitness}

    def _file_stage(self) -> None:
        """Keep the finished stage's best in stages/<name>/ and note it in stages.json."""
        stage, best = self.stage, self.best
        folder = self.out / "stages" / stage.name
        folder.mkdir(parents=True, exist_ok=True)
        copy_file_atomic(self.out / "best.json", folder / "best.json")
        copy_file_atomic(self.out / "controller.json", folder / "controller.json")
        self.finished.append({"name": stage.name, "objective": stage.objective,
                              "generations": self.population.generation, "solved": stage.solved(best.fitness),
                              "best_fitness": best.fitness, "max_fitness": stage.max_fitness, "wall_s": self.wall_s})
        write_json_atomic(self.out / "stages.json", self.finished)

    def _next_stage(self) -> None:
        """Start the next stage on top of the champion of the one just filed."""
        best, nxt = self.best, self.stage
        self.log(f"stage {nxt.name} ({nxt.objective}) starts on top of {', '.join(best.genome.modules)}")
        below, silent = self._silent_inputs(len(self.finished) - 1), self._silent_inputs(len(self.finished))
        self.population = Population.on_top_of(self.config.neat, best.genome, nxt.name, silent_inputs=silent,
                                               connect=below - silent,  # inputs that speak from this stage on
                                               seed=self.config.seed + 1_000_003 * len(self.finished))
        self.best = None
        (self.out / "best.json").unlink()

    def _checkpoint(self, force: bool = False) -> None:
        """The latest checkpoint, if ``force``d, at a stage's start or a numbered snapshot's
        generation, or CHECKPOINT_INTERVAL_S after the last; the numbered snapshot."""
        pop = self.population
        every = self.config.checkpoint_every
        snapshot = bool(every) and pop.generation % every == 0
        if force or snapshot or pop.generation == 0 or time.monotonic() - self._checkpoint_at >= CHECKPOINT_INTERVAL_S:
            pop.save(self.out / "checkpoint.json.gz")
            self.checkpoint_generation, self._checkpoint_at = pop.generation, time.monotonic()
        if snapshot:
            (self.out / "checkpoints").mkdir(exist_ok=True)
            copy_file_atomic(self.out / "checkpoint.json.gz",
                             self.out / "checkpoints" / f"gen_{pop.generation:05d}.json.gz")

    def _save_best(self) -> None:
        b = self.best
        write_json_atomic(self.out / "best.json", {
            "fitness": b.fitness, "distance_m": b.distance_m, "upright_s": b.upright_s,
            "generation": b.generation, "harness": b.harness, "genome": b.genome.to_dict(),
            **({"validation": b.validation} if b.validation else {})})
        self.controller().save(self.out / "controller.json")

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

    def _append_stats(self, row: dict) -> None:
        """One row, appended whole or not at all: a row the disk refuses half-way is cut
        back off, so that a resume never reads a truncated generation number."""
        path = self.out / "stats.csv"
        line = _csv_text([[_fmt(row[c]) for c in self.columns]]).encode()
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC, 0o666)
        try:
            size = os.fstat(fd).st_size
            try:
                view = memoryview(line)
                while view:
                    view = view[os.write(fd, view):]
            except OSError as exc:
                os.ftruncate(fd, size)  # frees what was written: succeeds on a full disk
                raise OutputError(path, exc, f"generation {row['generation']} was not recorded") from exc
        finally:
            os.close(fd)

    def plot(self) -> None:
        plot_stats(self.out / "stats.csv", self.out / "fitness.png")


def term_columns(config: EvolveConfig) -> tuple[str, ...]:
    """The fitness terms of every objective of the run, in stage order, each once."""
    kinds = [stage.kind for stage in config.stages] or [OBJECTIVES[DEFAULT_OBJECTIVE]]
    return tuple(dict.fromkeys(name for kind in kinds for name in kind.terms))


def code_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("servo-biped-evolve")
    except PackageNotFoundError:
        return "unknown"


def _csv_text(rows: list[list]) -> str:
    """Rows as CSV text (``csv``'s dialect: comma-separated, CRLF line ends)."""
    buffer = io.StringIO(newline="")
    csv.writer(buffer).writerows(rows)
    return buffer.getvalue()


def _fmt(value) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def read_stats(path: Path) -> list[dict]:
    """A run's stats.csv as one dict a generation (strings, as written); [] without one."""
    if not path.exists():
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _progress_line(row: dict, done: int, generations: int | None, eta_s: float, stage: Stage | None = None,
                   intensity: float = 0.0) -> str:
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


def plot_stats(stats_csv: Path, png: Path) -> bool:
    """Best / mean fitness and best distance over generations; False without matplotlib."""
    try:
        plt = pyplot()
    except BipedError:  # no matplotlib
        return False
    rows = read_stats(stats_csv)
    if not rows:
        return False
    gen = [int(r["generation"]) for r in rows]
    fig, ax = plt.subplots(figsize=(8, 4.5))
    staged = any(r.get("stage") for r in rows)
    ax.plot(gen, [float(r["best_fitness"]) for r in rows], label="best fitness" + ("" if staged else " (eq. 3)"))
    ax.plot(gen, [float(r["mean_fitness"]) for r in rows], label="mean fitness")
    ax.set_xlabel("generation")
    ax.set_ylabel("fitness")
    ax2 = ax.twinx()
    ax2.plot(gen, [float(r["best_distance_m"]) for r in rows], color="tab:green", alpha=0.7, label="best distance")
    ax2.set_ylabel("best distance [m]")
    for g, r, prev in zip(gen[1:], rows[1:], rows):
        if r.get("stage") != prev.get("stage"):  # a new stage: a new module, a new objective
            ax.axvline(g - 0.5, color="0.5", linestyle="--", linewidth=0.8)
            ax.text(g, ax.get_ylim()[1], f" {r['stage']}", va="top", fontsize=8, color="0.3")
    harness_end = [g for g, r in zip(gen, rows) if float(r["harness"]) > 0]
    if harness_end:
        ax.axvspan(0, max(harness_end) + 0.5, color="0.9", label="support harness")
    lines = ax.get_legend_handles_labels()
    lines2 = ax2.get_legend_handles_labels()
    ax.legend(lines[0] + lines2[0], lines[1] + lines2[1], loc="upper left", fontsize=8)
    fig.tight_layout()
    save_figure(fig, png, dpi=100)
    return True
