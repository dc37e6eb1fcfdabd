"""One run per folder: an exclusive lock on a run folder, held while a process works in it.

Two ``biped evolve --out runs/x`` (or two ``--resume``) at once used to both run, each
appending every generation to the same ``stats.csv`` and overwriting the other's
checkpoints.  :class:`RunLock` takes ``fcntl.flock(LOCK_EX | LOCK_NB)`` on ``runs/x/.lock``
and writes its process id there; a second process is refused at once with the folder and
that id (:class:`RunFolderBusy`).  The kernel drops the lock with the last descriptor of the
file, so a process that dies in any way, SIGKILL included, frees the folder: there is no
stale lock to remove by hand.  The lock file itself stays (removing it would race a process
that has just opened it).  The lock is on the file, so another name for the same folder (a
symbolic link, a relative path) meets it too.

    lock = RunLock.acquire(Path("runs/x"))   # RunFolderBusy if another process holds it
    ...                                       # every write into runs/x
    lock.release()                            # or: with RunLock.acquire(folder): ...

``flock`` locks belong to the open file, not the process: a second ``acquire`` of the same
folder in the same process is refused too, until the first is released.
"""

from __future__ import annotations

import errno
import fcntl
import os
import stat
from pathlib import Path

from sim2real.errors import UsageError

LOCK_NAME = ".lock"


class RunFolderBusy(UsageError):
    """Another process (or another, unreleased lock in this one) holds the run folder."""


class RunLock:
    """An exclusive ``flock`` on ``folder/.lock`` (see the module docstring)."""

    def __init__(self, folder: Path, fd: int):
        self.folder, self._fd = folder, fd

    @classmethod
    def acquire(cls, folder: Path | str) -> "RunLock":
        """Lock the existing ``folder`` for this process and write its id into the lock file;
        :class:`RunFolderBusy` naming the holder's id when it is taken."""
        folder = Path(folder)
        path = folder / LOCK_NAME
        try:  # O_NOFOLLOW: a symlink planted as the lock file is refused, not followed
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW | os.O_NONBLOCK, 0o644)
        except OSError as exc:
            why = "is a symbolic link" if exc.errno == errno.ELOOP else f"cannot be opened: {exc.strerror or exc}"
            raise UsageError(f"{folder}: cannot lock the run folder: {path} {why}") from None
        if not stat.S_ISREG(os.fstat(fd).st_mode):  # a FIFO or a device planted there: no lock file
            os.close(fd)
            raise UsageError(f"{folder}: cannot lock the run folder: {path} is not a regular file")
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            holder = _holder(fd)
            os.close(fd)
            if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN):
                raise
            raise RunFolderBusy(f"{folder}: another run is working in this folder ({holder}); two runs in one "
                                "folder would mix their generations. Wait for it to end (or stop it), or give "
                                "another --out") from None
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        except OSError:  # a full disk: the lock holds all the same, only the id is not shown
            pass
        return cls(folder, fd)

    @property
    def held(self) -> bool:
        return self._fd is not None

    def release(self) -> None:
        """Unlock (idempotent).  The pid stays in the file; only a held lock makes it count."""
        if self._fd is not None:
            fd, self._fd = self._fd, None
            os.close(fd)  # closing the last descriptor drops the flock

    def __enter__(self) -> "RunLock":
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def __del__(self) -> None:  # a lock forgotten by its owner is freed with it
        try:
            self.release()
        except Exception:  # noqa: BLE001 - at interpreter exit os may be gone; the kernel frees it then
            pass


def _holder(fd: int) -> str:
    """Who holds the lock, in words: the process id its holder wrote."""
    try:
        text = os.pread(fd, 64, 0).decode("ascii", "replace").strip()
    except OSError:
        text = ""
    if text.isdigit():
        pid = int(text)
        return "process id " + text + (", this process" if pid == os.getpid() else "")
    return "process id not yet written"
