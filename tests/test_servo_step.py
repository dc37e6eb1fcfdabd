"""One servo and its load: step responses of every servo profile (the servo model's speed and
torque) and the gears' free play seen from the goal."""

import math

import mujoco
import numpy as np
import pytest

from sim2real.robot.profiles import available_profiles, load_profile
from sim2real.robot.servo_model import servo_physics
from sim2real.simulation.model.parts import add_backlash_joint, CLOSED_PLAY_RAD, configure_servo_actuator, configure_servo_joint
from sim2real.simulation.model.robot_model import JointAngles

SERVOS = [m for m in available_profiles() if load_profile(m).is_servo]
LOAD_INERTIA = 2e-4  # a light link on the horn [kg m^2]


def rig(model_name: str, timestep: float = 0.0005, load_inertia: float = LOAD_INERTIA,
        backlash_rad: float | None = None, load_friction: float = 0.0) -> tuple[mujoco.MjModel, JointAngles]:
    """One servo turning a load about a vertical axis (no gravity): the servo model's joint and
    actuator, a backlash joint of width ``backlash_rad`` behind it if given, and a bearing of
    Coulomb friction ``load_friction`` [N m] on the output shaft (a tendon over both joints)."""
    phys = servo_physics(load_profile(model_name))
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.option.gravity = [0, 0, 0]
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    body = spec.worldbody.add_body(name="horn")
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.01], mass=1e-3)
    body.inertia, body.mass, body.explicitinertial = [load_inertia] * 3, 0.05, True
    configure_servo_joint(body.add_joint(name="servo", axis=[0, 0, 1]), phys)
    if backlash_rad is not None:
        add_backlash_joint(body, "servo", (0, 0, 1), timestep)
    if load_friction:
        bearing = spec.add_tendon(name="output", frictionloss=load_friction)
        for joint in spec.joints:
            bearing.wrap_joint(joint.name, 1.0)
    configure_servo_actuator(spec.add_actuator(name="servo", target="servo",
                                               trntype=mujoco.mjtTrn.mjTRN_JOINT), phys)
    model = spec.compile()
    angles = JointAngles.of(model)
    if backlash_rad is not None:
        model.jnt_range[angles.play_joint] = np.array([-1, 1]) * max(backlash_rad, CLOSED_PLAY_RAD) / 2
    return model, angles


def step_response(model_name: str, step_rad: float = 2.0, seconds: float = 1.0):
    phys = servo_physics(load_profile(model_name))
    model, _ = rig(model_name)
    data = mujoco.MjData(model)
    data.ctrl[0] = step_rad
    speeds, torques = [], []
    for _ in range(int(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)
        speeds.append(data.qvel[0])
        torques.append(data.actuator_force[0])
    return phys, np.array(speeds), np.array(torques), data.qpos[0]


@pytest.mark.parametrize("model_name", SERVOS)
def test_step_reaches_no_load_speed_within_10_percent(model_name):
    phys, speeds, _, final = step_response(model_name)
    assert np.max(np.abs(speeds)) == pytest.approx(phys.no_load_speed, rel=0.10)
    assert final == pytest.approx(2.0, abs=math.radians(1.0))  # and settles on the goal


@pytest.mark.parametrize("model_name", SERVOS)
def test_step_never_exceeds_stall_torque(model_name):
    phys, _, torques, _ = step_response(model_name)
    assert np.max(np.abs(torques)) <= phys.force_limit + 1e-9
    assert np.max(np.abs(torques)) == pytest.approx(phys.force_limit)  # a large step saturates


def test_small_step_is_proportional_below_saturation():
    phys, _, torques, _ = step_response("XL430-W250-T", step_rad=0.05, seconds=0.01)
    assert torques[0] == pytest.approx(phys.kp * 0.05, rel=0.02)


def hysteresis_deg(backlash_rad: float | None, amplitude: float = math.radians(20), period: float = 8.0) -> float:
    """Lost motion from goal to output [deg]: the goal sweeps slowly back and forth (a
    triangle) against a bearing's friction, and at each goal of the middle half of the sweep
    the encoder's angle on the way down minus on the way up, averaged (second cycle)."""
    model, angles = rig("XL430-W250-T", timestep=0.002, load_inertia=2e-3, backlash_rad=backlash_rad,
                        load_friction=0.05)
    data = mujoco.MjData(model)
    n = int(period / model.opt.timestep)
    goal, out = np.empty(2 * n), np.empty(2 * n)
    for k in range(2 * n):
        phase = (k / n) % 1.0
        goal[k] = amplitude * (4 * phase - 1 if phase < 0.5 else 3 - 4 * phase)
        data.ctrl[0] = goal[k]
        mujoco.mj_step(model, data)
        out[k] = angles.read(data.qpos)[0]
    goal, out = goal[n:], out[n:]
    grid = np.linspace(-amplitude / 2, amplitude / 2, 21)
    up, down = slice(0, n // 2), slice(n // 2, n)  # the second cycle rises, then falls
    rising = np.interp(grid, goal[up], out[up])
    falling = np.interp(grid, goal[down][::-1], out[down][::-1])
    return math.degrees(float(np.mean(falling - rising)))


@pytest.mark.parametrize("width_deg", [0.3, 1.0])
def test_free_play_seen_from_the_goal_is_the_backlash_width(width_deg):
    # Without backlash the lost motion is the position loop's friction band (2 f / kp) and
    # damping; the backlash joint adds its width to it, no more and no less.
    closed = hysteresis_deg(0.0)
    assert closed > 1.0  # the friction band alone: the sweep does load the loop
    assert hysteresis_deg(math.radians(width_deg)) - closed == pytest.approx(width_deg, abs=0.01)


def test_closed_gears_behave_as_the_rigid_model():
    assert hysteresis_deg(0.0) == pytest.approx(hysteresis_deg(None), abs=0.01)
