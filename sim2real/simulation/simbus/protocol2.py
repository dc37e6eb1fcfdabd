"""Dynamixel Protocol 2.0 packets: CRC-16, byte stuffing, building and parsing.

``FF FF FD 00 | ID | LEN_L LEN_H | INST | params | CRC_L CRC_H`` with LEN = params + 3 (for
a status packet the error byte counts as a parameter); FF FF FD inside a packet is sent as
FF FF FD FD.  Source: ROBOTIS e-manual, "Protocol 2.0".
"""

from __future__ import annotations

from sim2real.simulation.simbus.framing import SKIP, Packet, StreamParser

HEADER = b"\xff\xff\xfd\x00"
MAX_LENGTH = 1024  # longer than any packet a chain of 253 devices exchanges with us
BROADCAST = 0xFE
STATUS = 0x55
CRC_ERROR = 0x03
PING, READ, WRITE, REG_WRITE, ACTION, FACTORY_RESET, REBOOT = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x08
SYNC_READ, SYNC_WRITE, FAST_SYNC_READ, BULK_READ, BULK_WRITE, FAST_BULK_READ = 0x82, 0x83, 0x8A, 0x92, 0x93, 0x9A


def _crc_table() -> list[int]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return table


_TABLE = _crc_table()


def crc16(data: bytes) -> int:
    """CRC-16 (polynomial 0x8005, initial 0, no reflection): crc16(b"123456789") == 0xFEE8."""
    crc = 0
    for byte in data:
        crc = ((crc << 8) ^ _TABLE[((crc >> 8) ^ byte) & 0xFF]) & 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    return body.replace(b"\xff\xff\xfd", b"\xff\xff\xfd\xfd")


def unstuff(body: bytes) -> bytes:
    return body.replace(b"\xff\xff\xfd\xfd", b"\xff\xff\xfd")


def packet(dxl_id: int, instruction: int, params: bytes = b"") -> bytes:
    """A complete packet (instruction, or status with the error byte first in ``params``)."""
    body = stuff(bytes([instruction]) + params)
    length = len(body) + 2
    head = HEADER + bytes([dxl_id, length & 0xFF, length >> 8])
    crc = crc16(head + body)
    return head + body + bytes([crc & 0xFF, crc >> 8])


def status(dxl_id: int, error: int, data: bytes = b"") -> bytes:
    return packet(dxl_id, STATUS, bytes([error]) + data)


def fast_status(replies: list[tuple[int, int, bytes]]) -> bytes:
    """The one status packet of FAST_SYNC_READ / FAST_BULK_READ: for each device its error
    byte, ID, data and a CRC of the packet so far; the last CRC is the packet's."""
    length = 1 + sum(4 + len(data) for _, _, data in replies)
    out = bytearray(HEADER + bytes([BROADCAST, length & 0xFF, length >> 8, STATUS]))
    for dxl_id, error, data in replies:
        out += bytes([error, dxl_id]) + data
        crc = crc16(bytes(out))
        out += bytes([crc & 0xFF, crc >> 8])
    return bytes(out)


class Parser(StreamParser):
    """Splits a byte stream into packets: yields (id, instruction, params) of each intact one;
    packets with a bad CRC are counted in ``crc_errors`` and dropped."""

    header = HEADER

    def _take(self) -> Packet | object | None:
        if len(self.buffer) < 7:
            return None
        length = self.buffer[5] | (self.buffer[6] << 8)
        if not 3 <= length <= MAX_LENGTH:  # not a packet: resynchronize on the next header
            del self.buffer[:1]
            return SKIP
        raw = self._cut(7 + length)
        if raw is None:
            return None
        if crc16(raw[:-2]) != (raw[-2] | (raw[-1] << 8)):
            return self._reject(raw[4])
        body = unstuff(raw[7:-2])
        return raw[4], body[0], body[1:]
