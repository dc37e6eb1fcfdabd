"""A run's statistics: ``stats.csv``, one row a generation, and its plot ``fitness.png``.

The columns are :data:`STATS_COLUMNS`, then one column per fitness term of the run's
objectives (:func:`term_columns`: the generation champion's value, unweighted - the genome of
``best_fitness`` - and empty in the rows of a stage whose objective has no such term), then,
with validation draws, :data:`VALIDATION_COLUMNS`.  In a staged run ``generation`` counts
across stages (the population's own count restarts with every stage).

Rows are appended as they come, each whole or not at all (:meth:`StatsFile.append`): a resume
keeps the rows below its checkpoint's generation by their number, so a row cut short must
never stay.  The file is rewritten whole only on a resume (:meth:`StatsFile.keep_below`).
"""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

from evolve.config import EvolveConfig
from evolve.locomotion.objectives import DEFAULT_OBJECTIVE, OBJECTIVES, WalkObjective
from sim2real.atomic_json import OutputError, write_text_atomic
from sim2real.errors import BipedError
from sim2real.figures import pyplot, save_figure

STATS_COLUMNS = ("generation", "stage", "best_fitness", "mean_fitness", "best_distance_m", "best_upright_s",
                 "species", "mean_connections", "mean_hidden", "evaluations", "evaluations_per_s",
                 "steps_per_s", "wall_s", "harness", "threshold")  # then the fitness terms (term_columns)
# with validation draws: the validated champion's walks and mean fitness there (empty between validations)
VALIDATION_COLUMNS = ("validation_walked", "validation_fitness")


def term_columns(config: EvolveConfig) -> tuple[str, ...]:
    """The fitness terms of every objective of the run, in stage order, each once (walking's
    gait and smooth terms with their coefficients only: they are computed only then)."""
    kinds = [stage.kind for stage in config.stages] or [OBJECTIVES[DEFAULT_OBJECTIVE]]
    names = [name for kind in kinds for name in kind.terms]
    walking = any(kind.terms == WalkObjective.TERMS for kind in kinds)
    if config.task.selection_gait_coeff > 0 and walking:
        names.append(WalkObjective.GAIT_TERM)
    if config.task.selection_smooth_coeff > 0 and walking:
        names.append(WalkObjective.SMOOTH_TERM)
    return tuple(dict.fromkeys(names))


def stats_columns(config: EvolveConfig) -> tuple[str, ...]:
    """stats.csv's columns for ``config``'s run: :data:`STATS_COLUMNS`, then
    :func:`term_columns`, then the validation's (with validation draws)."""
    validation = VALIDATION_COLUMNS if config.randomize.validation.active else ()
    return STATS_COLUMNS + term_columns(config) + validation


class StatsFile:
    """``stats.csv`` at ``path`` with ``columns``: rows are dicts keyed by column name."""

    def __init__(self, path: Path, columns: tuple[str, ...]):
        self.path, self.columns = Path(path), columns

    def start(self) -> None:
        """A new file: the header alone."""
        write_text_atomic(self.path, _csv_text([self.columns]))

    def append(self, row: dict) -> None:
        """One row, appended whole or not at all: a row the disk refuses half-way is cut
        back off, so that a resume never reads a truncated generation number."""
        line = _csv_text([[_fmt(row[c]) for c in self.columns]]).encode()
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC, 0o666)
        try:
            size = os.fstat(fd).st_size
            try:
                view = memoryview(line)
                while view:
                    view = view[os.write(fd, view):]
            except OSError as exc:
                os.ftruncate(fd, size)  # frees what was written: succeeds on a full disk
                raise OutputError(self.path, exc, f"generation {row['generation']} was not recorded") from exc
        finally:
            os.close(fd)

    def keep_below(self, generation: int) -> float:
        """Keep the rows of generations below ``generation`` (a resume's: the rows after its
        checkpoint are evolved again) under this file's columns, and return the last kept
        row's ``wall_s`` [s] (0 without one).  A file from before the term columns gets them
        (empty); written whole, so a full disk keeps the old file."""
        kept = [r for r in read_stats(self.path) if int(r["generation"]) < generation]
        write_text_atomic(self.path, _csv_text([self.columns] + [[r.get(c) or "" for c in self.columns]
                                                                 for r in kept]))
        return float(kept[-1]["wall_s"]) if kept else 0.0


def read_stats(path: Path) -> list[dict]:
    """A run's stats.csv as one dict a generation (strings, as written); [] without one."""
    if not path.exists():
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


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


def _csv_text(rows: list) -> str:
    """Rows as CSV text (``csv``'s dialect: comma-separated, CRLF line ends)."""
    buffer = io.StringIO(newline="")
    csv.writer(buffer).writerows(rows)
    return buffer.getvalue()


def _fmt(value) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)
