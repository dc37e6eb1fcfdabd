"""The servos' Bus Watchdog: the only guard left when the computer driving them dies at once
(SIGKILL, a kernel panic, a pulled cable), since then nothing turns torque off.

Start-up sets it to 100 ms on every X-series servo.  What the firmware then does, from the
ROBOTIS e-manual ("Bus Watchdog(98)", X series control tables): it watches while Torque Enable
is 1; after longer than its value (20 ms units) without an instruction packet the servo stops
and the entry reads -1; the goal entries are read-only (a Data Range Error) until 0 is written
there.  Torque Enable stays 1: the servo holds where it stopped.  These tests hold the emulated
servos (``MockDevice``, behind the mock bus and the simulated bus) to that: first on a fake clock,
then over a pseudo-terminal through the official SDK, then with a real ``biped run`` killed
mid-walk.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from sim2real.hardware import MockBus
from sim2real.hardware.bus import ServoError
from sim2real.hardware.dynamixel.errors import ALERT_BIT, DATA_RANGE_ERROR
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.robot.timing import WATCHDOG_MS, WATCHDOG_UNIT_MS
from sim2real.hardware.mock import WATCHDOG_GOALS
from sim2real.robot import load_robot
from sim2real.robot.paths import data_root
from sim2real.robot.profiles import load_profile
from sim2real.simulation.simbus import protocol2 as p2
from sim2real.simulation.simbus.server import EmulatedChain, PtyServer

ROBOT = load_robot()
SERVOS = [j.servo.id for j in ROBOT.joints]
PROFILE = ROBOT.joints[0].servo.profile  # XL430-W250-T: every servo of the default robot
WATCHDOG = WATCHDOG_MS // WATCHDOG_UNIT_MS  # what start-up writes: 5 (x 20 ms)
EXPIRED_RAW = 0xFF  # -1 in the one-byte, signed entry
WALKER = data_root() / "configs" / "controllers" / "xl430_biped_no_gyro.json"


def address(name: str) -> int:
    return PROFILE.register(name).address


class Wire:
    """Instruction packets straight into an :class:`EmulatedChain` (no pseudo-terminal, a
    clock the test moves); replies decoded: (error byte, value)."""

    def __init__(self, chain: EmulatedChain):
        self.chain = chain

    def _status(self, reply: bytes) -> tuple[int, int]:
        [(_, inst, params)] = p2.Parser().feed(reply)
        assert inst == p2.STATUS
        return params[0], int.from_bytes(params[1:], "little")

    def write(self, dxl_id: int, name: str, value: int) -> int:
        reg = PROFILE.register(name)
        data = (value & ((1 << (8 * reg.size)) - 1)).to_bytes(reg.size, "little")
        return self._status(self.chain.handle(dxl_id, p2.WRITE, reg.address.to_bytes(2, "little") + data))[0]

    def read(self, dxl_id: int, name: str) -> tuple[int, int]:
        reg = PROFILE.register(name)
        params = reg.address.to_bytes(2, "little") + reg.size.to_bytes(2, "little")
        return self._status(self.chain.handle(dxl_id, p2.READ, params))


def idle(chain: EmulatedChain, now: list[float], seconds: float, step_s: float = 0.01) -> None:
    """The wire stays silent for ``seconds``: the serving thread ticks the chain every ``step_s``."""
    for _ in range(int(round(seconds / step_s))):
        now[0] += step_s
        chain.tick()


def test_the_goal_entries_it_locks_are_in_the_x_series_profiles():
    """The names the emulation locks are spelt as the profiles spell them."""
    for model in ("xl430_w250_t", "xm430_w350", "xl330_m288_t", "mx28_p2"):
        table = load_profile(model).control_table
        assert Reg.BUS_WATCHDOG in table and table[Reg.BUS_WATCHDOG].address == 98
        assert {"goal_pwm", "goal_velocity", Reg.GOAL_POSITION} <= {g for g in WATCHDOG_GOALS if g in table}


def test_a_silent_host_stops_the_servo_which_keeps_torque_and_refuses_goals_until_cleared():
    now = [0.0]
    chain = EmulatedChain(MockBus(ROBOT).devices, clock=lambda: now[0])
    wire = Wire(chain)
    servo = chain.devices[1]
    start = servo.get_named(Reg.PRESENT_POSITION)
    assert wire.write(1, Reg.BUS_WATCHDOG, WATCHDOG) == 0
    assert wire.write(1, Reg.TORQUE_ENABLE, 1) == 0
    assert wire.write(1, Reg.GOAL_POSITION, start + 1500) == 0  # 0.39 s away at the no-load speed
    idle(chain, now, 0.09)
    assert servo.get_named(Reg.BUS_WATCHDOG) == WATCHDOG  # not yet: 90 ms of silence
    idle(chain, now, 0.05)
    stopped = servo.get_named(Reg.PRESENT_POSITION)
    speed = PROFILE.motor.no_load_speed_rad_s / PROFILE.position.rad_per_tick  # [tick/s]
    assert speed * 0.09 < stopped - start <= speed * 0.11 + 1  # it stopped at 100-110 ms, not at the goal
    idle(chain, now, 1.0)
    assert servo.get_named(Reg.PRESENT_POSITION) == stopped  # and stays there

    # what the host finds when it talks again: no alert, no hardware error, torque on
    assert wire.read(1, Reg.BUS_WATCHDOG) == (0, EXPIRED_RAW)
    assert wire.read(1, Reg.TORQUE_ENABLE) == (0, 1)
    assert wire.read(1, Reg.GOAL_POSITION) == (0, stopped)  # the goal is where it stopped
    assert wire.read(1, Reg.HARDWARE_ERROR_STATUS) == (0, 0)
    error = wire.write(1, Reg.GOAL_POSITION, start)
    assert error == DATA_RANGE_ERROR and not error & ALERT_BIT  # refused, and nothing applied
    assert wire.read(1, Reg.GOAL_POSITION) == (0, stopped)
    # only 0 clears it (the e-manual names no other way; a new setting first is refused here)
    assert wire.write(1, Reg.BUS_WATCHDOG, WATCHDOG) == DATA_RANGE_ERROR
    assert wire.write(1, Reg.BUS_WATCHDOG, 0) == 0
    assert wire.read(1, Reg.BUS_WATCHDOG) == (0, 0)
    # then goals are taken again and the servo moves, without torque being enabled again
    assert wire.write(1, Reg.GOAL_POSITION, start) == 0
    idle(chain, now, 0.5)
    assert servo.get_named(Reg.PRESENT_POSITION) == start


def test_no_watch_while_torque_is_off_and_any_packet_feeds_it():
    now = [0.0]
    chain = EmulatedChain(MockBus(ROBOT).devices, clock=lambda: now[0])
    wire = Wire(chain)
    for dxl_id in (1, 2):
        assert wire.write(dxl_id, Reg.BUS_WATCHDOG, WATCHDOG) == 0
    assert wire.write(1, Reg.TORQUE_ENABLE, 1) == 0
    for _ in range(20):  # 1 s during which the host talks only to servo 2, every 50 ms
        idle(chain, now, 0.05)
        wire.read(2, Reg.PRESENT_POSITION)
    assert chain.devices[1].get_named(Reg.BUS_WATCHDOG) == WATCHDOG  # every servo hears every packet
    idle(chain, now, 1.0)
    assert chain.devices[1].get_named(Reg.BUS_WATCHDOG) == EXPIRED_RAW
    assert chain.devices[2].get_named(Reg.BUS_WATCHDOG) == WATCHDOG  # torque off: not watching


def test_the_simulators_own_stall_does_not_trip_it():
    """Checked on the idle wire only: a simulated bus that was itself held up (no tick for a
    second) and then finds an instruction waiting has not seen a silent host."""
    now = [0.0]
    chain = EmulatedChain(MockBus(ROBOT).devices, clock=lambda: now[0])
    wire = Wire(chain)
    assert wire.write(1, Reg.BUS_WATCHDOG, WATCHDOG) == 0 and wire.write(1, Reg.TORQUE_ENABLE, 1) == 0
    now[0] += 1.0
    assert wire.read(1, Reg.BUS_WATCHDOG) == (0, WATCHDOG)


def test_the_physics_behind_the_simulated_bus_stops_too():
    """The same on the MuJoCo-backed servos: the waist, sent 44 deg away, stops where it was
    when the watchdog expired (about 300 of 500 ticks, after a little overshoot; without the
    watchdog, the whole way) and holds there."""
    from sim2real.simulation.simbus.physics import PhysicsChain

    now = [0.0]
    physics = PhysicsChain(ROBOT, clock=lambda: now[0])
    chain = EmulatedChain(physics.devices, clock=lambda: now[0], advance=physics.advance)
    wire = Wire(chain)
    for dxl_id in SERVOS:
        assert wire.write(dxl_id, Reg.BUS_WATCHDOG, WATCHDOG) == 0 and wire.write(dxl_id, Reg.TORQUE_ENABLE, 1) == 0
    _, start = wire.read(1, Reg.PRESENT_POSITION)
    assert wire.write(1, Reg.GOAL_POSITION, start + 500) == 0
    idle(chain, now, 1.0)
    waist = physics.devices[1]
    held = waist.get_named(Reg.PRESENT_POSITION)
    assert 100 < held - start < 400, held - start
    assert abs(waist.get_named(Reg.GOAL_POSITION) - held) <= 50  # the stop's own goal, overshot a little
    idle(chain, now, 1.0)
    # still: at most a creep of the position loop back through friction to its goal [tick]
    assert abs(waist.get_named(Reg.PRESENT_POSITION) - held) <= 3
    assert all(physics.devices[i].get_named(Reg.TORQUE_ENABLE) == 1 for i in SERVOS)
    assert all(physics.devices[i].get_named(Reg.BUS_WATCHDOG) == EXPIRED_RAW for i in SERVOS)
    assert abs(float(physics.data.qvel[physics.angles.servo_dof[0]])) < 0.05  # [rad/s]


def test_the_mock_bus_stops_a_servo_where_it_was_when_the_watchdog_expired():
    now = [0.0]
    bus = MockBus(ROBOT, clock=lambda: now[0])
    bus.open()
    start = bus.read(1, address(Reg.PRESENT_POSITION), 4)
    bus.write(1, address(Reg.BUS_WATCHDOG), 1, WATCHDOG)
    bus.write(1, address(Reg.TORQUE_ENABLE), 1, 1)
    bus.write(1, address(Reg.GOAL_POSITION), 4, start + 1500)
    now[0] += 0.5  # silent: the next instruction finds a servo stopped 100 ms after the last one
    speed = PROFILE.motor.no_load_speed_rad_s / PROFILE.position.rad_per_tick  # [tick/s]
    assert bus.read(1, address(Reg.PRESENT_POSITION), 4) - start == pytest.approx(speed * 0.1, abs=1)
    assert bus.read(1, address(Reg.BUS_WATCHDOG), 1) == EXPIRED_RAW
    assert bus.read(1, address(Reg.TORQUE_ENABLE), 1) == 1
    with pytest.raises(ServoError, match="data range error"):
        bus.write(1, address(Reg.GOAL_POSITION), 4, start)
    bus.reboot(1)  # a REBOOT resets the RAM entries as power-on does: torque off, watchdog off
    assert bus.read(1, address(Reg.BUS_WATCHDOG), 1) == 0 and bus.read(1, address(Reg.TORQUE_ENABLE), 1) == 0


# -- through the official SDK, on a pseudo-terminal, in real time -------------------------------------


class Sdk:
    """The official ``dynamixel_sdk`` on a port; reads and writes retried a few times (a packet
    cut by a killed process may still sit in the simulated bus's parser)."""

    def __init__(self, port: str):
        from dynamixel_sdk import PacketHandler, PortHandler

        self.port = PortHandler(port)
        assert self.port.openPort() and self.port.setBaudRate(1_000_000)
        self.packets = PacketHandler(2.0)

    def close(self) -> None:
        self.port.closePort()

    def _retry(self, call):
        from dynamixel_sdk import COMM_SUCCESS

        for _ in range(5):
            *value, result, error = call()
            if result == COMM_SUCCESS:
                return (value[0] if value else None), error
        raise AssertionError(f"no status packet: {self.packets.getTxRxResult(result)}")

    def read(self, dxl_id: int, name: str) -> tuple[int, int]:
        """(value as the SDK returns it: unsigned, error byte)."""
        reg = PROFILE.register(name)
        method = {1: self.packets.read1ByteTxRx, 2: self.packets.read2ByteTxRx,
                  4: self.packets.read4ByteTxRx}[reg.size]
        return self._retry(lambda: method(self.port, dxl_id, reg.address))

    def write(self, dxl_id: int, name: str, value: int) -> int:
        """The status packet's error byte."""
        reg = PROFILE.register(name)
        method = {1: self.packets.write1ByteTxRx, 2: self.packets.write2ByteTxRx,
                  4: self.packets.write4ByteTxRx}[reg.size]
        return self._retry(lambda: method(self.port, dxl_id, reg.address, value & ((1 << (8 * reg.size)) - 1)))[1]


def wait_until_expired(port: str, timeout_s: float = 60.0) -> Sdk:
    """Stay silent a second, then ask every servo's Bus Watchdog; again until all read -1.
    (Asking feeds the watchdog: never poll faster than it expires.)"""
    deadline = time.monotonic() + timeout_s
    while True:
        time.sleep(1.0)
        sdk = Sdk(port)
        values = {i: sdk.read(i, Reg.BUS_WATCHDOG)[0] for i in SERVOS}
        if all(v == EXPIRED_RAW for v in values.values()):
            return sdk
        sdk.close()
        assert time.monotonic() < deadline, f"Bus Watchdog never expired: {values}"


def test_over_the_wire_the_sdk_reads_what_a_real_servo_reports():
    chain = EmulatedChain(MockBus(ROBOT).devices)
    with PtyServer(chain, baud=1_000_000) as server:
        sdk = Sdk(server.port)
        try:
            for dxl_id in SERVOS:
                assert sdk.write(dxl_id, Reg.BUS_WATCHDOG, WATCHDOG) == 0
                assert sdk.write(dxl_id, Reg.TORQUE_ENABLE, 1) == 0
        finally:
            sdk.close()
        sdk = wait_until_expired(server.port)
        try:
            for dxl_id in SERVOS:
                assert sdk.read(dxl_id, Reg.TORQUE_ENABLE) == (1, 0)
                assert sdk.read(dxl_id, Reg.HARDWARE_ERROR_STATUS) == (0, 0)
                goal, _ = sdk.read(dxl_id, Reg.GOAL_POSITION)
                assert sdk.write(dxl_id, Reg.GOAL_POSITION, goal + 100) == DATA_RANGE_ERROR
                assert sdk.read(dxl_id, Reg.GOAL_POSITION) == (goal, 0)
                assert sdk.write(dxl_id, Reg.BUS_WATCHDOG, 0) == 0
                assert sdk.write(dxl_id, Reg.GOAL_POSITION, goal + 100) == 0
                assert sdk.write(dxl_id, Reg.TORQUE_ENABLE, 0) == 0
        finally:
            sdk.close()


def test_biped_run_killed_mid_walk_leaves_servos_stopped_with_torque_on(tmp_path):
    """SIGKILL cannot be caught: `biped run` on the standalone simulated bus, killed while it
    walks, never turns torque off.  Read back through the official SDK: the watchdog stopped
    every servo - Torque Enable 1, Bus Watchdog -1, the goal where the servo is, goals refused,
    present positions still - which is all a real X-series chain does when its computer dies."""
    simbus = subprocess.Popen([sys.executable, "-m", "sim2real.simulation.simbus", "--exit-on-stdin-eof", "--no-mlock"],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    run_ = None
    try:
        port = simbus.stdout.readline().strip()
        assert port.startswith("/dev/"), port
        trace = tmp_path / "walk.csv"
        # --lost-after-ms 5000: a loaded machine's stall must not end the run before the kill
        run_ = subprocess.Popen([sys.executable, "-m", "evolve.cli", "run", str(WALKER), "--port", port,
                                 "--duration", "120", "--trace", str(trace), "--no-mlock", "--lost-after-ms", "5000"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 120
        # walking: the trace (flushed every second) holds a second of the loop's rows
        while not (trace.exists() and len(trace.read_text().splitlines()) > 30):
            assert run_.poll() is None, f"biped run ended before it walked (exit {run_.returncode})"
            assert time.monotonic() < deadline, "biped run never reached its loop"
            time.sleep(0.2)
        os.kill(run_.pid, signal.SIGKILL)
        assert run_.wait(timeout=30) == -signal.SIGKILL
        sdk = wait_until_expired(port)
        try:
            assert {i: sdk.read(i, Reg.TORQUE_ENABLE)[0] for i in SERVOS} == {i: 1 for i in SERVOS}
            assert all(sdk.read(i, Reg.HARDWARE_ERROR_STATUS) == (0, 0) for i in SERVOS)
            # a robot stopped mid-step topples (measured: it does, in about a second), and then
            # its joints creep a few ticks back to their goals through friction, less each second
            time.sleep(2.0)
            first = np.array([sdk.read(i, Reg.PRESENT_POSITION)[0] for i in SERVOS])
            time.sleep(1.0)
            second = np.array([sdk.read(i, Reg.PRESENT_POSITION)[0] for i in SERVOS])
            assert np.all(np.abs(second - first) <= 5), (first, second)  # [tick]; walking moves hundreds
            goals = [sdk.read(i, Reg.GOAL_POSITION)[0] for i in SERVOS]
            for dxl_id, goal in zip(SERVOS, goals):
                assert sdk.write(dxl_id, Reg.GOAL_POSITION, goal + 50) == DATA_RANGE_ERROR
            assert [sdk.read(i, Reg.GOAL_POSITION)[0] for i in SERVOS] == goals  # nothing applied
            for dxl_id in SERVOS:  # leave the bus as a careful user would: torque off
                sdk.write(dxl_id, Reg.TORQUE_ENABLE, 0)
        finally:
            sdk.close()
    finally:
        if run_ is not None and run_.poll() is None:
            run_.kill()
        simbus.stdin.close()
        simbus.wait(timeout=30)


def test_a_run_whose_wire_fell_silent_says_the_watchdog_tripped(grown_controller):
    """A host held up longer than the watchdog allows: the servos stopped and refused goals;
    the stop's report names them (and torque still goes off, read back)."""
    from sim2real.hardware.deploy import drive
    from sim2real.hardware.loop import RAMP_TICK_S
    from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus

    chain = EmulatedChain(MockBus(ROBOT).devices)
    sleeps = {"n": 0}

    def sleep(seconds: float) -> None:
        if seconds != RAMP_TICK_S:  # the loop's sleeps
            sleeps["n"] += 1
            if sleeps["n"] == 3:
                time.sleep(3 * WATCHDOG_MS / 1000)  # the host stalls with torque on
        time.sleep(seconds)

    with PtyServer(chain, baud=1_000_000) as server:
        report = drive(DynamixelBus(server.port, 1_000_000, ROBOT), ROBOT, grown_controller, duration_s=0.5,
                       ramp_s=0.1, lost_after_s=2.0, log=lambda s: None, sleep=sleep)
    assert any(note.startswith(f"the Bus Watchdog of servo {', '.join(map(str, SERVOS))} tripped")
               for note in report.stop_notes), report.stop_notes
    assert report.torque_off.confirmed == SERVOS
