"""The roles a robot YAML gives a model file's bodies, checked against the model's tree.

A robot from an MJCF or URDF names its parts in ``model:`` (:mod:`sim2real.robot.loading`):
the root, the IMU's body, the feet, the hands.  That each name is a body of the file is
checked where the model is built; here, that the roles make sense on the model's kinematic
tree (the bodies and their parents, before anything is compiled):

* every element's name is its own: two joints (bodies, geoms, sites) of one name are refused
  naming them (MuJoCo's URDF reader takes them, then fails on the first look-up); this one
  runs on every model file read (:func:`~sim2real.simulation.model.files.load_model_spec`);
* the root is the robot's kinematic root: a body that hangs from the world;
* the IMU and the hands are on the robot: the root or a body below it, never the world;
* the feet are two distinct bodies of the robot, neither below the other, and neither the
  root; each is below its own leg's hip and knee joints (the left foot below every left hip
  and knee joint the map names, the right below the right's) - so a foot on the trunk, on an
  arm, above its knee or on the other leg is refused.

Each refusal is a :class:`~sim2real.errors.ConfigError` naming the robot config and the key
(``model.feet.left.body``, ...).  :func:`~sim2real.simulation.model.file_robot.model_spec` runs
them, so every command that builds a model robot does (``robot show``, ``robot mjcf``,
``simbus``, evolution, the dry run).
"""

from __future__ import annotations

import re
from pathlib import Path

import mujoco

from sim2real.errors import ConfigError
from sim2real.robot import RobotSpec
from sim2real.robot.validation import show

SIDES = ("left", "right")
LEG_JOINTS = ("hip", "knee")  # a foot hangs below its leg's joints of these locations
MAX_DEPTH = 100_000  # bodies from any body up to the world, at most (a guard: a tree is finite)


def check_unique_names(spec: mujoco.MjSpec, source: Path | str) -> None:
    """Refuse a model two of whose elements of one kind share a name.  MuJoCo's URDF reader
    takes such a file (it blanks the second name) and then fails with "repeated name" on
    the first look-up that lists a body's children: list them all here, once."""
    try:
        for body in spec.bodies:
            for _ in (body.bodies, body.joints, body.geoms, body.sites):
                pass
    except ValueError as exc:
        text = " ".join(str(exc).split())
        found = re.search(r"repeated name '(.*?)' in (\w+)", text)
        if found is None:
            raise ConfigError(str(source), "", f"MuJoCo cannot read the model: {text[:300]}") from None
        name, kind = found.groups()
        raise ConfigError(str(source), "", f"two {kind}s are named {show(name)}: each {kind} needs a name of its "
                          "own (a robot config maps them by name); rename one") from None


def check_roles(spec: mujoco.MjSpec, robot: RobotSpec) -> None:
    """Refuse a role map that makes no sense on the model's tree (the module docstring)."""
    source = robot.model
    assert source is not None
    where = robot.source
    world = spec.worldbody.name

    def refuse(key: str, problem: str) -> ConfigError:
        return ConfigError(where, key, problem)

    root = spec.body(source.root)
    if root.name == world:
        raise refuse("model.root", "is the world, not a body of the robot: the root is the body the robot's "
                     "tree hangs from (the one with the free joint, or a URDF's base link)")
    chain = _above(root)
    if len(chain) > 2:  # [root, its parent, ..., world]
        raise refuse("model.root", f"body {show(root.name)} is not the robot's kinematic root: it hangs from "
                     f"{show(chain[1])}; the root is the body that hangs from the world (here {show(chain[-2])})")

    def on_robot(key: str, name: str, what: str) -> list[str]:
        above = _above(spec.body(name))
        if name == world or root.name not in above:
            it = "the world" if name == world else f"body {show(name)}, not the root {show(root.name)} or below it"
            raise refuse(key, f"is {it}: {what}")
        return above

    on_robot("model.imu.body", source.imu_body, "the IMU sits on a body of the robot")
    for side, hand in source.hands.items():
        on_robot(f"model.hands.{side}", hand, "a hand is a body of the robot")
    feet = {side: source.feet[side].body for side in SIDES}
    above = {side: on_robot(f"model.feet.{side}.body", feet[side], "a foot is a body of the robot")
             for side in SIDES}
    for side in SIDES:
        if feet[side] == root.name:
            raise refuse(f"model.feet.{side}.body", f"is the root {show(root.name)} (the trunk): a foot is the "
                         "last body of a leg")
    if feet["left"] == feet["right"]:
        raise refuse("model.feet.right.body", f"is {show(feet['right'])}, the same body as model.feet.left.body: "
                     "the feet are two bodies, one at the end of each leg")
    for side, other in (("left", "right"), ("right", "left")):
        if feet[other] in above[side][1:]:
            raise refuse(f"model.feet.{side}.body", f"body {show(feet[side])} is below the {other} foot "
                         f"{show(feet[other])}: each foot ends a leg of its own")
    for side, other in (("left", "right"), ("right", "left")):
        _check_below_leg(spec, robot, side, other, feet[side], above[side], refuse)


def _check_below_leg(spec: mujoco.MjSpec, robot: RobotSpec, side: str, other: str, foot: str,
                     above: list[str], refuse) -> None:
    """The foot of ``side`` below every hip and knee joint of that side the map names."""
    def body_of(joint_name: str) -> str | None:
        joint = spec.joint(joint_name)
        return None if joint is None else joint.parent.name  # a missing joint: refused by name later

    for joint in robot.joints:
        if joint.side != side or joint.location not in LEG_JOINTS:
            continue
        body = body_of(joint.name)
        if body is None or body in above:
            continue
        swapped = any(body_of(j.name) in above for j in robot.joints
                      if j.side == other and j.location in LEG_JOINTS)
        hint = f"; it is on the {other} leg: are left and right swapped?" if swapped else ""
        raise refuse(f"model.feet.{side}.body", f"body {show(foot)} is not below the {side} {joint.location} "
                     f"joint {show(joint.name)} (on body {show(body)}): a foot is the last body of its own "
                     f"leg{hint}")


def _above(body) -> list[str]:
    """The names of ``body`` and of every body above it, up to the world's (last)."""
    names: list[str] = []
    while body is not None and len(names) <= MAX_DEPTH:
        names.append(body.name)
        body = body.parent
    return names
