"""What both protocols' packet parsers share: a byte buffer that resynchronizes on the
protocol's header, and a count (with the IDs) of packets dropped for a bad checksum or CRC,
whose addressed servo answers with an error status."""

from __future__ import annotations

Packet = tuple[int, int, bytes]  # (id, instruction, params)
SKIP = object()  # _take's answer for bytes that were dropped (not a packet, or a bad checksum)


class StreamParser:
    """Subclasses give ``header`` and ``_take``, which reads one packet at the buffer's head."""

    header: bytes = b""

    def __init__(self) -> None:
        self.buffer = bytearray()
        self.crc_errors = 0
        self.bad_crc_ids: list[int] = []  # IDs of packets dropped for their checksum, for a status

    def feed(self, data: bytes) -> list[Packet]:
        """The intact packets that ``data`` completes, in order."""
        self.buffer += data
        out = []
        while self._to_header():
            packet = self._take()
            if packet is None:  # incomplete: wait for more bytes
                break
            if packet is not SKIP:
                out.append(packet)
        return out

    def _take(self) -> Packet | object | None:
        """The packet at the head of the buffer (removed from it), SKIP, or None for more bytes."""
        raise NotImplementedError

    def _to_header(self) -> bool:
        """Drop the bytes before the next header; False when there is none yet (keeping what
        may be the start of one)."""
        start = self.buffer.find(self.header)
        if start < 0:
            del self.buffer[:-(len(self.header) - 1)]
            return False
        del self.buffer[:start]
        return True

    def _cut(self, size: int) -> bytes | None:
        """The buffer's first ``size`` bytes, removed from it; None while fewer have come."""
        if len(self.buffer) < size:
            return None
        raw = bytes(self.buffer[:size])
        del self.buffer[:size]
        return raw

    def _reject(self, dxl_id: int) -> object:
        self.crc_errors += 1
        self.bad_crc_ids.append(dxl_id)
        return SKIP
