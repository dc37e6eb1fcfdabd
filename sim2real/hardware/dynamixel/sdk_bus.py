"""The real bus: ``dynamixel-sdk`` (PortHandler / PacketHandler) on a serial port.

Works around the SDK 4.1.0 pitfalls listed in DESIGN.md section 6, in this layer only:

* no busy-wait: our port blocks in the serial driver until bytes arrive or the packet's
  time is up, instead of the SDK's spinning on a non-blocking read;
* timeouts from the wire: bytes x 10 bits / baud, plus Return Delay Time and the USB
  adapter's latency, not the SDK's 34 ms floor (16 ms latency timer x 2 + 2);
* per-servo error bytes: sync reads go through ``syncReadTx`` + ``readRx`` per servo, so
  each status's error byte (and its hardware-alert bit) is kept, and one silent servo is
  named instead of failing the whole read anonymously;
* servos of both protocols on one port: one ``PortHandler``, one ``PacketHandler`` per
  protocol, each instruction sent with the handler of the servos it addresses.  A sync read
  exists only in protocol 2.0; a bulk read in 2.0 and on MX servos in 1.0, where the SDK's
  ``GroupBulkRead`` raises ``TypeError`` (it passes the 2.0 handler's ``fast_option`` to the
  1.0 handler's ``bulkReadTx``), so bulk reads call ``bulkReadTx`` and collect the status
  packets here; which servos get which instruction is planned above the bus
  (:mod:`sim2real.robot.bus_plan`), and an instruction that cannot reach every servo it
  names is refused before it is sent (``ValueError``);
* a reply is the status packet of the servo asked *with the expected number of bytes*: the
  SDK takes the first packet with the right ID, so a late status of an exchange given up on
  (a sync read repeated under load) was read as the answer to the next question - a 4-byte
  position's low byte decoded as a Hardware Error Status, or a 2-byte load's status read as
  a 4-byte position (CRC bytes and all).  Such packets are now skipped, in reads and sync
  reads alike;
* an exchange that ends in an exception (the serial device gone, or any exception raised
  between a packet sent and its reply) left the SDK's port flagged busy, and it then refused
  every later packet, the torque-off included.  Each exchange here clears the flag and the
  input buffer on the way out, and a serial error becomes a :class:`CommunicationError`.
"""

from __future__ import annotations

import functools
import time

import dynamixel_sdk as sdk

from sim2real.hardware.bus import Bus, CommunicationError
from sim2real.hardware.dynamixel.errors import ERROR_NUMBER_MASK, status_error
from sim2real.robot import RobotSpec
from sim2real.robot.bus_plan import BULK_READ, SYNC_READ, SYNC_WRITE, check_group
from sim2real.robot.profiles import DeviceProfile

P1, P2 = sdk.protocol1_packet_handler, sdk.protocol2_packet_handler
STATUS_OVERHEAD = 4  # protocol 2.0: LENGTH counts instruction, error and the 2 CRC bytes besides the data
STATUS_OVERHEAD_P1 = 2  # protocol 1.0: LENGTH counts the error byte and the checksum besides the data
LATENCY_MS = 1.0  # the USB adapter's latency timer, once set to 1 ms (start-up warns otherwise)
MARGIN_MS = 2.0  # scheduling slack on the host


class _Port(sdk.PortHandler):
    """A PortHandler whose reads block until data or the deadline, and whose timeouts follow
    the baud rate and Return Delay Time."""

    def __init__(self, port_name: str, return_delay_us: float = 0.0):
        super().__init__(port_name)
        self.return_delay_us = return_delay_us

    def setupPort(self, cflag_baud):
        ok = super().setupPort(cflag_baud)
        self.ser.timeout = 0.0
        return ok

    def setPacketTimeout(self, packet_length):
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = (self.tx_time_per_byte * packet_length + self.return_delay_us / 1000.0
                               + 2 * LATENCY_MS + MARGIN_MS)

    def readPort(self, length):
        remaining_s = max(0.0, (self.packet_timeout - self.getTimeSinceStart()) / 1000.0)
        self.ser.timeout = remaining_s  # block in the driver, do not spin
        return self.ser.read(length)


def _exchange(method):
    """One exchange on the wire: whatever ends it, the port is free for the next one."""

    @functools.wraps(method)
    def exchange(self: "DynamixelBus", *args, **kwargs):
        try:
            return method(self, *args, **kwargs)
        except CommunicationError:
            raise
        except BaseException as exc:
            self.port.is_using = False
            try:  # a reply half read would be taken for the start of the next one
                self.port.clearPort()
            except Exception:  # noqa: BLE001 - the port may be gone: the error below says so
                pass
            if isinstance(exc, OSError):  # pyserial's SerialException: the device went away
                raise CommunicationError([], f"{self.port_name}: {exc}") from exc
            raise
        finally:
            self.port.is_using = False

    return exchange


class DynamixelBus(Bus):
    """The official SDK on one serial port.  With ``robot``, each device is addressed in its
    own profile's protocol (a chain may mix 1.0 and 2.0); ``protocol`` (default: the first
    servo's, else 2.0) is that of IDs the robot does not name."""

    def __init__(self, port: str, baud: int, robot: RobotSpec | None = None, protocol: float | None = None,
                 return_delay_us: float = 0.0):
        self.profiles: dict[int, DeviceProfile] = {}
        if robot is not None:
            self.profiles = {j.servo.id: j.servo.profile for j in robot.joints if j.servo is not None}
            if robot.sensor_board is not None:
                self.profiles[robot.sensor_board.id] = robot.sensor_board.profile
        if protocol is None:
            protocol = next((j.servo.profile.protocol for j in robot.joints if j.servo), 2.0) if robot else 2.0
        self.protocol = protocol
        self.port_name, self.baud = port, baud
        self.port = _Port(port, return_delay_us)
        self.handlers = {p: sdk.PacketHandler(p) for p in sorted({protocol, *(d.protocol for d in self.profiles.values())})}
        self.packets = self.handlers[protocol]

    def protocol_of(self, dxl_id: int) -> float:
        """The protocol device ``dxl_id`` speaks."""
        profile = self.profiles.get(dxl_id)
        return self.protocol if profile is None else profile.protocol

    def _group(self, kind: str, items: list[tuple[int, int, int]]) -> float:
        """The protocol of one group instruction to ``items`` ((id, address, size) each), refused
        (``ValueError``) unless it can reach all of them."""
        protocols = {self.protocol_of(i) for i, _, _ in items}
        check_group(kind, self.profiles, items)
        if len(protocols) > 1:  # IDs the robot does not name, of another protocol than those it does
            raise ValueError(f"one {kind.replace('_', ' ')} cannot reach servos of protocols 1.0 and 2.0")
        protocol = protocols.pop()
        if kind == SYNC_READ and protocol == 1.0:
            raise ValueError("protocol 1.0 has no sync read: read each servo, or bulk-read MX servos")
        return protocol

    def open(self) -> None:
        if self.port.is_open:
            return
        try:
            self.port.openPort()
        except Exception as exc:  # pyserial raises SerialException and OSError variants
            raise CommunicationError([], f"cannot open {self.port_name}: {exc}") from exc
        if not self.port.setBaudRate(self.baud):
            raise CommunicationError([], f"{self.port_name}: baud rate {self.baud} is not supported")

    def close(self) -> None:
        if self.port.is_open:
            self.port.closePort()

    def _check(self, ids, result: int, error: int, what: str, value: int | None = None) -> None:
        if result == sdk.COMM_RX_CORRUPT:
            raise CommunicationError(ids, f"{what}: corrupt reply (CRC error)", corrupt=True)
        if result != sdk.COMM_SUCCESS:
            handler = self.handlers[self.protocol_of(ids[0])]
            raise CommunicationError(ids, f"{what}: {handler.getTxRxResult(result)}")
        if error:
            raise status_error(ids[0], error, value)

    @_exchange
    def ping(self, dxl_id: int) -> int:
        try:
            model, result, error = self.handlers[self.protocol_of(dxl_id)].ping(self.port, dxl_id)
        except IndexError:  # protocol 1.0: the SDK indexes a reply to its model-number read unchecked
            raise self._stale([dxl_id], "ping") from None
        self._check([dxl_id], result, error & ERROR_NUMBER_MASK, "ping")
        return model

    def _stale(self, ids: list[int], what: str) -> CommunicationError:
        """A reply of the wrong length where protocol 1.0 matches replies by ID alone: a late
        status packet of an earlier exchange (the host stalled past its timeout) taken for this
        one's.  The port is cleared and the exchange counts as failed, to be tried again."""
        self.port.clearPort()
        return CommunicationError(ids, f"{what}: a reply of the wrong length (a late one of an earlier exchange?)")

    def _status(self, dxl_id: int, size: int) -> tuple[list[int], int, int]:
        """Protocol 2.0: the status packet of ``dxl_id`` carrying ``size`` data bytes, skipping
        any other that comes first (see the module docstring) -> (data, result, error)."""
        while True:
            packet, result = self.handlers[2.0].rxPacket(self.port, False)
            if result != sdk.COMM_SUCCESS:
                return [], result, 0
            length = sdk.DXL_MAKEWORD(packet[P2.PKT_LENGTH_L], packet[P2.PKT_LENGTH_H])
            if packet[P2.PKT_ID] == dxl_id and length == size + STATUS_OVERHEAD:
                first = P2.PKT_PARAMETER0 + 1
                return packet[first:first + size], result, packet[P2.PKT_ERROR]

    @_exchange
    def read(self, dxl_id: int, address: int, size: int) -> int:
        protocol = self.protocol_of(dxl_id)
        handler = self.handlers[protocol]
        if protocol == 1.0:
            data, result, error = handler.readTxRx(self.port, dxl_id, address, size)
            if result == sdk.COMM_SUCCESS and len(data) != size:
                raise self._stale([dxl_id], f"read {size} bytes at {address}")
        else:
            result = handler.readTx(self.port, dxl_id, address, size)
            data, error = [], 0
            if result == sdk.COMM_SUCCESS:
                data, result, error = self._status(dxl_id, size)
        value = int.from_bytes(bytes(data), "little") if result == sdk.COMM_SUCCESS else None
        self._check([dxl_id], result, error, f"read {size} bytes at {address}", value)
        return value

    @_exchange
    def write(self, dxl_id: int, address: int, size: int, value: int) -> None:
        data = list(int(value).to_bytes(size, "little"))
        protocol = self.protocol_of(dxl_id)
        handler = self.handlers[protocol]
        if protocol == 1.0:
            result, error = handler.writeTxRx(self.port, dxl_id, address, size, data)
        else:
            result, error = handler.writeTxOnly(self.port, dxl_id, address, size, data), 0
            if result == sdk.COMM_SUCCESS:
                self.port.setPacketTimeout(11)  # the shortest status packet
                _, result, error = self._status(dxl_id, 0)
        self._check([dxl_id], result, error, f"write at {address}")

    @_exchange
    def sync_read(self, ids: list[int], address: int, size: int) -> dict[int, int]:
        self._group(SYNC_READ, [(i, address, size) for i in ids])
        result = self.handlers[2.0].syncReadTx(self.port, address, size, list(ids), len(ids), False)
        if result != sdk.COMM_SUCCESS:
            raise CommunicationError(ids, f"sync read: {self.handlers[2.0].getTxRxResult(result)}")
        return self._collect(2.0, {i: size for i in ids}, "sync read")

    @_exchange
    def bulk_read(self, items: dict[int, tuple[int, int]]) -> dict[int, int]:
        protocol = self._group(BULK_READ, [(i, *where) for i, where in items.items()])
        handler = self.handlers[protocol]
        param = []
        for dxl_id, (address, size) in items.items():
            if protocol == 1.0:  # e-manual, Protocol 1.0 Bulk Read: length, ID, address per device
                param += [size, dxl_id, address]
            else:
                param += [dxl_id, sdk.DXL_LOBYTE(address), sdk.DXL_HIBYTE(address), sdk.DXL_LOBYTE(size),
                          sdk.DXL_HIBYTE(size)]
        result = (handler.bulkReadTx(self.port, param, len(param)) if protocol == 1.0
                  else handler.bulkReadTx(self.port, param, len(param), False))
        if result != sdk.COMM_SUCCESS:
            raise CommunicationError(list(items), f"bulk read: {handler.getTxRxResult(result)}")
        return self._collect(protocol, {i: size for i, (_, size) in items.items()}, "bulk read")

    def _collect(self, protocol: float, sizes: dict[int, int], what: str) -> dict[int, int]:
        """The status packets of a sync or bulk read, one per device (``sizes``: id -> data
        bytes), in any order; the SDK's ``readRx`` would swallow the packets of the devices
        after a silent one while it waits for that one."""
        handler = self.handlers[protocol]
        values, errors, pending, corrupt = {}, [], dict(sizes), 0
        while pending:
            packet, result = handler.rxPacket(self.port) if protocol == 1.0 else handler.rxPacket(self.port, False)
            if result == sdk.COMM_RX_CORRUPT:  # one bad packet; the others may still come
                corrupt += 1
                continue
            if result != sdk.COMM_SUCCESS:
                break
            if protocol == 1.0:
                dxl_id, length, error = packet[P1.PKT_ID], packet[P1.PKT_LENGTH], packet[P1.PKT_ERROR]
                overhead, first = STATUS_OVERHEAD_P1, P1.PKT_PARAMETER0
            else:
                dxl_id, error = packet[P2.PKT_ID], packet[P2.PKT_ERROR]
                length = sdk.DXL_MAKEWORD(packet[P2.PKT_LENGTH_L], packet[P2.PKT_LENGTH_H])
                overhead, first = STATUS_OVERHEAD, P2.PKT_PARAMETER0 + 1
            if dxl_id not in pending or length != pending[dxl_id] + overhead:  # a late reply to another question
                continue
            size = pending.pop(dxl_id)
            values[dxl_id] = int.from_bytes(bytes(packet[first:first + size]), "little")
            if error:
                errors.append((dxl_id, error))
        missing = [i for i in sizes if i in pending]
        self.port.is_using = False
        if missing:
            if corrupt:
                raise CommunicationError(missing, f"{what}: {corrupt} corrupt repl{'ies' if corrupt > 1 else 'y'} "
                                         "(CRC error)", corrupt=True)
            raise CommunicationError(missing, f"no status packet in {what}")
        if errors:
            dxl_id, error = errors[0]
            raise status_error(dxl_id, error, values[dxl_id])
        return values

    @_exchange
    def sync_write(self, address: int, size: int, values: dict[int, int]) -> None:
        protocol = self._group(SYNC_WRITE, [(i, address, size) for i in values])
        group = sdk.GroupSyncWrite(self.port, self.handlers[protocol], address, size)  # both protocols have it
        for dxl_id, value in values.items():
            group.addParam(dxl_id, list(int(value).to_bytes(size, "little")))
        result = group.txPacket()
        if result != sdk.COMM_SUCCESS:
            raise CommunicationError(list(values), f"sync write: {self.handlers[protocol].getTxRxResult(result)}")

    @_exchange
    def reboot(self, dxl_id: int) -> None:
        result, error = self.handlers[self.protocol_of(dxl_id)].reboot(self.port, dxl_id)
        self._check([dxl_id], result, error & ERROR_NUMBER_MASK, "reboot")
        time.sleep(0.5)  # the servo boots before it answers again
