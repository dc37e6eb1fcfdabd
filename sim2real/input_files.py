"""Input files: every file a command reads must be a regular file, checked before it is opened.

Opening a named pipe (FIFO) for reading waits until some writer opens it - forever, if none
does: ``biped run FIFO`` hung.  A character device such as ``/dev/zero`` never ends, a
serial port may be a robot's bus (opening it can toggle its control lines), a directory or a
socket is no file at all.  So readers check the path first (``stat``, which opens nothing),
and open it without blocking and check the opened file again (the path could have been
swapped since):

    raw = read_regular_bytes(path, limit=4 << 20)   # ConfigError naming the file otherwise
    check_regular_file(path)                        # before handing the path to a library
    refuse_repeats(traces, "trace")                 # one file given twice, or a copy of it
    file_sha256(walker)                             # what a record keeps of the file it used

No MuJoCo here; :func:`sim2real.robot.validation.load_yaml` and the command-line types of
:mod:`sim2real.arg_types` and :mod:`sim2real.cli.args` use it too.
"""

from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path
from typing import BinaryIO, Sequence

from sim2real.errors import ConfigError, UsageError

_CHUNK_BYTES = 1 << 20  # read at a time when hashing a file


def kind_problem(mode: int) -> str | None:
    """Why a file of this ``st_mode`` is no input file, or None for a regular file."""
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "is a directory, not a file"
    if stat.S_ISFIFO(mode):
        return "is a named pipe (FIFO), not a regular file: reading it would wait for a writer, perhaps forever"
    if stat.S_ISCHR(mode):
        return "is a character device, not a regular file (a device such as /dev/zero never ends)"
    if stat.S_ISBLK(mode):
        return "is a block device, not a regular file"
    if stat.S_ISSOCK(mode):
        return "is a socket, not a regular file"
    return "is not a regular file"


def regular_file_problem(path: Path | str) -> str | None:
    """Why ``path`` cannot be read as an input file (missing, not a regular file, not
    readable), or None.  Opens nothing: a FIFO or a device is refused unopened."""
    try:
        mode = os.stat(path).st_mode
    except OSError as exc:
        return f"cannot read: {exc.strerror or exc}"
    problem = kind_problem(mode)
    if problem is None and not os.access(path, os.R_OK):
        return "cannot read: Permission denied"
    return problem


def check_regular_file(path: Path | str, source: str | None = None) -> Path:
    """``path``, or :class:`ConfigError` naming ``source`` (default: the path) when it is not
    a regular file that can be read."""
    problem = regular_file_problem(path)
    if problem is not None:
        raise ConfigError(source or str(path), "", problem)
    return Path(path)


def open_regular(path: Path | str, source: str | None = None) -> BinaryIO:
    """``path`` opened for reading in binary, checked to be a regular file before and after
    opening; :class:`ConfigError` naming ``source`` otherwise."""
    source = source or str(path)
    check_regular_file(path, source)
    try:  # O_NONBLOCK: a FIFO put in the path's place since the check opens without waiting
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY | os.O_CLOEXEC)
    except OSError as exc:
        raise ConfigError(source, "", f"cannot read: {exc.strerror or exc}") from None
    problem = kind_problem(os.fstat(fd).st_mode)
    if problem is not None:
        os.close(fd)
        raise ConfigError(source, "", problem)
    os.set_blocking(fd, True)
    return os.fdopen(fd, "rb")


def read_regular_bytes(path: Path | str, source: str | None = None, limit: int | None = None,
                       what: str = "file") -> bytes:
    """The bytes of the regular file ``path``; with ``limit``, a larger file is refused
    unread (``what`` names its kind in the message: "controller", "trace", ...)."""
    source = source or str(path)
    with open_regular(path, source) as f:
        try:
            if limit is not None:
                size = os.fstat(f.fileno()).st_size
                if size > limit:
                    raise ConfigError(source, "", f"{size} bytes is too large for a {what} (at most {limit} bytes)")
                raw = f.read(limit + 1)  # a file growing while it is read stops at the limit
                if len(raw) > limit:
                    raise ConfigError(source, "", f"more than {limit} bytes is too large for a {what}")
                return raw
            return f.read()
        except OSError as exc:
            raise ConfigError(source, "", f"cannot read: {exc.strerror or exc}") from None


def decode_utf8(raw: bytes, source: str, what: str) -> str:
    """``raw`` as UTF-8 text, or a :class:`ConfigError` naming ``source``, the first byte that is
    not UTF-8 and its line, as ``what`` (e.g. "not a YAML file: binary, or not UTF-8 text")."""
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise ConfigError(source, "", f"{what}: byte 0x{raw[exc.start]:02x} at line {line} (offset {exc.start})") from None


def file_sha256(path: Path | str) -> str:
    """The SHA-256 of a regular file's bytes, in hex, read in chunks (:func:`open_regular`; a
    clear :class:`ConfigError` naming the file otherwise)."""
    source = str(path)
    digest = hashlib.sha256()
    with open_regular(path, source) as f:
        try:
            for chunk in iter(lambda: f.read(_CHUNK_BYTES), b""):
                digest.update(chunk)
        except OSError as exc:
            raise ConfigError(source, "", f"cannot read: {exc.strerror or exc}") from None
    return digest.hexdigest()


def refuse_repeats(paths: Sequence[Path | str], what: str = "file") -> None:
    """:class:`UsageError` when two of ``paths`` are one file (the same path, a link and its
    target: the same real path) or hold the same bytes (a copy): a command that takes several
    inputs (``biped sysid T.csv T.csv``) would count that one twice.  Each is read once, in
    chunks, as a regular file (:func:`open_regular`)."""
    by_path: dict[str, str] = {}
    by_content: dict[str, str] = {}
    for path in paths:
        source = str(path)
        real = os.path.realpath(path)
        if real in by_path:
            raise UsageError(f"{source}: the {what} {by_path[real]} again (one file, given twice): give each "
                             f"{what} once")
        by_path[real] = source
        key = file_sha256(path)
        if key in by_content:
            raise UsageError(f"{source}: the same bytes as {by_content[key]} (a copy of that {what}): give each "
                             f"{what} once")
        by_content[key] = source
