"""Flag values: the ``argparse`` types that turn a flag's text into a checked value.

Each converter turns the text into the value or raises ``argparse.ArgumentTypeError``, so that
argparse prints the usage and ``<prog>: error: argument --flag: <problem>`` and exits 2 before
anything runs:

    parser.add_argument("--seed", type=seed, default=0)
    parser.add_argument("--robot", type=robot_name)

They sit below the command line so that a process with flags of its own (the simulated bus,
``python -m sim2real.simulation.simbus``) and the ``biped`` commands (:mod:`sim2real.cli.args`,
which gives them to every subcommand with the checks that need more than one flag) read the
same flags the same way.  No MuJoCo here (:func:`reality_name` imports it when called).
"""

from __future__ import annotations

import argparse
import math
import os
from typing import Callable

from sim2real.errors import BipedError
from sim2real.hardware.realtime import DEFAULT_PRIORITY, RealtimeRequest
from sim2real.input_files import regular_file_problem
from sim2real.robot.validation import show

MAX_SEED = 2**32 - 1  # numpy seeds are non-negative; keys are stored as 64-bit integers


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


def _loads(load: Callable[[str], object], text: str, *, is_path: bool = True) -> str:
    """``text`` if ``load(text)`` reads and validates it, else the loader's error as the flag's
    (``is_path`` False: a name the loader looks up, whatever the working folder holds)."""
    problem = input_file_problem(text) if is_path else None
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
    from sim2real.robot import available_robots, load_robot

    # a project robot's name is that robot, even beside a file or folder of that name
    return _loads(load_robot, text, is_path=text.split(":", 1)[0] not in available_robots())


def reality_name(text: str) -> str:
    """A reality profile: ``nominal``, a name from ``configs/reality/`` or a YAML path, read
    and validated now (this imports MuJoCo: only for commands that simulate)."""
    from sim2real.simulation.reality import load_reality

    return _loads(load_reality, text)


HEADING_HELP = ("steer a controller with a heading input: hold the start's heading turned by DEG (left "
                "positive), or follow a schedule SECONDS:DEG,... (e.g. 0:0,5:90,12:-45: 90 deg left from 5 s on, "
                "45 deg right from 12 s on)")


def heading_schedule(text: str):
    """``--heading``'s value: the heading to hold over time (argparse type)."""
    from sim2real.controller.steering import parse_schedule, schedule_command

    try:
        return schedule_command(parse_schedule(text))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


REACH_HELP = ("where a reaching controller's right hand reaches: X,Y,Z in metres in the robot's root body's "
              "frame (x forward, y left, z up; default: the target it was evolved for)")


def reach_target(text: str) -> tuple[float, float, float]:
    """``--reach-target``'s value: X,Y,Z [m], three finite numbers (argparse type)."""
    parts = [p.strip() for p in text.split(",")]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not X,Y,Z in metres") from None
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"{text!r}: three finite numbers X,Y,Z in metres")
    return values  # type: ignore[return-value]
