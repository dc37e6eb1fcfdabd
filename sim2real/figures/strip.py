"""Frames of several walkers side by side over time (seed 000, figure 1): one row a walker,
one column a moment."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from sim2real.figures import pyplot, save_figure


def save_strip(path: Path | str, rows: Sequence[Sequence[np.ndarray]], times_s: Sequence[float],
               labels: Sequence[str], dpi: int = 100) -> None:
    """``rows[r][c]``: the frame (height, width, 3) of walker ``r`` at ``times_s[c]``; a row
    whose replay ended early is left blank after its last frame."""
    plt = pyplot()
    n_rows, n_cols = len(rows), len(times_s)
    h, w = rows[0][0].shape[:2]
    fig, axes = plt.subplots(n_rows, n_cols, figsize=(n_cols * w / dpi, n_rows * h / dpi + 0.4), squeeze=False,
                             gridspec_kw={"wspace": 0.02, "hspace": 0.04})
    for r, frames in enumerate(rows):
        for c in range(n_cols):
            ax = axes[r][c]
            if c < len(frames):
                ax.imshow(frames[c])
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(f"{times_s[c]:.1f} s", fontsize=9)
            if c == 0:
                ax.set_ylabel(labels[r], fontsize=8)
    save_figure(fig, path, dpi=dpi, bbox_inches="tight")
