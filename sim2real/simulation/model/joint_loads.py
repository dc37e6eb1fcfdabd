"""What a joint carries, read from a compiled model: the bodies it moves and their inertia.

With the stance foot fixed, a leg joint moves every body on the root's side of it; a waist,
neck or arm joint the bodies beyond it (:func:`carried_bodies`).  :func:`axis_inertia` sums their moment of
inertia about the joint's axis [kg m^2] (:mod:`sim2real.simulation.model.builder` sizes each
joint's armature and gains with it; :mod:`sim2real.simulation.standing.statics` their holding torques
from the same bodies).  Every sum goes through :func:`dot3`, plain floats in a fixed order,
so that a model compiles to the same bytes on every CPU.

    mujoco.mj_kinematics(model, data)
    inertia = axis_inertia(model, data, joint)  # [kg m^2]
"""

from __future__ import annotations

import mujoco

from sim2real.robot import Joint
from sim2real.robot.spec import LEG_LOCATIONS


def _subtree(model: mujoco.MjModel, root: int) -> set[int]:
    members = {root}
    for body in range(root + 1, model.nbody):  # parents precede children in MuJoCo
        if model.body_parentid[body] in members:
            members.add(body)
    return members


def carried_bodies(model: mujoco.MjModel, joint: Joint) -> set[int]:
    """Bodies a joint holds up: for a leg joint with its foot on the ground, everything on the
    root's side of it; for any other (waist, neck, arm) the bodies beyond it (the trunk, the
    head, the arm)."""
    below = _subtree(model, model.jnt_bodyid[model.joint(joint.name).id])
    return set(range(1, model.nbody)) - below if joint.location in LEG_LOCATIONS else below


def dot3(a, b) -> float:
    """``a . b`` of two 3-vectors, summed left to right in plain floats.

    Why not ``np.dot`` or ``@``: they go to OpenBLAS, whose kernel (picked for the CPU at
    run time) rounds differently - the same robot got gains one ulp apart under its SkylakeX
    and Haswell kernels, and a walker evolved with one fell with the other (benchmarks/
    RESULTS.md, "Why a walker fell on another machine")."""
    return float(a[0]) * float(b[0]) + float(a[1]) * float(b[1]) + float(a[2]) * float(b[2])


def axis_inertia(model: mujoco.MjModel, data: mujoco.MjData, joint: Joint) -> float:
    """Moment of inertia of the carried bodies about the joint's axis [kg m^2] (needs
    kinematics); the same to the bit on every CPU (:func:`dot3`)."""
    jid = model.joint(joint.name).id
    anchor, axis = data.xanchor[jid], data.xaxis[jid]
    total = 0.0
    for b in carried_bodies(model, joint):
        rot = data.ximat[b].reshape(3, 3)
        local = [dot3(rot[:, k], axis) for k in range(3)]  # the axis in the body's inertia frame
        offset = data.xipos[b] - anchor
        perp = offset - dot3(offset, axis) * axis
        total += dot3(model.body_inertia[b], [x * x for x in local]) + float(model.body_mass[b]) * dot3(perp, perp)
    return total
