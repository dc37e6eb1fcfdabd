"""The simulated bus as a process: ``biped simbus`` and ``python -m sim2real.simulation.simbus``.

    python -m sim2real.simulation.simbus --robot xl430_biped --reality default --exit-on-stdin-eof --report

prints the pseudo-terminal's path as its first line, then serves until SIGTERM, Ctrl-C or
(with ``--exit-on-stdin-eof``) its standard input closing - which is how a dry run stops it,
and how it ends by itself if the dry run dies.  A line ``end of run`` on its standard input
marks the end of the parent's loop: the ground truth it reports is the one of that moment, not
after the stop's ramp to rest and torque off.  With ``--report`` its last line is one JSON
object: the simulator's ground truth (distance, fell, simulated seconds; ``fell_after_stop``
once marked) and what real-time treatment it got.

It runs in its own process so that its physics never competes with the runtime it serves for
one Python interpreter: in one process the runtime's busy-wait before each deadline held the
interpreter lock while replies were due, and replies came late.
"""

from __future__ import annotations

import argparse
import functools
import gc
import json
import os
import signal
import sys
import threading
from typing import TYPE_CHECKING

from sim2real.arg_types import add_realtime_arguments, realtime_request
from sim2real.hardware.realtime import RealtimeRequest
from sim2real.robot import RobotSpec
from sim2real.simulation.simbus.faults import END_OF_RUN, parse_faults

if TYPE_CHECKING:
    from sim2real.simulation.simbus.physics import PhysicsChain
    from sim2real.simulation.simbus.server import EmulatedChain



def add_arguments(parser: argparse.ArgumentParser) -> None:
    from sim2real.arg_types import (
        baud_rate,
        float_within,
        reality_name,
        robot_name,
        seed,
    )
    from sim2real.hardware.trace import MAX_TIME_S
    from sim2real.robot import DEFAULT_ROBOT

    parser.add_argument("--robot", type=robot_name, default=DEFAULT_ROBOT,
                        help="robot name from configs/robots/ or a path to a robot YAML (default: xl430_biped)")
    parser.add_argument("--baud", type=baud_rate, help="pace replies like the wire at this baud (default: the robot's)")
    parser.add_argument("--faults", help="inject faults: silent:ID@SECONDS,overload:ID@SECONDS (after the "
                        "first torque on),drop:RATE,corrupt:RATE or a YAML file of them")
    parser.add_argument("--reality", type=reality_name, metavar="PROFILE",
                        help="perturb the simulated robot: a configs/reality/ name (e.g. default) or a path")
    parser.add_argument("--seed", type=seed, default=0, help="seed of the reality profile's random parts (default: %(default)s)")
    parser.add_argument("--suspended", action="store_true",
                        help="hang the robot by its pelvis, feet off the floor (as for biped excite)")
    add_realtime_arguments(parser)
    parser.add_argument("--fault-delay", type=float_within(0.0, MAX_TIME_S), default=0.0, help=argparse.SUPPRESS)  # dry runs: the ramp
    parser.add_argument("--exit-on-stdin-eof", action="store_true",
                        help="also stop when standard input closes (for a parent process)")
    parser.add_argument("--report", action="store_true",
                        help="print the simulator's ground truth as one JSON line at the end")


def serve(args: argparse.Namespace) -> int:
    """Serve until told to stop; see the module docstring."""
    from sim2real.hardware.realtime import request_realtime
    from sim2real.robot import load_robot
    from sim2real.simulation.model.physique import measured
    from sim2real.simulation.reality.file import load_reality
    from sim2real.simulation.simbus.physics import REPLY_CATCH_UP_S, PhysicsChain
    from sim2real.simulation.simbus.server import EmulatedChain, PtyServer

    robot = measured(load_robot(args.robot))
    physics = PhysicsChain(robot, reality=load_reality(args.reality), seed=args.seed, suspended=args.suspended)
    # In chunks of REPLY_CATCH_UP_S: after a stall the physics catches up between
    # instructions, and a reply waits for one chunk at most, not for all it missed
    chain = EmulatedChain(physics.devices, advance=functools.partial(physics.advance, REPLY_CATCH_UP_S))
    rates = arm_faults(args.faults, chain, physics, delay_s=args.fault_delay, robot=robot)
    # Everything built so far lives as long as the process: a full collection scanned its
    # ~50,000 objects for 15 ms (45 ms on a loaded core), on whichever reply was due.
    gc.collect()
    gc.freeze()
    # Real time only now, the model built and compiled: that work (0.2 s, seconds for a large
    # model) under SCHED_FIFO held a core from every other real-time thread of its priority,
    # and a run started beside a running one left its simulated bus unserved for 235 ms.
    # The whole process, main thread first: every thread started later inherits the class.
    # A main thread left to ordinary scheduling could be preempted by a busy neighbour
    # while it holds Python's interpreter lock, and the serving thread would wait on it.
    grant = request_realtime(realtime_request(args) or RealtimeRequest.off())
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *a: done.set())
    if args.exit_on_stdin_eof:
        threading.Thread(target=_set_on_eof, args=(done, physics), daemon=True).start()
    baud = args.baud or (robot.bus.baud if robot.bus else None)
    with PtyServer(chain, baud=baud, **rates) as server:
        print(server.port, flush=True)
        if grant.refused:
            print(f"simbus: {grant.describe()}", file=sys.stderr, flush=True)
        warned = 0
        try:
            while not done.wait(0.2):
                warned = _warn_of_stalls(server.stalls, warned)
        except KeyboardInterrupt:
            pass
        _warn_of_stalls(server.stalls, warned)
    if args.report:
        print(json.dumps({**physics.ground_truth(), "realtime": grant.summary(),
                          "stalls": stall_summary(server.stalls)}), flush=True)
    return 0


def stall_summary(stalls: list[tuple[float, float]]) -> dict[str, float | int | None]:
    """How often and how long the serving loop was held up (see ``PtyServer.stalls``)."""
    return {"count": len(stalls), "longest_ms": max((d for _, d in stalls), default=0.0) * 1e3,
            "first_at_s": stalls[0][0] if stalls else None}


def _warn_of_stalls(stalls: list[tuple[float, float]], warned: int) -> int:
    """Say on standard error, as it happens, that this computer held the simulated bus up: a
    runtime on the other end of the port may then report lost communication that no real
    robot would have caused.  Returns how many stalls have been reported."""
    for at_s, length_s in stalls[warned:len(stalls)]:
        print(f"simbus: warning: the simulated bus was held up {length_s * 1e3:.0f} ms at {at_s:.1f} s (this "
              "computer was busy: replies were late)", file=sys.stderr, flush=True)
    return len(stalls)


def arm_faults(spec: str | None, chain: "EmulatedChain", physics: "PhysicsChain",
               delay_s: float = 0.0, robot: RobotSpec | None = None) -> dict[str, float]:
    """Give ``physics`` the silent servos and overloads (timed ``delay_s`` after the first
    torque on, see :mod:`.physics`); return the wire's drop/corrupt rates as
    :class:`PtyServer` keyword arguments."""
    rates = {}
    physics.on_silent = chain.silent.add
    for kind, dxl_id, at in parse_faults(spec, robot):
        if kind in ("silent", "overload"):
            (physics.silent_at if kind == "silent" else physics.overload_at)[dxl_id] = delay_s + at
        else:
            rates[f"{kind}_rate"] = at
    return rates



def _set_on_eof(done: threading.Event, physics: "PhysicsChain") -> None:
    # Raw reads of the descriptor, not sys.stdin: a daemon thread blocked inside the buffered
    # reader holds its lock, and the interpreter's exit (after a SIGTERM) then aborted with
    # "Fatal Python error: _enter_buffered_busy".
    pending = b""
    try:
        while chunk := os.read(sys.stdin.fileno(), 4096):
            pending += chunk
            *lines, pending = pending.split(b"\n")
            if any(line.decode(errors="replace").strip() == END_OF_RUN for line in lines):
                physics.mark_end_of_run()
    except (OSError, ValueError):
        pass
    done.set()


def main(argv: list[str] | None = None) -> int:
    from sim2real.errors import BipedError

    parser = argparse.ArgumentParser(prog="python -m sim2real.simulation.simbus", description=__doc__.splitlines()[0])
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        return serve(args)
    except BipedError as exc:
        print(f"simbus: error: {exc}", file=sys.stderr)
        return 2
