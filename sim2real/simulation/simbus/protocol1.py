"""Dynamixel Protocol 1.0 packets (AX-12A): ``FF FF | ID | LEN | INST | params | CHK``,
LEN = params + 2, CHK = ~(ID + LEN + INST + params) & 0xFF; the status carries an error
byte of flags in place of INST.  Source: ROBOTIS e-manual, "Protocol 1.0"."""

from __future__ import annotations

from sim2real.simulation.simbus.framing import SKIP, Packet, StreamParser

HEADER = b"\xff\xff"
BROADCAST = 0xFE
PING, READ, WRITE, SYNC_WRITE = 0x01, 0x02, 0x03, 0x83
BULK_READ = 0x92  # MX firmware only: 0x00, then (length, ID, address) per device
# status error flags
INSTRUCTION_ERROR, CHECKSUM_ERROR, RANGE_ERROR = 0x40, 0x10, 0x08


def checksum(body: bytes) -> int:
    return (~sum(body)) & 0xFF


def packet(dxl_id: int, instruction_or_error: int, params: bytes = b"") -> bytes:
    body = bytes([dxl_id, len(params) + 2, instruction_or_error]) + params
    return HEADER + body + bytes([checksum(body)])


def status(dxl_id: int, error: int, data: bytes = b"") -> bytes:
    return packet(dxl_id, error, data)


class Parser(StreamParser):
    """Yields (id, instruction, params) of each intact packet; packets with a bad checksum are
    counted in ``crc_errors`` and dropped."""

    header = HEADER

    def _take(self) -> Packet | object | None:
        while len(self.buffer) > 2 and self.buffer[2] == 0xFF:  # FF FF FF: skip one
            del self.buffer[0]
        if len(self.buffer) < 4:
            return None
        length = self.buffer[3]
        if length < 2:
            del self.buffer[:2]
            return SKIP
        raw = self._cut(4 + length)
        if raw is None:
            return None
        if checksum(raw[2:-1]) != raw[-1]:
            return self._reject(raw[2])
        return raw[2], raw[4], raw[5:-1]
