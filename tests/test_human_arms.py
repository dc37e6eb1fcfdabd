"""Seed 002's human with arms (configs/robots/human_arms.yaml over the project's own MJCF
configs/robots/human_arms/human_arms.xml): table A.1's body (16 parts, 75.16 kg) with table A.2's
mass shares, 27 PD-driven hinges that pair left with right, standing on its soles at home with
its hands at its sides; and a PD robot from a model file refused by key when its config is bad."""

import copy

import mujoco
import numpy as np
import pytest
import yaml

from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome
from sim2real.errors import ConfigError
from sim2real.robot import load_robot, parse_robot
from sim2real.simulation.model.physique import load_measured
from sim2real.robot.paths import robots_dir
from sim2real.simulation.model.builder import build_model
from sim2real.simulation.model.importing.mirror import mirror_pairs
from sim2real.simulation.model.robot_model import RobotModel

TABLE_A1_MASS_KG = 75.16
# Table A.2: each body part's share of the mass; (s) parts once per side
TABLE_A2_SHARE = {"pelvis": 0.156, "thorax": 0.357, "femur": 0.124, "tibia": 0.049, "talus": 0.018,
                  "toes": 0.003, "humerus": 0.027, "forearm": 0.016, "hand": 0.006}
SOURCE = str(robots_dir() / "human_arms.yaml")


@pytest.fixture(scope="module")
def human():
    robot = load_measured("human_arms")
    return robot, build_model(robot)


def _doc() -> dict:
    return yaml.safe_load((robots_dir() / "human_arms.yaml").read_text())


def test_it_loads_as_a_pd_robot_from_its_model_file(human):
    robot, model = human
    assert robot.model is not None and robot.body is None and robot.pd is not None
    assert robot.bus is None and robot.sensor_board is None and all(j.servo is None for j in robot.joints)
    assert set(robot.control_sets) >= {"stand", "reach", "all"}
    assert set(robot.control_sets["all"]) == set(robot.joint_names)
    # the cap per kg waits for the measured mass: 2.661 N m/kg x 75.16 kg = seed 002's 200 N m
    assert robot.pd.max_torque_nm is None
    assert robot.pd_torque_cap_nm == pytest.approx(2.661 * robot.mass) == pytest.approx(200.0, abs=0.01)
    assert model.actuator_forcerange == pytest.approx(np.tile([-robot.pd_torque_cap_nm, robot.pd_torque_cap_nm],
                                                              (model.nu, 1)))


def test_sixteen_bodies_carry_table_a1s_mass_in_table_a2s_shares(human):
    robot, model = human
    massive = {model.body(b).name: float(model.body_mass[b]) for b in range(1, model.nbody) if model.body_mass[b] > 0}
    assert len(massive) == 16
    total = sum(massive.values())
    assert total == pytest.approx(TABLE_A1_MASS_KG, rel=0.005) and robot.mass == pytest.approx(total)
    for name, mass in massive.items():
        part = name.split("_", 1)[-1]
        # the table's rounded shares sum to 99.9 %, so each is a thousandth above its share
        assert mass / total == pytest.approx(TABLE_A2_SHARE[part] / 0.999, rel=1e-3), name


def test_twenty_seven_driven_hinges(human):
    robot, model = human
    assert len(robot.joints) == 27 and model.nu == 27
    driven = {int(model.actuator_trnid[a, 0]) for a in range(model.nu)}
    assert all(model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE for j in driven) and len(driven) == 27
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    assert len(hinges) == 27 and model.nq == 7 + 27  # the free root and the hinges, nothing else
    # 15 joints (seed 002 table A.1): the lumbar joint and seven per side, each one body's hinges
    assert len({int(model.jnt_bodyid[j]) for j in hinges}) == 15


def test_mirror_inference_pairs_every_left_joint_with_its_right_one(human):
    robot, model = human
    inferred = mirror_pairs(model)
    left = sorted(j.name for j in robot.joints if j.side == "left")
    assert sorted(p.left for p in inferred.pairs) == left and len(left) == 12
    assert all(p.right == p.left.replace("left_", "right_", 1) and p.sign == 1 for p in inferred.pairs)
    assert set(inferred.centre) == {"lumbar_yaw", "lumbar_roll", "lumbar_pitch"}
    assert not inferred.unpaired and not inferred.conflicts
    # the config's sides are the geometry's
    assert all(inferred.sides[j.name] == j.side for j in robot.joints)


def test_it_stands_three_seconds_at_home_under_pd(human):
    robot, model = human
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    parts = RobotModel.of(model, robot)
    start = parts.root_com(data.xipos)[2]
    lowest_up = 1.0
    for _ in range(int(round(3.0 / model.opt.timestep))):
        mujoco.mj_step(model, data)  # ctrl stays the keyframe's: PD holding home
        lowest_up = min(lowest_up, float(parts.up(data.sensordata)[2]))
    assert lowest_up > 0.98
    assert start - parts.root_com(data.xipos)[2] < 0.01  # sag [m]: no fall, no crouch
    assert data.sensordata[parts.touch].sum() == pytest.approx(robot.mass * 9.81, rel=0.05)  # on its soles
    assert np.abs(data.qvel).max() < 0.01  # and still


def test_the_right_hand_hangs_at_the_side_of_the_thorax_at_home(human):
    robot, model = human
    assert robot.model.hands == {"left": "left_hand", "right": "right_hand"}
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_kinematics(model, data)
    hand, thorax = data.xipos[model.body("right_hand").id], data.xipos[model.body("thorax").id]
    half_width = float(model.geom_size[model.geom("trunk").id][1])
    assert hand[1] - thorax[1] < -half_width - 0.03  # right of the trunk, clear of it
    assert abs(hand[0] - thorax[0]) < 0.05  # neither in front nor behind
    shoulder = data.xanchor[model.joint("right_shoulder_pitch").id]
    assert hand[2] < shoulder[2] - 0.5  # hanging: the arm's length below the shoulder
    assert data.xipos[model.body("left_hand").id] == pytest.approx(hand * [1, -1, 1], abs=1e-9)


def test_evolution_evaluates_it_with_the_stand_set(human):
    robot, _ = human
    task = TaskConfig(control_set="stand", episode_s=0.5)
    ev = LocomotionEvaluator(robot, task, 2, threads=1)
    episodes = ev.evaluate([Genome(i, ev.neat_layout) for i in range(2)], 1.0, harness=0.0)
    assert np.isfinite(episodes.fitness).all() and not episodes.unstable.any()


BAD = [
    ("a preset", lambda d: None, "human_arms:male_50", "name", "no presets"),
    ("anthropometry", lambda d: d.update(anthropometry={"default_preset": "x"}), None, "anthropometry",
     "the model file is the body"),
    ("a box tree too", lambda d: d.update(body={}), None, "body", "the model file is the body"),
    ("no gains", lambda d: d.pop("pd_gains"), None, "pd_gains", "missing required key 'pd_gains'"),
    ("two caps", lambda d: d["pd_gains"].update(max_torque_nm=200.0), None, "pd_gains", "exactly one of"),
    ("a servo", lambda d: d["joints"][0].update(servo={"id": 1}), None, "joints[0].servo",
     "only allowed with actuation: servo"),
]


@pytest.mark.parametrize("what, mutate, preset, key, problem", BAD, ids=[b[0] for b in BAD])
def test_a_bad_pd_model_config_is_refused_naming_file_and_key(what, mutate, preset, key, problem):
    doc = copy.deepcopy(_doc())
    mutate(doc)
    with pytest.raises(ConfigError) as err:
        parse_robot(doc, SOURCE, preset.split(":")[1] if preset else None)
    assert err.value.key == key and str(err.value).startswith(f"{SOURCE}: {key}") and problem in str(err.value)


def test_a_box_robot_has_no_toes():
    doc = yaml.safe_load((robots_dir() / "xl430_biped.yaml").read_text())
    for side, dxl_id in (("right", 98), ("left", 99)):
        doc["joints"].append({"name": f"{side}_toe", "side": side, "location": "toe", "axis": "pitch",
                              "range_deg": [0, 10], "servo": {"id": dxl_id}})
    problem = r"joints\[11\]\.location: the box tree has joints at the waist, hip, knee, ankle only; 'right_toe'"
    with pytest.raises(ConfigError, match=problem):
        parse_robot(doc, "box.yaml")
