"""What a joint's name says about it: side, body location and axis, read from its words.

    words("LHipYaw")            # ['l', 'hip', 'yaw']
    side_of("r_sho_pitch")      # 'right'
    base_of("left_knee_joint")  # 'knee_joint': the name without its side, to pair names
    location_of("l_ank_roll")   # 'ankle'
    axis_of("head_pan")         # 'yaw'

A name is split into words at ``_``, ``-``, ``.``, spaces, digits and camelCase humps
(``LHipYaw``, ``r_hip_yaw_joint``, ``HIP_L`` all split), lower-cased.  Sides are the words
``l``/``left`` and ``r``/``right`` wherever they stand (``l_knee``, ``knee_l``, ``LKnee``,
``leg_left_hip``).  Locations come from word beginnings as robot makers abbreviate them
(``LOCATION_WORDS``): ROBOTIS writes ``sho``, ``el``, ``ank``; others ``shoulder``,
``elbow``, ``ankle``.  Only names are read here (no MuJoCo): the geometry that confirms or
contradicts them is :mod:`sim2real.simulation.model.importing.mirror`'s.
"""

from __future__ import annotations

import re

SIDE_WORDS = {"l": "left", "left": "left", "r": "right", "right": "right"}
# (location, word prefixes, whole words), tried in this order for each word of a name.
LOCATION_WORDS: tuple[tuple[str, tuple[str, ...], tuple[str, ...]], ...] = (
    ("hip", ("hip",), ()),
    ("knee", ("knee",), ("kn",)),
    ("ankle", ("ank",), ()),
    ("shoulder", ("sho",), ()),
    ("elbow", ("elb",), ("el",)),
    ("wrist", ("wrist",), ("wr",)),
    ("neck", ("head", "neck"), ()),
    ("waist", ("waist", "torso", "trunk"), ()),
)
AXIS_WORDS = {"yaw": "yaw", "pan": "yaw", "roll": "roll", "pitch": "pitch", "tilt": "pitch"}
_PART = re.compile(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+")


def words(name: str) -> list[str]:
    """The name's words, lower-cased (digits and punctuation separate words and are dropped)."""
    return [w.lower() for w in _PART.findall(name)]


def side_of(name: str) -> str | None:
    """``"left"``, ``"right"``, or None when the name names no side (or both)."""
    sides = {SIDE_WORDS[w] for w in words(name) if w in SIDE_WORDS}
    return sides.pop() if len(sides) == 1 else None


def base_of(name: str) -> str:
    """The name's words without its side words, joined by ``_``: equal for a left joint and
    its right partner when they are named alike."""
    return "_".join(w for w in words(name) if w not in SIDE_WORDS)


def locations_in(name: str) -> list[str]:
    """Every location a word of the name points to, in the order of the words, once each."""
    found: list[str] = []
    for word in words(name):
        for location, prefixes, whole in LOCATION_WORDS:
            if (word.startswith(prefixes) or word in whole) and location not in found:
                found.append(location)
                break
    return found


def location_of(name: str) -> str | None:
    """The one location the name points to, or None (none, or several that differ)."""
    found = locations_in(name)
    return found[0] if len(found) == 1 else None


def axis_of(name: str) -> str | None:
    """``"yaw"``, ``"roll"`` or ``"pitch"`` when the name says which (``pan`` is a yaw,
    ``tilt`` a pitch), else None."""
    axes = {AXIS_WORDS[w] for w in words(name) if w in AXIS_WORDS}
    return axes.pop() if len(axes) == 1 else None
