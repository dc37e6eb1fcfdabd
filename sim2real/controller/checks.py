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
* with a robot: its joint-map hash (:func:`joint_map_hash`), and inputs, outputs, symmetry
  and joint ranges exactly those the robot gives for the driven joints (its control set);
  every hold angle inside its joint's range; and ``tick_s`` within :func:`tick_bounds` - no
  shorter than one bus cycle (the loop could not read and write every servo in it), no
  longer than half the Bus Watchdog start-up sets (one late tick would trip it and the
  servos would stop taking goals).  A tick other than the robot's own is allowed within
  these bounds.

The field checker here speaks JSON (objects, ``a.b[0]`` key paths, missing keys before
unknown ones) where :class:`sim2real.robot.validation.Node` speaks YAML; both echo values
through :func:`sim2real.robot.validation.show`, the one cutter of user input in messages.
"""

from __future__ import annotations

import hashlib
import json
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
from sim2real.controller.symmetry import symmetric_layout
from sim2real.errors import ConfigError
from sim2real.robot import RobotSpec
from sim2real.robot.timing import control_timing
from sim2real.robot.validation import show

RANGE_TOLERANCE_RAD = 1e-9  # [rad] a file's joint range may differ from the robot's by rounding


# -- the field checker -------------------------------------------------------------------------
def _join(path: str, key: Any) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    if isinstance(key, str) and key.isidentifier():
        return f"{path}.{key}" if path else key
    return f"{path}[{show(key)}]"


class _Checker:
    """Type, shape and range checks that name the field: ``FILE: FIELD: problem``."""

    def __init__(self, source: str):
        self.source = source

    def error(self, key: str, problem: str) -> ConfigError:
        return ConfigError(self.source, key, problem)

    def obj(self, value: Any, key: str, required: tuple[str, ...] = (), optional: tuple[str, ...] = (),
            free: bool = False) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.error(key, f"must be an object, got {show(value)}")
        for name in required:
            if name not in value:
                raise self.error(_join(key, name), "missing")
        if not free:
            allowed = required + optional
            for name in value:
                if name not in allowed:
                    raise self.error(_join(key, name), f"unknown key (allowed: {', '.join(allowed)})")
        return value

    def string(self, value: Any, key: str) -> str:
        if not isinstance(value, str) or not value:
            raise self.error(key, f"must be a non-empty string, got {show(value)}")
        return value

    def names(self, value: Any, key: str, min_len: int = 0) -> list[str]:
        if not isinstance(value, list):
            raise self.error(key, f"must be a list of names, got {show(value)}")
        if len(value) < min_len:
            raise self.error(key, f"must have at least {min_len} entr{'y' if min_len == 1 else 'ies'}")
        for i, name in enumerate(value):
            self.string(name, f"{key}[{i}]")
        if len(set(value)) != len(value):
            twice = next(n for i, n in enumerate(value) if n in value[:i])
            raise self.error(key, f"{show(twice)} appears twice")
        return value

    def number(self, value: Any, key: str, lo: float, hi: float, lo_open: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float, NonFinite)):
            raise self.error(key, f"must be a number, got {show(value)}")
        if isinstance(value, NonFinite) or isinstance(value, float) and not math.isfinite(value):
            raise self.error(key, f"must be a finite number, got {show(value)}")
        if value < lo or (lo_open and value == lo) or value > hi:
            raise self.error(key, f"must be within {'(' if lo_open else '['}{lo:g}, {hi:g}], got {show(value)}")
        return float(value)

    def same_names(self, key: str, got: list[str], want: list[str], why: str) -> None:
        if got == want:
            return
        if len(got) != len(want):
            raise self.error(key, f"has {len(got)} names where {why} has {len(want)}: {show(want)}")
        i = next(i for i, (a, b) in enumerate(zip(got, want)) if a != b)
        raise self.error(f"{key}[{i}]", f"is {show(got[i])} where {why} has {show(want[i])}")

    def finite_everywhere(self, value: Any, key: str) -> None:
        """Free-form blocks (task, provenance) may hold anything JSON allows, finite numbers only."""
        if isinstance(value, dict):
            for k, v in value.items():
                self.finite_everywhere(v, _join(key, k))
        elif isinstance(value, list):
            for i, v in enumerate(value):
                self.finite_everywhere(v, f"{key}[{i}]")
        elif isinstance(value, NonFinite) or (isinstance(value, float) and not math.isfinite(value)):
            raise self.error(key, f"must be a finite number, got {show(value)}")


# -- the format ---------------------------------------------------------------------------------
def check_controller(data: Any, source: str, robot: RobotSpec | None = None) -> dict[str, Any]:
    """Check a decoded controller whole (see the module docstring); returns it unchanged."""
    c = _Checker(source)
    if not isinstance(data, dict):
        raise c.error("", f"a controller file must hold a JSON object, got {show(data)}")
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
        _check_robot(c, data, robot)
    return data


def _check_reach_arm(c: _Checker, data: dict[str, Any], chosen: dict[str, dict[str, float]],
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


def _vector(c: _Checker, value: Any, key: str, size: int, bound: float, unit: bool = False) -> None:
    if not isinstance(value, list) or len(value) != size:
        raise c.error(key, f"must be {size} numbers, got {show(value)}")
    for i, v in enumerate(value):
        c.number(v, f"{key}[{i}]", -bound, bound)
    if unit and abs(math.sqrt(sum(v * v for v in value)) - 1.0) > 1e-6:
        raise c.error(key, f"must have length 1, got {show(value)}")


def _check_modules(c: _Checker, modules: Any) -> int:
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


def _check_hidden(c: _Checker, hidden: Any, n_interface: int, n_modules: int) -> set[int]:
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


def _check_connections(c: _Checker, conns: Any, n_in: int, n_bias: int, n_out: int, hidden: set[int],
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


def _check_joints(c: _Checker, joints: Any) -> list[str]:
    c.obj(joints, "joints", *JOINTS_KEYS)
    driven = c.names(joints["driven"], "joints.driven", FIELDS["joints"]["properties"]["driven"]["minItems"])
    ranges = c.obj(joints["range_rad"], "joints.range_rad", free=True)
    for name in driven:
        if name not in ranges:
            raise c.error(_join("joints.range_rad", name), "missing (every driven joint needs its range)")
    for name, pair in ranges.items():
        key = _join("joints.range_rad", name)
        if not isinstance(pair, list) or len(pair) != 2:
            raise c.error(key, f"must be [low, high] [rad], got {show(pair)}")
        lo = c.number(pair[0], f"{key}[0]", -ANGLE_LIMIT_RAD, ANGLE_LIMIT_RAD)
        hi = c.number(pair[1], f"{key}[1]", -ANGLE_LIMIT_RAD, ANGLE_LIMIT_RAD)
        if not lo < hi:
            raise c.error(key, f"low must be below high, got {show(pair)}")
    for name, value in c.obj(joints.get("hold_rad", {}), "joints.hold_rad", free=True).items():
        c.number(value, _join("joints.hold_rad", name), -ANGLE_LIMIT_RAD, ANGLE_LIMIT_RAD)
        if name in driven:
            raise c.error(_join("joints.hold_rad", name), "is a driven joint: only joints not driven are held")
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
            key = _join("joints.centre_rad", name)
            low, high = joints["range_rad"][name]
            c.number(centres[name], key, low, high)
    return driven


def _check_input_channels(c: _Checker, data: dict[str, Any]) -> dict[str, dict[str, float]]:
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


def _check_symmetry(c: _Checker, sym: Any, driven: list[str], inputs: list[str], outputs: list[str],
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
        raise c.error("symmetry", _difference("joints.driven", sorted(set(wired) - set(driven)),
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


def _difference(what: str, extra: list[str], lacking: list[str]) -> str:
    parts = [f"has {show(extra)} beyond {what}"] if extra else []
    return "; ".join(parts + ([f"lacks {show(lacking)} of {what}"] if lacking else []))


# -- against a robot ---------------------------------------------------------------------------
def joint_map_hash(robot: RobotSpec) -> str:
    """A short hash of what a controller relies on: joint names, order, ranges and servos."""
    parts = []
    for j in robot.joints:
        servo = (j.servo.id, j.servo.profile.model, j.servo.direction, round(j.servo.zero_offset_rad, 9)) if j.servo else None
        # a model joint turned over (sign -1) adds its sign: older robots' hashes stay as they were
        parts.append([j.name, j.side, j.location, j.axis, [round(a, 9) for a in j.range_rad], servo]
                     + ([j.sign] if j.sign != 1 else []) + ([{"index": j.index}] if j.index else []))
    return hashlib.sha256(json.dumps(parts).encode()).hexdigest()[:16]


def _check_robot(c: _Checker, data: dict[str, Any], robot: RobotSpec) -> None:
    want = joint_map_hash(robot)
    if data["robot"]["joint_map_hash"] != want:
        raise c.error("robot.joint_map_hash", f"made for robot {data['robot']['name']!r} with joint map "
                      f"{data['robot']['joint_map_hash']}, but {robot.name} has {want}")
    driven = data["joints"]["driven"]
    control_set = data["task"].get("control_set")
    if control_set is not None:
        if control_set not in robot.control_sets:
            raise c.error("task.control_set", f"robot {robot.name} has no control set {show(control_set)} "
                          f"(has {', '.join(robot.control_sets)})")
        members = set(robot.control_sets[control_set])
        if set(driven) != members:
            raise c.error("joints.driven", _difference(f"robot {robot.name}'s {control_set!r} control set "
                                                       "(task.control_set)", sorted(set(driven) - members),
                                                       sorted(members - set(driven))))
    try:
        layout = symmetric_layout(robot, tuple(driven), selection(data))
    except (ValueError, KeyError) as exc:
        raise c.error("joints.driven", str(exc)) from None
    why = f"robot {robot.name} driving {show(list(layout.driven))}"
    c.same_names("outputs", data["outputs"], list(layout.output_names), why)
    c.same_names("inputs", data["inputs"], list(layout.input_names), why)
    names = robot.joint_names
    sym = data["symmetry"]
    for side in NETWORKS:
        c.same_names(f"symmetry.leg_joints.{side}", sym["leg_joints"][side],
                     [names[i] for i in layout.leg_index[side]], why)
    c.same_names("symmetry.center_joints", sym["center_joints"], [names[i] for i in layout.center_index], why)
    if [float(m) for m in sym["center_mirror_for_left"]] != layout.center_mirror.tolist():
        raise c.error("symmetry.center_mirror_for_left", f"must be {layout.center_mirror.tolist()} for {why}")
    for block in ("range_rad", "hold_rad"):
        for name, value in data["joints"].get(block, {}).items():
            if name not in names:
                raise c.error(_join(f"joints.{block}", name), f"robot {robot.name} has no such joint")
            actual = robot.joint(name).range_rad
            if block == "range_rad":
                if any(abs(a - b) > RANGE_TOLERANCE_RAD for a, b in zip(value, actual)):
                    raise c.error(_join("joints.range_rad", name), f"{show(value)} differs from robot "
                                  f"{robot.name}'s {list(actual)}")
            elif not actual[0] - RANGE_TOLERANCE_RAD <= value <= actual[1] + RANGE_TOLERANCE_RAD:
                raise c.error(_join("joints.hold_rad", name), f"{show(value)} rad ({math.degrees(value):.1f} deg) "
                              f"is outside the joint's range [{actual[0]:.6g}, {actual[1]:.6g}] rad "
                              f"([{math.degrees(actual[0]):.1f}, {math.degrees(actual[1]):.1f}] deg, robot "
                              f"{robot.name}'s range_deg): a held joint must hold an angle it can reach")
    low, high, why = tick_bounds(robot)
    tick = data["tick_s"]
    if not low - 1e-12 <= tick <= high + 1e-12:
        try:  # a robot from a model file measures its leg on the model: MuJoCo, which a robot computer may lack
            own = f"; its own tick is {control_timing(robot).tick_s * 1e3:.3g} ms"
        except RuntimeError:
            own = ""
        raise c.error("tick_s", f"{show(tick)} s is outside the ticks robot {robot.name} can run at, "
                      f"[{low * 1e3:.3g}, {high * 1e3:.3g}] ms: {why}{own}")


def tick_bounds(robot: RobotSpec) -> tuple[float, float, str]:
    """The control ticks a controller may run at on ``robot``: (shortest, longest [s], where
    both come from, in words).  Shortest: one bus cycle - the reads of every position and of
    the sensor board and the writes of every goal, grouped by protocol and control table, at
    the robot's baud, with the host's turnaround per exchange
    (:func:`sim2real.robot.bus_plan.bus_time`) - or one physics step for a robot without a
    bus.  Longest: half the Bus Watchdog that start-up sets on servos that have one (goals
    must keep coming though one tick runs late), else the format's bound."""
    from sim2real.hardware.dynamixel.registers import Reg
    from sim2real.hardware.dynamixel.startup import WATCHDOG_MS
    from sim2real.robot.bus_plan import bus_time
    from sim2real.robot.timing import PHYSICS_DT_S

    time, step = bus_time(robot), robot.physics_dt_s or PHYSICS_DT_S
    if time is not None and time.total_s >= step:
        low = time.total_s
        why = (f"the shortest is one bus cycle ({time.packets} packets, {time.bytes} bytes at {robot.bus.baud} baud "
               "with the host's turnaround, sim2real/robot/bus_plan.py)")
    else:
        low, why = step, f"the shortest is one physics step ({step * 1e3:g} ms, longer than a bus cycle)"
    watched = robot.bus is not None and any(
        j.servo is not None and Reg.BUS_WATCHDOG in j.servo.profile.control_table for j in robot.joints)
    if watched:
        high = WATCHDOG_MS / 2e3
        why += (f"; the longest half the {WATCHDOG_MS} ms Bus Watchdog that start-up sets on its servos "
                "(one late tick must not trip it)")
    else:
        high = TICK_RANGE_S[1]
        why += "; the longest the format's"
    return low, high, why


def bus_problems(robot: RobotSpec, tick_s: float, *, baud: int | None = None, motion: tuple[str, ...] = ()) -> list[str]:
    """Why ``robot``'s bus cannot run a tick of ``tick_s`` [s] at ``baud`` (default: the
    robot's), every reason at once: a device that cannot be set to the baud rate (servos of
    both protocols that need different ones), a tick's reads and writes (and ``motion``'s
    extra reads) that take longer than the tick, or a bus that no tick the Bus Watchdog
    allows can serve.  Empty when it can; checked by ``biped robot show`` and before a run
    opens its port."""
    from sim2real.robot.bus_plan import baud_problem, bus_devices, bus_time, tick_problem

    if robot.bus is None:
        return []
    baud = baud or robot.bus.baud
    problems = [p for p in (baud_problem(bus_devices(robot), baud),) if p]
    time = bus_time(robot, baud, motion)
    _, high, why = tick_bounds(robot)
    if time.total_s > high + 1e-12:
        problems.append(f"one control tick's bus traffic takes {time.total_s * 1e3:.2f} ms, longer than the longest "
                        f"tick the robot can run at ({high * 1e3:.3g} ms: {why.split('; ')[-1]}): {time.describe()}")
    else:
        problem = tick_problem(robot, tick_s, baud, motion)
        if problem:
            problems.append(problem)
    return problems
