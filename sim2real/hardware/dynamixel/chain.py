"""A robot's devices on a bus: named registers, signed values, retries, the sensor board.

The middle layer between the real-time loop and any :class:`Bus`: it maps register names to
addresses from each device's profile, groups an access to many servos by protocol and
control table (:mod:`sim2real.robot.bus_plan`), decodes signed fields, retries missing replies
(``retries`` more times, then one :class:`CommunicationError` naming the servos), and reads
the foot switches and up-vector from the sensor board.
"""

from __future__ import annotations

import time
from typing import Callable, NamedTuple, TypeVar

import numpy as np

from sim2real.hardware.bus import Bus, CommunicationError, ServoError
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.robot import RobotSpec
from sim2real.robot.bus_plan import BULK_READ, SYNC_READ, SYNC_WRITE, Exchange, board_span, plan_reads, plan_writes, span
from sim2real.robot.profiles import DeviceProfile, Register

T = TypeVar("T")


class BoardReading(NamedTuple):
    """One read of the sensor board."""

    feet: np.ndarray  # (2,) bool: left, right touching
    up: np.ndarray  # (3,) world up in the torso frame, unit
    heading: float | None  # [rad] the IMU's yaw; None from a board without the register
    gyro: np.ndarray | None = None  # (3,) [rad/s] the torso's roll, pitch, yaw rate; None without the registers


# What a controller may read beyond feet and up-vector (a channels.Readings field) -> the
# board register that must be there for it
SENSOR_REGISTERS = {"heading": Reg.HEADING, "gyro": Reg.GYRO_Z}


def board_reports(robot: RobotSpec, sensor: str) -> bool:
    """Whether the robot's sensor board reports ``sensor`` (``heading``, ``gyro``): a
    controller that reads it needs a board that does."""
    board = robot.sensor_board
    return board is not None and SENSOR_REGISTERS[sensor] in board.profile.control_table


def decode(reg: Register, raw: int) -> int:
    """A register's raw unsigned value as the number it holds (two's complement when signed)."""
    if reg.encoding == "sign_magnitude_bit10":
        return -(raw & 0x3FF) if raw & 0x400 else raw & 0x3FF
    if reg.signed and raw >= 1 << (8 * reg.size - 1):
        return raw - (1 << (8 * reg.size))
    return raw


def encode(reg: Register, value: int) -> int:
    """A number as the register's raw unsigned value (two's complement when signed; bit 10 as the
    sign on the protocol-1.0 speed and load entries), the inverse of :func:`decode`."""
    value = int(value)
    if reg.encoding == "sign_magnitude_bit10":
        if abs(value) > 0x3FF:
            raise ValueError(f"{reg.name}: {value} does not fit 10 bits and a sign")
        return abs(value) | (0x400 if value < 0 else 0)
    lo, hi = (-(1 << (8 * reg.size - 1)), (1 << (8 * reg.size - 1)) - 1) if reg.signed else (0, (1 << (8 * reg.size)) - 1)
    if not lo <= value <= hi:
        raise ValueError(f"{reg.name}: {value} does not fit {reg.size} {'signed' if reg.signed else 'unsigned'} bytes")
    return value & ((1 << (8 * reg.size)) - 1)


class ServoChain:
    """``attempts`` is how often a read or write is tried before its
    :class:`CommunicationError` goes up (default ``1 + retries``); ``retries_used`` counts the
    repeats that were needed."""

    def __init__(self, bus: Bus, robot: RobotSpec, retries: int = 2):
        self.bus, self.robot, self.retries = bus, robot, retries
        self.retries_used = 0
        self.servo_ids = [j.servo.id for j in robot.joints if j.servo is not None]
        self.devices: dict[int, DeviceProfile] = {j.servo.id: j.servo.profile for j in robot.joints if j.servo}
        self.board_id = robot.sensor_board.id if robot.sensor_board else None
        if robot.sensor_board:
            self.devices[self.board_id] = robot.sensor_board.profile

    def with_retries(self, call: Callable[[], T], attempts: int | None = None, patience_s: float = 0.0) -> T:
        """``call()``, repeated on :class:`CommunicationError` until it has been tried
        ``attempts`` times in all and ``patience_s`` seconds have passed."""
        attempts = self.retries + 1 if attempts is None else attempts
        give_up_at = time.monotonic() + patience_s
        attempt = 0
        while True:
            try:
                return call()
            except CommunicationError:
                attempt += 1
                if attempt >= attempts and time.monotonic() >= give_up_at:
                    raise
                self.retries_used += 1

    def register(self, dxl_id: int, name: Reg) -> Register:
        return self.devices[dxl_id].register(name)

    def ping(self, dxl_id: int, attempts: int | None = None, patience_s: float = 0.0) -> int:
        """The device's model number."""
        return self.with_retries(lambda: self.bus.ping(dxl_id), attempts, patience_s)

    def read(self, dxl_id: int, name: Reg, attempts: int | None = None, patience_s: float = 0.0) -> int:
        reg = self.register(dxl_id, name)
        return decode(reg, self.with_retries(lambda: self.bus.read(dxl_id, reg.address, reg.size), attempts,
                                             patience_s))

    def write(self, dxl_id: int, name: Reg, value: int, attempts: int | None = None, patience_s: float = 0.0) -> None:
        reg = self.register(dxl_id, name)
        raw = encode(reg, value)
        self.with_retries(lambda: self.bus.write(dxl_id, reg.address, reg.size, raw), attempts, patience_s)

    def _exchange(self, exchange: Exchange) -> dict[int, int]:
        """One planned read on the bus -> raw value per device."""
        if exchange.kind == SYNC_READ:
            _, address, size = exchange.items[0]
            return self.bus.sync_read(list(exchange.ids), address, size)
        if exchange.kind == BULK_READ:
            return self.bus.bulk_read({i: (address, size) for i, address, size in exchange.items})
        (dxl_id, address, size), = exchange.items
        return {dxl_id: self.bus.read(dxl_id, address, size)}

    def _read_span(self, names: list[Reg], ids: list[int], attempts: int | None,
                   patience_s: float) -> dict[int, int]:
        """The raw bytes ``names`` span on each device of ``ids``, read in the exchanges
        :func:`~sim2real.robot.bus_plan.plan_reads` groups them into (by protocol and layout);
        each exchange is tried ``attempts`` times."""
        raw: dict[int, int] = {}
        for exchange in plan_reads(self.devices, names, ids):
            raw.update(self.with_retries(lambda e=exchange: self._exchange(e), attempts, patience_s))
        return raw

    def sync_read(self, name: Reg, ids: list[int] | None = None, attempts: int | None = None,
                  patience_s: float = 0.0) -> np.ndarray:
        """Decoded values in ``ids`` order (default: every servo in joint order): a sync read,
        bulk read or single reads for each group of servos, as their protocols and models have
        them (:mod:`sim2real.robot.bus_plan`)."""
        ids = self.servo_ids if ids is None else ids
        raw = self._read_span([name], ids, attempts, patience_s)
        return np.array([decode(self.register(i, name), raw[i]) for i in ids], dtype=np.int64)

    def sync_read_span(self, names: list[Reg], ids: list[int] | None = None,
                       attempts: int | None = None) -> dict[Reg, np.ndarray]:
        """Several registers that lie next to each other, read in one go of the bytes they
        span -> decoded values per register, in ``ids`` order.  One exchange a group instead
        of one each, and a reply length no single register has (a late reply cannot pass for
        the answer to another read).  ``ValueError`` if they are apart on some servo."""
        ids = self.servo_ids if ids is None else ids
        raw = self._read_span(names, ids, attempts, 0.0)
        starts = {i: span(self.devices[i], names)[0] for i in ids}

        def field(dxl_id: int, name: Reg) -> int:
            reg = self.register(dxl_id, name)
            return decode(reg, (raw[dxl_id] >> (8 * (reg.address - starts[dxl_id]))) & ((1 << (8 * reg.size)) - 1))

        return {name: np.array([field(i, name) for i in ids], dtype=np.int64) for name in names}

    def sync_write(self, name: Reg, values: np.ndarray, ids: list[int] | None = None) -> None:
        """One sync write per protocol and layout (:func:`~sim2real.robot.bus_plan.plan_writes`),
        without replies; a single write for a servo without sync write."""
        ids = self.servo_ids if ids is None else ids
        raw = {i: encode(self.register(i, name), v) for i, v in zip(ids, values)}
        for exchange in plan_writes(self.devices, name, ids):
            _, address, size = exchange.items[0]
            if exchange.kind == SYNC_WRITE:
                self.bus.sync_write(address, size, {i: raw[i] for i in exchange.ids})
            else:
                self.bus.write(exchange.ids[0], address, size, raw[exchange.ids[0]])

    def torque(self, on: bool, ids: list[int] | None = None, attempts: int | None = None,
               patience_s: float = 0.0) -> None:
        for dxl_id in self.servo_ids if ids is None else ids:
            self.write(dxl_id, Reg.TORQUE_ENABLE, int(on), attempts, patience_s)

    def hardware_error(self, dxl_id: int, attempts: int | None = None, patience_s: float = 0.0) -> int:
        """The device's Hardware Error Status bits (0: none), read even when its hardware
        alert comes with them.  ``KeyError`` for a device without that entry."""
        try:
            return self.read(dxl_id, Reg.HARDWARE_ERROR_STATUS, attempts, patience_s)
        except ServoError as exc:  # the alert bit comes with the very value we asked for
            if exc.value is None:
                raise
            return exc.value

    def read_board(self, attempts: int | None = None) -> BoardReading:
        """Foot switches (left, right: True touching), the torso up-vector (unit, torso frame)
        and, from a board that reports them, the heading [rad] and angular rates [rad/s] - in
        one read."""
        if self.board_id is None:
            raise ValueError(f"robot {self.robot.name} has no sensor board")
        profile = self.devices[self.board_id]
        has_heading, has_gyro = (board_reports(self.robot, sensor) for sensor in ("heading", "gyro"))
        first, size = board_span(profile)  # the bytes the tick's bus time counts
        raw = self.with_retries(lambda: self.bus.read(self.board_id, first, size), attempts)
        block = raw.to_bytes(size, "little")

        def field(name: Reg) -> int:
            reg = profile.register(name)
            offset = reg.address - first
            return decode(reg, int.from_bytes(block[offset:offset + reg.size], "little"))

        touching = profile.sensors.get("foot_switch", {}).get("touching", 1)
        feet = np.array([field(Reg.FOOT_SWITCH_LEFT) == touching, field(Reg.FOOT_SWITCH_RIGHT) == touching])
        up = np.array([field(Reg.UP_VECTOR_X), field(Reg.UP_VECTOR_Y), field(Reg.UP_VECTOR_Z)], dtype=float) \
            * profile.units["up_vector_unit"]
        heading = field(Reg.HEADING) * profile.units["heading_unit"] if has_heading else None
        gyro = (np.array([field(Reg.GYRO_X), field(Reg.GYRO_Y), field(Reg.GYRO_Z)], dtype=float)
                * profile.units["gyro_unit"] if has_gyro else None)
        return BoardReading(feet, up, heading, gyro)
