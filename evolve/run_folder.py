"""A run's folder: the files an evolution writes, and what a resume reads back.

    run/
      config.yaml          the resolved configuration (every default written out)
      checkpoint.json.gz   the latest generation, resumable (atomic; at most CHECKPOINT_INTERVAL_S
                           old, and written at every numbered snapshot, stage start and stop)
      checkpoints/         numbered snapshots every ``checkpoint_every`` generations
      stats.csv            one row per generation, flushed as it goes (:mod:`evolve.run_stats`)
      fitness.png          best / mean fitness and best distance over generations
      controller.json      the best controller so far (of the stage running)
      best.json            its genome and scores (what a resume needs to keep it)
      stages.json          a staged run's finished stages (:mod:`evolve.stages`)
      stages/<name>/       each finished stage's controller.json and best.json
      .lock                the id of the process working in the folder, there while it does

One process works in a folder at a time: :class:`evolve.run.Run` holds the folder's lock
(:mod:`sim2real.run_lock`) while it works there.  Every file but ``stats.csv`` is replaced whole
(written beside, then renamed: a full disk leaves the previous file); a row of ``stats.csv``
that the disk refuses is taken back out.  Checkpoints are the population's own JSON
(:meth:`evolve.neat.Population.save`), so a resume from any of them reruns the same
generations exactly.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from evolve.champion import Best
from evolve.config import EvolveConfig, parse_evolve_config
from evolve.neat import Layout, Population
from evolve.run_stats import StatsFile, plot_stats
from sim2real.atomic_json import copy_file_atomic, read_json, write_json_atomic, write_text_atomic
from sim2real.controller.file import Controller
from sim2real.input_files import check_regular_file
from sim2real.robot.validation import load_yaml

# Writing the latest checkpoint costs about 0.35 s for 128 genomes of 600 links (JSON, gzip,
# fsync): 13 % of a 2.6 s generation when it was written every generation (measured on
# reach_baseline seed 1).  A kill loses at most this much evolution; a resume from an older
# checkpoint reruns the same generations exactly.
CHECKPOINT_INTERVAL_S = 15.0


def holds_run(folder: Path) -> bool:
    """Whether ``folder`` holds a run to resume (its latest checkpoint)."""
    return (Path(folder) / "checkpoint.json.gz").exists()


def write_config(folder: Path, config: EvolveConfig) -> None:
    """``config.yaml``: the run's configuration, every default written out."""
    write_text_atomic(Path(folder) / "config.yaml", config.to_yaml())


def read_config(folder: Path, robot_file: str | None = None) -> EvolveConfig:
    """The run's ``config.yaml``; ``robot_file``: the robot file it evolves for, given again by
    the caller (a path read from a file is never opened on its own)."""
    path = Path(folder) / "config.yaml"
    return parse_evolve_config(load_yaml(check_regular_file(path)), str(path), robot_file=robot_file)


def read_population(folder: Path) -> Population:
    """The population of the latest checkpoint."""
    return Population.load(Path(folder) / "checkpoint.json.gz")


class RunFolder:
    """The files of the run in ``path`` (created by its caller) whose stats.csv has ``columns``
    (:func:`evolve.run_stats.stats_columns`)."""

    def __init__(self, path: Path, columns: tuple[str, ...]):
        self.path = Path(path)
        self.stats = StatsFile(self.path / "stats.csv", columns)
        self.checkpoint_generation: int | None = None  # the population's generation on disk
        self._checkpoint_at = -math.inf  # [s, time.monotonic] when it was written

    # -- checkpoints ---------------------------------------------------------------------------
    def checkpoint(self, population: Population, every: int, force: bool = False) -> None:
        """The latest checkpoint, if ``force``d, at a stage's start (generation 0) or a
        numbered snapshot's generation (every ``every``; 0: none), or CHECKPOINT_INTERVAL_S
        after the last; the numbered snapshot."""
        generation = population.generation
        snapshot = bool(every) and generation % every == 0
        if force or snapshot or generation == 0 or time.monotonic() - self._checkpoint_at >= CHECKPOINT_INTERVAL_S:
            population.save(self.path / "checkpoint.json.gz")
            self.checkpoint_generation, self._checkpoint_at = generation, time.monotonic()
        if snapshot:
            (self.path / "checkpoints").mkdir(exist_ok=True)
            copy_file_atomic(self.path / "checkpoint.json.gz",
                             self.path / "checkpoints" / f"gen_{generation:05d}.json.gz")

    # -- the champion --------------------------------------------------------------------------
    def save_best(self, best: Best, controller: Controller) -> None:
        """``best.json`` and its ``controller.json``."""
        write_json_atomic(self.path / "best.json", best.to_dict())
        controller.save(self.path / "controller.json")

    def read_best(self, layout: Layout) -> Best | None:
        """The champion in ``best.json`` (None without one), its genome read for ``layout``."""
        path = self.path / "best.json"
        return Best.from_dict(read_json(path), layout) if path.exists() else None

    def drop_best(self) -> None:
        """Forget the champion (a new stage starts without one); its controller.json stays
        until the new stage's first champion replaces it."""
        (self.path / "best.json").unlink()

    # -- stages --------------------------------------------------------------------------------
    def read_stages(self) -> list[dict]:
        """``stages.json``: the finished stages, in order ([] before the first)."""
        path = self.path / "stages.json"
        return read_json(path) if path.exists() else []

    def file_stage(self, name: str, finished: list[dict]) -> None:
        """Keep the champion of the stage ``name`` in stages/<name>/ and write ``finished``
        (every finished stage, this one last) to stages.json."""
        folder = self.path / "stages" / name
        folder.mkdir(parents=True, exist_ok=True)
        copy_file_atomic(self.path / "best.json", folder / "best.json")
        copy_file_atomic(self.path / "controller.json", folder / "controller.json")
        write_json_atomic(self.path / "stages.json", finished)

    def plot(self) -> bool:
        """``fitness.png`` from stats.csv; False without matplotlib or rows."""
        return plot_stats(self.stats.path, self.path / "fitness.png")
