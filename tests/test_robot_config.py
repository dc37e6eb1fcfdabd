"""Robot configs load, and each kind of bad config is refused with file, key and problem."""

import copy
import math

import pytest
import yaml
from conftest import ROOT, all_robot_names

from sim2real.errors import ConfigError
from sim2real.robot import load_robot, parse_robot
from sim2real.simulation.model.physique import load_measured


@pytest.mark.parametrize("name", all_robot_names())
def test_every_robot_and_preset_loads(name):
    robot = load_measured(name)
    assert robot.mass > 0 and robot.height > 0
    for joint in robot.joints:
        lo, hi = joint.range_rad
        assert lo <= joint.home_rad <= hi


def test_default_robot_is_the_11_servo_xl430_biped():
    robot = load_robot()
    assert robot.name == "xl430_biped"
    assert len(robot.joints) == 11
    assert {j.servo.profile.model for j in robot.joints} == {"XL430-W250-T"}
    assert 0.35 <= robot.height <= 0.45
    # at least the servos' own 57.2 g each, plus frame, battery and controller
    assert robot.mass > 11 * 0.0572 * 1.3


def test_op3_legs_adds_hip_yaw_on_xm430():
    robot = load_robot("op3_legs")
    assert len(robot.joints) == 12
    assert {"left_hip_yaw", "right_hip_yaw"} <= set(robot.joint_names)
    assert all(j.servo.profile.model.startswith("XM430-W350") for j in robot.joints)


def test_human_presets_scale_with_stature_and_mass():
    small, large = load_robot("human:female_5"), load_robot("human:male_95")
    assert small.body.height == pytest.approx(1.496, rel=0.01)
    assert large.body.height == pytest.approx(1.872, rel=0.01)
    assert small.body.mass == pytest.approx(50.7, rel=0.01)
    # seed 000 table 1: knee 0..3pi/4, ankle sagittal +-pi/4
    assert small.joint("left_knee").range_rad == pytest.approx((0, 3 * math.pi / 4))
    assert small.joint("left_ankle_pitch").range_rad == pytest.approx((-math.pi / 4, math.pi / 4))


def test_torque_cap_in_proportion_to_mass():
    doc = _doc("human")
    doc["pd_gains"] = {"kp": 300.0, "kd": 30.0, "max_torque_nm_per_kg": 4.0}
    small, large = (parse_robot(doc, "human.yaml", preset) for preset in ("female_5", "male_95"))
    assert small.pd.max_torque_nm == pytest.approx(4.0 * 50.7)
    assert large.pd.max_torque_nm == pytest.approx(4.0 * 131.8)


def test_pd_no_load_speed_scales_with_leg_and_limits_goals_and_torque():
    """A PD body's no-load speed in Froude units: the same number moves a short body's joints
    faster; the goal's step a tick and the joints' damping (cap / w0) follow from it."""
    import mujoco
    import numpy as np

    from sim2real.controller.mapping import max_steps
    from sim2real.simulation.model.builder import build_model

    doc = _doc("human_stepping")
    assert load_robot("human_stepping").pd_no_load_speed_rad_s == math.inf  # the shipped body: no limit
    assert np.isinf(max_steps(load_robot("human_stepping"), 0.07)).all()
    doc["pd_gains"]["no_load_speed_froude"] = 0.94
    small, large = (parse_robot(doc, "human_stepping.yaml", preset) for preset in ("female_5", "male_95"))
    for robot in (small, large):
        w0 = robot.pd_no_load_speed_rad_s
        assert w0 == pytest.approx(0.94 * math.sqrt(9.81 / robot.leg_length))
        assert max_steps(robot, 0.07) == pytest.approx(np.full(len(robot.joints), w0 * 0.07))
        model = build_model(robot)
        knee = model.joint("left_knee").dofadr[0]
        assert model.dof_damping[knee] == pytest.approx(robot.pd_torque_cap_nm / w0)
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, "left_knee") >= 0
    assert small.pd_no_load_speed_rad_s > large.pd_no_load_speed_rad_s
    doc["pd_gains"]["no_load_speed_froude"] = -1.0
    with pytest.raises(ConfigError, match="no_load_speed_froude"):
        parse_robot(doc, "human_stepping.yaml")


def test_pd_stiffness_in_body_units_is_one_number_for_every_joint_at_eq2s_damping_ratio():
    """``stiffness_mgl``: every joint's stiffness is that many m g L a radian (a servo's is the
    same on every joint), where eq. 2 scales each by its inertia; each joint keeps eq. 2's damping
    ratio on its own inertia, and the key is checked like the others."""
    import numpy as np

    from sim2real.simulation.model.builder import build_model

    doc = _doc("human_stepping")
    eq2 = build_model(parse_robot(doc, "human_stepping.yaml", "male_95"))
    doc["pd_gains"]["stiffness_mgl"] = 2.0
    robot = parse_robot(doc, "human_stepping.yaml", "male_95")
    model = build_model(robot)
    stiffness = 2.0 * robot.mass * 9.81 * robot.leg_length
    assert model.actuator_gainprm[:, 0] == pytest.approx(np.full(model.nu, stiffness))
    assert -model.actuator_biasprm[:, 1] == pytest.approx(np.full(model.nu, stiffness))
    inertia = eq2.actuator_gainprm[:, 0] / robot.pd.kp  # eq. 2's kp x I, read back
    ratio = -model.actuator_biasprm[:, 2] / (2.0 * np.sqrt(stiffness * inertia))
    assert ratio == pytest.approx(np.full(model.nu, robot.pd.kd / (2.0 * np.sqrt(robot.pd.kp))))
    assert eq2.actuator_gainprm[:, 0].max() > 5 * eq2.actuator_gainprm[:, 0][3:].min()  # eq. 2's spread
    doc["pd_gains"]["stiffness_mgl"] = 0.0
    with pytest.raises(ConfigError, match="stiffness_mgl"):
        parse_robot(doc, "human_stepping.yaml")


@pytest.mark.parametrize("caps", [{}, {"max_torque_nm": 300.0, "max_torque_nm_per_kg": 4.0}])
def test_torque_cap_must_be_given_one_way(caps):
    doc = _doc("human")
    doc["pd_gains"] = {"kp": 300.0, "kd": 30.0, **caps}
    with pytest.raises(ConfigError, match="pd_gains: give exactly one of max_torque_nm"):
        parse_robot(doc, "human.yaml")


def _doc(name="xl430_biped"):
    return yaml.safe_load((ROOT / "configs" / "robots" / f"{name}.yaml").read_text())


def _joint(doc, name):
    return next(j for j in doc["joints"] if j["name"] == name)


BAD_CONFIGS = [
    ("unknown key", lambda d: d.update(wheels=4), "wheels", "unknown key 'wheels'"),
    ("unknown joint key", lambda d: _joint(d, "right_knee").update(gear=2), "joints[3].gear", "unknown key"),
    ("missing servo", lambda d: _joint(d, "right_knee").pop("servo"), "joints[3].servo", "has no servo"),
    ("range outside the servo's", lambda d: _joint(d, "right_knee").update(range_deg=[0, 200]),
     "joints[3].servo", "outside the XL430-W250-T's"),
    ("range outside via zero offset", lambda d: _joint(d, "right_knee")["servo"].update(zero_offset_deg=150),
     "joints[3].servo", "outside"),
    ("duplicate ID", lambda d: _joint(d, "left_knee")["servo"].update(id=4), "joints[8].servo.id",
     "duplicate ID 4"),
    ("ID shared with the sensor board", lambda d: d["sensor_board"].update(id=1), "sensor_board.id",
     "duplicate ID 1"),
    ("unknown profile", lambda d: d.update(servo_model="XL999"), "servo_model", "unknown servo profile 'XL999'"),
    ("unknown per-joint profile", lambda d: _joint(d, "right_knee")["servo"].update(model="MX-999"),
     "joints[3].servo.model", "unknown servo profile"),
    ("missing twin", lambda d: d["joints"].remove(_joint(d, "left_knee")), "joints", "no left twin"),
    ("home outside range", lambda d: _joint(d, "right_knee").update(home_deg=-5), "joints[3].home_deg",
     "outside range_deg"),
    ("bad axis", lambda d: _joint(d, "right_knee").update(axis="roll"), "joints[3].axis", "pitch joint"),
    ("unknown control-set joint", lambda d: d["control_sets"]["walk"].append("tail"),
     "control_sets.walk[7]", "unknown joint 'tail'"),
    ("non-numeric mass", lambda d: d["body"]["trunk"].update(mass="heavy"), "body.trunk.mass", "number"),
]


@pytest.mark.parametrize("what, mutate, key, problem", BAD_CONFIGS, ids=[b[0] for b in BAD_CONFIGS])
def test_bad_config_is_refused_naming_file_key_and_problem(what, mutate, key, problem):
    doc = copy.deepcopy(_doc())
    mutate(doc)
    with pytest.raises(ConfigError) as err:
        parse_robot(doc, "configs/robots/bad_robot.yaml")
    message = str(err.value)
    assert err.value.key == key, message
    assert message.startswith("configs/robots/bad_robot.yaml: " + key), message
    assert problem in message


def test_unknown_human_preset_lists_the_known_ones():
    with pytest.raises(ConfigError, match="unknown preset 'giant'.*male_50"):
        load_robot("human:giant")


def test_unknown_robot_name_lists_the_known_ones():
    with pytest.raises(FileNotFoundError, match="xl430_biped"):
        load_robot("no_such_robot")


def test_yaml_is_loaded_safely(tmp_path):
    path = tmp_path / "evil.yaml"
    path.write_text("name: !!python/object/apply:os.system ['true']\n")
    with pytest.raises(ConfigError, match="invalid YAML"):
        load_robot(path)


@pytest.mark.parametrize("path", sorted((ROOT / "configs" / "evolve").glob("*.yaml")), ids=lambda p: p.stem)
def test_every_shipped_evolution_config_loads(path):
    """Each config names a robot and a control set it has, with keys and values in range."""
    from evolve.config import load_evolve_config

    config = load_evolve_config(path)
    assert config.task.control_set in load_robot(config.robot).control_sets
