"""Every signal that can be caught ends a run in a safe stop, torque read back off (issue 31).

In process: the runtime drives emulated servos through the official SDK on a pseudo-terminal,
signals are real (``os.kill`` of this process, from a timer thread at random moments, so
they land anywhere: inside an SDK exchange, a trace write, a sleep), and Torque Enable is
read straight from the emulated servos.  Through the command line: ``biped run --port``
against a standalone simulated bus, read back through the SDK after the run; ``biped run
--bus mock`` and ``biped dry-run`` (signalled as a terminal does, to the whole process group)
report their own read-back.
"""

from __future__ import annotations

import errno
import json
import os
import queue
import random
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from sim2real.hardware import MockBus
from sim2real.hardware.bus import CommunicationError
from sim2real.hardware.deploy import drive
from sim2real.hardware.safe_stop import STOP_SIGNALS, signal_stop_reason
from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus
from sim2real.hardware.trace import TraceWriter
from sim2real.robot import load_robot
from sim2real.simulation.simbus.server import EmulatedChain, PtyServer
from tests.test_stop_paths import Hooks

ROOT = Path(__file__).resolve().parent.parent
ROBOT = load_robot()
SERVOS = [j.servo.id for j in ROBOT.joints]
TORQUE_ENABLE = ROBOT.joints[0].servo.profile.register("torque_enable").address
RANDOM_SIGINTS = 25  # the issue asks for at least 20 SIGINTs with a trace at random moments


@pytest.fixture(scope="module")
def controller(grown_controller):
    return grown_controller


def emulated_torque(chain) -> dict[int, int]:
    return {i: chain.devices[i].get_named("torque_enable") for i in SERVOS}


def run(port, controller, **kw):
    # lost_after_s 2 s: what is tested is the stop, not whether a loaded host stalls 100 ms
    kw = {"duration_s": 0.6, "ramp_s": 0.1, "lost_after_s": 2.0, **kw}
    return drive(DynamixelBus(port, 1_000_000, ROBOT), ROBOT, controller, log=lambda s: None, **kw)


def assert_all_off(chain, report):
    assert report.torque_off.confirmed == SERVOS and report.torque_off.unconfirmed == []
    assert all(v == 0 for v in emulated_torque(chain).values()), emulated_torque(chain)


# -- in process -----------------------------------------------------------------------------------


@pytest.mark.parametrize("signum", STOP_SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_every_stop_signal_ends_in_a_safe_stop(served_chain, controller, signum):
    chain, port = served_chain
    # sent from the loop's own sleep, not a timer: a timer that fired before drive() had its
    # handlers (a slow start-up) would meet the signal's default action, in pytest itself
    report = run(port, controller, duration_s=5.0, sleep=Hooks(in_loop=lambda: os.kill(os.getpid(), signum)))
    name = signal.Signals(signum).name
    assert report.stop_signal == name and report.stop_reason == signal_stop_reason(name)
    assert_all_off(chain, report)


def test_sigints_at_random_moments_while_tracing_always_end_with_torque_off(controller_file, tmp_path):
    """The reported failure: a SIGINT that landed inside an SDK exchange left the port flagged
    busy, every later packet was refused and all 11 servos stayed powered (2 in 6 traced
    runs).  Signals now land anywhere - start-up, ramp, loop, trace write, final ramp - of runs
    in a child process (``tests/sigint_child.py``), at moments from a seeded generator after
    each run's start.  Never in this process: here, one that came after a run had ended was a
    KeyboardInterrupt that stopped pytest."""
    rng = random.Random(31)
    moments = [rng.uniform(0.0, 0.9) for _ in range(RANDOM_SIGINTS)]  # a run lasts about 0.8 s: some land after it
    child = subprocess.Popen([sys.executable, "-m", "tests.sigint_child", str(controller_file), str(tmp_path)],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=ROOT)
    lines: queue.Queue[str] = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in child.stdout] and None, daemon=True).start()
    stop_reasons = []
    try:
        for k, delay in enumerate(moments):
            child.stdin.write(f"run {k}\n")
            child.stdin.flush()
            assert read_line(child, lines) == f"start {k}"
            time.sleep(delay)
            child.send_signal(signal.SIGINT)
            result = json.loads(read_line(child, lines))
            assert result["confirmed"] == SERVOS and result["unconfirmed"] == [], result
            assert result["torque"] == [0] * len(SERVOS), result  # read straight from the emulated servos
            stop_reasons.append(result["stop_reason"])
    finally:
        child.stdin.close()
        child.wait(timeout=30)
    assert child.returncode == 0
    assert "interrupted (Ctrl-C)" in stop_reasons  # most land in the loop


def read_line(child: subprocess.Popen, lines: "queue.Queue[str]", timeout_s: float = 30.0) -> str:
    """The child's next line of output (``lines``, fed by a thread); an assertion if none comes
    within ``timeout_s``."""
    try:
        return lines.get(timeout=timeout_s).strip()
    except queue.Empty:
        raise AssertionError(f"no line from the child in {timeout_s:.0f} s (exit {child.poll()})") from None


def test_a_second_signal_during_the_stop_only_cuts_the_ramp_short(served_chain, controller):
    chain, port = served_chain
    hooks = Hooks(in_loop=lambda: os.kill(os.getpid(), signal.SIGHUP),
                  in_final_ramp=lambda: os.kill(os.getpid(), signal.SIGINT), ramp_s=1.0)
    report = run(port, controller, duration_s=5.0, ramp_s=1.0, sleep=hooks)
    assert report.stop_signal == "SIGHUP"
    assert "ramp to rest cut short by SIGINT" in report.stop_notes
    assert_all_off(chain, report)


def test_an_exception_inside_an_sdk_exchange_leaves_the_port_usable(served_chain, monkeypatch):
    """Whatever ends an exchange, the next one is not refused as 'port is in use'."""
    chain, port = served_chain
    bus = DynamixelBus(port, 1_000_000, ROBOT)
    bus.open()
    try:
        real_read_port = type(bus.port).readPort
        fired = {"n": 0}

        def interrupted_read(self, length):
            if fired["n"] == 0:
                fired["n"] += 1
                raise KeyboardInterrupt  # as a signal handler's exception would, mid-reply
            return real_read_port(self, length)

        monkeypatch.setattr(type(bus.port), "readPort", interrupted_read)
        with pytest.raises(KeyboardInterrupt):
            bus.read(SERVOS[0], TORQUE_ENABLE, 1)
        assert not bus.port.is_using
        assert bus.read(SERVOS[0], TORQUE_ENABLE, 1) == 0
    finally:
        bus.close()


def test_a_serial_error_becomes_a_communication_error(served_chain, monkeypatch):
    import serial

    chain, port = served_chain
    bus = DynamixelBus(port, 1_000_000, ROBOT)
    bus.open()
    try:
        def gone(self, length):
            raise serial.SerialException("device reports readiness to read but returned no data")

        monkeypatch.setattr(type(bus.port), "readPort", gone)
        with pytest.raises(CommunicationError, match="returned no data"):
            bus.read(SERVOS[0], TORQUE_ENABLE, 1)
        assert not bus.port.is_using
    finally:
        bus.close()


def test_a_trace_that_cannot_be_written_stops_the_run_safely(served_chain, controller, tmp_path, monkeypatch):
    chain, port = served_chain
    real_write, calls = TraceWriter.write, {"n": 0}

    def full_disk(self, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 5:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_write(self, *args, **kwargs)

    monkeypatch.setattr(TraceWriter, "write", full_disk)
    report = run(port, controller, duration_s=5.0, trace_path=tmp_path / "t.csv")
    assert report.stop_reason.startswith(f"cannot write the trace {tmp_path / 't.csv'}")
    assert "No space left" in report.stop_reason
    assert_all_off(chain, report)


def test_a_trace_that_cannot_be_closed_does_not_hide_the_report(served_chain, controller, tmp_path, monkeypatch):
    chain, port = served_chain

    def fail_close(self):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(TraceWriter, "close", fail_close)
    report = run(port, controller, trace_path=tmp_path / "t.csv")
    assert report.stop_reason == "duration reached"
    assert any("trace's last rows were not written" in note for note in report.stop_notes)
    assert_all_off(chain, report)


def test_a_log_that_cannot_be_written_does_not_keep_torque_on(served_chain, controller):
    """After a SIGHUP the terminal is gone: every write to it fails (EIO)."""
    chain, port = served_chain

    def gone(line):
        raise OSError(errno.EIO, "Input/output error")

    report = drive(DynamixelBus(port, 1_000_000, ROBOT), ROBOT, controller, duration_s=0.3, ramp_s=0.1,
                   lost_after_s=2.0, log=gone)
    assert_all_off(chain, report)


# -- through the command line ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def controller_file(controller, tmp_path_factory):
    path = tmp_path_factory.mktemp("c") / "c.json"
    controller.save(path)
    return path


@pytest.fixture(scope="module")
def simbus_port():
    """A standalone simulated bus, as `biped simbus` serves it."""
    proc = subprocess.Popen([sys.executable, "-m", "sim2real.simulation.simbus", "--exit-on-stdin-eof", "--no-mlock"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        yield proc.stdout.readline().strip()
    finally:
        proc.stdin.close()
        proc.wait(timeout=30)


def read_torque(port) -> dict[int, int]:
    bus = DynamixelBus(port, 1_000_000, ROBOT)
    bus.open()
    try:
        return {i: bus.read(i, TORQUE_ENABLE, 1) for i in SERVOS}
    finally:
        bus.close()


def biped(*args: str, **popen) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "evolve.cli", *args, "--json", "--no-mlock"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **popen)


def wait_for_loop(trace: Path, timeout_s: float = 60.0) -> None:
    """Until the trace has rows: the loop has run for at least a second (rows are flushed once a second)."""
    give_up = time.monotonic() + timeout_s
    while time.monotonic() < give_up:
        if trace.exists() and len(trace.read_text().splitlines()) > 2:
            return
        time.sleep(0.05)
    raise AssertionError(f"the run never wrote {trace}")


def finish(proc: subprocess.Popen) -> tuple[dict, str]:
    out, err = proc.communicate(timeout=120)
    assert "Traceback" not in err and "Fatal Python error" not in err, err
    assert proc.returncode == 0, err
    return json.loads(out.splitlines()[-1]), err


@pytest.mark.parametrize("signame", ["SIGINT", "SIGINT", "SIGINT", "SIGHUP", "SIGQUIT", "SIGTSTP"])
def test_biped_run_on_a_port_stops_safely_on_a_signal_while_tracing(controller_file, simbus_port, tmp_path, signame):
    trace = tmp_path / "t.csv"
    proc = biped("run", str(controller_file), "--port", simbus_port, "--duration", "30", "--trace", str(trace),
                 "--lost-after-ms", "2000")
    wait_for_loop(trace)
    time.sleep(random.uniform(0.0, 1.0))
    proc.send_signal(getattr(signal, signame))
    result, _ = finish(proc)
    assert result["stop_signal"] == signame
    assert result["torque_off"] == {"confirmed": SERVOS, "unconfirmed": []}
    assert all(v == 0 for v in read_torque(simbus_port).values())  # read back through the SDK here


def test_biped_run_on_the_mock_bus_stops_safely_on_sighup(controller_file, tmp_path):
    trace = tmp_path / "t.csv"
    proc = biped("run", str(controller_file), "--bus", "mock", "--duration", "30", "--trace", str(trace))
    wait_for_loop(trace)
    proc.send_signal(signal.SIGHUP)
    result, _ = finish(proc)
    assert result["stop_signal"] == "SIGHUP"
    assert result["torque_off"] == {"confirmed": SERVOS, "unconfirmed": []}


@pytest.mark.parametrize("signame", ["SIGINT", "SIGINT", "SIGHUP"])
def test_dry_run_signalled_as_a_terminal_does_stops_safely(controller_file, tmp_path, signame):
    """A terminal's Ctrl-C (or hang-up) reaches the whole foreground process group: the simulated
    bus the dry run started must outlive the run's safe stop (it crashed at once before)."""
    trace = tmp_path / "t.csv"
    proc = biped("dry-run", str(controller_file), "--duration", "30", "--trace", str(trace), "--lost-after-ms", "2000",
                 start_new_session=True)  # its own group, so that this test's runner is not signalled
    wait_for_loop(trace)
    time.sleep(random.uniform(0.0, 1.0))
    os.killpg(proc.pid, getattr(signal, signame))
    result, err = finish(proc)
    assert result["stop_signal"] == signame
    assert result["torque_off"] == {"confirmed": SERVOS, "unconfirmed": []}
    assert "torque off, read back from all 11 servos" in err


# -- a simulated bus held up by its computer (issue 31, section 5) -------------------------------


def test_a_held_up_simulated_bus_says_so(monkeypatch, capsys):
    """Beside a process first-touching 11 GiB, this machine held the simulated bus up for 79 ms
    and the runtime reported lost communication: the bus now records and reports such stalls."""
    from sim2real.simulation.simbus.server import STALL_S
    from sim2real.simulation.simbus.service import _warn_of_stalls, stall_summary

    chain = EmulatedChain(MockBus(ROBOT).devices)
    real_tick, held = chain.tick, {"n": 0}

    def tick():
        held["n"] += 1
        if held["n"] == 20:
            time.sleep(3 * STALL_S)  # as a busy computer would hold the serving thread
        real_tick()

    monkeypatch.setattr(chain, "tick", tick)
    with PtyServer(chain, baud=1_000_000) as server:
        give_up = time.monotonic() + 10
        while not server.stalls and time.monotonic() < give_up:
            time.sleep(0.05)
    assert max(length for _, length in server.stalls) >= 3 * STALL_S  # a natural stall may come first
    summary = stall_summary(server.stalls)
    assert summary["count"] == len(server.stalls) and summary["longest_ms"] >= 3e3 * STALL_S
    assert _warn_of_stalls(server.stalls, 0) == len(server.stalls)
    assert "the simulated bus was held up" in capsys.readouterr().err
