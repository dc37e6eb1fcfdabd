"""DynamixelBus: the official SDK over a real pseudo-terminal, against byte-exact fake servos.

What every bus must do is in test_bus_contract.py; here is what only this one does (the
wire's timeouts, protocol 1.0, the SDK's other instructions, CRC errors)."""

import os
import pty
import threading
import tty

import numpy as np
import pytest
from conftest import REPLY_ALLOWANCE_US

from sim2real.hardware import CommunicationError, MockBus, ServoChain
from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus
from sim2real.robot import load_robot
from sim2real.simulation.simbus import protocol1 as p1
from sim2real.simulation.simbus.protocol2 import crc16, status
from sim2real.simulation.simbus.server import EmulatedChain, PtyServer

ROBOT = load_robot()


def _serve(return_delay_us: float):
    devices = MockBus(ROBOT).devices
    chain = EmulatedChain(devices)
    with PtyServer(chain) as server:
        bus = DynamixelBus(server.port, 1_000_000, ROBOT, return_delay_us=return_delay_us)
        bus.open()
        yield bus, chain, devices
        bus.close()


@pytest.fixture
def served():
    yield from _serve(REPLY_ALLOWANCE_US)


@pytest.fixture
def served_on_the_wire():
    """Timeouts as the wire sets them (no allowance)."""
    yield from _serve(0.0)


def test_crc_matches_the_emanual_check_value():
    assert crc16(b"123456789") == 0xFEE8


def test_the_sensor_board_is_read_in_one_block_and_decoded(served):
    bus, _, devices = served
    devices[200].set_named("foot_switch_left", 1)
    devices[200].set_named("up_vector_x", -1000)
    devices[200].set_named("heading", -8192)
    devices[200].set_named("gyro_x", -450)  # rolling left at half a radian a second
    devices[200].set_named("gyro_z", 900)
    feet, up, heading, gyro = ServoChain(bus, ROBOT).read_board()
    assert feet.tolist() == [True, False] and up == pytest.approx([-1000 / 16384, 0, 1]) and heading == -1.0
    assert gyro.tolist() == [-0.5, 0.0, 1.0]


def test_timeouts_follow_the_wire_not_the_sdk_floor_and_do_not_spin(served_on_the_wire):
    """Counted, not timed (a timed test fails on a busy machine): the packet timeout the SDK
    is given, and how often a failed read asks the serial driver for bytes."""
    bus, chain_server, _ = served_on_the_wire
    chain_server.silent.add(4)
    reads, timeouts = [], []
    real_read, real_set = bus.port.ser.read, bus.port.setPacketTimeout

    def counting_read(n):
        reads.append(bus.port.ser.timeout)
        return real_read(n)

    def recording_set(length):
        real_set(length)
        timeouts.append((length, bus.port.packet_timeout))

    bus.port.ser.read, bus.port.setPacketTimeout = counting_read, recording_set
    with pytest.raises(CommunicationError):
        bus.read(4, 132, 4)
    (length, timeout_ms), = timeouts
    # the reply's bytes at 1 Mbps (10 bits a byte) + 2 x 1 ms USB latency + 2 ms slack
    assert timeout_ms == pytest.approx(length * 10 / 1_000_000 * 1e3 + 4.0)
    assert timeout_ms < 34.0  # the SDK's own floor
    # blocked in the driver until the deadline: a handful of reads, each with a timeout,
    # not thousands of zero-timeout polls
    assert 1 <= len(reads) <= 5 and all(timeout > 0 for timeout in reads[:1])


def test_the_whole_run_over_the_real_sdk_and_a_pty(tmp_path):
    from evolve.locomotion.evaluator import neat_layout
    from evolve.locomotion.export import controller_from_genome
    from evolve.locomotion.task import TaskConfig
    from evolve.neat import NeatConfig, Population
    from sim2real.controller.symmetry import symmetric_layout
    from sim2real.hardware.deploy import drive

    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"])
    pop = Population(NeatConfig(population_size=6, target_species=2), neat_layout(layout), seed=3)
    controller = controller_from_genome(pop.genomes[0], ROBOT, layout, TaskConfig(), 1.0, {"seed": 3})
    devices = MockBus(ROBOT).devices
    with PtyServer(EmulatedChain(devices)) as server:
        report = drive(DynamixelBus(server.port, 1_000_000, ROBOT), ROBOT, controller, duration_s=0.5,
                       trace_path=tmp_path / "t.csv", log=lambda s: None, ramp_s=0.1)
    assert report.stop_reason == "duration reached" and report.bus_errors == 0
    assert report.ticks == round(0.5 / controller.tick_s)
    assert all(d.get_named("torque_enable") == 0 for d in devices.values() if d.profile.is_servo)
    assert all(d.get_named("return_delay_time") == 0 for d in devices.values() if d.profile.is_servo)


def test_protocol_1_ax12a_chain_through_the_sdk(tmp_path):
    """AX-12A: protocol 1.0, no sync read (servo by servo), 2-byte positions."""
    import yaml
    from conftest import ROOT

    doc = yaml.safe_load((ROOT / "configs" / "robots" / "xl430_biped.yaml").read_text())
    doc["servo_model"] = "AX-12A"
    for joint in doc["joints"]:  # AX-12A turns 300 deg: the ranges fit
        joint["range_deg"] = [max(-60, joint["range_deg"][0]), min(100, joint["range_deg"][1])]
    path = tmp_path / "ax_biped.yaml"
    path.write_text(yaml.safe_dump(doc))
    robot = load_robot(path)
    devices = {i: d for i, d in MockBus(robot).devices.items() if d.profile.is_servo}
    with PtyServer(EmulatedChain(devices)) as server:
        bus = DynamixelBus(server.port, 1_000_000, robot)
        assert bus.protocol == 1.0
        bus.open()
        chain = ServoChain(bus, robot)
        chain.sync_write("goal_position", np.full(11, 600))
        assert chain.sync_read("present_position").tolist() == [512] * 11  # (a round trip)
        assert devices[4].get_named("goal_position") == 600
        assert bus.ping(3) in (0, 12)  # the SDK's protocol-1.0 ping reads the model number separately
        # a bad checksum gets a status with the checksum-error bit, as a real AX-12A sends
        bad = bytearray(p1.packet(3, p1.PING))
        bad[-1] ^= 0xFF
        bus.port.clearPort()
        bus.port.writePort(bytes(bad))
        bus.port.setPacketTimeout(6)
        packet, result = bus.packets.rxPacket(bus.port)
        assert packet[2] == 3 and packet[4] == p1.CHECKSUM_ERROR
        bus.close()


def test_reg_write_waits_for_action_and_broadcast_ping_finds_everyone(served):
    import dynamixel_sdk as sdk

    bus, _, devices = served
    assert bus.packets.regWriteTxRx(bus.port, 3, 116, 4, list((1234).to_bytes(4, "little")))[0] == sdk.COMM_SUCCESS
    assert devices[3].get_named("goal_position") == 2048  # held
    bus.packets.action(bus.port, sdk.BROADCAST_ID)
    bus.ping(1)
    assert devices[3].get_named("goal_position") == 1234
    found, result = bus.packets.broadcastPing(bus.port)
    assert result == sdk.COMM_SUCCESS
    assert sorted(found) == sorted(devices) and found[200][0] == 32512


def test_factory_reset_restores_defaults(served):
    import dynamixel_sdk as sdk

    bus, _, devices = served
    ServoChain(bus, ROBOT).write(6, "return_delay_time", 0)
    result, _ = bus.packets.factoryReset(bus.port, 6, 0x02)  # everything but the ID
    assert result == sdk.COMM_SUCCESS
    assert devices[6].get_named("return_delay_time") == 250 and devices[6].get_named("id") == 6


def test_bulk_write_and_bulk_read_through_the_sdk_groups(served):
    import dynamixel_sdk as sdk

    bus, _, devices = served
    write = sdk.GroupBulkWrite(bus.port, bus.packets)
    write.addParam(2, 116, 4, list((1500).to_bytes(4, "little")))
    write.addParam(200, 68, 1, [1])  # a different address on another device
    assert write.txPacket() == sdk.COMM_SUCCESS
    read = sdk.GroupBulkRead(bus.port, bus.packets)
    read.addParam(2, 116, 4)
    read.addParam(200, 100, 2)
    devices[200].set_named("foot_switch_right", 1)
    assert read.txRxPacket() == sdk.COMM_SUCCESS
    assert read.getData(2, 116, 4) == 1500 and read.getData(200, 100, 2) == 0x0100


def test_fast_sync_read_and_fast_bulk_read_through_the_sdk_groups(served):
    import dynamixel_sdk as sdk

    bus, _, devices = served
    devices[4].set_named("present_position", 1999)
    group = sdk.GroupSyncRead(bus.port, bus.packets, 132, 4)
    for dxl_id in (3, 4, 5):
        group.addParam(dxl_id)
    assert group.fastSyncRead() == sdk.COMM_SUCCESS
    assert [group.getData(i, 132, 4) for i in (3, 4, 5)] == [2048, 1999, 2048]
    bulk = sdk.GroupBulkRead(bus.port, bus.packets)
    bulk.addParam(4, 132, 4)
    bulk.addParam(200, 0, 2)
    assert bulk.fastBulkRead() == sdk.COMM_SUCCESS
    assert bulk.getData(4, 132, 4) == 1999 and bulk.getData(200, 0, 2) == 32512


def test_a_packet_with_a_bad_crc_gets_a_crc_error_status(served):
    from sim2real.simulation.simbus import protocol2 as p2

    bus, _, _ = served
    bad = bytearray(p2.packet(3, p2.PING))
    bad[-1] ^= 0xFF
    bus.port.clearPort()
    bus.port.writePort(bytes(bad))
    bus.port.setPacketTimeout(11)
    packet, result = bus.packets.rxPacket(bus.port, False)
    assert packet[8] == p2.CRC_ERROR and packet[4] == 3


@pytest.mark.parametrize("what", ["read", "write", "sync_read"])
def test_a_late_status_of_an_earlier_exchange_is_not_taken_for_the_reply(what):
    """Under load the runtime repeats a sync read whose replies were late; they then arrive
    during the next exchange.  A 4-byte Present Position of servo 7 (hardware alert set) must
    not be read as the 1-byte Hardware Error Status asked next, nor as a write's status; a
    2-byte Present Load not as the 4-byte Present Position of a sync read."""
    master, slave = pty.openpty()
    tty.setraw(slave)
    late = status(7, 0x80, (2049).to_bytes(4, "little"))  # position 2049: low byte 1 = "input voltage"
    reply = status(7, 0x80, bytes([32])) if what == "read" else status(7, 0)  # the write went through
    if what == "sync_read":  # a 2-byte Present Load late, then the 4-byte Present Position asked
        late, reply = status(7, 0, (300).to_bytes(2, "little")), status(7, 0, (2049).to_bytes(4, "little"))

    def servo():
        os.read(master, 64)  # the instruction
        os.write(master, late + reply)

    threading.Thread(target=servo, daemon=True).start()
    bus = DynamixelBus(os.ttyname(slave), 1_000_000, ROBOT, return_delay_us=REPLY_ALLOWANCE_US)
    bus.open()
    try:
        if what == "read":
            chain = ServoChain(bus, ROBOT)
            assert chain.hardware_error(7) == 32  # overload, the true answer
        elif what == "sync_read":
            assert bus.sync_read([7], 132, 4) == {7: 2049}
        else:
            bus.write(7, 64, 1, 0)  # no error: the late packet's alert is not this write's
    finally:
        bus.close()
        os.close(master)
        os.close(slave)
