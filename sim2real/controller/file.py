"""Controller files: versioned, self-describing JSON of an evolved network (data only).

:class:`Controller` is what crosses from evolution to the robot: a frozen, valid controller
(``Controller.load``/``save``; ``from_dict``/``to_dict`` for the JSON values;
``for_robot`` writes the wiring of a robot's control set around an evolved network).  A
controller names its robot (and a hash of the robot's joint map, so that a file for
another robot is refused), its control tick (and its gait clock's period, if it has one),
the network's inputs and outputs in order,
the bilateral-symmetry wiring, its modules, its nodes and enabled connections, how outputs
map onto joints, and where it came from.  Its keys and bounds are those of the published
schema, ``schemas/controller-v1.schema.json`` (:mod:`sim2real.controller.schema` reads them).

``Controller.load`` checks a file whole before anything moves or simulates, so that
whatever it returns runs (:class:`~sim2real.controller.policy.Policy`) without an exception;
every problem is one :class:`ConfigError` line, ``FILE: FIELD: problem``.  The bytes are
decoded by :mod:`sim2real.controller.json_reader` (size, UTF-8, nesting depth, duplicate
keys, non-finite numbers), the values checked by
:func:`~sim2real.controller.checks.check_controller` (every field, and with a robot its
joint map, control set, joint ranges and tick), the one validation, which every
``Controller`` passes on construction too.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, ClassVar, Mapping

import numpy as np

from sim2real.atomic_json import write_text_atomic
from sim2real.controller.checks import check_controller
from sim2real.controller.robot_checks import joint_map_hash
from sim2real.controller.json_reader import decode, read_bounded
from sim2real.controller import channels
from sim2real.controller.mapping import OUTPUT_RULES, hold_pose
from sim2real.controller.schema import FIELDS, FORMAT, NETWORKS, VERSION
from sim2real.controller.symmetry import BIAS, CENTER_OUTPUT, SymmetricLayout, symmetric_layout, wired_layout
from sim2real.errors import ConfigError
from sim2real.robot import RobotSpec, load_robot
from sim2real.robot.names import ROBOT_FLAG, load_named_robot
from sim2real.robot.timing import control_timing

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
    centre_rad: Mapping[str, float] | None = None  # the home rule's middles, driven joints [rad]

    def to_dict(self) -> dict[str, Any]:
        block: dict[str, Any] = {"driven": list(self.driven), "range_rad": _thawed(self.range_rad)}
        if self.hold_rad is not None:
            block["hold_rad"] = dict(self.hold_rad)
        if self.output_rule is not None:
            block["output_rule"] = self.output_rule
        if self.centre_rad is not None:
            block["centre_rad"] = dict(self.centre_rad)
        return block

    def centres(self) -> np.ndarray | None:
        """The driven joints' output centres in ``driven`` order (None: the range rule)."""
        return None if self.centre_rad is None else np.array([self.centre_rad[n] for n in self.driven])


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
    # the optional input channels on, with their settings (sim2real.controller.channels; a
    # file holds them as each channel's keys: heading_input, phase_period_s, ...)
    input_channels: Mapping[str, Mapping[str, float]] = field(default_factory=lambda: MappingProxyType({}))
    # a reaching controller's right arm, root to hand (sim2real.controller.kinematics.ArmChain)
    reach_arm: Mapping[str, Any] | None = None

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
                            joints.get("output_rule"),
                            MappingProxyType(dict(joints["centre_rad"])) if "centre_rad" in joints else None),
            task=_frozen(data["task"]), provenance=_frozen(data["provenance"]),
            input_channels=_frozen(channels.selection(data)),
            reach_arm=_frozen(data["reach_arm"]) if "reach_arm" in data else None,
        )

    def to_dict(self) -> dict[str, Any]:
        """The JSON values of the file, keys in the format's order."""
        keys = channels.selection_keys(self.input_channels)
        input_keys = {key: keys[key] for key in FIELDS if key in keys}  # in the format's order
        return {
            "format": self.format, "version": self.version,
            "robot": {"name": self.robot_name, "joint_map_hash": self.joint_map_hash},
            "tick_s": self.tick_s, **input_keys, "inputs": list(self.inputs), "outputs": list(self.outputs),
            "bias": _thawed(self.bias), "symmetry": self.symmetry.to_dict(),
            "sigmoid_steepness": self.sigmoid_steepness,
            "modules": [{"name": m, "enabled": True} for m in self.modules],
            "hidden": _thawed(self.hidden), "connections": _thawed(self.connections),
            "joints": self.joints.to_dict(),
            **({"reach_arm": _thawed(self.reach_arm)} if self.reach_arm is not None else {}),
            "task": _thawed(self.task), "provenance": _thawed(self.provenance),
        }

    @classmethod
    def for_robot(cls, robot: RobotSpec, layout: SymmetricLayout, *, sigmoid_steepness: float,
                  modules: tuple[str, ...], hidden: list[tuple[int, int]],
                  connections: list[tuple[int, int, float, int]], task: Mapping[str, Any],
                  provenance: Mapping[str, Any], reach_arm: Mapping[str, Any] | None = None) -> "Controller":
        """An evolved network (``hidden`` and ``connections`` in node ids) wired for
        ``robot``'s joints by ``layout`` (its inputs too): its tick, bias values, symmetry
        block, joint ranges and hold pose are the robot's and the conventions' own; the output
        rule is the task's ``output_centre`` (range, default, or home)."""
        hold = hold_pose(robot, layout.driven)
        centre = task.get("output_centre", "range")
        return cls(
            robot_name=robot.name, joint_map_hash=joint_map_hash(robot), tick_s=control_timing(robot).tick_s,
            inputs=layout.input_names, outputs=layout.output_names, bias=BIAS, symmetry=Symmetry.of(robot, layout),
            sigmoid_steepness=sigmoid_steepness, modules=tuple(modules), hidden=_frozen(hidden),
            connections=_frozen(connections),
            joints=JointMap(layout.driven, _frozen({j.name: j.range_rad for j in robot.joints}),
                            MappingProxyType({j.name: float(hold[i]) for i, j in enumerate(robot.joints)
                                              if j.name not in layout.driven}), OUTPUT_RULES[centre],
                            None if centre == "range" else MappingProxyType(
                                {j.name: float(j.home_rad) for j in robot.joints if j.name in layout.driven})),
            task=_frozen(dict(task)), provenance=_frozen(dict(provenance)),
            input_channels=_frozen(dict(layout.inputs)), reach_arm=None if reach_arm is None else _frozen(dict(reach_arm)),
        )

    # -- the input channels' settings, by name ---------------------------------------------------
    @property
    def phase_period_s(self) -> float | None:
        """The gait clock's period [s]; None: no clock."""
        return self.input_channels["clock"]["phase_period_s"] if "clock" in self.input_channels else None

    @property
    def efference_copy(self) -> bool:
        return "efference" in self.input_channels

    @property
    def heading_input(self) -> bool:
        return "heading" in self.input_channels

    # -- files ---------------------------------------------------------------------------------
    @classmethod
    def load(cls, path: Path | str, robot: RobotSpec | None = None) -> "Controller":
        """Read and check a controller file; with ``robot``, refuse one made for another robot
        or driving other joints.  Raises :class:`ConfigError` (one line) for any problem."""
        source = str(path)
        return cls.from_dict(decode(read_bounded(path, source), source), source, robot)

    @classmethod
    def load_for_robot(cls, path: Path | str, robot: str | None = None, *,
                       robot_flag: str | None = ROBOT_FLAG) -> tuple["Controller", RobotSpec]:
        """The controller and its robot - ``robot`` if named (on the command line: a name or
        a path), else the one the file names, looked up among the project's robots only
        (:func:`~sim2real.robot.names.load_named_robot`; ``robot_flag``: how the command takes
        a robot file instead, None if it does not) - checked against each other."""
        if robot:
            spec = load_robot(robot)
        else:
            spec = load_named_robot(cls.load(path).robot_name, str(path), "robot.name", flag=robot_flag)
        return cls.load(path, spec), spec

    def save(self, path: Path | str) -> None:
        """Write atomically, one top-level key a line (:func:`dumps`)."""
        write_text_atomic(path, dumps(self.to_dict()))

    @classmethod
    def ship(cls, source: Path | str, path: Path | str, made: dict[str, Any]) -> str:
        """Write the controller file ``source`` as ``path`` with ``made`` (the command that made it,
        its measures) added to its provenance.  The evolution's run folder (``run``) is left out:
        it names a folder on the machine that trained it.  Returns ``path`` as a string."""
        data = cls.load(source).to_dict()
        data["provenance"] = {**{k: v for k, v in data["provenance"].items() if k != "run"}, **made}
        cls.from_dict(data, str(path)).save(path)
        return str(path)

    # -- wiring ----------------------------------------------------------------------------------
    def layout(self, robot: RobotSpec) -> SymmetricLayout:
        """The wiring of the symmetry block on ``robot``, checked to be the one the robot
        gives for the driven joints (:func:`~sim2real.controller.symmetry.symmetric_layout`)."""
        s = self.symmetry
        source = f"controller for {self.robot_name}"
        try:
            wired = wired_layout(robot, s.right, s.left, s.center, s.center_mirror_for_left, self.input_channels)
            rule = symmetric_layout(robot, self.joints.driven, self.input_channels)
        except ValueError as exc:
            raise ConfigError(source, "symmetry", str(exc)) from None
        if wired != rule or (rule.input_names, rule.output_names) != (self.inputs, self.outputs):
            raise ConfigError(source, "symmetry", f"the wiring differs from robot {robot.name}'s for the driven "
                              f"joints {list(rule.driven)} (inputs {list(rule.input_names)}, outputs "
                              f"{list(rule.output_names)})")
        return wired
