"""A trace CSV's rows as numbers, read in chunks: bounded memory and numpy's C parser.

A trace of an hour at 100 Hz is ~120 MB of text.  Read whole and split into Python lists of
strings and floats it took 1.7 GB and two minutes; here the file is read ``CHUNK_BYTES`` at a
time, each chunk cut at its last end of line and parsed by ``numpy.loadtxt`` (C code) into one
array allocated for every row (the rows are counted first, by their ends of line).  Peak memory
is that array and a chunk; a file larger than ``MAX_TRACE_BYTES`` is refused unread.

:func:`read_rows_plain` - the whole text, field by field with the csv module and ``float`` - is
the reference.  A chunk numpy cannot read alone (a blank line, quotes, a cell that is no
number, a row of another length) is parsed again field by field, so that every error names
its row and column as the reference does, and tests hold the fast path to it.

    header, values, cut = read_rows(path, source)   # values (rows, columns); cut: last row dropped
"""

from __future__ import annotations

import csv
import math
import os
import warnings
from pathlib import Path
from typing import BinaryIO, Callable, Sequence

import numpy as np

from sim2real.errors import ConfigError
from sim2real.input_files import open_regular, read_regular_bytes

# The largest trace read [bytes]: a week at the robot's 34 ms tick, or over eight hours of
# excite's 100 Hz, every joint; its numbers take about as many bytes again in memory.
MAX_TRACE_BYTES = 1 << 30
CHUNK_BYTES = 4 << 20  # read and parsed at a time: a few MB keep numpy's parser fast and the memory flat
MAX_LINE_BYTES = 1 << 20  # a row: a few hundred bytes (~10 a value); a "line" of a MB has lost its ends of line

Rows = tuple[list[str], np.ndarray, bool]  # header, values (rows, columns), a cut last row dropped
HeaderCheck = Callable[[list[str]], None]  # raises ConfigError for a header that is no trace's


def _decoded(raw: bytes, source: str) -> str:
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = "\0"
    if "\0" in text:
        raise ConfigError(source, "", "not a trace: a binary file, not CSV text")
    return text


def _parse(rows: Sequence[Sequence[str]], header: Sequence[str], source: str, first_row: int) -> np.ndarray:
    """csv ``rows`` as an array (rows, len(header)), field by field; :class:`ConfigError`
    naming the file row (``first_row``: the file row of ``rows[0]``, the header is row 1)."""
    width = len(header)
    values = np.empty((len(rows), width))
    for k, row in enumerate(rows):
        if len(row) != width:
            raise ConfigError(source, f"row {first_row + k}", f"has {len(row)} fields, the header {width}")
        for j, cell in enumerate(row):
            try:
                values[k, j] = float(cell)
            except ValueError:
                values[k, j] = math.nan
            if not math.isfinite(values[k, j]):
                raise ConfigError(source, f"row {first_row + k}", f"{header[j]}: {cell!r} is not a finite number")
    return values


def _header(rows: list[list[str]], source: str) -> list[str]:
    header = rows[0] if rows else []
    if len(set(header)) != len(header) or not all(header):
        raise ConfigError(source, "header", "column names must be unique and non-empty")
    return header


def read_rows_plain(path: Path | str, source: str, check_header: HeaderCheck = lambda header: None) -> Rows:
    """The reference reader: the whole file in memory, split into lines, every field parsed
    with ``float`` (slow: two minutes and 1.7 GB for 120 MB).  What :func:`read_rows` reads."""
    text = _decoded(read_regular_bytes(path, source), source)
    if not text.strip():
        raise ConfigError(source, "", "the trace is empty (no header row)")
    lines = text.splitlines(keepends=True)
    rows = list(csv.reader(lines))
    while len(rows) > 1 and not rows[-1]:  # blank lines at the end
        rows.pop()
        lines.pop()
    header, rows = _header(rows, source), rows[1:]
    check_header(header)
    cut = bool(rows) and (not lines[-1].endswith(("\n", "\r")) or len(rows[-1]) < len(header))
    if cut:
        rows.pop()
    return header, _parse(rows, header, source, 2), cut


def read_rows(path: Path | str, source: str, check_header: HeaderCheck = lambda header: None) -> Rows:
    """What :func:`read_rows_plain` reads - the header, the rows, and whether a last row cut
    short (no end of line, or too few fields: what a run killed mid-write leaves) was dropped -
    in chunks, in bounded memory.  :class:`ConfigError` naming ``source`` for a file that is
    not a regular file, larger than ``MAX_TRACE_BYTES``, binary, empty, with a header of names
    not unique and non-empty, a line longer than ``MAX_LINE_BYTES``, or a row the reference
    refuses; ``check_header(header)`` is called before any row is read."""
    with open_regular(path, source) as f:
        size = os.fstat(f.fileno()).st_size
        if size > MAX_TRACE_BYTES:
            raise ConfigError(source, "", f"{size / 2**20:.0f} MB is too large for a trace (at most "
                              f"{MAX_TRACE_BYTES / 2**20:.0f} MB, {MAX_TRACE_BYTES} bytes: cut it into parts)")
        try:
            return _read(f, source, check_header)
        except OSError as exc:
            raise ConfigError(source, "", f"cannot read: {exc.strerror or exc}") from None


def _count_lines(f: BinaryIO) -> int:
    """Ends of line (``\\n``) from the current position on, a chunk at a time."""
    count = 0
    while chunk := f.read(CHUNK_BYTES):
        count += chunk.count(b"\n")
    return count


def _fast(lines: list[str], width: int) -> np.ndarray | None:
    """``lines`` parsed by numpy, or None where that might differ from the reference: blank
    lines (numpy skips them), quotes, anything it refuses, a value not finite."""
    if any(not line or '"' in line for line in lines):
        return None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            values = np.loadtxt(lines, delimiter=",", dtype=float, comments=None, ndmin=2)
    except ValueError:
        return None
    if values.shape != (len(lines), width) or not np.isfinite(values).all():
        return None
    return values


def _read(f: BinaryIO, source: str, check_header: HeaderCheck) -> Rows:
    first = f.readline(MAX_LINE_BYTES + 1)
    if len(first) > MAX_LINE_BYTES:
        raise ConfigError(source, "header", f"longer than {MAX_LINE_BYTES} bytes: not a trace's header")
    head = _decoded(first, source)
    if not head.strip():  # a blank first line: the file may still hold text further on
        rest = f.read(MAX_LINE_BYTES)
        if not _decoded(rest, source).strip() and not f.read(1):
            raise ConfigError(source, "", "the trace is empty (no header row)")
        f.seek(len(first))
    header = _header(list(csv.reader([head])), source)
    check_header(header)
    width, start = len(header), f.tell()
    values = np.empty((_count_lines(f) + 1, width))  # + a last row without an end of line
    f.seek(start)
    filled, row = 0, 2  # rows parsed; the file row of the next line to parse (the header is row 1)
    pending: list[str] = []  # the last non-blank line so far and blank lines after it: maybe the end
    carry = b""
    while chunk := f.read(CHUNK_BYTES):
        data = carry + chunk
        end = data.rfind(b"\n") + 1
        carry = data[end:]
        if len(carry) > MAX_LINE_BYTES:
            raise ConfigError(source, f"row {row + len(pending)}", f"longer than {MAX_LINE_BYTES} bytes without "
                              "an end of line: not a trace's row")
        if not end:
            continue
        lines = pending + _decoded(data[:end], source).splitlines()
        last = max((k for k, line in enumerate(lines) if line), default=len(lines))
        body, pending = lines[:last], lines[last:]
        parsed = _fast(body, width)
        if parsed is None:
            parsed = _parse(list(csv.reader(body)), header, source, row)
        values = _put(values, filled, parsed)
        filled, row = filled + len(body), row + len(body)
    # the end, by the reference's rules: blank lines dropped, then a last row without an end
    # of line or with too few fields (the pending lines had theirs: "\n" stands for it)
    lines = ("".join(line + "\n" for line in pending) + _decoded(carry, source)).splitlines(keepends=True)
    rows = list(csv.reader(lines))
    while rows and not rows[-1]:
        rows.pop()
        lines.pop()
    cut = bool(rows) and (not lines[-1].endswith(("\n", "\r")) or len(rows[-1]) < width)
    if cut:
        rows.pop()
    values = _put(values, filled, _parse(rows, header, source, row))
    return header, values[:filled + len(rows)], cut


def _put(values: np.ndarray, at: int, rows: np.ndarray) -> np.ndarray:
    """``rows`` written into ``values`` from row ``at``; grown first in the rare file whose
    lines end in breaks other than ``\n`` too (form feeds, ``\r`` alone: more rows than counted)."""
    if at + len(rows) > len(values):
        values = np.concatenate([values[:at], np.empty((at + len(rows) - at, values.shape[1]))])
    values[at:at + len(rows)] = rows
    return values
