"""Atomic output files (checkpoints, controllers, reports, pictures, videos): written to a
temporary file beside the target, then renamed.

A reader never sees half a file, and a crash or a full disk mid-write leaves the previous
file intact (or no file at all): never a 0-byte or truncated one.  A write that fails - the
disk full (ENOSPC), over a quota, read-only, the file too large - raises
:class:`OutputError`, an ``OSError`` whose message names the file, so every command ends
with one line ``biped: error: cannot write FILE: No space left on device (...)``.

    write_text_atomic("robot.xml", xml)              # str (UTF-8)
    write_bytes_atomic("image.png", raw)             # bytes
    with atomic_output("walk.mp4") as tmp:           # a library that wants a path to write
        imageio.imwrite(tmp, frames)                 # (tmp ends in .mp4 too)
    copy_file_atomic(src, dst)

Names ending in ``.gz`` are gzip-compressed by the text/JSON writers.  Data only: never pickle.
"""

from __future__ import annotations

import contextlib
import errno
import gzip
import json
import os
import tempfile
from pathlib import Path
from typing import Any, Iterator

from sim2real.input_files import read_regular_bytes


class OutputError(OSError):
    """An output file could not be written (it is left as it was, or absent): the
    ``errno`` and ``strerror`` of the failure, and the file in ``filename``."""

    def __init__(self, path: Path | str, cause: OSError, kept: str = "nothing was written"):
        super().__init__(cause.errno, cause.strerror or str(cause), str(path))
        self.kept = kept

    def __str__(self) -> str:
        hint = " (is the disk full?)" if self.errno in (errno.ENOSPC, errno.EDQUOT) else ""
        return f"cannot write {self.filename}: {self.strerror}{hint}; {self.kept}"


def write_json_atomic(path: Path | str, data: Any) -> None:
    write_text_atomic(path, json.dumps(data, separators=(",", ":")))


def write_text_atomic(path: Path | str, text: str) -> None:
    """``text`` as UTF-8 (gzip-compressed for a name ending in ``.gz``), atomically."""
    path = Path(path)
    raw = text.encode()
    if path.suffix == ".gz":
        raw = gzip.compress(raw, compresslevel=6, mtime=0)
    write_bytes_atomic(path, raw)


def write_bytes_atomic(path: Path | str, raw: bytes) -> None:
    """``raw`` into ``path``, atomically (parent folders created)."""
    with atomic_output(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(raw)


def copy_file_atomic(source: Path | str, target: Path | str) -> None:
    """A copy of ``source`` at ``target``, atomically: a full disk leaves no half copy."""
    with atomic_output(target) as tmp:
        with open(source, "rb") as src, open(tmp, "wb") as dst:
            while chunk := src.read(1 << 20):
                dst.write(chunk)


@contextlib.contextmanager
def atomic_output(path: Path | str) -> Iterator[Path]:
    """A temporary path beside ``path`` (hidden, ending in the same suffix, so that writers
    choosing a format by the name still do) to write the whole output to; on success it is
    flushed to the disk and renamed onto ``path``.  On any failure the temporary file is
    removed and ``path`` left as it was; an ``OSError`` becomes :class:`OutputError` naming
    ``path``."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=f".tmp{path.suffix}")
        os.close(fd)
    except OSError as exc:
        raise OutputError(path, exc) from exc
    tmp = Path(name)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp's 0600 would make every output private
        _fsync(tmp)
        os.replace(tmp, path)
    except BaseException as exc:
        tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError) and not isinstance(exc, OutputError):
            kept = ("it is a directory" if path.is_dir() else
                    "the previous file is kept" if path.exists() else "nothing was written")
            raise OutputError(path, exc, kept) from exc
        raise


def _umask() -> int:
    """The process's file-creation mask, read without changing it (os.umask would, for a
    moment, for every thread)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    return 0o022


def _fsync(path: Path) -> None:
    """The file's data on the disk before the rename (a crash then leaves the old or the
    new file, never an empty one; a full disk surfaces here at the latest)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def read_json(path: Path | str) -> Any:
    """JSON (gzip-compressed for a name ending in ``.gz``) from a regular file."""
    path = Path(path)
    raw = read_regular_bytes(path)
    if path.suffix == ".gz":
        raw = gzip.decompress(raw)
    return json.loads(raw)
