"""The servo catalogue: every profile in ``firmware_profiles/`` is served by the emulated bus and
answers the official SDK in its own protocol, at its own addresses; a robot mixes models.

A new profile that the bus cannot serve (a protocol the emulated chain does not speak, an entry
that does not read back what the device holds, a goal the device does not move to) fails here,
one case per file."""

from __future__ import annotations

import time
from pathlib import Path

import dynamixel_sdk as sdk
import pytest
import yaml

from sim2real.hardware.mock import MockDevice
from sim2real.simulation.model.physique import load_measured
from sim2real.robot.paths import profiles_dir
from sim2real.robot.profiles import DeviceProfile, parse_profile
from sim2real.robot.validation import load_yaml
from sim2real.simulation.simbus.server import EmulatedChain, PtyServer

ROOT = Path(__file__).resolve().parent.parent
PROFILE_FILES = sorted(profiles_dir().glob("*.yaml"))
DXL_ID = 7
GOAL_OFFSET_TICKS = 100  # from the centre: inside every servo's range
MOVE_PATIENCE_S = 10.0  # a servo at no-load speed covers 100 ticks in well under 0.1 s


def _sdk_port(path: str) -> sdk.PortHandler:
    port = sdk.PortHandler(path)
    assert port.openPort() and port.setBaudRate(1_000_000)
    return port


def _read(packets, port, address: int, size: int) -> int:
    data, result, error = packets.readTxRx(port, DXL_ID, address, size)
    assert result == sdk.COMM_SUCCESS, packets.getTxRxResult(result)
    assert error == 0, packets.getRxPacketError(error)
    return int.from_bytes(bytes(data), "little")


def _write(packets, port, address: int, size: int, value: int) -> None:
    result, error = packets.writeTxRx(port, DXL_ID, address, size, list(int(value).to_bytes(size, "little")))
    assert result == sdk.COMM_SUCCESS, packets.getTxRxResult(result)
    assert error == 0, packets.getRxPacketError(error)


@pytest.mark.parametrize("path", PROFILE_FILES, ids=lambda p: p.stem)
def test_every_profile_is_served_to_the_official_sdk_in_its_protocol(path):
    profile: DeviceProfile = parse_profile(load_yaml(path), path)
    device = MockDevice(DXL_ID, profile)
    with PtyServer(EmulatedChain({DXL_ID: device})) as server:
        port = _sdk_port(server.port)
        packets = sdk.PacketHandler(profile.protocol)
        try:
            model, result, error = packets.ping(port, DXL_ID)  # protocol 1.0: ping, then read address 0
            assert (result, error, model) == (sdk.COMM_SUCCESS, 0, profile.model_number)
            for reg in profile.control_table.values():  # every entry, at its address and size
                assert _read(packets, port, reg.address, reg.size) == device.get(reg.address, reg.size), reg.name
            if not profile.is_servo:
                return
            goal_reg = profile.register("goal_position")
            goal = profile.position.center_tick + GOAL_OFFSET_TICKS
            _write(packets, port, profile.register("torque_enable").address, 1, 1)
            _write(packets, port, goal_reg.address, goal_reg.size, goal)
            assert device.get_named("goal_position") == goal
            present = profile.register("present_position")
            give_up = time.monotonic() + MOVE_PATIENCE_S
            while _read(packets, port, present.address, present.size) != goal and time.monotonic() < give_up:
                time.sleep(0.01)
            assert _read(packets, port, present.address, present.size) == goal  # it moved there
            _write(packets, port, profile.register("torque_enable").address, 1, 0)
            assert device.get_named("torque_enable") == 0
        finally:
            port.closePort()


# -- a robot that mixes models and protocols ---------------------------------------------------
MIXED = {  # OP3's joints on the servos a Darwin-OP-like robot has (legs MX, head AX, arms XM430)
    "head_pan": "AX-12A", "head_tilt": "AX-12A",
    "r_hip_yaw": "MX-28", "l_hip_yaw": "MX-28", "r_hip_roll": "MX-64", "l_hip_roll": "MX-64",
    "r_hip_pitch": "MX-64", "l_hip_pitch": "MX-64", "r_knee": "MX-64", "l_knee": "MX-64",
    "r_ank_pitch": "MX-28", "l_ank_pitch": "MX-28", "r_ank_roll": "MX-28", "l_ank_roll": "MX-28",
}  # the arms keep the config's servo_model, XM430-W350-R (protocol 2.0)


@pytest.fixture
def mixed_robot(tmp_path) -> Path:
    doc = yaml.safe_load((ROOT / "configs" / "robots" / "op3.yaml").read_text())
    for joint in doc["joints"]:
        if joint["name"] in MIXED:
            joint["servo"]["model"] = MIXED[joint["name"]]
    doc["bus"]["baud"] = 1_000_000  # the AX-12A's top rate (OP3 runs its XM430s at 2 Mbps)
    doc["model"]["file"] = str(ROOT / "configs" / "robots" / "op3" / "op3.xml")
    path = tmp_path / "mixed.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_a_robot_mixing_models_and_protocols_loads_with_each_joints_own_profile(mixed_robot):
    robot = load_measured(mixed_robot)
    by_joint = {j.name: j.servo.profile for j in robot.joints}
    for name, model in MIXED.items():
        assert by_joint[name].model == model
    assert by_joint["r_el"].model == "XM430-W350" and by_joint["r_el"].protocol == 2.0
    assert {p.protocol for p in by_joint.values()} == {1.0, 2.0}


def test_robot_show_names_each_joints_model_protocol_and_profile_file(mixed_robot, capsys):
    from sim2real.cli.robot_commands import _print_description, describe

    d = describe(load_measured(mixed_robot))
    joints = {j["name"]: j for j in d["joints"]}
    assert (joints["r_knee"]["servo_model"], joints["r_knee"]["servo_protocol"],
            joints["r_knee"]["servo_profile"]) == ("MX-64", 1.0, "mx64_p1.yaml")
    assert (joints["head_pan"]["servo_model"], joints["head_pan"]["servo_protocol"]) == ("AX-12A", 1.0)
    assert (joints["l_el"]["servo_model"], joints["l_el"]["servo_protocol"]) == ("XM430-W350", 2.0)
    _print_description(d)
    out = capsys.readouterr().out
    knee_row = next(line for line in out.splitlines() if line.split()[:1] == ["r_knee"])
    assert knee_row.split()[2:4] == ["MX-64", "1.0"]
    for model, file, protocol in (("MX-28", "mx28_p1.yaml", "1.0"), ("MX-64", "mx64_p1.yaml", "1.0"),
                                  ("AX-12A", "ax12a.yaml", "1.0"), ("XM430-W350", "xm430_w350.yaml", "2.0")):
        assert f"servo {model}: firmware_profiles/{file}, protocol {protocol}" in out


# -- protocol 1.0's sign-magnitude entries on the simulated bus ---------------------------------
def test_sign_magnitude_entries_encode_as_the_servo_sends_them():
    from sim2real.hardware.dynamixel.chain import decode, encode
    from sim2real.robot.profiles import load_profile

    load = load_profile("MX-64").register("present_load")
    assert encode(load, -5) == 0x405 and encode(load, 5) == 5  # bit 10: CW
    assert [decode(load, encode(load, v)) for v in (-1023, -1, 0, 1, 1023)] == [-1023, -1, 0, 1, 1023]
    with pytest.raises(ValueError):
        encode(load, 1024)


def test_the_simulated_bus_reports_a_protocol_1_servos_load_with_its_sign_bit(tmp_path):
    """A standing robot on MX-64 (protocol 1.0): Present Load decodes to the torque each servo
    carries, in 0.1 % of its stall torque, negative ones included."""
    import numpy as np

    from sim2real.hardware.dynamixel.chain import decode
    from sim2real.simulation.simbus.physics import PhysicsChain

    doc = yaml.safe_load((ROOT / "configs" / "robots" / "xl430_biped.yaml").read_text())
    doc["servo_model"] = "MX-64"
    doc["bus"]["baud"] = 1_000_000
    path = tmp_path / "mx64_biped.yaml"
    path.write_text(yaml.safe_dump(doc))
    robot = load_measured(path)
    now = [0.0]
    physics = PhysicsChain(robot, clock=lambda: now[0])
    for dxl_id in physics.ids:  # hold the home pose
        physics.devices[dxl_id].set_named("torque_enable", 1)
    now[0] = 0.2
    physics.advance()
    expected = np.rint(physics.mapping.direction * physics.data.actuator_force / physics.stall * 1000.0)
    reported = []
    for dxl_id in physics.ids:
        device = physics.devices[dxl_id]
        reg = device.profile.register("present_load")
        reported.append(decode(reg, device.get(reg.address, reg.size)))
    assert np.any(expected < 0)  # the case that needs the sign bit
    assert reported == [int(np.clip(v, -1023, 1023)) for v in expected]
