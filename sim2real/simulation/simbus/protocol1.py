"""Dynamixel Protocol 1.0 packets (AX-12A): ``FF FF | ID | LEN | INST | params | CHK``,
LEN = params + 2, CHK = ~(ID + LEN + INST + params) & 0xFF; the status carries an error
byte of flags in place of INST.  Source: ROBOTIS e-manual, "Protocol 1.0"."""

from __future__ import annotations

HEADER = b"\xff\xff"
BROADCAST = 0xFE
PING, READ, WRITE, SYNC_WRITE = 0x01, 0x02, 0x03, 0x83
# status error flags
INSTRUCTION_ERROR, CHECKSUM_ERROR, RANGE_ERROR = 0x40, 0x10, 0x08


def checksum(body: bytes) -> int:
    return (~sum(body)) & 0xFF


def packet(dxl_id: int, instruction_or_error: int, params: bytes = b"") -> bytes:
    body = bytes([dxl_id, len(params) + 2, instruction_or_error]) + params
    return HEADER + body + bytes([checksum(body)])


def status(dxl_id: int, error: int, data: bytes = b"") -> bytes:
    return packet(dxl_id, error, data)


class Parser:
    """Yields (id, instruction, params) of each intact packet; packets with a bad checksum are
    counted in ``crc_errors`` and dropped."""

    def __init__(self) -> None:
        self.buffer = bytearray()
        self.crc_errors = 0
        self.bad_crc_ids: list[int] = []  # IDs of packets dropped for their checksum, for a status

    def feed(self, data: bytes) -> list[tuple[int, int, bytes]]:
        self.buffer += data
        out = []
        while True:
            start = self.buffer.find(HEADER)
            if start < 0:
                del self.buffer[:-1]
                return out
            del self.buffer[:start]
            while len(self.buffer) > 2 and self.buffer[2] == 0xFF:  # FF FF FF: skip one
                del self.buffer[0]
            if len(self.buffer) < 4:
                return out
            length = self.buffer[3]
            if length < 2:
                del self.buffer[:2]
                continue
            if len(self.buffer) < 4 + length:
                return out
            raw = bytes(self.buffer[:4 + length])
            del self.buffer[:4 + length]
            if checksum(raw[2:-1]) != raw[-1]:
                self.crc_errors += 1
                self.bad_crc_ids.append(raw[2])
                continue
            out.append((raw[2], raw[4], raw[5:-1]))
