"""Robot config -> MuJoCo model, with the servo model of :mod:`sim2real.robot.servo_model`.

The tree is the one of :mod:`sim2real.robot`: the pelvis is the floating root, the trunk
sits on it through the waist joints, and each leg hangs from a hip joint at the pelvis'
bottom.  Joints at one location share a body (hip: yaw, roll, pitch; ankle: pitch,
roll), as a servo chain does.  Each joint gets a ``position`` actuator named after it.

Collision filtering: legs collide with the floor and with the other leg, the trunk and
pelvis only with the floor; links of one side never collide with each other (adjacent
links overlap at the joints, and a servo bracket cannot pass through itself anyway).

Sensors: ``<side>_foot_touch`` (normal force under each sole [N]), ``torso_up`` (world up
in the torso frame, x forward, y left, z up: what the sensor board's IMU reports),
``torso_forward`` (the torso's x axis in the world frame, whose yaw :func:`heading_rad` is the
board's heading) and ``<joint>_pos`` (the servo joint's angle [rad], unquantized).  The
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
(:func:`sim2real.simulation.reality.apply`); the compiled model holds them closed.

    model = build_model(load_robot("xl430_biped"))
    angles = JointAngles.of(model).read(data.qpos)  # [rad], robot.joints order
    xml = to_mjcf(load_robot("human:male_95"))
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Sequence

import mujoco
import numpy as np

from sim2real.errors import BipedError
from sim2real.robot import Joint, RobotSpec
from sim2real.robot.servo_model import ServoPhysics, servo_physics
from sim2real.robot.timing import control_timing
from sim2real.simulation.joint_loads import axis_inertia, dot3

FLOOR, LEFT, RIGHT, TORSO = 1, 2, 4, 8  # contype / conaffinity bits
COLLISION_BITS = {  # (contype, conaffinity)
    "floor": (FLOOR, LEFT | RIGHT | TORSO),
    "left": (LEFT, FLOOR | RIGHT),
    "right": (RIGHT, FLOOR | LEFT),
    "center": (TORSO, FLOOR),
}
FLOOR_FRICTION = (1.0, 0.005, 0.0001)  # sliding, torsional, rolling (rubber-ish soles on a hard floor)
# A hard floor: contact time constant 10 ms (MuJoCo's default 20 ms lets a stiff PD-held human
# rock on its soles; >= 2 timesteps keeps it stable).
FLOOR_SOLREF = (0.01, 1.0)
JOINT_ORDER = {"waist": ("yaw", "roll", "pitch"), "hip": ("yaw", "roll", "pitch"),
               "knee": ("pitch",), "ankle": ("yaw", "pitch", "roll")}
# Joint axes for the right side and the centre; the left side mirrors roll and yaw so that
# one anatomical angle means one motion on both legs (see sim2real.robot).
_AXES = {
    ("waist", "yaw"): (0, 0, 1), ("waist", "roll"): (1, 0, 0), ("waist", "pitch"): (0, 1, 0),
    ("hip", "yaw"): (0, 0, -1), ("hip", "roll"): (-1, 0, 0), ("hip", "pitch"): (0, -1, 0),
    ("knee", "pitch"): (0, 1, 0),
    ("ankle", "yaw"): (0, 0, -1), ("ankle", "roll"): (-1, 0, 0), ("ankle", "pitch"): (0, -1, 0),
}
COLORS = {"left": (0.85, 0.45, 0.2, 1), "right": (0.2, 0.5, 0.85, 1), "center": (0.75, 0.75, 0.78, 1)}
SOLE_CLEARANCE_M = 0.0005  # the home keyframe starts the soles this far above the floor
SUSPENDED_HEIGHT_LEGS = 2.0  # a hung robot's pelvis, in leg lengths above the floor: feet well clear
OFFSCREEN_SIZE = (1280, 720)  # [px] the offscreen framebuffer: the largest picture `biped render` makes

BACKLASH_SUFFIX = "_backlash"  # <joint>_backlash: the gears' free play behind <joint>
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


def joint_axis(joint: Joint) -> tuple[float, float, float]:
    x, y, z = _AXES[(joint.location, joint.axis)]
    if joint.side == "left" and joint.axis in ("roll", "yaw"):
        x, z = -x, -z
    return (float(x), float(y), float(z))


def _look_at(forward: np.ndarray) -> list[float]:
    """Camera ``xyaxes`` looking along ``forward`` with the world's z up."""
    f = forward / math.sqrt(dot3(forward, forward))  # not np.linalg.norm: see dot3
    x = np.cross(f, [0.0, 0.0, 1.0])
    x /= math.sqrt(dot3(x, x))
    return [*x, *np.cross(x, f)]


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


def build_spec(robot: RobotSpec, backlash: bool = False, suspended: bool = False) -> mujoco.MjSpec:
    """The robot as an editable :class:`mujoco.MjSpec` (gains of PD robots not yet scaled),
    with a backlash joint behind each joint if ``backlash``; ``suspended`` hangs it by the
    pelvis, fixed in the air with its feet off the floor (no root joint), as a robot is hung
    for system identification."""
    b = robot.body
    timing = control_timing(robot)
    spec = mujoco.MjSpec()
    spec.modelname = robot.name.replace(":", "_")
    spec.compiler.degree = False  # every angle here is in radians (MJCF's default is degrees)
    spec.option.timestep = timing.physics_dt_s
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.visual.global_.offwidth, spec.visual.global_.offheight = OFFSCREEN_SIZE

    spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, width=256, height=256,
                     rgb1=[0.22, 0.25, 0.3], rgb2=[0.3, 0.33, 0.38])
    tile = 4 / max(b.height, 0.1)  # checker squares of about a quarter of the robot's height
    grid = spec.add_material(name="grid", texrepeat=[tile, tile], texuniform=True)
    grid.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"

    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, width=256, height=256,
                     rgb1=[0.55, 0.7, 0.85], rgb2=[0.1, 0.12, 0.16])
    world = spec.worldbody
    world.add_light(name="sun", pos=[0, 0, 3 * max(1.0, b.height)], dir=[0, 0, -1],
                    type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    contype, conaffinity = COLLISION_BITS["floor"]
    world.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                   material="grid", friction=list(FLOOR_FRICTION), solref=list(FLOOR_SOLREF),
                   contype=contype, conaffinity=conaffinity)

    pelvis = world.add_body(name="pelvis", pos=[0, 0, (SUSPENDED_HEIGHT_LEGS if suspended else 1.0) * b.leg_length])
    if not suspended:
        pelvis.add_freejoint(name="root")
    _box_geom(pelvis, "pelvis", b.pelvis.size, [0, 0, b.pelvis.size[2] / 2], b.pelvis.mass, "center")
    offset = 2.6 * b.height * np.array([0.45, -0.88, 0.12])  # front-right, slightly above
    pelvis.add_camera(name="track", mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM, pos=offset.tolist(),
                      xyaxes=_look_at(-offset))

    trunk = pelvis.add_body(name="trunk", pos=[0, 0, b.pelvis.size[2]])
    dt = timing.physics_dt_s
    _add_joints(robot, trunk, "center", "waist", backlash, dt)
    _box_geom(trunk, "trunk", b.trunk.size, [0, 0, b.trunk.size[2] / 2], b.trunk.mass, "center")
    trunk.add_site(name="imu", pos=[0, 0, b.trunk.size[2] / 2])

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
        foot.add_site(name=f"{side}_sole", type=mujoco.mjtGeom.mjGEOM_BOX, pos=sole_center,
                      size=[f.length / 2 + 1e-3, f.width / 2 + 1e-3, f.thickness], group=3)
        spec.add_sensor(name=f"{side}_foot_touch", type=mujoco.mjtSensor.mjSENS_TOUCH,
                        objtype=mujoco.mjtObj.mjOBJ_SITE, objname=f"{side}_sole")

    # world up in the torso frame: what the sensor board's IMU reports
    spec.add_sensor(name="torso_up", type=mujoco.mjtSensor.mjSENS_FRAMEZAXIS,
                    objtype=mujoco.mjtObj.mjOBJ_BODY, objname="world",
                    reftype=mujoco.mjtObj.mjOBJ_SITE, refname="imu")
    # the torso's forward axis in the world: its yaw is the heading the board's IMU reports
    spec.add_sensor(name="torso_forward", type=mujoco.mjtSensor.mjSENS_FRAMEXAXIS,
                    objtype=mujoco.mjtObj.mjOBJ_SITE, objname="imu")
    for joint in robot.joints:
        spec.add_sensor(name=f"{joint.name}_pos", type=mujoco.mjtSensor.mjSENS_JOINTPOS,
                        objtype=mujoco.mjtObj.mjOBJ_JOINT, objname=joint.name)
        _add_actuator(spec, joint)
    return spec


def heading_rad(forward: np.ndarray) -> np.ndarray:
    """The heading an IMU reports from the ``torso_forward`` sensor's values (..., 3): the
    yaw of the torso's forward axis about world up, counter-clockwise seen from above [rad]."""
    return np.arctan2(forward[..., 1], forward[..., 0])


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


def _add_actuator(spec: mujoco.MjSpec, joint: Joint) -> None:
    act = spec.add_actuator(name=joint.name, target=joint.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.ctrlrange = list(joint.range_rad)
    if joint.servo is not None:
        configure_servo_actuator(act, servo_physics(joint.servo.profile))
    else:
        act.set_to_position(kp=1.0, kv=0.0)  # scaled by the joint inertia in build_model


def _home_keyframe(robot: RobotSpec, spec: mujoco.MjSpec, model: mujoco.MjModel) -> None:
    """Add keyframe ``home``: joints at home, root lowered until the soles touch the floor."""
    data = mujoco.MjData(model)
    home = home_ctrl(robot, model)
    JointAngles.of(model).place(data.qpos, home)
    mujoco.mj_kinematics(model, data)
    lowest = np.inf
    for side in ("left", "right"):
        geom = model.geom(f"{side}_foot").id
        up_row = data.geom_xmat[geom].reshape(3, 3)[2]  # world z of the foot's local axes
        centre_z = float(data.geom_xpos[geom][2])
        for corner in itertools.product((-1, 1), repeat=3):
            lowest = min(lowest, centre_z + dot3(np.array(corner) * model.geom_size[geom], up_row))
    qpos = data.qpos.copy()
    if model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE:  # standing: lowered onto the floor; hung: as it is
        qpos[2] -= lowest - SOLE_CLEARANCE_M
    spec.add_key(name="home", qpos=qpos.tolist(), ctrl=home.tolist())


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


@dataclass(frozen=True)
class JointAngles:
    """Where a model keeps the robot's joint angles: the one reader of them from ``qpos``.

    A joint's angle is what its encoder reports, on the servo's output shaft: the servo
    (motor-side) joint's angle plus, in a model with backlash, the backlash joint's.
    Index arrays are in the order of the names given (default: the actuated joints, in
    actuator order = ``robot.joints`` order).
    """

    servo_joint: np.ndarray  # joint ids
    servo_qpos: np.ndarray  # qpos addresses
    servo_dof: np.ndarray  # qvel addresses
    play_joint: np.ndarray | None  # the backlash joints' ids, or None in a model without
    play_qpos: np.ndarray | None
    play_dof: np.ndarray | None

    @classmethod
    def of(cls, model: mujoco.MjModel, names: Sequence[str] | None = None) -> "JointAngles":
        if names is None:
            names = [model.joint(model.actuator_trnid[i, 0]).name for i in range(model.nu)]
        servo = np.array([model.joint(n).id for n in names], dtype=np.intp)
        play_names = [n + BACKLASH_SUFFIX for n in names]
        found = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) >= 0 for n in play_names]
        if any(found) and not all(found):
            raise ValueError(f"backlash joints behind only some of the joints {list(names)}")
        play = np.array([model.joint(n).id for n in play_names], dtype=np.intp) if any(found) else None
        return cls(servo, model.jnt_qposadr[servo], model.jnt_dofadr[servo], play,
                   None if play is None else model.jnt_qposadr[play],
                   None if play is None else model.jnt_dofadr[play])

    @property
    def has_play(self) -> bool:
        return self.play_joint is not None

    def read(self, qpos: np.ndarray) -> np.ndarray:
        """The encoders' angles (..., joints) [rad] from ``qpos`` (..., nq)."""
        q = qpos[..., self.servo_qpos]
        return q if self.play_qpos is None else q + qpos[..., self.play_qpos]

    def speeds(self, qvel: np.ndarray) -> np.ndarray:
        """The output shafts' speeds (..., joints) [rad/s] from ``qvel`` (..., nv)."""
        v = qvel[..., self.servo_dof]
        return v if self.play_dof is None else v + qvel[..., self.play_dof]

    def servo(self, qpos: np.ndarray) -> np.ndarray:
        """The servo (motor-side) joints' angles (..., joints) [rad]: what the actuator sees."""
        return qpos[..., self.servo_qpos]

    def place(self, qpos: np.ndarray, angles: np.ndarray) -> None:
        """Put the joints at ``angles`` [rad] in ``qpos``, the gears centred in their play."""
        qpos[..., self.servo_qpos] = angles
        if self.play_qpos is not None:
            qpos[..., self.play_qpos] = 0.0


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
    """
    assert robot.pd is not None
    data = mujoco.MjData(model)
    JointAngles.of(model, robot.joint_names).place(data.qpos, np.array([j.home_rad for j in robot.joints]))
    mujoco.mj_kinematics(model, data)
    for joint in robot.joints:
        inertia = axis_inertia(model, data, joint)
        act = spec.actuator(joint.name)
        act.set_to_position(kp=inertia * robot.pd.kp, kv=inertia * robot.pd.kd)
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-robot.pd.max_torque_nm, robot.pd.max_torque_nm]
