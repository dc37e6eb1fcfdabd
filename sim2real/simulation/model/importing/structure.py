"""A humanoid's kinematic chains from its body tree: legs, arms, neck and spine, and where
along each chain a hinge sits (hip, knee, ankle, toe; shoulder, elbow, wrist).

    legs = find_legs(bodies, hinges, root)           # no facing needed
    places = leg_places(legs.chains[0], hinges, bodies, legs.lateral)
    upper = find_upper(bodies, hinges, root, legs, sides)   # sides: mirror_pairs(...).sides

Plain data in, plain data out (no MuJoCo): :mod:`sim2real.simulation.model.importing.importer` measures the model
at its zero pose and hands the facts here.  The rules, for a robot modelled standing:

* **Legs**: the two branches of the body tree that reach the floor.  From the root, while one
  child's subtree alone reaches the lowest collision geometry (within ``FLOOR_SHARE`` of the
  robot's height), go down it (waist joints above a pelvis); where two do, the legs part.
  Each leg runs from there to its foot, the body whose collision geometry reaches lowest (the
  more distal of two within 1 mm).
* **Along a leg**: the knee is the hinge about the lateral axis (the line between the feet)
  that splits the leg into two long segments (the largest of its distances to the first hip
  hinge and to the sole); hinges before it are the hip, those after it within
  ``CLUSTER_SHARE`` of the shank from the first are the ankle, a lateral hinge beyond them and
  lower is a toe; anything else is an extra.
* **Above**: the central chain going up from the root (each step the sagittal branch that
  reaches highest); the arms are the mirrored pair of sided branches hanging from the central
  bodies with the most hinges; the spine (waist) is the central hinges from the root to where
  the arms part, the neck those above.  Along an arm: the elbow is the hinge across the limb
  (not along it) that splits it into two long segments; before it the shoulder, after it the
  wrist (at most two hinges close together); the rest (grippers, fingers, branches where a hand
  parts into fingers) are extras, held by the model builder.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Iterable, Sequence

import numpy as np

from sim2real.simulation.model.importing.joint_names import words

FLOOR_SHARE = 0.05  # a body within this share of the robot's height of the lowest point stands on the floor
MIN_FLOOR_TOL_M = 0.005
CLUSTER_SHARE = 0.35  # hinges within this share of the shank (forearm) of the first after the knee (elbow)
MIN_SEGMENT_SHARE = 0.15  # a knee (elbow) is at least this share of the leg (arm) from either end
LATERAL_COS = math.cos(math.radians(35.0))  # a hinge this near the line between the feet turns in the sagittal plane
ACROSS_COS = 0.5  # an elbow's axis is within 60 deg of square to the forearm
FOOT_TIE_M = 1e-3
GRIPPER_WORDS = ("grip", "finger", "claw", "jaw", "thumb", "hand", "gripper")


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
    """A body at the zero pose: its parent, depth below the world, the lowest point [m] of its
    collision geometry and that geometry's world bounding box (None without any)."""

    name: str
    parent: str | None
    depth: int
    lowest_z: float | None
    low: tuple[float, float, float] | None = None  # [m] world bounding box of its collision geoms
    high: tuple[float, float, float] | None = None
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [m] its origin in the world


@dataclass(frozen=True)
class Chain:
    """A limb or the spine: its bodies from the root outward, the hinges moving them in that
    order, and its end body (foot, hand)."""

    kind: str  # leg | arm | neck | waist
    bodies: tuple[str, ...]
    hinges: tuple[str, ...]
    end: str | None = None


@dataclass(frozen=True)
class Legs:
    split: str  # the body where the legs part
    lower: tuple[str, ...]  # the central bodies from the root down to ``split``
    chains: tuple[Chain, Chain]
    lateral: tuple[float, float, float]  # unit, horizontal, from the second foot to the first
    floor: float  # [m] the lowest point of the collision geometry
    extras: tuple[tuple[str, str], ...] = ()  # (hinge, why) in the legs' subtrees, off their chains


@dataclass(frozen=True)
class Upper:
    arms: tuple[Chain, ...]  # none or two
    neck: Chain | None
    waist: Chain | None
    arm_base: str | None  # the central body the arms hang from
    extras: tuple[tuple[str, str], ...] = ()
    notes: tuple[str, ...] = ()


@dataclass
class Place:
    """Where a hinge sits along its chain, and why (for the report)."""

    location: str
    why: str


@dataclass
class Tree:
    """The body tree with its hinges: children, hinges per body, subtree extents."""

    bodies: dict[str, Body]
    hinges: dict[str, Hinge]
    children: dict[str, list[str]] = field(default_factory=dict)
    on_body: dict[str, list[str]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name, body in self.bodies.items():
            self.children.setdefault(name, [])
            if body.parent is not None and body.parent in self.bodies:
                self.children.setdefault(body.parent, []).append(name)
        for hinge in self.hinges.values():
            self.on_body.setdefault(hinge.body, []).append(hinge.name)

    def subtree(self, name: str) -> list[str]:
        out, todo = [], [name]
        while todo:
            b = todo.pop()
            out.append(b)
            todo.extend(reversed(self.children.get(b, [])))
        return out

    def low(self, name: str) -> float:
        """[m] the lowest collision point in the subtree (inf without any)."""
        zs = [self.bodies[b].lowest_z for b in self.subtree(name) if self.bodies[b].lowest_z is not None]
        return min(zs) if zs else math.inf

    def top(self, name: str) -> float:
        zs = [self.bodies[b].high[2] for b in self.subtree(name) if self.bodies[b].high is not None]
        zs += [self.hinges[h].anchor[2] for b in self.subtree(name) for h in self.on_body.get(b, [])]
        return max(zs) if zs else -math.inf

    def hinged(self, name: str) -> bool:
        return any(self.on_body.get(b) for b in self.subtree(name))

    def branches(self, name: str) -> list[str]:
        """The hinged bodies hanging from ``name``, looking through welded (hingeless) bodies."""
        out = []
        for child in self.children.get(name, []):
            if self.on_body.get(child):
                out.append(child)
            elif self.hinged(child):
                out.extend(self.branches(child))
        return out

    def path_hinges(self, path: Iterable[str]) -> list[str]:
        return [h for b in path for h in self.on_body.get(b, [])]

    def path_to(self, start: str, end: str) -> list[str]:
        """Bodies from ``start`` down to ``end`` (both included)."""
        path = [end]
        while path[-1] != start:
            parent = self.bodies[path[-1]].parent
            if parent is None:
                raise ValueError(f"{end} is not below {start}")
            path.append(parent)
        return path[::-1]


def _vec(values) -> np.ndarray:
    return np.asarray(values, dtype=float)


def _centre(body: Body) -> np.ndarray | None:
    return None if body.low is None else 0.5 * (_vec(body.low) + _vec(body.high))


def find_legs(tree: Tree, root: str) -> Legs | str:
    """The two legs, or why they cannot be found (a sentence)."""
    floor = tree.low(root)
    if not math.isfinite(floor):
        return "the model has no collision geometry: the feet are the lowest collision geoms"
    height = tree.top(root) - floor
    tol = max(MIN_FLOOR_TOL_M, FLOOR_SHARE * height)
    lower, body = [root], root
    while True:
        down = sorted((c for c in tree.children[body] if tree.low(c) <= floor + tol), key=tree.low)
        if len(down) >= 2:
            break
        if not down:
            return (f"only one branch of the body tree reaches the floor, down to {body}: a biped's two legs "
                    "part below its root (is the root the torso or pelvis, and the model standing?)")
        body = down[0]
        lower.append(body)
    extras = []
    for other in down[2:]:
        extras += [(h, f"its branch ({other}) reaches the floor beside the two legs: not a leg")
                   for h in tree.path_hinges(tree.subtree(other))]
    chains = []
    for start in down[:2]:
        low = tree.low(start)
        feet = [b for b in tree.subtree(start) if tree.bodies[b].lowest_z is not None
                and tree.bodies[b].lowest_z <= low + FOOT_TIE_M]
        foot = max(feet, key=lambda b: tree.bodies[b].depth)
        path = tree.path_to(start, foot)
        chains.append(Chain("leg", tuple(path), tuple(tree.path_hinges(path)), foot))
        extras += [(h, f"in the leg's subtree below {start}, off its chain to the foot {foot}")
                   for h in tree.path_hinges(b for b in tree.subtree(start) if b not in path)]
    ca, cb = (_centre(tree.bodies[c.end]) for c in chains)
    lateral = (ca - cb) * np.array([1.0, 1.0, 0.0])
    if np.linalg.norm(lateral) < 1e-4:
        return f"the two feet ({chains[0].end}, {chains[1].end}) stand at one place: no left and right"
    lateral /= np.linalg.norm(lateral)
    return Legs(body, tuple(lower), (chains[0], chains[1]), tuple(float(v) for v in lateral), floor, tuple(extras))


def _split_point(points: Sequence[np.ndarray], candidates: Sequence[int], top: np.ndarray,
                 end: np.ndarray) -> tuple[int | None, float]:
    """The candidate whose anchor is farthest from both ends of a limb, and that distance [m]."""
    best, score = None, -1.0
    for i in candidates:
        s = min(float(np.linalg.norm(points[i] - top)), float(np.linalg.norm(points[i] - end)))
        if s > score:
            best, score = i, s
    return best, score


def leg_places(tree: Tree, leg: Chain, lateral: Sequence[float]) -> tuple[dict[str, Place], list[tuple[str, str]]]:
    """Each hinge of a leg's chain placed (hip, knee, ankle, toe), and the extras with why."""
    names = list(leg.hinges)
    if not names:
        return {}, []
    points = [_vec(tree.hinges[n].anchor) for n in names]
    foot = tree.bodies[leg.end]
    sole = _centre(foot)
    sole[2] = foot.lowest_z
    top = points[0]
    lat = _vec(lateral)
    across = [i for i, n in enumerate(names) if abs(_vec(tree.hinges[n].axis) @ lat) >= LATERAL_COS]
    knee, score = _split_point(points, across, top, sole)
    length = float(np.linalg.norm(sole - top))
    if knee is None or score < MIN_SEGMENT_SHARE * length:
        return {}, [(n, f"no knee on its leg: no hinge about the line between the feet splits the leg "
                     f"({leg.bodies[0]} to {leg.end}) into thigh and shank") for n in names]
    places = {n: Place("hip", f"{i + 1} of {knee} before the knee") for i, n in enumerate(names[:knee])}
    places[names[knee]] = Place("knee", f"the lateral hinge {score * 1e3:.0f} mm from both ends of the leg")
    extras = []
    after = names[knee + 1:]
    if after:
        first = points[knee + 1]
        radius = CLUSTER_SHARE * float(np.linalg.norm(first - points[knee]))
        for k, n in enumerate(after):
            p = points[knee + 1 + k]
            if float(np.linalg.norm(p - first)) <= radius:
                places[n] = Place("ankle", f"{k + 1} after the knee, at the ankle")
            elif knee + 1 + k in across and p[2] < first[2]:
                places[n] = Place("toe", f"a lateral hinge {np.linalg.norm(p - first) * 1e3:.0f} mm from the ankle, "
                                  "lower: the ball of the foot")
            else:
                extras.append((n, f"beyond the ankle of its leg, {np.linalg.norm(p - first) * 1e3:.0f} mm from it, "
                                  "and no toe"))
    return places, extras


def find_upper(tree: Tree, root: str, legs: Legs, sides: dict[str, str], partner) -> Upper:
    """Arms, neck and spine above (or around) the legs; ``sides``: hinge -> left | right |
    center (the mirror's, in the facing frame); ``partner(hinge)``: its mirror partner or None."""
    in_legs = {b for c in legs.chains for b in tree.subtree(c.bodies[0])}
    side_of = lambda b: sides[tree.on_body[b][0]]  # noqa: E731 - a hinged body's side: its first hinge's
    up, body, extras, notes = [], root, [], []
    while True:  # the central chain going up: each step the sagittal branch reaching highest
        central = [c for c in tree.branches(body) if c not in in_legs and c not in legs.lower
                   and side_of(c) == "center"]
        if not central:
            break
        body = max(central, key=tree.top)
        for other in central:
            if other != body:
                extras += [(h, f"a central branch from {tree.bodies[other].parent} that is not the spine or neck")
                           for h in tree.path_hinges(tree.subtree(other))]
        up.append(body)
    centre_bodies = [*legs.lower, *up]
    sided = [(b, c) for b in centre_bodies for c in tree.branches(b)
             if c not in in_legs and c not in legs.lower and c not in up and side_of(c) != "center"]
    pairs = []
    for b, c in sided:
        other = partner(tree.on_body[c][0])
        match = [d for a, d in sided if other is not None and tree.on_body[d][0] == other]
        if match and side_of(c) == "left":
            pairs.append((b, c, match[0]))
    arms: tuple[Chain, ...] = ()
    base = None
    if pairs:
        base, left, right = max(pairs, key=lambda p: (len(tree.path_hinges(tree.subtree(p[1]))), tree.top(p[1])))
        arms = tuple(_arm_chain(tree, start) for start in (left, right))
    for b, c in sided:
        if not arms or c not in (arms[0].bodies[0], arms[1].bodies[0]):
            why = ("a mirrored pair of branches besides the arms" if partner(tree.on_body[c][0]) else
                   "a sided branch with no mirror partner")
            extras += [(h, f"{why} (from {b})") for h in tree.path_hinges(tree.subtree(c))]
    for arm in arms:
        on_chain = set(arm.bodies)
        extras += [(h, f"where the hand ({arm.end}) parts into branches: a gripper or fingers")
                   for h in tree.path_hinges(b for b in tree.subtree(arm.bodies[0]) if b not in on_chain)]
    cut = up.index(base) + 1 if base in up else 0
    waist_path = [*legs.lower[1:], *up[:cut]]
    neck_path = up[cut:]
    if not arms and neck_path:
        notes.append("no arms: the central chain above the root is taken as the neck")
    waist = Chain("waist", tuple(waist_path), tuple(tree.path_hinges(waist_path))) if waist_path else None
    neck = Chain("neck", tuple(neck_path), tuple(tree.path_hinges(neck_path))) if neck_path else None
    return Upper(arms, neck, waist, base, tuple(extras), tuple(notes))


def _arm_chain(tree: Tree, start: str) -> Chain:
    path = [start]
    while len(tree.branches(path[-1])) == 1:
        path.append(tree.branches(path[-1])[0])
    hand = path[-1]
    while len(tree.branches(hand)) == 0 and len(tree.children[hand]) == 1:  # a fused palm, a wrist link
        hand = tree.children[hand][0]
    return Chain("arm", tuple(path), tuple(tree.path_hinges(path)), hand)


def _far_point(tree: Tree, chain: Chain, start: np.ndarray) -> np.ndarray:
    points = [_vec(tree.hinges[h].anchor) for h in chain.hinges]
    for b in chain.bodies[-1:] + ((chain.end,) if chain.end else ()):
        body = tree.bodies[b]
        if body.low is not None:
            lo, hi = _vec(body.low), _vec(body.high)
            points += [np.where(np.array(c, dtype=bool), hi, lo) for c in np.ndindex(2, 2, 2)]
    return max(points, key=lambda p: float(np.linalg.norm(p - start)))


def arm_places(tree: Tree, arm: Chain) -> tuple[dict[str, Place], list[tuple[str, str]], np.ndarray]:
    """Each hinge of an arm placed (shoulder, elbow, wrist), the extras with why, and the
    arm's far end [m] (where the hand reaches, for the elbow's flexion)."""
    names = list(arm.hinges)
    points = [_vec(tree.hinges[n].anchor) for n in names]
    end = _far_point(tree, arm, points[0])
    across = []
    for i in range(1, len(names)):
        limb = end - points[i]
        if np.linalg.norm(limb) > 1e-9 and abs(_vec(tree.hinges[names[i]].axis) @ limb) <= \
                ACROSS_COS * np.linalg.norm(limb):
            across.append(i)
    elbow, score = _split_point(points, across, points[0], end)
    length = float(np.linalg.norm(end - points[0]))
    if elbow is None or score < MIN_SEGMENT_SHARE * length:
        return ({n: Place("shoulder", f"{i + 1} of {len(names)} on an arm with no elbow") for i, n in enumerate(names)},
                [], end)
    places = {n: Place("shoulder", f"{i + 1} of {elbow} before the elbow") for i, n in enumerate(names[:elbow])}
    places[names[elbow]] = Place("elbow", f"the hinge across the arm {score * 1e3:.0f} mm from both its ends")
    extras = []
    after = names[elbow + 1:]
    if after:
        first = points[elbow + 1]
        radius = CLUSTER_SHARE * float(np.linalg.norm(first - points[elbow]))
        wrists = 0
        for k, n in enumerate(after):
            gripper = any(w.startswith(GRIPPER_WORDS) for w in words(n))
            if wrists < 2 and not gripper and float(np.linalg.norm(points[elbow + 1 + k] - first)) <= radius:
                places[n] = Place("wrist", f"{k + 1} after the elbow, at the wrist")
                wrists += 1
            else:
                why = "its name says gripper or finger" if gripper else "beyond the wrist"
                extras.append((n, f"after the elbow, {why}: a gripper's or a hand's"))
    return places, extras, end
