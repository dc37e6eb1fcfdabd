"""Firmware profiles load, validate, and agree with the ROBOTIS e-manual."""

import copy
import math

import pytest
import yaml

from sim2real.errors import ConfigError
from sim2real.robot.paths import profiles_dir
from sim2real.robot.profiles import available_profiles, load_profile, parse_profile
from sim2real.robot.servo_model import position_gain, servo_physics

# (model number, protocol, stall torque [N m], no-load speed [rpm], nominal voltage [V]):
# e-manual specification tables, as listed in DESIGN.md section 6.
EMANUAL = {
    "XL430-W250-T": (1060, 2.0, 1.4, 57, 11.1),
    "XM430-W350-T": (1020, 2.0, 4.1, 46, 12.0),
    "XL330-M288-T": (1200, 2.0, 0.52, 103, 5.0),
    "MX-28(2.0)": (30, 2.0, 2.5, 55, 12.0),
    "AX-12A": (12, 1.0, 1.5, 59, 12.0),
    # the catalogue of issue 48: ROBOTIS-GIT/emanual docs/en/dxl/... pages and _data/dxl_*_info.yml
    "MX-28": (29, 1.0, 2.5, 55, 12.0),
    "MX-64": (310, 1.0, 6.0, 63, 12.0),
    "MX-64(2.0)": (311, 2.0, 6.0, 63, 12.0),
    "MX-106": (320, 1.0, 8.4, 45, 12.0),
    "MX-106(2.0)": (321, 2.0, 8.4, 45, 12.0),
    "AX-18A": (18, 1.0, 1.8, 97, 12.0),
    "XC330-M288-T": (1240, 2.0, 0.93, 81, 5.0),
    "XC430-W240-T": (1080, 2.0, 1.9, 70, 12.0),
    "XH430-W350": (1000, 2.0, 3.4, 30, 12.0),
    "2XL430-W250-T": (1090, 2.0, 1.4, 57, 11.1),
}
MX_PROTOCOL_1_ADDRESSES = {  # e-manual control table of MX-28/64/106 with the protocol 1.0 firmware
    "torque_enable": 24, "d_gain": 26, "i_gain": 27, "p_gain": 28, "goal_position": 30,
    "moving_speed": 32, "torque_limit": 34, "present_position": 36, "present_speed": 38,
    "present_load": 40, "present_voltage": 42, "present_temperature": 43,
}
X_SERIES_ADDRESSES = {  # e-manual control table of the X series / MX(2.0)
    "return_delay_time": 9, "operating_mode": 11, "max_position_limit": 48,
    "min_position_limit": 52, "torque_enable": 64, "hardware_error_status": 70,
    "position_d_gain": 80, "position_i_gain": 82, "position_p_gain": 84, "bus_watchdog": 98,
    "profile_acceleration": 108, "profile_velocity": 112, "goal_position": 116, "moving": 122,
    "present_velocity": 128, "present_position": 132, "present_input_voltage": 144,
    "present_temperature": 146,
}
AX12_ADDRESSES = {"torque_enable": 24, "goal_position": 30, "moving_speed": 32, "present_position": 36}


def test_every_profile_in_the_folder_loads():
    names = available_profiles()
    assert {"XL430-W250-T", "XL330-M288-T", "MX-28(2.0)", "AX-12A"} <= set(names)
    assert any(n.startswith("XM430-W350") for n in names)
    assert any(load_profile(n).kind == "sensor_board" for n in names)


@pytest.mark.parametrize("model", sorted(EMANUAL))
def test_servo_constants_match_the_emanual(model):
    number, protocol, stall, rpm, volts = EMANUAL[model]
    p = load_profile(model)
    assert p.model_number == number
    assert p.protocol == protocol
    assert p.motor.stall_torque_nm == pytest.approx(stall)
    assert p.motor.no_load_speed_rpm == pytest.approx(rpm)
    assert p.motor.nominal_voltage_v == pytest.approx(volts)
    assert p.register("model_number").default == number


@pytest.mark.parametrize("model", ["XL430-W250-T", "XM430-W350-R", "XL330-M288-T", "MX-28(2.0)", "MX-64(2.0)",
                                   "MX-106(2.0)", "XC330-M288-T", "XC430-W240-T", "XH430-W350", "2XL430-W250-T"])
def test_x_series_control_table_addresses(model):
    p = load_profile(model)
    for name, address in X_SERIES_ADDRESSES.items():
        assert p.register(name).address == address, name
    assert p.register("goal_position").size == 4 and p.register("goal_position").signed
    assert p.register("present_velocity").signed
    assert p.register("torque_enable").area == "RAM"
    assert p.register("operating_mode").area == "EEPROM"
    assert p.position.resolution == 4096


def test_ax12a_is_protocol_1_with_its_own_table():
    p = load_profile("AX-12A")
    for name, address in AX12_ADDRESSES.items():
        assert p.register(name).address == address, name
    assert p.position.resolution == 1024
    assert math.degrees(p.position.range_rad[1] - p.position.range_rad[0]) == pytest.approx(300, abs=0.5)


def test_default_gains_convert_to_physical_units():
    p = load_profile("XL430-W250-T")
    assert p.gains.values["position_p"] == 640
    # KPP = 640/128 = 5 PWM units a tick; 885 units = full duty = stall torque
    expected = 1.4 * 5 * (4096 / (2 * math.pi)) / 885
    assert position_gain(p) == pytest.approx(expected)


@pytest.mark.parametrize("model", sorted(EMANUAL))
def test_servo_physics_reproduces_the_no_load_speed(model):
    p = load_profile(model)
    phys = servo_physics(p)
    w0 = p.motor.no_load_speed_rad_s
    # at full torque and no load the motor's torque balances friction and back-EMF exactly
    assert phys.force_limit - phys.frictionloss - phys.damping * w0 == pytest.approx(0, abs=1e-12)
    assert phys.kp > 0 and phys.armature > 0


def test_sensor_board_documents_feet_and_up_vector():
    board = next(load_profile(n) for n in available_profiles() if load_profile(n).kind == "sensor_board")
    assert board.protocol == 2.0
    names = set(board.control_table)
    assert {"foot_switch_left", "foot_switch_right", "up_vector_x", "up_vector_y", "up_vector_z"} <= names
    assert board.register("up_vector_z").signed
    assert board.register("heading").signed and board.units["heading_unit"] == 1 / 8192
    last = board.register("heading")
    assert last.address + last.size - board.register("foot_switch_left").address == 10  # one read of 10 bytes


@pytest.mark.parametrize("mutate, problem", [
    (lambda d: d["sensors"].pop("heading_unit"), "heading_unit .* must be given"),
    (lambda d: d["sensors"].update(heading_unit="1/4096"), "must be given and be heading's unit"),
])
def test_a_boards_heading_needs_its_unit(mutate, problem, tmp_path):
    doc = yaml.safe_load((profiles_dir() / "foot_sensor_board.yaml").read_text())
    mutate(doc)
    with pytest.raises(ConfigError, match=problem):
        parse_profile(doc, tmp_path / "board.yaml")


def _xl430_doc():
    return yaml.safe_load((profiles_dir() / "xl430_w250_t.yaml").read_text())


@pytest.mark.parametrize(
    "mutate, key, problem",
    [
        (lambda d: d.update(colour="red"), "colour", "unknown key"),
        (lambda d: d["motor"].pop("stall_torque_nm"), "motor.stall_torque_nm", "missing"),
        (lambda d: d["control_table"][0].update(size=3), "control_table[0].size", "1, 2 or 4"),
        (lambda d: d.update(protocol=3), "protocol", "1.0 or 2.0"),
        (lambda d: d["motor"].update(no_load_speed_rpm="fast"), "motor.no_load_speed_rpm", "number"),
    ],
)
def test_bad_profile_is_refused_naming_file_and_key(mutate, key, problem, tmp_path):
    doc = copy.deepcopy(_xl430_doc())
    mutate(doc)
    with pytest.raises(ConfigError) as err:
        parse_profile(doc, tmp_path / "bad.yaml")
    assert err.value.key == key
    assert "bad.yaml" in str(err.value) and problem in str(err.value)


@pytest.mark.parametrize("model", ["MX-28", "MX-64", "MX-106"])
def test_mx_servos_with_the_protocol_1_firmware_have_their_own_table(model):
    p = load_profile(model)
    assert p.protocol == 1.0
    for name, address in MX_PROTOCOL_1_ADDRESSES.items():
        assert p.register(name).address == address, name
    assert p.register("goal_position").size == 2 and p.position.resolution == 4096
    assert p.register("present_load").encoding == "sign_magnitude_bit10"
    assert p.register("baud_rate").default == 34  # 57600 bps as shipped
    # the 2.0 firmware of the same servo is another profile, found by its own name
    assert load_profile(f"{model}(2.0)").model_number == p.model_number + 1


def test_each_servo_profile_lists_what_its_model_answers():
    servos = [load_profile(n) for n in available_profiles() if load_profile(n).is_servo]
    assert all(p.instructions for p in servos)
    for p in servos:
        assert ("sync_read" in p.instructions) == (p.protocol == 2.0), p.model  # protocol 1.0 has no Sync Read
        if p.protocol == 1.0:  # Bulk Read in protocol 1.0: MX only
            assert ("bulk_read" in p.instructions) == p.model.startswith("MX"), p.model
    assert "reboot" not in load_profile("AX-12A").instructions and "reboot" in load_profile("MX-28").instructions


@pytest.mark.parametrize("mutate, key, problem", [
    (lambda d: d.update(instructions=["ping", "read", "write", "sync_read"]), "instructions[3]", "must be one of"),
    (lambda d: d.update(instructions=["read", "write"]), "instructions", "must list ping"),
    (lambda d: d.update(instructions=["ping", "read", "write", "read"]), "instructions", "twice"),
    (lambda d: d["control_table"].append({"name": "far", "address": 300, "size": 2, "signed": False,
                                          "access": "R", "area": "RAM", "unit": None}),
     "control_table[32].address", "beyond address 255"),
])
def test_a_protocol_1_profile_keeps_to_what_protocol_1_has(mutate, key, problem, tmp_path):
    doc = yaml.safe_load((profiles_dir() / "ax12a.yaml").read_text())
    mutate(doc)
    with pytest.raises(ConfigError) as err:
        parse_profile(doc, tmp_path / "ax.yaml")
    assert err.value.key == key and problem in str(err.value)


def test_one_axis_of_a_two_axis_module_carries_half_its_mass():
    axis = load_profile("2XL430-W250")
    assert axis.mass_kg == pytest.approx(0.0982 / 2)  # the e-manual's 98.2 g for the module
    assert axis.motor.stall_torque_nm == load_profile("XL430-W250-T").motor.stall_torque_nm
