"""Dynamixel packet codecs: round trips, stuffing, and a fuzz of the parsers."""

from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.simulation.simbus import protocol1 as p1
from sim2real.simulation.simbus import protocol2 as p2


def test_protocol2_round_trip_with_byte_stuffing():
    params = bytes([0x74, 0x00, 0xFF, 0xFF, 0xFD, 0x01])
    packet = p2.packet(7, p2.WRITE, params)
    assert b"\xff\xff\xfd\xfd" in packet[7:]  # stuffed on the wire
    assert p2.Parser().feed(packet) == [(7, p2.WRITE, params)]


def test_protocol2_drops_a_corrupt_packet_and_keeps_the_next():
    good = p2.packet(3, p2.PING)
    bad = bytearray(p2.packet(4, p2.READ, b"\x84\x00\x04\x00"))
    bad[-3] ^= 0x55
    parser = p2.Parser()
    assert parser.feed(bytes(bad) + good) == [(3, p2.PING, b"")]
    assert parser.crc_errors == 1


def test_protocol1_round_trip():
    packet = p1.packet(5, p1.WRITE, bytes([30, 0x00, 0x02]))
    assert p1.Parser().feed(b"\xff" + packet) == [(5, p1.WRITE, bytes([30, 0x00, 0x02]))]


@settings(max_examples=400, deadline=None)
@given(st.lists(st.one_of(st.binary(max_size=80),
                          st.builds(lambda i, inst, p: p2.packet(i, inst, p), st.integers(0, 253),
                                    st.integers(0, 255), st.binary(max_size=40))), max_size=12),
       st.integers(1, 17))
def test_protocol2_parser_survives_garbage_truncation_and_oversize(chunks, split):
    stream = b"".join(chunks) + b"\xff\xff\xfd\x00\x01\xff\xff"  # an oversized length at the end
    parser = p2.Parser()
    packets = []
    for k in range(0, len(stream), split):
        packets += parser.feed(stream[k:k + split])
    assert all(0 <= i <= 255 and isinstance(params, bytes) for i, _, params in packets)
    assert len(parser.buffer) <= len(stream)
    good = p2.packet(9, p2.PING)
    # never stuck behind garbage: a pending partial packet is at most MAX_LENGTH bytes
    received = [packet for _ in range(p2.MAX_LENGTH // len(good) + 2) for packet in parser.feed(good)]
    assert (9, p2.PING, b"") in received


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(st.binary(max_size=80),
                          st.binary(max_size=6).map(lambda tail: p1.HEADER + tail),  # a header, then junk
                          st.builds(lambda i, inst, p: p1.packet(i, inst, p), st.integers(0, 253),
                                    st.integers(0, 255), st.binary(max_size=40))), max_size=8),
       st.integers(1, 9))
def test_protocol1_parser_survives_garbage(chunks, split):
    stream = b"".join(chunks) + b"\xff\xff\x01\xff"  # a length longer than what follows, at the end
    parser = p1.Parser()
    packets = []
    for k in range(0, len(stream), split):
        packets += parser.feed(stream[k:k + split])
    assert all(0 <= i <= 255 and 0 <= inst <= 255 and isinstance(params, bytes) for i, inst, params in packets)
    assert len(parser.buffer) <= len(stream)
    good = p1.packet(9, p1.PING)
    # never stuck behind garbage: a pending partial packet is at most 4 + 255 bytes (LEN is one byte)
    received = [packet for _ in range((4 + 255) // len(good) + 2) for packet in parser.feed(good)]
    assert (9, p1.PING, b"") in received
