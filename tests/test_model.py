"""The MuJoCo model: every robot compiles, stands on its servos, and exports as MJCF."""

import os
import platform
import subprocess
import sys

import mujoco
import numpy as np
import pytest
from conftest import all_robot_names

from sim2real.controller.mapping import hold_pose
from sim2real.simulation.model.physique import load_measured
from sim2real.simulation.model.builder import build_model, to_mjcf
from sim2real.simulation.model.parts import CLOSED_PLAY_RAD
from sim2real.simulation.model.robot_model import BACKLASH_SUFFIX, JointAngles
from sim2real.simulation.standing.statics import holding_torques


@pytest.fixture(scope="module", params=all_robot_names())
def robot_and_model(request):
    robot = load_measured(request.param)
    return robot, build_model(robot)


def test_one_position_actuator_per_joint_named_after_it(robot_and_model):
    robot, model = robot_and_model
    assert model.nu == len(robot.joints)
    for i, joint in enumerate(robot.joints):
        assert model.actuator(i).name == joint.name
        assert model.actuator_biastype[i] == mujoco.mjtBias.mjBIAS_AFFINE  # position servo
        jid = model.joint(joint.name).id
        assert model.jnt_range[jid] == pytest.approx(joint.range_rad)
        if joint.servo is not None:
            stall = joint.servo.profile.motor.stall_torque_nm
            assert model.actuator_forcerange[i] == pytest.approx([-stall, stall])
            assert model.dof_armature[model.jnt_dofadr[jid]] > 0
            assert model.dof_damping[model.jnt_dofadr[jid]] > 0


def test_robot_held_at_home_by_its_servos_stands_for_5_s(robot_and_model):
    robot, model = robot_and_model
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    start_height = data.qpos[2]
    weight = robot.mass * 9.81
    for _ in range(int(5.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
        assert data.qpos[2] > 0.9 * start_height, f"fell at t={data.time:.2f} s"
    assert data.sensor("torso_up").data[2] > 0.99  # still upright
    feet = data.sensor("left_foot_touch").data[0] + data.sensor("right_foot_touch").data[0]
    assert feet == pytest.approx(weight, rel=0.05)  # both soles carry the robot
    assert np.abs(data.qvel).max() < 0.1  # and it is at rest (a hundredth of a servo's speed)


def test_only_the_feet_touch_the_floor_at_home(robot_and_model):
    robot, model = robot_and_model
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    for _ in range(50):
        mujoco.mj_step(model, data)
    feet = ({model.body(f.body).id for f in robot.model.feet.values()} if robot.model is not None
            else {model.body(f"{side}_foot").id for side in ("left", "right")})
    touching = {frozenset((int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2]))) for c in data.contact}
    assert touching <= {frozenset((0, foot)) for foot in feet}  # the world's floor and a foot, nothing else
    assert touching, "the feet should be on the floor"


def test_adjacent_links_never_collide_but_the_legs_do():
    model = build_model(load_measured())
    geom = {model.geom(i).name: i for i in range(model.ngeom)}

    def collide(a, b):
        g1, g2 = geom[a], geom[b]
        return bool(model.geom_contype[g1] & model.geom_conaffinity[g2]
                    or model.geom_contype[g2] & model.geom_conaffinity[g1])

    assert not collide("pelvis", "left_thigh") and not collide("left_thigh", "left_shank")
    assert not collide("trunk", "pelvis") and not collide("left_shank", "left_foot")
    assert collide("left_foot", "right_foot") and collide("left_shank", "right_shank")
    assert collide("floor", "left_foot") and collide("floor", "trunk")


def test_undriven_joints_hold_the_centre_of_their_range():
    robot = load_measured()
    ctrl = hold_pose(robot, robot.control_sets["walk"])
    for target, joint in zip(ctrl, robot.joints):
        expected = joint.home_rad if joint.name in robot.control_sets["walk"] else joint.center_rad
        assert target == pytest.approx(expected)


@pytest.mark.parametrize("name", ["xl430_biped", "human:male_50"])
def test_mjcf_export_is_self_contained_and_reloads(name, tmp_path):
    robot = load_measured(name)
    xml = to_mjcf(robot)
    assert "file=" not in xml  # no external assets
    path = tmp_path / "robot.xml"
    path.write_text(xml)
    model = mujoco.MjModel.from_xml_path(str(path))
    original = build_model(robot)
    assert model.nu == original.nu and model.nbody == original.nbody
    home = model.key("home")
    assert home.qpos == pytest.approx(original.key("home").qpos, abs=1e-6)
    assert home.ctrl == pytest.approx([j.home_rad for j in robot.joints], abs=1e-6)
    assert model.actuator_gainprm[:, 0] == pytest.approx(original.actuator_gainprm[:, 0], rel=1e-5)


def test_holding_torque_of_a_stance_hip_roll_is_body_weight_times_half_hip_spacing():
    robot = load_measured()
    model = build_model(robot)
    torques = {t.joint: t for t in holding_torques(robot, model)}
    expected = robot.mass * 9.81 * robot.body.hip_spacing / 2  # roll axis at the hip
    assert torques["right_hip_roll"].torque_nm == pytest.approx(expected, rel=1e-6)
    assert torques["waist_yaw"].margin is None  # a yaw axis carries no gravity load
    assert all(t.margin is None or t.margin > 1.5 for t in torques.values())


def test_torso_up_reads_world_up_in_the_torso_frame_as_an_imu_does():
    model = build_model(load_measured())
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    tilt = 0.3
    data.qpos[3:7] = [np.cos(tilt / 2), 0, np.sin(tilt / 2), 0]  # pitched forward about +y
    mujoco.mj_forward(model, data)
    up = data.sensor("torso_up").data
    assert up == pytest.approx([-np.sin(tilt), 0, np.cos(tilt)], abs=1e-9)


def test_backlash_joints_only_when_asked_each_right_behind_its_joint():
    robot = load_measured()
    nominal, geared = build_model(robot), build_model(robot, backlash=True)
    assert nominal.nq == 7 + len(robot.joints)  # the free root and one hinge per joint
    assert not any(nominal.joint(i).name.endswith(BACKLASH_SUFFIX) for i in range(nominal.njnt))
    assert not JointAngles.of(nominal).has_play
    assert geared.nq == nominal.nq + len(robot.joints) and geared.nu == nominal.nu
    angles = JointAngles.of(geared)
    for joint, servo, play in zip(robot.joints, angles.servo_joint, angles.play_joint):
        assert geared.joint(play).name == joint.name + BACKLASH_SUFFIX
        assert play == servo + 1 and geared.jnt_bodyid[play] == geared.jnt_bodyid[servo]  # in series
        assert geared.jnt_axis[play] == pytest.approx(geared.jnt_axis[servo])
        assert geared.jnt_range[play] == pytest.approx([-CLOSED_PLAY_RAD / 2, CLOSED_PLAY_RAD / 2])
    assert set(geared.actuator_trnid[:, 0]) == set(angles.servo_joint)  # the motors drive the servo joints


def test_closed_backlash_joints_stand_as_the_rigid_model():
    robot = load_measured()
    held = []
    for backlash in (False, True):
        model = build_model(robot, backlash=backlash)
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
        for _ in range(int(2.0 / model.opt.timestep)):
            mujoco.mj_step(model, data)
        held.append((data.qpos[2], JointAngles.of(model).read(data.qpos)))
    (rigid_z, rigid_q), (closed_z, closed_q) = held
    assert closed_z == pytest.approx(rigid_z, abs=2e-4)  # pelvis height [m]
    assert np.degrees(closed_q) == pytest.approx(np.degrees(rigid_q), abs=0.05)  # joints [deg]


_MODEL_BYTES = """
import hashlib, sys, mujoco, numpy as np
from sim2real.simulation.model.physique import load_measured
from sim2real.simulation.model.builder import build_model
for name in sys.argv[1:]:
    model = build_model(load_measured(name))
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    print(name, hashlib.sha256(buffer.tobytes()).hexdigest())
"""


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="OpenBLAS's x86 kernel names")
def test_a_model_is_the_same_to_the_bit_whatever_blas_kernel_the_cpu_gets():
    """OpenBLAS picks its kernel for the CPU at load time (``OPENBLAS_CORETYPE`` overrides it;
    an unsupported one falls back), and the kernels round differently: gains computed with
    ``np.dot`` were an ulp apart under the SkylakeX and Haswell kernels, enough for a
    knife-edge human walker to fall with one.  These two presets differed under the old code."""
    names = ["human_stepping:male_50", "human:male_50"]
    hashes = set()
    for core in ("Prescott", "Haswell", "SkylakeX"):
        env = {**os.environ, "OPENBLAS_CORETYPE": core}
        done = subprocess.run([sys.executable, "-c", _MODEL_BYTES, *names], capture_output=True, text=True,
                              env=env, check=True, timeout=300)
        hashes.add(done.stdout)
    assert len(hashes) == 1
