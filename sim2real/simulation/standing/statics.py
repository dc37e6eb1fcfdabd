"""Static holding torques: can the servos hold the robot in a crouch?

For each joint the torque needed to hold still, in a half crouch (knee at
``CROUCH_KNEE_DEG``, hip and ankle pitch at half of it so the foot stays flat and the
trunk upright) on one stance leg carrying the whole robot, the worst case of a walk.
With the stance foot fixed, a leg joint carries the weight of every body on the pelvis
side of it; a waist joint carries the trunk.  The margin is the actuator's torque limit
(stall torque for a servo) over that torque.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from sim2real.robot import RobotSpec
from sim2real.robot.spec import GRAVITY
from sim2real.simulation.model.joint_loads import carried_bodies
from sim2real.simulation.model.robot_model import JointAngles

CROUCH_KNEE_DEG = 60.0
GRAVITY_VECTOR = np.array([0.0, 0.0, -GRAVITY])  # [m/s^2], world frame


@dataclass(frozen=True)
class HoldingTorque:
    joint: str
    torque_nm: float  # |static torque| in the crouch [N m]
    limit_nm: float  # stall torque or PD torque limit [N m]

    @property
    def margin(self) -> float | None:
        """limit / torque; None when the joint carries no gravity load."""
        return self.limit_nm / self.torque_nm if self.torque_nm > 1e-9 else None


def crouch_pose(robot: RobotSpec, knee_deg: float = CROUCH_KNEE_DEG) -> dict[str, float]:
    """Joint angles of the half crouch, clipped to each joint's range [rad]."""
    knee = math.radians(knee_deg)
    wanted = {("hip", "pitch"): knee / 2, ("knee", "pitch"): knee, ("ankle", "pitch"): knee / 2}
    pose = {}
    for j in robot.joints:
        angle = wanted.get((j.location, j.axis), 0.0) if j.index == 0 else 0.0
        pose[j.name] = min(max(angle, j.range_rad[0]), j.range_rad[1])
    return pose


def holding_torques(
    robot: RobotSpec, model: mujoco.MjModel, knee_deg: float = CROUCH_KNEE_DEG
) -> list[HoldingTorque]:
    """Holding torque and margin of every joint, in ``robot.joints`` order."""
    data = mujoco.MjData(model)
    pose = crouch_pose(robot, knee_deg)
    JointAngles.of(model, list(pose)).place(data.qpos, np.array(list(pose.values())))
    mujoco.mj_kinematics(model, data)
    result = []
    for joint in robot.joints:
        jid = model.joint(joint.name).id
        anchor, axis = data.xanchor[jid], data.xaxis[jid]
        torque = sum(
            np.dot(np.cross(data.xipos[b] - anchor, model.body_mass[b] * GRAVITY_VECTOR), axis)
            for b in carried_bodies(model, joint)
        )
        if joint.servo is not None:
            limit = joint.servo.profile.motor.stall_torque_nm
        else:
            limit = float(model.actuator_forcerange[model.actuator(joint.name).id][1])
        result.append(HoldingTorque(joint.name, abs(float(torque)), limit))
    return result
