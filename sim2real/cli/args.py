"""Checked command-line values, shared by every ``biped`` subcommand.

Flags get a typed converter (``type=int_within(1, 64)``, ``type=output_file(".csv")``): it turns
the text into the value or raises ``argparse.ArgumentTypeError``, so argparse prints the
usage and ``biped <command>: error: argument --flag: <problem>`` and exits 2 before
anything runs.  Checks that need more than one flag's text - a robot's baud rates, a
controller's tick, a default path - raise :class:`UsageError`, which ``biped`` prints as
one line, ``biped: error: <problem>``, exit 2.  A run that started but did not end as
asked reports with :func:`run_failed`: one line, exit 1.

    run.add_argument("--duration", type=positive_float_at_most(MAX_TIME_S, "a week"))
    run.add_argument("--trace", type=output_file(".csv", exclude=(".json",)))

Used by :mod:`sim2real.cli.robot_commands`, :mod:`sim2real.cli.view_commands`, :mod:`sim2real.cli.deploy_commands`,
:mod:`evolve.cli_commands` and :mod:`evolve.quickstart_cli`.  The converters of values (numbers, seeds, baud rates, real-time
treatment, robot and reality names) live in :mod:`sim2real.arg_types`, below the command line,
which the simulated bus's own process reads its flags with too; they are re-exported here.
No MuJoCo here.
"""

from __future__ import annotations

import argparse
import functools
import io
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from sim2real.arg_types import (  # the flag values, re-exported: every command takes them from here
    MAX_SEED,
    add_realtime_arguments,
    baud_rate,
    cpu_index,
    float_within,
    input_file_problem,
    int_within,
    positive_float_at_most,
    realtime_flags,
    realtime_request,
    reality_name,
    robot_name,
    rt_priority,
    seed,
)
from sim2real.atomic_json import OutputError
from sim2real.errors import UsageError
from sim2real.input_files import kind_problem

if TYPE_CHECKING:
    from sim2real.robot import RobotSpec

__all__ = [  # its own, then the flag values of sim2real.arg_types
    "MAX_RENDER_PX", "MAX_REPLAY_S", "MAX_SETTLE_S", "MAX_STRIP_FRAMES", "MAX_VIDEO_S", "NamedStdout", "check_baud", "check_duration",
    "check_input_file", "check_output_file", "holding_lock", "output_dir", "output_dir_problem", "output_file",
    "output_file_problem", "print_result", "require_module", "run_failed",
    "MAX_SEED", "add_realtime_arguments", "baud_rate", "cpu_index", "float_within", "input_file_problem",
    "int_within", "positive_float_at_most", "realtime_flags", "realtime_request", "reality_name",
    "robot_name", "rt_priority", "seed",
]

# Replays of a controller (plot gait, render): at most evolution's longest episode
# (evolve.limits.MAX_EPISODE_S; this package never imports evolve) [s].  A video holds every
# frame in memory until it is written (~80 MB a simulated second at 1280 x 720), so a render's
# own --seconds is shorter; a --strip films at most MAX_STRIP_FRAMES moments.
MAX_REPLAY_S = 300.0
MAX_VIDEO_S = 60.0
MAX_STRIP_FRAMES = 50
MAX_RENDER_PX = (1280, 720)  # a render's width, height [px]: simulation.model.parts.OFFSCREEN_SIZE (no MuJoCo here)
MAX_SETTLE_S = 60.0  # simulated seconds a robot stands before its picture (default 1: it is still within a second)


# -- checks of more than one flag ---------------------------------------------------------------
def check_baud(robot: RobotSpec, baud: int, flag: str = "--baud") -> None:
    """Refuse a baud rate that not every device on ``robot``'s bus can be set to."""
    from sim2real.robot.bus_plan import baud_problem, bus_devices

    problem = baud_problem(bus_devices(robot), baud)  # names the devices that cannot take it, by model and protocol
    if problem:
        raise UsageError(f"{flag} {baud}: not a rate every device of {robot.name} supports: {problem}")


def check_duration(seconds: float | None, tick_s: float, flag: str = "--duration") -> None:
    """Refuse a run shorter than one control tick (it would end after no tick at all)."""
    if seconds is not None and round(seconds / tick_s) < 1:
        raise UsageError(f"{flag} {seconds:g}: shorter than one control tick ({tick_s:g} s)")


def check_input_file(text: str) -> None:
    """:func:`input_file_problem` as a :class:`UsageError`, for a name-or-path argument that
    has no checked type (a positional ROBOT that may be a controller instead)."""
    problem = input_file_problem(text)
    if problem is not None:
        raise UsageError(problem)


# -- output paths ----------------------------------------------------------------------------
def _unwritable(folder: Path) -> str | None:
    """Why no file can be created in ``folder`` (an existing directory), or None."""
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        return f"cannot write in {folder}: {exc.strerror or exc}"
    return None


def output_file_problem(path: Path, suffixes: tuple[str, ...] = (), exclude: tuple[str, ...] = ()) -> str | None:
    """Why ``path`` cannot be written as an output file, or None.  Its directory must exist
    and be writable (checked now, so that nothing runs and then fails to write)."""
    suffix = path.suffix.lower()
    if suffixes and suffix not in suffixes:
        ends = " or ".join([", ".join(suffixes[:-1]), suffixes[-1]] if len(suffixes) > 1 else suffixes)
        return f"{path}: the name must end in {ends}"
    if suffix in exclude:
        return f"{path}: the name must not end in {suffix}"
    if path.is_dir():
        return f"{path} is a directory"
    if os.path.exists(path):
        kind = kind_problem(os.stat(path).st_mode)
        if kind is not None:  # outputs go to a new file renamed over the old: never into a FIFO or a device
            return f"{path} {kind}"
    folder = path.parent
    if not folder.exists():
        return f"directory {folder} does not exist"
    if not folder.is_dir():
        return f"{folder} is not a directory"
    if path.exists() and not _writable_file(path):
        return f"{path} is not writable"
    return _unwritable(folder)


def _writable_file(path: Path) -> bool:
    try:
        with open(path, "ab"):
            return True
    except OSError:
        return False


def output_dir_problem(path: Path) -> str | None:
    """Why ``path`` cannot be (created and) written as an output folder, or None."""
    if path.exists():
        return f"{path} is not a directory" if not path.is_dir() else _unwritable(path)
    ancestor = path.parent
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        return f"cannot create {path}: {ancestor} is not a directory"
    return _unwritable(ancestor)


def output_file(*suffixes: str, exclude: tuple[str, ...] = ()) -> Callable[[str], Path]:
    """A converter for a file to write, with one of ``suffixes`` (any if none), none of ``exclude``."""

    def convert(text: str) -> Path:
        path = Path(text)
        problem = output_file_problem(path, tuple(s.lower() for s in suffixes), exclude)
        if problem:
            raise argparse.ArgumentTypeError(problem)
        return path

    convert.__name__ = "output_file"
    return convert


def output_dir(text: str) -> Path:
    """A converter for a folder to write into (created if missing)."""
    path = Path(text)
    problem = output_dir_problem(path)
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return path


def check_output_file(path: Path, flag: str, suffixes: tuple[str, ...] = ()) -> None:
    """:func:`output_file`'s check for a path the command chose (a default, a suffix rule
    that depends on another argument): raises :class:`UsageError` naming ``flag``."""
    problem = output_file_problem(Path(path), tuple(s.lower() for s in suffixes))
    if problem:
        raise UsageError(f"{flag}: {problem}")


# -- one writer per output ------------------------------------------------------------------
def holding_lock(attribute: str, *, what: str, flag: str, folder: bool = False
                 ) -> Callable[[Callable[[argparse.Namespace], int]], Callable[[argparse.Namespace], int]]:
    """Decorate a command ``cmd(args)`` that writes ``args.<attribute>``: it runs holding
    :mod:`sim2real.run_lock`'s lock on it - a folder (made if missing, removed again if left
    empty) when ``folder``, else a named output file and what is named after it (a trace's
    sidecar) - so a second instance is refused at once, naming it and the holder's process
    id.  Nothing is locked when the value is None (the output was not asked for)."""
    from sim2real.run_lock import RunLock, output_lock

    def decorate(cmd: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
        @functools.wraps(cmd)
        def locked(args: argparse.Namespace) -> int:
            target = getattr(args, attribute)
            if folder and target is not None:
                lock = RunLock.acquire(target, what=what, flag=flag, create=True)
            else:
                lock = output_lock(target, what=what, flag=flag)
            with lock:
                return cmd(args)

        return locked

    return decorate


# -- ends ------------------------------------------------------------------------------------
def print_result(result: dict, as_json: bool) -> None:
    """A command's result: one JSON line, or aligned ``key: value`` lines for people."""
    if as_json:
        print(json.dumps(result))
    else:
        width = max(map(len, result), default=0)
        for key, value in result.items():
            print(f"{key:>{width}}: {value}")


class NamedStdout:
    """``sys.stdout`` whose write errors name where it goes: ``biped robot mjcf > robot.xml``
    on a full disk says ``cannot write robot.xml: No space left on device`` (through
    :class:`~sim2real.atomic_json.OutputError`), not a bare ``[Errno 28]``.  A closed pipe
    (``| head``) stays a ``BrokenPipeError``."""

    def __init__(self, stream: Any):
        self._stream = stream

    def write(self, text: str) -> int:
        return self._named(self._stream.write, text)

    def flush(self) -> None:
        return self._named(self._stream.flush)

    def _named(self, call: Callable[..., Any], *args: Any) -> Any:
        try:
            return call(*args)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise OutputError(self.name_of_target(), exc, "the output is cut short") from exc

    def name_of_target(self) -> str:
        """The file standard output is redirected to, or "the standard output"."""
        try:
            target = os.readlink(f"/proc/self/fd/{self._stream.fileno()}")
        except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
            return "the standard output"
        return target if target.startswith("/") else "the standard output"

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def run_failed(problem: str) -> int:
    """A run that started but did not end as asked: one line on stderr, exit status 1."""
    print(f"biped: error: {problem}", file=sys.stderr)
    return 1


def require_module(module: str, what: str, extra: str = "plot") -> None:
    """Refuse up front, before a run, what needs an optional package that is not installed."""
    import importlib.util

    if importlib.util.find_spec(module) is None:
        raise UsageError(f"{what} needs {module.replace('_', '-')}: pip install 'servo-biped-evolve[{extra}]'")
