"""Running a piece of a test as an unprivileged user, for the cases root cannot see.

    result = as_unprivileged(lambda: biped_captured(argv))

Root reads a file whatever its mode, so a test of the "unreadable file" refusal, run by a
suite that runs as root (CI containers, this project's machine), proves nothing unless the
command runs as someone else.  :func:`as_unprivileged` forks, drops the child to ``nobody``
(uid and gid 65534, no supplementary groups, so no capability is left), runs the function
there and hands its result back; as an ordinary user it just runs it.

Fork, not a new interpreter: the interpreter may live where ``nobody`` cannot reach (here,
under ``/root/.pyenv``).  For the same reason the child should import nothing it has not
inherited: every module of the project, and the optional packages its commands check for
(:data:`OPTIONAL`), are imported before the fork (:func:`import_everything`).  A command that
comes to import some other module lazily fails in the child with that module's
``PermissionError`` - loudly, never by passing.  Files the child reads or writes go in a folder
it can reach (:func:`open_folder`): pytest's own temporary folders are root's alone (mode 700).
"""

from __future__ import annotations

import contextlib
import importlib
import io
import os
import pickle
import pkgutil
import shutil
import signal
import tempfile
import time
import traceback
from pathlib import Path
from typing import Callable, Iterator, TypeVar

T = TypeVar("T")
NOBODY = 65534  # uid and gid of nobody/nogroup on Debian-like systems
AS_ROOT = os.geteuid() == 0
TIMEOUT_S = 60.0
OPTIONAL = ("mujoco.sysid", "scipy.optimize", "matplotlib.pyplot", "networkx", "imageio")  # imported when installed
_imported = False


def import_everything() -> None:
    """Import every module of ``evolve`` and ``sim2real`` (and what they import), once."""
    global _imported
    if _imported:
        return
    import evolve
    import sim2real

    for package in (evolve, sim2real):
        for module in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
            if not module.name.endswith("__main__"):
                importlib.import_module(module.name)
    for name in OPTIONAL:
        try:
            importlib.import_module(name)
        except ImportError:  # not installed: the command says so, as it would anywhere
            pass
    _imported = True


@contextlib.contextmanager
def open_folder() -> Iterator[Path]:
    """A new folder under the system's temporary folder that every user can enter and write
    in (mode 777: a command's outputs go there as they would in the user's own folder; the
    files in it as their modes say), removed afterwards."""
    folder = Path(tempfile.mkdtemp(prefix="biped-unprivileged-"))
    try:
        folder.chmod(0o777)
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def as_unprivileged(function: Callable[[], T]) -> T:
    """``function()`` run as ``nobody`` in a forked child when this process is root (else
    here); its result (picklable) or its exception's traceback, as an ``AssertionError``."""
    if not AS_ROOT:
        return function()
    import_everything()
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        status = 1
        try:
            os.close(read_end)
            os.setgroups([])
            os.setgid(NOBODY)
            os.setuid(NOBODY)  # last: after it nothing can be changed back
            try:
                payload = pickle.dumps((True, function()))
                status = 0
            except BaseException:  # noqa: BLE001 - reported to the parent, whatever it was
                payload = pickle.dumps((False, traceback.format_exc()))
            with os.fdopen(write_end, "wb") as out:
                out.write(payload)
        finally:
            os._exit(status)
    os.close(write_end)
    deadline = time.monotonic() + TIMEOUT_S
    with os.fdopen(read_end, "rb") as pipe:
        data = _read_until(pipe, pid, deadline)
    _, status = os.waitpid(pid, 0)
    if not data:
        raise AssertionError(f"the unprivileged child ended with status {status} and no result")
    ok, value = pickle.loads(data)
    if not ok:
        raise AssertionError(f"in the unprivileged child:\n{value}")
    return value


def _read_until(pipe: io.BufferedReader, pid: int, deadline: float) -> bytes:
    """All the child writes; the child killed if it has not finished by ``deadline``."""
    import select

    chunks = []
    while True:
        left = deadline - time.monotonic()
        ready, _, _ = select.select([pipe], [], [], max(0.0, left))
        if not ready:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            raise AssertionError(f"the unprivileged child did not finish in {TIMEOUT_S:.0f} s")
        chunk = os.read(pipe.fileno(), 65536)
        if not chunk:
            return b"".join(chunks)
        chunks.append(chunk)


def captured(function: Callable[[], int]) -> tuple[int, str, str]:
    """(exit code, standard output, standard error) of ``function()`` (a CLI's main), with
    ``SystemExit`` taken as its code."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = function()
        except SystemExit as exc:
            code = exc.code
    return code, out.getvalue(), err.getvalue()
