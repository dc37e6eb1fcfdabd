"""Robot config -> MuJoCo model, with the servo model of :mod:`sim2real.robot.servo_model`.

A robot from a model file is built by :mod:`sim2real.simulation.model.file_robot`; both builders
give their robots the same parts (:mod:`sim2real.simulation.model.parts`), named as
:mod:`sim2real.simulation.model.robot_model` reads them.  Here: the box tree, the home keyframe,
PD gains of the human characters (box tree or model file), and :func:`build_model` for every
robot.

The box tree is the one of :mod:`sim2real.robot`: the pelvis is the floating root, the trunk
sits on it through the waist joints, and each leg hangs from a hip joint at the pelvis'
bottom.  Joints at one location share a body (hip: yaw, roll, pitch; ankle: pitch,
roll), as a servo chain does.  Each joint gets a ``position`` actuator named after it.

Collision filtering: legs collide with the floor and with the other leg, the trunk and
pelvis only with the floor; links of one side never collide with each other (adjacent
links overlap at the joints, and a servo bracket cannot pass through itself anyway).

Sensors: ``<side>_foot_touch`` (normal force under each sole [N]), ``torso_up`` (world up
in the torso frame, x forward, y left, z up: what the sensor board's IMU reports),
``torso_forward`` (the torso's x axis in the world frame, whose yaw :func:`heading_rad` is the
board's heading), ``<joint>_pos`` (the servo joint's angle [rad], unquantized) and
``torso_gyro`` (the torso's angular rate about its x, y, z axes [rad/s], as the board's gyro).  The
keyframe ``home`` holds the standing pose in ``qpos`` and ``ctrl``.

Gear backlash, when asked for (``backlash=True``), is a passive hinge ``<joint>_backlash``
in series behind each joint: same body and axis, right after the servo joint (MuJoCo
composes a body's joints in order), free between its limits ``+-width/2`` and without an
actuator - Open Duck Mini v2's model (apirrone/Open_Duck_Playground@f82b5e7:playground/
open_duck_mini_v2/xmls/open_duck_mini_v2_backlash.xml).  The position actuator drives the
servo (motor-side) joint; the encoder sits on the output shaft, behind the gears, so the
angle the robot reports is servo joint + backlash joint.  :class:`JointAngles` is the one
reader of that angle from ``qpos``; the ``<joint>_pos`` sensors stay on the servo joint.
Each simulation's width goes into the backlash joints' ``jnt_range``
(:func:`sim2real.simulation.reality.randomize.apply`); the compiled model holds them closed.

    model = build_model(load_robot("xl430_biped"))
    angles = JointAngles.of(model).read(data.qpos)  # [rad], robot.joints order
    xml = to_mjcf(load_robot("human:male_95"))
"""

from __future__ import annotations

import itertools

import mujoco
import numpy as np

from sim2real.errors import BipedError
from sim2real.robot import Joint, RobotSpec
from sim2real.robot.anatomy import anatomical_axis
from sim2real.robot.servo_model import servo_physics
from sim2real.robot.spec import GRAVITY
from sim2real.simulation.model.joint_loads import axis_inertia, dot3
from sim2real.simulation.model.parts import (
    COLLISION_BITS,
    COLORS,
    SUSPENDED_HEIGHT_LEGS,
    add_backlash_joint,
    add_scene,
    add_sensors_and_actuators,
    add_touch_sensor,
    add_tracking_camera,
    configure_servo_joint,
    physics_dt,
)
from sim2real.simulation.model.file_robot import level_feet, lowest_sole_point, model_spec
from sim2real.simulation.model.robot_model import FEET, IMU_SITE, JointAngles, sole_site

JOINT_ORDER = {"waist": ("yaw", "roll", "pitch"), "hip": ("yaw", "roll", "pitch"),
               "knee": ("pitch",), "ankle": ("yaw", "pitch", "roll")}
SOLE_CLEARANCE_M = 0.0005  # the home keyframe starts the soles this far above the floor
def joint_axis(joint: Joint) -> tuple[float, float, float]:
    """A box robot's joint axis: its role's anatomical axis (:mod:`sim2real.robot.anatomy`)."""
    return anatomical_axis(joint.side, joint.location, joint.axis)


def _box_geom(body, name, size, pos, mass, side):
    contype, conaffinity = COLLISION_BITS[side]
    return body.add_geom(
        name=name, type=mujoco.mjtGeom.mjGEOM_BOX, size=[s / 2 for s in size], pos=pos,
        mass=mass, contype=contype, conaffinity=conaffinity, rgba=COLORS[side],
    )


def _add_joints(robot: RobotSpec, body, side: str, location: str, backlash: bool, dt: float) -> None:
    here = [j for j in robot.joints if j.side == side and j.location == location]
    for axis in JOINT_ORDER[location]:
        for joint in here:
            if joint.axis != axis:
                continue
            jnt = body.add_joint(
                name=joint.name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=joint_axis(joint),
                range=list(joint.range_rad), limited=mujoco.mjtLimited.mjLIMITED_TRUE,
            )
            if joint.servo is not None:
                configure_servo_joint(jnt, servo_physics(joint.servo.profile))
            if backlash:  # right behind its servo joint: the gears between motor and link
                add_backlash_joint(body, joint.name, joint_axis(joint), dt)


def build_spec(robot: RobotSpec, backlash: bool = False, suspended: bool = False) -> mujoco.MjSpec:
    """The robot as an editable :class:`mujoco.MjSpec` (gains of PD robots not yet scaled),
    with a backlash joint behind each joint if ``backlash``; ``suspended`` hangs it by the
    pelvis, fixed in the air with its feet off the floor (no root joint), as a robot is hung
    for system identification."""
    if robot.model is not None:  # a user's MJCF or URDF
        return model_spec(robot, backlash, suspended)
    b = robot.body
    spec = mujoco.MjSpec()
    spec.compiler.degree = False  # every angle here is in radians (MJCF's default is degrees)
    dt = physics_dt(robot)
    add_scene(spec, robot, b.height)
    world = spec.worldbody

    pelvis = world.add_body(name=robot.root_body, pos=[0, 0, (SUSPENDED_HEIGHT_LEGS if suspended else 1.0) * b.leg_length])
    if not suspended:
        pelvis.add_freejoint(name="root")
    _box_geom(pelvis, "pelvis", b.pelvis.size, [0, 0, b.pelvis.size[2] / 2], b.pelvis.mass, "center")
    add_tracking_camera(pelvis, b.height)

    trunk = pelvis.add_body(name="trunk", pos=[0, 0, b.pelvis.size[2]])
    _add_joints(robot, trunk, "center", "waist", backlash, dt)
    _box_geom(trunk, "trunk", b.trunk.size, [0, 0, b.trunk.size[2] / 2], b.trunk.mass, "center")
    trunk.add_site(name=IMU_SITE, pos=[0, 0, b.trunk.size[2] / 2])

    f = b.foot
    for side, y in (("left", 1.0), ("right", -1.0)):
        thigh = pelvis.add_body(name=f"{side}_thigh", pos=[0, y * b.hip_spacing / 2, 0])
        _add_joints(robot, thigh, side, "hip", backlash, dt)
        _box_geom(thigh, f"{side}_thigh", b.thigh.size, [0, 0, -b.thigh.size[2] / 2], b.thigh.mass, side)
        shank = thigh.add_body(name=f"{side}_shank", pos=[0, 0, -b.thigh.size[2]])
        _add_joints(robot, shank, side, "knee", backlash, dt)
        _box_geom(shank, f"{side}_shank", b.shank.size, [0, 0, -b.shank.size[2] / 2], b.shank.mass, side)
        foot = shank.add_body(name=f"{side}_foot", pos=[0, 0, -b.shank.size[2]])
        _add_joints(robot, foot, side, "ankle", backlash, dt)
        sole_center = [f.length / 2 - f.heel, 0, -f.ankle_height + f.thickness / 2]
        _box_geom(foot, f"{side}_foot", (f.length, f.width, f.thickness), sole_center, f.mass, side)
        # The touch site covers the sole and a sliver below it, where contact points lie.
        foot.add_site(name=sole_site(side), type=mujoco.mjtGeom.mjGEOM_BOX, pos=sole_center,
                      size=[f.length / 2 + 1e-3, f.width / 2 + 1e-3, f.thickness], group=3)
        add_touch_sensor(spec, side)
    add_sensors_and_actuators(spec, robot)
    return spec


# MuJoCo's warnings of a simulation gone numerically unstable.  On a bad acceleration it resets
# the state to the model's qpos0 and carries on from there (time 0, the robot upright at the
# origin), so whatever is measured afterwards - distance, falls - is no result.
UNSTABLE_WARNINGS = {mujoco.mjtWarning.mjWARN_BADQACC: "NaN, Inf or huge value in the accelerations",
                     mujoco.mjtWarning.mjWARN_BADQVEL: "NaN, Inf or huge value in the velocities",
                     mujoco.mjtWarning.mjWARN_BADQPOS: "NaN, Inf or huge value in the positions"}


def instability(data: mujoco.MjData) -> str | None:
    """Why the simulation in ``data`` went numerically unstable (MuJoCo's warning since its
    last reset, or a position that is not finite), or None if it did not."""
    for warning, what in UNSTABLE_WARNINGS.items():
        if data.warning[warning].number > 0:
            return f"numerically unstable: {what} (MuJoCo reset the simulation)"
    if not np.all(np.isfinite(data.qpos)):
        return "numerically unstable: NaN or Inf in the positions"
    return None


class SimulationUnstable(BipedError):
    """A simulation went numerically unstable: what it measured is no result.  The message
    says where; the cause is almost always a value of the robot or reality far off (each
    is bounded to a plausible range, but combinations can still blow up)."""


def _home_keyframe(robot: RobotSpec, spec: mujoco.MjSpec, model: mujoco.MjModel) -> None:
    """Add keyframe ``home``: joints at home, root lowered until the soles touch the floor."""
    data = mujoco.MjData(model)
    home = home_ctrl(robot, model)
    JointAngles.of(model).place(data.qpos, home)
    mujoco.mj_kinematics(model, data)
    if robot.model is not None:
        if model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE:
            level_feet(model, data, robot)
        lowest = lowest_sole_point(model, data, robot)
    else:
        lowest = _lowest_box_sole_point(model, data)
    qpos = data.qpos.copy()
    if model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE:  # standing: lowered onto the floor; hung: as it is
        qpos[2] -= lowest - SOLE_CLEARANCE_M
    spec.add_key(name="home", qpos=qpos.tolist(), ctrl=home.tolist())


def _lowest_box_sole_point(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """The lowest corner of a box robot's feet in the world [m]."""
    lowest = np.inf
    for side in FEET:
        geom = model.geom(f"{side}_foot").id
        up_row = data.geom_xmat[geom].reshape(3, 3)[2]  # world z of the foot's local axes
        centre_z = float(data.geom_xpos[geom][2])
        for corner in itertools.product((-1, 1), repeat=3):
            lowest = min(lowest, centre_z + dot3(np.array(corner) * model.geom_size[geom], up_row))
    return lowest


def home_ctrl(robot: RobotSpec, model: mujoco.MjModel) -> np.ndarray:
    """Actuator targets of the home pose, in actuator order (= robot.joints order) [rad]."""
    return np.array([robot.joints[i].home_rad for i in range(model.nu)])


def finished_spec(robot: RobotSpec, actuator_history_s: float = 0.0, backlash: bool = False,
                  suspended: bool = False) -> mujoco.MjSpec:
    """:func:`build_spec` with PD gains scaled by joint inertia and the ``home`` keyframe.

    ``actuator_history_s`` > 0 keeps that much control history per actuator, so that
    ``actuator_delay`` can model a control latency of up to as long; ``backlash`` adds the
    backlash joints (closed: each simulation's width is set through ``jnt_range``);
    ``suspended`` hangs the robot (:func:`build_spec`).
    """
    spec = build_spec(robot, backlash, suspended)
    model = spec.compile()
    if robot.pd is not None:
        _scale_pd_gains(robot, spec, model)
    _home_keyframe(robot, spec, model)
    if actuator_history_s > 0:
        samples = int(np.ceil(actuator_history_s / spec.option.timestep)) + 2
        for joint in robot.joints:
            act = spec.actuator(joint.name)
            act.nsample, act.interp = samples, 0  # zero-order hold, as the servo holds its goal
    return spec


def build_model(robot: RobotSpec, actuator_history_s: float = 0.0, backlash: bool = False,
                suspended: bool = False) -> mujoco.MjModel:
    """The robot's compiled MuJoCo model (see :func:`finished_spec`)."""
    return finished_spec(robot, actuator_history_s, backlash, suspended).compile()


def to_mjcf(robot: RobotSpec) -> str:
    """Self-contained MJCF text of the robot (no external assets)."""
    spec = finished_spec(robot)
    spec.compile()
    return spec.to_xml()


def _scale_pd_gains(robot: RobotSpec, spec: mujoco.MjSpec, model: mujoco.MjModel) -> None:
    """Seed 000 eq. 2: torque = I (kp e - kd qdot) with I "the total moment of inertia at the
    joint".  We take I as the inertia, at home, of what the joint moves when its foot is on
    the ground (the whole body above an ankle; the trunk for a waist joint), since a stance
    leg's joints carry the body; a joint scaled by its distal inertia alone could not stand.
    Box tree and model file alike (:func:`~sim2real.simulation.model.joint_loads.carried_bodies`:
    an arm's or a neck's joint moves what lies beyond it).  With ``pd_gains.stiffness_mgl`` every
    joint has that stiffness in units of the body's m g L a radian instead (as a servo's is one
    number for every joint), at eq. 2's damping ratio on its own inertia.
    """
    assert robot.pd is not None
    pd = robot.pd
    uniform = None if pd.stiffness_mgl is None else pd.stiffness_mgl * robot.mass * GRAVITY * robot.leg_length  # [N m/rad]
    cap = robot.pd_torque_cap_nm  # [N m]; a model robot's per-kg cap on its measured mass
    no_load = robot.pd_no_load_speed_rad_s  # [rad/s]; inf: no speed limit
    data = mujoco.MjData(model)
    JointAngles.of(model, robot.joint_names).place(data.qpos, np.array([j.home_rad for j in robot.joints]))
    mujoco.mj_kinematics(model, data)
    for joint in robot.joints:
        inertia = axis_inertia(model, data, joint)
        act = spec.actuator(joint.name)
        if uniform is None:
            act.set_to_position(kp=inertia * pd.kp, kv=inertia * pd.kd)
        else:  # damping ratio kd / (2 sqrt(kp)) on stiffness `uniform` and this inertia
            act.set_to_position(kp=uniform, kv=pd.kd * np.sqrt(uniform * inertia / pd.kp))
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-cap, cap]
        if np.isfinite(no_load):  # a servo's torque-speed line: the cap at rest, nothing left at no-load speed
            spec.joint(joint.name).damping += cap / no_load
