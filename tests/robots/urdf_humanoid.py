"""A small Dynamixel humanoid as a URDF, written on demand for the import tests.

    files = write_humanoid(tmp_path)                     # tmp_path/humanoid.urdf, meshes/
    files = write_humanoid(tmp_path, package=True)       # package:// mesh paths
    files = write_humanoid(tmp_path, inertia_scale={"r_thigh_link": 50.0})

About 0.48 m tall and 2.8 kg, shaped like a 20-servo kit robot: a torso (``base_link``), a
head (pan, tilt), two arms (shoulder pitch, shoulder roll, elbow) ending in a two-finger
gripper on prismatic joints, and two legs (hip yaw, roll, pitch, knee, ankle pitch, roll)
standing on flat box feet.  It reads like a CAD export rather than a textbook: every joint
axis is written in its own link's frame as the CAD tool had it, so some left axes are
antiparallel to the mirror image of the right's (hip yaw and roll, knee, elbow: equal angles
turn the two sides opposite ways), links are named ``r_thigh_link``, ``l_foot_link``, joints
``r_knee_joint``, and the head tilt sits 12 mm off the sagittal plane as a servo horn does.

Collision geometry is boxes and cylinders plus a binary STL prism for each thigh (written
with numpy); the head's visual is an STL of its own.  Inertias are those of the collision
geometry, unless ``inertia_scale`` multiplies a link's or ``unbalanced`` breaks
``A + B >= C`` for a link.  ``missing`` leaves mesh files out, ``xacro=True`` writes a
``.urdf.xacro`` with a property still to expand, ``rename`` renames joints after the fact,
and ``shift`` moves a joint's origin [m] (to break its mirror partner).

:attr:`HumanoidFiles.expected` holds what an import should find for each hinge: side,
location, anatomical axis and sign (anatomical angle = sign * URDF angle).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

PACKAGE = "humanoid_description"
THIGH_LENGTH = 0.09  # [m] hip pitch to knee
SHIN_LENGTH = 0.09  # [m] knee to ankle
STANDING_BASE_HEIGHT = 0.26  # [m] base_link's origin above the soles at the zero pose


@dataclass(frozen=True)
class Role:
    side: str
    location: str
    axis: str
    sign: int
    index: int = 0  # among joints of one side, location and axis along the chain


@dataclass
class HumanoidFiles:
    urdf: Path  # the model file (.urdf, or .urdf.xacro)
    root: Path  # the folder written into
    package_dir: Path | None  # what --package-dir must name for package:// paths
    meshes: list[Path] = field(default_factory=list)  # mesh files referenced (written or not)
    expected: dict[str, Role] = field(default_factory=dict)  # hinge name -> role
    pairs: list[tuple[str, str, int]] = field(default_factory=list)  # (left, right, relative sign)
    mass: float = 0.0  # [kg]
    forward: str = "+x"  # the way the robot faces in the file
    feet: dict[str, str] = field(default_factory=dict)  # side -> the body an import should take as the foot
    hands: dict[str, str] = field(default_factory=dict)  # side -> hand body
    held: list[str] = field(default_factory=list)  # hinges an import should leave out (grippers' fingers)
    servos: dict[str, str] = field(default_factory=dict)  # hinge -> servo model, when a mix was asked for


@dataclass(frozen=True)
class _Link:
    name: str
    mass: float  # [kg]
    shape: tuple  # ("box", (x, y, z)) | ("cylinder", (r, length)) | ("mesh", (file, r, length))
    center: tuple[float, float, float]  # [m] of the geometry and the centre of mass, link frame
    visual: str | None = None  # a mesh file for the visual, else the collision shape


@dataclass(frozen=True)
class _Joint:
    name: str
    kind: str  # revolute | continuous | prismatic | fixed
    parent: str
    child: str
    origin: tuple[float, float, float]  # [m]
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    limits: tuple[float, float] | None = None  # [rad] or [m]
    role: Role | None = None


def _limits(role: Role, anatomical_deg: tuple[float, float]) -> tuple[float, float]:
    """The URDF's limits [rad] of a joint whose anatomical range is ``anatomical_deg``."""
    lo, hi = sorted(math.radians(a) * role.sign for a in anatomical_deg)
    return (lo, hi)


# Spines: (name, axis in the link frame, anatomical axis, sign, index, range [deg]); five
# joints as Poppy's (abs_y, abs_x, abs_z, bust_y, bust_x: a pitch and a roll twice)
SPINE = (("abs_y", (0, 1, 0), "pitch", 1, 0, (-20, 40)), ("abs_x", (-1, 0, 0), "roll", -1, 0, (-20, 20)),
         ("abs_z", (0, 0, 1), "yaw", 1, 0, (-40, 40)), ("bust_y", (0, -1, 0), "pitch", -1, 1, (-20, 40)),
         ("bust_x", (1, 0, 0), "roll", 1, 1, (-20, 20)))
SPINE_STEP = 0.012  # [m] between spine joints
SPINE_START = 0.03  # [m] the first spine joint above the base's origin


def _humanoid(spine: int = 0, leg: int = 6, gripper: str = "slide",
              wrist: bool = False) -> tuple[list[_Link], list[_Joint]]:
    """Links and joints of the humanoid; ``spine`` joints between a pelvis (the base) and a
    chest, ``leg`` 6 or 5 joints (no ankle roll), fingers on slides or hinges, a wrist."""
    if spine:
        top = SPINE_START + SPINE_STEP * (spine - 1)  # the chest's origin above the base's
        trunk = "chest_link"
        links = [_Link("base_link", 0.35, ("box", (0.08, 0.12, 0.05)), (0.0, 0.0, 0.0)),
                 _Link("chest_link", 0.50, ("box", (0.08, 0.12, 0.09)), (0.0, 0.0, 0.075 - top))]
        joints = []
        parent = "base_link"
        for i, (name, axis, role_axis, sign, index, rng) in enumerate(SPINE[:spine]):
            child = "chest_link" if i == spine - 1 else f"spine{i + 1}_link"
            if child != "chest_link":
                links.append(_Link(child, 0.015, ("box", (0.02, 0.02, 0.008)), (0.0, 0.0, 0.0)))
            role = Role("center", "waist", role_axis, sign, index)
            joints.append(_Joint(name, "revolute", parent, child, (0.0, 0.0, SPINE_START if i == 0 else SPINE_STEP),
                                 axis, _limits(role, rng), role))
            parent = child
    else:
        top, trunk = 0.0, "base_link"
        links = [_Link("base_link", 0.90, ("box", (0.08, 0.12, 0.16)), (0.0, 0.0, 0.05))]
        joints = []
    links += [_Link("neck_link", 0.03, ("cylinder", (0.012, 0.025)), (0.0, 0.0, 0.0125)),
              _Link("head_link", 0.12, ("box", (0.06, 0.06, 0.06)), (0.0, -0.012, 0.035), visual="head.stl")]
    pan = Role("center", "neck", "yaw", 1)
    tilt = Role("center", "neck", "pitch", -1)
    joints += [_Joint("head_pan", "continuous", trunk, "neck_link", (0.0, 0.0, 0.13 - top), (0, 0, 1), None, pan),
               _Joint("head_tilt", "revolute", "neck_link", "head_link", (0.0, 0.012, 0.025), (0, -1, 0),
                      _limits(tilt, (-30, 60)), tilt)]
    for p, side, s in (("r", "right", -1), ("l", "left", 1)):
        # Axes as the CAD tool wrote them: (right, left) in each link's frame.  Signs follow
        # from the anatomical convention (sim2real.simulation.model.builder._AXES).
        def j(name, kind, parent, child, origin, axis, role_axis, location, sign, rng=None):
            role = Role(side, location, role_axis, sign) if kind in ("revolute", "continuous") else None
            return _Joint(f"{p}_{name}", kind, parent, child, origin, axis,
                          _limits(role, rng) if rng is not None and role is not None else None, role)

        right = side == "right"
        links += [
            _Link(f"{p}_pelvis_link", 0.03, ("box", (0.03, 0.03, 0.02)), (0.0, 0.0, -0.01)),
            _Link(f"{p}_hip_link", 0.12, ("box", (0.04, 0.035, 0.045)), (0.0, 0.0, -0.01)),
            _Link(f"{p}_thigh_link", 0.15, ("mesh", ("thigh.stl", 0.022, THIGH_LENGTH)),
                  (0.0, 0.0, -THIGH_LENGTH / 2), visual="thigh.stl"),
            _Link(f"{p}_shin_link", 0.12, ("box", (0.035, 0.04, SHIN_LENGTH)), (0.0, 0.0, -SHIN_LENGTH / 2)),
            _Link(f"{p}_ankle_link", 0.12, ("box", (0.035, 0.035, 0.03)), (0.0, 0.0, 0.0)),
            _Link(f"{p}_foot_link", 0.08, ("box", (0.11, 0.065, 0.01)), (0.01, s * 0.005, -0.03)),
            _Link(f"{p}_shoulder_link", 0.03, ("box", (0.03, 0.02, 0.03)), (0.0, s * 0.01, 0.0)),
            _Link(f"{p}_upper_arm_link", 0.10, ("cylinder", (0.015, 0.08)), (0.0, 0.0, -0.04)),
            _Link(f"{p}_forearm_link", 0.08, ("box", (0.03, 0.03, 0.07)), (0.0, 0.0, -0.035)),
            _Link(f"{p}_gripper_palm_link", 0.04, ("box", (0.03, 0.04, 0.015)), (0.0, 0.0, -0.0075)),
            _Link(f"{p}_gripper_finger1_link", 0.01, ("box", (0.01, 0.005, 0.03)), (0.0, 0.0, -0.015)),
            _Link(f"{p}_gripper_finger2_link", 0.01, ("box", (0.01, 0.005, 0.03)), (0.0, 0.0, -0.015)),
        ]
        joints += [
            j("hip_yaw_joint", "revolute", "base_link", f"{p}_pelvis_link", (0.0, s * 0.04, -0.02),
              (0, 0, 1), "yaw", "hip", -1 if right else 1, (-30, 30)),
            j("hip_roll_joint", "revolute", f"{p}_pelvis_link", f"{p}_hip_link", (0.0, 0.0, -0.025),
              (1, 0, 0), "roll", "hip", -1 if right else 1, (-20, 40)),
            j("hip_pitch_joint", "revolute", f"{p}_hip_link", f"{p}_thigh_link", (0.0, 0.0, 0.0),
              (0, 1, 0), "pitch", "hip", -1, (-30, 100)),
            j("knee_joint", "revolute", f"{p}_thigh_link", f"{p}_shin_link", (0.0, 0.0, -THIGH_LENGTH),
              (0, 1, 0) if right else (0, -1, 0), "pitch", "knee", 1 if right else -1, (0, 130)),
            j("ankle_pitch_joint", "revolute", f"{p}_shin_link", f"{p}_ankle_link", (0.0, 0.0, -SHIN_LENGTH),
              (0, -1, 0), "pitch", "ankle", 1, (-40, 50)),
            j("ankle_roll_joint", "revolute" if leg == 6 else "fixed", f"{p}_ankle_link", f"{p}_foot_link",
              (0.0, 0.0, 0.0), (1, 0, 0) if right else (-1, 0, 0), "roll", "ankle", -1, (-25, 20)),
            j("shoulder_pitch_joint", "revolute", trunk, f"{p}_shoulder_link", (0.0, s * 0.075, 0.11 - top),
              (0, 1, 0), "pitch", "shoulder", -1, (-60, 180)),
            j("shoulder_roll_joint", "revolute", f"{p}_shoulder_link", f"{p}_upper_arm_link", (0.0, s * 0.02, 0.0),
              (1, 0, 0) if right else (-1, 0, 0), "roll", "shoulder", -1, (-10, 100)),
            j("elbow_joint", "revolute", f"{p}_upper_arm_link", f"{p}_forearm_link", (0.0, 0.0, -0.08),
              (0, 1, 0) if right else (0, -1, 0), "pitch", "elbow", -1 if right else 1, (0, 120)),
            # a wrist turning about the forearm (a yaw with the arm hanging), or the palm fixed
            j("wrist_joint" if wrist else "gripper_joint", "revolute" if wrist else "fixed", f"{p}_forearm_link",
              f"{p}_gripper_palm_link",
              (0.0, 0.0, -0.07), (0, 0, 1), "yaw", "wrist", -1 if right else 1, (-90, 90)),
        ]
        if gripper == "slide":
            joints += [_Joint(f"{p}_gripper_finger1_joint", "prismatic", f"{p}_gripper_palm_link",
                              f"{p}_gripper_finger1_link", (0.0, 0.012, -0.015), (0, 1, 0), (-0.01, 0.0)),
                       _Joint(f"{p}_gripper_finger2_joint", "prismatic", f"{p}_gripper_palm_link",
                              f"{p}_gripper_finger2_link", (0.0, -0.012, -0.015), (0, -1, 0), (-0.01, 0.0))]
        else:  # two jaws on hinges: a hand that parts into fingers, no role of the project's
            joints += [_Joint(f"{p}_gripper_finger{k}_joint", "revolute", f"{p}_gripper_palm_link",
                              f"{p}_gripper_finger{k}_link", (0.0, y, -0.015), (1, 0, 0), (-0.5, 0.5))
                       for k, y in ((1, 0.012), (2, -0.012))]
    return links, joints


def _inertia(link: _Link) -> tuple[float, float, float]:
    """Principal moments [kg m^2] of the link's collision shape at its mass, about its centre."""
    kind, size = link.shape
    m = link.mass
    if kind == "box":
        x, y, z = size
        return (m * (y * y + z * z) / 12, m * (x * x + z * z) / 12, m * (x * x + y * y) / 12)
    r, length = size[-2:]  # a cylinder, or the mesh's prism taken as one
    side = m * (3 * r * r + length * length) / 12
    return (side, side, m * r * r / 2)


def write_prism_stl(path: Path, radius: float, length: float, sides: int = 6) -> None:
    """A closed ``sides``-gon prism along -z from 0 to -``length`` [m], as binary STL."""
    angles = np.arange(sides) * 2 * np.pi / sides
    ring = np.stack([radius * np.cos(angles), radius * np.sin(angles)], axis=1)
    top = np.column_stack([ring, np.zeros(sides)])
    bottom = np.column_stack([ring, np.full(sides, -length)])
    triangles = []
    for i in range(sides):
        k = (i + 1) % sides
        triangles += [(top[i], bottom[i], bottom[k]), (top[i], bottom[k], top[k])]  # outward
        triangles += [(np.zeros(3), top[k], top[i]), (np.array([0, 0, -length]), bottom[i], bottom[k])]
    tri = np.array(triangles, dtype=np.float32)  # (n, 3, 3)
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    record = np.zeros(len(tri), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    record["n"], record["v"] = normals, tri
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as f:
        f.write(b"prism for the URDF humanoid test robot".ljust(80, b" "))
        f.write(struct.pack("<I", len(tri)))
        f.write(record.tobytes())


def _fmt(values) -> str:
    return " ".join(f"{v:.6g}" for v in values)


# Darwin-OP's joint names (ROBOTIS's darwin.urdf), side as a suffix; the wrist and jaws as such a kit adds them
DARWIN = {"hip_yaw_joint": "j_pelvis", "hip_roll_joint": "j_thigh1", "hip_pitch_joint": "j_thigh2",
          "knee_joint": "j_tibia", "ankle_pitch_joint": "j_ankle1", "ankle_roll_joint": "j_ankle2",
          "shoulder_pitch_joint": "j_shoulder", "shoulder_roll_joint": "j_high_arm", "elbow_joint": "j_low_arm",
          "wrist_joint": "j_wrist", "gripper_finger1_joint": "j_gripper1", "gripper_finger2_joint": "j_gripper2",
          "head_pan": "j_pan", "head_tilt": "j_tilt"}
MIXED_SERVOS = {"legs": "MX-28(2.0)", "neck": "AX-12A"}  # and XM430-W350 elsewhere: --servo WHERE=MODEL
FACING_YAW_DEG = {"+x": 0.0, "+y": 90.0, "-x": 180.0, "-y": -90.0}
# The class of humanoids the tests import (write_humanoid's options): each option value at
# least once, each facing with more than one other option
VARIANTS = [
    dict(names="numbered", forward="+y", spine=5, leg=5, gripper="hinge", wrist=True),
    dict(names="darwin", forward="-x", spine=3, leg=6, gripper="hinge", wrist=False),
    dict(names="numbered", forward="-y", spine=0, leg=6, gripper="slide", wrist=True),
    dict(names="darwin", forward="+y", spine=5, leg=6, gripper="slide", wrist=True, mixed_servos=True),
    dict(names="words", forward="-y", spine=3, leg=5, gripper="hinge", wrist=True),
    dict(names="numbered", forward="+x", spine=3, leg=6, gripper="hinge", wrist=False, mixed_servos=True),
    dict(names="darwin", forward="+x", spine=0, leg=5, gripper="slide", wrist=False),
]


def variant_id(v: dict) -> str:
    """A variant's test id: ``numbered-+y-spine5-leg5-hinge-wrist``."""
    return "-".join(f"{v[k]}" for k in ("names", "forward")) + f"-spine{v['spine']}-leg{v['leg']}-{v['gripper']}" \
        + ("-wrist" if v["wrist"] else "") + ("-mixed" if v.get("mixed_servos") else "")


def servo_args(variant: dict) -> list[str]:
    """The ``--servo`` flags a user of this variant passes to ``biped robot import``."""
    mixed = [a for where, model in MIXED_SERVOS.items() for a in ("--servo", f"{where}={model}")]
    return ["--servo", "XM430-W350"] + (mixed if variant.get("mixed_servos") else [])


def _names(scheme: str, links: list[_Link], joints: list[_Joint]) -> tuple[dict[str, str], dict[str, str]]:
    """(joint, link) renames of a naming ``scheme``: ``words`` (as built), ``darwin``, ``numbered``."""
    if scheme == "words":
        return {}, {}
    if scheme == "numbered":  # no word of anatomy anywhere: j1..jN, b1..bN (the base keeps its name)
        return ({j.name: f"j{i + 1}" for i, j in enumerate(joints)},
                {link.name: f"b{i}" for i, link in enumerate(links) if link.name != "base_link"})
    if scheme != "darwin":
        raise ValueError(f"names: words, darwin or numbered, got {scheme!r}")
    out = {}
    for j in joints:
        side, _, base = j.name.partition("_")
        if side in ("l", "r") and base in DARWIN:
            out[j.name] = f"{DARWIN[base]}_{side}"
        elif j.name in DARWIN:
            out[j.name] = DARWIN[j.name]
    return out, {}


def write_humanoid(folder: Path, *, package: bool = False, xacro: bool = False,
                   missing: tuple[str, ...] = (), inertia_scale: dict[str, float] | None = None,
                   unbalanced: tuple[str, ...] = (), rename: dict[str, str] | None = None,
                   shift: dict[str, tuple[float, float, float]] | None = None, names: str = "words",
                   forward: str = "+x", spine: int = 0, leg: int = 6, gripper: str = "slide",
                   wrist: bool = False, mixed_servos: bool = False) -> HumanoidFiles:
    """Write the humanoid into ``folder`` and say what it holds.

    ``package``: meshes as ``package://humanoid_description/meshes/...`` with the URDF in
    ``humanoid_description/urdf/`` (``files.package_dir`` is the folder to give as the
    package root); otherwise ``meshes/...`` beside the URDF.  ``missing``: mesh file names
    (``thigh.stl``, ``head.stl``) not to write.  ``inertia_scale``: link -> factor on its
    inertia.  ``unbalanced``: links whose inertia breaks ``A + B >= C``.  ``rename``: joint
    -> new name.  ``shift``: joint -> offset [m] added to its origin.

    The class of humanoids: ``names`` ``words`` (``r_knee_joint``), ``darwin``
    (``j_tibia_r``) or ``numbered`` (``j1``..., links ``b1``...); ``forward``: the whole robot
    turned about z to face ``+x``, ``-x``, ``+y`` or ``-y``; ``spine``: 0, 3 or 5 joints
    between a pelvis and a chest (5: Poppy's, a pitch and a roll twice); ``leg``: 6 joints or
    5 (no ankle roll); ``gripper``: fingers on ``slide`` or ``hinge`` joints (held either way);
    ``wrist``: a wrist joint; ``mixed_servos``: ``files.servos`` gives MX-28 legs and an AX-12A
    neck (:data:`MIXED_SERVOS`)."""
    folder = Path(folder)
    links, joints = _humanoid(spine, leg, gripper, wrist)
    inertia_scale, rename, shift = inertia_scale or {}, rename or {}, shift or {}
    joint_names, link_names = _names(names, links, joints)
    rename = {**joint_names, **rename}
    link_name = lambda name: link_names.get(name, name)  # noqa: E731
    yaw = math.radians(FACING_YAW_DEG[forward])
    if package:
        pkg = folder / PACKAGE
        urdf_dir, mesh_dir, package_dir = pkg / "urdf", pkg / "meshes", folder
        mesh_ref = f"package://{PACKAGE}/meshes/"
    else:
        urdf_dir, package_dir = folder, None
        mesh_dir, mesh_ref = folder / "meshes", "meshes/"
    urdf_dir.mkdir(parents=True, exist_ok=True)
    files = HumanoidFiles(urdf_dir / ("humanoid.urdf.xacro" if xacro else "humanoid.urdf"), folder, package_dir,
                          forward=forward)
    for name in ("thigh.stl", "head.stl"):
        path = mesh_dir / name
        files.meshes.append(path)
        if name not in missing:
            radius, length = (0.022, THIGH_LENGTH) if name == "thigh.stl" else (0.035, 0.06)
            write_prism_stl(path, radius, length)

    out = ['<?xml version="1.0"?>',
           '<robot name="humanoid"' + (' xmlns:xacro="http://www.ros.org/wiki/xacro"' if xacro else "") + ">"]
    if xacro:
        out.append(f'  <xacro:property name="thigh_length" value="{THIGH_LENGTH}"/>')
    for link in links:
        out += _link_xml(link, mesh_ref, inertia_scale.get(link.name, 1.0), link.name in unbalanced,
                         link_name(link.name), yaw if link.name == "base_link" else 0.0)
    for joint in joints:
        name = rename.get(joint.name, joint.name)
        origin = np.add(joint.origin, shift.get(joint.name, (0.0, 0.0, 0.0)))
        turn = yaw if joint.parent == "base_link" else 0.0  # the base's children turn the whole robot
        xyz = "0 0 -${thigh_length}" if xacro and joint.name.endswith("knee_joint") else \
            _fmt(_turned(origin, turn) if turn else origin)
        out.append(f'  <joint name={quoteattr(name)} type="{joint.kind}">')
        out.append(f'    <parent link="{link_name(joint.parent)}"/>\n    <child link="{link_name(joint.child)}"/>')
        out.append(f'    <origin xyz="{xyz}" rpy="0 0 {turn:.9g}"/>')
        if joint.kind != "fixed":
            out.append(f'    <axis xyz="{_fmt(joint.axis)}"/>')
        if joint.limits is not None:
            out.append(f'    <limit lower="{joint.limits[0]:.6g}" upper="{joint.limits[1]:.6g}" '
                       f'effort="4.1" velocity="4.8"/>')
        elif joint.kind == "continuous":
            out.append('    <limit effort="4.1" velocity="4.8"/>')
        out.append("  </joint>")
        if joint.role is not None:
            files.expected[name] = joint.role
            if mixed_servos:
                group = "legs" if joint.role.location in ("hip", "knee", "ankle") else joint.role.location
                files.servos[name] = MIXED_SERVOS.get(group, "XM430-W350")
        elif joint.kind == "revolute":
            files.held.append(name)
    out.append("</robot>\n")
    files.urdf.write_text("\n".join(out))
    files.mass = sum(link.mass for link in links)
    for left in (j for j in joints if j.role is not None and j.role.side == "left"):
        right = next(j for j in joints if j.name == "r" + left.name[1:])
        files.pairs.append((rename.get(left.name, left.name), rename.get(right.name, right.name),
                            left.role.sign * right.role.sign))
    for p, side in (("l", "left"), ("r", "right")):
        files.feet[side] = link_name(f"{p}_foot_link" if leg == 6 else f"{p}_ankle_link")  # a fixed joint fuses
        files.hands[side] = link_name(f"{p}_gripper_palm_link" if wrist else f"{p}_forearm_link")
    return files


def _turned(xyz, yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    x, y, z = xyz
    return np.array([c * x - s * y, s * x + c * y, z])


def _link_xml(link: _Link, mesh_ref: str, scale: float, unbalanced: bool, name: str | None = None,
              yaw: float = 0.0) -> list[str]:
    """A link's XML; ``yaw`` [rad] turns its geometry and inertia about z (the base of a
    robot turned to face another way)."""
    ixx, iyy, izz = (scale * i for i in _inertia(link))
    if unbalanced:  # A + B < C: what a hand-typed or mis-exported inertia looks like
        ixx, iyy, izz = ixx / 10, iyy / 10, ixx + iyy
    kind, size = link.shape
    centre = _fmt(_turned(link.center, yaw)) if yaw else _fmt(link.center)
    if kind == "box":
        geometry = f'<box size="{_fmt(size)}"/>'
        origin = centre
    elif kind == "cylinder":
        geometry = f'<cylinder radius="{size[0]:.6g}" length="{size[1]:.6g}"/>'
        origin = centre
    else:  # the prism's own frame starts at the joint and runs down
        geometry = f'<mesh filename="{mesh_ref}{size[0]}"/>'
        origin = "0 0 0"
    visual = f'<mesh filename="{mesh_ref}{link.visual}"/>' if link.visual else geometry
    visual_origin = "0 0 0" if link.visual else origin
    rpy = f"0 0 {yaw:.9g}"
    return [
        f'  <link name="{name or link.name}">',
        f'    <inertial>\n      <origin xyz="{centre}" rpy="{rpy}"/>\n'
        f'      <mass value="{link.mass:.6g}"/>\n'
        f'      <inertia ixx="{ixx:.6g}" ixy="0" ixz="0" iyy="{iyy:.6g}" iyz="0" izz="{izz:.6g}"/>\n    </inertial>',
        f'    <visual>\n      <origin xyz="{visual_origin}" rpy="{rpy}"/>\n'
        f'      <geometry>{visual}</geometry>\n    </visual>',
        f'    <collision>\n      <origin xyz="{origin}" rpy="{rpy}"/>\n      <geometry>{geometry}</geometry>\n'
        f'    </collision>',
        "  </link>",
    ]
