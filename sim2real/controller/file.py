"""Controller files: versioned, self-describing JSON of an evolved network (data only).

:class:`Controller` is what crosses from evolution to the robot: a frozen, valid controller
(``Controller.load``/``save``; ``from_dict``/``to_dict`` for the JSON values;
``for_robot`` writes the wiring of a robot's control set around an evolved network).  A
controller names its robot (and a hash of the robot's joint map, so that a file for
another robot is refused), its control tick (and its gait clock's period, if it has one),
the network's inputs and outputs in order,
the bilateral-symmetry wiring, its modules, its nodes and enabled connections, how outputs
map onto joints, and where it came from.  Its keys and bounds are those of the published
schema, ``schemas/controller-v1.schema.json``, which this module reads them from.

``Controller.load`` checks a file whole before anything moves or simulates
(:func:`check_controller`, the one validation, which every ``Controller`` passes), so that
whatever it returns runs (:class:`~sim2real.controller.policy.Policy`) without an exception; every
problem is one :class:`ConfigError` line, ``FILE: FIELD: problem``.  In order:

* bytes: at most ``MAX_BYTES`` (4 MiB; a 300-connection controller is under 20 KB),
  checked before reading; UTF-8; brackets nested at most ``MAX_DEPTH`` deep (scanned
  before decoding, so decoding cannot recurse); no duplicate keys; no ``NaN`` or
  ``Infinity`` anywhere (JSON has neither), nor numbers that overflow to them (``1e999``).
* fields: every field's type, shape and range: ``tick_s`` in ``TICK_RANGE_S`` [s],
  ``sigmoid_steepness`` in (0, ``MAX_STEEPNESS``], two bias rows (right, left) of two
  values in [-1, 1], node ids integers (not booleans) below 2^31, hidden ids unique and
  above the interface, connections ``[src, dst, weight, module]`` between existing nodes,
  never into an input or bias node, with ``|weight| <= MAX_WEIGHT``
  (50x evolution's default clip of 20; the sigmoid saturates long before), and the
  inputs, outputs, symmetry block and driven joints consistent with each other; every
  module enabled (switching one off is ``--disable-module``'s job); no unknown keys
  outside the free-form ``task`` and ``provenance``.
* with a robot: its joint-map hash, and inputs, outputs, symmetry and joint ranges
  exactly those the robot gives for the driven joints (its control set); every hold angle
  inside its joint's range; and ``tick_s`` within :func:`tick_bounds` - no shorter than one
  bus cycle (the loop could not read and write every servo in it), no longer than half the
  Bus Watchdog start-up sets (one late tick would trip it and the servos would stop taking
  goals).  A tick other than the robot's own is allowed within these bounds.
"""

from __future__ import annotations

import codecs
import hashlib
import json
import math
import re
import reprlib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Any, ClassVar, Mapping

import numpy as np

from sim2real.atomic_json import write_text_atomic
from sim2real.controller.mapping import OUTPUT_RULE, hold_pose
from sim2real.controller.symmetry import (
    BIAS,
    CENTER_OUTPUT,
    GOAL_SUFFIX,
    HEADING_INPUT,
    HEADING_SCALE_DEG,
    PHASE_INPUTS,
    SENSOR_INPUTS,
    SIDES,
    SymmetricLayout,
    symmetric_layout,
    wired_layout,
)
from sim2real.errors import ConfigError
from sim2real.input_files import read_regular_bytes
from sim2real.robot import RobotSpec, load_robot
from sim2real.robot.timing import control_timing

# The format's keys and bounds are the published schema's, read from it: written once.
SCHEMA: dict[str, Any] = json.loads((resources.files("sim2real.controller") / "schemas"
                                     / "controller-v1.schema.json").read_text(encoding="utf-8"))
_FIELDS, _DEFS = SCHEMA["properties"], SCHEMA["$defs"]
FORMAT: str = _FIELDS["format"]["const"]
VERSION: int = _FIELDS["version"]["const"]
REQUIRED: tuple[str, ...] = tuple(SCHEMA["required"])
OPTIONAL: tuple[str, ...] = tuple(k for k in _FIELDS if k not in REQUIRED)  # the inputs' options
PHASE_RANGE_S = (float(_FIELDS["phase_period_s"]["minimum"]), float(_FIELDS["phase_period_s"]["maximum"]))
HEADING_SCALE_MAX_DEG = float(_FIELDS["heading_scale_deg"]["maximum"])
MAX_WEIGHT = float(_FIELDS["connections"]["items"]["prefixItems"][2]["maximum"])  # NeatConfig clips to 20
MAX_STEEPNESS = float(_FIELDS["sigmoid_steepness"]["maximum"])  # seed 000 uses 1, classic NEAT 4.9
TICK_RANGE_S = (float(_FIELDS["tick_s"]["minimum"]), float(_FIELDS["tick_s"]["maximum"]))  # [s]; robots: 10-70 ms
_BIAS = _FIELDS["bias"]["items"]["items"]
BIAS_RANGE = (float(_BIAS["minimum"]), float(_BIAS["maximum"]))  # bias nodes are inputs (seed 000 7.3)
MAX_NODE_ID: int = _DEFS["node_id"]["maximum"]
ANGLE_LIMIT_RAD = float(_DEFS["angle"]["maximum"])  # joint ranges and hold angles [rad]
NETWORKS = list(SIDES)

MAX_BYTES = 4 * 1024 * 1024  # a 300-connection controller is < 20 KB; 4 MiB holds ~200,000
MAX_DEPTH = 64  # the format nests 3 deep, provenance's config about 6
RANGE_TOLERANCE_RAD = 1e-9

_ESCAPE = re.compile(rb"\\.", re.DOTALL)  # in valid JSON a backslash starts a 2-byte escape


def _show(value: Any) -> str:
    """A value for a one-line message: long strings and lists cut short."""
    return _REPR.repr(value)


_REPR = reprlib.Repr()  # Python 3.11's takes no keywords
_REPR.maxstring, _REPR.maxother, _REPR.maxlist, _REPR.maxdict, _REPR.maxlevel = 40, 40, 4, 3, 2


def joint_map_hash(robot: RobotSpec) -> str:
    """A short hash of what a controller relies on: joint names, order, ranges and servos."""
    parts = []
    for j in robot.joints:
        servo = (j.servo.id, j.servo.profile.model, j.servo.direction, round(j.servo.zero_offset_rad, 9)) if j.servo else None
        parts.append([j.name, j.side, j.location, j.axis, [round(a, 9) for a in j.range_rad], servo])
    return hashlib.sha256(json.dumps(parts).encode()).hexdigest()[:16]


def dumps(data: dict[str, Any]) -> str:
    """One top-level key a line, each value compact: readable, and a 300-connection
    controller stays well under 20 KB."""
    lines = [f" {json.dumps(k)}: {json.dumps(v, separators=(',', ':'), allow_nan=False)}" for k, v in data.items()]
    return "{\n" + ",\n".join(lines) + "\n}\n"


def _frozen(value: Any) -> Any:
    """JSON values made immutable: objects as read-only mappings, arrays as tuples."""
    if isinstance(value, dict):
        return MappingProxyType({k: _frozen(v) for k, v in value.items()})
    if isinstance(value, (list, tuple)):
        return tuple(_frozen(v) for v in value)
    return value


def _thawed(value: Any) -> Any:
    """:func:`_frozen` undone: plain JSON values again."""
    if isinstance(value, Mapping):
        return {k: _thawed(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [_thawed(v) for v in value]
    return value


@dataclass(frozen=True)
class Symmetry:
    """The ``symmetry`` block: which joints each network drives (seed 000 section 7.3)."""

    right: tuple[str, ...]  # the right network's leg joints, slot by slot
    left: tuple[str, ...]  # the left network's, the same slots
    center: tuple[str, ...]  # joints both drive; each gets the mean of their outputs
    center_mirror_for_left: tuple[float, ...]  # -1 where the left network sees a centre joint mirrored
    center_output: str | None = None  # how a centre joint's output is made, in words

    @classmethod
    def of(cls, robot: RobotSpec, layout: SymmetricLayout) -> "Symmetry":
        names = robot.joint_names
        right, left = (tuple(names[i] for i in layout.leg_index[side]) for side in ("right", "left"))
        return cls(right, left, tuple(names[i] for i in layout.center_index), tuple(layout.center_mirror.tolist()),
                   CENTER_OUTPUT)

    def to_dict(self) -> dict[str, Any]:
        block = {"networks": list(NETWORKS), "leg_joints": {"right": list(self.right), "left": list(self.left)},
                 "center_joints": list(self.center), "center_mirror_for_left": list(self.center_mirror_for_left)}
        if self.center_output is not None:
            block["center_output"] = self.center_output
        return block


@dataclass(frozen=True)
class JointMap:
    """The ``joints`` block: the driven joints, every joint's range [rad], the angles the
    others hold [rad], and the output rule in words."""

    driven: tuple[str, ...]
    range_rad: Mapping[str, tuple[float, float]]
    hold_rad: Mapping[str, float] | None = None
    output_rule: str | None = None

    def to_dict(self) -> dict[str, Any]:
        block: dict[str, Any] = {"driven": list(self.driven), "range_rad": _thawed(self.range_rad)}
        if self.hold_rad is not None:
            block["hold_rad"] = dict(self.hold_rad)
        if self.output_rule is not None:
            block["output_rule"] = self.output_rule
        return block


@dataclass(frozen=True)
class Controller:
    """A controller, checked whole (:func:`check_controller` on construction): numbers as
    the file holds them, so that saving an unchanged controller writes the same bytes.
    Node ids: inputs, the two bias nodes, outputs, then hidden nodes."""

    robot_name: str
    joint_map_hash: str  # of the robot it was made for (:func:`joint_map_hash`)
    tick_s: float  # control tick [s]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    bias: tuple[tuple[float, ...], ...]  # bias node values of the right and the left network
    symmetry: Symmetry
    sigmoid_steepness: float
    modules: tuple[str, ...]  # control modules, lowest first (seed 002), all enabled
    hidden: tuple[tuple[int, int], ...]  # (node id, module index)
    connections: tuple[tuple[int, int, float, int], ...]  # (source id, target id, weight, module index)
    joints: JointMap
    task: Mapping[str, Any]  # the task it was evolved for (free-form)
    provenance: Mapping[str, Any]  # seed, generation, fitness, ... (free-form)
    phase_period_s: float | None = None  # the gait clock's period [s]; None: no clock
    efference_copy: bool = False  # the last goals are inputs too
    heading_input: bool = False  # the torso's heading is an input (the sensor board must report it)
    heading_scale_deg: float = HEADING_SCALE_DEG  # [deg] the turn the heading input reads as 1

    format: ClassVar[str] = FORMAT
    version: ClassVar[int] = VERSION

    def __post_init__(self) -> None:
        check_controller(self.to_dict(), "<controller>")

    # -- JSON values ---------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: Any, source: str = "<controller>", robot: RobotSpec | None = None) -> "Controller":
        """A controller from decoded JSON, checked (with ``robot``: against it too);
        :class:`ConfigError` naming ``source`` and the field otherwise."""
        check_controller(data, source, robot)
        sym, joints = data["symmetry"], data["joints"]
        return cls(
            robot_name=data["robot"]["name"], joint_map_hash=data["robot"]["joint_map_hash"],
            tick_s=data["tick_s"], inputs=tuple(data["inputs"]), outputs=tuple(data["outputs"]),
            bias=_frozen(data["bias"]),
            symmetry=Symmetry(tuple(sym["leg_joints"]["right"]), tuple(sym["leg_joints"]["left"]),
                              tuple(sym["center_joints"]), tuple(sym["center_mirror_for_left"]),
                              sym.get("center_output")),
            sigmoid_steepness=data["sigmoid_steepness"], modules=tuple(m["name"] for m in data["modules"]),
            hidden=_frozen(data["hidden"]), connections=_frozen(data["connections"]),
            joints=JointMap(tuple(joints["driven"]), _frozen(joints["range_rad"]),
                            MappingProxyType(dict(joints["hold_rad"])) if "hold_rad" in joints else None,
                            joints.get("output_rule")),
            task=_frozen(data["task"]), provenance=_frozen(data["provenance"]),
            phase_period_s=data.get("phase_period_s"), efference_copy=data.get("efference_copy", False),
            heading_input=data.get("heading_input", False),
            heading_scale_deg=data.get("heading_scale_deg", HEADING_SCALE_DEG),
        )

    def to_dict(self) -> dict[str, Any]:
        """The JSON values of the file, keys in the format's order."""
        input_keys = {} if self.phase_period_s is None else {"phase_period_s": self.phase_period_s}
        if self.heading_input:
            input_keys["heading_input"] = True
            if self.heading_scale_deg != HEADING_SCALE_DEG:  # files of the default stay as they were
                input_keys["heading_scale_deg"] = self.heading_scale_deg
        if self.efference_copy:
            input_keys["efference_copy"] = True
        return {
            "format": self.format, "version": self.version,
            "robot": {"name": self.robot_name, "joint_map_hash": self.joint_map_hash},
            "tick_s": self.tick_s, **input_keys, "inputs": list(self.inputs), "outputs": list(self.outputs),
            "bias": _thawed(self.bias), "symmetry": self.symmetry.to_dict(),
            "sigmoid_steepness": self.sigmoid_steepness,
            "modules": [{"name": m, "enabled": True} for m in self.modules],
            "hidden": _thawed(self.hidden), "connections": _thawed(self.connections),
            "joints": self.joints.to_dict(), "task": _thawed(self.task), "provenance": _thawed(self.provenance),
        }

    @classmethod
    def for_robot(cls, robot: RobotSpec, layout: SymmetricLayout, *, sigmoid_steepness: float,
                  modules: tuple[str, ...], hidden: list[tuple[int, int]],
                  connections: list[tuple[int, int, float, int]], task: Mapping[str, Any],
                  provenance: Mapping[str, Any], phase_period_s: float | None = None,
                  heading_scale_deg: float = HEADING_SCALE_DEG) -> "Controller":
        """An evolved network (``hidden`` and ``connections`` in node ids) wired for
        ``robot``'s joints by ``layout`` (with a clock of ``phase_period_s`` [s] and a heading
        read on ``heading_scale_deg`` when the layout has them): its tick, bias values,
        symmetry block, joint ranges and hold pose are the robot's and the conventions' own."""
        hold = hold_pose(robot, layout.driven)
        return cls(
            robot_name=robot.name, joint_map_hash=joint_map_hash(robot), tick_s=control_timing(robot).tick_s,
            inputs=layout.input_names, outputs=layout.output_names, bias=BIAS, symmetry=Symmetry.of(robot, layout),
            sigmoid_steepness=sigmoid_steepness, modules=tuple(modules), hidden=_frozen(hidden),
            connections=_frozen(connections),
            joints=JointMap(layout.driven, _frozen({j.name: j.range_rad for j in robot.joints}),
                            MappingProxyType({j.name: float(hold[i]) for i, j in enumerate(robot.joints)
                                              if j.name not in layout.driven}), OUTPUT_RULE),
            task=_frozen(dict(task)), provenance=_frozen(dict(provenance)), phase_period_s=phase_period_s,
            efference_copy=layout.efference, heading_input=layout.heading,
            heading_scale_deg=heading_scale_deg if layout.heading else HEADING_SCALE_DEG,
        )

    # -- files ---------------------------------------------------------------------------------
    @classmethod
    def load(cls, path: Path | str, robot: RobotSpec | None = None) -> "Controller":
        """Read and check a controller file; with ``robot``, refuse one made for another robot
        or driving other joints.  Raises :class:`ConfigError` (one line) for any problem."""
        source = str(path)
        return cls.from_dict(decode(read_bounded(path, source), source), source, robot)

    @classmethod
    def load_for_robot(cls, path: Path | str, robot: str | None = None) -> tuple["Controller", RobotSpec]:
        """The controller and its robot - ``robot`` if named, else the one the file names -
        checked against each other."""
        spec = load_robot(robot or cls.load(path).robot_name)
        return cls.load(path, spec), spec

    def save(self, path: Path | str) -> None:
        """Write atomically, one top-level key a line (:func:`dumps`)."""
        write_text_atomic(path, dumps(self.to_dict()))

    # -- wiring ----------------------------------------------------------------------------------
    def layout(self, robot: RobotSpec) -> SymmetricLayout:
        """The wiring of the symmetry block on ``robot``, checked to be the one the robot
        gives for the driven joints (:func:`~sim2real.controller.symmetry.symmetric_layout`)."""
        s = self.symmetry
        source = f"controller for {self.robot_name}"
        try:
            clock = self.phase_period_s is not None
            wired = wired_layout(robot, s.right, s.left, s.center, s.center_mirror_for_left, clock,
                                 self.efference_copy, self.heading_input)
            rule = symmetric_layout(robot, self.joints.driven, clock, self.efference_copy, self.heading_input)
        except ValueError as exc:
            raise ConfigError(source, "symmetry", str(exc)) from None
        if wired != rule or (rule.input_names, rule.output_names) != (self.inputs, self.outputs):
            raise ConfigError(source, "symmetry", f"the wiring differs from robot {robot.name}'s for the driven "
                              f"joints {list(rule.driven)} (inputs {list(rule.input_names)}, outputs "
                              f"{list(rule.output_names)})")
        return wired


# -- bytes to JSON ------------------------------------------------------------------------------
def read_bounded(path: Path | str, source: str) -> bytes:
    """The file's bytes, refused unread when larger than ``MAX_BYTES`` (a 300-connection
    controller is about 20 KB) or not a regular file (a FIFO would block the open, a device
    never end: :mod:`sim2real.input_files`)."""
    return read_regular_bytes(path, source, limit=MAX_BYTES, what="controller")


class _NonFinite:
    """What ``NaN``/``Infinity`` decode to, so that the field holding one can be named."""

    __slots__ = ("literal",)

    def __init__(self, literal: str):
        self.literal = literal

    def __repr__(self) -> str:
        return self.literal


class DuplicateKey(Exception):
    """A JSON object names one key twice (``args[0]``: the key)."""


def unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """``object_pairs_hook`` for ``json.loads``: a key given twice in one object raises
    :class:`DuplicateKey` instead of the last one silently winning."""
    obj = dict(pairs)
    if len(obj) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise DuplicateKey(key)
            seen.add(key)
    return obj


def nesting_depth(raw: bytes) -> tuple[int, int]:
    """(deepest bracket nesting, 1-based line where it first passes ``MAX_DEPTH``, else 0)
    of JSON text, brackets inside strings ignored: a linear scan, no recursion."""
    b = np.frombuffer(_ESCAPE.sub(b"", raw), dtype=np.uint8)
    outside = np.bitwise_xor.accumulate((b == ord('"')).view(np.uint8)) == 0  # quote parity
    step = ((b == ord("[")) | (b == ord("{"))).astype(np.int32) - ((b == ord("]")) | (b == ord("}")))
    level = np.cumsum(step * outside, dtype=np.int32)
    depth = int(level.max(initial=0))
    if depth <= MAX_DEPTH:
        return depth, 0
    where = int(np.argmax(level > MAX_DEPTH))
    return depth, int(np.count_nonzero(b[:where] == ord("\n"))) + 1


def decode(raw: bytes, source: str) -> Any:
    """UTF-8 JSON text to Python values; ``NaN``/``Infinity`` become markers for the check."""
    if raw.startswith(codecs.BOM_UTF8):
        raw = raw[len(codecs.BOM_UTF8):]
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise ConfigError(source, "", f"not UTF-8 text (binary, or another encoding?): byte 0x{raw[exc.start]:02x} "
                          f"at line {line} (offset {exc.start})") from None
    depth, line = nesting_depth(raw)
    if depth > MAX_DEPTH:
        raise ConfigError(source, "", f"JSON nested {depth} levels deep (line {line}); "
                          f"a controller nests at most {MAX_DEPTH}")
    try:
        return json.loads(text, parse_constant=_NonFinite, object_pairs_hook=unique_keys)
    except json.JSONDecodeError as exc:
        raise ConfigError(source, "", f"not valid JSON (truncated?): {exc.msg} (line {exc.lineno} "
                          f"column {exc.colno})") from None
    except DuplicateKey as exc:
        raise ConfigError(source, "", f"key {_show(exc.args[0])} appears twice in one object "
                          "(JSON keys must be unique)") from None
    except RecursionError:  # not reached after the depth scan; kept as the last guard
        raise ConfigError(source, "", "JSON nested too deep") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise ConfigError(source, "", f"not valid JSON: {str(exc).split(';')[0]}") from None


# -- the check --------------------------------------------------------------------------------
def _join(path: str, key: Any) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    if isinstance(key, str) and key.isidentifier():
        return f"{path}.{key}" if path else key
    return f"{path}[{_show(key)}]"


class _Checker:
    """Type, shape and range checks that name the field: ``FILE: FIELD: problem``."""

    def __init__(self, source: str):
        self.source = source

    def error(self, key: str, problem: str) -> ConfigError:
        return ConfigError(self.source, key, problem)

    def obj(self, value: Any, key: str, required: tuple[str, ...] = (), optional: tuple[str, ...] = (),
            free: bool = False) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.error(key, f"must be an object, got {_show(value)}")
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
            raise self.error(key, f"must be a non-empty string, got {_show(value)}")
        return value

    def names(self, value: Any, key: str, min_len: int = 0) -> list[str]:
        if not isinstance(value, list):
            raise self.error(key, f"must be a list of names, got {_show(value)}")
        if len(value) < min_len:
            raise self.error(key, f"must have at least {min_len} entr{'y' if min_len == 1 else 'ies'}")
        for i, name in enumerate(value):
            self.string(name, f"{key}[{i}]")
        if len(set(value)) != len(value):
            twice = next(n for i, n in enumerate(value) if n in value[:i])
            raise self.error(key, f"{_show(twice)} appears twice")
        return value

    def number(self, value: Any, key: str, lo: float, hi: float, lo_open: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float, _NonFinite)):
            raise self.error(key, f"must be a number, got {_show(value)}")
        if isinstance(value, _NonFinite) or isinstance(value, float) and not math.isfinite(value):
            raise self.error(key, f"must be a finite number, got {_show(value)}")
        if value < lo or (lo_open and value == lo) or value > hi:
            raise self.error(key, f"must be within {'(' if lo_open else '['}{lo:g}, {hi:g}], got {_show(value)}")
        return float(value)

    def same_names(self, key: str, got: list[str], want: list[str], why: str) -> None:
        if got == want:
            return
        if len(got) != len(want):
            raise self.error(key, f"has {len(got)} names where {why} has {len(want)}: {_show(want)}")
        i = next(i for i, (a, b) in enumerate(zip(got, want)) if a != b)
        raise self.error(f"{key}[{i}]", f"is {_show(got[i])} where {why} has {_show(want[i])}")

    def finite_everywhere(self, value: Any, key: str) -> None:
        """Free-form blocks (task, provenance) may hold anything JSON allows, finite numbers only."""
        if isinstance(value, dict):
            for k, v in value.items():
                self.finite_everywhere(v, _join(key, k))
        elif isinstance(value, list):
            for i, v in enumerate(value):
                self.finite_everywhere(v, f"{key}[{i}]")
        elif isinstance(value, _NonFinite) or (isinstance(value, float) and not math.isfinite(value)):
            raise self.error(key, f"must be a finite number, got {_show(value)}")


def check_controller(data: Any, source: str, robot: RobotSpec | None = None) -> dict[str, Any]:
    """Check a decoded controller whole (see the module docstring); returns it unchanged."""
    c = _Checker(source)
    if not isinstance(data, dict):
        raise c.error("", f"a controller file must hold a JSON object, got {_show(data)}")
    if data.get("format") != FORMAT:
        problem = "missing" if "format" not in data else f"{_show(data['format'])}"
        raise c.error("format", f"not a controller file (format {problem}, expected {FORMAT!r})")
    version = data.get("version")
    if type(version) is not int or version != VERSION:
        raise c.error("version", f"version {_show(version)} is not supported (this code reads {VERSION})")
    c.obj(data, "", REQUIRED, OPTIONAL)
    clock = "phase_period_s" in data
    if clock:
        c.number(data["phase_period_s"], "phase_period_s", *PHASE_RANGE_S)
    efference, heading = data.get("efference_copy", False), data.get("heading_input", False)
    for key, value in (("efference_copy", efference), ("heading_input", heading)):
        if not isinstance(value, bool):
            raise c.error(key, f"must be true or false, got {_show(value)}")
    if "heading_scale_deg" in data:
        if not heading:
            raise c.error("heading_scale_deg", "is the heading input's scale: give it only with heading_input: true")
        c.number(data["heading_scale_deg"], "heading_scale_deg", 0.0, HEADING_SCALE_MAX_DEG, lo_open=True)
    rob = c.obj(data["robot"], "robot", ("name", "joint_map_hash"))
    c.string(rob["name"], "robot.name")
    if not isinstance(rob["joint_map_hash"], str) or not re.fullmatch(r"[0-9a-f]{16}", rob["joint_map_hash"]):
        raise c.error("robot.joint_map_hash", f"must be 16 hex digits, got {_show(rob['joint_map_hash'])}")
    c.number(data["tick_s"], "tick_s", *TICK_RANGE_S)
    c.number(data["sigmoid_steepness"], "sigmoid_steepness", 0.0, MAX_STEEPNESS, lo_open=True)
    inputs = c.names(data["inputs"], "inputs", 1)
    outputs = c.names(data["outputs"], "outputs", 1)
    bias = data["bias"]
    if not isinstance(bias, list) or len(bias) != len(NETWORKS):
        raise c.error("bias", f"must be two rows (right network, left network), got {_show(bias)}")
    for s, row in enumerate(bias):
        if not isinstance(row, list) or len(row) != 2:
            raise c.error(f"bias[{s}]", f"must be the two bias node values of one network, got {_show(row)}")
        for k, value in enumerate(row):
            c.number(value, f"bias[{s}][{k}]", *BIAS_RANGE)
    driven = _check_joints(c, data["joints"])
    # the interface first: it numbers the nodes
    _check_symmetry(c, data["symmetry"], driven, inputs, outputs, clock, efference, heading)
    n_in, n_bias, n_out = len(inputs), len(bias[0]), len(outputs)
    n_modules = _check_modules(c, data["modules"])
    hidden = _check_hidden(c, data["hidden"], n_in + n_bias + n_out, n_modules)
    _check_connections(c, data["connections"], n_in, n_bias, n_out, hidden, n_modules)
    for block in ("task", "provenance"):
        c.obj(data[block], block, free=True)
        c.finite_everywhere(data[block], block)
    if "control_set" in data["task"]:
        c.string(data["task"]["control_set"], "task.control_set")
    if robot is not None:
        _check_robot(c, data, robot)
    return data


def _check_modules(c: _Checker, modules: Any) -> int:
    if not isinstance(modules, list) or not modules:
        raise c.error("modules", f"must be a non-empty list of {{name, enabled}}, got {_show(modules)}")
    for i, m in enumerate(modules):
        c.obj(m, f"modules[{i}]", ("name", "enabled"))
        c.string(m["name"], f"modules[{i}].name")
        if m["enabled"] is not True:
            raise c.error(f"modules[{i}].enabled", f"must be true, got {_show(m['enabled'])} (switch a module "
                          "off at run time with --disable-module NAME)")
    c.names([m["name"] for m in modules], "modules")
    return len(modules)


def _check_hidden(c: _Checker, hidden: Any, n_interface: int, n_modules: int) -> set[int]:
    if not isinstance(hidden, list):
        raise c.error("hidden", f"must be a list of [node id, module index], got {_show(hidden)}")
    ids: set[int] = set()
    for i, entry in enumerate(hidden):
        if not isinstance(entry, list) or len(entry) != 2:
            raise c.error(f"hidden[{i}]", f"must be [node id, module index], got {_show(entry)}")
        node, module = entry
        if type(node) is not int or not n_interface <= node <= MAX_NODE_ID:
            raise c.error(f"hidden[{i}]", f"node id must be an integer within [{n_interface}, {MAX_NODE_ID}] "
                          f"(ids below {n_interface} are inputs, biases and outputs), got {_show(node)}")
        if type(module) is not int or not 0 <= module < n_modules:
            raise c.error(f"hidden[{i}]", f"module {_show(module)} is not an index into modules "
                          f"(0..{n_modules - 1})")
        if node in ids:
            raise c.error(f"hidden[{i}]", f"node id {node} appears twice")
        ids.add(node)
    return ids


def _check_connections(c: _Checker, conns: Any, n_in: int, n_bias: int, n_out: int, hidden: set[int],
                       n_modules: int) -> None:
    """The hot loop of the check: a 300-connection controller takes well under 1 ms."""
    if not isinstance(conns, list):
        raise c.error("connections", f"must be a list of [src, dst, weight, module], got {_show(conns)}")
    n_interface, first_driven = n_in + n_bias + n_out, n_in + n_bias
    for i, conn in enumerate(conns):
        if not isinstance(conn, list) or len(conn) != 4:
            raise c.error(f"connections[{i}]", f"must be [src, dst, weight, module], got {_show(conn)}")
        src, dst, weight, module = conn
        for end, node in (("src", src), ("dst", dst)):
            if type(node) is not int:
                raise c.error(f"connections[{i}]", f"{end} must be an integer node id, got {_show(node)}")
            if not (0 <= node < n_interface or node in hidden):
                raise c.error(f"connections[{i}]", f"{end} {_show(node)} is not a node of this network "
                              f"(0..{n_interface - 1} and the hidden ids)")
        if dst < first_driven:
            raise c.error(f"connections[{i}]", f"dst {dst} is an input or bias node (nothing drives those)")
        if isinstance(weight, _NonFinite) or isinstance(weight, float) and not math.isfinite(weight):
            raise c.error(f"connections[{i}]", f"weight must be a finite number, got {_show(weight)}")
        if isinstance(weight, bool) or not isinstance(weight, (int, float)):
            raise c.error(f"connections[{i}]", f"weight must be a number, got {_show(weight)}")
        if not -MAX_WEIGHT <= weight <= MAX_WEIGHT:
            raise c.error(f"connections[{i}]", f"weight {_show(weight)} is beyond the format's bound "
                          f"|weight| <= {MAX_WEIGHT:g}")
        if type(module) is not int or not 0 <= module < n_modules:
            raise c.error(f"connections[{i}]", f"module {_show(module)} is not an index into modules "
                          f"(0..{n_modules - 1})")


def _check_joints(c: _Checker, joints: Any) -> list[str]:
    c.obj(joints, "joints", ("driven", "range_rad"), ("hold_rad", "output_rule"))
    driven = c.names(joints["driven"], "joints.driven", 1)
    ranges = c.obj(joints["range_rad"], "joints.range_rad", free=True)
    for name in driven:
        if name not in ranges:
            raise c.error(_join("joints.range_rad", name), "missing (every driven joint needs its range)")
    for name, pair in ranges.items():
        key = _join("joints.range_rad", name)
        if not isinstance(pair, list) or len(pair) != 2:
            raise c.error(key, f"must be [low, high] [rad], got {_show(pair)}")
        lo = c.number(pair[0], f"{key}[0]", -ANGLE_LIMIT_RAD, ANGLE_LIMIT_RAD)
        hi = c.number(pair[1], f"{key}[1]", -ANGLE_LIMIT_RAD, ANGLE_LIMIT_RAD)
        if not lo < hi:
            raise c.error(key, f"low must be below high, got {_show(pair)}")
    for name, value in c.obj(joints.get("hold_rad", {}), "joints.hold_rad", free=True).items():
        c.number(value, _join("joints.hold_rad", name), -ANGLE_LIMIT_RAD, ANGLE_LIMIT_RAD)
        if name in driven:
            raise c.error(_join("joints.hold_rad", name), "is a driven joint: only joints not driven are held")
    if "output_rule" in joints:
        c.string(joints["output_rule"], "joints.output_rule")
    return driven


def _check_symmetry(c: _Checker, sym: Any, driven: list[str], inputs: list[str], outputs: list[str],
                    clock: bool, efference: bool, heading: bool) -> None:
    """The symmetry block against the driven joints, and the inputs and outputs it implies
    (:func:`sim2real.controller.symmetry.symmetric_layout` names them so): the heading after
    the sensors with a ``heading_input``, the clock's after them when the file has a
    ``phase_period_s``, the last goals last with an ``efference_copy``."""
    c.obj(sym, "symmetry", ("networks", "leg_joints", "center_joints", "center_mirror_for_left"),
          ("center_output",))
    if sym["networks"] != NETWORKS:
        raise c.error("symmetry.networks", f"must be {NETWORKS}, got {_show(sym['networks'])}")
    legs = c.obj(sym["leg_joints"], "symmetry.leg_joints", ("right", "left"))
    right = c.names(legs["right"], "symmetry.leg_joints.right")
    left = c.names(legs["left"], "symmetry.leg_joints.left")
    if len(right) != len(left):
        raise c.error("symmetry.leg_joints", f"{len(right)} right joints but {len(left)} left")
    center = c.names(sym["center_joints"], "symmetry.center_joints")
    mirror = sym["center_mirror_for_left"]
    if not isinstance(mirror, list) or len(mirror) != len(center):
        raise c.error("symmetry.center_mirror_for_left", f"must be one of -1, 1 per centre joint, got {_show(mirror)}")
    for i, m in enumerate(mirror):
        if isinstance(m, bool) or m not in (-1, 1):
            raise c.error(f"symmetry.center_mirror_for_left[{i}]", f"must be -1 or 1, got {_show(m)}")
    if "center_output" in sym:
        c.string(sym["center_output"], "symmetry.center_output")
    wired = right + left + center
    if len(set(wired)) != len(wired):
        raise c.error("symmetry", f"{_show(next(n for i, n in enumerate(wired) if n in wired[:i]))} is wired twice")
    if set(wired) != set(driven):
        raise c.error("symmetry", _difference("joints.driven", sorted(set(wired) - set(driven)),
                                              sorted(set(driven) - set(wired))))
    k = len(right)
    own = outputs[:k]
    for i, name in enumerate(own):
        if not name.startswith("own_"):
            raise c.error(f"outputs[{i}]", f"{_show(name)}: the first {k} outputs are the own leg's (own_...)")
    why = f"the symmetry block ({k} leg joints, centre joints {_show(center)})"
    c.same_names("outputs", outputs, own + center, why)
    angles = own + ["other_" + n[4:] for n in own] + center
    sensors = list(SENSOR_INPUTS) + ([HEADING_INPUT] if heading else []) + (list(PHASE_INPUTS) if clock else [])
    goals = [n + GOAL_SUFFIX for n in angles] if efference else []
    c.same_names("inputs", inputs, angles + sensors + goals,
                 why[:-1] + (", then 4 sensors" + (" and the heading (heading_input)" if heading
                                                   else "; a heading input needs heading_input: true"))
                 + (", then the clock (phase_period_s)" if clock else "; a clock's inputs need a phase_period_s")
                 + (", then the last goals (efference_copy))" if efference
                    else "; the last goals as inputs need efference_copy: true)"))


def _difference(what: str, extra: list[str], lacking: list[str]) -> str:
    parts = [f"has {_show(extra)} beyond {what}"] if extra else []
    return "; ".join(parts + ([f"lacks {_show(lacking)} of {what}"] if lacking else []))


def _check_robot(c: _Checker, data: dict[str, Any], robot: RobotSpec) -> None:
    want = joint_map_hash(robot)
    if data["robot"]["joint_map_hash"] != want:
        raise c.error("robot.joint_map_hash", f"made for robot {data['robot']['name']!r} with joint map "
                      f"{data['robot']['joint_map_hash']}, but {robot.name} has {want}")
    driven = data["joints"]["driven"]
    control_set = data["task"].get("control_set")
    if control_set is not None:
        if control_set not in robot.control_sets:
            raise c.error("task.control_set", f"robot {robot.name} has no control set {_show(control_set)} "
                          f"(has {', '.join(robot.control_sets)})")
        members = set(robot.control_sets[control_set])
        if set(driven) != members:
            raise c.error("joints.driven", _difference(f"robot {robot.name}'s {control_set!r} control set "
                                                       "(task.control_set)", sorted(set(driven) - members),
                                                       sorted(members - set(driven))))
    try:
        layout = symmetric_layout(robot, tuple(driven), "phase_period_s" in data, data.get("efference_copy", False),
                                  data.get("heading_input", False))
    except (ValueError, KeyError) as exc:
        raise c.error("joints.driven", str(exc)) from None
    why = f"robot {robot.name} driving {_show(list(layout.driven))}"
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
                    raise c.error(_join("joints.range_rad", name), f"{_show(value)} differs from robot "
                                  f"{robot.name}'s {list(actual)}")
            elif not actual[0] - RANGE_TOLERANCE_RAD <= value <= actual[1] + RANGE_TOLERANCE_RAD:
                raise c.error(_join("joints.hold_rad", name), f"{_show(value)} rad ({math.degrees(value):.1f} deg) "
                              f"is outside the joint's range [{actual[0]:.6g}, {actual[1]:.6g}] rad "
                              f"([{math.degrees(actual[0]):.1f}, {math.degrees(actual[1]):.1f}] deg, robot "
                              f"{robot.name}'s range_deg): a held joint must hold an angle it can reach")
    low, high, why = tick_bounds(robot)
    tick = data["tick_s"]
    if not low - 1e-12 <= tick <= high + 1e-12:
        raise c.error("tick_s", f"{_show(tick)} s is outside the ticks robot {robot.name} can run at, "
                      f"[{low * 1e3:.3g}, {high * 1e3:.3g}] ms: {why}; its own tick is "
                      f"{control_timing(robot).tick_s * 1e3:.3g} ms")


def tick_bounds(robot: RobotSpec) -> tuple[float, float, str]:
    """The control ticks a controller may run at on ``robot``: (shortest, longest [s], where
    both come from, in words).  Shortest: one bus cycle - the sync write of every goal, the
    sync read of every position and the sensor board's read at the robot's baud
    (:func:`sim2real.robot.timing.bus_cycle_s`) - or one physics step for a robot without a
    bus.  Longest: half the Bus Watchdog that start-up sets on servos that have one (goals
    must keep coming though one tick runs late), else the format's bound."""
    from sim2real.hardware.dynamixel.registers import Reg
    from sim2real.hardware.dynamixel.startup import WATCHDOG_MS
    from sim2real.robot.timing import PHYSICS_DT_S, bus_cycle_bytes, bus_cycle_s

    cycle, step = bus_cycle_s(robot), robot.physics_dt_s or PHYSICS_DT_S
    if robot.bus is not None and cycle >= step:
        low = cycle
        why = (f"the shortest is one bus cycle ({bus_cycle_bytes(robot)} bytes at {robot.bus.baud} baud, "
               "sim2real/robot/timing.py)")
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
