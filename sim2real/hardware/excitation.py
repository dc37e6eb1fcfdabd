"""Excitation programs: goals that make a robot's servos show their dynamics, for system
identification (``biped excite``; the fit is ``biped sysid``).

A program moves one group of joints at a time around the home pose while the others hold
it: a lone joint (the waist) or a symmetric pair (both knees, both hip rolls...).  Each
group gets, in order:

- a *chirp*: a sine whose frequency sweeps exponentially from ``f0_hz`` to ``f1_hz``, its
  amplitude cut where a servo would have to turn faster than ``speed_share`` of its no-load
  speed, faded in and out over ``ramp_s``;
- *steps* of a few amplitudes, up and down from home, each held ``step_hold_s`` - small steps
  show the gain and friction, the largest saturate the servo and show its torque;
- holds at home between the parts.

Pairs move so that the legs stay parallel in the world: pitch joints with the same angle,
roll and yaw joints with opposite angles (angles are anatomical and mirrored, see
:mod:`sim2real.robot.spec`), so the legs never close in on each other.  Every goal stays
``margin_deg`` inside its joint's limits: amplitudes shrink to fit, and the finished program
is checked whole before it is used (:meth:`ExcitationProgram.check`).

The program drives the robot through :func:`sim2real.hardware.deploy.drive` like a controller
(the same start-up checks, ramp, real-time loop and safe stop), at its own tick - much faster
than a controller's, because a 34 ms tick would alias a 10 Hz chirp - and without the
controller's rate limit.  No MuJoCo here.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from sim2real.errors import UsageError
from sim2real.robot import RobotSpec

POSES = ("suspended", "standing")
PAIR_SIGN = {"pitch": 1.0, "roll": -1.0, "yaw": -1.0}  # the left joint's sign against the right's


@dataclass(frozen=True)
class ExcitationSettings:
    """What a program is made of; times [s], angles [deg], frequencies [Hz]."""

    tick_s: float = 0.01
    chirp_s: float = 12.0
    f0_hz: float = 0.2
    f1_hz: float = 10.0
    chirp_deg: float = 10.0  # the chirp's amplitude where the speed allows it
    speed_share: float = 0.5  # of the servo's no-load speed, at most
    step_deg: tuple[float, ...] = (2.0, 5.0, 10.0, 20.0)
    step_hold_s: float = 0.4
    hold_s: float = 0.5
    ramp_s: float = 1.0
    margin_deg: float = 2.0

    @classmethod
    def for_pose(cls, pose: str, tick_s: float = 0.01) -> "ExcitationSettings":
        """Defaults per pose: a standing robot carries its weight on the joints, so it gets
        small, slow motions that keep it on its feet."""
        if pose not in POSES:
            raise UsageError(f"pose {pose!r}: expected one of {', '.join(POSES)}")
        if pose == "standing":
            return cls(tick_s=tick_s, chirp_deg=3.0, f1_hz=4.0, step_deg=(1.0, 2.0, 4.0))
        return cls(tick_s=tick_s)

    def check(self) -> None:
        if not (math.isfinite(self.tick_s) and 0.001 <= self.tick_s <= 0.1):
            raise UsageError(f"excitation tick {self.tick_s!r} s: expected 0.001-0.1 s")
        if not 0 < self.f0_hz < self.f1_hz:
            raise UsageError(f"chirp {self.f0_hz!r}-{self.f1_hz!r} Hz: expected 0 < start < end")
        nyquist = 0.5 / self.tick_s
        if self.f1_hz > nyquist / 2:
            raise UsageError(f"chirp up to {self.f1_hz:g} Hz at a {self.tick_s * 1e3:g} ms tick: at least four "
                             f"goals a period are needed (at most {nyquist / 2:g} Hz); use a faster tick")
        if min(self.chirp_s, self.step_hold_s, self.hold_s, self.ramp_s) <= 0:
            raise UsageError("excitation durations must be > 0")
        if self.chirp_s <= 2 * self.ramp_s:
            raise UsageError(f"chirp of {self.chirp_s:g} s: must be longer than its fade in and out "
                             f"({2 * self.ramp_s:g} s)")


@dataclass(frozen=True)
class Segment:
    """One part of a program: ``kind`` (chirp | steps) of group ``group`` (its joints),
    ticks ``start`` to ``end`` (exclusive)."""

    group: str
    joints: tuple[str, ...]
    kind: str
    start: int
    end: int


def joint_groups(robot: RobotSpec, joints: list[str] | None = None) -> list[tuple[str, tuple[str, ...]]]:
    """(name, joints) to excite: centre joints alone, left/right pairs together; ``joints``
    (names, or pair names such as ``knee`` or ``hip_pitch``) picks some; default all."""
    names = robot.joint_names
    groups: dict[str, tuple[str, ...]] = {}
    for j in robot.joints:
        key = f"{j.location}_{j.axis}" if j.side != "center" else j.name
        if j.location == "knee":
            key = "knee"
        if j.side != "center" and j.index:  # the second joint of one role along the chain
            key += f"_{j.index + 1}"
        groups[key] = groups.get(key, ()) + (j.name,)
    if not joints:
        return list(groups.items())
    chosen = []
    for item in joints:
        if item in groups:
            chosen.append((item, groups[item]))
        elif item in names:
            chosen.append((item, (item,)))
        else:
            raise UsageError(f"--joints {item!r}: not a joint or pair of {robot.name} "
                             f"(pairs: {', '.join(groups)}; joints: {', '.join(names)})")
    return chosen


@dataclass
class ExcitationProgram:
    """Goals a tick [rad], in robot joint order, and what each stretch of them is.

    It is a goal source for :func:`sim2real.hardware.deploy.drive`: ``tick_s``, ``hold``
    (the pose it starts and ends in), :meth:`reset` and :meth:`step`.
    """

    robot: RobotSpec
    pose: str
    settings: ExcitationSettings
    goals: np.ndarray  # (ticks, joints) [rad]
    segments: list[Segment] = field(default_factory=list)
    trace_motion = True  # the loop traces velocities and loads too (identification may use them)

    @property
    def tick_s(self) -> float:
        return self.settings.tick_s

    @property
    def hold(self) -> np.ndarray:
        return np.array([j.home_rad for j in self.robot.joints])

    @property
    def duration_s(self) -> float:
        return len(self.goals) * self.tick_s

    def reset(self) -> np.ndarray:
        return self.hold.copy()

    def step(self, angles: np.ndarray, feet_touching: np.ndarray, up: np.ndarray, previous: np.ndarray,
             tick: int = 0, heading: float | None = None, gyro: np.ndarray | None = None) -> np.ndarray:
        """The program's goals at ``tick`` (its clock is the loop's tick count, so a missed
        tick does not stretch the program); home after its end."""
        return self.goals[tick].copy() if tick < len(self.goals) else self.hold

    def check(self) -> None:
        """Every goal finite and inside its joint's limits (with the margin); raises otherwise."""
        low, high = (np.array([j.range_rad[k] for j in self.robot.joints]) for k in (0, 1))
        margin = math.radians(self.settings.margin_deg) - 1e-9
        bad = ~np.isfinite(self.goals) | (self.goals < low + margin) | (self.goals > high - margin)
        if bad.any():
            tick, k = map(int, np.argwhere(bad)[0])
            raise UsageError(f"excitation goal {math.degrees(self.goals[tick, k]):.2f} deg for "
                             f"{self.robot.joint_names[k]} at {tick * self.tick_s:.2f} s is outside its limits "
                             f"with a {self.settings.margin_deg:g} deg margin")

    def trace_metadata(self) -> dict[str, Any]:
        """What a trace of this program records about it (``biped sysid`` reads it)."""
        return {"excitation": {"pose": self.pose, "settings": asdict(self.settings),
                               "segments": [asdict(s) for s in self.segments]}}

    def describe(self) -> str:
        groups = ", ".join(dict.fromkeys(s.group for s in self.segments))
        return (f"excitation of {groups} ({self.pose}): {self.duration_s:.0f} s at a "
                f"{self.tick_s * 1e3:g} ms tick, chirps {self.settings.f0_hz:g}-{self.settings.f1_hz:g} Hz, "
                f"steps of {', '.join(f'{a:g}' for a in self.settings.step_deg)} deg")


def build_program(robot: RobotSpec, pose: str = "suspended", joints: list[str] | None = None,
                  settings: ExcitationSettings | None = None) -> ExcitationProgram:
    """The excitation program for ``robot`` (every servo joint unless ``joints`` picks
    groups), checked whole."""
    if pose not in POSES:
        raise UsageError(f"pose {pose!r}: expected one of {', '.join(POSES)}")
    settings = settings or ExcitationSettings.for_pose(pose)
    settings.check()
    home = np.array([j.home_rad for j in robot.joints])
    index = {name: k for k, name in enumerate(robot.joint_names)}
    rows: list[np.ndarray] = []
    segments: list[Segment] = []
    n_ticks = 0

    def add(kind: str, group: str, members: tuple[str, ...], offsets: np.ndarray) -> None:
        """``offsets`` (ticks,) [rad] applied to the group's joints (with the pair's signs)."""
        nonlocal n_ticks
        block = np.tile(home, (len(offsets), 1))
        for name in members:
            j = robot.joint(name)
            sign = PAIR_SIGN[j.axis] if j.side == "left" else 1.0
            block[:, index[name]] += sign * offsets
        rows.append(block)
        if kind != "hold":
            segments.append(Segment(group, members, kind, n_ticks, n_ticks + len(offsets)))
        n_ticks += len(offsets)

    ticks = lambda seconds: max(1, int(round(seconds / settings.tick_s)))  # noqa: E731
    for group, members in joint_groups(robot, joints):
        room = _room(robot, members, home, settings)  # [rad] each way, for every member
        speed = settings.speed_share * min(_no_load_speed(robot.joint(m)) for m in members)
        add("hold", group, members, np.zeros(ticks(settings.hold_s)))
        add("chirp", group, members, _chirp(settings, min(room, math.radians(settings.chirp_deg)), speed))
        add("hold", group, members, np.zeros(ticks(settings.hold_s)))
        levels = []
        for amplitude in settings.step_deg:
            a = min(math.radians(amplitude), room)
            levels += [a, 0.0, -a, 0.0]
        add("steps", group, members, np.repeat(levels, ticks(settings.step_hold_s)))
    program = ExcitationProgram(robot, pose, settings, np.vstack(rows), segments)
    program.check()
    return program


def _room(robot: RobotSpec, members: tuple[str, ...], home: np.ndarray, settings: ExcitationSettings) -> float:
    """How far every member can move each way from home and stay inside its limits [rad]."""
    margin = math.radians(settings.margin_deg)
    room = math.inf
    for name in members:
        j = robot.joint(name)
        room = min(room, j.home_rad - j.range_rad[0] - margin, j.range_rad[1] - j.home_rad - margin)
    if room <= 0:
        raise UsageError(f"joints {', '.join(members)}: home is within {settings.margin_deg:g} deg of a limit; "
                         "nothing to excite")
    return room


def _no_load_speed(joint) -> float:
    """The joint's servo's no-load speed [rad/s] (a generous default for a servo-less joint)."""
    if joint.servo is None:
        return 6.0
    return joint.servo.profile.motor.no_load_speed_rad_s


def _chirp(s: ExcitationSettings, amplitude: float, max_speed: float) -> np.ndarray:
    """An exponential chirp from ``f0`` to ``f1`` [rad offsets], its amplitude capped where
    ``2 pi f A`` would pass ``max_speed`` and faded in and out (raised cosine)."""
    t = np.arange(int(round(s.chirp_s / s.tick_s))) * s.tick_s
    k = math.log(s.f1_hz / s.f0_hz) / s.chirp_s
    frequency = s.f0_hz * np.exp(k * t)
    phase = 2 * math.pi * s.f0_hz * (np.exp(k * t) - 1) / k
    a = np.minimum(amplitude, max_speed / (2 * math.pi * frequency))
    fade = np.clip(np.minimum(t, s.chirp_s - t) / s.ramp_s, 0.0, 1.0)
    return a * 0.5 * (1 - np.cos(math.pi * fade)) * np.sin(phase)
