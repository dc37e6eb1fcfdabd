"""The robot YAML ``biped robot import`` writes: the importer's result as text, every guess
commented.

    text = robot_yaml(result)       # paths relative to result.output
    write_robot_yaml(result)        # checked by the project's YAML reader, written atomically

PyYAML cannot write comments, and the comments are the point (what was guessed, what was
left out and why), so the text is composed here line by line in the shape the robot loader
reads: joints in flow style, one a line, in model order; names quoted only where YAML would
misread them.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from sim2real.simulation.model.importing.importer import (
    DEFAULT_BUS,
    DEFAULT_SENSOR_BOARD,
    GUESSED,
    ImportResult,
    number_text,
)
from sim2real.robot.spec import LEG_LOCATIONS

# seed 000's "Walk" set for a robot without a waist, as configs/robots/op3.yaml has it: the hips
# (the yaw steers) and the knees; the ankles hold their stance
WALK_LOCATIONS = ("hip", "knee")

_PLAIN = re.compile(r"[A-Za-z_.][A-Za-z0-9_.\-/]*")
_YAML_WORDS = {"true", "false", "yes", "no", "on", "off", "null", "y", "n", "~"}


def _scalar(text: str) -> str:
    """A YAML scalar for a name: plain when safe, else JSON-quoted (valid YAML)."""
    if _PLAIN.fullmatch(text) and text.lower() not in _YAML_WORDS:
        return text
    return json.dumps(text)


def _relative(path: Path, start: Path) -> str:
    return Path(os.path.relpath(Path(path).resolve(), Path(start).resolve())).as_posix()


def robot_yaml(result: ImportResult) -> str:
    """The robot YAML for ``result.output``: paths relative to it, every guess commented."""
    r = result
    here = r.output.parent
    out = [f"# Imported by `biped robot import` from {r.model_file.name} ({r.kind.upper()}).",
           f"# Lines marked \"{GUESSED}\" are guesses from the model's structure and geometry: check each",
           "# against the real robot before evolving a controller, and before powering a servo.",
           "# Angles are anatomical: anatomical angle = sign * model angle, the sign from each joint's axis",
           "# at the model's zero pose in the robot's frame, x forward (model.forward), y left, z up",
           "# (right side: hip/ankle/shoulder/wrist yaw -z, roll -x,",
           "# pitch -y; knee pitch +y; waist/neck yaw +z, roll +x, pitch +y; the left mirrors roll and yaw).",
           f"# Mirror pairs found from the geometry ({len(r.mirror.pairs)}; +1: equal model angles make "
           "mirror-image poses, -1: opposite motions):"]
    out += [f"#   {p.left} <-> {p.right} ({p.sign:+d})" for p in r.mirror.pairs]
    if r.mirror.centre:
        out.append(f"# On the sagittal plane: {', '.join(r.mirror.centre)}")
    for name in r.mirror.unpaired:
        out.append(f"# UNPAIRED ({GUESSED}): {name} has no mirror partner in the geometry")
    for c in r.mirror.conflicts:
        out.append(f"# NAMES DISAGREE ({GUESSED}): {c}")
    if r.facing is not None:
        out += [f"# {line.strip()}" for line in r.facing.report()]
    for note in (*r.mirror.notes, *r.notes):
        out.append(f"# NOTE: {note}")
    for text in r.contradictions:
        out.append(f"# LIMIT AGAINST THE GEOMETRY: {text}")
    if r.missing_visual_meshes:
        out.append(f"# NOTE: {len(r.missing_visual_meshes)} visual mesh file(s) are missing (the collision "
                   "geometry is whole): loading with visuals needs them")
        out += [f"#   {m}" for m in r.missing_visual_meshes]
    if r.stand is not None:
        out += [f"# {line}" for line in r.stand.yaml_comments()]
    if r.held:
        out.append("# Not mapped, so held (welded) at their home pose:")
        out += [f"#   {name}: {why}" for name, why in r.held]
    out += [f"name: {_scalar(r.output.stem)}",
            f"description: {json.dumps(f'imported from {r.model_file.name}: {len(r.joints)} servos')}",
            "actuation: servo",
            f"servo_model: {_scalar(r.servo_model)}",
            f"bus: {{port: {DEFAULT_BUS[0]}, baud: {DEFAULT_BUS[1]}}}  # {GUESSED} the adapter's port and "
            "the servos' baud",
            f"sensor_board: {{profile: {DEFAULT_SENSOR_BOARD[0]}, id: {DEFAULT_SENSOR_BOARD[1]}}}  # {GUESSED}",
            "model:",
            f"  file: {_scalar(_relative(r.model_file, here))}"]
    if r.package_dirs:
        out.append(f"  package_dirs: [{', '.join(_scalar(_relative(d, here)) for d in r.package_dirs)}]")
    base = "the URDF's base link: it gets a free joint" if r.kind == "urdf" else "the body that floats"
    if r.forward != "+x":
        out.append(f"  forward: \"{r.forward}\"  # the way the robot faces in the model file ({GUESSED}); "
                   "the model is turned to face +x")
    out += [f"  root: {_scalar(r.root)}  # {base}",
            f"  imu: {{body: {_scalar(r.root)}, pos: [0.0, 0.0, 0.0]}}  # {GUESSED} where the IMU sits, "
            "in this body's frame [m]",
            "  feet:"]
    for side in ("left", "right"):
        if side in r.feet:
            out.append(f"    {side}: {{body: {_scalar(r.feet[side])}}}  # {GUESSED} the end of the "
                       f"{side} leg; its collision geoms are the sole")
        else:
            out.append(f"    # {side}: {{body: ...}}  NOT FOUND: no {side} leg joint was recognised; "
                       "name the foot body")
    if r.hands:
        hands = ", ".join(f"{s}: {_scalar(b)}" for s, b in r.hands.items())
        out.append(f"  hands: {{{hands}}}  # {GUESSED} the distal bodies of the arms")
    why = f"  # {r.inertias_why}" if r.inertias_why else ""
    out.append(f"  inertias: {r.inertias}{why}")
    out += ["joints:",
            f"  # side and location from the chains of the body tree, axis and sign from the axis in the facing's "
            f"frame ({GUESSED});",
            "  # index: the second (third...) joint of one side, location and axis along its chain",
            f"  # servo ids numbered 1.. in model order ({GUESSED}): set each to its servo's ID",
            "  # servo direction = sign: the servo's angle taken to be the model's, centre tick at 0, as ROBOTIS",
            f"  # maps its robots ({GUESSED}: a servo mounted the other way round needs the other direction)"]
    for j in r.joints:
        note = f"  # {'; '.join(j.notes)}" if j.notes else ""
        index = f", index: {j.index}" if j.index else ""
        model = f", model: {_scalar(j.servo_model)}" if j.servo_model else ""
        out.append(f"  - {{name: {_scalar(j.name)}, side: {j.side}, location: {j.location}, axis: {j.axis}{index}, "
                   f"sign: {j.sign}, range_deg: [{number_text(j.range_deg[0])}, {number_text(j.range_deg[1])}], "
                   f"home_deg: {number_text(j.home_deg)}, servo: {{id: {j.servo_id}{model}, direction: {j.sign}}}}}"
                   f"{note}")
    legs = [j.name for j in r.joints if j.location in LEG_LOCATIONS or j.location == "waist"]
    walk = [j.name for j in r.joints if j.location in WALK_LOCATIONS]
    out.append("control_sets:")
    if legs:
        out.append(f"  legs: [{', '.join(_scalar(n) for n in legs)}]")
    if walk:
        out.append("  # seed 000's walk for a robot without a waist (as op3.yaml's): hips and knees, the ankles hold")
        out.append(f"  walk: [{', '.join(_scalar(n) for n in walk)}]")
    out.append(f"  all: [{', '.join(_scalar(j.name) for j in r.joints)}]")
    return "\n".join(out) + "\n"


def write_robot_yaml(result: ImportResult) -> str:
    """The YAML written to ``result.output`` atomically, after reading it back (it must parse
    as the project's bounded YAML reader reads it); its text."""
    from sim2real.atomic_json import write_text_atomic
    from sim2real.robot.validation import parse_yaml

    text = robot_yaml(result)
    parse_yaml(text, str(result.output))  # a name YAML would misread shows here, not at load
    write_text_atomic(result.output, text)
    return text
