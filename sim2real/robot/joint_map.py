"""A robot config's joint map checked as a whole, every problem at once with its fix.

    problems = joint_map_problems(root, joints) + id_problems(root, joints, board)
    raise_all(root.source, problems)   # one ConfigError: the one problem, or all of them

The loader (:mod:`sim2real.robot.loading`) reads each joint and collects what is wrong with
it (a home outside its range, a range beyond its servo's reach) instead of stopping at the
first; these checks then look at the joints together: repeated names, two joints of one
(side, location, axis, index) slot, indexes that skip, sided joints without a twin, devices
sharing an ID.  A user mends a config in one round, not one per problem.
"""

from __future__ import annotations

from sim2real.errors import ConfigError
from sim2real.robot.spec import BOX_LOCATIONS, Joint, SensorBoard
from sim2real.robot.validation import Node, show


def raise_all(source: str, problems: list[ConfigError]) -> None:
    """Raise the one problem, or every problem in one error keyed ``joints`` (a line each,
    with its key and fix), so that a config is mended in one round, not one per problem."""
    unique = {(p.key, p.problem): p for p in problems}  # the robot's servo_model refused once, not per joint
    problems = list(unique.values())
    if len(problems) == 1:
        raise problems[0]
    if problems:
        raise ConfigError(source, "joints", f"{len(problems)} problems, each with its fix:\n" + "\n".join(
            f"  {p.key}: {p.problem}" for p in problems))


def joint_map_problems(root: Node, joints: tuple[Joint, ...], complete: bool = True) -> list[ConfigError]:
    """Repeated names, two joints in one (side, location, axis, index) slot, indexes that skip,
    and (when every joint was read: ``complete``) sided joints without their twin."""
    problems: list[ConfigError] = []
    seen: dict[str, int] = {}
    slots: dict[tuple[str, str, str, int], str] = {}
    for i, joint in enumerate(joints):
        key = f"joints[{i}].name"
        if joint.name in seen:
            problems.append(ConfigError(root.source, key, f"duplicate joint name {show(joint.name)} (fix: rename one)"))
            continue
        seen[joint.name] = i
        slot = (joint.side, joint.location, joint.axis, joint.index)
        if slot in slots:
            fix = (f"index: {max(s[3] for s in slots if s[:3] == slot[:3]) + 1} if it is the next {joint.axis} joint "
                   f"along the chain (a model robot's), or another axis")
            problems.append(ConfigError(root.source, key, f"{show(joint.name)} repeats the {' '.join(slot[:3])} axis "
                                        f"of {show(slots[slot])}" + (f" (index {joint.index})" if joint.index else "")
                                        + f" (fix: {fix})"))
            continue
        slots[slot] = joint.name
    for (side, location, axis, index), name in slots.items():
        if index and (side, location, axis, index - 1) not in slots:
            problems.append(ConfigError(root.source, "joints", f"{show(name)} has index {index} but no {side} "
                                        f"{location} {axis} has index {index - 1} (fix: count 0, 1, ... along the "
                                        "chain)"))
    if complete:
        for joint in joints:
            if joint.side != "center":
                other = "left" if joint.side == "right" else "right"
                if (other, *joint.slot) not in slots:
                    problems.append(ConfigError(root.source, "joints", f"{show(joint.name)} has no {other} twin "
                                                f"(bipeds are symmetric; fix: map its {other} twin, or leave it out "
                                                "and it is held at home)"))
    return problems


def box_location_problems(root: Node, joints: tuple[Joint, ...]) -> list[ConfigError]:
    return [ConfigError(root.source, f"joints[{i}].location", f"the box tree has joints at the "
                        f"{', '.join(BOX_LOCATIONS)} only; {show(joint.name)} is a {joint.location} "
                        "joint: a body with arms, a neck or toes comes as a model file (model:)")
            for i, joint in enumerate(joints) if joint.location not in BOX_LOCATIONS]


def id_problems(root: Node, joints: tuple[Joint, ...], board: SensorBoard | None) -> list[ConfigError]:
    owners: dict[int, str] = {}
    problems = []
    devices = [(j.servo.id, f"joint {show(j.name)}") for j in joints if j.servo is not None]
    if board is not None:
        devices.append((board.id, "the sensor board"))
    for i, (dxl_id, owner) in enumerate(devices):
        if dxl_id in owners:
            key = f"joints[{i}].servo.id" if i < len(joints) else "sensor_board.id"
            problems.append(ConfigError(root.source, key, f"duplicate ID {dxl_id}: used by {owners[dxl_id]} and "
                                        f"{owner} (fix: each device its own ID)"))
            continue
        owners[dxl_id] = owner
    return problems
