"""Driving the robot: start-up checks, the real-time loop, and a safe stop on every exit path.

    report = drive(bus, robot, controller, duration_s=30, trace_path="run.csv")

Start-up pings every configured device and checks its model number (every problem in one
error), sets Return Delay Time 0, position mode, position limits from the joint ranges and
the Bus Watchdog, refuses servos with a latched hardware error, then turns torque on and
ramps slowly from the present pose to the controller's start pose.  The loop keeps a fixed
rate on absolute deadlines (an overrun re-syncs instead of catching up, and is counted);
each tick reads joints, feet and up-vector, activates, maps and sync-writes.  Whatever ends
the run - its duration, Ctrl-C, SIGTERM, an exception, lost communication, a hardware
error, a non-finite output - the robot ramps to its rest pose if the bus still answers and
torque goes off.  No MuJoCo here.
"""

from __future__ import annotations

import math
import signal
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from sim2real.bus.base import Bus, CommunicationError, ServoError, decode_hardware_error
from sim2real.bus.chain import ServoChain
from sim2real.errors import BipedError
from sim2real.mapping import ServoMapping
from sim2real.policy import Policy
from sim2real.robot import RobotSpec
from sim2real.trace import TraceWriter

POSITION_MODE = 3
WATCHDOG_MS = 100  # servos stop if the host is silent this long (X series: 20 ms units)
RAMP_S = 2.0  # start-up and shutdown ramps [s]
RAMP_TICK_S = 0.02
SPIN_S = 0.0005  # the loop spins this long before each deadline instead of sleeping (5 % of a 10 ms tick)


class StartupError(BipedError):
    """The bus does not hold the robot the config describes."""


class UnsafeOutput(BipedError):
    """The controller produced a non-finite goal: the last goals were held."""


class Shutdown(BaseException):
    """SIGTERM, raised in the main thread like KeyboardInterrupt."""


@dataclass
class RunReport:
    ticks: int = 0
    overruns: int = 0
    bus_errors: int = 0
    stop_reason: str = ""
    compute_s: list[float] = field(default_factory=list)
    jitter_s: list[float] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        def pct(values, q, scale):
            return float(np.percentile(values, q) * scale) if values else None

        return {"ticks": self.ticks, "overruns": self.overruns, "bus_errors": self.bus_errors,
                "stop_reason": self.stop_reason,
                "compute_us_p50": pct(self.compute_s, 50, 1e6), "compute_us_p99": pct(self.compute_s, 99, 1e6),
                "jitter_ms_p99": pct(self.jitter_s, 99, 1e3)}


def start_up(chain: ServoChain, mapping: ServoMapping, warn: Callable[[str], None] = print) -> None:
    problems = []
    for dxl_id, profile in chain.devices.items():
        try:
            model = chain._retry(lambda: chain.bus.ping(dxl_id))
        except CommunicationError:
            problems.append(f"ID {dxl_id} ({profile.model}) does not answer")
            continue
        if model != profile.model_number:
            problems.append(f"ID {dxl_id} is model number {model}, the config expects {profile.model} "
                            f"({profile.model_number})")
    if problems:
        raise StartupError("the bus does not match the robot config: " + "; ".join(problems))
    errors = []
    for dxl_id in chain.servo_ids:
        if "hardware_error_status" in chain.devices[dxl_id].control_table:
            try:
                status = chain.read(dxl_id, "hardware_error_status")
            except ServoError as exc:  # the alert bit comes with the very value we asked for
                if exc.value is None:
                    raise
                status = exc.value
            if status:
                errors.append(f"ID {dxl_id}: {decode_hardware_error(status)}")
    if errors:
        raise StartupError("hardware errors latched (power-cycle or REBOOT the servo): " + "; ".join(errors))
    chain.torque(False)  # EEPROM settings need torque off
    for k, dxl_id in enumerate(chain.servo_ids):
        profile = chain.devices[dxl_id]
        chain.write(dxl_id, "return_delay_time", 0)
        if "operating_mode" in profile.control_table:
            chain.write(dxl_id, "operating_mode", POSITION_MODE)
        if "min_position_limit" in profile.control_table:
            chain.write(dxl_id, "min_position_limit", int(mapping.tick_low[k]))
            chain.write(dxl_id, "max_position_limit", int(mapping.tick_high[k]))
        if "bus_watchdog" in profile.control_table:
            chain.write(dxl_id, "bus_watchdog", 0)  # clears a tripped watchdog
            chain.write(dxl_id, "bus_watchdog", WATCHDOG_MS // 20)
    latency = usb_latency_timer_ms(getattr(chain.bus, "port_name", None))
    if latency is not None and latency != 1:
        warn(f"warning: the USB adapter's latency timer is {latency} ms; set it to 1 ms "
             f"(echo 1 > /sys/bus/usb-serial/devices/<tty>/latency_timer)")


def usb_latency_timer_ms(port: str | None) -> int | None:
    """The FTDI latency timer of a /dev/ttyUSB* port (Linux sysfs), or None."""
    if not port:
        return None
    path = Path("/sys/bus/usb-serial/devices") / Path(port).name / "latency_timer"
    try:
        return int(path.read_text().strip())
    except (OSError, ValueError):
        return None


def ramp(chain: ServoChain, mapping: ServoMapping, start: np.ndarray, target: np.ndarray,
         seconds: float = RAMP_S, sleep: Callable[[float], None] = time.sleep) -> None:
    """Move goals linearly from ``start`` to ``target`` [rad] over ``seconds``."""
    steps = max(1, int(math.ceil(seconds / RAMP_TICK_S)))
    for k in range(1, steps + 1):
        chain.sync_write("goal_position", mapping.ticks(start + (target - start) * k / steps))
        sleep(RAMP_TICK_S)


class RealTimeLoop:
    def __init__(self, chain: ServoChain, mapping: ServoMapping, policy: Policy, tick_s: float,
                 trace: TraceWriter | None = None, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep):
        self.chain, self.mapping, self.policy, self.tick_s = chain, mapping, policy, tick_s
        self.trace, self.clock, self.sleep = trace, clock, sleep
        self.goal = policy.hold.copy()

    def run(self, duration_s: float | None, report: RunReport) -> None:
        start = deadline = self.clock()
        n_ticks = None if duration_s is None else int(round(duration_s / self.tick_s))
        while n_ticks is None or report.ticks < n_ticks:
            began = self.clock()
            report.jitter_s.append(max(0.0, began - deadline))
            t_bus = self.clock()
            angles = self.mapping.angles(self.chain.sync_read("present_position"))
            feet, up = self.chain.read_board()
            bus_s = self.clock() - t_bus
            t0 = self.clock()
            goal = self.policy.step(angles, feet, up, self.goal)
            compute_s = self.clock() - t0
            if not np.all(np.isfinite(goal)):
                raise UnsafeOutput(f"non-finite goal at tick {report.ticks}: held the last goals")
            t_bus = self.clock()
            self.chain.sync_write("goal_position", self.mapping.ticks(goal))
            bus_s += self.clock() - t_bus
            self.goal = goal
            report.compute_s.append(compute_s)
            deadline += self.tick_s
            now = self.clock()
            overrun = now > deadline
            if overrun:
                report.overruns += 1
                deadline = now  # re-sync: never try to catch up
            if self.trace is not None:
                self.trace.write(began - start, report.ticks, goal, angles, feet, up, compute_s, bus_s, overrun)
            report.ticks += 1
            if not overrun:
                self._wait_until(deadline)

    def _wait_until(self, deadline: float) -> None:
        """Sleep, then spin the last ``SPIN_S``: a thread woken from a long sleep starts late
        and runs its first microseconds cold (caches, clock frequency) - measured at ~4x the
        warm compute time on this project's machine."""
        remaining = deadline - self.clock()
        if remaining > SPIN_S:
            self.sleep(remaining - SPIN_S)
        while self.clock() < deadline:
            pass


def _on_sigterm(signum, frame):
    raise Shutdown()


def drive(bus: Bus, robot: RobotSpec, controller: dict[str, Any], duration_s: float | None = None,
          trace_path: Path | str | None = None, disabled_modules: tuple[str, ...] = (),
          log: Callable[[str], None] = print, clock: Callable[[], float] = time.monotonic,
          sleep: Callable[[float], None] = time.sleep, ramp_s: float = RAMP_S) -> RunReport:
    """Start up, ramp, run the loop, and always end safe; returns what happened."""
    report = RunReport()
    chain = ServoChain(bus, robot)
    mapping = ServoMapping(robot)
    policy = Policy(controller, robot, disabled_modules)
    trace = None
    previous = signal.signal(signal.SIGTERM, _on_sigterm) if _main_thread() else None
    loop = None
    bus.open()
    try:
        start_up(chain, mapping, warn=log)
        if trace_path is not None:
            trace = TraceWriter(trace_path, robot.joint_names, {
                "robot": robot.name, "controller_hash": controller["robot"]["joint_map_hash"],
                "controller_provenance": controller.get("provenance", {}), "tick_s": policy.tick_s,
                "software": "servo-biped-evolve"})
        present = mapping.angles(chain.sync_read("present_position"))
        chain.torque(True)
        ramp(chain, mapping, present, policy.reset(), ramp_s, sleep)
        loop = RealTimeLoop(chain, mapping, policy, policy.tick_s, trace, clock, sleep)
        loop.run(duration_s, report)
        report.stop_reason = "duration reached"
    except KeyboardInterrupt:
        report.stop_reason = "interrupted (Ctrl-C)"
    except Shutdown:
        report.stop_reason = "terminated (SIGTERM)"
    except ServoError as exc:
        report.bus_errors += 1
        detail = ""
        try:
            detail = decode_hardware_error(chain.read(exc.id, "hardware_error_status"))
        except ServoError as again:
            detail = decode_hardware_error(again.value or 0)
        except BipedError:
            pass
        report.stop_reason = f"{exc}" + (f" (hardware error: {detail})" if detail and detail != "none" else "")
    except CommunicationError as exc:
        report.bus_errors += 1
        report.stop_reason = f"lost communication: {exc}"
    except UnsafeOutput as exc:
        report.stop_reason = str(exc)
    except StartupError:
        _torque_off(chain)
        bus.close()
        raise
    except Exception as exc:  # a bug must not leave torque on
        report.stop_reason = f"error: {type(exc).__name__}: {exc}"
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        if report.stop_reason:
            _stop_safely(chain, mapping, policy, loop, report, sleep, ramp_s, log)
            if trace is not None:
                trace.close()
            bus.close()
    return report


def _stop_safely(chain, mapping, policy, loop, report, sleep, ramp_s, log) -> None:
    try:
        if "hardware" not in report.stop_reason:
            present = mapping.angles(chain.sync_read("present_position"))
            ramp(chain, mapping, present, policy.hold, ramp_s, sleep)
    except (BipedError, KeyboardInterrupt, Shutdown):
        log("warning: could not ramp to the rest pose; turning torque off")
    _torque_off(chain)


def _torque_off(chain: ServoChain) -> None:
    """Torque off on every servo that answers; keeps going past the ones that do not."""
    for dxl_id in chain.servo_ids:
        try:
            chain.write(dxl_id, "torque_enable", 0)
        except (BipedError, ValueError):
            continue


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()
