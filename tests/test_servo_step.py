"""Single-joint step responses of every servo profile: the servo model's speed and torque."""

import math

import mujoco
import numpy as np
import pytest

from sim2real.robot.profiles import available_profiles, load_profile
from sim2real.robot.servo_model import servo_physics
from sim2real.simulation.model_builder import (
    configure_servo_actuator,
    configure_servo_joint,
)

SERVOS = [m for m in available_profiles() if load_profile(m).is_servo]
LOAD_INERTIA = 2e-4  # a light link on the horn [kg m^2]


def step_response(model_name: str, step_rad: float = 2.0, seconds: float = 1.0):
    phys = servo_physics(load_profile(model_name))
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.option.gravity = [0, 0, 0]
    spec.option.timestep = 0.0005
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    body = spec.worldbody.add_body(name="horn")
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.01], mass=1e-3)
    body.inertia, body.mass, body.explicitinertial = [LOAD_INERTIA] * 3, 0.05, True
    configure_servo_joint(body.add_joint(name="servo", axis=[0, 0, 1]), phys)
    configure_servo_actuator(spec.add_actuator(name="servo", target="servo",
                                               trntype=mujoco.mjtTrn.mjTRN_JOINT), phys)
    model = spec.compile()
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
