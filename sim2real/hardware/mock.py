"""An in-memory Dynamixel chain for tests: control tables from ``firmware_profiles/``,
servos that move toward their goals at the profile's no-load speed, and injectable faults.
Each device takes a write - by WRITE or SYNC WRITE - under its firmware's rules (EEPROM
locked while torque is on, the e-manual's ranges, goals within the position limits).

    bus = MockBus(robot)                   # every servo and the sensor board of the robot
    bus.faults.silent.add(4)               # servo 4 stops answering
    bus.faults.alert[7] = 0b100000         # servo 7 overloads: alert bit, torque off
    bus.faults.timeouts[3] = 2             # servo 3 misses its next two replies

A sync read, bulk read or sync write reaches only devices of one protocol whose firmware has
the instruction, as on a real chain (:func:`~sim2real.robot.bus_plan.check_group`); ``sent``
lists every instruction packet, for tests of what a tick costs.

Servos with a Bus Watchdog (X series, address 98) stop when the host falls silent longer than it
is set to, as the firmware does (:meth:`MockDevice.watch`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable

from sim2real.hardware.bus import Bus, CommunicationError
from sim2real.hardware.dynamixel.errors import (
    ACCESS_ERROR,
    ALERT_BIT,
    DATA_LENGTH_ERROR,
    DATA_LIMIT_ERROR,
    DATA_RANGE_ERROR,
    ERROR_NUMBER_MASK,
    status_error,
)
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.hardware.dynamixel.chain import decode
from sim2real.robot import RobotSpec
from sim2real.robot.bus_plan import BULK_READ, READ, SYNC_READ, SYNC_WRITE, WRITE, check_group
from sim2real.robot.profiles import DeviceProfile
from sim2real.robot.timing import WATCHDOG_UNIT_MS

WATCHDOG_UNIT_S = WATCHDOG_UNIT_MS / 1e3  # Bus Watchdog (98) counts in 20 ms [s]
WATCHDOG_EXPIRED = -1  # what Bus Watchdog (98) reads once it has stopped the servo
# The goal entries an expired Bus Watchdog makes read-only (those a profile has).
WATCHDOG_GOALS = ("goal_pwm", "goal_current", "goal_velocity", Reg.GOAL_POSITION)


@dataclass
class Faults:
    silent: set[int] = field(default_factory=set)  # never answer
    timeouts: dict[int, int] = field(default_factory=dict)  # miss this many more replies
    alert: dict[int, int] = field(default_factory=dict)  # hardware error bits to raise now


class MockDevice:
    def __init__(self, dxl_id: int, profile: DeviceProfile):
        self.id, self.profile = dxl_id, profile
        end = max(r.address + r.size for r in profile.control_table.values())
        self.table = bytearray(end)
        for reg in profile.control_table.values():
            self.set(reg.address, reg.size, reg.default & ((1 << (8 * reg.size)) - 1))
        if Reg.ID in profile.control_table:
            self.set(profile.register(Reg.ID).address, 1, dxl_id)
        if profile.is_servo:  # a robot at rest, horns near their centre
            self.set_named(Reg.PRESENT_POSITION, profile.position.center_tick)
            self.set_named(Reg.GOAL_POSITION, profile.position.center_tick)
        self.position = float(self.get_named(Reg.PRESENT_POSITION)) if profile.is_servo else 0.0

    def get(self, address: int, size: int) -> int:
        return int.from_bytes(self.table[address:address + size], "little")

    def set(self, address: int, size: int, value: int) -> None:
        self.table[address:address + size] = int(value).to_bytes(size, "little")

    def get_named(self, name: str) -> int:
        reg = self.profile.register(name)
        return self.get(reg.address, reg.size)

    def set_named(self, name: str, value: int) -> None:
        reg = self.profile.register(name)
        self.set(reg.address, reg.size, value & ((1 << (8 * reg.size)) - 1))

    # -- what a servo's firmware answers: (value, error byte) ---------------------------------
    def alert(self) -> int:
        table = self.profile.control_table
        return ALERT_BIT if Reg.HARDWARE_ERROR_STATUS in table and self.get_named(Reg.HARDWARE_ERROR_STATUS) else 0

    def read(self, address: int, size: int) -> tuple[int, int]:
        return self.get(address, size), self.alert()

    def write(self, address: int, size: int, value: int) -> int:
        """Apply a WRITE as the firmware would; returns the status error byte.

        A write may span consecutive entries (e.g. profile velocity and goal position in one
        go); one shorter than its first entry is a data length error.
        """
        reg = next((r for r in self.profile.control_table.values() if r.address == address), None)
        if reg is not None and size < reg.size:
            return DATA_LENGTH_ERROR | self.alert()
        if reg is not None and size > reg.size:
            error = self.write(address, reg.size, value & ((1 << (8 * reg.size)) - 1))
            if error & ERROR_NUMBER_MASK:
                return error
            return self.write(address + reg.size, size - reg.size, value >> (8 * reg.size))
        if reg is None or reg.access != "RW":
            return ACCESS_ERROR | self.alert()
        torque_on = self.profile.is_servo and self.get_named(Reg.TORQUE_ENABLE)
        if reg.area == "EEPROM" and torque_on and self.profile.protocol == 2.0:
            return ACCESS_ERROR | self.alert()  # X series: EEPROM is locked while torque is on
        if reg.range is not None:
            if not reg.range[0] <= decode(reg, value) <= reg.range[1]:
                return DATA_RANGE_ERROR | self.alert()
        if reg.name == Reg.TORQUE_ENABLE and value and self.alert():
            return self.alert()  # refused until REBOOT, and the alert bit says why
        if self.watchdog_expired() and (reg.name in WATCHDOG_GOALS or (reg.name == Reg.BUS_WATCHDOG and value)):
            # goals are read-only until 0 is written to Bus Watchdog (the only way the e-manual
            # gives to clear the error): a Data Range Error, nothing applied
            return DATA_RANGE_ERROR | self.alert()
        if reg.name == Reg.GOAL_POSITION and Reg.MIN_POSITION_LIMIT in self.profile.control_table:
            if not self.get_named(Reg.MIN_POSITION_LIMIT) <= decode(reg, value) <= self.get_named(Reg.MAX_POSITION_LIMIT):
                return DATA_LIMIT_ERROR | self.alert()  # outside the position limits: not applied
        self.set(address, size, value)
        if reg.name == Reg.TORQUE_ENABLE and value:
            self.position = float(self.get_named(Reg.PRESENT_POSITION))
        return self.alert()

    def factory_reset(self, keep_id: bool) -> None:
        """Every entry back to its default (the ID too unless ``keep_id``; then ID 1)."""
        dxl_id = self.id
        for reg in self.profile.control_table.values():
            self.set(reg.address, reg.size, reg.default & ((1 << (8 * reg.size)) - 1))
        if keep_id and Reg.ID in self.profile.control_table:
            self.set_named(Reg.ID, dxl_id)

    def reboot(self) -> None:
        self.set_named(Reg.HARDWARE_ERROR_STATUS, 0)
        if self.profile.is_servo:
            self.set_named(Reg.TORQUE_ENABLE, 0)
        if Reg.BUS_WATCHDOG in self.profile.control_table:  # RAM, reset as at power-on: off, no error
            self.set_named(Reg.BUS_WATCHDOG, 0)

    # -- the Bus Watchdog (X series, address 98) ----------------------------------------------
    # Source: ROBOTIS e-manual, X series control table, "Bus Watchdog(98)"
    # (emanual.robotis.com/docs/en/dxl/x/xl430-w250/#bus-watchdog98; the text is
    # _includes/en/dxl/control_table_buswatchdog.md in github.com/ROBOTIS-GIT/emanual).  It watches
    # only while Torque Enable is 1; when no instruction packet has come for longer than its value
    # (20 ms units) the servo stops and the entry reads -1; the goal entries are then read-only (a
    # write gets a Data Range Error) until 0 is written to it.  Torque is not dropped: the
    # e-manual's example resumes motion after writing 0, without enabling torque again, and
    # stopping in position mode means holding the present position (ROBOTIS-GIT/DynamixelSDK
    # issue 584: the firmware rewrites Goal Position when the watchdog expires).  Nothing sets
    # Hardware Error Status or the alert bit.
    def watchdog_s(self) -> float | None:
        """How long the host may stay silent before this servo stops [s]; None while its
        watchdog is not watching (no such entry, set to 0, already expired, or torque off)."""
        table = self.profile.control_table
        if not self.profile.is_servo or Reg.BUS_WATCHDOG not in table or not self.get_named(Reg.TORQUE_ENABLE):
            return None
        reg = table[Reg.BUS_WATCHDOG]
        setting = decode(reg, self.get(reg.address, reg.size))
        return setting * WATCHDOG_UNIT_S if setting > 0 else None

    def watchdog_expired(self) -> bool:
        """Bus Watchdog reads -1: this servo stopped for a silent host and takes no goal."""
        table = self.profile.control_table
        if Reg.BUS_WATCHDOG not in table:
            return False
        reg = table[Reg.BUS_WATCHDOG]
        return decode(reg, self.get(reg.address, reg.size)) == WATCHDOG_EXPIRED

    def watch(self, silent_s: float) -> bool:
        """The host has sent no instruction packet for ``silent_s`` [s]: if that is longer
        than the watchdog allows, stop (the goal becomes the present position, torque stays
        on) and read -1 in Bus Watchdog.  True if it expired now."""
        limit = self.watchdog_s()
        if limit is None or silent_s <= limit:
            return False
        self.set_named(Reg.BUS_WATCHDOG, WATCHDOG_EXPIRED)
        self.set_named(Reg.GOAL_POSITION, self.get_named(Reg.PRESENT_POSITION))
        self.position = float(self.get_named(Reg.PRESENT_POSITION))
        return True

    def raise_hardware_error(self, bits: int) -> None:
        self.set_named(Reg.HARDWARE_ERROR_STATUS, bits)
        if self.profile.is_servo:
            self.set_named(Reg.TORQUE_ENABLE, 0)  # the firmware drops torque on a hardware error

    def advance(self, dt: float) -> None:
        """Move toward the goal at the no-load speed while torque is on [ticks]."""
        if not self.profile.is_servo or not self.get_named(Reg.TORQUE_ENABLE):
            return
        goal_reg = self.profile.register(Reg.GOAL_POSITION)
        goal = decode(goal_reg, self.get(goal_reg.address, goal_reg.size))
        speed = self.profile.motor.no_load_speed_rad_s / self.profile.position.rad_per_tick  # [tick/s]
        step = max(-speed * dt, min(speed * dt, goal - self.position))
        self.position += step
        self.set_named(Reg.PRESENT_POSITION, int(round(self.position)))
        if Reg.PRESENT_VELOCITY in self.profile.control_table:
            rpm = step / max(dt, 1e-9) * self.profile.position.rad_per_tick * 60 / (2 * math.pi)
            self.set_named(Reg.PRESENT_VELOCITY, int(round(rpm / self.profile.units.get("velocity_unit_rpm", 1.0))))


class MockBus(Bus):
    def __init__(self, robot: RobotSpec, clock: Callable[[], float] = time.monotonic):
        self.devices: dict[int, MockDevice] = {}
        for joint in robot.joints:
            if joint.servo is not None:
                self.devices[joint.servo.id] = MockDevice(joint.servo.id, joint.servo.profile)
        if robot.sensor_board is not None:
            self.devices[robot.sensor_board.id] = MockDevice(robot.sensor_board.id, robot.sensor_board.profile)
        self.faults = Faults()
        self.clock = clock
        self._last = clock()  # the last instruction, whatever it was (the watchdogs count from it)
        self.is_open = False
        # (id, address, value) of every write and sync-write item a device received, applied or
        # refused: what went over the wire, for tests
        self.writes: list[tuple[int, int, int]] = []
        # (instruction, IDs) of every instruction packet sent ("read", "sync_read", "bulk_read", ...)
        self.sent: list[tuple[str, tuple[int, ...]]] = []
        self.profiles = {i: d.profile for i, d in self.devices.items()}

    def open(self) -> None:
        self.is_open = True

    def close(self) -> None:
        self.is_open = False

    # -- device behaviour -------------------------------------------------------------------------
    def _advance(self) -> None:
        """Called with every instruction: the devices move on, and a servo whose watchdog
        expired during the host's silence stops where it was then (it still answers this one)."""
        now = self.clock()
        dt, self._last = now - self._last, now
        for device in self.devices.values():
            limit = device.watchdog_s()
            if limit is not None and dt > limit:
                device.advance(limit)
                device.watch(dt)
                device.advance(dt - limit)  # stopped: holds its goal
            else:
                device.advance(dt)

    def _device(self, dxl_id: int) -> MockDevice:
        if not self.is_open:
            raise CommunicationError([dxl_id], "the port is not open")
        self._advance()
        device = self.devices.get(dxl_id)
        if device is None or dxl_id in self.faults.silent:
            raise CommunicationError([dxl_id], "no status packet (timeout)")
        if self.faults.timeouts.get(dxl_id, 0) > 0:
            self.faults.timeouts[dxl_id] -= 1
            raise CommunicationError([dxl_id], "no status packet (timeout)")
        bits = self.faults.alert.pop(dxl_id, 0)
        if bits:
            device.raise_hardware_error(bits)
        return device

    @staticmethod
    def _raise(device: MockDevice, error: int, value: int | None = None) -> None:
        if error:
            raise status_error(device.id, error, value)

    # -- Bus --------------------------------------------------------------------------------------
    def ping(self, dxl_id: int) -> int:
        self.sent.append(("ping", (dxl_id,)))
        device = self._device(dxl_id)
        return device.get_named(Reg.MODEL_NUMBER)

    def read(self, dxl_id: int, address: int, size: int) -> int:
        self.sent.append((READ, (dxl_id,)))
        device = self._device(dxl_id)
        value, error = device.read(address, size)
        self._raise(device, error, value)
        return value

    def write(self, dxl_id: int, address: int, size: int, value: int) -> None:
        self.sent.append((WRITE, (dxl_id,)))
        device = self._device(dxl_id)
        self.writes.append((dxl_id, address, value))
        self._raise(device, device.write(address, size, value))

    def sync_read(self, ids: list[int], address: int, size: int) -> dict[int, int]:
        check_group(SYNC_READ, self.profiles, [(i, address, size) for i in ids])  # as a real chain: one protocol
        self.sent.append((SYNC_READ, tuple(ids)))
        return self._group_read(SYNC_READ, {i: (address, size) for i in ids})

    def bulk_read(self, items: dict[int, tuple[int, int]]) -> dict[int, int]:
        check_group(BULK_READ, self.profiles, [(i, *where) for i, where in items.items()])
        self.sent.append((BULK_READ, tuple(items)))
        return self._group_read(BULK_READ, items)

    def _group_read(self, kind: str, items: dict[int, tuple[int, int]]) -> dict[int, int]:
        values, missing = {}, []
        for dxl_id, (address, size) in items.items():
            try:
                values[dxl_id] = self._device(dxl_id).get(address, size)
            except CommunicationError:
                missing.append(dxl_id)
        if missing:
            raise CommunicationError(missing, f"no status packet in {kind.replace('_', ' ')}")
        for dxl_id in items:  # each status packet carries its servo's error byte
            self._raise(self.devices[dxl_id], self.devices[dxl_id].alert(), values[dxl_id])
        return values

    def sync_write(self, address: int, size: int, values: dict[int, int]) -> None:
        check_group(SYNC_WRITE, self.profiles, [(i, address, size) for i in values])
        self.sent.append((SYNC_WRITE, tuple(values)))
        self._advance()
        for dxl_id, value in values.items():
            device = self.devices.get(dxl_id)
            if device is None or dxl_id in self.faults.silent:
                continue
            self.writes.append((dxl_id, address, value))
            device.write(address, size, value)  # the firmware's rules; no status packet says if it refused

    def reboot(self, dxl_id: int) -> None:
        self.sent.append(("reboot", (dxl_id,)))
        self._device(dxl_id).reboot()
