"""Which way a model's robot faces, from its legs: the feet, the knees, the toes.

    facing = infer_facing(tree, legs, places)          # places: hinge -> Place, both legs
    facing.forward        # "+x" | "-x" | "+y" | "-y" (sim2real.robot.anatomy.FORWARDS)
    facing.first_is_left  # whether legs.chains[0] is the left leg
    facing.report()       # each cue and its vote, in sentences

The line between the feet is the lateral axis; forward is one of the two horizontal
directions square to it.  Each cue votes for one (+1, -1) or abstains:

* **foot**: a sole reaches farther ahead of the ankle (its last hinge, which carries the foot)
  than behind it (the heel is short); the foot is all that hinge carries (sensor pads or toes
  on hinges of their own included);
* **knee bend**: a knee bent at the zero pose (or in the ``home`` keyframe) sits ahead of
  the line from the hip to the ankle;
* **knee limits**: a knee flexes far more than it extends, and flexion moves the foot back;
* **toe**: a toe hinge lies ahead of the ankle.

The sum decides; the names (``l_``/``r_`` on the legs' joints) break a tie; with no cue the
model is taken as drawn (the direction nearest +x, then +y) and the report says so.  A cue
that votes against the decision is named: a knee limit that lets a knee bend only forward
contradicts the geometry.  ``forward=`` (``--forward``) overrides the vote, and the cues
that disagree with it are named.  Plain data (no MuJoCo).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim2real.robot.anatomy import FORWARDS
from sim2real.simulation.model.importing.joint_names import side_of
from sim2real.simulation.model.importing.structure import Legs, Place, Tree, _vec

FOOT_SHARE = 0.05  # a sole centred within this share of its length on the ankle gives no vote
BEND_SHARE = 0.02  # a knee within this share of the leg of the hip-ankle line is straight
ASYMMETRY = 1.5  # a knee flexes at least this many times farther than it extends
HOME_BEND_DEG = 5.0
SNAP_DEG = 20.0  # forward farther than this from every axis is noted


@dataclass(frozen=True)
class Cue:
    what: str  # "foot l_foot_link", "knee limits l_knee", ...
    vote: int  # +1: forward is ``Facing.axis``, -1: its opposite
    detail: str  # the measurement, for the report
    joint: str | None = None  # the hinge whose limit or bend voted, if any


@dataclass(frozen=True)
class Facing:
    forward: str  # key of FORWARDS
    first_is_left: bool
    decided_by: str  # "geometry" | "names" | "--forward" | "default"
    cues: tuple[Cue, ...]
    axis: tuple[float, float, float]  # the forward the cues vote +1 for (horizontal, square to the feet)
    against: tuple[Cue, ...] = ()  # cues voting against the decision
    notes: tuple[str, ...] = ()

    def report(self) -> list[str]:
        head = {"geometry": "from the geometry", "names": "the geometry ties; the names' l_/r_ decide",
                "--forward": "as --forward says", "default": "NO CUE decided: taken as drawn; give --forward"}
        lines = [f"facing {self.forward} ({head[self.decided_by]})"]
        for cue in self.cues:
            lines.append(f"  {cue.what}: {'for' if cue.vote * self._sign > 0 else 'AGAINST'} ({cue.detail})")
        return lines + [f"  note: {n}" for n in self.notes]

    @property
    def _sign(self) -> int:
        return 1 if _vec(FORWARDS[self.forward]) @ _vec(self.axis) > 0 else -1


def _sign(value: float) -> int:
    return 1 if value > 0 else -1


def infer_facing(tree: Tree, legs: Legs, places: dict[str, Place], forward: str | None = None) -> Facing:
    """The facing of the robot whose ``legs`` are placed (``places``); ``forward`` overrides."""
    lat = _vec(legs.lateral)
    axis = np.cross(lat, [0.0, 0.0, 1.0])  # lateral from leg b to leg a: facing +axis makes leg a the left
    cues = []
    for leg in legs.chains:
        knee_h = next((h for h in leg.hinges if places.get(h) and places[h].location == "knee"), None)
        # the ankle hinge that carries the foot (OP3's roll axis sits 24 mm behind its pitch axis,
        # and the sole 24 mm ahead of the roll axis: ROBOTIS's op3_kinematics_dynamics.cpp)
        ankle_h = next((h for h in reversed(leg.hinges) if places.get(h) and places[h].location == "ankle"), None)
        # the foot: all the ankle hinge carries (a sole with sensor pads or toes on hinges of
        # their own is one foot: the lowest of its bodies alone may be a pad at one end)
        foot_body = tree.hinges[ankle_h].body if ankle_h else leg.end
        foot = _extent(tree, foot_body)
        ankle = _vec(tree.hinges[ankle_h].anchor) if ankle_h else None
        if ankle is not None and foot is not None:
            ahead = float((0.5 * (foot[0] + foot[1]) - ankle) @ axis)
            length = float(abs((foot[1] - foot[0]) @ axis))
            if abs(ahead) > FOOT_SHARE * length:
                cues.append(Cue(f"foot {foot_body}", _sign(ahead), f"its sole's centre {abs(ahead) * 1e3:.0f} mm "
                                f"from the ankle toward {_name(axis * _sign(ahead))}"))
        if knee_h is None or ankle is None:
            continue
        knee = tree.hinges[knee_h]
        hip = _vec(tree.hinges[leg.hinges[0]].anchor)
        k = _vec(knee.anchor)
        line = ankle - hip
        off = k - hip - line * ((k - hip) @ line) / max(float(line @ line), 1e-12)
        bend = float(off @ axis)
        if abs(bend) > BEND_SHARE * float(np.linalg.norm(line)):
            cues.append(Cue(f"knee bend {knee_h}", _sign(bend), f"the knee {abs(bend) * 1e3:.0f} mm off the "
                            f"hip-ankle line toward {_name(axis * _sign(bend))} at the zero pose", knee_h))
        moves = np.cross(_vec(knee.axis), ankle - k)  # the ankle's motion for a positive turn
        along = float(moves @ axis)
        if abs(along) <= 0.5 * float(np.linalg.norm(moves)):
            continue
        if knee.range_rad is not None:
            lo, hi = knee.range_rad
            flex = 1 if hi > -lo else -1
            if max(abs(lo), abs(hi)) >= ASYMMETRY * min(abs(lo), abs(hi)) + 1e-9:
                cues.append(Cue(f"knee limits {knee_h}", -_sign(flex * along),
                                f"limits [{math.degrees(lo) + 0.0:.0f}, {math.degrees(hi) + 0.0:.0f}] deg: it flexes "
                                f"{'positive' if flex > 0 else 'negative'}, and flexion moves the foot back", knee_h))
        if abs(math.degrees(knee.home_rad)) > HOME_BEND_DEG:
            cues.append(Cue(f"knee home {knee_h}", -_sign(_sign(knee.home_rad) * along),
                            f"bent {math.degrees(knee.home_rad):.0f} deg in the home keyframe", knee_h))
        for h in leg.hinges:
            if places.get(h) and places[h].location == "toe":
                ahead = float((_vec(tree.hinges[h].anchor) - ankle) @ axis)
                cues.append(Cue(f"toe {h}", _sign(ahead), f"{abs(ahead) * 1e3:.0f} mm from the ankle toward "
                                f"{_name(axis * _sign(ahead))}"))
    total = sum(c.vote for c in cues)
    notes = []
    if forward is not None:
        decided, sign = "--forward", _sign(float(_vec(FORWARDS[forward]) @ axis)) if abs(
            float(_vec(FORWARDS[forward]) @ axis)) > 1e-6 else 1
    elif total != 0:
        decided, sign = "geometry", _sign(total)
    else:
        said = [side_of(h) for h in legs.chains[0].hinges]
        lefts, rights = said.count("left"), said.count("right")
        if lefts != rights:
            decided, sign = "names", 1 if lefts > rights else -1
        else:
            decided, sign = "default", 0
    if forward is None:
        if sign == 0:
            forward = "+x" if abs(axis[0]) >= abs(axis[1]) else "+y"
            sign = _sign(float(_vec(FORWARDS[forward]) @ axis))
        else:
            facing = axis * sign
            forward = max(FORWARDS, key=lambda key: float(_vec(FORWARDS[key]) @ facing))
            off = math.degrees(math.acos(min(1.0, float(_vec(FORWARDS[forward]) @ facing))))
            if off > SNAP_DEG:
                notes.append(f"the robot faces {off:.0f} deg from {forward}: the project takes its facing along "
                             "+-x or +-y (turn the model in its file)")
    elif abs(float(_vec(FORWARDS[forward]) @ axis)) < math.cos(math.radians(45.0)):
        notes.append(f"--forward {forward} runs along the line between the feet: the legs' left and right "
                     "are taken from it as nearly as they go")
    against = tuple(c for c in cues if c.vote != sign)
    return Facing(forward, sign > 0, decided, tuple(cues), tuple(float(v) for v in axis), against, tuple(notes))


def _extent(tree: Tree, body: str) -> tuple[np.ndarray, np.ndarray] | None:
    """(low, high) [m] the world bounding box of the collision geometry of ``body`` and all
    below it, or None without any."""
    boxes = [tree.bodies[b] for b in tree.subtree(body) if tree.bodies[b].low is not None]
    if not boxes:
        return None
    return (np.min([_vec(b.low) for b in boxes], axis=0), np.max([_vec(b.high) for b in boxes], axis=0))


def _name(vector: np.ndarray) -> str:
    key = max(FORWARDS, key=lambda k: float(_vec(FORWARDS[k]) @ vector))
    return key
