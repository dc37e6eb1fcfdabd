"""Left/right mirror pairs of a model's hinges, found from its geometry, checked against names.

    mirror = mirror_pairs(model)     # at the model's zero pose (qpos0)
    mirror.pairs       # MirrorPair(left, right, sign): sign +1 when equal angles mirror
    mirror.centre      # hinges whose axis the mirror maps onto itself: head pan, waist yaw...
    mirror.unpaired    # hinges off the sagittal plane that pair with nothing
    mirror.sides       # every hinge: "left" (+y) | "right" | "center"
    mirror.conflicts   # where the names and the geometry disagree, one sentence each

Method (DESIGN.md 11): at qpos0 (``mj_kinematics``) each hinge has a world anchor ``p`` and
axis ``u``, taken into the anatomical frame of the robot's facing (``forward``: ``+x`` by
default; :func:`sim2real.robot.anatomy.to_anatomical`), so that below x is forward and y left.
Mirroring across the sagittal plane (x-z, through the root body's origin, wherever it stands) maps a point ``(x, y, z)`` to
``(x, -y, z)`` and an axis of rotation ``(x, y, z)`` to ``-(x, -y, z)`` (a rotation's axis is
a pseudo-vector: the mirror turns its sense).  A hinge's partner has its anchor within
``tolerance`` of the mirrored anchor and its axis parallel or antiparallel to the mirrored
axis; their dot product is the pair's sign: +1 "mirrored" when equal angles make mirror-image
poses (the author mirrored the axis: a pitch axis the same world vector on both sides, a roll
or yaw axis opposite), -1 "opposed" when equal angles make opposite motions (ROBOTIS OP3's
nine pairs all are).  The tolerance grows with
the robot (1 % of its size, at least 1 mm): a few mm for a 0.5 m humanoid.

A hinge with no partner is a centre joint when the mirror maps its axis *line* onto itself
(an axis along y anywhere, or along x or z on the plane) and what it moves is centred: its
anchor on the plane, or its subtree's centre of mass (a head tilted by a servo horn 19 mm off
the plane, as ROBOTIS OP3's).  Any other is unpaired, on the side of its anchor.

Names are read for their side (``l_``, ``_right``, ``LHip`` ...: :mod:`sim2real.simulation.model.importing.joint_names`)
and checked: a pair whose names differ once the side is taken out, a name that says left on a
hinge right of the plane, two names that pair but whose geometry does not.  A model that pairs
better across the other vertical plane faces the other way than ``forward`` says: ``notes``
says so.  ``anchors`` and ``axes`` are in the anatomical frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from sim2real.robot.anatomy import DEFAULT_FORWARD, to_anatomical
from sim2real.simulation.model.importing.joint_names import base_of, side_of

SIZE_FRACTION = 0.01  # anchor tolerance, of the robot's size
MIN_TOLERANCE_M = 0.001
AXIS_TOLERANCE_DEG = 10.0  # mirrored axes this close to (anti)parallel are one line
CENTRED_COM_FRACTION = 0.03  # a subtree's centre of mass this near the plane (of the size) is centred
_MIRROR_POINT = np.array([1.0, -1.0, 1.0])
_MIRROR_AXIS = -_MIRROR_POINT  # a rotation axis is a pseudo-vector: the mirror turns its sense


@dataclass(frozen=True)
class MirrorPair:
    """A left hinge (anchor at +y) and its right partner; ``sign`` is the dot product of the
    right axis with the mirrored left one, rounded: +1 when equal angles make mirror-image
    poses, -1 when they make opposite motions."""

    left: str
    right: str
    sign: int
    anchor_error: float  # [m] between the right anchor and the mirrored left one
    axis_dot: float  # the dot product before rounding


@dataclass(frozen=True)
class MirrorInference:
    pairs: tuple[MirrorPair, ...]
    centre: tuple[str, ...]
    unpaired: tuple[str, ...]
    sides: dict[str, str]  # hinge -> left | right | center, from the geometry
    conflicts: tuple[str, ...]  # sentences: names against geometry
    tolerance: float  # [m] the anchor tolerance used
    notes: tuple[str, ...] = ()  # about the model as a whole (e.g. it faces along y)
    # [m] from the root, qpos0, and unit axes: in the anatomical frame (x forward, y left, z up)
    anchors: dict[str, tuple[float, float, float]] = field(repr=False, default_factory=dict)
    axes: dict[str, tuple[float, float, float]] = field(repr=False, default_factory=dict)
    forward: str = DEFAULT_FORWARD  # the model's facing the frame is taken from

    def partner(self, name: str) -> str | None:
        for pair in self.pairs:
            if name in (pair.left, pair.right):
                return pair.right if name == pair.left else pair.left
        return None

    def report(self) -> list[str]:
        """The inference in sentences, for a person."""
        lines = [f"{len(self.pairs)} mirror pair{'s' if len(self.pairs) != 1 else ''} (anchor tolerance "
                 f"{self.tolerance * 1e3:.1f} mm):"]
        lines += [f"  {p.left} <-> {p.right}: {'mirrored (+1)' if p.sign > 0 else 'opposed (-1)'}"
                  for p in self.pairs]
        if self.centre:
            lines.append(f"centre (on the sagittal plane): {', '.join(self.centre)}")
        for name in self.unpaired:
            x, y, z = self.anchors[name]
            lines.append(f"unpaired: {name} ({self.sides[name]}, anchor ({x:.3f}, {y:.3f}, {z:.3f}) m from the root): "
                         f"no hinge at its mirror image ({x:.3f}, {-y:.3f}, {z:.3f}) m with a mirrored axis")
        lines += [f"names disagree: {c}" for c in self.conflicts]
        lines += [f"note: {n}" for n in self.notes]
        return lines


def mirror_pairs(model: mujoco.MjModel, forward: str = DEFAULT_FORWARD) -> MirrorInference:
    """Mirror pairs, centre and unpaired hinges of ``model`` at its zero pose (qpos0), the
    robot facing ``forward`` (a key of :data:`sim2real.robot.anatomy.FORWARDS`)."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)  # subtree centres of mass
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    names = [model.joint(j).name or f"joint{j}" for j in hinges]
    origin = data.xpos[_root(model)].copy()  # the mirror plane runs through the root's origin
    frame = np.array([to_anatomical(e, forward) for e in np.eye(3)]).T  # world -> anatomical
    world_anchors = np.array([data.xanchor[j] for j in hinges]).reshape(-1, 3)
    anchors = (world_anchors - origin) @ frame.T
    axes = np.array([data.xaxis[j] / np.linalg.norm(data.xaxis[j]) for j in hinges]).reshape(-1, 3) @ frame.T
    size = _robot_size(model, data, world_anchors)  # both in world coordinates
    tol = max(MIN_TOLERANCE_M, SIZE_FRACTION * size)
    cos_tol = math.cos(math.radians(AXIS_TOLERANCE_DEG))

    pairs = _pairs(names, anchors, axes, tol, cos_tol, plane_normal=1)
    paired = {names.index(n) for p in pairs for n in (p.left, p.right)}
    notes = []
    sideways = _pairs(names, anchors, axes, tol, cos_tol, plane_normal=0)
    if len(sideways) > len(pairs):  # a model facing along the other axis pairs across the other plane
        other = "y" if forward in ("+x", "-x") else "x"
        notes.append(f"{len(sideways)} pairs form across the {other}-z plane against {len(pairs)} across the "
                     f"plane square to its left: the model seems to face along {other}, not {forward} "
                     f"(biped robot import --forward +{other} or -{other})")

    sides, centre, unpaired = {}, [], []
    com_tol = max(tol, CENTRED_COM_FRACTION * size)
    for i, name in enumerate(names):
        on_plane = abs(anchors[i, 1]) <= tol
        com = (data.subtree_com[model.jnt_bodyid[hinges[i]]] - origin) @ frame.T
        if i not in paired and _line_is_symmetric(anchors[i], axes[i], tol, cos_tol) and (
                on_plane or abs(com[1]) <= com_tol):
            sides[name] = "center"
            centre.append(name)
            continue
        sides[name] = "center" if on_plane else ("left" if anchors[i, 1] > 0 else "right")
        if i not in paired:
            unpaired.append(name)
    return MirrorInference(tuple(pairs), tuple(centre), tuple(unpaired), sides,
                           tuple(_name_conflicts(pairs, sides, names)), tol, tuple(notes),
                           {n: tuple(float(v) for v in a) for n, a in zip(names, anchors)},
                           {n: tuple(float(v) for v in u) for n, u in zip(names, axes)}, forward)


def _pairs(names: list[str], anchors: np.ndarray, axes: np.ndarray, tol: float, cos_tol: float,
           plane_normal: int) -> list[MirrorPair]:
    """Mirror pairs across the plane through the origin normal to coordinate ``plane_normal``
    (1: the sagittal x-z plane); "left" is the + side of that coordinate."""
    point = np.ones(3)
    point[plane_normal] = -1.0
    axis_mirror = -point  # a rotation axis is a pseudo-vector: the mirror turns its sense
    n = plane_normal
    off_plane = [i for i in range(len(names)) if abs(anchors[i, n]) > tol]
    candidates: dict[int, list[tuple[float, int, float]]] = {}
    for i in off_plane:
        for k in off_plane:
            if anchors[k, n] * anchors[i, n] >= 0:
                continue
            error = float(np.linalg.norm(anchors[k] - anchors[i] * point))
            dot = float(axes[k] @ (axes[i] * axis_mirror))
            if error <= tol and abs(dot) >= cos_tol:
                # names that pair break a tie between hinges at one place (a 2-axis hip)
                penalty = 0.0 if base_of(names[i]) == base_of(names[k]) else 1e-9
                candidates.setdefault(i, []).append((error + penalty, k, dot))
    best = {i: min(c) for i, c in candidates.items()}
    pairs = []
    for i in sorted(best):
        error, k, dot = best[i]
        if anchors[i, n] > 0 and k in best and best[k][1] == i:  # each the other's best
            pairs.append(MirrorPair(names[i], names[k], 1 if dot > 0 else -1,
                                    float(np.linalg.norm(anchors[k] - anchors[i] * point)), dot))
    return pairs


def _root(model: mujoco.MjModel) -> int:
    """The body with the free joint, else the first body under the world."""
    free = [int(model.jnt_bodyid[j]) for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
    return free[0] if free else (1 if model.nbody > 1 else 0)


def _robot_size(model: mujoco.MjModel, data: mujoco.MjData, anchors: np.ndarray) -> float:
    """[m] the largest extent of the robot's bodies and hinge anchors at qpos0 (its height, for a biped)."""
    points = np.vstack([data.xpos[1:], anchors]) if model.nbody > 1 else anchors
    return float(np.max(points.max(axis=0) - points.min(axis=0))) if len(points) else 0.0


def _line_is_symmetric(anchor: np.ndarray, axis: np.ndarray, tol: float, cos_tol: float) -> bool:
    """Whether the mirror maps the hinge's axis line onto itself."""
    if abs(axis @ (axis * _MIRROR_AXIS)) < cos_tol:
        return False
    offset = anchor * _MIRROR_POINT - anchor
    return float(np.linalg.norm(offset - (offset @ axis) * axis)) <= tol


def _name_conflicts(pairs: list[MirrorPair], sides: dict[str, str], names: list[str]) -> list[str]:
    conflicts = []
    for name in names:
        said = side_of(name)
        if said is not None and sides[name] != said:
            where = {"center": "on the sagittal plane", "left": "on the left (y > 0)",
                     "right": "on the right (y < 0)"}[sides[name]]
            conflicts.append(f"{name}: its name says {said}, its anchor is {where}")
    for pair in pairs:
        if base_of(pair.left) != base_of(pair.right):
            conflicts.append(f"the geometry pairs {pair.left} with {pair.right}, whose names do not match: "
                             "a joint renamed or mislabelled?")
    paired = {(p.left, p.right) for p in pairs}
    by_base: dict[str, dict[str, list[str]]] = {}
    for name in names:
        said = side_of(name)
        if said is not None:
            by_base.setdefault(base_of(name), {}).setdefault(said, []).append(name)
    for base, named in by_base.items():
        if len(named.get("left", [])) == 1 and len(named.get("right", [])) == 1:
            left, right = named["left"][0], named["right"][0]
            if (left, right) not in paired:
                conflicts.append(f"the names pair {left} with {right} but the geometry does not: their anchors "
                                 "or axes are not mirror images")
    return conflicts
