"""Seed 000's human character: segment sizes and masses scaled from three measures.

Allen & Faloutsos (2009, section 7) scale every segment linearly from stature, body mass
and bi-iliac breadth (BIB) with the proportions of their table 2 (fractions of stature
stacked sole to crown, and of body mass, bilateral segments summed).  What table 2 does
not give - foot length and breadth, trunk width, hip-joint spacing - comes from the
ratios in the config's ``shape`` block, each with its source; segment depths follow from
the mass at a uniform density.
"""

from __future__ import annotations

import math

from sim2real.robot.spec import Body, Box, Foot
from sim2real.robot.validation import Node, show

SEGMENTS = ("trunk", "waist", "thigh", "shank", "foot")
SHAPE_KEYS = (
    "density_kg_m3", "foot_length", "foot_breadth", "heel", "sole", "trunk_width", "hip_spacing",
)


def _measures(root: Node, preset: str | None) -> dict[str, float | str]:
    anth = root["anthropometry"].mapping(required=("default_preset", "presets", "source"))
    presets = anth["presets"]
    name = preset or anth["default_preset"].string()
    if name not in presets.free_mapping():
        known = ", ".join(map(show, list(presets.value)[:20]))
        raise anth.error(f"unknown preset {show(name)} (known: {known})", key="presets")
    node = presets[name].mapping(required=("stature_m", "mass_kg", "bib_m"))
    return dict(
        preset=name,
        stature_m=node["stature_m"].number(0.5, 2.5),
        mass_kg=node["mass_kg"].number(10.0, 300.0),
        bib_m=node["bib_m"].number(0.1, 0.6),
    )


def human_body(root: Node, preset: str | None) -> tuple[Body, dict[str, float | str]]:
    """The :class:`Body` of the config's human character at a preset (default if None)."""
    for key in ("anthropometry", "proportions", "shape"):
        if not root.has(key):
            raise root.error(f"missing required key {key!r} for actuation: pd", key=key)
    if root.has("body") and root["body"].value != "from_anthropometry":
        raise root.error("must be 'from_anthropometry' for actuation: pd", key="body")
    m = _measures(root, preset)
    H, M, B = float(m["stature_m"]), float(m["mass_kg"]), float(m["bib_m"])

    props = root["proportions"].mapping(required=SEGMENTS)
    frac = {}
    for seg in SEGMENTS:
        node = props[seg].mapping(required=("height", "mass"))
        frac[seg] = (node["height"].number(0.0, 1.0), node["mass"].number(0.0, 1.0))
    total_h = sum(h for h, _ in frac.values())
    if abs(total_h - 1.0) > 0.01:
        raise props.error(f"segment heights must add up to 1 (stature), got {total_h:.3f}")
    shape = root["shape"].mapping(required=SHAPE_KEYS)
    s = {k: shape[k].number(positive=True) for k in SHAPE_KEYS}
    rho = s["density_kg_m3"]

    def length(seg: str) -> float:
        return frac[seg][0] * H

    def mass(seg: str, per_side: bool = False) -> float:
        return frac[seg][1] * M / (2 if per_side else 1)

    def limb(seg: str) -> Box:
        side = math.sqrt(mass(seg, True) / (rho * length(seg)))  # square section
        return Box(size=(side, side, length(seg)), mass=mass(seg, True))

    trunk_w = s["trunk_width"] * H
    trunk = Box(
        size=(mass("trunk") / (rho * trunk_w * length("trunk")), trunk_w, length("trunk")),
        mass=mass("trunk"),
    )
    pelvis = Box(
        size=(mass("waist") / (rho * B * length("waist")), B, length("waist")), mass=mass("waist")
    )
    ankle_h = length("foot")
    foot = Foot(
        length=s["foot_length"] * H,
        width=s["foot_breadth"] * H,
        thickness=s["sole"] * ankle_h,
        ankle_height=ankle_h,
        heel=s["heel"] * s["foot_length"] * H,
        mass=mass("foot", True),
    )
    body = Body(
        trunk=trunk,
        pelvis=pelvis,
        hip_spacing=s["hip_spacing"] * B,
        thigh=limb("thigh"),
        shank=limb("shank"),
        foot=foot,
    )
    return body, m
