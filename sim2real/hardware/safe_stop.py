"""The safe stop: on every way out of a run, ramp to rest if the bus still answers, torque
off, and every servo's Torque Enable read back.

Whatever ends the run - its duration, a signal (Ctrl-C, SIGTERM, a closed terminal's SIGHUP,
SIGQUIT, Ctrl-Z and every other signal whose default would end or stop the process; see
:class:`StopSignals`), an exception, ``SystemExit``, lost communication, a hardware error, a
non-finite output, a trace that cannot be written - :func:`stop_safely` ramps the robot to its
rest pose if the bus still answers, turns torque off and reads every servo's Torque Enable
back (:func:`torque_off`): the report lists the servos confirmed off and those that are not.
Signals never interrupt a bus exchange or a trace write: they are taken between ticks.  Signals
that arrive during the stop cut the ramp short; nothing skips the torque-off.
:func:`sim2real.hardware.deploy.drive` calls it from its ``finally``.
"""

from __future__ import annotations

import signal
import threading
import time
from typing import Any, Callable

import numpy as np

from sim2real.controller.mapping import ServoMapping
from sim2real.errors import BipedError
from sim2real.hardware.bus import CommunicationError, ServoError
from sim2real.hardware.dynamixel.chain import ServoChain
from sim2real.hardware.dynamixel.errors import decode_hardware_error
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.hardware.dynamixel.startup import StartupError
from sim2real.hardware.loop import GoalSource, TraceWriteError, UnsafeOutput, ramp
from sim2real.hardware.run_report import RunReport, TorqueOff

# Start-up and torque-off keep asking a device at least this often and this long: nothing
# moves meanwhile, and a host busy for a few tens of ms must not make a servo look silent
# (or, at the end, make the tool tell the user to cut the power for nothing).
PATIENT_ATTEMPTS = 3
PATIENCE_S = 0.3


class StopRequested(BaseException):
    """A signal asked the run to stop; raised by the loop itself between two ticks (never
    from inside a bus exchange), so it is a ``BaseException`` like ``KeyboardInterrupt``."""

    def __init__(self, signal_name: str):
        super().__init__(signal_name)
        self.signal_name = signal_name


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
    """The report's stop reason for a signal by its name (``"SIGINT"``)."""
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


class SafeLog:
    """The run's log, which never raises: after a SIGHUP the terminal is gone and writing to
    it fails (EIO), and no message may keep the stop from turning torque off."""

    def __init__(self, log: Callable[[str], None]):
        self.log = log

    def __call__(self, line: str) -> None:
        try:
            self.log(line)
        except Exception:  # noqa: BLE001 - a lost terminal must not keep torque on
            pass


def stop_reason(exc: BaseException, chain: ServoChain, report: RunReport) -> str:
    """The report's stop reason for what ended the run (counting a bus error, and naming the
    signal, into ``report``); a servo's latched hardware error is read and decoded if it answers."""
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


def stop_safely(chain: ServoChain, mapping: ServoMapping, policy: GoalSource, report: RunReport,
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
