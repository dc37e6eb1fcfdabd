"""A robot from a user's MJCF or URDF: its model file made into a project model.

The robot config's ``model:`` block names the file and where its parts are; its ``joints:``
map the model's hinges onto roles and servos.  :func:`model_spec` loads the file
(:func:`~sim2real.simulation.model.files.load_model_spec`), drops what the project supplies
itself (the file's actuators, sensors, keyframes; its visual-only geoms unless asked to keep
them), floats the root body, and then gives it exactly what a box robot has, with the same
code (:mod:`sim2real.simulation.model.parts`): the scene, the servo physics on every mapped
joint (``kp``, force range, damping, friction, armature; backlash joints when asked), a
position actuator each, the IMU site and sensors, the sole sites and touch sensors.  A PD
robot's joints keep the file's dynamics and get their gains as a box robot's PD character
does (:func:`~sim2real.simulation.model.builder.finished_spec`).

* A mapped joint whose ``sign`` is -1 has its axis turned over, so that the model's angle *is*
  the anatomical angle everything else reads; its range is the config's.
* A joint the map does not name (a gripper, a spare hinge) is removed: its child body is held
  fixed to its parent at the model's zero pose.
* The sole site of a foot is a box over the bottom of the foot's collision geoms (bounding box
  in the foot's frame) reaching a little below them, where contact points lie; the bottom is
  along the foot frame's axis nearest world down at the zero pose (a URDF link's frame may
  have its z forward, as Darwin-OP's ankle links do).
* Links that touch at the model's zero pose (CAD meshes overlapping at a joint) never collide.
* A model drawn facing another way than +x (``model.forward``) has its root turned about z to
  face +x, and the IMU site turned back by as much on its body, so that the IMU's x is still
  forward (its axes are the body's, as drawn, turned to the robot's facing).

:func:`measure_physique` gives mass, height and leg length from the compiled model at its
zero pose (:func:`sim2real.simulation.model.physique.measured` hands them to the robot's spec);
the control tick and the holding-torque margins follow from them as for a box robot.  Every
other function here takes a robot so measured.
"""

from __future__ import annotations

import itertools
import math

import mujoco
import numpy as np

from sim2real.errors import ConfigError
from sim2real.robot import RobotSpec
from sim2real.robot.anatomy import facing_turn_deg
from sim2real.robot.servo_model import servo_physics
from sim2real.robot.spec import Physique
from sim2real.simulation.model.parts import (
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
from sim2real.simulation.model.files import add_free_joint, compile_model, load_model_spec
from sim2real.simulation.model.inertias import recompute_inertias
from sim2real.simulation.model.body_roles import check_roles
from sim2real.simulation.model.robot_model import FEET, IMU_SITE, is_collision_geom, sole_site

DEFAULT_RGBA = (0.5, 0.5, 0.5, 1.0)  # MuJoCo's colour of a geom that sets none
SOLE_MARGIN_M = 1e-3  # the sole site reaches this far beyond the foot's geoms sideways
SOLE_BELOW_M = 3e-3  # and this far below them, where contact points lie
# ... and up to this far above their lowest point (or this share of their height): a touch
# sensor sums every contact of the foot's body inside its site, and one with the shank at the
# ankle is no foot switch closing
SOLE_SLAB_M = 5e-3
SOLE_SLAB_SHARE = 0.2


def model_spec(robot: RobotSpec, backlash: bool = False, suspended: bool = False,
               for_measure: bool = False) -> mujoco.MjSpec:
    """The robot's spec, as :func:`~sim2real.simulation.model.builder.build_spec` gives a box
    robot's; ``for_measure``: before its physique is known (placed as the file places it, for
    :func:`measure_physique`)."""
    source = robot.model
    assert source is not None
    where = robot.source
    spec = load_model_spec(source.path, source.package_dirs, drop_visuals=source.drop_visuals)
    for element in (*spec.actuators, *spec.sensors, *spec.keys):
        spec.delete(element)
    root = spec.body(source.root)
    if root is None:
        raise ConfigError(where, "model.root", f"no body {source.root!r} in {source.path.name} (bodies: "
                          f"{', '.join(b.name for b in spec.bodies if b.name and b.name != 'world')})")
    _check_bodies(spec, robot)
    check_roles(spec, robot)
    turn = facing_turn_deg(source.forward)
    if turn:
        _turn_about_z(spec, root, turn)
    degree = bool(spec.compiler.degree)  # the file's angle unit: joint ranges are written in it
    frees = [j for j in root.joints if j.type == mujoco.mjtJoint.mjJNT_FREE]
    if suspended:
        for joint in frees:
            spec.delete(joint)
        spec.compiler.fusestatic = False  # else a compile fuses the jointless root into the world
    elif not frees:
        add_free_joint(spec, source.root)
    mapped = {j.name: j for j in robot.joints}
    for joint in list(spec.joints):
        if joint.type == mujoco.mjtJoint.mjJNT_FREE:
            continue
        if joint.name not in mapped:
            spec.delete(joint)  # held: its body fixed to its parent at the model's zero pose
            continue
        if joint.type != mujoco.mjtJoint.mjJNT_HINGE:
            raise ConfigError(where, f"joints.{joint.name}", "is not a hinge in the model: a servo turns a hinge")
    missing = [name for name in mapped if spec.joint(name) is None]
    if missing:
        raise ConfigError(where, "joints", f"{', '.join(missing)}: no such joint in {source.path.name}")
    if source.inertias == "from_geometry":
        recompute_inertias(spec, source=where)
    dt = physics_dt(robot)
    for robot_joint in robot.joints:
        joint = spec.joint(robot_joint.name)
        if robot_joint.sign < 0:
            joint.axis = -np.asarray(joint.axis)
        joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        low, high = robot_joint.range_rad
        joint.range = [math.degrees(low), math.degrees(high)] if degree else [low, high]
        if robot_joint.servo is not None:
            configure_servo_joint(joint, servo_physics(robot_joint.servo.profile))
        if backlash:
            body = joint.parent
            if body.joints[len(body.joints) - 1].name != joint.name:
                raise ConfigError(where, f"joints.{joint.name}", "backlash goes right behind a joint, and this "
                                  "one is not its body's last: split the body's joints in the model")
            add_backlash_joint(body, joint.name, joint.axis, dt)
    _colour_by_side(spec, robot)
    height = 1.0 if for_measure else robot.height
    add_scene(spec, robot, height)
    if not for_measure:
        lift = (SUSPENDED_HEIGHT_LEGS if suspended else 1.0) * robot.leg_length
        root.pos = [root.pos[0], root.pos[1], root.pos[2] + lift]
        add_tracking_camera(root, height)
    imu = spec.body(source.imu_body)
    if turn:  # the IMU's x forward: its body's axes turned back by the root's turn
        imu.add_site(name=IMU_SITE, pos=list(source.imu_pos), quat=_z_quat(-turn).tolist())
    else:
        imu.add_site(name=IMU_SITE, pos=list(source.imu_pos))
    model = compile_model(spec, where)
    _exclude_touching_links(spec, model)
    zero = mujoco.MjData(model)
    mujoco.mj_kinematics(model, zero)  # the zero pose, the robot standing as drawn
    for side in FEET:
        low, high = _foot_box(model, robot, side)
        up, sign = _up_axis(zero.xmat[model.body(source.feet[side].body).id])
        slab = max(SOLE_SLAB_M, SOLE_SLAB_SHARE * (high[up] - low[up]))  # the sole, not the ankle above it
        if sign > 0:
            high[up] = min(high[up], low[up] + slab)
            low[up] -= SOLE_BELOW_M
        else:  # the foot's frame points this axis down (a URDF's link frames follow its joints)
            low[up] = max(low[up], high[up] - slab)
            high[up] += SOLE_BELOW_M
        centre = 0.5 * (low + high)
        half = 0.5 * (high - low) + np.array([SOLE_MARGIN_M, SOLE_MARGIN_M, 0.0])
        spec.body(source.feet[side].body).add_site(name=sole_site(side), type=mujoco.mjtGeom.mjGEOM_BOX,
                                                   pos=centre.tolist(), size=half.tolist(), group=3)
        add_touch_sensor(spec, side)
    add_sensors_and_actuators(spec, robot)
    return spec


def _z_quat(turn_deg: float) -> np.ndarray:
    quat = np.zeros(4)
    mujoco.mju_axisAngle2Quat(quat, np.array([0.0, 0.0, 1.0]), math.radians(turn_deg))
    return quat


def _turn_about_z(spec: mujoco.MjSpec, root, turn_deg: float) -> None:
    """Turn the root body by ``turn_deg`` about world z, about its own origin (its orientation
    as the file writes it, in any of MJCF's forms, read from a compiled copy)."""
    if root.alt.type != mujoco.mjtOrientation.mjORIENTATION_QUAT:
        model = spec.copy().compile()
        root.quat = model.body_quat[model.body(root.name).id].tolist()
        root.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
    quat = np.zeros(4)
    mujoco.mju_mulQuat(quat, _z_quat(turn_deg), np.asarray(root.quat, dtype=float))
    root.quat = quat.tolist()


def _colour_by_side(spec: mujoco.MjSpec, robot: RobotSpec) -> None:
    """Paint the parts the model leaves plain (no material, MuJoCo's default grey) as the box
    robots are: a body takes the side of the nearest mapped joint at or above it."""
    sides = {spec.joint(j.name).parent.name: j.side for j in robot.joints}

    def side_of(body) -> str:
        while body is not None and body.name != "world":
            if body.name in sides:
                return sides[body.name]
            body = body.parent
        return "center"

    for geom in spec.geoms:
        if not geom.material and np.allclose(geom.rgba, DEFAULT_RGBA):
            geom.rgba = COLORS[side_of(geom.parent)]


def _exclude_touching_links(spec: mujoco.MjSpec, model: mujoco.MjModel) -> None:
    """No contacts between two links that already touch at the model's zero pose: CAD meshes
    overlap at the joints (MuJoCo leaves out only parent and child), and a contact there is
    the robot pressing on itself with hundreds of newtons, not a collision."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    pairs = set()
    for k in range(data.ncon):
        b1, b2 = (int(model.geom_bodyid[g]) for g in (data.contact[k].geom1, data.contact[k].geom2))
        if b1 and b2 and b1 != b2:
            pairs.add(tuple(sorted((model.body(b1).name, model.body(b2).name))))
    for first, second in sorted(pairs):
        spec.add_exclude(bodyname1=first, bodyname2=second)


def _check_bodies(spec: mujoco.MjSpec, robot: RobotSpec) -> None:
    source = robot.model
    named = [("model.imu.body", source.imu_body)]
    named += [(f"model.feet.{side}.body", foot.body) for side, foot in source.feet.items()]
    named += [(f"model.hands.{side}", body) for side, body in source.hands.items()]
    for key, name in named:
        if spec.body(name) is None:
            raise ConfigError(robot.source, key, f"no body {name!r} in {source.path.name}")


def _foot_geoms(model: mujoco.MjModel, robot: RobotSpec, side: str) -> list[int]:
    """The geoms a foot stands on: those named in the config, else every collision geom of
    the foot's body."""
    foot = robot.model.feet[side]
    body = model.body(foot.body).id
    if foot.geoms:
        ids = []
        for name in foot.geoms:
            gid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
            if gid < 0 or model.geom_bodyid[gid] != body:
                raise ConfigError(robot.source, f"model.feet.{side}.geoms", f"no geom {name!r} on body {foot.body!r}")
            ids.append(gid)
        return ids
    ids = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body
           and is_collision_geom(model.geom_contype[g], model.geom_conaffinity[g])]
    if not ids:
        raise ConfigError(robot.source, f"model.feet.{side}.body", f"body {foot.body!r} has no collision geometry "
                          "to stand on")
    return ids


def _rotated(mat: np.ndarray, points: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """(k, 3) ``mat`` (9,) applied to each point, plus ``offset``: MuJoCo's own arithmetic, not
    BLAS's (whose rounding depends on the CPU: these numbers end up in the compiled model)."""
    out = np.empty((len(points), 3))
    for i, point in enumerate(points):
        mujoco.mju_mulMatVec3(out[i], mat, np.ascontiguousarray(point, dtype=float))
    return out + offset


def _corners_in_body(model: mujoco.MjModel, geom: int) -> np.ndarray:
    """(8, 3) the corners of a geom's bounding box in its body's frame [m]."""
    centre, half = model.geom_aabb[geom, :3], model.geom_aabb[geom, 3:]
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, model.geom_quat[geom])
    local = np.array([centre + np.array(c) * half for c in itertools.product((-1, 1), repeat=3)])
    return _rotated(rot, local, model.geom_pos[geom])


def _up_axis(xmat: np.ndarray) -> tuple[int, int]:
    """The axis (0, 1, 2) of a body's frame nearest world up, from its world orientation
    ``xmat`` (9,), and +1 if it points up, -1 if down."""
    up_row = np.asarray(xmat).reshape(3, 3)[2]  # world z of the body's axes
    axis = int(np.argmax(np.abs(up_row)))
    return axis, 1 if up_row[axis] > 0 else -1


def _foot_box(model: mujoco.MjModel, robot: RobotSpec, side: str) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners of the box over a foot's geoms, in the foot body's frame [m]."""
    corners = np.concatenate([_corners_in_body(model, g) for g in _foot_geoms(model, robot, side)])
    return corners.min(axis=0), corners.max(axis=0)


def lowest_sole_point(model: mujoco.MjModel, data: mujoco.MjData, robot: RobotSpec) -> float:
    """The lowest point of either foot's geoms in the world [m] (from ``data``'s kinematics)."""
    lowest = math.inf
    for side in FEET:
        for geom in _foot_geoms(model, robot, side):
            body = model.geom_bodyid[geom]
            world = _rotated(data.xmat[body], _corners_in_body(model, geom), data.xpos[body])
            lowest = min(lowest, float(world[:, 2].min()))
    return lowest


def level_feet(model: mujoco.MjModel, data: mujoco.MjData, robot: RobotSpec) -> None:
    """Turn the floating root in ``data.qpos`` so that the feet, at the joint angles there,
    stand as level as they do at the model's zero pose (a crouch that leans the trunk forward,
    as ROBOTIS's walking stance does, then starts with its soles flat, not on their heels).
    Needs a free root joint first in ``qpos``; recomputes the kinematics."""
    feet = [model.body(robot.model.feet[side].body).id for side in FEET]
    zero = mujoco.MjData(model)
    zero.qpos[3:7] = data.qpos[3:7]
    mujoco.mj_kinematics(model, zero)
    mujoco.mj_kinematics(model, data)
    # each foot's local direction that points up at the zero pose, seen in the world now
    up_now = np.zeros(3)
    for b in feet:
        local, world = np.zeros(3), np.zeros(3)
        mujoco.mju_mulMatTVec3(local, zero.xmat[b], np.array([0.0, 0.0, 1.0]))
        mujoco.mju_mulMatVec3(world, data.xmat[b], local)
        up_now += world
    mujoco.mju_normalize3(up_now)
    axis = np.zeros(3)
    mujoco.mju_cross(axis, up_now, np.array([0.0, 0.0, 1.0]))
    sin, cos = mujoco.mju_norm3(axis), float(up_now[2])
    if sin < 1e-12:
        return
    turn = np.zeros(4)
    mujoco.mju_axisAngle2Quat(turn, axis / sin, math.atan2(sin, cos))
    root = np.zeros(4)
    mujoco.mju_mulQuat(root, turn, data.qpos[3:7])
    data.qpos[3:7] = root
    mujoco.mj_kinematics(model, data)


def measure_physique(robot: RobotSpec) -> Physique:
    """Mass, height and leg length of a robot from a model file, on its compiled model at the
    zero pose: height from the lowest to the highest point of its collision geometry; leg
    length from the highest hip joint's anchor to the lowest point of the feet (legs straight
    at zero, as a URDF or MJCF is drawn)."""
    model = compile_model(model_spec(robot, for_measure=True), robot.source)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mass = float(model.body_mass.sum())
    collision = [g for g in range(model.ngeom) if model.geom_bodyid[g] > 0
                 and is_collision_geom(model.geom_contype[g], model.geom_conaffinity[g])]
    zs = np.concatenate([_rotated(data.xmat[model.geom_bodyid[g]], _corners_in_body(model, g),
                                  data.xpos[model.geom_bodyid[g]])[:, 2] for g in collision])
    sole = lowest_sole_point(model, data, robot)
    hips = [model.joint(j.name).id for j in robot.joints if j.location == "hip"]
    if not hips:
        raise ConfigError(robot.source, "joints", "no hip joint: a biped's leg length runs from its hips")
    hip_z = max(float(data.xanchor[j][2]) for j in hips)
    if not hip_z > sole:
        raise ConfigError(robot.source, "joints", f"the hips ({hip_z:.3f} m) are not above the soles ({sole:.3f} m) "
                          "at the model's zero pose: is the model upright, z up?")
    return Physique(mass=mass, height=float(zs.max()) - sole, leg_length=hip_z - sole)
