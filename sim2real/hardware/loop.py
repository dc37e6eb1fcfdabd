"""The real-time loop: a fixed rate on absolute deadlines, each tick read, step, write.

    loop = RealTimeLoop(chain, mapping, policy, policy.tick_s, trace)
    loop.run(duration_s, report)

Each tick reads joints, feet, up-vector (and heading or angular rates, from a board with
them), steps the goal source (:class:`GoalSource`) and sync-writes its goals.  An overrun
re-syncs instead of catching up, and is counted.  A noisy bus does not stop the robot: a failed
read is retried while the tick's budget lasts (:func:`read_budget`), a tick without a good read
holds the last goals (and is counted), and communication counts as lost only after
``lost_after_s`` without one good read.  A non-finite goal stops the loop (:class:`UnsafeOutput`)
with the last goals held, and so does a trace that cannot be written (:class:`TraceWriteError`).
:func:`ramp` moves the goals slowly to the start pose and, at the stop, to the rest pose.

The loop never turns torque off itself: whatever ends it, :func:`sim2real.hardware.deploy.drive`
hands over to the safe stop (:mod:`sim2real.hardware.safe_stop`).
"""

from __future__ import annotations

import math
import time
from typing import Any, Callable, Protocol

import numpy as np

from sim2real.controller.mapping import ServoMapping
from sim2real.errors import BipedError
from sim2real.hardware.bus import CommunicationError
from sim2real.hardware.dynamixel.chain import BoardReading, ServoChain
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.hardware.readings import MotionReadings
from sim2real.hardware.run_report import RunReport
from sim2real.hardware.trace import TraceWriter

RAMP_S = 2.0  # start-up and shutdown ramps [s]
RAMP_TICK_S = 0.02
SPIN_S = 0.0005  # the loop spins this long before each deadline instead of sleeping (5 % of a 10 ms tick)
# The retry budget of the loop's reads (said in one line at the start, :func:`read_budget`):
LOST_AFTER_S = 0.1  # communication is lost after this long without one good read [s]
READ_BUDGET = 0.6  # a tick's reads are retried until this share of the tick has passed
TICK_ATTEMPTS = 4  # ... and at most this often each (a failing mock bus answers at once)


class UnsafeOutput(BipedError):
    """The controller produced a non-finite goal: the last goals were held."""


class TraceWriteError(BipedError):
    """The trace could not be written (disk full, file system gone): the run stops safely."""


class GoalSource(Protocol):
    """What the loop drives the robot with: a controller's :class:`Policy`, or an excitation
    program (:mod:`sim2real.hardware.excitation`)."""

    tick_s: float
    hold: np.ndarray  # the rest pose the run ends in [rad]

    def reset(self) -> np.ndarray: ...  # the pose the run starts from [rad]

    def step(self, angles: np.ndarray, feet_touching: np.ndarray, up: np.ndarray, previous: np.ndarray,
             tick: int = 0, heading: float | None = None,
             gyro: np.ndarray | None = None) -> np.ndarray: ...  # this tick's goals [rad]

    def trace_metadata(self) -> dict[str, Any]: ...

    # Optional, read with getattr because an excitation program has none of them (a Policy has
    # each): ``trace_motion = True`` asks the loop to trace each servo's velocity and load or
    # current too (:mod:`sim2real.hardware.readings`), at the cost of bus time every tick;
    # ``sensors`` (the board's sensors it reads, checked before any servo moves);
    # ``trace_channels`` and ``trace_values()`` (columns it adds to a trace, and their values);
    # ``apply_commands(heading=, reach_target=, log=)`` (a user's commands for the run, refused
    # before any servo moves where the source cannot take them) and ``task_report()`` (what the
    # run reports of its task, e.g. a reaching controller's goals reached).


def ramp(chain: ServoChain, mapping: ServoMapping, start: np.ndarray, target: np.ndarray,
         seconds: float = RAMP_S, sleep: Callable[[float], None] = time.sleep,
         cut_short: Callable[[], bool] = lambda: False) -> bool:
    """Move goals linearly from ``start`` to ``target`` [rad] over ``seconds``; False if
    ``cut_short()`` turned true on the way (the goals stop where they were)."""
    steps = max(1, int(math.ceil(seconds / RAMP_TICK_S)))
    for k in range(1, steps + 1):
        if cut_short():
            return False
        chain.sync_write(Reg.GOAL_POSITION, mapping.ticks(start + (target - start) * k / steps))
        sleep(RAMP_TICK_S)
    return True


def read_budget(tick_s: float, lost_after_s: float) -> str:
    """The loop's retry budget in words: how often and for how long a read is tried within a
    tick [s], and when communication counts as lost [s]."""
    return (f"bus reads: each tried up to {TICK_ATTEMPTS} times within the first {READ_BUDGET * tick_s * 1e3:.3g} ms "
            f"({READ_BUDGET:.0%}) of the {tick_s * 1e3:.3g} ms tick, a tick without a good read holds its goals; "
            f"communication counts as lost after {lost_after_s * 1e3:.3g} ms without one")


class RealTimeLoop:
    def __init__(self, chain: ServoChain, mapping: ServoMapping, policy: GoalSource, tick_s: float,
                 trace: TraceWriter | None = None, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep, lost_after_s: float = LOST_AFTER_S,
                 motion: MotionReadings | None = None, check_stop: Callable[[], None] = lambda: None):
        self.chain, self.mapping, self.policy, self.tick_s = chain, mapping, policy, tick_s
        self.trace, self.clock, self.sleep, self.motion = trace, clock, sleep, motion
        self.lost_after_s = lost_after_s
        self.check_stop = check_stop  # raises StopRequested once a signal came: called between ticks
        self.goal = policy.hold.copy()
        self.goal_ticks = mapping.ticks(self.goal)
        self.failed_tries = 0  # reads failed since the last good one (said if communication is lost)

    def policy_values(self) -> tuple[float, ...]:
        """What the policy adds to a trace row (:meth:`Policy.trace_values`)."""
        values = getattr(self.policy, "trace_values", None)
        return values() if values is not None else ()

    def run(self, duration_s: float | None, report: RunReport) -> None:
        start = deadline = self.clock()
        self.failing_since: float | None = None
        n_ticks = None if duration_s is None else int(round(duration_s / self.tick_s))
        while n_ticks is None or report.ticks < n_ticks:
            self.check_stop()
            began = self.clock()
            report.jitter_s.append(max(0.0, began - deadline))
            readings = self._read(began + READ_BUDGET * self.tick_s, report)
            bus_s = self.clock() - began
            compute_s = 0.0
            if readings is None:  # hold the last goals; writing them again keeps the watchdog fed
                report.missed_ticks += 1
            else:
                angles, board = readings
                feet, up = board.feet, board.up
                t0 = self.clock()
                goal = self.policy.step(angles, feet, up, self.goal, tick=report.ticks, heading=board.heading,
                                        gyro=board.gyro)
                compute_s = self.clock() - t0
                if not np.all(np.isfinite(goal)):
                    raise UnsafeOutput(f"non-finite goal at tick {report.ticks}: held the last goals")
                self.goal, self.goal_ticks = goal, self.mapping.ticks(goal)
                report.compute_s.append(compute_s)
            t_bus = self.clock()
            self.chain.sync_write(Reg.GOAL_POSITION, self.goal_ticks)
            bus_s += self.clock() - t_bus
            deadline += self.tick_s
            now = self.clock()
            overrun = now > deadline
            if overrun:
                report.overruns += 1
                deadline = now  # re-sync: never try to catch up
            if self.trace is not None and readings is not None:
                extra = (*(() if board.heading is None else (board.heading,)),
                         *(() if board.gyro is None else board.gyro), *self.policy_values())
                if self.motion is not None:  # traced only: a tick without them loses its row, not its goals
                    motion = self._attempt(lambda: self.motion.read(attempts=1), began + self.tick_s, report)
                    extra = None if motion is None else (*extra, *motion)
                if extra is not None:
                    try:
                        self.trace.write(began - start, report.ticks, self.goal, angles, feet, up, compute_s,
                                         bus_s, overrun, extra)
                    except (OSError, ValueError) as exc:  # ValueError: a closed file
                        raise TraceWriteError(f"cannot write the trace {self.trace.path}: {exc}") from exc
            report.ticks += 1
            if not overrun:
                self._wait_until(deadline)

    def _read(self, give_up_at: float, report: RunReport) -> tuple[np.ndarray, BoardReading] | None:
        """Joint angles and the board's reading, each read retried until ``give_up_at``;
        None when the tick ran out.  Raises :class:`CommunicationError` once reads have
        failed for ``lost_after_s`` without one success."""
        angles = self._attempt(lambda: self.mapping.angles(self.chain.sync_read(Reg.PRESENT_POSITION, attempts=1)),
                               give_up_at, report)
        if angles is None:
            return None
        board = self._attempt(lambda: self.chain.read_board(attempts=1), give_up_at, report)
        if board is None:
            return None
        self.failing_since, self.failed_tries = None, 0
        return angles, board

    def _attempt(self, read: Callable[[], Any], give_up_at: float, report: RunReport) -> Any:
        for attempt in range(TICK_ATTEMPTS):
            try:
                return read()
            except CommunicationError as exc:
                report.corrupt_replies += exc.corrupt
                now = self.clock()
                # Timed from the first failure, not the last success: a host that stalled
                # between two good reads has not lost its bus.
                if self.failing_since is None:
                    self.failing_since, self.failing_tick = now, report.ticks
                self.failed_tries += 1
                failing_s = now - self.failing_since
                if failing_s >= self.lost_after_s:
                    ticks = report.ticks - self.failing_tick + 1
                    raise CommunicationError(exc.ids, f"{exc.what} (no good reply for {failing_s * 1e3:.0f} ms: "
                                             f"{self.failed_tries} tries failed over {ticks} tick{'s' * (ticks > 1)})",
                                             exc.corrupt) from exc
                if now >= give_up_at or attempt == TICK_ATTEMPTS - 1:
                    return None
                report.retries += 1
        return None

    def _wait_until(self, deadline: float) -> None:
        """Sleep, then spin the last ``SPIN_S``: a thread woken from a long sleep starts late
        and runs its first microseconds cold (caches, clock frequency) - measured at ~4x the
        warm compute time on this project's machine."""
        remaining = deadline - self.clock()
        if remaining > SPIN_S:
            self.sleep(remaining - SPIN_S)
        while self.clock() < deadline:
            pass
