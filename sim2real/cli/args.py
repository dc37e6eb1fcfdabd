"""Checked command-line values, shared by every ``biped`` subcommand.

Flags get a typed converter (``type=positive_int``, ``type=output_file(".csv")``): it turns
the text into the value or raises ``argparse.ArgumentTypeError``, so argparse prints the
usage and ``biped <command>: error: argument --flag: <problem>`` and exits 2 before
anything runs.  Checks that need more than one flag's text - a robot's baud rates, a
controller's tick, a default path - raise :class:`UsageError`, which ``biped`` prints as
one line, ``biped: error: <problem>``, exit 2.  A run that started but did not end as
asked reports with :func:`run_failed`: one line, exit 1.

    run.add_argument("--duration", type=positive_finite_float)
    run.add_argument("--trace", type=output_file(".csv", exclude=(".json",)))

Used by :mod:`sim2real.cli.robot_commands`, :mod:`sim2real.cli.deploy_commands`, :mod:`evolve.cli_commands` and
:mod:`evolve.quickstart`.  No MuJoCo here.
"""

from __future__ import annotations

import argparse
import io
import json
import math
import os
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from sim2real.atomic_json import OutputError
from sim2real.errors import BipedError, UsageError
from sim2real.hardware.realtime import DEFAULT_PRIORITY, RealtimeRequest
from sim2real.input_files import kind_problem, regular_file_problem
from sim2real.robot.validation import show

if TYPE_CHECKING:
    from sim2real.robot import RobotSpec

MAX_SEED = 2**32 - 1  # numpy seeds are non-negative; keys are stored as 64-bit integers
# Replays of a controller (plot gait, render): at most evolution's longest episode
# (evolve.limits.MAX_EPISODE_S; this package never imports evolve) [s].  A video holds every
# frame in memory until it is written (~80 MB a simulated second at 1280 x 720), so a render's
# own --seconds is shorter; a --strip films at most MAX_STRIP_FRAMES moments.
MAX_REPLAY_S = 300.0
MAX_VIDEO_S = 60.0
MAX_STRIP_FRAMES = 50


# -- numbers ---------------------------------------------------------------------------------
def _whole(text: str) -> int:
    try:
        return int(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None


def _finite(text: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def int_at_least(low: int) -> Callable[[str], int]:
    """A converter for whole numbers >= ``low``."""

    def convert(text: str) -> int:
        value = _whole(text)
        if value < low:
            raise argparse.ArgumentTypeError(f"must be a whole number >= {low}, got {text!r}")
        return value

    convert.__name__ = f"int_at_least_{low}"
    return convert


def int_within(low: int, high: int, why: str = "") -> Callable[[str], int]:
    """A converter for whole numbers in [``low``, ``high``]; ``why`` says what the upper bound
    protects (e.g. "memory grows with it"), in the message."""

    def convert(text: str) -> int:
        value = _whole(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be a whole number within [{low}, {high}]"
                                             f"{f' ({why})' if why else ''}, got {show(text)}")
        return value

    convert.__name__ = f"int_within_{low}_{high}"
    return convert


def positive_float_at_most(high: float, why: str = "") -> Callable[[str], float]:
    """A converter for finite numbers in (0, ``high``]."""

    def convert(text: str) -> float:
        value = _finite(text)
        if not 0 < value <= high:
            raise argparse.ArgumentTypeError(f"must be a number within (0, {high:g}]"
                                             f"{f' ({why})' if why else ''}, got {show(text)}")
        return value

    convert.__name__ = f"positive_float_at_most_{high:g}"
    return convert


positive_int = int_at_least(1)
positive_int.__name__ = "positive_int"
non_negative_int = int_at_least(0)
non_negative_int.__name__ = "non_negative_int"


def seed(text: str) -> int:
    """A random seed: a whole number in [0, 2^32 - 1]."""
    value = _whole(text)
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"a seed must be a whole number in [0, {MAX_SEED}], got {text!r}")
    return value


def positive_finite_float(text: str) -> float:
    value = _finite(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return value


def non_negative_finite_float(text: str) -> float:
    value = _finite(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text!r}")
    return value


def baud_rate(text: str) -> int:
    """A Dynamixel baud rate [bit/s]: one that some profile in ``firmware_profiles/`` lists."""
    from sim2real.robot.profiles import supported_baud_rates

    rates = supported_baud_rates()
    value = _whole(text)
    if value not in rates:
        raise argparse.ArgumentTypeError(f"{text} is not a Dynamixel baud rate "
                                         f"(firmware_profiles/ list: {', '.join(map(str, rates))})")
    return value


def check_baud(robot: RobotSpec, baud: int, flag: str = "--baud") -> None:
    """Refuse a baud rate that not every device on ``robot``'s bus can be set to."""
    rates = robot.baud_rates
    if rates is not None and baud not in rates:
        raise UsageError(f"{flag} {baud}: not a rate every device of {robot.name} supports "
                         f"({', '.join(map(str, rates))})")


def check_duration(seconds: float | None, tick_s: float, flag: str = "--duration") -> None:
    """Refuse a run shorter than one control tick (it would end after no tick at all)."""
    if seconds is not None and round(seconds / tick_s) < 1:
        raise UsageError(f"{flag} {seconds:g}: shorter than one control tick ({tick_s:g} s)")


def rt_priority(text: str) -> int:
    """A SCHED_FIFO priority, 1-99."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if not 1 <= value <= 99:
        raise argparse.ArgumentTypeError(f"{text!r}: a SCHED_FIFO priority is an integer 1-99")
    return value


def cpu_index(text: str) -> int:
    """A CPU this process may run on."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value not in os.sched_getaffinity(0):
        raise argparse.ArgumentTypeError(f"{text!r}: not a CPU this process may use "
                                         f"({sorted(os.sched_getaffinity(0))})")
    return value


# -- real-time treatment --------------------------------------------------------------------
def add_realtime_arguments(parser: argparse.ArgumentParser) -> None:
    """``--no-realtime``, ``--rt-priority``, ``--cpu``, ``--no-mlock``: shared by every command
    that runs something in real time."""
    group = parser.add_argument_group("real-time treatment (Linux; each refusal is reported, never fatal)")
    group.add_argument("--no-realtime", action="store_true",
                       help="do not ask for a real-time scheduling class, locked memory or a CPU")
    group.add_argument("--rt-priority", type=rt_priority, default=DEFAULT_PRIORITY, metavar="P",
                       help=f"SCHED_FIFO priority 1-99 (default {DEFAULT_PRIORITY})")
    group.add_argument("--cpu", type=cpu_index, metavar="N", help="pin to this CPU (default: any)")
    group.add_argument("--no-mlock", action="store_true", help="do not lock memory")


def realtime_request(args: argparse.Namespace) -> RealtimeRequest | None:
    """What the flags ask for (None: nothing, with ``--no-realtime``)."""
    if args.no_realtime:
        return None
    return RealtimeRequest(priority=args.rt_priority, cpu=args.cpu, lock_memory=not args.no_mlock)


def realtime_flags(args: argparse.Namespace) -> list[str]:
    """The same choices as command-line flags, for a child process."""
    if args.no_realtime:
        return ["--no-realtime"]
    flags = ["--rt-priority", str(args.rt_priority)] + (["--cpu", str(args.cpu)] if args.cpu is not None else [])
    return flags + (["--no-mlock"] if args.no_mlock else [])


# -- names of data files ---------------------------------------------------------------------
def input_file_problem(text: str) -> str | None:
    """Why the file a name-or-path argument names cannot be read, or None: checked before
    any loader opens it, so that a FIFO does not block and a device is not read forever
    (:mod:`sim2real.input_files`).  A bare name (``xl430_biped``, ``human:male_95``) that is
    no path is left to the loader; so is the file part of ``FILE.yaml:preset``."""
    for candidate in dict.fromkeys((text, text.split(":", 1)[0])):
        if candidate and os.path.lexists(candidate):
            problem = regular_file_problem(candidate)
            return None if problem is None else f"{candidate}: {problem}"
    return None


def check_input_file(text: str) -> None:
    """:func:`input_file_problem` as a :class:`UsageError`, for a name-or-path argument that
    has no checked type (a positional ROBOT that may be a controller instead)."""
    problem = input_file_problem(text)
    if problem is not None:
        raise UsageError(problem)


def _loads(load: Callable[[str], object], text: str) -> str:
    """``text`` if ``load(text)`` reads and validates it, else the loader's error as the flag's."""
    problem = input_file_problem(text)
    if problem is not None:
        raise argparse.ArgumentTypeError(problem)
    try:
        load(text)
    except (BipedError, FileNotFoundError, KeyError) as exc:
        message = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
        raise argparse.ArgumentTypeError(message) from None
    return text


def robot_name(text: str) -> str:
    """A robot: a name from ``configs/robots/`` (presets as ``human:male_95``) or a YAML path,
    read and validated now."""
    from sim2real.robot import load_robot

    return _loads(load_robot, text)


def reality_name(text: str) -> str:
    """A reality profile: ``nominal``, a name from ``configs/reality/`` or a YAML path, read
    and validated now (this imports MuJoCo: only for commands that simulate)."""
    from sim2real.simulation.reality import load_reality

    return _loads(load_reality, text)


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
