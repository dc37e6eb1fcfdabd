"""What a network senses: its input channels, in one ordered registry (:data:`CHANNELS`).

A channel turns one tick's sensor readings (:class:`Readings`, the same in evolution and on
the robot) into a few raw values, and says which of them each of the two networks of a
symmetric controller reads, with which sign: the right network reads a value as it is, the
left network reads the mirror image - an odd quantity (a lateral tilt, a roll or yaw rate,
a turn) with its sign changed, an even one (a forward tilt, a pitch rate) as it is, the other
leg's joints where the right network reads its own.  Evolution (``mujoco.batch``) and the
runtime (:class:`~sim2real.controller.policy.Policy`) both call :meth:`InputWiring.inputs`,
so they agree bit for bit by construction; :func:`sim2real.controller.symmetry.network_inputs`
is the plain per-side reference they are tested against.

Channels come in registry order: the joint angles, the feet, the up-vector (always), then the
optional ones a task config or controller file switches on by their keys (:attr:`Channel.switch`,
with their :class:`Setting` values): the heading, the gyro, the gait clock, the efference copy.
A channel that needs a sensor the sensor board may lack names it (:attr:`Channel.sensor`:
a :class:`Readings` field); the runtime refuses such a controller on a board without it
before any servo moves.  Adding a channel is a class here, an entry in :data:`CHANNELS`, its
keys in the controller schema and its reading in the sensor's source (the board's registers,
the simulation's sensor).

    wiring = InputWiring(layout, low, high)           # once
    x = wiring.inputs(Readings(angles=..., feet=..., up=..., time_s=t))   # (2 n, n_inputs)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from sim2real.controller.mapping import normalized_angle
from sim2real.controller.schema import FIELDS

if TYPE_CHECKING:  # the layout imports this module for the names
    from sim2real.controller.symmetry import SymmetricLayout


InputSettings = Mapping[str, Mapping[str, float]]  # optional channel key -> its settings, for the channels on


@dataclass(frozen=True)
class Readings:
    """One tick's readings of ``n`` robots (rows), in SI units."""

    angles: np.ndarray  # (n, joints) joint angles [rad], robot order
    feet: np.ndarray  # (n, 2) bool: (left, right) foot switch closed
    up: np.ndarray  # (n, 3) world up in the torso frame (x forward, y left, z up), an IMU's gravity negated
    time_s: float = 0.0  # since the first tick [s]: the gait clock's time
    previous_goal: np.ndarray | None = None  # (n, joints) the goals sent last tick [rad]
    heading: np.ndarray | None = None  # (n,) the IMU's yaw, counter-clockwise seen from above [rad]
    target_heading: np.ndarray | None = None  # (n,) the heading to hold [rad]: the first tick's, turned by a command
    gyro: np.ndarray | None = None  # (n, 3) the torso's angular rate about its x, y, z axes [rad/s]
    reach_state: np.ndarray | None = None  # (n,) 1 while the right hand reaches, 0 while it returns
    reach_target: np.ndarray | None = None  # (n, 3) the target from the right shoulder [arm lengths], root frame


@dataclass(frozen=True)
class Setting:
    """A value a channel takes from the task config or controller file, bounded by the schema."""

    key: str  # the key in task configs and controller files
    default: float
    low: float
    high: float  # inclusive
    unit: str
    low_open: bool  # low itself is refused

    @classmethod
    def of_schema(cls, key: str, default: float, unit: str) -> "Setting":
        field = FIELDS[key]
        low_open = "exclusiveMinimum" in field
        low = field["exclusiveMinimum"] if low_open else field["minimum"]
        return cls(key, default, float(low), float(field["maximum"]), unit, low_open)

    def admits(self, value: float) -> bool:
        return (self.low < value if self.low_open else self.low <= value) and value <= self.high

    @property
    def bounds(self) -> str:
        return f"{'(' if self.low_open else '['}{self.low:g}, {self.high:g}] {self.unit}"


class Channel:
    """One kind of input; see the module docstring.  Subclasses fill in the three methods."""

    key: str = ""
    switch: str | None = None  # the key that turns it on (None: always on, or on by its first setting > 0)
    settings: tuple[Setting, ...] = ()
    sensor: str | None = None  # the Readings field it needs beyond angles, feet and up
    width: int = 0  # raw values (joint channels: one a joint)

    @property
    def optional(self) -> bool:
        return self.switch is not None or bool(self.settings)

    def names(self, angles: list[str]) -> list[str]:
        """The right network's input names, given those of the joint angles (own_..., other_...,
        centre joints: :func:`angle_names`)."""
        raise NotImplementedError

    def raw_width(self, n_joints: int) -> int:
        return self.width

    def raw(self, r: Readings, wiring: "InputWiring") -> np.ndarray:
        """(n, raw_width) the values both networks read from."""
        raise NotImplementedError

    def gather(self, layout: "SymmetricLayout") -> tuple[np.ndarray, np.ndarray]:
        """(2, inputs) which raw value each network's input is, and (2, inputs) its sign;
        rows right, left."""
        raise NotImplementedError

    def setting(self, wiring: "InputWiring", key: str) -> float:
        return float(wiring.layout.inputs[self.key][key])


def turn_rad(heading_rad: np.ndarray | float, start_rad: np.ndarray | float) -> np.ndarray:
    """The turn from ``start_rad`` to ``heading_rad`` (yaws about world up, counter-clockwise
    seen from above, as an IMU reports them [rad]), wrapped to [-pi, pi]."""
    return np.angle(np.exp(1j * (np.asarray(heading_rad, dtype=float) - start_rad)))


def _same(width: int, signs: tuple[float, ...] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Both networks read values 0..width-1 in order, the right as they are, the left times ``signs``."""
    index = np.tile(np.arange(width), (2, 1))
    sign = np.ones((2, width))
    if signs is not None:
        sign[1] = signs
    return index, sign


class JointAngles(Channel):
    """Driven joint angles, own leg, other leg, centre (mirrored: yaw and roll), over each range to
    [-1, 1]."""

    key = "joints"

    def names(self, angles):
        return list(angles)

    def raw_width(self, n_joints):
        return n_joints

    def raw(self, r, wiring):
        return normalized_angle(r.angles, wiring.low, wiring.high)

    def gather(self, layout):
        right, left, centre = layout.leg_index["right"], layout.leg_index["left"], layout.center_index
        index = np.stack([np.concatenate([right, left, centre]), np.concatenate([left, right, centre])])
        sign = np.ones(index.shape)
        sign[1, 2 * len(right):] = layout.center_mirror
        return index, sign


class Feet(Channel):
    """Foot switches, own foot first: -1 touching, +1 not (seed 000 section 7.1)."""

    key = "feet"
    width = 2

    def names(self, angles):
        return ["own_foot", "other_foot"]

    def raw(self, r, wiring):
        return np.where(r.feet, -1.0, 1.0)  # columns left, right

    def gather(self, layout):
        return np.array([[1, 0], [0, 1]]), np.ones((2, 2))


class UpVector(Channel):
    """The torso's tilt forward (both networks alike) and toward the network's own side (mirrored),
    from the IMU's up-vector."""

    key = "up"
    width = 2

    def names(self, angles):
        return ["up_forward", "up_sideways"]

    def raw(self, r, wiring):
        return r.up[:, :2]

    def gather(self, layout):
        # leaning forward tilts world up toward the torso's -x; leaning right toward its +y
        return np.array([[0, 1], [0, 1]]), np.array([[-1.0, 1.0], [-1.0, -1.0]])


class Heading(Channel):
    """The torso's turn from the heading to hold (the first tick's, turned by a command) toward the
    network's own side, over heading_scale_deg, clipped to [-1, 1] (mirrored)."""

    key = "heading"
    width = 1
    switch = "heading_input"
    settings = (Setting.of_schema("heading_scale_deg", 180.0, "deg"),)
    sensor = "heading"

    def names(self, angles):
        return ["heading"]

    def raw(self, r, wiring):
        if r.target_heading is None:
            raise ValueError("the heading input needs the target heading")
        turn = turn_rad(r.heading, r.target_heading)
        scale = np.radians(self.setting(wiring, "heading_scale_deg"))
        return np.clip(-turn / scale, -1.0, 1.0)[:, None]  # turning right is positive for the right network

    def gather(self, layout):
        return _same(1, (-1.0,))


class Gyro(Channel):
    """The torso's angular rate (roll, pitch, yaw) over gyro_scale_dps, clipped to [-1, 1]; roll
    and yaw rate mirrored, pitch rate not."""

    key = "gyro"
    width = 3
    switch = "gyro_input"
    settings = (Setting.of_schema("gyro_scale_dps", 180.0, "deg/s"),)
    sensor = "gyro"

    def names(self, angles):
        return ["gyro_roll", "gyro_pitch", "gyro_yaw"]

    def raw(self, r, wiring):
        scale = np.radians(self.setting(wiring, "gyro_scale_dps"))
        return np.clip(np.asarray(r.gyro, dtype=float) / scale, -1.0, 1.0)

    def gather(self, layout):
        return _same(3, (-1.0, 1.0, -1.0))


class Clock(Channel):
    """The gait clock: sin and cos of 2 pi t / phase_period_s, the left network's half a period
    later."""

    key = "clock"
    width = 2
    settings = (Setting.of_schema("phase_period_s", 0.0, "s"),)

    def names(self, angles):
        return ["phase_sin", "phase_cos"]

    def raw(self, r, wiring):
        angle = 2.0 * np.pi * np.asarray(r.time_s, dtype=float) / self.setting(wiring, "phase_period_s")
        n = len(r.angles)
        return np.broadcast_to(np.stack([np.sin(angle), np.cos(angle)], axis=-1), (n, 2))

    def gather(self, layout):
        return _same(2, (-1.0, -1.0))


class EfferenceCopy(Channel):
    """The goals sent last tick, read as the joint angles are."""

    key = "efference"
    switch = "efference_copy"

    def names(self, angles):
        return [name + "_goal" for name in angles]

    def raw_width(self, n_joints):
        return n_joints

    def raw(self, r, wiring):
        return normalized_angle(r.previous_goal, wiring.low, wiring.high)

    def gather(self, layout):
        return JOINT_ANGLES.gather(layout)


class Reach(Channel):
    """Seed 002's "reach control" input and where to reach: the right network reads the reach
    state (1 reaching, 0 returning to rest) and, while reaching, the target's offset from the
    right shoulder [arm lengths] (x forward, y left, z up in the root body's frame); the left
    network reads 0 for all four.  A symmetric controller meets a one-handed task this way: one
    genome, but only the right copy is told to reach, so the left arm keeps its rest."""

    key = "reach"
    width = 5  # the state, the target (x, y, z), and the left network's zero
    switch = "reach_input"
    settings = (Setting.of_schema("reach_forward", 0.7, "arm lengths"),
                Setting.of_schema("reach_left", 0.0, "arm lengths"),
                Setting.of_schema("reach_up", 0.2, "arm lengths"),
                Setting.of_schema("reach_tolerance", 0.15, "arm lengths"),
                Setting.of_schema("reach_phase_s", 1.0, "s"))

    def names(self, angles):
        return ["reach_control", "target_forward", "target_left", "target_up"]

    def raw(self, r, wiring):
        if r.reach_state is None or r.reach_target is None:
            raise ValueError("the reach input needs the reach state and target")
        state = np.asarray(r.reach_state, dtype=float)[:, None]
        return np.concatenate([state, state * r.reach_target, np.zeros_like(state)], axis=1)

    def gather(self, layout):
        return np.array([[0, 1, 2, 3], [4, 4, 4, 4]]), np.ones((2, 4))

    @staticmethod
    def target(settings: Mapping[str, float]) -> np.ndarray:
        """(3,) the target a controller's settings give [arm lengths from the right shoulder]."""
        return np.array([settings["reach_forward"], settings["reach_left"], settings["reach_up"]])


JOINT_ANGLES = JointAngles()
REACH = Reach()
CHANNELS: tuple[Channel, ...] = (JOINT_ANGLES, Feet(), UpVector(), Heading(), Gyro(), Clock(), EfferenceCopy(),
                                 REACH)
BY_KEY: dict[str, Channel] = {c.key: c for c in CHANNELS}


def selection(values: Mapping[str, Any]) -> dict[str, dict[str, float]]:
    """The optional channels that ``values`` (a task config's or controller file's keys,
    already checked) switch on, with their settings, in registry order."""
    chosen = {}
    for channel in CHANNELS:
        if not channel.optional:
            continue
        if channel.switch is not None:
            on = bool(values.get(channel.switch, False))
        else:  # on by its first setting, > 0 (the clock's period)
            first = values.get(channel.settings[0].key)
            on = first is not None and float(first) > 0
        if on:
            chosen[channel.key] = {s.key: float(values.get(s.key, s.default)) for s in channel.settings}
    return chosen


def selection_keys(settings: InputSettings) -> dict[str, Any]:
    """The keys a controller file writes for ``settings``: each channel's switch, and each
    setting that is not its default (files of the defaults stay as they were)."""
    keys: dict[str, Any] = {}
    for channel in CHANNELS:
        if channel.key not in settings:
            continue
        if channel.switch is not None:
            keys[channel.switch] = True
        for i, s in enumerate(channel.settings):
            value = settings[channel.key][s.key]
            if (channel.switch is None and i == 0) or value != s.default:
                keys[s.key] = value
    return keys


def angle_names(leg_slots: Sequence[tuple[str, ...]], center: Sequence[str]) -> list[str]:
    """The joint angles' input names: ``own_<location>_<axis>`` for each leg slot (``own_knee``
    for the knee; the second joint of a slot along its chain, index 1, ``own_<location>_<axis>_2``),
    the same with ``other_``, then the centre joints' own names.  A slot is (location, axis) or
    (location, axis, index)."""
    slots = [(f"{slot[0]}_{slot[1]}" if slot[0] != "knee" else "knee")
             + (f"_{slot[2] + 1}" if len(slot) > 2 and slot[2] else "") for slot in leg_slots]
    return [f"own_{s}" for s in slots] + [f"other_{s}" for s in slots] + list(center)


def every_key(settings: InputSettings) -> dict[str, Any]:
    """Every channel's keys with their values for ``settings``: switches true or false, the
    settings of channels off at their defaults - what a task config takes to read exactly
    these inputs, whatever it read before."""
    keys: dict[str, Any] = {}
    for channel in CHANNELS:
        if channel.switch is not None:
            keys[channel.switch] = channel.key in settings
        for s in channel.settings:
            keys[s.key] = settings[channel.key][s.key] if channel.key in settings else s.default
    return keys


def input_names(angles: list[str], settings: InputSettings) -> tuple[str, ...]:
    """The right network's input names, channel by channel in registry order, for the joint
    angles' names ``angles`` (:func:`angle_names`) and the optional channels ``settings``."""
    return tuple(name for c in active(settings) for name in c.names(angles))


def active(settings: InputSettings) -> tuple[Channel, ...]:
    """The channels a controller with these optional ``settings`` reads, in registry order."""
    unknown = set(settings) - set(BY_KEY)
    if unknown:
        raise ValueError(f"unknown input channels {sorted(unknown)} (known: {', '.join(BY_KEY)})")
    return tuple(c for c in CHANNELS if not c.optional or c.key in settings)


def sensors_needed(settings: InputSettings) -> tuple[str, ...]:
    """The :class:`Readings` fields beyond angles, feet and up that these inputs read."""
    return tuple(c.sensor for c in active(settings) if c.sensor)


class InputWiring:
    """Both networks' inputs of a layout as one gather from its channels' raw values.

    ``low``, ``high``: every joint's range [rad] (robot order), over which angles are normalized.
    """

    def __init__(self, layout: "SymmetricLayout", low: np.ndarray, high: np.ndarray):
        self.layout, self.low, self.high = layout, np.asarray(low, dtype=float), np.asarray(high, dtype=float)
        self.channels = active(layout.inputs)
        index, sign, offset = [], [], 0
        for channel in self.channels:
            i, s = channel.gather(layout)
            index.append(i + offset)
            sign.append(s)
            offset += channel.raw_width(len(self.low))
        self.index = np.concatenate(index, axis=1)  # (2, n_inputs) into the raw values
        self.sign = np.concatenate(sign, axis=1)
        self.sensors = sensors_needed(layout.inputs)

    def raw(self, r: Readings) -> np.ndarray:
        """(n, raw values) every channel's raw values side by side."""
        for sensor in self.sensors:
            if getattr(r, sensor) is None:
                raise ValueError(f"these inputs read the {sensor}: give it in the readings")
        parts = [c.raw(r, self) for c in self.channels]
        return np.concatenate(parts, axis=1)

    def inputs(self, r: Readings) -> np.ndarray:
        """(2 n, n_inputs) both networks' inputs of every robot, rows interleaved right, left."""
        raw = self.raw(r)
        return (raw[:, self.index] * self.sign).reshape(-1, self.index.shape[1])
