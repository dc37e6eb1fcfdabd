"""Driving the robot: start-up checks, the real-time loop, and a safe stop on every exit path.

    report = drive(bus, robot, controller, duration_s=30, trace_path="run.csv")

Start-up (:mod:`sim2real.hardware.dynamixel.startup`) checks that the bus holds the robot of
the config and configures its servos; then torque goes on and the goals ramp slowly from the
present pose to the controller's start pose.  The loop keeps a fixed rate on absolute
deadlines (an overrun re-syncs instead of catching up, and is counted); each tick reads
joints, feet, up-vector (and heading, from a board with one), activates, maps and sync-writes.

A noisy bus does not stop the robot: a failed read is retried while the tick's budget lasts,
a tick without a good read holds the last goals (and is counted), and communication counts
as lost only after ``lost_after_s`` without one good read.  The servos' Bus Watchdog stops
them on its own if the host itself goes silent.

Whatever ends the run - its duration, a signal (Ctrl-C, SIGTERM, a closed terminal's SIGHUP,
SIGQUIT, Ctrl-Z and every other signal whose default would end or stop the process; see
:class:`StopSignals`), an exception, ``SystemExit``, lost communication, a hardware error, a
non-finite output, a trace that cannot be written - the robot ramps to its rest pose if the
bus still answers, torque goes off, and every servo's Torque Enable is read back: the report
lists the servos confirmed off and those that are not.  Signals never interrupt a bus
exchange or a trace write: they are taken between ticks.  Signals that arrive during the stop
cut the ramp short; nothing skips the torque-off.  No MuJoCo here.
"""

from __future__ import annotations

import math
import signal
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Protocol

import numpy as np

from sim2real.controller.channels import CHANNELS
from sim2real.controller.file import Controller
from sim2real.controller.mapping import ServoMapping
from sim2real.controller.policy import Policy
from sim2real.controller.robot_checks import bus_problems
from sim2real.errors import BipedError, ConfigError, UsageError
from sim2real.hardware.bus import Bus, CommunicationError, ServoError
from sim2real.hardware.dynamixel.chain import BoardReading, ServoChain, board_reports
from sim2real.hardware.dynamixel.errors import decode_hardware_error
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.hardware.dynamixel.startup import StartupError, start_up
from sim2real.hardware.realtime import (
    RealtimeRequest,
    no_garbage_collection,
    release_realtime,
    request_realtime,
)
from sim2real.hardware.readings import MotionReadings, traced_registers
from sim2real.hardware.trace import GYRO_CHANNELS, HEADING_CHANNEL, Channel, TraceWriter
from sim2real.robot import RobotSpec

RAMP_S = 2.0  # start-up and shutdown ramps [s]
RAMP_TICK_S = 0.02
SPIN_S = 0.0005  # the loop spins this long before each deadline instead of sleeping (5 % of a 10 ms tick)
# The retry budget of the loop's reads (said in one line at the start, :func:`read_budget`):
LOST_AFTER_S = 0.1  # communication is lost after this long without one good read [s]
READ_BUDGET = 0.6  # a tick's reads are retried until this share of the tick has passed
TICK_ATTEMPTS = 4  # ... and at most this often each (a failing mock bus answers at once)
# Start-up and torque-off keep asking a device at least this often and this long: nothing
# moves meanwhile, and a host busy for a few tens of ms must not make a servo look silent
# (or, at the end, make the tool tell the user to cut the power for nothing).
PATIENT_ATTEMPTS = 3
PATIENCE_S = 0.3


class UnsafeOutput(BipedError):
    """The controller produced a non-finite goal: the last goals were held."""


class StopRequested(BaseException):
    """A signal asked the run to stop; raised by the loop itself between two ticks (never
    from inside a bus exchange), so it is a ``BaseException`` like ``KeyboardInterrupt``."""

    def __init__(self, signal_name: str):
        super().__init__(signal_name)
        self.signal_name = signal_name


class TraceWriteError(BipedError):
    """The trace could not be written (disk full, file system gone): the run stops safely."""


@dataclass
class TorqueOff:
    """Servos whose Torque Enable read back 0 after the stop, and those that did not answer
    (or still read 1): power to those must be cut by hand."""

    confirmed: list[int] = field(default_factory=list)
    unconfirmed: list[int] = field(default_factory=list)


@dataclass
class RunReport:
    ticks: int = 0
    overruns: int = 0
    bus_errors: int = 0
    retries: int = 0  # reads repeated within a tick
    missed_ticks: int = 0  # ticks without a good read: the last goals were held
    corrupt_replies: int = 0  # failed reads whose reply came but was corrupt
    stop_reason: str = ""
    stop_signal: str | None = None  # the signal that stopped the run (e.g. "SIGINT"), if one did
    stop_notes: list[str] = field(default_factory=list)
    torque_off: TorqueOff | None = None
    realtime: dict[str, Any] | None = None
    task: dict[str, Any] = field(default_factory=dict)  # the goal source's own report (GoalSource.task_report)
    compute_s: list[float] = field(default_factory=list)
    jitter_s: list[float] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        def pct(values, q, scale):
            return float(np.percentile(values, q) * scale) if values else None

        torque = None if self.torque_off is None else {"confirmed": self.torque_off.confirmed,
                                                       "unconfirmed": self.torque_off.unconfirmed}
        return {"ticks": self.ticks, "overruns": self.overruns, "bus_errors": self.bus_errors,
                "retries": self.retries, "missed_ticks": self.missed_ticks, "corrupt_replies": self.corrupt_replies,
                "stop_reason": self.stop_reason, "stop_signal": self.stop_signal, "stop_notes": self.stop_notes,
                "torque_off": torque,
                "compute_us_p50": pct(self.compute_s, 50, 1e6), "compute_us_p99": pct(self.compute_s, 99, 1e6),
                "jitter_ms_p99": pct(self.jitter_s, 99, 1e3), "realtime": self.realtime, **self.task}


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


# Every asynchronous signal whose default action ends or stops the process: with torque on,
# any of them would leave the robot powered.  (SIGKILL and SIGSTOP cannot be caught: the
# servos' Bus Watchdog is the only guard then.  SIGTTOU is ignored instead - see below.)
STOP_SIGNALS = tuple(getattr(signal, name) for name in (
    "SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT", "SIGTSTP", "SIGUSR1", "SIGUSR2", "SIGALRM", "SIGVTALRM",
    "SIGPROF", "SIGXCPU", "SIGXFSZ", "SIGIO", "SIGPWR") if hasattr(signal, name))
SIGNAL_STOP_REASONS = {  # the report's stop reason for each signal; every other reads "stopped by SIGxxx"
    "SIGINT": "interrupted (Ctrl-C)",
    "SIGTERM": "terminated (SIGTERM)",
    "SIGHUP": "hung up (SIGHUP: the terminal or SSH session closed)",
    "SIGQUIT": "quit (SIGQUIT)",
    "SIGTSTP": "suspended (Ctrl-Z, SIGTSTP): a robot is not paused with torque on",
}


def signal_stop_reason(signal_name: str) -> str:
    return SIGNAL_STOP_REASONS.get(signal_name, f"stopped by {signal_name}")


class StopSignals:
    """The stop signals (:data:`STOP_SIGNALS`) for the whole of a run, from start-up to the
    read-back of torque.

    A handler never raises: it records the signal, and the run takes it at its next safe
    point (:meth:`check`, between two ticks or two ramp steps) by raising
    :class:`StopRequested`.  An exception raised from a handler lands wherever the main
    thread happens to be - inside the SDK between sending a packet and reading its reply, it
    left the port marked busy and every later packet, the torque-off included, was refused
    (measured: 2 SIGINTs in 6 during a traced run left all 11 servos powered).  Once the
    stop has begun, or a signal is already pending, further signals only set ``cut_short``,
    which ends the ramp to rest early; nothing skips the torque-off.  SIGTTOU is ignored
    meanwhile so that a run sent to the background keeps writing to its terminal instead of
    being stopped by it.
    """

    def __init__(self) -> None:
        self.stopping = False  # the stop has begun
        self.cut_short = False
        self.received: list[str] = []
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> "StopSignals":
        if threading.current_thread() is threading.main_thread():
            for signum in STOP_SIGNALS:
                self._previous[signum] = signal.signal(signum, self._handle)
            if hasattr(signal, "SIGTTOU"):
                self._previous[signal.SIGTTOU] = signal.signal(signal.SIGTTOU, signal.SIG_IGN)
        return self

    def __exit__(self, *exc) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)

    def check(self) -> None:
        """Raise :class:`StopRequested` if a signal has come (call only at safe points)."""
        if self.received and not self.stopping:
            raise StopRequested(self.received[0])

    def _handle(self, signum: int, frame) -> None:
        if self.stopping or self.received:
            self.cut_short = True
        self.received.append(signal.Signals(signum).name)


class _SafeLog:
    """The run's log, which never raises: after a SIGHUP the terminal is gone and writing to
    it fails (EIO), and no message may keep the stop from turning torque off."""

    def __init__(self, log: Callable[[str], None]):
        self.log = log

    def __call__(self, line: str) -> None:
        try:
            self.log(line)
        except Exception:  # noqa: BLE001 - a lost terminal must not keep torque on
            pass


def policy_channels(policy: GoalSource) -> tuple[Channel, ...]:
    """The trace columns a policy adds (:attr:`Policy.trace_channels`), in its order."""
    return tuple(Channel(name, unit) for name, unit in getattr(policy, "trace_channels", ()))


def drive(bus: Bus, robot: RobotSpec, controller: Controller | GoalSource, duration_s: float | None = None,
          trace_path: Path | str | None = None, disabled_modules: tuple[str, ...] = (),
          log: Callable[[str], None] = print, clock: Callable[[], float] = time.monotonic,
          sleep: Callable[[float], None] = time.sleep, ramp_s: float = RAMP_S,
          lost_after_s: float = LOST_AFTER_S, realtime: RealtimeRequest | None = None,
          on_loop_end: Callable[[], None] | None = None,
          heading: Callable[[float], float] | None = None,
          reach_target: tuple[float, float, float] | None = None) -> RunReport:
    """Start up, ramp, run the loop, and always end with torque off, read back; returns what
    happened (``report.torque_off`` lists servos confirmed off and those that are not).
    ``controller`` is a controller file's contents or any other :class:`GoalSource`.
    ``realtime``: ask the OS for real-time treatment first (None: do not ask).
    ``on_loop_end`` is called once the loop has ended, however, before the stop (a dry run
    takes its ground truth then); nothing it raises delays the torque-off.  ``heading`` (the
    heading to hold [rad, from the start's] at a time since the start [s]; None: the start's)
    and ``reach_target`` (where a reaching controller's right hand reaches, root frame [m];
    None: where it was evolved to) are a user's commands, handed to the goal source
    (:meth:`~sim2real.controller.policy.Policy.apply_commands`) before any servo moves."""
    if isinstance(controller, Controller):
        policy: GoalSource = Policy(controller, robot, disabled_modules)
        metadata = {"controller_hash": controller.joint_map_hash,
                    "controller_provenance": controller.to_dict()["provenance"]}
    else:
        policy, metadata = controller, controller.trace_metadata()
    if heading is not None or reach_target is not None:  # before any servo moves
        apply_commands = getattr(policy, "apply_commands", None)
        if apply_commands is None:
            raise UsageError(f"{type(policy).__name__} takes no commands (a heading to hold, a reach target)")
        apply_commands(heading=heading, reach_target=reach_target, log=log)
    if duration_s is not None and not (math.isfinite(duration_s) and round(duration_s / policy.tick_s) >= 1):
        raise UsageError(f"duration {duration_s!r} s: not a finite time of at least one control tick "
                         f"({policy.tick_s} s)")  # before any servo moves
    for sensor in getattr(policy, "sensors", ()):  # before any servo moves
        if not board_reports(robot, sensor):
            switch = next(c.switch for c in CHANNELS if c.sensor == sensor)
            raise UsageError(f"the controller reads the torso's {sensor} ({switch}), but robot {robot.name}'s "
                             f"sensor board reports none (no {sensor} register in its profile)")
    report = RunReport()
    log = _SafeLog(log)
    chain = ServoChain(bus, robot)
    mapping = ServoMapping(robot)
    traced = traced_registers(robot) if trace_path is not None and getattr(policy, "trace_motion", False) else ()
    problems = bus_problems(robot, policy.tick_s, baud=bus.baud, motion=traced)
    if problems:  # before any port is opened: this bus cannot serve this tick
        raise ConfigError(robot.source, "bus", "; ".join(problems))
    trace = None
    startup_error: StartupError | None = None
    grant = None
    if realtime is not None:
        grant = request_realtime(realtime)
        report.realtime = grant.summary()
        log(grant.describe())
    bus.open()  # a port that does not open: nothing was sent, nothing to stop
    with StopSignals() as signals:
        try:
            start_up(chain, mapping, attempts=PATIENT_ATTEMPTS, patience_s=PATIENCE_S, warn=log)
            signals.check()
            motion = MotionReadings(chain, robot) if getattr(policy, "trace_motion", False) else None
            if motion is not None and motion.left_out:
                log(f"note: the trace leaves out servo {' and '.join(motion.left_out)}: not on every servo")
            if trace_path is not None:
                board_channels = ((Channel(HEADING_CHANNEL, "rad"),) if board_reports(robot, "heading") else ()) + \
                    (tuple(Channel(name, "rad/s") for name in GYRO_CHANNELS) if board_reports(robot, "gyro") else ())
                try:
                    trace = TraceWriter(trace_path, robot.joint_names, {
                        "robot": robot.name, **metadata, "tick_s": policy.tick_s, "software": "servo-biped-evolve"},
                        extra=(*board_channels, *policy_channels(policy), *(motion.channels if motion else ())))
                except OSError as exc:  # before torque goes on: nothing has moved
                    raise TraceWriteError(f"cannot start the trace: {exc}") from exc
            loop = RealTimeLoop(chain, mapping, policy, policy.tick_s, trace, clock, sleep, lost_after_s,
                                motion if trace is not None else None, check_stop=signals.check)
            log(read_budget(policy.tick_s, lost_after_s))
            # The collector's last pass before torque goes on: between the start ramp and the
            # loop it took 130-170 ms on a large heap, the wire fell silent longer than the
            # servos' 100 ms Bus Watchdog, and they refused every goal of the run.
            with no_garbage_collection():
                present = mapping.angles(chain.sync_read(Reg.PRESENT_POSITION, None, PATIENT_ATTEMPTS, PATIENCE_S))
                signals.check()
                chain.torque(True, attempts=PATIENT_ATTEMPTS, patience_s=PATIENCE_S)
                ramp(chain, mapping, present, policy.reset(), ramp_s, sleep, lambda: bool(signals.received))
                loop.run(duration_s, report)
            report.stop_reason = "duration reached"
        except BaseException as exc:  # noqa: BLE001 - every way out leads to the same safe stop
            if isinstance(exc, StartupError):
                startup_error = exc
            report.stop_reason = _stop_reason(exc, chain, report)
        finally:
            signals.stopping = True  # from here on a signal only cuts the ramp short
            if on_loop_end is not None:
                try:
                    on_loop_end()
                except Exception:  # noqa: BLE001 - a report's hook must not keep torque on
                    report.stop_notes.append("the end-of-loop hook failed")
            _stop_safely(chain, mapping, policy, report, signals, sleep, ramp_s, log,
                         ramp_to_rest=startup_error is None)
            report.retries += chain.retries_used
            if trace is not None:
                try:
                    trace.close()
                except OSError as exc:  # the robot is already safe; say what was lost
                    report.stop_notes.append(f"the trace's last rows were not written: {exc}")
            try:
                bus.close()
            except Exception as exc:  # noqa: BLE001 - torque is already off and read back
                report.stop_notes.append(f"the bus did not close cleanly: {exc}")
            if grant is not None:
                release_realtime(grant)
    if len(signals.received) > 1 or (signals.received and report.stop_reason == "duration reached"):
        report.stop_notes.append(f"signals received: {', '.join(signals.received)}")
    if signals.cut_short:
        report.stop_notes.append(f"ramp to rest cut short by {signals.received[-1]}")
    task_report = getattr(policy, "task_report", None)
    if task_report is not None:
        report.task = task_report()
    if startup_error is not None:
        raise startup_error
    return report


def _stop_reason(exc: BaseException, chain: ServoChain, report: RunReport) -> str:
    if isinstance(exc, (StopRequested, KeyboardInterrupt)):  # outside the main thread, Python's own SIGINT
        report.stop_signal = exc.signal_name if isinstance(exc, StopRequested) else "SIGINT"
        return signal_stop_reason(report.stop_signal)
    if isinstance(exc, ServoError):
        report.bus_errors += 1
        detail = ""
        try:
            detail = decode_hardware_error(chain.hardware_error(exc.id))
        except (BipedError, KeyError):
            pass
        return f"{exc}" + (f" (hardware error: {detail})" if detail and detail != "none" else "")
    if isinstance(exc, CommunicationError):
        report.bus_errors += 1
        return f"lost communication: {exc}" + (" (corrupt replies: noise on the wire?)" if exc.corrupt else "")
    if isinstance(exc, (UnsafeOutput, StartupError, TraceWriteError)):
        return str(exc)
    if isinstance(exc, SystemExit):
        return f"exit requested inside the loop (SystemExit {exc.code!r})"
    return f"error: {type(exc).__name__}: {exc}"  # a bug must not leave torque on


def _stop_safely(chain: ServoChain, mapping: ServoMapping, policy: GoalSource, report: RunReport,
                 signals: StopSignals, sleep: Callable[[float], None], ramp_s: float,
                 log: Callable[[str], None], ramp_to_rest: bool = True) -> None:
    """Ramp to the rest pose unless a servo is in hardware error, the bus is silent or a
    signal cuts it short; then torque off on every servo, read back."""
    if ramp_to_rest and "hardware" not in report.stop_reason and not signals.cut_short:
        log(f"stopping ({report.stop_reason}): ramp to rest over {ramp_s:.1f} s, then torque off")
        try:
            present = mapping.angles(chain.sync_read(Reg.PRESENT_POSITION))
            if not ramp(chain, mapping, present, policy.hold, ramp_s, sleep, lambda: signals.cut_short):
                log("warning: ramp to rest cut short by a signal; turning torque off")
        except Exception as exc:  # noqa: BLE001 - whatever failed, torque goes off next
            log(f"warning: could not ramp to the rest pose ({exc}); turning torque off")
    report.torque_off = torque_off(chain)
    tripped = watchdog_tripped(chain)
    if tripped:
        report.stop_notes.append(f"the Bus Watchdog of servo {', '.join(map(str, tripped))} tripped during the run: the "
                                 "wire was silent longer than it allows, and from then on those servos held their "
                                 "pose and refused goals")
        log(f"warning: {report.stop_notes[-1]}")
    if not report.torque_off.unconfirmed:
        log(f"torque off, read back from all {len(report.torque_off.confirmed)} servos")
    else:
        log(f"DANGER: torque off not confirmed on servo(s) {', '.join(map(str, report.torque_off.unconfirmed))}: "
            "cut the power to the robot")


def watchdog_tripped(chain: ServoChain) -> list[int]:
    """Servos whose Bus Watchdog reads -1 (it expired: they stopped and refuse goals until it
    is cleared, which the next start-up does); servos without one, or that do not answer, are
    not listed."""
    tripped = []
    for dxl_id in chain.servo_ids:
        if Reg.BUS_WATCHDOG not in chain.devices[dxl_id].control_table:
            continue
        try:
            if chain.read(dxl_id, Reg.BUS_WATCHDOG, attempts=1) < 0:
                tripped.append(dxl_id)
        except Exception:  # noqa: BLE001 - a report, after torque off: never an obstacle
            pass
    return tripped


def torque_off(chain: ServoChain, attempts: int = PATIENT_ATTEMPTS, patience_s: float = PATIENCE_S) -> TorqueOff:
    """Torque off on every servo, confirmed by reading Torque Enable back.

    One sync write first (a single packet, no reply to lose, reaches every servo at once),
    then per servo: read back, and write again while it still reads 1 - for at least
    ``attempts`` tries and ``patience_s`` seconds.
    """
    # Exception, not only BipedError: on the way to torque off, no failure may skip a servo.
    try:
        chain.sync_write(Reg.TORQUE_ENABLE, np.zeros(len(chain.servo_ids), dtype=np.int64))
    except Exception:  # noqa: BLE001 - a port gone, or servos of different tables: per servo below
        pass
    result = TorqueOff()
    for dxl_id in chain.servo_ids:
        give_up_at = time.monotonic() + patience_s
        attempt = 0
        while attempt < attempts or time.monotonic() < give_up_at:
            attempt += 1
            try:
                if chain.read(dxl_id, Reg.TORQUE_ENABLE, attempts=1) == 0:
                    result.confirmed.append(dxl_id)
                    break
            except ServoError as exc:  # alert bit set: the value still came with it
                if exc.value == 0:
                    result.confirmed.append(dxl_id)
                    break
            except Exception:  # noqa: BLE001
                continue
            try:
                chain.write(dxl_id, Reg.TORQUE_ENABLE, 0, attempts=1)
            except Exception:  # noqa: BLE001
                pass
        else:
            result.unconfirmed.append(dxl_id)
    return result
