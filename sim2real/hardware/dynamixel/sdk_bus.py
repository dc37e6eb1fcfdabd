"""The real bus: ``dynamixel-sdk`` (PortHandler / PacketHandler) on a serial port.

Works around the SDK 4.1.0 pitfalls listed in DESIGN.md section 6, in this layer only:

* no busy-wait: our port blocks in the serial driver until bytes arrive or the packet's
  time is up, instead of the SDK's spinning on a non-blocking read;
* timeouts from the wire: bytes x 10 bits / baud, plus Return Delay Time and the USB
  adapter's latency, not the SDK's 34 ms floor (16 ms latency timer x 2 + 2);
* per-servo error bytes: sync reads go through ``syncReadTx`` + ``readRx`` per servo, so
  each status's error byte (and its hardware-alert bit) is kept, and one silent servo is
  named instead of failing the whole read anonymously;
* protocol 1.0 (AX-12A): no sync read exists and the SDK's protocol-1.0 bulk read is
  broken, so reads go servo by servo;
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

P2 = sdk.protocol2_packet_handler
STATUS_OVERHEAD = 4  # protocol 2.0: LENGTH counts instruction, error and the 2 CRC bytes besides the data
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
    def __init__(self, port: str, baud: int, robot: RobotSpec | None = None, protocol: float | None = None,
                 return_delay_us: float = 0.0):
        if protocol is None:
            protocol = next((j.servo.profile.protocol for j in robot.joints if j.servo), 2.0) if robot else 2.0
        self.protocol = protocol
        self.port_name, self.baud = port, baud
        self.port = _Port(port, return_delay_us)
        self.packets = sdk.PacketHandler(protocol)

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
            raise CommunicationError(ids, f"{what}: {self.packets.getTxRxResult(result)}")
        if error:
            raise status_error(ids[0], error, value)

    @_exchange
    def ping(self, dxl_id: int) -> int:
        model, result, error = self.packets.ping(self.port, dxl_id)
        self._check([dxl_id], result, error & ERROR_NUMBER_MASK, "ping")
        return model

    def _status(self, dxl_id: int, size: int) -> tuple[list[int], int, int]:
        """Protocol 2.0: the status packet of ``dxl_id`` carrying ``size`` data bytes, skipping
        any other that comes first (see the module docstring) -> (data, result, error)."""
        while True:
            packet, result = self.packets.rxPacket(self.port, False)
            if result != sdk.COMM_SUCCESS:
                return [], result, 0
            length = sdk.DXL_MAKEWORD(packet[P2.PKT_LENGTH_L], packet[P2.PKT_LENGTH_H])
            if packet[P2.PKT_ID] == dxl_id and length == size + STATUS_OVERHEAD:
                first = P2.PKT_PARAMETER0 + 1
                return packet[first:first + size], result, packet[P2.PKT_ERROR]

    @_exchange
    def read(self, dxl_id: int, address: int, size: int) -> int:
        if self.protocol == 1.0:
            data, result, error = self.packets.readTxRx(self.port, dxl_id, address, size)
        else:
            result = self.packets.readTx(self.port, dxl_id, address, size)
            data, error = [], 0
            if result == sdk.COMM_SUCCESS:
                data, result, error = self._status(dxl_id, size)
        value = int.from_bytes(bytes(data), "little") if result == sdk.COMM_SUCCESS else None
        self._check([dxl_id], result, error, f"read {size} bytes at {address}", value)
        return value

    @_exchange
    def write(self, dxl_id: int, address: int, size: int, value: int) -> None:
        data = list(int(value).to_bytes(size, "little"))
        if self.protocol == 1.0:
            result, error = self.packets.writeTxRx(self.port, dxl_id, address, size, data)
        else:
            result, error = self.packets.writeTxOnly(self.port, dxl_id, address, size, data), 0
            if result == sdk.COMM_SUCCESS:
                self.port.setPacketTimeout(11)  # the shortest status packet
                _, result, error = self._status(dxl_id, 0)
        self._check([dxl_id], result, error, f"write at {address}")

    @_exchange
    def sync_read(self, ids: list[int], address: int, size: int) -> dict[int, int]:
        if self.protocol == 1.0:  # no SYNC_READ in protocol 1.0
            return {i: self.read(i, address, size) for i in ids}
        result = self.packets.syncReadTx(self.port, address, size, list(ids), len(ids), False)
        if result != sdk.COMM_SUCCESS:
            raise CommunicationError(ids, f"sync read: {self.packets.getTxRxResult(result)}")
        # One status packet per servo, in any order; the SDK's readRx would swallow the
        # packets of the servos after a silent one while it waits for that one.
        values, errors, pending, corrupt = {}, [], set(ids), 0
        while pending:
            packet, result = self.packets.rxPacket(self.port, False)
            if result == sdk.COMM_RX_CORRUPT:  # one bad packet; the others may still come
                corrupt += 1
                continue
            if result != sdk.COMM_SUCCESS:
                break
            dxl_id = packet[sdk.protocol2_packet_handler.PKT_ID]
            length = sdk.DXL_MAKEWORD(packet[P2.PKT_LENGTH_L], packet[P2.PKT_LENGTH_H])
            if dxl_id not in pending or length != size + STATUS_OVERHEAD:  # a late reply to another question
                continue
            pending.discard(dxl_id)
            first = sdk.protocol2_packet_handler.PKT_PARAMETER0 + 1
            values[dxl_id] = int.from_bytes(bytes(packet[first:first + size]), "little")
            error = packet[sdk.protocol2_packet_handler.PKT_ERROR]
            if error:
                errors.append((dxl_id, error))
        missing = [i for i in ids if i in pending]
        self.port.is_using = False
        if missing:
            if corrupt:
                raise CommunicationError(missing, f"sync read: {corrupt} corrupt repl{'ies' if corrupt > 1 else 'y'} "
                                         "(CRC error)", corrupt=True)
            raise CommunicationError(missing, "no status packet in sync read")
        if errors:
            dxl_id, error = errors[0]
            raise status_error(dxl_id, error, values[dxl_id])
        return values

    @_exchange
    def sync_write(self, address: int, size: int, values: dict[int, int]) -> None:
        group = sdk.GroupSyncWrite(self.port, self.packets, address, size)  # both protocols have it
        for dxl_id, value in values.items():
            group.addParam(dxl_id, list(int(value).to_bytes(size, "little")))
        result = group.txPacket()
        if result != sdk.COMM_SUCCESS:
            raise CommunicationError(list(values), f"sync write: {self.packets.getTxRxResult(result)}")

    @_exchange
    def reboot(self, dxl_id: int) -> None:
        result, error = self.packets.reboot(self.port, dxl_id)
        self._check([dxl_id], result, error & ERROR_NUMBER_MASK, "reboot")
        time.sleep(0.5)  # the servo boots before it answers again
