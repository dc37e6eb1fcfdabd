"""What every robot model is given, box tree or model file alike: the same code, so that the
servo model and the sensors mean the same thing on every robot.

* :func:`add_scene`: the options (timestep, integrator), a checkered floor, the sky and the sun;
* :func:`configure_servo_joint` / :func:`configure_servo_actuator`: the servo model of
  :mod:`sim2real.robot.servo_model` (motor side on the joint: armature, friction, damping;
  firmware side on a position actuator: ``kp``, saturating at the stall torque);
* :func:`add_backlash_joint`: the gears' free play behind a joint (see
  :mod:`sim2real.simulation.model.builder`);
* :func:`add_touch_sensor`, :func:`add_sensors_and_actuators`: the parts
  :class:`~sim2real.simulation.model.robot_model.RobotModel` reads, named as it names them.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from sim2real.robot import Joint, RobotSpec
from sim2real.robot.servo_model import ServoPhysics, servo_physics
from sim2real.robot.timing import PHYSICS_DT_S
from sim2real.simulation.model.joint_loads import dot3
from sim2real.simulation.model.robot_model import (
    BACKLASH_SUFFIX,
    FLOOR_GEOM,
    FORWARD_SENSOR,
    GYRO_SENSOR,
    IMU_SITE,
    UP_SENSOR,
    joint_sensor,
    sole_site,
    touch_sensor,
)

FLOOR, LEFT, RIGHT, TORSO = 1, 2, 4, 8  # contype / conaffinity bits
COLLISION_BITS = {  # (contype, conaffinity)
    "floor": (FLOOR, LEFT | RIGHT | TORSO),
    "left": (LEFT, FLOOR | RIGHT),
    "right": (RIGHT, FLOOR | LEFT),
    "center": (TORSO, FLOOR),
}
COLORS = {"left": (0.85, 0.45, 0.2, 1), "right": (0.2, 0.5, 0.85, 1), "center": (0.75, 0.75, 0.78, 1)}  # parts by side
FLOOR_FRICTION = (1.0, 0.005, 0.0001)  # sliding, torsional, rolling (rubber-ish soles on a hard floor)
# A hard floor: contact time constant 10 ms (MuJoCo's default 20 ms lets a stiff PD-held human
# rock on its soles; >= 2 timesteps keeps it stable).
FLOOR_SOLREF = (0.01, 1.0)
SUSPENDED_HEIGHT_LEGS = 2.0  # a hung robot's pelvis, in leg lengths above the floor: feet well clear
OFFSCREEN_SIZE = (1280, 720)  # [px] the offscreen framebuffer: the largest picture `biped render` makes

# A width-0 draw closes the play to this [rad] (a limited joint needs low < high): its two
# limits then hold the joint at 0 as the nominal model's rigid gears do.
CLOSED_PLAY_RAD = 1e-6
# In the gap the link moves freely, so what the backlash joint adds must be small next to the
# smallest link a servo moves (xl430_biped: a foot about its ankle roll, 1.9e-4 kg m^2) and to
# a servo's own damping (0.04-0.8 N m s/rad); a little armature keeps the joint's row of the
# mass matrix away from 0 whatever it carries.  Open Duck's 0.01 kg m^2 would be 50 feet and
# set how a link crosses its gap.  Stable at the 2 ms implicitfast step: standing, knee
# steps, and 64 random controllers x 3 s with play up to 3 deg (docs/servo_model.md).
PLAY_ARMATURE = 1e-5  # [kg m^2]
PLAY_DAMPING = 1e-3  # [N m s/rad]
# Limits as stiff as MuJoCo lets them be at a 2 ms step (time constant 2 steps, critically
# damped) with an impedance near 1: the standing robot's closed knee yields 0.01 deg, as
# against 1.3 deg with MuJoCo's default solref and solimp, a compliance the gears do not have.
PLAY_SOLREF_STEPS = 2.0
PLAY_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)



def _look_at(forward: np.ndarray) -> list[float]:
    """Camera ``xyaxes`` looking along ``forward`` with the world's z up."""
    f = forward / math.sqrt(dot3(forward, forward))  # not np.linalg.norm: see dot3
    x = np.cross(f, [0.0, 0.0, 1.0])
    x /= math.sqrt(dot3(x, x))
    return [*x, *np.cross(x, f)]


def add_backlash_joint(body, servo_joint: str, axis, dt: float):
    """The gears' free play behind joint ``servo_joint``: add it to ``body`` right after that
    joint, with its ``axis``; closed (``jnt_range`` sets each simulation's width); ``dt`` is
    the physics timestep [s]."""
    return body.add_joint(
        name=servo_joint + BACKLASH_SUFFIX, type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(axis),
        range=[-CLOSED_PLAY_RAD / 2, CLOSED_PLAY_RAD / 2], limited=mujoco.mjtLimited.mjLIMITED_TRUE,
        armature=PLAY_ARMATURE, damping=[PLAY_DAMPING, 0.0, 0.0],
        solref_limit=[PLAY_SOLREF_STEPS * dt, 1.0], solimp_limit=list(PLAY_SOLIMP),
    )


def configure_servo_joint(jnt, phys: ServoPhysics) -> None:
    """The motor side of the servo model on a hinge joint spec."""
    jnt.armature, jnt.frictionloss = phys.armature, phys.frictionloss
    jnt.damping = [phys.damping, 0.0, 0.0]  # linear term of MuJoCo's damping polynomial


def configure_servo_actuator(act, phys: ServoPhysics) -> None:
    """The firmware side: a position loop saturating at the stall torque."""
    act.set_to_position(kp=phys.kp)
    act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.forcerange = [-phys.force_limit, phys.force_limit]


def add_actuator(spec: mujoco.MjSpec, joint: Joint) -> None:
    act = spec.add_actuator(name=joint.name, target=joint.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.ctrlrange = list(joint.range_rad)
    if joint.servo is not None:
        configure_servo_actuator(act, servo_physics(joint.servo.profile))
    else:
        act.set_to_position(kp=1.0, kv=0.0)  # scaled by the joint inertia in build_model


def physics_dt(robot: RobotSpec) -> float:
    """MuJoCo's timestep for the robot [s] (the control tick is a whole number of them)."""
    return robot.physics_dt_s or PHYSICS_DT_S


def add_scene(spec: mujoco.MjSpec, robot: RobotSpec, height: float) -> None:
    """The world every robot stands in: the options, a checkered floor, the sky and the sun;
    ``height`` [m] (the robot's) sizes the floor's checkers and the light."""
    spec.modelname = robot.name.replace(":", "_")
    spec.option.timestep = physics_dt(robot)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.visual.global_.offwidth, spec.visual.global_.offheight = OFFSCREEN_SIZE

    spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, width=256, height=256,
                     rgb1=[0.22, 0.25, 0.3], rgb2=[0.3, 0.33, 0.38])
    tile = 4 / max(height, 0.1)  # checker squares of about a quarter of the robot's height
    grid = spec.add_material(name="grid", texrepeat=[tile, tile], texuniform=True)
    grid.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"

    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, width=256, height=256,
                     rgb1=[0.55, 0.7, 0.85], rgb2=[0.1, 0.12, 0.16])
    world = spec.worldbody
    world.add_light(name="sun", pos=[0, 0, 3 * max(1.0, height)], dir=[0, 0, -1],
                    type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    contype, conaffinity = COLLISION_BITS["floor"]
    world.add_geom(name=FLOOR_GEOM, type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                   material="grid", friction=list(FLOOR_FRICTION), solref=list(FLOOR_SOLREF),
                   contype=contype, conaffinity=conaffinity)


def add_tracking_camera(body, height: float) -> None:
    """A camera following the robot's centre of mass from the front right, slightly above."""
    offset = 2.6 * height * np.array([0.45, -0.88, 0.12])
    body.add_camera(name="track", mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM, pos=offset.tolist(),
                    xyaxes=_look_at(-offset))


def add_touch_sensor(spec: mujoco.MjSpec, side: str) -> None:
    """The foot switch's ground truth: the normal force within the sole site [N]."""
    spec.add_sensor(name=touch_sensor(side), type=mujoco.mjtSensor.mjSENS_TOUCH,
                    objtype=mujoco.mjtObj.mjOBJ_SITE, objname=sole_site(side))


def add_sensors_and_actuators(spec: mujoco.MjSpec, robot: RobotSpec) -> None:
    """The IMU's sensors on the ``imu`` site, each joint's angle sensor and position actuator
    (robot order), the gyro: the parts :class:`~sim2real.simulation.model.robot_model.RobotModel`
    reads, after the body tree and the touch sensors."""
    # world up in the torso frame: what the sensor board's IMU reports
    spec.add_sensor(name=UP_SENSOR, type=mujoco.mjtSensor.mjSENS_FRAMEZAXIS,
                    objtype=mujoco.mjtObj.mjOBJ_BODY, objname="world",
                    reftype=mujoco.mjtObj.mjOBJ_SITE, refname=IMU_SITE)
    # the torso's forward axis in the world: its yaw is the heading the board's IMU reports
    spec.add_sensor(name=FORWARD_SENSOR, type=mujoco.mjtSensor.mjSENS_FRAMEXAXIS,
                    objtype=mujoco.mjtObj.mjOBJ_SITE, objname=IMU_SITE)
    for joint in robot.joints:
        spec.add_sensor(name=joint_sensor(joint.name), type=mujoco.mjtSensor.mjSENS_JOINTPOS,
                        objtype=mujoco.mjtObj.mjOBJ_JOINT, objname=joint.name)
        add_actuator(spec, joint)
    # the torso's angular rate about its own axes [rad/s]: what the sensor board's gyro reports
    # (last, so that the older sensors keep their addresses)
    spec.add_sensor(name=GYRO_SENSOR, type=mujoco.mjtSensor.mjSENS_GYRO, objtype=mujoco.mjtObj.mjOBJ_SITE,
                    objname=IMU_SITE)
