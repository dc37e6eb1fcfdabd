"""One bus, both protocols: XL430-W250-T servos (protocol 2.0) and AX-12A (1.0) on one port
(issue 48, item 3) - and protocol-1.0 MX servos, which have Bulk Read.

The robot is the default biped with its four ankle servos on AX-12A; its knees are MX-28 with
protocol-1.0 firmware where that profile exists (``firmware_profiles/mx28_p1.yaml``), else
XL430.  In process, a stand-in for a protocol-1.0 MX (the AX-12A's table with Bulk Read) covers
bulk reads whatever the catalogue holds.  What is checked: the plan of each access (which
instruction reaches which servos, and the bytes it takes), that the mock and the official SDK
over a pseudo-terminal both refuse an instruction that cannot reach every servo it names, the
packets a control tick sends (counted at the emulated servos, not timed), and torque off read
back on every servo of both protocols after a SIGINT to ``biped run``.
"""

from __future__ import annotations

import collections
import dataclasses
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import REPLY_ALLOWANCE_US
import yaml

from sim2real.controller.mapping import ServoMapping
from sim2real.controller.policy import Policy
from sim2real.hardware import MockBus, ServoChain
from sim2real.hardware.loop import RealTimeLoop
from sim2real.hardware.run_report import RunReport
from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus
from sim2real.hardware.dynamixel.startup import start_up
from sim2real.robot import load_robot
from sim2real.robot.bus_plan import BULK_READ, READ, SYNC_READ, SYNC_WRITE, bus_time, check_group, plan_reads
from sim2real.robot.paths import profiles_dir, robots_dir
from sim2real.robot.profiles import load_profile
from sim2real.simulation.simbus import protocol1 as p1
from sim2real.simulation.simbus import protocol2 as p2
from sim2real.simulation.simbus.server import EmulatedChain, PtyServer

AX_JOINTS = ("ankle_pitch", "ankle_roll")  # IDs 5, 6, 10, 11
MX_P1 = "mx28_p1" if (profiles_dir() / "mx28_p1.yaml").exists() else None  # knees, IDs 4 and 9
INSTRUCTIONS = {(2.0, p2.SYNC_READ): SYNC_READ, (2.0, p2.READ): READ, (2.0, p2.SYNC_WRITE): SYNC_WRITE,
                (2.0, p2.BULK_READ): BULK_READ, (1.0, p1.READ): READ, (1.0, p1.SYNC_WRITE): SYNC_WRITE,
                (1.0, p1.BULK_READ): BULK_READ}


def mixed_doc() -> dict:
    doc = yaml.safe_load((robots_dir() / "xl430_biped.yaml").read_text())
    doc["name"] = "mixed_biped"
    for joint in doc["joints"]:
        if joint["name"].endswith(AX_JOINTS):  # AX-12A turns 300 deg: the ranges fit
            joint["servo"]["model"] = "AX-12A"
            joint["range_deg"] = [max(-60, joint["range_deg"][0]), min(100, joint["range_deg"][1])]
        elif MX_P1 and joint["name"].endswith("knee"):
            joint["servo"]["model"] = MX_P1
    return doc


@pytest.fixture(scope="module")
def robot_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("mixed") / "mixed_biped.yaml"
    path.write_text(yaml.safe_dump(mixed_doc()))
    return path


@pytest.fixture(scope="module")
def robot(robot_file):
    return load_robot(str(robot_file))


def with_stand_in_mx(robot):
    """The robot with its knees on a protocol-1.0 servo that has Bulk Read (the AX-12A's table:
    MX firmware 1.0 keeps the AX's addresses for position and goal)."""
    mx = dataclasses.replace(load_profile("AX-12A"), model="MX (1.0) stand-in", instructions=load_profile("AX-12A").instructions + ("bulk_read",))
    joints = tuple(dataclasses.replace(j, servo=dataclasses.replace(j.servo, profile=mx)) if j.name.endswith("knee")
                   else j for j in robot.joints)
    return dataclasses.replace(robot, joints=joints)


def ids_of(robot, protocol: float, has: str | None = None) -> list[int]:
    return [j.servo.id for j in robot.joints if j.servo.profile.protocol == protocol
            and (has is None or j.servo.profile.has(has))]


# -- the plan --------------------------------------------------------------------------------------


def test_a_read_is_grouped_by_protocol_and_instruction_and_priced_in_bytes(robot):
    stand_in = with_stand_in_mx(robot)
    devices = {j.servo.id: j.servo.profile for j in stand_in.joints}
    plan = plan_reads(devices, ["present_position"], [j.servo.id for j in stand_in.joints])
    assert [(e.kind, e.protocol, e.ids) for e in plan] == [
        (SYNC_READ, 2.0, (1, 2, 3, 7, 8)), (BULK_READ, 1.0, (4, 9)),
        (READ, 1.0, (5,)), (READ, 1.0, (6,)), (READ, 1.0, (10,)), (READ, 1.0, (11,))]
    sync, bulk, single = plan[0], plan[1], plan[2]
    assert (sync.out_bytes(), sync.in_bytes()) == (14 + 5, 5 * (11 + 4))  # e-manual, Protocol 2.0
    assert (bulk.out_bytes(), bulk.in_bytes()) == (6 + 1 + 2 * 3, 2 * (6 + 2))  # Protocol 1.0: 0x00, (len, ID, addr)
    assert (single.out_bytes(), single.in_bytes()) == (8, 8)
    time = bus_time(stand_in)
    # + the board's read and a sync write per protocol; 1 ms of turnaround for each that waits
    assert time.packets == len(plan) + 3 and time.turnaround_s == pytest.approx((len(plan) + 1) * 1e-3)


def test_an_instruction_that_cannot_reach_every_servo_it_names_is_refused(robot):
    devices = {j.servo.id: j.servo.profile for j in with_stand_in_mx(robot).joints}
    for kind, items, words in (
            (SYNC_READ, [(1, 132, 4), (5, 132, 4)], "protocols 1.0 (5) and 2.0 (1)"),
            (SYNC_READ, [(5, 36, 2), (6, 36, 2)], "AX-12A, protocol 1.0) have no sync read"),
            (BULK_READ, [(5, 36, 2), (6, 36, 2)], "have no bulk read"),
            (BULK_READ, [(4, 36, 2)], "cannot read a single servo"),
            (SYNC_WRITE, [(1, 116, 4), (5, 30, 2)], "one instruction per protocol")):
        with pytest.raises(ValueError, match=words.replace("(", r"\(").replace(")", r"\)")):
            check_group(kind, devices, items)
    check_group(BULK_READ, devices, [(4, 36, 2), (9, 36, 2)])
    check_group(SYNC_WRITE, devices, [(5, 30, 2), (4, 30, 2)])


# -- the bus contract on the mixed chain: mock and official SDK alike -------------------------------


@pytest.fixture(params=["mock", "sdk-emulated"])
def subject(request, robot):
    robot = with_stand_in_mx(robot)
    if request.param == "mock":
        bus = MockBus(robot)
        bus.open()
        yield robot, bus, bus.devices
        bus.close()
        return
    devices = MockBus(robot).devices
    with PtyServer(EmulatedChain(devices)) as server:
        bus = DynamixelBus(server.port, 1_000_000, robot, return_delay_us=REPLY_ALLOWANCE_US)
        bus.open()
        yield robot, bus, devices
        bus.close()


def test_each_bus_refuses_a_group_instruction_across_protocols_or_without_the_instruction(subject):
    robot, bus, _ = subject
    ax, xl = ids_of(robot, 1.0, None), ids_of(robot, 2.0)
    with pytest.raises(ValueError, match="protocols 1.0"):
        bus.sync_read(xl + ax[:1], 132, 4)
    with pytest.raises(ValueError, match="no sync read"):
        bus.sync_read([5, 6], 36, 2)
    with pytest.raises(ValueError, match="no bulk read"):
        bus.bulk_read({5: (36, 2), 6: (36, 2)})
    with pytest.raises(ValueError, match="protocols 1.0"):
        bus.sync_write(30, 2, {1: 512, 5: 512})
    assert sorted(bus.sync_read(xl, 132, 4)) == xl  # the bus is still in order


def test_each_bus_bulk_reads_protocol_1_mx_and_protocol_2_devices_at_their_own_addresses(subject):
    robot, bus, devices = subject
    devices[4].set_named("present_position", 700)
    devices[9].set_named("present_position", 300)
    assert bus.bulk_read({4: (36, 2), 9: (36, 2)}) == {4: 700, 9: 300}
    devices[1].set_named("goal_position", 2100)
    assert bus.bulk_read({1: (116, 4), 200: (0, 2)}) == {1: 2100, 200: robot.sensor_board.profile.model_number}


def test_the_chain_reads_and_writes_servos_of_both_protocols(subject):
    robot, bus, devices = subject
    chain = ServoChain(bus, robot)
    for j in robot.joints:
        devices[j.servo.id].set_named("present_position", 100 + j.servo.id)
    assert chain.sync_read("present_position").tolist() == [100 + j.servo.id for j in robot.joints]
    goals = np.array([2000 if j.servo.profile.protocol == 2.0 else 600 for j in robot.joints])
    chain.sync_write("goal_position", goals)
    assert chain.sync_read("goal_position").tolist() == goals.tolist()  # (a round trip: the writes have landed)
    assert [devices[j.servo.id].get_named("goal_position") for j in robot.joints] == goals.tolist()
    chain.torque(True)
    assert chain.sync_read("torque_enable").tolist() == [1] * len(robot.joints)
    chain.sync_write("torque_enable", np.zeros(len(robot.joints), dtype=np.int64))
    assert chain.sync_read("torque_enable").tolist() == [0] * len(robot.joints)
    assert [devices[j.servo.id].get_named("torque_enable") for j in robot.joints] == [0] * len(robot.joints)


# -- a control tick: every position read, every goal written, in the planned packets -----------------


@pytest.fixture(scope="module")
def controller(robot):
    from evolve.locomotion.evaluator import neat_layout
    from evolve.locomotion.export import controller_from_genome
    from evolve.locomotion.task import TaskConfig
    from evolve.neat import NeatConfig, Population
    from sim2real.controller.symmetry import symmetric_layout

    layout = symmetric_layout(robot, robot.control_sets["walk"])
    pop = Population(NeatConfig(population_size=6, target_species=2), neat_layout(layout), seed=48)
    return controller_from_genome(pop.genomes[0], robot, layout, TaskConfig(), 1.0, {"seed": 48})


@pytest.mark.parametrize("stand_in", [False, True], ids=["as-configured", "with-mx-bulk-read"])
def test_every_tick_reads_every_position_and_writes_both_protocols_in_the_planned_packets(robot, controller,
                                                                                          stand_in):
    from sim2real.controller.robot_checks import bus_problems

    robot = with_stand_in_mx(robot) if stand_in else robot
    tick_s = controller.tick_s
    time_ = bus_time(robot)
    assert bus_problems(robot, tick_s) == [] and time_.total_s < tick_s  # within the tick's budget
    devices = MockBus(robot).devices
    emulated = EmulatedChain(devices)
    heard: list[tuple[float, int, int, bytes]] = []
    handle = emulated.handle

    def recording(dxl_id, inst, params, protocol=None):
        heard.append((emulated.protocol if protocol is None else protocol, inst, dxl_id, params))
        return handle(dxl_id, inst, params, protocol)

    emulated.handle = recording
    with PtyServer(emulated) as server:
        bus = DynamixelBus(server.port, 1_000_000, robot, return_delay_us=REPLY_ALLOWANCE_US)
        bus.open()
        chain, mapping = ServoChain(bus, robot), ServoMapping(robot)
        start_up(chain, mapping, attempts=3, patience_s=0.3, warn=lambda s: None)
        policy = Policy(controller, robot)
        loop = RealTimeLoop(chain, mapping, policy, tick_s, lost_after_s=2.0)
        ticks, report = 5, RunReport()
        heard.clear()
        loop.run(ticks * tick_s, report)
        bus.close()
    assert report.ticks == ticks and report.missed_ticks == 0 and report.retries == 0
    sent = collections.Counter((protocol, INSTRUCTIONS[protocol, inst]) for protocol, inst, _, _ in heard)
    planned = collections.Counter((e.protocol, e.kind) for e in time_.exchanges)
    assert sent == {key: n * ticks for key, n in planned.items()}
    assert len(heard) == ticks * time_.packets
    # every servo's position asked for every tick, in its own protocol
    asked = collections.Counter()
    for protocol, inst, dxl_id, params in heard:
        if inst == (p2.SYNC_READ if protocol == 2.0 else -1):
            asked.update(params[4:])
        elif protocol == 1.0 and inst == p1.BULK_READ:
            asked.update(params[2::3])
        elif inst == (p1.READ if protocol == 1.0 else p2.READ) and dxl_id != 200:
            asked[dxl_id] += 1
    assert asked == {j.servo.id: ticks for j in robot.joints}
    # the last goals reached the servos of both protocols
    for k, j in enumerate(robot.joints):
        assert devices[j.servo.id].get_named("goal_position") == loop.goal_ticks[k], j.name
    assert {1.0, 2.0} == {protocol for protocol, inst, _, _ in heard if INSTRUCTIONS[protocol, inst] == SYNC_WRITE}


# -- robot show, and the refusals before any port is opened -------------------------------------------


def biped(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "evolve.cli", *args], capture_output=True, text=True,
                          timeout=300, **kw)


def test_robot_show_lists_the_exchanges_of_a_tick(robot_file, robot):
    done = biped("robot", "show", str(robot_file), "--json")
    assert done.returncode == 0, done.stderr
    shown = json.loads(done.stdout)
    assert shown["bus_problems"] == []
    kinds = {(e["protocol"], e["kind"]) for e in shown["bus_tick"]["exchanges"]}
    assert {(2.0, SYNC_READ), (1.0, READ), (2.0, SYNC_WRITE), (1.0, SYNC_WRITE)} <= kinds
    assert shown["bus_tick"]["packets"] == bus_time(robot).packets and shown["tick_s"] >= shown["bus_tick"]["time_s"]


def test_a_mix_that_cannot_be_read_within_its_tick_or_set_to_one_baud_is_refused(robot_file, tmp_path, controller):
    slow = mixed_doc() | {"bus": {"port": "/dev/ttyUSB0", "baud": 57600}}
    (tmp_path / "slow.yaml").write_text(yaml.safe_dump(slow))
    done = biped("robot", "show", str(tmp_path / "slow.yaml"))
    assert done.returncode == 2
    took = bus_time(load_robot(str(tmp_path / "slow.yaml"))).total_s * 1e3  # about 55 ms at 57600 baud
    assert took > 50 and f"bus: one control tick's bus traffic takes {took:.2f} ms, longer than the longest tick" \
        in done.stderr and "read (protocol 1.0) of servo 5" in done.stderr
    fast = mixed_doc() | {"bus": {"port": "/dev/ttyUSB0", "baud": 2_000_000}}
    (tmp_path / "fast.yaml").write_text(yaml.safe_dump(fast))
    done = biped("robot", "show", str(tmp_path / "fast.yaml"))
    assert done.returncode == 2 and "bus.baud: " in done.stderr
    assert "AX-12A (protocol 1.0, IDs 5, 6, 10, 11) cannot be set to 2000000 baud" in done.stderr
    # `biped run` refuses before any port is opened (this one does not exist)
    controller.save(tmp_path / "c.json")
    done = biped("run", str(tmp_path / "c.json"), "--robot", str(robot_file), "--port", "/dev/ttyNOPE",
                 "--baud", "57600", "--no-mlock")
    assert done.returncode == 2 and "bus traffic takes" in done.stderr and "ttyNOPE" not in done.stderr


# -- a signal to `biped run`: torque off, read back, on every servo of both protocols ---------------


def test_biped_run_on_a_mixed_bus_stops_on_sigint_with_torque_off_read_back_on_every_servo(robot_file, robot,
                                                                                           controller, tmp_path):
    controller.save(tmp_path / "c.json")
    simbus = subprocess.Popen([sys.executable, "-m", "sim2real.simulation.simbus", "--robot", str(robot_file),
                               "--exit-on-stdin-eof", "--no-mlock"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                              text=True)
    try:
        port = simbus.stdout.readline().strip()
        trace = tmp_path / "t.csv"
        run = subprocess.Popen([sys.executable, "-m", "evolve.cli", "run", str(tmp_path / "c.json"), "--robot",
                                str(robot_file), "--port", port, "--duration", "30", "--trace", str(trace),
                                "--lost-after-ms", "2000", "--json", "--no-mlock"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        give_up = time.monotonic() + 60
        while not (trace.exists() and len(trace.read_text().splitlines()) > 2):  # the loop has run
            assert time.monotonic() < give_up and run.poll() is None, run.communicate()[1]
            time.sleep(0.05)
        run.send_signal(signal.SIGINT)
        out, err = run.communicate(timeout=120)
        assert run.returncode == 0, err
        result = json.loads(out.splitlines()[-1])
        assert result["stop_signal"] == "SIGINT" and result["bus_errors"] == 0
        servos = [j.servo.id for j in robot.joints]
        assert result["torque_off"] == {"confirmed": servos, "unconfirmed": []}
        bus = DynamixelBus(port, robot.bus.baud, robot)  # read back here, through the SDK, each in its protocol
        bus.open()
        try:
            chain = ServoChain(bus, robot)
            assert {i: chain.read(i, "torque_enable") for i in servos} == {i: 0 for i in servos}
        finally:
            bus.close()
    finally:
        simbus.stdin.close()
        simbus.wait(timeout=30)


def test_the_simulated_bus_answers_each_protocol_only_from_its_own_servos(robot):
    """Below our bus's checks: the SDK's own packets of each protocol on one port."""
    import dynamixel_sdk as sdk

    devices = MockBus(robot).devices
    with PtyServer(EmulatedChain(devices)) as server:
        bus = DynamixelBus(server.port, 1_000_000, robot, return_delay_us=REPLY_ALLOWANCE_US)
        bus.open()
        one, two = bus.handlers[1.0], bus.handlers[2.0]
        # an AX-12A does not parse a protocol-2.0 sync read that names it; the XL430 named with it answers
        group = sdk.GroupSyncRead(bus.port, two, 132, 4)
        for dxl_id in (1, 5):
            group.addParam(dxl_id)
        assert group.txPacket() == sdk.COMM_SUCCESS
        assert two.readRx(bus.port, 1, 4)[1] == sdk.COMM_SUCCESS
        assert two.readRx(bus.port, 5, 4)[1] == sdk.COMM_RX_TIMEOUT
        # nor an XL430 a protocol-1.0 read, or a 1.0 sync write at its ID
        assert one.readTxRx(bus.port, 1, 36, 2)[1] == sdk.COMM_RX_TIMEOUT
        assert one.syncWriteTxOnly(bus.port, 30, 2, [1, 0x58, 0x02, 5, 0x58, 0x02], 6) == sdk.COMM_SUCCESS
        assert one.readTxRx(bus.port, 5, 30, 2)[0] == [0x58, 0x02]  # the AX-12A took its goal, 600
        assert two.read4ByteTxRx(bus.port, 1, 116)[0] == 2048  # the XL430 kept its own
        bus.close()


def test_a_late_reply_of_the_wrong_length_in_protocol_1_is_a_failed_exchange_not_a_value(monkeypatch):
    """Protocol 1.0 matches a status packet to its request by ID alone: after a host stall, the
    late reply of an earlier exchange (a ping's, with no data) can arrive in place of a read's.
    The SDK then indexes past its end (ping) or returns fewer bytes (read); either is a failed
    exchange, retried, with the port cleared - never a crash, never a value read as 0."""
    import dynamixel_sdk as sdk

    from sim2real.hardware.bus import CommunicationError
    from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus

    bus = DynamixelBus("/dev/null", 1_000_000, protocol=1.0)
    cleared = []
    monkeypatch.setattr(bus.port, "clearPort", lambda: cleared.append(True))
    handler = bus.handlers[1.0]
    monkeypatch.setattr(handler, "readTxRx", lambda port, dxl_id, address, size: ([], sdk.COMM_SUCCESS, 0))
    with pytest.raises(CommunicationError, match="wrong length"):
        bus.read(7, 36, 2)
    monkeypatch.setattr(handler, "ping", lambda port, dxl_id: [][0])  # what the SDK does with an empty reply
    with pytest.raises(CommunicationError, match="ping: a reply of the wrong length"):
        bus.ping(7)
    assert len(cleared) == 2 and not bus.port.is_using
