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
import ipaddress
import math
import os
import re
from typing import Any, Callable

from sim2real.errors import BipedError
from sim2real.hardware.realtime import DEFAULT_PRIORITY, RealtimeRequest
from sim2real.input_files import regular_file_problem
from sim2real.controller.steering import TURN_RATE_DEG_S
from sim2real.robot.validation import show

MAX_SEED = 2**32 - 1  # numpy seeds are non-negative; keys are stored as 64-bit integers


# -- numbers ---------------------------------------------------------------------------------
# Every numeric flag's converter carries ``bounds = (low, high)``, both finite, and
# ``low_open`` (True: ``low`` itself is refused): what the value means bounds it, so that no
# flag reaches the code as 1e308 (an OverflowError in a tick count) or a count that fills the
# memory.  tests/test_hostile_io.py walks every parser and holds each numeric flag to it.
def _bounded(convert: Callable[[str], Any], name: str, low: float, high: float, low_open: bool = False
             ) -> Callable[[str], Any]:
    convert.__name__ = name
    convert.bounds = (low, high)  # type: ignore[attr-defined]
    convert.low_open = low_open  # type: ignore[attr-defined]
    return convert


def _whole(text: str) -> int:
    try:
        return int(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"must be a whole number, got {show(text)}") from None


def _finite(text: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"must be a number, got {show(text)}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {show(text)}")
    return value


def int_within(low: int, high: int, why: str = "") -> Callable[[str], int]:
    """A converter for whole numbers in [``low``, ``high``]; ``why`` says what the upper bound
    protects (e.g. "memory grows with it"), in the message."""

    def convert(text: str) -> int:
        value = _whole(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be a whole number within [{low}, {high}]"
                                             f"{f' ({why})' if why else ''}, got {show(text)}")
        return value

    return _bounded(convert, f"int_within_{low}_{high}", low, high)


def positive_float_at_most(high: float, why: str = "") -> Callable[[str], float]:
    """A converter for finite numbers in (0, ``high``]."""
    return float_within(0.0, high, why, low_open=True)


def float_within(low: float, high: float, why: str = "", *, low_open: bool = False) -> Callable[[str], float]:
    """A converter for finite numbers in [``low``, ``high``] ((``low``, ``high``] with
    ``low_open``); ``why`` says what the bounds mean (e.g. "a week"), in the message."""

    def convert(text: str) -> float:
        value = _finite(text)
        if not (low < value if low_open else low <= value) or value > high:
            raise argparse.ArgumentTypeError(f"must be a number within {'(' if low_open else '['}{low:g}, {high:g}]"
                                             f"{f' ({why})' if why else ''}, got {show(text)}")
        return value

    return _bounded(convert, f"float_within_{low:g}_{high:g}", low, high, low_open)


def seed(text: str) -> int:
    """A random seed: a whole number in [0, 2^32 - 1]."""
    value = _whole(text)
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"a seed must be a whole number in [0, {MAX_SEED}], got {show(text)}")
    return value


_bounded(seed, "seed", 0, MAX_SEED)


def baud_rate(text: str) -> int:
    """A Dynamixel baud rate [bit/s]: one that some profile in ``firmware_profiles/`` lists."""
    from sim2real.robot.profiles import supported_baud_rates

    rates = supported_baud_rates()
    value = _whole(text)
    if value not in rates:
        raise argparse.ArgumentTypeError(f"{show(text)} is not a Dynamixel baud rate "
                                         f"(firmware_profiles/ list: {', '.join(map(str, rates))})")
    return value


def rt_priority(text: str) -> int:
    """A SCHED_FIFO priority, 1-99."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if not 1 <= value <= 99:
        raise argparse.ArgumentTypeError(f"{show(text)}: a SCHED_FIFO priority is an integer 1-99")
    return value


_bounded(rt_priority, "rt_priority", 1, 99)


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
    from sim2real.simulation.reality.file import load_reality

    return _loads(load_reality, text)


# -- a cluster's address -------------------------------------------------------------------
def cluster_address(text: str) -> str:
    """A Ray cluster's address: ``HOST:PORT`` (or ``ray://HOST:PORT``, Ray's client) with a
    port in 1-65535 and a host name or IP address (IPv6 in brackets), or ``auto`` (the
    cluster this machine runs, found by Ray).  Only the form is checked here; that something
    answers there is checked before connecting (:func:`evolve.ray_backend.check_reachable`)."""
    if text == "auto":
        return text
    try:
        host_port(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


_HOST_LABEL = re.compile(r"(?!-)[A-Za-z0-9-]{1,63}(?<!-)")


def host_port(address: str) -> tuple[str, int]:
    """(host, port) of ``[ray://]HOST:PORT``; ``ValueError`` saying what is wrong."""
    rest = address.removeprefix("ray://")
    host, sep, port = rest.rpartition(":")
    if not sep or not host:
        raise ValueError(f"{show(address)} is not HOST:PORT (e.g. 10.0.0.1:6379)")
    if not port.isascii() or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise ValueError(f"{show(address)}: the port must be a whole number within [1, 65535], got {show(port)}")
    if host.startswith("[") and host.endswith("]"):  # [IPv6]
        try:
            ipaddress.IPv6Address(host[1:-1])
        except ValueError:
            raise ValueError(f"{show(address)}: {show(host)} is not an IPv6 address") from None
        return host[1:-1], int(port)
    labels = host.removesuffix(".").split(".")
    if len(host) > 253 or not all(_HOST_LABEL.fullmatch(label) for label in labels):
        raise ValueError(f"{show(address)}: {show(host)} is not a host name or IPv4 address")
    return host, int(port)


HEADING_HELP = ("steer a controller with a heading input: hold the start's heading turned by DEG (left "
                "positive), or follow a schedule SECONDS:DEG,... (e.g. 0:0,5:90,12:-45: toward 90 deg left from 5 s "
                f"on, toward 45 deg right from 12 s on); the heading to hold turns to each at {TURN_RATE_DEG_S:g} deg/s")


def heading_schedule(text: str):
    """``--heading``'s value: the heading to hold over time (argparse type)."""
    from sim2real.controller.steering import parse_schedule, schedule_command

    try:
        return schedule_command(parse_schedule(text))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


REACH_HELP = ("where a reaching controller's right hand reaches: X,Y,Z in metres in the robot's root body's "
              "frame (x forward, y left, z up; default: the target it was evolved for)")


MAX_REACH_M = 10.0  # |X|, |Y|, |Z| of a reach target [m]: past any robot's arm (a human's spans ~0.8 m)


def reach_target(text: str) -> tuple[float, float, float]:
    """``--reach-target``'s value: X,Y,Z [m], three finite numbers (argparse type)."""
    parts = [p.strip() for p in text.split(",")]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{show(text)} is not X,Y,Z in metres") from None
    if len(values) != 3 or not all(math.isfinite(v) and abs(v) <= MAX_REACH_M for v in values):
        raise argparse.ArgumentTypeError(f"{show(text)}: three numbers X,Y,Z in metres, each within +-{MAX_REACH_M:g} "
                                         "(no robot's hand reaches further)")
    return values  # type: ignore[return-value]
