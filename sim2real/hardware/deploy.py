"""Driving the robot: the checks before any servo moves, start-up, the run, and the safe stop.

    report = drive(bus, robot, controller, duration_s=30, trace_path="run.csv")

Before anything moves, :func:`drive` refuses what cannot run: commands the controller cannot
take, a duration shorter than a tick, a sensor the board lacks, a bus that cannot serve the tick
(:func:`sim2real.controller.robot_checks.bus_problems`, before the port opens).  Start-up
(:mod:`sim2real.hardware.dynamixel.startup`) checks that the bus holds the robot of the config
and configures its servos; then torque goes on, the goals ramp slowly from the present pose to
the controller's start pose, and the real-time loop runs (:mod:`sim2real.hardware.loop`).  The
servos' Bus Watchdog stops them on its own if the host itself goes silent.

Whatever ends the run, the safe stop (:mod:`sim2real.hardware.safe_stop`) follows in a
``finally``: the robot ramps to its rest pose if the bus still answers, torque goes off, and
every servo's Torque Enable is read back into the report (:mod:`sim2real.hardware.run_report`).
No MuJoCo here.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Callable

from sim2real.controller.channels import CHANNELS
from sim2real.controller.file import Controller
from sim2real.controller.mapping import ServoMapping
from sim2real.controller.policy import Policy
from sim2real.controller.robot_checks import bus_problems
from sim2real.errors import ConfigError, UsageError
from sim2real.hardware.bus import Bus
from sim2real.hardware.dynamixel.chain import ServoChain, board_reports
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.hardware.dynamixel.startup import StartupError, start_up
from sim2real.hardware.loop import (
    LOST_AFTER_S,
    RAMP_S,
    GoalSource,
    RealTimeLoop,
    TraceWriteError,
    ramp,
    read_budget,
)
from sim2real.hardware.realtime import (
    RealtimeRequest,
    no_garbage_collection,
    release_realtime,
    request_realtime,
)
from sim2real.hardware.readings import MotionReadings, traced_registers
from sim2real.hardware.run_report import RunReport
from sim2real.hardware.safe_stop import (
    PATIENCE_S,
    PATIENT_ATTEMPTS,
    SafeLog,
    StopSignals,
    stop_reason,
    stop_safely,
)
from sim2real.hardware.trace import GYRO_CHANNELS, HEADING_CHANNEL, Channel, TraceWriter
from sim2real.robot import RobotSpec


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
    log = SafeLog(log)
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
            report.stop_reason = stop_reason(exc, chain, report)
        finally:
            signals.stopping = True  # from here on a signal only cuts the ramp short
            if on_loop_end is not None:
                try:
                    on_loop_end()
                except Exception:  # noqa: BLE001 - a report's hook must not keep torque on
                    report.stop_notes.append("the end-of-loop hook failed")
            stop_safely(chain, mapping, policy, report, signals, sleep, ramp_s, log,
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
