"""What a joint's role means as a motion: the one table of anatomical axes.

Joint angles are anatomical and mirrored between the sides, so that one angle means one
motion on either side (a symmetric controller relies on it): pitch is flexion (hip, shoulder
and elbow forward, knee bending back, toes up), roll is abduction (the limb outward; the
ankle the same sense), yaw is external rotation (toes outward); at the waist and the neck,
pitch bends forward, roll leans right and yaw turns left.  A toe joint (the ball of the foot)
turns as the ankle does: pitch lifts the toes (the metatarsophalangeal joints' extension,
which the ankle's dorsiflexion matches in sense).

:data:`ANATOMICAL_AXES` gives each role's positive rotation axis in world coordinates at the
zero pose (facing +x, left +y, z up) for the right side and the centre; the left side mirrors
roll and yaw (:func:`anatomical_axis`).  The box builder turns its joints about these axes;
a robot from a model file relates each model joint to its role by the sign of the dot
product (``sign`` in its config), which ``biped robot import`` infers from them.
"""

from __future__ import annotations

_HIP_LIKE = {"yaw": (0, 0, -1), "roll": (-1, 0, 0), "pitch": (0, -1, 0)}
_WAIST_LIKE = {"yaw": (0, 0, 1), "roll": (1, 0, 0), "pitch": (0, 1, 0)}
ANATOMICAL_AXES: dict[tuple[str, str], tuple[int, int, int]] = {
    **{("waist", a): v for a, v in _WAIST_LIKE.items()},
    **{("hip", a): v for a, v in _HIP_LIKE.items()},
    ("knee", "pitch"): (0, 1, 0),
    **{("ankle", a): v for a, v in _HIP_LIKE.items()},
    **{("toe", a): v for a, v in _HIP_LIKE.items()},
    **{("shoulder", a): v for a, v in _HIP_LIKE.items()},
    # the elbow flexes forward with the arm hanging; held out sideways (a T pose, as ROBOTIS's
    # OP3 at zero) it turns about the forward axis, as an elbow roll
    **{("elbow", a): v for a, v in _HIP_LIKE.items()},
    **{("wrist", a): v for a, v in _HIP_LIKE.items()},
    **{("neck", a): v for a, v in _WAIST_LIKE.items()},
}


def anatomical_axis(side: str, location: str, axis: str) -> tuple[float, float, float]:
    """The positive rotation axis of a role in world coordinates at the zero pose (see the
    module docstring); ``KeyError`` for a role the project does not know."""
    x, y, z = ANATOMICAL_AXES[(location, axis)]
    if side == "left" and axis in ("roll", "yaw"):
        x, z = -x, -z
    return (float(x), float(y), float(z))


# -- facing: where a model file's robot looks ------------------------------------------------------
# The anatomical frame is x forward, y left, z up.  A model file may draw its robot facing
# any horizontal axis (Poppy's URDF faces +y); ``forward`` names it, and the model builder
# turns the robot about z so that it faces +x in the simulation.
FORWARDS: dict[str, tuple[float, float, float]] = {
    "+x": (1.0, 0.0, 0.0), "-x": (-1.0, 0.0, 0.0), "+y": (0.0, 1.0, 0.0), "-y": (0.0, -1.0, 0.0)}
DEFAULT_FORWARD = "+x"


def facing_turn_deg(forward: str) -> float:
    """[deg] the turn about world z that makes a model facing ``forward`` face +x (``+y``:
    -90, a right turn); ``KeyError`` for a direction not in :data:`FORWARDS`."""
    return {"+x": 0.0, "+y": -90.0, "-x": 180.0, "-y": 90.0}[forward]


def to_anatomical(vector, forward: str) -> tuple[float, float, float]:
    """A world vector of a model facing ``forward`` in the anatomical frame (x forward, y
    left, z up): its components along forward, left (up x forward) and up."""
    fx, fy, _ = FORWARDS[forward]
    x, y, z = (float(v) for v in vector)
    return (fx * x + fy * y, -fy * x + fx * y, z)
