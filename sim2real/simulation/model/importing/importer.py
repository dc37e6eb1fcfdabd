"""``biped robot import``: a starting robot YAML from a user's MJCF or URDF, and a report.

    result = import_robot("op3.xml", "configs/robots/op3.yaml", servo="XM430-W350")
    print("\\n".join(result.report()))
    write_robot_yaml(result)          # sim2real.simulation.model.importing.robot_yaml: every guess commented

What it infers, at the model's zero pose (``qpos0``), from the robot's structure:

* the legs, arms, spine and neck from the body tree, and where each hinge sits along its
  chain (hip, knee, ankle, toe; shoulder, elbow, wrist): :mod:`.structure`;
* which way the robot faces, from its feet, knees and toes (or ``forward=``): :mod:`.facing`;
* each hinge's side from its chain, its mirror partner from the geometry
  (:mod:`sim2real.simulation.model.importing.mirror`), its axis (yaw, roll, pitch) in the facing's
  anatomical frame, its index among hinges of one role along the chain, and its sign,
  anatomical angle = sign * model angle: :mod:`.roles`;
* its range from the model's (turned anatomical by the sign, cut to its servo's reach), or
  +-90 deg where the model sets none; its home from a keyframe named ``home``, else 0 (``biped
  robot import`` then checks that it stands and proposes a home that does, with leg ranges
  centred on it: :mod:`sim2real.simulation.standing.imported`); servo IDs 1, 2, ... in model order;
* the root (the body with the free joint, or a URDF's base), the IMU at the root's origin, each
  foot as the end of its leg, each hand as the end of its arm.

Names are a hint only: they break a tie of the facing's cues and a wrist-or-gripper question,
and the report notes where a name says another role than the structure.  A hinge off every
chain (a gripper, fingers, a tail), one whose axis is far from every principal one, one with
no twin on the other side, and slide or ball joints are left out of ``joints`` and so held at
their home pose by the model builder; the report and the YAML's comments say which and why.
A knee or elbow whose limits let it bend only the wrong way is named as a limit against the
geometry and, where the facing rests on cues (or ``--forward``), written turned to its flexion
side (a robot no home makes stand otherwise); the note says so.

Only :func:`import_robot` needs MuJoCo (imported inside it): the rest is plain data, so the
command line reads :data:`DEFAULT_SERVO` for its help where MuJoCo is not installed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Iterable, Protocol, Sequence

import numpy as np

from sim2real.simulation.model.importing import structure
from sim2real.robot.anatomy import DEFAULT_FORWARD, to_anatomical
from sim2real.simulation.model.importing.facing import Facing, infer_facing
from sim2real.simulation.model.importing.roles import (  # noqa: F401 - the constants, JointGuess and number_text: this module's API
    GUESSED,
    MAX_AXIS_OFF_DEG,
    UNLIMITED_RANGE_DEG,
    JointGuess,
    Placed,
    assign_roles,
    bends_backwards,
    number_text,
    with_note,
)
from sim2real.simulation.model.importing.structure import Body, Hinge

if TYPE_CHECKING:  # pragma: no cover
    from sim2real.simulation.model.inertias import InertiaProblem
    from sim2real.simulation.model.importing.mirror import MirrorInference

DEFAULT_SERVO = "XL430-W250-T"
DEFAULT_BUS = ("/dev/ttyUSB0", 1_000_000)
DEFAULT_SENSOR_BOARD = ("BIPED-FOOT-BOARD", 200)


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


class Reported(Protocol):
    """What the import's report takes from the stand check it is handed."""

    def report(self) -> list[str]: ...


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
    facing: "Facing | None" = None
    contradictions: list[str] = field(default_factory=list)  # limits against the geometry, one sentence each
    # the stand check and the home it proposed: an ImportStand of sim2real.simulation.standing.imported,
    # which judges the robot this builds (so this module does not import it, not even for its type)
    stand: "Reported | None" = None

    @property
    def forward(self) -> str:
        return self.facing.forward if self.facing is not None else DEFAULT_FORWARD

    def report(self) -> list[str]:
        """What was inferred and what was not, in sentences."""
        lines = [f"{self.model_file} ({self.kind.upper()}): root {self.root}, {len(self.joints)} joints mapped, "
                 f"{len(self.held)} held"]
        if self.facing is not None:
            lines += self.facing.report()
        lines += self.mirror.report()
        lines.append("roles (anatomical angle = sign * model angle):")
        for j in self.joints:
            lo, hi = (number_text(a) for a in j.range_deg)
            index = f" #{j.index + 1}" if j.index else ""
            servo = f" ({j.servo_model})" if j.servo_model else ""
            lines.append(f"  {j.name}: {j.side} {j.location} {j.axis}{index}, sign {j.sign:+d}, range [{lo}, {hi}] "
                         f"deg, servo id {j.servo_id}{servo}" + "".join(f"; {n}" for n in j.notes))
            if j.why:
                lines.append(f"    decided: {j.why}")
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
        lines += [f"LIMIT AGAINST THE GEOMETRY: {c}" for c in self.contradictions]
        lines += self.notes
        if self.stand is not None:
            lines += self.stand.report()
        return lines


# -- from a model file ---------------------------------------------------------------------------
GROUPS = {"leg": "legs", "arm": "arms", "neck": "neck", "spine": "waist"}  # chain word -> --servo WHERE


def import_robot(model_file: Path | str, output: Path | str, *, servo: str = DEFAULT_SERVO,
                 servos: dict[str, str] | None = None, package_dirs: Iterable[Path | str] = (),
                 recompute_inertias: bool = False, forward: str | None = None) -> ImportResult:
    """Read ``model_file`` (MJCF or URDF) and infer the robot YAML for ``output`` (not written:
    :func:`write_robot_yaml`).  ``servo``: the servos' model; ``servos``: where others sit
    (``legs``, ``arms``, ``neck``, ``waist`` or a joint's name -> model); ``forward``: the
    robot's facing (``+x``, ``-x``, ``+y``, ``-y``), inferred when None.  Refusals are
    :class:`~sim2real.errors.ConfigError` naming the file."""
    from sim2real.errors import ConfigError
    from sim2real.robot.profiles import load_profile
    from sim2real.simulation.model import files as mf
    from sim2real.simulation.model import inertias as model_inertias
    from sim2real.simulation.model.importing.mirror import mirror_pairs

    model_file, output = Path(model_file), Path(output)
    dirs = tuple(Path(d).expanduser() for d in package_dirs)
    servo_model = servo_model_name(servo)
    where_servo = {key: servo_model_name(model) for key, model in (servos or {}).items()}
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
    hinges, bodies, others = _model_facts(model)
    unknown = sorted(set(where_servo) - {"legs", "arms", "neck", "waist"} - {h.name for h in hinges})
    if unknown:
        raise ConfigError(str(model_file), "", f"--servo {unknown[0]}=...: no such joint or group (legs, arms, "
                          "neck, waist, or a hinge's name)")
    tree = structure.Tree(bodies, {h.name: h for h in hinges})
    legs = structure.find_legs(tree, root)
    if isinstance(legs, str):
        raise ConfigError(str(model_file), "", f"no two legs found: {legs}")
    places: dict[str, structure.Place] = {}
    held: list[tuple[str, str]] = list(legs.extras)
    for leg in legs.chains:
        leg_place, extra = structure.leg_places(tree, leg, legs.lateral)
        places.update(leg_place)
        held += extra
    facing = infer_facing(tree, legs, places, forward)
    mirror = mirror_pairs(model, facing.forward)
    upper = structure.find_upper(tree, root, legs, mirror.sides, mirror.partner)
    held += upper.extras
    placed: list[Placed] = []
    for leg, left in zip(legs.chains, (facing.first_is_left, not facing.first_is_left)):
        placed += _placed(tree, leg, f"{'left' if left else 'right'} leg", "left" if left else "right", places)
    feet = {("left" if left else "right"): _foot(tree, leg, places)
            for leg, left in zip(legs.chains, (facing.first_is_left, not facing.first_is_left))}
    hands = {}
    for arm in upper.arms:
        arm_place, extra, end = structure.arm_places(tree, arm)
        held += extra
        side = "left" if to_anatomical(end - np.asarray(bodies[root].pos), facing.forward)[1] > 0 else "right"
        placed += _placed(tree, arm, f"{side} arm", side, arm_place, tuple(float(v) for v in end))
        hands[side] = arm.end
    for chain, name in ((upper.waist, "spine"), (upper.neck, "neck")):
        if chain is not None:
            location = "waist" if name == "spine" else "neck"
            placed += _placed(tree, chain, name, "center",
                              {h: structure.Place(location, f"on the {name}") for h in chain.hinges})
    done = {p.hinge.name for p in placed} | {name for name, _ in held}
    held += [(h.name, "on no chain: not a leg, arm, spine or neck hinge") for h in hinges if h.name not in done]

    reach = {}

    def reach_deg(name: str, chain: str) -> float:
        model_name = where_servo.get(name) or next((where_servo[g] for w, g in GROUPS.items()
                                                    if w in chain.split() and g in where_servo), servo_model)
        if model_name not in reach:
            reach[model_name] = math.degrees(min(abs(a) for a in load_profile(model_name).position.range_rad))
        return reach[model_name]

    joints, refused = assign_roles(placed, facing.forward, reach_deg, [h.name for h in hinges])
    held += refused
    unnamed = {model.joint(k).name or f"joint{k}" for k in range(model.njnt) if not model.joint(k).name}
    held += [(j.name, f"unnamed in the model, so the YAML cannot name it (it would be a {j.side} {j.location} "
             f"{j.axis}): give it a name in the file") for j in joints if j.name in unnamed]
    joints = [replace(j, servo_id=i + 1) for i, j in enumerate(j for j in joints if j.name not in unnamed)]
    joints = [_with_servo(j, where_servo, servo_model) for j in joints]
    if not joints:
        raise ConfigError(str(model_file), "", "no hinge could be given a role: " + "; ".join(
            f"{name}: {why}" for name, why in held[:6]) + ("; ..." if len(held) > 6 else ""))
    fused_notes = []
    if spec.compiler.fusestatic:  # as a URDF compiles: a body left with no mapped joint fuses into its parent
        mapped = {j.name for j in joints}
        for ends, what in ((feet, "foot"), (hands, "hand")):
            for side, body in list(ends.items()):
                ends[side] = _kept_body(tree, body, mapped, root)
                if ends[side] != body:
                    fused_notes.append(f"the {side} {what} {body} has no mapped joint left, so the model's compile "
                                       f"fuses it into {ends[side]}: the {what} is {ends[side]}")
    order = {h.name: i for i, h in enumerate(hinges)}
    held = sorted(held, key=lambda item: order.get(item[0], len(order))) + others
    result = ImportResult(model_file, output, kind, servo_model, dirs, root, joints, held, feet, hands, mirror,
                          problems, inertias, why, mf.missing_meshes(model_file, dirs), list(upper.notes), facing)
    result.notes += [f"facing: {n}" for n in facing.notes]
    result.notes += fused_notes
    if not any(j.location == "knee" for j in joints):
        result.notes.append("no knee was found on the legs: check the leg chains in the report")
    result.contradictions += _contradictions(joints, facing)
    wrong = {text.split(":")[0] for text in result.contradictions}
    result.joints = [_flexion_side(j, facing) if j.name in wrong else j for j in result.joints]
    for pair in mirror.pairs:
        left, right = (next((j for j in joints if j.name == n), None) for n in (pair.left, pair.right))
        if left is not None and right is not None and (left.location, left.axis) != (right.location, right.axis):
            result.notes.append(f"{GUESSED}: the mirror pairs {left.name} ({left.location} {left.axis}) with "
                                f"{right.name} ({right.location} {right.axis})")
    # the stand check and a home that stands: sim2real.simulation.standing.imported.stand_imported(result), which
    # the command line calls (standing judges what model building makes, a job above this one)
    return result


def _foot(tree: structure.Tree, leg: structure.Chain, places: dict[str, structure.Place]) -> str:
    """A leg's foot: its end, or, where the toes are flat on the floor with it and so reach as
    low, the body the toe joint hangs from (the sole that carries the heel)."""
    toes = [h for h in leg.hinges if places.get(h) and places[h].location == "toe"]
    if toes and tree.hinges[toes[0]].body == leg.end:
        return tree.bodies[leg.end].parent or leg.end
    return leg.end


def _kept_body(tree: structure.Tree, body: str, mapped: set[str], root: str) -> str:
    """The body ``body`` ends up in once the joints not in ``mapped`` are held and the model
    compiles with ``fusestatic`` (a URDF's default): itself if a mapped hinge moves it, else
    the nearest ancestor that one moves (or the root)."""
    while body != root and not set(tree.on_body.get(body, ())) & mapped and tree.bodies[body].parent in tree.bodies:
        body = tree.bodies[body].parent
    return body


def _placed(tree: structure.Tree, chain: structure.Chain, name: str, side: str,
            places: dict[str, structure.Place], far_end: tuple[float, float, float] | None = None) -> list[Placed]:
    on = [h for h in chain.hinges if h in places]
    return [Placed(tree.hinges[h], name, side, places[h], k + 1, len(chain.hinges), far_end)
            for k, h in enumerate(on)]


def _with_servo(j: JointGuess, where: dict[str, str], default: str) -> JointGuess:
    group = next((g for w, g in GROUPS.items() if w in j.chain.split() and g in where), None)
    model = where.get(j.name) or (where[group] if group else default)
    return replace(j, servo_model=model if model != default else "")


def _limits_fixed(facing: Facing) -> bool:
    """Whether a knee's or an elbow's limits against the geometry are replaced by their
    flexion side in the YAML: when the facing rests on cues (or --forward), not on a guess."""
    return facing.decided_by in ("geometry", "--forward")


def _flexion_side(j: JointGuess, facing: Facing) -> JointGuess:
    """A joint whose limits are against the geometry: with its range turned to the flexion
    side (as the report's fix says) where the facing is sure, else as the model has it; noted.
    A URDF whose two knees share an axis direction but not their limits (Poppy's) is fixed so,
    instead of leaving a knee that cannot bend and a robot that no home makes stand."""
    if not _limits_fixed(facing):
        return with_note(j, f"LIMIT AGAINST THE GEOMETRY: {GUESSED} (see the header)")
    lo, hi = _flexion_range(j)
    return replace(j, range_deg=(lo, hi), home_deg=min(max(j.home_deg, lo), hi) + 0.0,
                   notes=(*j.notes, f"LIMIT AGAINST THE GEOMETRY: the model's [{number_text(j.range_deg[0])}, "
                          f"{number_text(j.range_deg[1])}] turned to the flexion side, {GUESSED} (see the header)"))


def _flexion_range(j: JointGuess) -> tuple[float, float]:
    """[deg] a backward-bending joint's range mirrored to the flexion side (from 0)."""
    lo, hi = j.range_deg
    return max(0.0, -float(hi)), -float(lo)


def _contradictions(joints: Sequence[JointGuess], facing: Facing) -> list[str]:
    """A knee or an elbow whose limits let it bend only the wrong way: named as a limit
    against the geometry (the facing and the cues it rests on), with the fix."""
    out = []
    for j in joints:
        if bends_backwards(j):
            lo, hi = (number_text(a) for a in j.range_deg)
            way = "forward" if j.location == "knee" else "backward"
            cues = ", ".join(c.what for c in facing.cues if c.joint != j.name and c not in facing.against)
            basis = f"from {cues}" if cues else f"{facing.decided_by}"
            fixed = "; the YAML has it" if _limits_fixed(facing) else ""
            flex_lo, flex_hi = (number_text(a) for a in _flexion_range(j))
            out.append(f"{j.name}: its limits in the model, [{lo}, {hi}] deg anatomical, let this {j.side} {j.location} "
                       f"bend only {way}, against the geometry (facing {facing.forward}, {basis}): the model's limits "
                       f"are wrong for this joint (fix: range_deg [{flex_lo}, {flex_hi}], the flexion side, as its "
                       f"twin's{fixed})")
    return out


def _model_facts(model) -> tuple[list[Hinge], dict[str, Body], list[tuple[str, str]]]:
    """Hinges and bodies of the compiled model at qpos0, and the other joints (slide, ball)
    with why they are held."""
    import mujoco

    from sim2real.simulation.model.robot_model import is_collision_geom

    data = mujoco.MjData(model)
    key = next((k for k in range(model.nkey) if model.key(k).name == "home"), None)
    home_qpos = model.key_qpos[key] if key is not None else None
    mujoco.mj_kinematics(model, data)  # at qpos0: the pose the axes and signs refer to
    low: dict[int, np.ndarray] = {}
    high: dict[int, np.ndarray] = {}
    for g in range(model.ngeom):
        if is_collision_geom(model.geom_contype[g], model.geom_conaffinity[g]):
            center, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
            rot = data.geom_xmat[g].reshape(3, 3)
            mid, reach = data.geom_xpos[g] + rot @ center, np.abs(rot) @ half  # the world box around it
            b = int(model.geom_bodyid[g])
            low[b] = np.minimum(low.get(b, mid - reach), mid - reach)
            high[b] = np.maximum(high.get(b, mid + reach), mid + reach)
    bodies: dict[str, Body] = {}
    depth = [0] * model.nbody
    for b in range(1, model.nbody):
        parent = int(model.body_parentid[b])
        depth[b] = depth[parent] + 1
        box = [tuple(float(v) for v in corner[b]) if b in corner else None for corner in (low, high)]
        bodies[model.body(b).name] = Body(model.body(b).name, model.body(parent).name if parent else None,
                                          depth[b], box[0][2] if box[0] else None, box[0], box[1],
                                          tuple(float(v) for v in data.xpos[b]))
    hinges, others = [], []
    kinds = {int(mujoco.mjtJoint.mjJNT_SLIDE): "a slide (prismatic) joint, e.g. a gripper's: not a servo's hinge",
             int(mujoco.mjtJoint.mjJNT_BALL): "a ball joint: not a servo's hinge"}
    for j in range(model.njnt):
        name = model.joint(j).name or f"joint{j}"  # as mirror.py names it; held below, the map needs a name
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
