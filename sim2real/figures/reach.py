"""A reach over time (seed 002's reaching): the hand's distance to its goal, with the state
machine's phases shaded - reaching for the target, returning to rest - and the tolerance
within which a goal counts as reached.  Drawn alike from a trace (``reach_state`` and
``hand_error`` columns: a real robot's or a dry run's) and from a simulated replay."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim2real.figures import pyplot, save_figure


@dataclass(frozen=True)
class Reach:
    times_s: np.ndarray  # (n,)
    hand_error: np.ndarray  # (n,) the hand's distance to the goal it had [arm lengths]
    state: np.ndarray  # (n,) 1 reaching, 0 returning
    tolerance: float | None  # [arm lengths], if known
    title: str

    @classmethod
    def from_trace(cls, trace, tolerance: float | None, title: str) -> "Reach":
        for name in ("reach_state", "hand_error"):
            if name not in trace:
                raise ValueError(f"the trace has no {name} column: it was not recorded from a reaching controller")
        return cls(np.asarray(trace.times), np.asarray(trace["hand_error"]), np.asarray(trace["reach_state"]),
                   tolerance, title)

    @property
    def reaches(self) -> int:
        """Goals reached: the state's toggles."""
        return int(np.count_nonzero(np.diff(self.state)))


def plot_reach(reach: Reach, path: Path | str) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 3.2))
    t, state = reach.times_s, reach.state
    edges = np.flatnonzero(np.diff(state)) + 1
    starts = np.concatenate([[0], edges])
    ends = np.concatenate([edges, [len(t) - 1]])
    for a, b in zip(starts, ends):
        colour = "#f4c7c3" if state[a] == 1 else "#cfe2f3"
        ax.axvspan(t[a], t[b], color=colour, lw=0)
    ax.plot(t, reach.hand_error, color="black", lw=1.2, label="hand to goal")
    if reach.tolerance is not None:
        ax.axhline(reach.tolerance, color="grey", ls="--", lw=0.8, label="reached within")
    handles, labels = ax.get_legend_handles_labels()
    from matplotlib.patches import Patch

    handles += [Patch(color="#f4c7c3", label="reaching"), Patch(color="#cfe2f3", label="returning")]
    ax.legend(handles=handles, loc="upper right", fontsize=8, ncol=4)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("distance [arm lengths]")
    ax.set_xlim(t[0], t[-1])
    ax.set_ylim(0, max(1.0, float(np.max(reach.hand_error)) * 1.15))
    n = reach.reaches
    ax.set_title(f"{reach.title}: {n} goal{'' if n == 1 else 's'} reached", fontsize=10)
    save_figure(fig, path, dpi=120, bbox_inches="tight")
