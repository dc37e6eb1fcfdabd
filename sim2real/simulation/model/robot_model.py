"""Where a compiled robot model keeps what the simulation reads: the one owner of its names.

The model builder gives every robot - a box tree or a user's MJCF or URDF - the same
project-named parts: a site ``imu`` on the torso with the sensors ``torso_up`` (world up in the
IMU's frame: what the sensor board's up-vector reports), ``torso_forward`` (the IMU's x axis in
the world, whose yaw is the board's heading) and ``torso_gyro`` (the IMU's angular rate about
its own axes [rad/s]); per foot a box site ``<side>_sole`` over its sole with a touch sensor
``<side>_foot_touch`` (normal force [N]); the floor geom ``floor``.  The root body - the one
that floats, whose centre of mass the fall test watches - is the robot's (``pelvis`` for a box
robot).  :class:`RobotModel` resolves them once into ids and addresses; the evaluator, the
simulated bus, ``compare``, ``sysid`` and the objectives read through it, over any leading
axes (one ``MjData``'s arrays, or a batch's ``(nsim, ...)``).  :class:`JointAngles` is the one
reader of the joint angles from ``qpos``.

    parts = RobotModel.of(model, robot)
    parts.up(data.sensordata), parts.feet_touching(data.sensordata), parts.root_com(data.xipos)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import mujoco
import numpy as np

from sim2real.controller.channels import turn_rad
from sim2real.robot import RobotSpec
from sim2real.robot.spec import ARM_LOCATIONS
from sim2real.simulation.model.mujoco_log import no_log_file

no_log_file()  # every MuJoCo model passes through here: no MUJOCO_LOG.TXT in the user's folder
FEET = ("left", "right")  # the order of every per-foot array
IMU_SITE = "imu"
UP_SENSOR = "torso_up"
FORWARD_SENSOR = "torso_forward"
GYRO_SENSOR = "torso_gyro"
FLOOR_GEOM = "floor"
BACKLASH_SUFFIX = "_backlash"  # <joint>_backlash: the gears' free play behind <joint>


def sole_site(side: str) -> str:
    return f"{side}_sole"


def touch_sensor(side: str) -> str:
    return f"{side}_foot_touch"


def joint_sensor(joint: str) -> str:
    return f"{joint}_pos"


def is_collision_geom(contype: int, conaffinity: int) -> bool:
    """Whether a geom takes part in contacts (a visual-only geom has both bitmasks 0)."""
    return bool(contype) or bool(conaffinity)


def imu_between(newer: np.ndarray, older: np.ndarray, share: np.ndarray | float) -> np.ndarray:
    """IMU readings (..., 7) as :meth:`RobotModel.imu` packs them, ``share`` (0-1, broadcast
    over the leading axes) of the way from ``newer`` back to ``older``: what a board reports
    whose readings are that old.  The yaw (last) is interpolated the short way round."""
    share = np.asarray(share, dtype=float)[..., None]
    out = newer + share * (older - newer)
    out[..., 6] = newer[..., 6] + share[..., 0] * turn_rad(older[..., 6], newer[..., 6])
    return out


def heading_rad(forward: np.ndarray) -> np.ndarray:
    """The heading an IMU reports from the ``torso_forward`` sensor's values (..., 3): the
    yaw of the torso's forward axis about world up, counter-clockwise seen from above [rad]."""
    return np.arctan2(forward[..., 1], forward[..., 0])


@dataclass(frozen=True)
class Arm:
    """One arm's parts in a compiled model, as seed 002's reaching reads them: the hand (its
    body's centre of mass), the shoulder (the origin of the arm's first jointed body), the
    elbow (the origin of the elbow's body; the hand's, without an elbow joint), and the torso
    (the body holding the IMU) with the box around its collision geoms in its own frame - the
    elbow inside it is the upper arm through the thorax, which collisions between jointed
    neighbours do not stop."""

    joints: tuple[str, ...]  # the arm's joints, robot order
    hand: int
    shoulder: int
    elbow: int
    torso: int
    torso_box: np.ndarray  # (2, 3) low and high corners [m], torso frame

    @classmethod
    def of(cls, model: mujoco.MjModel, robot: RobotSpec, side: str = "right") -> "Arm":
        hands = robot.model.hands if robot.model is not None else {}
        if side not in hands:
            raise ValueError(f"robot {robot.name} names no {side} hand (model.hands in its config): "
                             "reaching needs one")
        joints = tuple(j.name for j in robot.joints if j.side == side and j.location in ARM_LOCATIONS)
        if not joints:
            raise ValueError(f"robot {robot.name} has no {side} arm joints (shoulder, elbow, wrist)")

        def body(joint: str) -> int:
            return int(model.jnt_bodyid[model.joint(joint).id])

        def depth(b: int) -> int:
            return 0 if b == 0 else 1 + depth(int(model.body_parentid[b]))

        hand = model.body(hands[side]).id
        shoulder = min((body(j) for j in joints), key=depth)
        elbows = [body(j.name) for j in robot.joints if j.side == side and j.location == "elbow"]
        torso = int(model.site_bodyid[model.site(IMU_SITE).id])
        return cls(joints, hand, shoulder, min(elbows, key=depth) if elbows else hand, torso,
                   _body_box(model, torso))


def arm_chain(model: mujoco.MjModel, robot: RobotSpec, arm: Arm) -> dict:
    """The bodies from the root to ``arm``'s hand as a controller file's ``reach_arm`` holds them
    (:class:`sim2real.controller.kinematics.ArmChain` walks it): each body's offset [m] and
    rotation (w, x, y, z) from its parent, its hinges (the robot's joint, anchor [m], axis in
    the body's frame; backlash joints, at rest on a nominal robot, left out), the hand's
    centre of mass in its body's frame [m], and which body is the shoulder's."""
    root = model.body(robot.root_body).id
    path, b = [], arm.hand
    while b != root:
        if b == 0:
            raise ValueError(f"the hand body {model.body(arm.hand).name!r} is not below the root {robot.root_body!r}")
        path.append(b)
        b = int(model.body_parentid[b])
    names = set(robot.joint_names)
    links = []
    for b in reversed(path):
        hinges = [{"name": model.joint(j).name, "pos": model.jnt_pos[j].tolist(), "axis": model.jnt_axis[j].tolist()}
                  for j in range(model.njnt) if model.jnt_bodyid[j] == b and model.joint(j).name in names]
        for j in range(model.njnt):  # the chain turns each hinge by its angle from 0
            if model.jnt_bodyid[j] == b and model.qpos0[model.jnt_qposadr[j]] != 0:
                raise ValueError(f"joint {model.joint(j).name!r} has a reference angle (ref) of "
                                 f"{model.qpos0[model.jnt_qposadr[j]]:g} rad: the arm's chain needs 0")
        links.append({"pos": model.body_pos[b].tolist(), "quat": model.body_quat[b].tolist(), "joints": hinges})
    return {"links": links, "hand_com": model.body_ipos[arm.hand].tolist(),
            "shoulder_link": list(reversed(path)).index(arm.shoulder)}


def _body_box(model: mujoco.MjModel, body: int) -> np.ndarray:
    """(2, 3) the box around a body's collision geoms in its own frame [m] (MuJoCo's geom
    bounding boxes, turned into the body frame)."""
    corners = []
    signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    for g in np.flatnonzero(model.geom_bodyid == body):
        if not is_collision_geom(model.geom_contype[g], model.geom_conaffinity[g]):
            continue
        rotation = np.empty(9)
        mujoco.mju_quat2Mat(rotation, model.geom_quat[g])
        centre, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        corners.append(model.geom_pos[g] + (centre + signs * half) @ rotation.reshape(3, 3).T)
    if not corners:
        return np.zeros((2, 3))
    points = np.concatenate(corners)
    return np.stack([points.min(axis=0), points.max(axis=0)])


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


@dataclass(frozen=True)
class RobotModel:
    """A compiled robot model's parts, resolved once; readers over any leading axes."""

    root: int  # the floating root body's id (the pelvis of a box robot)
    soles: np.ndarray  # (2,) the sole sites' ids, left and right
    touch: np.ndarray  # (2,) the touch sensors' sensordata addresses, left and right
    up_adr: int
    forward_adr: int
    gyro_adr: int
    angles: JointAngles  # the robot's joints, robot order
    foot_contact_n: float  # a foot switch closes above this sole force [N]

    @classmethod
    def of(cls, model: mujoco.MjModel, robot: RobotSpec) -> "RobotModel":
        def adr(name: str) -> int:
            return int(model.sensor_adr[model.sensor(name).id])

        return cls(root=model.body(robot.root_body).id,
                   soles=np.array([model.site(sole_site(s)).id for s in FEET]),
                   touch=np.array([adr(touch_sensor(s)) for s in FEET]),
                   up_adr=adr(UP_SENSOR), forward_adr=adr(FORWARD_SENSOR), gyro_adr=adr(GYRO_SENSOR),
                   angles=JointAngles.of(model, robot.joint_names), foot_contact_n=robot.foot_contact_n)

    def feet_touching(self, sensordata: np.ndarray) -> np.ndarray:
        """(..., 2) bool: each foot switch closed (left, right), noise-free."""
        return sensordata[..., self.touch] > self.foot_contact_n

    def up(self, sensordata: np.ndarray) -> np.ndarray:
        """(..., 3) world up in the torso frame, as the board's IMU reports it."""
        return sensordata[..., self.up_adr:self.up_adr + 3]

    def heading(self, sensordata: np.ndarray) -> np.ndarray:
        """(...) the torso's yaw [rad], as the board's IMU reports it (drift-free)."""
        return heading_rad(sensordata[..., self.forward_adr:self.forward_adr + 3])

    def gyro(self, sensordata: np.ndarray) -> np.ndarray:
        """(..., 3) the torso's angular rate about its x, y, z axes [rad/s], noise-free."""
        return sensordata[..., self.gyro_adr:self.gyro_adr + 3]

    def imu(self, sensordata: np.ndarray) -> np.ndarray:
        """(..., 7) everything the board's IMU reports, packed: up (3), gyro (3), yaw [rad] -
        what a delayed IMU keeps a history of (:func:`imu_between`)."""
        return np.concatenate([self.up(sensordata), self.gyro(sensordata), self.heading(sensordata)[..., None]], axis=-1)

    def root_com(self, xipos: np.ndarray) -> np.ndarray:
        """(..., 3) the root body's centre of mass [m] from ``xipos`` (..., nbody, 3)."""
        return xipos[..., self.root, :]

    def sole_positions(self, site_xpos: np.ndarray) -> np.ndarray:
        """(..., 2, 3) the sole sites' centres [m] (left, right) from ``site_xpos``."""
        return site_xpos[..., self.soles, :]
