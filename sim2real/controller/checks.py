"""The checks of a decoded controller: every field against the format, then against a robot.

:func:`check_controller` is the one validation: ``Controller.load`` runs it on a file's
decoded JSON (:mod:`sim2real.controller.json_reader`) and every
:class:`~sim2real.controller.file.Controller` passes it on construction, so that whatever
loads runs (:class:`~sim2real.controller.policy.Policy`) without an exception.  Every problem
is one :class:`ConfigError` line, ``FILE: FIELD: problem``.  Its keys and bounds are the
published schema's (:mod:`sim2real.controller.schema`); these checks say what the schema
says with messages that name the field, and what a schema cannot say.  In order:

* fields: every field's type, shape and range: ``tick_s`` in ``TICK_RANGE_S`` [s],
  ``sigmoid_steepness`` in (0, ``MAX_STEEPNESS``], two bias rows (right, left) of two
  values in [-1, 1], node ids integers (not booleans) below 2^31, hidden ids unique and
  above the interface, connections ``[src, dst, weight, module]`` between existing nodes,
  never into an input or bias node, with ``|weight| <= MAX_WEIGHT``
  (50x evolution's default clip of 20; the sigmoid saturates long before), and the
  inputs, outputs, symmetry block and driven joints consistent with each other; every
  module enabled (switching one off is ``--disable-module``'s job); no unknown keys
  outside the free-form ``task`` and ``provenance``; no ``NaN`` or ``Infinity`` anywhere.
* with a robot: its joint-map hash, joints, symmetry and tick against the robot's
  (:mod:`sim2real.controller.robot_checks`).

The field checker (:mod:`sim2real.controller.field_checker`) speaks JSON (objects, ``a.b[0]``
key paths, missing keys before unknown ones) where :class:`sim2real.robot.validation.Node`
speaks YAML; both echo values through :func:`sim2real.robot.validation.show`, the one cutter
of user input in messages.
"""

from __future__ import annotations

import math
import re
from typing import Any

from sim2real.controller.json_reader import NonFinite
from sim2real.controller.schema import (
    ANGLE_LIMIT_RAD,
    BIAS_RANGE,
    BIAS_SHAPE,
    FIELDS,
    FORMAT,
    JOINT_MAP_HASH_PATTERN,
    JOINTS_KEYS,
    LEG_JOINTS_KEYS,
    MAX_NODE_ID,
    MAX_STEEPNESS,
    MAX_WEIGHT,
    MIRROR_SIGNS,
    MODULE_KEYS,
    NETWORKS,
    OPTIONAL,
    REQUIRED,
    ROBOT_KEYS,
    SYMMETRY_KEYS,
    TICK_RANGE_S,
    VERSION,
)
from sim2real.controller.channels import CHANNELS, InputSettings, input_names, selection
from sim2real.controller.field_checker import FieldChecker, difference, join_key
from sim2real.controller.robot_checks import check_robot
from sim2real.robot import RobotSpec
from sim2real.robot.validation import show


def check_controller(data: Any, source: str, robot: RobotSpec | None = None) -> dict[str, Any]:
    """Check a decoded controller whole (see the module docstring); returns it unchanged."""
    c = FieldChecker(source)
    if not isinstance(data, dict):
        # its type only: a file that is not a controller at all is not echoed
        raise c.error("", f"a controller file must hold a JSON object, got {type(data).__name__}")
    if data.get("format") != FORMAT:
        problem = "missing" if "format" not in data else f"{show(data['format'])}"
        raise c.error("format", f"not a controller file (format {problem}, expected {FORMAT!r})")
    version = data.get("version")
    if type(version) is not int or version != VERSION:
        raise c.error("version", f"version {show(version)} is not supported (this code reads {VERSION})")
    c.obj(data, "", REQUIRED, OPTIONAL)
    chosen = _check_input_channels(c, data)
    rob = c.obj(data["robot"], "robot", *ROBOT_KEYS)
    c.string(rob["name"], "robot.name")
    hash_ = rob["joint_map_hash"]
    if not isinstance(hash_, str) or not re.fullmatch(JOINT_MAP_HASH_PATTERN, hash_):
        raise c.error("robot.joint_map_hash", f"must be 16 hex digits, got {show(rob['joint_map_hash'])}")
    c.number(data["tick_s"], "tick_s", *TICK_RANGE_S)
    c.number(data["sigmoid_steepness"], "sigmoid_steepness", 0.0, MAX_STEEPNESS, lo_open=True)
    inputs = c.names(data["inputs"], "inputs", FIELDS["inputs"]["minItems"])
    outputs = c.names(data["outputs"], "outputs", FIELDS["outputs"]["minItems"])
    bias = data["bias"]
    if not isinstance(bias, list) or len(bias) != BIAS_SHAPE[0]:
        raise c.error("bias", f"must be two rows (right network, left network), got {show(bias)}")
    for s, row in enumerate(bias):
        if not isinstance(row, list) or len(row) != BIAS_SHAPE[1]:
            raise c.error(f"bias[{s}]", f"must be the two bias node values of one network, got {show(row)}")
        for k, value in enumerate(row):
            c.number(value, f"bias[{s}][{k}]", *BIAS_RANGE)
    driven = _check_joints(c, data["joints"])
    # the interface first: it numbers the nodes
    _check_symmetry(c, data["symmetry"], driven, inputs, outputs, chosen)
    n_in, n_bias, n_out = len(inputs), len(bias[0]), len(outputs)
    n_modules = _check_modules(c, data["modules"])
    hidden = _check_hidden(c, data["hidden"], n_in + n_bias + n_out, n_modules)
    _check_connections(c, data["connections"], n_in, n_bias, n_out, hidden, n_modules)
    _check_reach_arm(c, data, chosen, driven)
    for block in ("task", "provenance"):
        c.obj(data[block], block, free=True)
        c.finite_everywhere(data[block], block)
    if "control_set" in data["task"]:
        c.string(data["task"]["control_set"], "task.control_set")
    if robot is not None:
        check_robot(c, data, robot)
    return data


def _check_reach_arm(c: FieldChecker, data: dict[str, Any], chosen: dict[str, dict[str, float]],
                     driven: list[str]) -> None:
    """The arm's chain: present exactly with the reach input, its numbers within the schema's
    bounds, rotations and axes of unit length, its hinges joints of the controller."""
    if ("reach" in chosen) != ("reach_arm" in data):
        raise c.error("reach_arm", "missing: a reach_input controller carries its arm's chain" if "reach" in chosen
                      else "only with reach_input: true")
    if "reach_arm" not in data:
        return
    schema = FIELDS["reach_arm"]
    arm = c.obj(data["reach_arm"], "reach_arm", tuple(schema["required"]))
    links = arm["links"]
    limit = schema["properties"]["links"]["maxItems"]
    if not isinstance(links, list) or not 1 <= len(links) <= limit:
        raise c.error("reach_arm.links", f"must be a list of 1 to {limit} bodies, got {show(links)}")
    known = set(driven) | set(data["joints"].get("hold_rad", {}))
    for i, link in enumerate(links):
        key = f"reach_arm.links[{i}]"
        c.obj(link, key, ("pos", "quat", "joints"))
        _vector(c, link["pos"], key + ".pos", 3, 10.0)
        _vector(c, link["quat"], key + ".quat", 4, 1.0, unit=True)
        if not isinstance(link["joints"], list) or len(link["joints"]) > 6:
            raise c.error(key + ".joints", f"must be a list of at most 6 hinges, got {show(link['joints'])}")
        for k, hinge in enumerate(link["joints"]):
            hkey = f"{key}.joints[{k}]"
            c.obj(hinge, hkey, ("name", "pos", "axis"))
            if c.string(hinge["name"], hkey + ".name") not in known:
                raise c.error(hkey + ".name", f"{show(hinge['name'])} is not one of the controller's joints")
            _vector(c, hinge["pos"], hkey + ".pos", 3, 10.0)
            _vector(c, hinge["axis"], hkey + ".axis", 3, 1.0, unit=True)
    _vector(c, arm["hand_com"], "reach_arm.hand_com", 3, 10.0)
    shoulder = arm["shoulder_link"]
    if type(shoulder) is not int or not 0 <= shoulder < len(links):
        raise c.error("reach_arm.shoulder_link", f"must be a link's index (0-{len(links) - 1}), got {show(shoulder)}")


def _vector(c: FieldChecker, value: Any, key: str, size: int, bound: float, unit: bool = False) -> None:
    if not isinstance(value, list) or len(value) != size:
        raise c.error(key, f"must be {size} numbers, got {show(value)}")
    for i, v in enumerate(value):
        c.number(v, f"{key}[{i}]", -bound, bound)
    if unit and abs(math.sqrt(sum(v * v for v in value)) - 1.0) > 1e-6:
        raise c.error(key, f"must have length 1, got {show(value)}")


def _check_modules(c: FieldChecker, modules: Any) -> int:
    if not isinstance(modules, list) or not modules:
        raise c.error("modules", f"must be a non-empty list of {{name, enabled}}, got {show(modules)}")
    for i, m in enumerate(modules):
        c.obj(m, f"modules[{i}]", *MODULE_KEYS)
        c.string(m["name"], f"modules[{i}].name")
        if m["enabled"] is not True:
            raise c.error(f"modules[{i}].enabled", f"must be true, got {show(m['enabled'])} (switch a module "
                          "off at run time with --disable-module NAME)")
    c.names([m["name"] for m in modules], "modules")
    return len(modules)


def _check_hidden(c: FieldChecker, hidden: Any, n_interface: int, n_modules: int) -> set[int]:
    if not isinstance(hidden, list):
        raise c.error("hidden", f"must be a list of [node id, module index], got {show(hidden)}")
    ids: set[int] = set()
    for i, entry in enumerate(hidden):
        if not isinstance(entry, list) or len(entry) != 2:
            raise c.error(f"hidden[{i}]", f"must be [node id, module index], got {show(entry)}")
        node, module = entry
        if type(node) is not int or not n_interface <= node <= MAX_NODE_ID:
            raise c.error(f"hidden[{i}]", f"node id must be an integer within [{n_interface}, {MAX_NODE_ID}] "
                          f"(ids below {n_interface} are inputs, biases and outputs), got {show(node)}")
        if type(module) is not int or not 0 <= module < n_modules:
            raise c.error(f"hidden[{i}]", f"module {show(module)} is not an index into modules "
                          f"(0..{n_modules - 1})")
        if node in ids:
            raise c.error(f"hidden[{i}]", f"node id {node} appears twice")
        ids.add(node)
    return ids


def _check_connections(c: FieldChecker, conns: Any, n_in: int, n_bias: int, n_out: int, hidden: set[int],
                       n_modules: int) -> None:
    """The hot loop of the check: a 300-connection controller takes well under 1 ms."""
    if not isinstance(conns, list):
        raise c.error("connections", f"must be a list of [src, dst, weight, module], got {show(conns)}")
    n_interface, first_driven = n_in + n_bias + n_out, n_in + n_bias
    for i, conn in enumerate(conns):
        if not isinstance(conn, list) or len(conn) != 4:
            raise c.error(f"connections[{i}]", f"must be [src, dst, weight, module], got {show(conn)}")
        src, dst, weight, module = conn
        for end, node in (("src", src), ("dst", dst)):
            if type(node) is not int:
                raise c.error(f"connections[{i}]", f"{end} must be an integer node id, got {show(node)}")
            if not (0 <= node < n_interface or node in hidden):
                raise c.error(f"connections[{i}]", f"{end} {show(node)} is not a node of this network "
                              f"(0..{n_interface - 1} and the hidden ids)")
        if dst < first_driven:
            raise c.error(f"connections[{i}]", f"dst {dst} is an input or bias node (nothing drives those)")
        if isinstance(weight, NonFinite) or isinstance(weight, float) and not math.isfinite(weight):
            raise c.error(f"connections[{i}]", f"weight must be a finite number, got {show(weight)}")
        if isinstance(weight, bool) or not isinstance(weight, (int, float)):
            raise c.error(f"connections[{i}]", f"weight must be a number, got {show(weight)}")
        if not -MAX_WEIGHT <= weight <= MAX_WEIGHT:
            raise c.error(f"connections[{i}]", f"weight {show(weight)} is beyond the format's bound "
                          f"|weight| <= {MAX_WEIGHT:g}")
        if type(module) is not int or not 0 <= module < n_modules:
            raise c.error(f"connections[{i}]", f"module {show(module)} is not an index into modules "
                          f"(0..{n_modules - 1})")


def _check_joints(c: FieldChecker, joints: Any) -> list[str]:
    c.obj(joints, "joints", *JOINTS_KEYS)
    driven = c.names(joints["driven"], "joints.driven", FIELDS["joints"]["properties"]["driven"]["minItems"])
    ranges = c.obj(joints["range_rad"], "joints.range_rad", free=True)
    for name in driven:
        if name not in ranges:
            raise c.error(join_key("joints.range_rad", name), "missing (every driven joint needs its range)")
    for name, pair in ranges.items():
        key = join_key("joints.range_rad", name)
        if not isinstance(pair, list) or len(pair) != 2:
            raise c.error(key, f"must be [low, high] [rad], got {show(pair)}")
        lo = c.number(pair[0], f"{key}[0]", -ANGLE_LIMIT_RAD, ANGLE_LIMIT_RAD)
        hi = c.number(pair[1], f"{key}[1]", -ANGLE_LIMIT_RAD, ANGLE_LIMIT_RAD)
        if not lo < hi:
            raise c.error(key, f"low must be below high, got {show(pair)}")
    for name, value in c.obj(joints.get("hold_rad", {}), "joints.hold_rad", free=True).items():
        c.number(value, join_key("joints.hold_rad", name), -ANGLE_LIMIT_RAD, ANGLE_LIMIT_RAD)
        if name in driven:
            raise c.error(join_key("joints.hold_rad", name), "is a driven joint: only joints not driven are held")
    rules = FIELDS["joints"]["properties"]["output_rule"]["enum"]
    rule = joints.get("output_rule", rules[0])
    if rule not in rules:
        raise c.error("joints.output_rule", f"must be one of {show(rules)}, got {show(rule)}")
    home_rule = rule == rules[1]
    if home_rule != ("centre_rad" in joints):
        raise c.error("joints.centre_rad", "missing: the home rule needs each driven joint's centre" if home_rule
                      else "only with the home rule (output_rule " + show(rules[1]) + ")")
    if home_rule:
        centres = c.obj(joints["centre_rad"], "joints.centre_rad", free=True)
        c.same_names("joints.centre_rad", sorted(centres), sorted(driven), "joints.driven")
        for name in driven:
            key = join_key("joints.centre_rad", name)
            low, high = joints["range_rad"][name]
            c.number(centres[name], key, low, high)
    return driven


def _check_input_channels(c: FieldChecker, data: dict[str, Any]) -> dict[str, dict[str, float]]:
    """Each input channel's keys (:data:`sim2real.controller.channels.CHANNELS`): its switch
    true or false, its settings within the schema's bounds and only with it on; returns the
    channels on with their settings."""
    for channel in CHANNELS:
        on = True
        if channel.switch is not None:
            on = data.get(channel.switch, False)
            if not isinstance(on, bool):
                raise c.error(channel.switch, f"must be true or false, got {show(on)}")
        for setting in channel.settings:
            if setting.key not in data:
                continue
            if not on:
                raise c.error(setting.key, f"is the {channel.key} input's setting: give it only with "
                              f"{channel.switch}: true")
            c.number(data[setting.key], setting.key, setting.low, setting.high, lo_open=setting.low_open)
    return selection(data)


def _check_symmetry(c: FieldChecker, sym: Any, driven: list[str], inputs: list[str], outputs: list[str],
                    chosen: InputSettings) -> None:
    """The symmetry block against the driven joints, and the inputs and outputs it implies
    (:func:`sim2real.controller.symmetry.symmetric_layout` names them so): the joint angles,
    then each input channel the file switches on, in the registry's order."""
    c.obj(sym, "symmetry", *SYMMETRY_KEYS)
    if sym["networks"] != NETWORKS:
        raise c.error("symmetry.networks", f"must be {NETWORKS}, got {show(sym['networks'])}")
    legs = c.obj(sym["leg_joints"], "symmetry.leg_joints", *LEG_JOINTS_KEYS)
    right = c.names(legs["right"], "symmetry.leg_joints.right")
    left = c.names(legs["left"], "symmetry.leg_joints.left")
    if len(right) != len(left):
        raise c.error("symmetry.leg_joints", f"{len(right)} right joints but {len(left)} left")
    center = c.names(sym["center_joints"], "symmetry.center_joints")
    mirror = sym["center_mirror_for_left"]
    if not isinstance(mirror, list) or len(mirror) != len(center):
        raise c.error("symmetry.center_mirror_for_left", f"must be one of -1, 1 per centre joint, got {show(mirror)}")
    for i, m in enumerate(mirror):
        if isinstance(m, bool) or m not in MIRROR_SIGNS:
            raise c.error(f"symmetry.center_mirror_for_left[{i}]", f"must be -1 or 1, got {show(m)}")
    if "center_output" in sym:
        c.string(sym["center_output"], "symmetry.center_output")
    wired = right + left + center
    if len(set(wired)) != len(wired):
        raise c.error("symmetry", f"{show(next(n for i, n in enumerate(wired) if n in wired[:i]))} is wired twice")
    if set(wired) != set(driven):
        raise c.error("symmetry", difference("joints.driven", sorted(set(wired) - set(driven)),
                                              sorted(set(driven) - set(wired))))
    k = len(right)
    own = outputs[:k]
    for i, name in enumerate(own):
        if not name.startswith("own_"):
            raise c.error(f"outputs[{i}]", f"{show(name)}: the first {k} outputs are the own leg's (own_...)")
    why = f"the symmetry block ({k} leg joints, centre joints {show(center)})"
    c.same_names("outputs", outputs, own + center, why)
    angles = own + ["other_" + n[4:] for n in own] + center
    on = [f"then the {ch.key} ({ch.switch or ch.settings[0].key})" for ch in CHANNELS
          if ch.key in chosen and ch.key != "joints"]
    off = [f"{'an' if ch.key[0] in 'aeiou' else 'a'} {ch.key} input needs "
           + (f"{ch.switch}: true" if ch.switch else f"a {ch.settings[0].key}") for ch in CHANNELS if ch.optional
           and ch.key not in chosen]
    c.same_names("inputs", inputs, list(input_names(angles, chosen)),
                 why[:-1] + "".join(", " + part for part in on) + "".join("; " + part for part in off) + ")")
