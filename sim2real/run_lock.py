"""One writer per output: an exclusive lock on a run folder, or on a named output file, held
while a process writes there.

Two ``biped evolve --out runs/x`` (or two ``polish --out``, two ``excite --trace t.csv``) at
once used to both run, each overwriting the other's files.  :class:`RunLock` takes
``fcntl.flock(LOCK_EX | LOCK_NB)`` on a lock file - ``runs/x/.lock`` for a folder,
``.t.csv.lock`` beside a named output (its sidecar, named after it, is covered too) - and
writes its process id there; a second process is refused at once with the folder or file and
that id (:class:`RunFolderBusy`).  The kernel drops the lock with the last descriptor of the
file, so a process that dies in any way, SIGKILL included, frees it: a lock file left by a
dead process (a stale pid) does not block.  The lock is on the file, so another name for the
same folder (a symbolic link, a relative path) meets it too.

    lock = RunLock.acquire(Path("runs/x"), what="biped polish")  # RunFolderBusy if taken
    ...                                                           # every write into runs/x
    lock.release()                                                # or: with RunLock.acquire(...):

    with RunLock.acquire_output(Path("t.csv"), what="biped excite", flag="--trace"):
        ...                                                       # write t.csv and t.json

:meth:`release` removes the lock file (and a folder ``create=True`` made, if nothing else was
written into it).  That is safe because :meth:`acquire` checks, once it holds the lock, that
the name still leads to the file it locked; a process that locked a file just removed tries
again on the new one.  ``flock`` locks belong to the open file, not the process: a second
``acquire`` of the same folder in the same process is refused too, until the first is
released (a caller that holds the lock hands it down, as ``adapt`` does to its run).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import functools
import inspect
import os
import stat
from pathlib import Path
from typing import Any, Callable, ContextManager, TypeVar

from sim2real.errors import UsageError

LOCK_NAME = ".lock"
ATTEMPTS = 5  # each lost only to a release that removed the file between our open and flock
F = TypeVar("F", bound=Callable[..., Any])


class RunFolderBusy(UsageError):
    """Another process (or another, unreleased lock in this one) holds the folder or output."""


class RunLock:
    """An exclusive ``flock`` on a lock file (see the module docstring)."""

    def __init__(self, folder: Path, fd: int, path: Path, created: tuple[Path, ...] = ()):
        self.folder, self._fd, self.path, self._created = folder, fd, path, created

    @classmethod
    def acquire(cls, folder: Path | str, *, what: str = "run", flag: str = "--out",
                create: bool = False) -> "RunLock":
        """Lock ``folder`` (created first, parents too, with ``create``) for this process and
        write its id into ``folder/.lock``; :class:`RunFolderBusy` naming the folder and the
        holder's id when it is taken.  ``what`` (e.g. "biped polish") and ``flag`` word the
        refusal."""
        folder = Path(folder)
        created: list[Path] = []
        if create:
            for parent in reversed((folder, *folder.parents)):
                if not os.path.lexists(parent):
                    try:
                        os.mkdir(parent)
                    except FileExistsError:  # made by another process just now: it is not ours to remove
                        continue
                    created.append(parent)
        try:
            return cls._take(folder, folder / LOCK_NAME, tuple(created),
                             busy=f"{folder}: another {what} is working in this folder",
                             advice=f"two in one folder would overwrite each other's files. Wait for it to end "
                             f"(or stop it), or give another {flag}",
                             cannot=f"{folder}: cannot lock the folder")
        except BaseException:
            _remove_empty(tuple(created))
            raise

    @classmethod
    def acquire_output(cls, path: Path | str, *, what: str, flag: str) -> "RunLock":
        """Lock the named output file ``path`` (in an existing folder) for this process: the
        lock file is ``.NAME.lock`` beside it; :class:`RunFolderBusy` naming ``path`` and the
        holder's id when another process is writing it."""
        path = Path(path)
        return cls._take(path.parent, path.parent / f".{path.name}.lock", (),
                         busy=f"{path}: another {what} is writing this file",
                         advice=f"two at once would overwrite each other. Wait for it to end (or stop it), or "
                         f"give another {flag}",
                         cannot=f"{path}: cannot lock the output")

    @classmethod
    def _take(cls, folder: Path, path: Path, created: tuple[Path, ...], busy: str, advice: str,
              cannot: str) -> "RunLock":
        for _ in range(ATTEMPTS):
            try:  # O_NOFOLLOW: a symlink planted as the lock file is refused, not followed
                fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW | os.O_NONBLOCK, 0o644)
            except OSError as exc:
                why = "is a symbolic link" if exc.errno == errno.ELOOP else f"cannot be opened: {exc.strerror or exc}"
                raise UsageError(f"{cannot}: {path} {why}") from None
            if not stat.S_ISREG(os.fstat(fd).st_mode):  # a FIFO or a device planted there: no lock file
                os.close(fd)
                raise UsageError(f"{cannot}: {path} is not a regular file")
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                holder = _holder(fd)
                os.close(fd)
                if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN):
                    raise
                raise RunFolderBusy(f"{busy} ({holder}); {advice}") from None
            if _same_file(fd, path):
                break
            os.close(fd)  # its holder removed it on release after we opened it: lock the new one
        else:
            raise RunFolderBusy(f"{busy} (its lock file {path} keeps changing); {advice}")
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        except OSError:  # a full disk: the lock holds all the same, only the id is not shown
            pass
        return cls(folder, fd, path, created)

    @property
    def held(self) -> bool:
        return self._fd is not None

    def release(self) -> None:
        """Unlock (idempotent): remove the lock file while still holding it, then close it
        (closing the last descriptor drops the flock); then remove the folders ``create``
        made if they are empty."""
        if self._fd is not None:
            fd, self._fd = self._fd, None
            try:
                if _same_file(fd, self.path):
                    os.unlink(self.path)
            except OSError:  # a read-only folder now: the lock file stays, and blocks no one
                pass
            os.close(fd)
            _remove_empty(self._created)

    def __enter__(self) -> "RunLock":
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def __del__(self) -> None:  # a lock forgotten by its owner is freed with it
        try:
            self.release()
        except Exception:  # noqa: BLE001 - at interpreter exit os may be gone; the kernel frees it then
            pass


def output_lock(path: Path | str | None, *, what: str, flag: str) -> ContextManager[RunLock | None]:
    """:meth:`RunLock.acquire_output` as a context manager; nothing to lock when ``path`` is
    None (a run without ``--trace``)."""
    return contextlib.nullcontext() if path is None else RunLock.acquire_output(path, what=what, flag=flag)


def _same_file(fd: int, path: Path) -> bool:
    """Whether ``path`` still names the open file ``fd`` (not removed, not replaced)."""
    try:
        now = os.stat(path, follow_symlinks=False)
    except OSError:
        return False
    held = os.fstat(fd)
    return (now.st_dev, now.st_ino) == (held.st_dev, held.st_ino)


def _remove_empty(folders: tuple[Path, ...]) -> None:
    """Remove those of ``folders`` (made by this lock, outermost first) that are empty,
    innermost first: a command that wrote nothing leaves no empty folder behind."""
    for folder in reversed(folders):
        try:
            os.rmdir(folder)
        except OSError:  # not empty (something was written), or gone: keep the rest
            return


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



def holds_folder(param: str, *, what: str, flag: str = "--out") -> Callable[[F], F]:
    """Decorate a function that writes a folder: each call holds :meth:`RunLock.acquire` on
    its argument ``param`` (the folder, made if missing and removed again if left empty)
    from start to end, so that a second call into the same folder, in another process, is
    refused before it reads or writes anything there.  A function with a ``lock``
    parameter is handed the held lock (to pass on, e.g. to :meth:`evolve.run.Run.create`)."""

    def decorate(fn: F) -> F:
        signature = inspect.signature(fn)
        hands_down = "lock" in signature.parameters

        @functools.wraps(fn)
        def locked(*args: Any, **kwargs: Any) -> Any:
            folder = signature.bind(*args, **kwargs).arguments[param]
            with RunLock.acquire(folder, what=what, flag=flag, create=True) as lock:
                return fn(*args, **({**kwargs, "lock": lock} if hands_down else kwargs))

        return locked  # type: ignore[return-value]

    return decorate
