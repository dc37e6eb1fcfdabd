"""Traces of a run: one type, :class:`Trace`, for the real robot, the mock bus and dry runs.

On disk a trace is a CSV file (a header row, one row a control tick) and a JSON sidecar of
metadata beside it (the same name ending in ``.json``); pandas and PlotJuggler read the CSV
as it is.  The real-time loop streams it through :class:`TraceWriter`: the sidecar is
written (atomically) before the first row, and rows are flushed at least once a second, so
a crash loses at most a second.  ``compare`` and system identification read it back:

    trace = Trace.read("run.csv")             # refuses what is not a trace, in one line
    trace.times                               # (n,) [s] since the loop began
    trace.goals(robot.joint_names)            # (n, joints) commanded angles [rad]
    trace.present(robot.joint_names)          # (n, joints) angles the servos reported [rad]
    trace["up_z"], trace.metadata["robot"]    # any channel; the sidecar's metadata

A :class:`Trace` is immutable and checks itself: increasing finite times, one finite value
a channel a tick, unique channel names.  Each channel has a unit (:func:`loop_channels`).
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from sim2real.atomic_json import write_text_atomic
from sim2real.errors import ConfigError
from sim2real.hardware.trace_rows import Rows, read_rows
from sim2real.input_files import read_regular_bytes

FLUSH_EVERY_S = 1.0
TIME = "time_s"  # the column of times: seconds since the loop began
TIMING = ("compute_ms", "bus_ms", "overrun")  # how the loop kept time, not what the robot did
GOAL, PRESENT = "_goal_rad", "_present_rad"  # after a joint's name: its commanded and reported angle [rad]
# What a trace may hold and still mean something (Trace.read refuses the rest, naming the row):
MAX_ANGLE_RAD = 2 * math.pi  # |a channel in rad| beyond a full turn is no joint angle or heading (degrees?)
MAX_TIME_S = 7 * 24 * 3600.0  # time_s past a week since the loop began: a clock in another unit, or epoch seconds
GAP_TICKS = 3  # more than this many ticks without a row is a gap, reported in notes (the loop writes no row
# for a tick whose reads failed, and holds its goals: a short gap is normal on a busy bus, a long one is news)
JOINT_RANGE_MARGIN_RAD = math.radians(10.0)  # a joint angle this far past its joint's range is not this robot's
MAX_SIDECAR_BYTES = 16 * 1024 * 1024  # a sidecar is metadata: a few KB, a controller's provenance included


@dataclass(frozen=True)
class Channel:
    """One column of a trace: its name in the CSV header and the unit of its values
    ("rad", "ms", "count", "flag" for 0/1, "1" for dimensionless, "" when not known)."""

    name: str
    unit: str


HEADING_CHANNEL = "heading_rad"  # the board's heading, when it reports one (after the loop's channels)
GYRO_CHANNELS = ("gyro_x_rad_s", "gyro_y_rad_s", "gyro_z_rad_s")  # the board's angular rates, when it reports them


def loop_channels(joints: Sequence[str]) -> tuple[Channel, ...]:
    """What the real-time loop records each tick, in CSV order after ``time_s``: the tick's
    number, goals and present angles per joint, the foot switches (1 touching), the torso's
    up-vector (unit, torso frame), the network's compute time and the bus time, and whether
    the tick overran its deadline."""
    return (Channel("tick", "count"), *(Channel(f"{j}{GOAL}", "rad") for j in joints),
            *(Channel(f"{j}{PRESENT}", "rad") for j in joints),
            Channel("foot_left", "flag"), Channel("foot_right", "flag"),
            *(Channel(f"up_{axis}", "1") for axis in "xyz"),
            Channel("compute_ms", "ms"), Channel("bus_ms", "ms"), Channel("overrun", "flag"))


def sidecar_path(path: Path | str) -> Path:
    """The JSON sidecar of a trace CSV: the same name ending in ``.json``."""
    return Path(path).with_suffix(".json")


class TraceCut(OSError):
    """The disk refused the trace part way: the file was cut back to its last whole row.
    The message says what was kept (rows, seconds, path) and why, without ``[Errno N]``."""

    def __init__(self, cause: OSError, message: str):
        super().__init__(cause.errno, message)
        self.message = message

    def __str__(self) -> str:
        return self.message


class TraceWriter:
    """Streams the loop's trace to ``path`` (and its sidecar: ``metadata`` plus the columns
    and the wall-clock start time), one row a :meth:`write`; ``extra`` channels (e.g.
    servo velocities, :mod:`sim2real.hardware.readings`) follow the loop's, their units in
    the sidecar.

    Rows are kept in memory and written at least once every ``FLUSH_EVERY_S``, whole rows
    at a time; if the disk refuses part of a write (full, gone), the file is cut back to its
    last whole row and :class:`TraceCut` says how many rows (and seconds) it keeps.  A trace
    that keeps no row is removed with its sidecar: a run that failed before writing anything
    useful leaves no empty files."""

    def __init__(self, path: Path | str, joints: Sequence[str], metadata: Mapping[str, Any],
                 extra: Sequence[Channel] = ()):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.columns = [TIME] + [c.name for c in loop_channels(joints)] + [c.name for c in extra]
        units = {"units": {c.name: c.unit for c in extra}} if extra else {}
        write_text_atomic(sidecar_path(self.path), json.dumps(
            {**metadata, "columns": self.columns, **units, "start_time": time.time()}, indent=1))
        self._fd: int | None = None
        self._pending: list[str] = []  # rows not yet written, each with its end of line
        self._pending_t: list[float] = []  # their times [s]
        self.rows, self.last_t = 0, 0.0  # rows written whole, and the last one's time [s]
        self._size = 0  # bytes of the file that are whole rows (the header included)
        try:
            self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_CLOEXEC, 0o644)
            self._write_all(_row_text(self.columns))  # now: a full disk is found before anything moves
        except (OSError, _Partial) as exc:
            self._remove()
            raise (exc.cause if isinstance(exc, _Partial) else exc) from None
        self._last_flush = time.monotonic()

    def write(self, t: float, tick: int, goal: np.ndarray, present: np.ndarray, feet: np.ndarray,
              up: np.ndarray, compute_s: float, bus_s: float, overrun: bool, extra: Sequence[float] = ()) -> None:
        """One tick: ``t`` [s] since the loop began, goals and present angles (joints,) [rad],
        feet (2,) touching, up (3,), compute and bus time [s], the deadline missed, and the
        ``extra`` channels' values.  :class:`TraceCut` when the disk refuses the rows."""
        if self._fd is None:
            raise ValueError(f"the trace {self.path} is closed")
        row = [f"{t:.6f}", str(tick), *(f"{v:.6f}" for v in goal), *(f"{v:.6f}" for v in present),
               str(int(feet[0])), str(int(feet[1])), *(f"{v:.5f}" for v in up),
               f"{compute_s * 1e3:.4f}", f"{bus_s * 1e3:.4f}", str(int(overrun)), *(f"{v:.6g}" for v in extra)]
        self._pending.append(_row_text(row))
        self._pending_t.append(t)
        now = time.monotonic()
        if now - self._last_flush >= FLUSH_EVERY_S:
            self._last_flush = now
            self._flush()

    def close(self) -> None:
        """Write the rows still held and close.  A write the disk refuses raises
        :class:`TraceCut` (the file cut back to its last whole row), and the file is closed all
        the same; a trace without a row is removed with its sidecar."""
        if self._fd is None:
            return
        try:
            self._flush()
        finally:
            fd, self._fd = self._fd, None
            os.close(fd)
            if self.rows == 0:
                self._remove()

    def _flush(self) -> None:
        if not self._pending:
            return
        text, times = "".join(self._pending), self._pending_t
        self._pending, self._pending_t = [], []
        try:
            self._write_all(text)
        except _Partial as cut:
            keep = text.rfind("\n", 0, cut.written) + 1  # the whole rows of what went in
            whole = text.count("\n", 0, keep)
            self._truncate(self._size + keep)
            self.rows += whole
            self.last_t = times[whole - 1] if whole else self.last_t
            cause = cut.cause
            kept = (f"kept {self.rows} rows ({self.last_t:.1f} s) in {self.path}, which ends at its last whole row"
                    if self.rows else f"no row kept: {self.path} and its sidecar are removed")
            fd, self._fd = self._fd, None
            if fd is not None:
                os.close(fd)
            if not self.rows:
                self._remove()
            raise TraceCut(cause, f"{cause.strerror or cause}: {kept}") from cause
        self.rows += len(times)
        self.last_t = times[-1]

    def _write_all(self, text: str) -> None:
        """``text`` appended whole, or :class:`_Partial` saying how much of it went in."""
        data, written = text.encode("ascii"), 0
        while written < len(data):
            try:
                written += os.write(self._fd, data[written:])
            except OSError as exc:
                raise _Partial(exc, written) from exc
        self._size += len(data)

    def _truncate(self, size: int) -> None:
        try:
            os.ftruncate(self._fd, size)
            self._size = size
        except OSError:  # cutting back frees space and does not fail; if it does, the reader drops a cut row
            pass

    def _remove(self) -> None:
        """Remove the trace and its sidecar (nothing of use was written)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        for path in (self.path, sidecar_path(self.path)):
            try:
                path.unlink()
            except FileNotFoundError:
                pass


class _Partial(Exception):
    """A write refused after ``written`` of its bytes."""

    def __init__(self, cause: OSError, written: int):
        super().__init__(str(cause))
        self.cause, self.written = cause, written


def _row_text(fields: Sequence[str]) -> str:
    """One CSV row as ``csv.writer`` writes it (numbers and names: nothing to quote)."""
    return ",".join(fields) + "\r\n"


@dataclass(frozen=True, eq=False)
class Trace:
    """A recorded run: ``times`` (n,) [s], increasing; ``data`` (n, m), one column a channel
    in its unit; ``channels`` (m,); ``metadata`` from the sidecar (robot, controller_hash,
    tick_s [s], ...); ``notes``: what reading the file found and set right.  The arrays are
    read-only copies; a ``ValueError`` names the argument that is wrong."""

    times: np.ndarray
    data: np.ndarray
    channels: tuple[Channel, ...]
    metadata: Mapping[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    _index: Mapping[str, int] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        times = np.array(self.times, dtype=float)
        if times.ndim != 1 or len(times) == 0:
            raise ValueError(f"times: must be a non-empty 1-D array [s], got shape {times.shape}")
        if not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
            raise ValueError("times: must be finite and increase")
        channels = tuple(self.channels)
        if not all(isinstance(c, Channel) for c in channels):
            raise ValueError("channels: must be Channel(name, unit) each")
        names = [c.name for c in channels]
        if TIME in names or len(set(names)) != len(names) or not all(names):
            raise ValueError(f"channels: names must be unique, non-empty and not {TIME!r}")
        data = np.array(self.data, dtype=float)
        if data.shape != (len(times), len(channels)):
            raise ValueError(f"data: shape {data.shape}, expected (times, channels) = ({len(times)}, {len(channels)})")
        if not np.all(np.isfinite(data)):
            raise ValueError("data: must be finite")
        times.setflags(write=False)
        data.setflags(write=False)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "data", data)
        object.__setattr__(self, "channels", channels)
        object.__setattr__(self, "metadata", MappingProxyType(dict(self.metadata)))
        object.__setattr__(self, "notes", tuple(self.notes))
        object.__setattr__(self, "_index", MappingProxyType({name: k for k, name in enumerate(names)}))

    def __len__(self) -> int:
        return len(self.times)

    def __contains__(self, name: object) -> bool:
        return name == TIME or name in self._index

    def __getitem__(self, name: str) -> np.ndarray:
        """One channel's values (n,) (``time_s``: the times)."""
        if name == TIME:
            return self.times
        try:
            return self.data[:, self._index[name]]
        except KeyError:
            raise KeyError(f"the trace has no channel {name!r}") from None

    def missing(self, names: Sequence[str]) -> list[str]:
        """Those of ``names`` the trace lacks, in order."""
        return [name for name in names if name not in self]

    def goals(self, joints: Sequence[str]) -> np.ndarray:
        """Commanded angles (n, joints) [rad]."""
        return np.stack([self[f"{j}{GOAL}"] for j in joints], axis=1)

    def present(self, joints: Sequence[str]) -> np.ndarray:
        """Angles the servos reported (n, joints) [rad]."""
        return np.stack([self[f"{j}{PRESENT}"] for j in joints], axis=1)

    @property
    def feet(self) -> np.ndarray:
        """Foot switches (n, 2): left, right; True touching."""
        return np.stack([self["foot_left"], self["foot_right"]], axis=1) > 0.5

    @classmethod
    def read(cls, path: Path | str, reader: Callable[..., Rows] | None = None) -> "Trace":
        """A trace CSV and its sidecar.

        Refused with :class:`ConfigError` naming the file: a file that is not a regular
        file (a FIFO, a device, a directory: :mod:`sim2real.input_files`) or cannot be read,
        is binary or empty, has no rows, a header unlike its sidecar's ``columns`` or without
        ``time_s``, a row of the wrong length or with something other than a finite number,
        ``time_s`` negative, past ``MAX_TIME_S`` or not increasing, an angle (a channel in
        rad) beyond +-``MAX_ANGLE_RAD``.  A last row cut short - no end of line, or too few
        fields: what a run killed mid-write leaves - is dropped and said in ``notes``; so is
        a missing sidecar (metadata ``{}``), and so are gaps of more than ``GAP_TICKS``
        ticks without a row (the tick: the sidecar's ``tick_s``, else the median step).
        Channels the loop writes get their units from :func:`loop_channels`; others have the
        unit "".  Joint angles against a robot's ranges: :func:`check_joint_angles`.  The rows
        are read in chunks (:mod:`sim2real.hardware.trace_rows`: a file past its
        ``MAX_TRACE_BYTES`` is refused); ``reader``: another reader of them, e.g. its
        reference ``read_rows_plain``.
        """
        path = Path(path)
        source = str(path)
        if path.suffix.lower() == ".json":
            raise ConfigError(source, "", "a trace is the CSV file; a .json beside it is its sidecar")
        notes: list[str] = []
        meta: dict[str, Any] = {}

        def check_header(header: list[str]) -> None:  # before any row is read
            meta.update(_read_sidecar(path, notes))
            columns = meta.pop("columns", None)
            if isinstance(columns, list) and columns != header:
                missing = [c for c in columns if c not in header]
                extra = [c for c in header if c not in columns]
                raise ConfigError(source, "header", f"does not match the columns of its sidecar "
                                  f"{sidecar_path(path).name} (missing {missing[:3]}, unexpected {extra[:3]})")
            if TIME not in header:
                raise ConfigError(source, "header", f"has no {TIME} column")

        # in chunks, in bounded memory, a file past MAX_TRACE_BYTES refused (a FIFO or a device unopened)
        header, values, cut = (reader or read_rows)(path, source, check_header)
        if cut:
            notes.append(f"{source}: the last row is cut short (a run killed mid-write?): dropped")
        if not len(values):
            raise ConfigError(source, "", "the trace has no rows")
        t = header.index(TIME)
        _check_times(values[:, t], meta, source, notes)
        joints = [name.removesuffix(GOAL) for name in header if name.endswith(GOAL)]
        units = {c.name: c.unit for c in loop_channels(joints)}
        units[HEADING_CHANNEL] = "rad"
        if isinstance(meta.get("units"), dict):
            units.update({str(k): str(v) for k, v in meta["units"].items() if k not in units})
        for j, name in enumerate(header):
            if units.get(name) == "rad" and np.any(np.abs(values[:, j]) > MAX_ANGLE_RAD):
                k = int(np.argmax(np.abs(values[:, j]) > MAX_ANGLE_RAD))
                raise ConfigError(source, f"row {k + 2}", f"{name}: {values[k, j]:.6g} rad is more than a full turn "
                                  f"(|angle| <= 2 pi): not an angle in radians (degrees?)")
        others = [j for j in range(len(header)) if j != t]
        times, data = values[:, t].copy(), values[:, others]
        del values  # the rows as read go before the trace copies its own: two arrays at most, not three
        return cls(times, data, tuple(Channel(header[j], units.get(header[j], "")) for j in others), meta, tuple(notes))


def _check_times(times: np.ndarray, meta: Mapping[str, Any], source: str, notes: list[str]) -> None:
    """Refuse times that cannot be a loop's (negative, beyond ``MAX_TIME_S``, not
    increasing); note gaps of more than ``GAP_TICKS`` ticks."""
    if times[0] < 0:
        raise ConfigError(source, "row 2", f"{TIME} {times[0]:g}: negative; it counts seconds since the loop began")
    if times[-1] > MAX_TIME_S:
        k = int(np.argmax(times > MAX_TIME_S))
        raise ConfigError(source, f"row {k + 2}", f"{TIME} {times[k]:g}: more than a week since the loop began "
                          "(a clock in another unit?)")
    steps = np.diff(times)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0)) + 1
        raise ConfigError(source, f"row {k + 2}", f"{TIME} does not increase")
    if not len(steps):
        return
    tick = meta.get("tick_s")
    if isinstance(tick, bool) or not isinstance(tick, (int, float)) or not 0 < tick < MAX_TIME_S:
        tick = float(np.median(steps))
    gaps = np.flatnonzero(steps > (GAP_TICKS + 0.5) * tick)
    if len(gaps):
        k = int(gaps[np.argmax(steps[gaps])])
        notes.append(f"{source}: {len(gaps)} gap(s) of more than {GAP_TICKS} ticks without a row, "
                     f"{float(np.sum(steps[gaps])):.3f} s in all; the longest {steps[k]:.3f} s after "
                     f"{TIME} {times[k]:g} (row {k + 2}; the tick is {tick * 1e3:g} ms): the goals are taken "
                     "as held across them, as the loop holds them")


def check_joint_angles(trace: "Trace", joints: Sequence[tuple[str, tuple[float, float]]], source: str) -> None:
    """Refuse a trace whose goal or present angle of a joint lies more than
    ``JOINT_RANGE_MARGIN_RAD`` outside that joint's range ``(name, (low, high))`` [rad]:
    not an angle this robot can take (another robot's trace, another calibration, degrees)."""
    for name, (low, high) in joints:
        for suffix in (GOAL, PRESENT):
            channel = f"{name}{suffix}"
            if channel not in trace:
                continue
            values = trace[channel]
            outside = (values < low - JOINT_RANGE_MARGIN_RAD) | (values > high + JOINT_RANGE_MARGIN_RAD)
            if np.any(outside):
                k = int(np.argmax(outside))
                raise ConfigError(source, f"row {k + 2}", f"{channel}: {values[k]:.6g} rad "
                                  f"({math.degrees(values[k]):.1f} deg) is more than "
                                  f"{math.degrees(JOINT_RANGE_MARGIN_RAD):g} deg outside the joint's range "
                                  f"[{math.degrees(low):.1f}, {math.degrees(high):.1f}] deg (the robot config's "
                                  "range_deg): not an angle this robot takes")


def _read_sidecar(path: Path, notes: list[str]) -> dict[str, Any]:
    """The sidecar's JSON object, read as controller files are: a regular file of at most
    ``MAX_SIDECAR_BYTES`` (:mod:`sim2real.input_files`), brackets nested at most as deep as a
    controller's (scanned before decoding), no key twice in one object."""
    from sim2real.controller.json_reader import MAX_DEPTH, DuplicateKey, nesting_depth, unique_keys  # no MuJoCo there either

    sidecar = sidecar_path(path)
    if not sidecar.exists():
        notes.append(f"{path}: no sidecar {sidecar.name} (the trace's metadata)")
        return {}
    source = str(sidecar)
    raw = read_regular_bytes(sidecar, limit=MAX_SIDECAR_BYTES, what="trace sidecar")  # a FIFO refused unopened
    depth, line = nesting_depth(raw)  # scanned before decoding, so that decoding cannot recurse
    if depth > MAX_DEPTH:
        raise ConfigError(source, "", f"not a trace sidecar: JSON nested {depth} levels deep (line {line}); at most "
                          f"{MAX_DEPTH}")
    try:
        meta = json.loads(raw.decode("utf-8"), object_pairs_hook=unique_keys)
    except DuplicateKey as exc:
        key = exc.args[0] if len(exc.args[0]) <= 40 else exc.args[0][:37] + "..."
        raise ConfigError(source, "", f"key {key!r} appears twice in one object (JSON keys must be unique)") from None
    except ValueError as exc:  # not UTF-8, not JSON, an integer of thousands of digits
        raise ConfigError(source, "", f"not a trace sidecar (JSON): {str(exc).split(';')[0][:120]}") from None
    except RecursionError:  # not reached after the depth scan; the last guard
        raise ConfigError(source, "", "not a trace sidecar: JSON nested too deep") from None
    if not isinstance(meta, dict):
        raise ConfigError(source, "", "not a trace sidecar: must hold a JSON object")
    return meta
