"""``biped robot import``: a starting robot YAML from a user's MJCF or URDF, and a report.

    result = import_robot("op3.xml", "configs/robots/op3.yaml", servo="XM430-W350")
    print("\\n".join(result.report()))
    write_robot_yaml(result)          # sim2real.robot.import_yaml: every guess commented

What it infers, at the model's zero pose (``qpos0``):

* each hinge's side, and its mirror partner, from the geometry (:mod:`sim2real.simulation.model_mirror`);
* its location from its name's words (``hip``, ``kn``/``knee``, ``ank``, ``sho``, ``el``/``elbow``,
  ``wrist``, ``head``/``neck``, ``waist``/``torso``: :mod:`.joint_names`);
* its axis (yaw, roll, pitch) as the principal direction nearest its world axis (refused past
  ``MAX_AXIS_OFF_DEG``), and its sign, anatomical angle = sign * model angle, from the dot of
  its world axis with the anatomical axis of its side, location and axis (``ANATOMICAL_AXES``);
* its range from the model's (turned anatomical by the sign), or +-90 deg where the model
  sets none; its home from a keyframe named ``home``, else 0; servo IDs 1, 2, ... in model order;
* the root (the body with the free joint, or a URDF's base), the IMU at the root's origin, each
  foot as the lowest body with collision geometry below that side's leg joints, each hand as
  the distal body of that side's arm joints.

A joint it cannot place (no location in its name, a role the project does not know, an axis
far from every principal one, a slide or ball joint) is left out of ``joints`` and so held at
its home pose by the model builder; the report and the YAML's comments say which and why.

Only :func:`import_robot` needs MuJoCo (imported inside it): the rest is plain data, so this
package still imports without MuJoCo.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Iterable, Sequence

from sim2real.robot.anatomy import ANATOMICAL_AXES, anatomical_axis
from sim2real.robot.joint_names import axis_of, location_of, locations_in, words
from sim2real.robot.spec import ARM_LOCATIONS, CENTER_LOCATIONS, LEG_LOCATIONS

if TYPE_CHECKING:  # pragma: no cover
    from sim2real.simulation.model_inertias import InertiaProblem
    from sim2real.simulation.model_mirror import MirrorInference

DEFAULT_SERVO = "XL430-W250-T"
DEFAULT_BUS = ("/dev/ttyUSB0", 1_000_000)
DEFAULT_SENSOR_BOARD = ("BIPED-FOOT-BOARD", 200)
MAX_AXIS_OFF_DEG = 30.0  # a hinge farther than this from every principal axis has no role
UNLIMITED_RANGE_DEG = 90.0  # the range guessed for a joint the model leaves unlimited
GUESSED = "guessed: check"
_PRINCIPAL = {"roll": (1.0, 0.0, 0.0), "pitch": (0.0, 1.0, 0.0), "yaw": (0.0, 0.0, 1.0)}


def servo_model_name(name: str) -> str:
    """The canonical model name of a servo profile in ``firmware_profiles/`` (``xm430-w350``
    gives ``XM430-W350``); KeyError naming the servo models there otherwise."""
    from sim2real.robot.profiles import available_profiles, load_profile

    try:
        profile = load_profile(name)
    except KeyError:
        profile = None
    if profile is None or not profile.is_servo:
        servos = [m for m in available_profiles() if load_profile(m).is_servo]
        raise KeyError(f"{name!r} is no servo profile (servos: {', '.join(servos)})")
    return profile.model


# -- what the model holds, as plain data -------------------------------------------------------
@dataclass(frozen=True)
class Hinge:
    """A hinge of the model at its zero pose: world anchor [m] and unit axis, range [rad] or
    None when unlimited, keyframe home [rad], and the body it moves."""

    name: str
    anchor: tuple[float, float, float]
    axis: tuple[float, float, float]
    range_rad: tuple[float, float] | None
    home_rad: float
    body: str


@dataclass(frozen=True)
class Body:
    """A body at the zero pose: its parent, depth below the world, and the lowest point [m]
    of its collision geometry (None without any)."""

    name: str
    parent: str | None
    depth: int
    lowest_z: float | None


# -- what the import infers --------------------------------------------------------------------
@dataclass(frozen=True)
class JointGuess:
    name: str
    side: str
    location: str
    axis: str
    sign: int
    range_deg: tuple[float, float]
    home_deg: float
    servo_id: int
    notes: tuple[str, ...] = ()  # what to check, as YAML comments


@dataclass
class ImportResult:
    """Everything ``biped robot import`` inferred, and what it could not."""

    model_file: Path
    output: Path
    kind: str  # mjcf | urdf
    servo_model: str
    package_dirs: tuple[Path, ...]
    root: str
    joints: list[JointGuess]
    held: list[tuple[str, str]]  # joint, why it is not mapped
    feet: dict[str, str]  # side -> body
    hands: dict[str, str]
    mirror: "MirrorInference"
    inertia_problems: list["InertiaProblem"] = field(default_factory=list)
    inertias: str = "as_given"  # or from_geometry
    inertias_why: str = ""
    missing_visual_meshes: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # anything else a person must read

    def report(self) -> list[str]:
        """What was inferred and what was not, in sentences."""
        lines = [f"{self.model_file} ({self.kind.upper()}): root {self.root}, {len(self.joints)} joints mapped, "
                 f"{len(self.held)} held"]
        lines += self.mirror.report()
        lines.append("roles (anatomical angle = sign * model angle):")
        for j in self.joints:
            lo, hi = (number_text(a) for a in j.range_deg)
            lines.append(f"  {j.name}: {j.side} {j.location} {j.axis}, sign {j.sign:+d}, range [{lo}, {hi}] deg, "
                         f"servo id {j.servo_id}" + "".join(f"; {n}" for n in j.notes))
        for name, why in self.held:
            lines.append(f"held (not mapped): {name}: {why}")
        for side in ("left", "right"):
            lines.append(f"{side} foot: {self.feet.get(side, 'NOT FOUND: set model.feet.' + side)}")
        if self.hands:
            lines.append("hands: " + ", ".join(f"{s} {b}" for s, b in self.hands.items()))
        lines.append(f"imu: at the origin of {self.root}")
        for p in self.inertia_problems:
            lines.append(f"implausible inertia: {p}")
        if self.inertias_why:
            lines.append(f"inertias: {self.inertias} ({self.inertias_why})")
        for m in self.missing_visual_meshes:
            lines.append(f"missing visual mesh (the model loads without it): {m}")
        lines += self.notes
        return lines


def infer_joints(hinges: Sequence[Hinge], mirror: "MirrorInference",
                 servo_reach_deg: float = 180.0) -> tuple[list[JointGuess], list[tuple[str, str]]]:
    """Each hinge's role, sign, range and home, or why it has none; servo IDs 1.. in order.
    ``servo_reach_deg``: how far the servo turns either way from its centre [deg]; a range
    beyond it is cut to it (servo angle = model angle, as ROBOTIS's robots map them)."""
    joints: list[JointGuess] = []
    held: list[tuple[str, str]] = []
    for hinge in hinges:
        guess = _role(hinge, mirror.sides[hinge.name])
        if isinstance(guess, str):
            held.append((hinge.name, guess))
            continue
        side, location, axis, sign, notes = guess
        lo, hi, home, more = _range_and_home(hinge, sign, servo_reach_deg)
        joints.append(JointGuess(hinge.name, side, location, axis, sign, (lo, hi), home, len(joints) + 1,
                                 tuple(notes + more)))
    roles = {j.name: j for j in joints}
    for pair in mirror.pairs:
        left, right = roles.get(pair.left), roles.get(pair.right)
        if left is None or right is None:
            continue
        if (left.location, left.axis) != (right.location, right.axis):
            for this, other in ((left, right), (right, left)):
                roles[this.name] = _with_note(this, f"{GUESSED}: its mirror partner {other.name} is a "
                                              f"{other.location} {other.axis}")
    return [roles[j.name] for j in joints], held


def _role(hinge: Hinge, side: str) -> tuple[str, str, str, int, list[str]] | str:
    """(side, location, axis, sign, notes) of a hinge, or why it has no role."""
    found = locations_in(hinge.name)
    if len(found) > 1:
        return f"its name points to several locations ({', '.join(found)})"
    location = location_of(hinge.name)
    if location is None:
        return f"no location in its name (words: {', '.join(words(hinge.name)) or 'none'})"
    if location in CENTER_LOCATIONS and side != "center":
        return f"a {location} joint off the sagittal plane ({side}): the project's {location} joints are central"
    if location not in CENTER_LOCATIONS and side == "center":
        return f"a {location} joint on the sagittal plane: which side is it?"
    u = hinge.axis
    dots = {a: abs(sum(p * q for p, q in zip(u, v))) for a, v in _PRINCIPAL.items()}
    axis = max(dots, key=dots.get)
    off = math.degrees(math.acos(min(1.0, dots[axis])))
    if off > MAX_AXIS_OFF_DEG:
        return (f"its axis ({_vec(u)}) is {off:.0f} deg from the nearest principal axis ({axis}): "
                f"more than {MAX_AXIS_OFF_DEG:g} deg")
    if (location, axis) not in ANATOMICAL_AXES:
        known = ", ".join(a for (loc, a) in ANATOMICAL_AXES if loc == location)
        article = "an" if location[0] in "aeiou" else "a"
        return f"{article} {location} {axis} is not a role the project knows ({location}: {known})"
    notes = []
    if off > 5.0:
        notes.append(f"axis {off:.0f} deg off the {axis} axis")
    said = axis_of(hinge.name)
    if said is not None and said != axis:
        notes.append(f"its name says {said}, its axis is a {axis}")
    dot = sum(p * q for p, q in zip(u, anatomical_axis(side, location, axis)))
    return side, location, axis, 1 if dot > 0 else -1, notes


def _range_and_home(hinge: Hinge, sign: int, reach_deg: float = 180.0) -> tuple[float, float, float, list[str]]:
    notes = []
    if hinge.range_rad is None:
        lo, hi = -UNLIMITED_RANGE_DEG, UNLIMITED_RANGE_DEG
        notes.append(f"unlimited in the model: range {GUESSED}")
    else:
        lo, hi = sorted(round(math.degrees(sign * r), 1) for r in hinge.range_rad)
        reach = math.floor(reach_deg * 10) / 10  # a tenth of a degree inside the servo's reach
        if lo < -reach or hi > reach:
            notes.append(f"the model's range [{number_text(lo)}, {number_text(hi)}] deg is cut to the servo's "
                         f"+-{number_text(reach)} deg")
            lo, hi = max(lo, -reach), min(hi, reach)
    home = round(math.degrees(sign * hinge.home_rad), 1)
    if not lo <= home <= hi:
        inside = min(max(home, lo), hi)
        notes.append(f"home {number_text(home)} deg is outside the range: set to {number_text(inside)}")
        home = inside
    return lo, hi, home + 0.0, notes


def number_text(value: float) -> str:
    """A number as a person writes it: ``30``, ``-12.5``."""
    return f"{value:g}" if value != int(value) else str(int(value))


def _vec(values) -> str:
    return ", ".join(f"{v:.3f}" for v in values)


def _with_note(j: JointGuess, note: str) -> JointGuess:
    return JointGuess(j.name, j.side, j.location, j.axis, j.sign, j.range_deg, j.home_deg, j.servo_id,
                      (*j.notes, note))


def find_feet(bodies: dict[str, Body], joints: Sequence[JointGuess], moved: dict[str, str]) -> dict[str, str]:
    """Per side, the body with collision geometry reaching lowest among those the side's leg
    joints move (the more distal of two within 1 mm); ``moved``: joint -> body it moves."""
    feet = {}
    for side in ("left", "right"):
        below = _subtrees(bodies, [moved[j.name] for j in joints if j.side == side and j.location in LEG_LOCATIONS])
        candidates = [bodies[b] for b in below if bodies[b].lowest_z is not None]
        if candidates:
            low = min(b.lowest_z for b in candidates)
            feet[side] = max((b for b in candidates if b.lowest_z <= low + 1e-3), key=lambda b: b.depth).name
    return feet


def find_hands(bodies: dict[str, Body], joints: Sequence[JointGuess], moved: dict[str, str]) -> dict[str, str]:
    """Per side, the body the most distal arm joint moves, or where its branches (fingers) part."""
    hands = {}
    for side in ("left", "right"):
        arm = [moved[j.name] for j in joints if j.side == side and j.location in ARM_LOCATIONS]
        if not arm:
            continue
        start = max(arm, key=lambda b: bodies[b].depth)
        below = _subtrees(bodies, [start])
        hand = start
        while True:  # down the chain while it has one child: a fused palm, a wrist link
            children = [b for b in below if bodies[b].parent == hand]
            if len(children) != 1:
                break
            hand = children[0]
        hands[side] = hand
    return hands


def _subtrees(bodies: dict[str, Body], roots: Iterable[str]) -> list[str]:
    roots = set(roots)
    found = []
    for name in bodies:  # bodies are in tree order: a parent before its children
        if name in roots or (bodies[name].parent in found):
            found.append(name)
    return found


# -- from a model file ---------------------------------------------------------------------------
def import_robot(model_file: Path | str, output: Path | str, *, servo: str = DEFAULT_SERVO,
                 package_dirs: Iterable[Path | str] = (), recompute_inertias: bool = False) -> ImportResult:
    """Read ``model_file`` (MJCF or URDF) and infer the robot YAML for ``output`` (not written:
    :func:`write_robot_yaml`).  Refusals are :class:`~sim2real.errors.ConfigError` naming the file."""
    from sim2real.robot.profiles import load_profile
    from sim2real.simulation import model_files as mf
    from sim2real.simulation import model_inertias
    from sim2real.simulation.model_mirror import mirror_pairs

    model_file, output = Path(model_file), Path(output)
    dirs = tuple(Path(d).expanduser() for d in package_dirs)
    servo_model = servo_model_name(servo)
    kind = mf.model_format(model_file)
    spec = mf.load_model_spec(model_file, dirs, drop_visuals=True)  # visuals play no part here
    root = mf.root_body(spec)
    problems = model_inertias.implausible_inertias(spec, source=str(model_file))
    inertias, why = "as_given", ""
    if recompute_inertias:
        inertias, why = "from_geometry", "from --recompute-inertias"
    elif any(p.unbalanced for p in problems):
        inertias, why = "from_geometry", (f"{GUESSED}: some inertias break A + B >= C, which MuJoCo refuses; "
                                          "as_given would not compile")
    elif problems:
        names = ", ".join(p.body for p in problems[:4]) + (", ..." if len(problems) > 4 else "")
        why = f"implausible inertias on {names} (see the report): consider from_geometry"
    if inertias == "from_geometry":
        model_inertias.recompute_inertias(spec)
    mf.add_free_joint(spec, root)
    model = mf.compile_model(spec, str(model_file))
    mirror = mirror_pairs(model)
    hinges, bodies, others = _model_facts(model)
    moved = {h.name: h.body for h in hinges}
    profile = load_profile(servo_model)
    reach = min(abs(a) for a in profile.position.range_rad)
    joints, held = infer_joints(hinges, mirror, math.degrees(reach))
    if not joints:
        from sim2real.errors import ConfigError

        raise ConfigError(str(model_file), "", "no hinge could be given a role: " + "; ".join(
            f"{name}: {why}" for name, why in held[:6]) + ("; ..." if len(held) > 6 else ""))
    held += others
    result = ImportResult(model_file, output, kind, servo_model, dirs, root, joints, held,
                          find_feet(bodies, joints, moved), find_hands(bodies, joints, moved), mirror,
                          problems, inertias, why, mf.missing_meshes(model_file, dirs))
    if not any(j.location in LEG_LOCATIONS for j in joints):
        result.notes.append("no leg joint (hip, knee, ankle) was recognised: name them in the YAML by hand")
    result.notes += _backward_knees(joints)
    return result


def _backward_knees(joints: Sequence[JointGuess]) -> list[str]:
    """A knee whose anatomical range is mostly negative bends backwards: the model faces -x, or
    the knee's name or axis is off (a robot's knee flexes, pitch > 0, far more than it extends)."""
    return [f"{j.name}: its range [{number_text(j.range_deg[0])}, {number_text(j.range_deg[1])}] deg is mostly "
            "negative, a knee bending backwards: does the model face -x (the convention is +x)?"
            for j in joints if j.location == "knee" and -j.range_deg[0] > j.range_deg[1]]


def _model_facts(model) -> tuple[list[Hinge], dict[str, Body], list[tuple[str, str]]]:
    """Hinges and bodies of the compiled model at qpos0, and the other joints (slide, ball)
    with why they are held."""
    import mujoco
    import numpy as np

    from sim2real.simulation.robot_model import is_collision_geom

    data = mujoco.MjData(model)
    key = next((k for k in range(model.nkey) if model.key(k).name == "home"), None)
    home_qpos = model.key_qpos[key] if key is not None else None
    mujoco.mj_kinematics(model, data)  # at qpos0: the pose the axes and signs refer to
    lowest: dict[int, float] = {}
    for g in range(model.ngeom):
        if is_collision_geom(model.geom_contype[g], model.geom_conaffinity[g]):
            center, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
            rot = data.geom_xmat[g].reshape(3, 3)
            z = data.geom_xpos[g, 2] + rot[2] @ center - np.abs(rot[2]) @ half
            b = int(model.geom_bodyid[g])
            lowest[b] = min(lowest.get(b, math.inf), float(z))
    bodies: dict[str, Body] = {}
    depth = [0] * model.nbody
    for b in range(1, model.nbody):
        parent = int(model.body_parentid[b])
        depth[b] = depth[parent] + 1
        bodies[model.body(b).name] = Body(model.body(b).name, model.body(parent).name if parent else None,
                                          depth[b], lowest.get(b))
    hinges, others = [], []
    kinds = {int(mujoco.mjtJoint.mjJNT_SLIDE): "a slide (prismatic) joint, e.g. a gripper's: not a servo's hinge",
             int(mujoco.mjtJoint.mjJNT_BALL): "a ball joint: not a servo's hinge"}
    for j in range(model.njnt):
        name = model.joint(j).name
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
            limited = bool(model.jnt_limited[j])
            hinges.append(Hinge(name, tuple(float(v) for v in data.xanchor[j]),
                                tuple(float(v) for v in data.xaxis[j] / np.linalg.norm(data.xaxis[j])),
                                (float(model.jnt_range[j, 0]), float(model.jnt_range[j, 1])) if limited else None,
                                float(home_qpos[model.jnt_qposadr[j]]) if key is not None else 0.0,
                                model.body(int(model.jnt_bodyid[j])).name))
        elif int(model.jnt_type[j]) in kinds:
            others.append((name, kinds[int(model.jnt_type[j])]))
    return hinges, bodies, others
