"""Traces of a run: CSV (header row, one row a tick) plus a JSON sidecar of metadata.

The same format serves the real robot, the mock bus and dry runs, and reads directly into
pandas or PlotJuggler.  Rows are flushed at least once a second, so a crash loses at most
a second; the sidecar is written (atomically) before the first row.  :func:`read_trace`
reads one back, refusing what is not a trace with one error naming the file, and dropping
(with a note) the partial last row that a killed run leaves.
"""

from __future__ import annotations

import csv
import json
import math
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from sim2real.atomic_json import write_text_atomic
from sim2real.errors import ConfigError

FLUSH_EVERY_S = 1.0


def trace_columns(joints: Sequence[str]) -> list[str]:
    return (["time_s", "tick"] + [f"{j}_goal_rad" for j in joints] + [f"{j}_present_rad" for j in joints]
            + ["foot_left", "foot_right", "up_x", "up_y", "up_z", "compute_ms", "bus_ms", "overrun"])


class TraceWriter:
    def __init__(self, path: Path | str, joints: Sequence[str], metadata: dict[str, Any]):
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


def sidecar_path(path: Path | str) -> Path:
    """The JSON sidecar of a trace CSV: the same name ending in ``.json``."""
    return Path(path).with_suffix(".json")


def read_trace(path: Path | str) -> tuple[dict[str, Any], dict[str, np.ndarray], list[str]]:
    """A trace CSV and its sidecar -> (metadata, {column: values (n,)}, notes).

    Refused with :class:`ConfigError` naming the file: a file that cannot be read, is
    binary or empty, has no rows, a header unlike its sidecar's ``columns``, a row of the
    wrong length or with something other than a finite number, ``time_s`` not increasing.
    A last row cut short - no end of line, or too few fields: what a run killed mid-write
    leaves - is dropped and said in ``notes``; so is a missing sidecar (metadata ``{}``).
    """
    path = Path(path)
    source = str(path)
    if path.suffix.lower() == ".json":
        raise ConfigError(source, "", "a trace is the CSV file; a .json beside it is its sidecar")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ConfigError(source, "", f"cannot read the trace: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = "\0"
    if "\0" in text:
        raise ConfigError(source, "", "not a trace: a binary file, not CSV text")
    if not text.strip():
        raise ConfigError(source, "", "the trace is empty (no header row)")
    notes: list[str] = []
    meta = _read_sidecar(path, notes)
    lines = text.splitlines(keepends=True)
    rows = list(csv.reader(lines))
    while len(rows) > 1 and not rows[-1]:  # blank lines at the end
        rows.pop()
        lines.pop()
    header, rows = rows[0], rows[1:]
    if len(set(header)) != len(header) or not all(header):
        raise ConfigError(source, "header", "column names must be unique and non-empty")
    if isinstance(meta.get("columns"), list) and meta["columns"] != header:
        missing = [c for c in meta["columns"] if c not in header]
        extra = [c for c in header if c not in meta["columns"]]
        raise ConfigError(source, "header", f"does not match the columns of its sidecar {sidecar_path(path).name}"
                          f" (missing {missing[:3]}, unexpected {extra[:3]})")
    if rows and (not lines[-1].endswith(("\n", "\r")) or len(rows[-1]) < len(header)):
        rows.pop()
        notes.append(f"{source}: the last row is cut short (a run killed mid-write?): dropped")
    if not rows:
        raise ConfigError(source, "", "the trace has no rows")
    values = np.empty((len(rows), len(header)))
    for k, row in enumerate(rows):
        if len(row) != len(header):
            raise ConfigError(source, f"row {k + 2}", f"has {len(row)} fields, the header {len(header)}")
        for j, cell in enumerate(row):
            try:
                values[k, j] = float(cell)
            except ValueError:
                values[k, j] = math.nan
            if not math.isfinite(values[k, j]):
                raise ConfigError(source, f"row {k + 2}", f"{header[j]}: {cell!r} is not a finite number")
    columns = {name: values[:, j] for j, name in enumerate(header)}
    if "time_s" in columns and np.any(np.diff(columns["time_s"]) <= 0):
        k = int(np.argmax(np.diff(columns["time_s"]) <= 0)) + 1
        raise ConfigError(source, f"row {k + 2}", "time_s does not increase")
    return meta, columns, notes


def _read_sidecar(path: Path, notes: list[str]) -> dict[str, Any]:
    sidecar = sidecar_path(path)
    if not sidecar.exists():
        notes.append(f"{path}: no sidecar {sidecar.name} (the trace's metadata)")
        return {}
    try:
        meta = json.loads(sidecar.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ConfigError(str(sidecar), "", f"not a trace sidecar (JSON): {exc}") from None
    if not isinstance(meta, dict):
        raise ConfigError(str(sidecar), "", "not a trace sidecar: must hold a JSON object")
    return meta
