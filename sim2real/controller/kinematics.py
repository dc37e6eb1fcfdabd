"""The right arm's forward kinematics, without MuJoCo: where the hand is, from joint angles.

Seed 002's reach state machine toggles when the hand reaches its goal; on a robot the runtime
knows the hand only from the joint angles.  A reaching controller's file carries the chain of
bodies from the root to the hand (``reach_arm``: each body's offset and rotation from its
parent, and its hinges' anchors, axes and joint names, as the compiled model has them; a
model robot's hinge axes are already turned so that its angle is the anatomical one), and
:class:`ArmChain` walks it.  Evolution runs the same chain on the same encoder readings, so
the state machine decides alike in both.

    chain = ArmChain.from_dict(controller.reach_arm, robot.joint_names)
    hand, shoulder = chain.hand(angles), chain.shoulder(angles)   # (n, 3) [m], root frame
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np


def quat_matrix(quat: Sequence[float]) -> np.ndarray:
    """(3, 3) the rotation of a unit quaternion (w, x, y, z)."""
    w, x, y, z = np.asarray(quat, dtype=float) / np.linalg.norm(quat)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def axis_rotations(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations by ``angle`` (n,) [rad] about the unit ``axis`` (3,) (Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * k + (1 - c) * (k @ k)


@dataclass(frozen=True)
class Link:
    """A body on the way to the hand: its frame from its parent's at zero angles, then its hinges."""

    pos: np.ndarray  # (3,) [m] in the parent's frame
    rotation: np.ndarray  # (3, 3)
    joints: tuple[tuple[int, np.ndarray, np.ndarray], ...]  # (robot joint index, anchor (3,) [m], unit axis (3,))


@dataclass(frozen=True)
class ArmChain:
    links: tuple[Link, ...]  # root's child first, the hand's body last
    hand_com: np.ndarray  # (3,) the hand's centre of mass in its body's frame [m]
    shoulder_link: int  # the link whose origin is the shoulder

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], joint_names: Sequence[str]) -> "ArmChain":
        """The chain a controller file's ``reach_arm`` holds, for a robot with ``joint_names``."""
        index = {name: i for i, name in enumerate(joint_names)}
        links = []
        for link in data["links"]:
            hinges = tuple((index[j["name"]], np.asarray(j["pos"], dtype=float),
                            np.asarray(j["axis"], dtype=float) / np.linalg.norm(j["axis"])) for j in link["joints"])
            links.append(Link(np.asarray(link["pos"], dtype=float), quat_matrix(link["quat"]), hinges))
        return cls(tuple(links), np.asarray(data["hand_com"], dtype=float), int(data["shoulder_link"]))

    def frames(self, angles: np.ndarray, upto: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(n, 3) position and (n, 3, 3) rotation in the root's frame of link ``upto`` (default
        the last) for joint angles (n, joints) [rad], robot order."""
        angles = np.atleast_2d(np.asarray(angles, dtype=float))
        n = len(angles)
        pos, rot = np.zeros((n, 3)), np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
        for link in self.links[:None if upto is None else upto + 1]:
            pos = pos + rot @ link.pos
            rot = rot @ link.rotation
            for joint, anchor, axis in link.joints:  # about the anchor: the origin moves unless it lies on the axis
                turn = axis_rotations(axis, angles[:, joint])
                pos = pos + np.einsum("nij,nj->ni", rot, anchor - turn @ anchor)
                rot = rot @ turn
        return pos, rot

    def hand(self, angles: np.ndarray) -> np.ndarray:
        """(n, 3) the hand's centre of mass in the root's frame [m]."""
        pos, rot = self.frames(angles)
        return pos + rot @ self.hand_com

    def shoulder(self, angles: np.ndarray) -> np.ndarray:
        """(n, 3) the shoulder (its link's origin) in the root's frame [m]."""
        return self.frames(angles, self.shoulder_link)[0]
