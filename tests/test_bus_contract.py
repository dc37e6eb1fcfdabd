"""One contract for every implementation of :class:`sim2real.hardware.bus.Bus`.

Each test runs against the in-memory mock, against the official SDK (``DynamixelBus``) over a
pseudo-terminal to the emulated chain, and against the SDK over the simulated bus (MuJoCo
physics behind the same chain).  The tests speak only through the bus; the devices behind
it are touched only to inject a fault (a silent servo, a hardware error).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import pytest
from conftest import REPLY_ALLOWANCE_US

from sim2real.hardware import CommunicationError, MockBus, ServoChain, ServoError
from sim2real.hardware.bus import Bus
from sim2real.hardware.dynamixel.errors import (
    ACCESS_ERROR,
    DATA_LENGTH_ERROR,
    DATA_LIMIT_ERROR,
    DATA_RANGE_ERROR,
    ERROR_NUMBER_MASK,
    OVERLOAD_BIT,
)
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus
from sim2real.hardware.mock import MockDevice
from sim2real.robot import load_robot
from sim2real.simulation.simbus.server import EmulatedChain, PtyServer

ROBOT = load_robot()
SERVOS = [j.servo.id for j in ROBOT.joints if j.servo is not None]
BOARD = ROBOT.sensor_board.id
SERVO = ROBOT.joints[0].servo.profile  # every servo of the default robot is this model
# Timing is not part of this contract (test_dynamixel_bus.py checks the wire's timeouts): the
# SDK's client allows each reply REPLY_ALLOWANCE_US more, and the simulated robot lives at a
# tenth of real time, so that stepping it in the test's own process stays cheap (a dry run
# serves it from a process of its own).
SIMULATED_PACE = 0.1


def at(name: str) -> tuple[int, int]:
    """(address, size) of a servo's control-table entry."""
    reg = SERVO.register(name)
    return reg.address, reg.size


@dataclass
class Subject:
    """A bus under test; ``devices`` and ``silent`` (IDs that stop answering) reach behind it."""

    bus: Bus
    devices: dict[int, MockDevice]
    silent: set[int]


def _over_a_pty(devices: dict[int, MockDevice], advance=None):
    chain = EmulatedChain(devices, advance=advance)
    with PtyServer(chain) as server:
        bus = DynamixelBus(server.port, 1_000_000, ROBOT, return_delay_us=REPLY_ALLOWANCE_US)
        bus.open()
        try:
            yield Subject(bus, devices, chain.silent)
        finally:
            bus.close()


@pytest.fixture(params=["mock", "sdk-emulated", "sdk-simulated"])
def subject(request):
    if request.param == "mock":
        bus = MockBus(ROBOT)
        bus.open()
        yield Subject(bus, bus.devices, bus.faults.silent)
        bus.close()
    elif request.param == "sdk-emulated":
        yield from _over_a_pty(MockBus(ROBOT).devices)
    else:
        from sim2real.simulation.simbus.physics import PhysicsChain

        physics = PhysicsChain(ROBOT, clock=lambda: SIMULATED_PACE * time.monotonic())
        yield from _over_a_pty(physics.devices, physics.advance)


def test_ping_answers_with_each_devices_model_number(subject):
    for dxl_id in SERVOS:
        assert subject.bus.ping(dxl_id) == SERVO.model_number
    assert subject.bus.ping(BOARD) == ROBOT.sensor_board.profile.model_number


def test_writes_and_reads_of_each_size_and_across_entries(subject):
    bus = subject.bus
    bus.write(2, *at(Reg.GOAL_POSITION), 1500)
    assert bus.read(2, *at(Reg.GOAL_POSITION)) == 1500
    bus.write(2, *at(Reg.RETURN_DELAY_TIME), 0)
    assert bus.read(2, *at(Reg.RETURN_DELAY_TIME)) == 0
    assert bus.read(BOARD, 0, 2) == ROBOT.sensor_board.profile.model_number
    velocity, _ = at("profile_velocity")  # 4 bytes right before the goal: one write sets both
    bus.write(2, velocity, 8, (2000 << 32) | 0)
    assert bus.read(2, *at(Reg.GOAL_POSITION)) == 2000
    with pytest.raises(ServoError) as err:  # fewer bytes than the entry holds
        bus.write(2, at(Reg.GOAL_POSITION)[0], 1, 5)
    assert err.value.id == 2 and err.value.error & ERROR_NUMBER_MASK == DATA_LENGTH_ERROR


def test_signed_values_cross_the_bus_as_unsigned_and_decode_in_the_chain(subject):
    address, size = at("homing_offset")  # signed, 4 bytes, and nothing but a write changes it
    ServoChain(subject.bus, ROBOT).write(3, "homing_offset", -1000)
    assert subject.bus.read(3, address, size) == (1 << 32) - 1000
    assert ServoChain(subject.bus, ROBOT).read(3, "homing_offset") == -1000


def test_sync_write_and_sync_read_reach_every_servo(subject):
    goals = {dxl_id: 1900 + k for k, dxl_id in enumerate(SERVOS)}
    subject.bus.sync_write(*at(Reg.GOAL_POSITION), goals)
    assert subject.bus.sync_read(SERVOS, *at(Reg.GOAL_POSITION)) == goals
    present = subject.bus.sync_read(SERVOS, *at(Reg.PRESENT_POSITION))
    assert sorted(present) == SERVOS and all(0 <= v < 1 << 32 for v in present.values())


def test_a_silent_servo_is_named_in_the_communication_error_and_the_bus_recovers(subject):
    subject.silent.add(5)
    with pytest.raises(CommunicationError, match="^servo 5: ") as err:
        subject.bus.sync_read(SERVOS, *at(Reg.PRESENT_POSITION))
    assert err.value.ids == (5,) and not err.value.corrupt
    for call in (lambda: subject.bus.read(5, *at(Reg.PRESENT_POSITION)), lambda: subject.bus.ping(5)):
        with pytest.raises(CommunicationError) as err:
            call()
        assert err.value.ids == (5,)
    subject.silent.discard(5)
    assert sorted(subject.bus.sync_read(SERVOS, *at(Reg.PRESENT_POSITION))) == SERVOS


def test_the_hardware_alert_of_one_servo_surfaces_in_a_sync_read_until_reboot(subject):
    subject.devices[8].raise_hardware_error(OVERLOAD_BIT)
    with pytest.raises(ServoError, match="^servo 8: hardware alert") as err:
        subject.bus.sync_read(SERVOS, *at(Reg.PRESENT_POSITION))
    assert err.value.id == 8 and err.value.alert and err.value.value is not None
    with pytest.raises(ServoError) as err:  # the firmware dropped torque; the value still comes
        subject.bus.read(8, *at(Reg.TORQUE_ENABLE))
    assert err.value.alert and err.value.value == 0
    with pytest.raises(ServoError):  # and refuses it back until REBOOT
        subject.bus.write(8, *at(Reg.TORQUE_ENABLE), 1)
    subject.bus.reboot(8)
    assert subject.bus.read(8, *at(Reg.HARDWARE_ERROR_STATUS)) == 0
    assert sorted(subject.bus.sync_read(SERVOS, *at(Reg.PRESENT_POSITION))) == SERVOS


def test_an_eeprom_write_with_torque_on_is_an_access_error(subject):
    subject.bus.write(2, *at(Reg.TORQUE_ENABLE), 1)
    with pytest.raises(ServoError, match="^servo 2: access error$") as err:
        subject.bus.write(2, *at(Reg.OPERATING_MODE), 3)
    assert err.value.error & ERROR_NUMBER_MASK == ACCESS_ERROR
    subject.bus.write(2, *at(Reg.TORQUE_ENABLE), 0)
    subject.bus.write(2, *at(Reg.OPERATING_MODE), 3)


def test_refused_writes_leave_the_value_as_it_was(subject):
    bus = subject.bus
    with pytest.raises(ServoError, match="^servo 2: data range error$") as err:
        bus.write(2, *at(Reg.OPERATING_MODE), 99)  # outside the e-manual's range
    assert err.value.error & ERROR_NUMBER_MASK == DATA_RANGE_ERROR
    assert bus.read(2, *at(Reg.OPERATING_MODE)) == 3
    with pytest.raises(ServoError, match="^servo 2: access error$"):
        bus.write(2, *at(Reg.MODEL_NUMBER), 7)  # read-only
    assert bus.read(2, *at(Reg.MODEL_NUMBER)) == SERVO.model_number


def test_a_goal_outside_the_position_limits_is_refused_by_write_and_skipped_by_sync_write(subject):
    bus = subject.bus
    for dxl_id in (2, 3):
        bus.write(dxl_id, *at(Reg.MIN_POSITION_LIMIT), 1000)
        bus.write(dxl_id, *at(Reg.MAX_POSITION_LIMIT), 3000)
        bus.write(dxl_id, *at(Reg.GOAL_POSITION), 2000)
    with pytest.raises(ServoError, match="^servo 2: data limit error$") as err:
        bus.write(2, *at(Reg.GOAL_POSITION), 3500)
    assert err.value.error & ERROR_NUMBER_MASK == DATA_LIMIT_ERROR
    bus.sync_write(*at(Reg.GOAL_POSITION), {2: 3500, 3: 2500})  # no replies: the firmware skips 2 silently
    assert bus.sync_read([2, 3], *at(Reg.GOAL_POSITION)) == {2: 2000, 3: 2500}
    bus.sync_write(*at(Reg.GOAL_POSITION), {2: 999, 3: 2999})
    assert bus.sync_read([2, 3], *at(Reg.GOAL_POSITION)) == {2: 2000, 3: 2999}


def test_torque_enable_reads_back_what_was_written(subject):
    bus = subject.bus
    for dxl_id in SERVOS:
        bus.write(dxl_id, *at(Reg.TORQUE_ENABLE), 1)
    assert bus.sync_read(SERVOS, *at(Reg.TORQUE_ENABLE)) == {dxl_id: 1 for dxl_id in SERVOS}
    bus.sync_write(*at(Reg.TORQUE_ENABLE), {dxl_id: 0 for dxl_id in SERVOS})
    assert all(bus.read(dxl_id, *at(Reg.TORQUE_ENABLE)) == 0 for dxl_id in SERVOS)
