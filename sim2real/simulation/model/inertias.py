"""Inertias a model file gives, checked against its collision geometry, and recomputed from it.

    problems = implausible_inertias(spec)     # [InertiaProblem(body, given, geometry, problem)]
    changed = recompute_inertias(spec)        # each body's inertia from its collision geometry

Real URDFs often carry inertias that are wrong: copied between links, in g mm^2 instead of
kg m^2, a CAD default, or breaking ``A + B >= C`` (which MuJoCo refuses to compile).  The
reference is the body's collision geometry at the body's own mass: MuJoCo computes it
(boxes, cylinders and meshes alike) in a copy of the spec compiled with ``inertiafromgeom``
forced, visual geoms removed and every collision geom at one density, so only the shapes
count.  A body whose principal moments differ from the geometry's by more than
``FACTOR`` (10x, either way) on some axis is flagged; so is one whose given moments
break the triangle inequality.  Both take the spec (not a compiled model): a model whose
inertias break ``A + B >= C`` does not compile, and a URDF's fixed links are fused away by
the compile.

:func:`recompute_inertias` keeps each body's mass and centre of mass [m] and takes the
principal moments (scaled to that mass) and principal axes from the geometry.  Bodies without
collision geometry, or without mass, keep what they have.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from sim2real.errors import ConfigError
from sim2real.simulation.model.robot_model import is_collision_geom

FACTOR = 10.0  # a principal moment this many times off the geometry's (either way) is implausible
_TRIANGLE_SLACK = 1e-6  # relative: rounding in a file's printed moments is no violation
_DENSITY = 1000.0  # [kg/m^3] any one value: only the shapes' proportions are used


@dataclass(frozen=True)
class InertiaProblem:
    """A body whose inertia looks wrong: its principal moments as given and those of its
    collision geometry at its mass [kg m^2], each ascending, and what is wrong."""

    body: str
    mass: float  # [kg]
    given: tuple[float, float, float]
    geometry: tuple[float, float, float] | None
    problem: str
    unbalanced: bool = False  # breaks A + B >= C: MuJoCo will not compile it as given

    def __str__(self) -> str:
        return f"body {self.body} ({self.mass:.3g} kg): {self.problem}"


@dataclass(frozen=True)
class _Geometric:
    mass: float  # [kg] of the collision geometry at _DENSITY
    moments: np.ndarray  # [kg m^2] principal, at that mass, in MuJoCo's order
    iquat: np.ndarray  # principal axes in the body frame


def implausible_inertias(spec: mujoco.MjSpec, factor: float = FACTOR, *, source: str | None = None
                         ) -> list[InertiaProblem]:
    """Bodies of ``spec`` with an explicit inertia (mass > 0) that is more than ``factor``
    times off their collision geometry's on some principal axis, or breaks ``A + B >= C``;
    in body order.  ``source``: the model file, named in a refusal."""
    geometric = _geometry_inertias(spec, source)
    problems = []
    for body in list(spec.bodies)[1:]:
        if not body.explicitinertial or not body.mass > 0:
            continue  # nothing given: MuJoCo computes it from the geoms anyway
        given = _given_moments(body)
        geo = geometric.get(body.name)
        scaled = None if geo is None else tuple(sorted(float(v) for v in geo.moments * body.mass / geo.mass))
        a, b, c = given
        issues = []
        if a + b < c * (1 - _TRIANGLE_SLACK):
            issues.append(f"A + B < C: principal moments {_moments(given)} kg m^2 cannot belong to a body "
                          "(MuJoCo refuses them)")
        if scaled is not None:
            ratios = [g / s if g > 0 else math.inf for g, s in zip(given, scaled)]
            worst = max(ratios, key=lambda r: max(r, 1 / r) if r > 0 else math.inf)
            if not (1 / factor <= worst <= factor):
                how = f"{worst:.3g}x" if worst >= 1 else f"1/{1 / worst:.3g}"
                issues.append(f"principal moments {_moments(given)} kg m^2 are {how} those of its collision "
                              f"geometry at its mass ({_moments(scaled)})")
        if issues:
            problems.append(InertiaProblem(body.name, float(body.mass), given, scaled, "; ".join(issues),
                                           unbalanced=a + b < c * (1 - _TRIANGLE_SLACK)))
    return problems


def recompute_inertias(spec: mujoco.MjSpec, *, source: str | None = None) -> list[str]:
    """Each body's inertia set from its collision geometry at its mass (its mass and centre
    of mass kept); the names of the bodies changed, in body order.  ``source``: the model
    file, named in a refusal."""
    geometric = _geometry_inertias(spec, source)
    changed = []
    for body in list(spec.bodies)[1:]:
        geo = geometric.get(body.name)
        if geo is None or not body.mass > 0 or not body.explicitinertial:
            continue  # without an explicit inertial MuJoCo already takes it from the geoms
        body.inertia = geo.moments * body.mass / geo.mass
        body.iquat = geo.iquat
        body.fullinertia = [math.nan, 0, 0, 0, 0, 0]  # unset (MuJoCo's default): inertia and iquat hold it
        changed.append(body.name)
    return changed


def _given_moments(body) -> tuple[float, float, float]:
    """The body's principal moments as the file gives them [kg m^2], ascending."""
    full = np.asarray(body.fullinertia, dtype=float)
    if np.isfinite(full[0]):  # (ixx, iyy, izz, ixy, ixz, iyz), as a URDF gives it
        xx, yy, zz, xy, xz, yz = full
        matrix = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        return tuple(float(v) for v in np.sort(np.linalg.eigvalsh(matrix)))
    return tuple(float(v) for v in np.sort(np.asarray(body.inertia, dtype=float)))


def _geometry_inertias(spec: mujoco.MjSpec, source: str | None = None) -> dict[str, _Geometric]:
    """Each body's collision geometry's mass, principal moments and axes, computed by
    MuJoCo in a copy: inertia from geoms forced, visuals deleted, one density throughout,
    no static bodies fused (so each of the spec's bodies is there)."""
    probe = _without_visuals(spec)
    probe.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE
    probe.compiler.balanceinertia = False
    probe.compiler.settotalmass = -1
    collision = set()
    for geom in probe.geoms:
        geom.mass = math.nan  # from the density, so that shapes an author made massless count too
        geom.density = _DENSITY
        collision.add(geom.parent.name)
    try:
        model = probe.compile()
    except ValueError as exc:
        _refuse_uncompilable(spec, source)  # a bad texture, skin, axis: MuJoCo's words, not ours
        raise ConfigError(source or spec.modelname or "model", "", "MuJoCo cannot compute the collision "
                          f"geometry's inertias: {' '.join(str(exc).split())[:300]}") from None
    found = {}
    for name in collision:
        i = model.body(name).id
        if model.body_mass[i] > 1e-9:
            found[name] = _Geometric(float(model.body_mass[i]), model.body_inertia[i].copy(),
                                     model.body_iquat[i].copy())
    return found


def _without_visuals(spec: mujoco.MjSpec) -> mujoco.MjSpec:
    """A copy of ``spec`` with only its collision geoms, no static body fused away, and
    bodies without geometry nearly massless (so that they compile)."""
    probe = spec.copy()
    probe.compiler.fusestatic = False
    probe.compiler.boundmass = 1e-12
    probe.compiler.boundinertia = 1e-18
    for geom in list(probe.geoms):
        if not is_collision_geom(geom.contype, geom.conaffinity):
            probe.delete(geom)
    return probe


def _refuse_uncompilable(spec: mujoco.MjSpec, source: str | None) -> None:
    """:class:`ConfigError` with MuJoCo's own message when the model fails to compile even
    without its inertias computed from geometry (the failure is then not about inertias)."""
    control = _without_visuals(spec)
    control.compiler.balanceinertia = True  # A + B < C as given is what the probe is for
    try:
        control.compile()
    except ValueError as exc:
        raise ConfigError(source or spec.modelname or "model", "", "MuJoCo cannot compile the model: "
                          f"{' '.join(str(exc).split())[:400]}") from None


def _moments(values) -> str:
    return "(" + ", ".join(f"{v:.3g}" for v in values) + ")"
