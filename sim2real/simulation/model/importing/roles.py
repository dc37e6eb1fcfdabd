"""From a hinge's place on its chain to its role: side, location, axis, index, sign, range.

    guesses, held = assign_roles(tree, placed, forward, reach_deg)

``placed`` lists each chain's hinges in order from the root with the chain's side and each
hinge's :class:`~sim2real.simulation.model.importing.structure.Place`.  For each hinge:

* its **axis** is the principal direction nearest its world axis seen in the anatomical frame
  of the facing (x forward, y left, z up; more than ``MAX_AXIS_OFF_DEG`` off every one: held);
  an elbow is the arm's flexion joint, ``pitch`` whichever way its axis lies (ROBOTIS's OP3
  holds its arms out sideways at zero, its elbow axis then runs forward);
* its **index** counts the hinges of one side, location and axis along the chain from the root
  (a spine's second pitch joint is ``index: 1``);
* its **sign** (anatomical angle = sign * model angle) is the dot of its axis with the role's
  anatomical axis (:mod:`sim2real.robot.anatomy`); an elbow's is the sense that folds the
  forearm forward when it hangs, down when it is held out sideways (unless its limits let it
  bend one way only: then that way), up when it points ahead;
* its **range** is the model's made anatomical, cut to its servo's reach, or +-90 deg where the
  model sets none; its home the ``home`` keyframe's, else 0.

A sided role whose twin on the other side is missing (the legs differ) is held: the project's
bipeds are symmetric.  Names are read only for notes (where the name says another axis or
location than the structure) - the structure decides.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np

from sim2real.robot.anatomy import ANATOMICAL_AXES, anatomical_axis, to_anatomical
from sim2real.simulation.model.importing.joint_names import axis_of, location_of
from sim2real.simulation.model.importing.structure import Hinge, Place

MAX_AXIS_OFF_DEG = 30.0  # a hinge farther than this from every principal axis has no role
ONE_SIDED = 4.0  # an elbow whose limits reach this many times farther one way bends that way
UNLIMITED_RANGE_DEG = 90.0  # the range guessed for a joint the model leaves unlimited
GUESSED = "guessed: check"
_PRINCIPAL = {"roll": (1.0, 0.0, 0.0), "pitch": (0.0, 1.0, 0.0), "yaw": (0.0, 0.0, 1.0)}


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
    index: int = 0  # along the chain among hinges of one side, location and axis
    chain: str = ""  # "left leg", "spine", ...
    why: str = ""  # how the role was decided, for the report
    servo_model: str = ""  # the servo's model (the robot's default when empty)


@dataclass(frozen=True)
class Placed:
    """A hinge of a chain: the chain's name and side, the hinge's place on it, its order."""

    hinge: Hinge
    chain: str  # "left leg", "right arm", "neck", "spine"
    side: str  # left | right | center
    place: Place
    order: int  # 1.. from the root along the chain
    of: int  # hinges on the chain
    far_end: tuple[float, float, float] | None = None  # an arm's far end [m] (for the elbow's flexion)


def number_text(value: float) -> str:
    """A number as a person writes it: ``30``, ``-12.5``."""
    return f"{value:g}" if value != int(value) else str(int(value))


def assign_roles(placed: Sequence[Placed], forward: str, reach_deg: Callable[[str, str], float],
                 model_order: Sequence[str]) -> tuple[list[JointGuess], list[tuple[str, str]]]:
    """Roles of the placed hinges in model order (``model_order``), servo IDs 1.. in that
    order, and the hinges held with why.  ``reach_deg(name, chain)``: how far the joint's
    servo turns either way from its centre [deg]."""
    roles: dict[str, tuple] = {}
    held: list[tuple[str, str]] = []
    count: dict[tuple[str, str, str], int] = {}
    for p in placed:
        role = _role(p, forward)
        if isinstance(role, str):
            held.append((p.hinge.name, role))
            continue
        axis, sign, notes, why = role
        slot = (p.side, p.place.location, axis)
        index = count.get(slot, 0)
        count[slot] = index + 1
        roles[p.hinge.name] = (p, axis, sign, index, notes, why)
    slots = {(r[0].side, r[0].place.location, r[1], r[3]) for r in roles.values()}
    for name, (p, axis, sign, index, notes, why) in list(roles.items()):
        if p.side != "center":
            other = "left" if p.side == "right" else "right"
            if (other, p.place.location, axis, index) not in slots:
                held.append((name, f"no {other} twin of this {p.side} {p.place.location} {axis}"
                             f"{f' (index {index})' if index else ''}: the two sides differ, and the project's "
                             "bipeds are symmetric"))
                del roles[name]
    guesses = []
    for name in model_order:
        if name not in roles:
            continue
        p, axis, sign, index, notes, why = roles[name]
        lo, hi, home, more = range_and_home(p.hinge, sign, reach_deg(name, p.chain))
        guesses.append(JointGuess(name, p.side, p.place.location, axis, sign, (lo, hi), home, len(guesses) + 1,
                                  tuple(notes + more), index, p.chain, why))
    return guesses, held


def _role(p: Placed, forward: str) -> tuple[str, int, list[str], str] | str:
    """(axis, sign, notes, why) of a placed hinge, or why it has no role."""
    u = np.array(to_anatomical(p.hinge.axis, forward))
    location = p.place.location
    dots = {a: abs(float(u @ v)) for a, v in _PRINCIPAL.items()}
    nearest = max(dots, key=dots.get)
    off = math.degrees(math.acos(min(1.0, dots[nearest])))
    where = f"{p.chain}, hinge {p.order} of {p.of} from the root: {p.place.why}"
    notes = []
    if location == "elbow":
        axis, sign, how = "pitch", *_elbow_flexion(p, forward)
        why = f"{where}; the arm's flexion joint (pitch), {how}"
    else:
        if off > MAX_AXIS_OFF_DEG:
            return (f"{where}; its axis ({_vec(u)}, facing {forward}) is {off:.0f} deg from the nearest principal "
                    f"axis ({nearest}): more than {MAX_AXIS_OFF_DEG:g} deg")
        axis = nearest
        if (location, axis) not in ANATOMICAL_AXES:
            known = ", ".join(a for (loc, a) in ANATOMICAL_AXES if loc == location)
            return f"{where}; a {location} {axis} is not a role the project knows ({location}: {known})"
        dot = float(u @ np.array(anatomical_axis(p.side, location, axis)))
        sign = 1 if dot > 0 else -1
        why = f"{where}; axis {axis} ({off:.0f} deg off, facing {forward})"
        if off > 5.0:
            notes.append(f"axis {off:.0f} deg off the {axis} axis")
    said = axis_of(p.hinge.name)
    if said is not None and said != axis and location != "elbow":
        notes.append(f"its name says {said}, its axis is a {axis}")
    named = location_of(p.hinge.name)
    if named is not None and named != location:
        notes.append(f"its name says {named}, its place on the {p.chain} says {location}")
    return axis, sign, notes, why


def _elbow_flexion(p: Placed, forward: str) -> tuple[int, str]:
    """(sign, how) of an elbow: the sense of the model's angle that flexes it."""
    anchor = np.array(to_anatomical(p.hinge.anchor, forward))
    r = np.array(to_anatomical(p.far_end, forward)) - anchor
    r /= max(float(np.linalg.norm(r)), 1e-12)
    moves = np.cross(np.array(to_anatomical(p.hinge.axis, forward)), r)  # the hand's way for a positive turn
    rng = p.hinge.range_rad
    if abs(r[2]) >= 0.7:
        want, how = np.array([-np.sign(r[2]), 0.0, 0.0]), "forward (the forearm hangs)" if r[2] < 0 else "back"
    elif abs(r[1]) >= abs(r[0]):
        want, how = np.array([0.0, 0.0, -1.0]), "down (the forearm is held out sideways)"
        # Held out sideways, the elbow folds down or up as the upper arm is turned: the owner's
        # limits, where they let it bend one way only, say which (Poppy's URDF holds its arms so,
        # its elbows folding up: poppy-project/poppy-humanoid, hardware/URDF/robots)
        if rng is not None and max(abs(rng[0]), abs(rng[1])) >= ONE_SIDED * min(abs(rng[0]), abs(rng[1])) + 1e-9:
            return (1 if rng[1] > -rng[0] else -1), ("+ is the side its limits reach (held out sideways, it may "
                                                     f"fold down or up) ({GUESSED})")
    else:
        want, how = np.array([0.0, 0.0, 1.0]), "up (the forearm points ahead)"
    along = float(moves @ want)
    if abs(along) > 0.3:
        return (1 if along > 0 else -1), f"+ folds the forearm {how}"
    if rng is not None and abs(rng[0] + rng[1]) > 1e-6:
        return (1 if rng[1] > -rng[0] else -1), f"+ is the side its limits reach farther ({GUESSED})"
    return 1, f"flexion's sense not decided: + as the model turns ({GUESSED})"


def range_and_home(hinge: Hinge, sign: int, reach_deg: float = 180.0) -> tuple[float, float, float, list[str]]:
    """(lo, hi, home) [deg] anatomical and notes: the model's range turned by ``sign`` and cut
    to the servo's reach; +-90 deg where the model sets none."""
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


def bends_backwards(j: JointGuess) -> bool:
    """Whether a knee's or an elbow's anatomical range is mostly negative: its limits let it
    bend the wrong way (a knee flexes, pitch > 0, far more than it extends)."""
    return j.location in ("knee", "elbow") and -j.range_deg[0] > j.range_deg[1] and j.range_deg[0] < -10.0


def with_note(j: JointGuess, note: str) -> JointGuess:
    return replace(j, notes=(*j.notes, note))


def _vec(values) -> str:
    return ", ".join(f"{v:.3f}" for v in values)
