"""One byte stream carrying packets of both Dynamixel protocols, as on a bus that mixes
protocol-1.0 servos (AX-12A, MX with its 1.0 firmware) and 2.0 ones.

Both start with ``FF FF``: protocol 2.0 goes on with ``FD 00`` (its header's third byte and
the reserved byte), protocol 1.0 with the ID and a length of at least 2, so ``FF FF FD 00``
is never the start of a valid 1.0 packet (ROBOTIS e-manual, "Protocol 1.0" and "Protocol
2.0").  A real servo parses the stream with its own protocol's rules and ignores the other's
packets; :class:`MixedParser` splits the stream the same way and tags each packet with its
protocol, so that the emulated chain lets only the devices of that protocol hear it.
"""

from __future__ import annotations

from sim2real.simulation.simbus import protocol1 as p1
from sim2real.simulation.simbus import protocol2 as p2
from sim2real.simulation.simbus.framing import SKIP, StreamParser

HEADER = b"\xff\xff"

TaggedPacket = tuple[int, int, bytes, float]  # (id, instruction, params, protocol)


class MixedParser(StreamParser):
    """Yields (id, instruction, params, protocol) of each intact packet of either protocol;
    packets with a bad checksum or CRC are counted in ``crc_errors`` and their IDs listed in
    ``bad_crc_ids`` (the addressed device answers in its own protocol)."""

    header = HEADER

    def __init__(self) -> None:
        super().__init__()
        # the protocols' own parsers, reading this parser's buffer
        self._parsers = {1.0: p1.Parser(), 2.0: p2.Parser()}
        for parser in self._parsers.values():
            parser.buffer = self.buffer

    def feed(self, data: bytes) -> list[TaggedPacket]:
        self.buffer += data
        out: list[TaggedPacket] = []
        while self._to_header():
            if len(self.buffer) < 4:
                break  # which protocol is not known yet
            protocol = 2.0 if self.buffer[2:4] == b"\xfd\x00" else 1.0
            parser = self._parsers[protocol]
            packet = parser._take()
            self._count(parser)
            if packet is None:
                break
            if packet is not SKIP:
                out.append((*packet, protocol))
        return out

    def _count(self, parser: StreamParser) -> None:
        """Take over what the protocol's parser rejected."""
        if parser.bad_crc_ids:
            self.crc_errors += len(parser.bad_crc_ids)
            self.bad_crc_ids += parser.bad_crc_ids
            parser.bad_crc_ids.clear()

    def _take(self):  # feed() picks the protocol's own
        raise NotImplementedError
