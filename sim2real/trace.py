"""Traces of a run: CSV (header row, one row a tick) plus a JSON sidecar of metadata.

The same format serves the real robot, the mock bus and dry runs, and reads directly into
pandas or PlotJuggler.  Rows are flushed at least once a second, so a crash loses at most
a second; the sidecar is written (atomically) before the first row.
"""

from __future__ import annotations

import csv
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from sim2real.atomic_json import write_text_atomic

FLUSH_EVERY_S = 1.0


def trace_columns(joints: Sequence[str]) -> list[str]:
    return (["time_s", "tick"] + [f"{j}_goal_rad" for j in joints] + [f"{j}_present_rad" for j in joints]
            + ["foot_left", "foot_right", "up_x", "up_y", "up_z", "compute_ms", "bus_ms", "overrun"])


class TraceWriter:
    def __init__(self, path: Path | str, joints: Sequence[str], metadata: dict[str, Any]):
        import json

        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.columns = trace_columns(joints)
        write_text_atomic(self.path.with_suffix(".json"), json.dumps(
            {**metadata, "columns": self.columns, "start_time": time.time()}, indent=1))
        self._file = open(self.path, "w", newline="")
        self._csv = csv.writer(self._file)
        self._csv.writerow(self.columns)
        self._last_flush = time.monotonic()

    def write(self, t: float, tick: int, goal: np.ndarray, present: np.ndarray, feet: np.ndarray,
              up: np.ndarray, compute_s: float, bus_s: float, overrun: bool) -> None:
        row = [f"{t:.6f}", tick, *(f"{v:.6f}" for v in goal), *(f"{v:.6f}" for v in present),
               int(feet[0]), int(feet[1]), *(f"{v:.5f}" for v in up),
               f"{compute_s * 1e3:.4f}", f"{bus_s * 1e3:.4f}", int(overrun)]
        self._csv.writerow(row)
        now = time.monotonic()
        if now - self._last_flush >= FLUSH_EVERY_S:
            self._file.flush()
            self._last_flush = now

    def close(self) -> None:
        if not self._file.closed:
            self._file.flush()
            self._file.close()
