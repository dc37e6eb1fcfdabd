"""Is it a walk?  Gait measures of an episode from its hip pitch angles and foot contacts.

Covering ground is not walking: a walker can hop on one leg, or skip with both feet in the air,
and still go 2 m.  These measures say which gait it is (issue 51), from what a simulated
episode and a trace of a real robot both have - joint angles and foot switches, tick by tick:

    measures = measure_gait(times_s, hips_rad, feet)        # one episode, as arrays
    measures = measure_recorded(gait)                       # a Gait record (replay or trace)
    meter = GaitMeter(n, tick_s); meter.add(ids, t, hips, feet) ...; meter.measures()  # n at once
    is_a_walk(measures), walk_faults(measures), describe(measures)

Per episode, after a start-up of ``skip_s`` (default 2 s: the start from standing is not the
gait): each leg's **hip swing** (its hip pitch range, max - min [deg]), their **symmetry**
(smaller swing / larger), the share of ticks in **flight** (both feet up) and in **double
support** (both down), the **steps** and the **cadence** [steps/min].  A step is a touch-down
(a foot switch closing: up on one tick, down on the next) of the foot that did not make the
last step, as a walk alternates its feet; a foot closing again before the other steps is its
switch chattering or the same leg hopping (both counted in ``touchdowns``), and two feet
landing on one tick are one step.  The hip pitch joints are the robot's roles (location hip,
axis pitch, first along the chain), never read from their names.

The bar a walk clears (issue 51's "done when"): symmetry >= :data:`MIN_SYMMETRY`, flight <=
:data:`MAX_FLIGHT_SHARE` of the ticks, and steps of both feet (:data:`MIN_STEPS`).
An episode no longer than the start-up has **empty measures** (no ticks; values NaN, None in
JSON) - a fall in the first seconds is a result, not an error - and is no walk.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from sim2real.robot.spec import RobotSpec

if TYPE_CHECKING:
    from sim2real.figures.gait import Gait

SKIP_S = 2.0  # start-up left out of the measures [s] (issue 51 measured 10 s with the first 2 s skipped)
MIN_SYMMETRY = 0.8  # a walk's smaller hip swing is at least this share of the larger (issue 51)
MAX_FLIGHT_SHARE = 0.02  # a walk has both feet up in at most this share of the ticks (issue 51)
MIN_STEPS = 2  # a walk steps with both feet: alternating steps, so two are one of each
_TIME_TOLERANCE_S = 1e-9  # a tick at 2.0 s that floats as 1.9999999999 is still after the start-up
SIDES = ("left", "right")


@dataclass(frozen=True)
class GaitMeasures:
    """One episode's gait after its start-up.  Empty (``ticks == 0``, values NaN) when the
    episode ended before the start-up did."""

    skipped_s: float  # start-up left out [s]
    measured_s: float  # the ticks measured times the tick [s]
    ticks: int  # control ticks measured
    hip_swing_deg: tuple[float, float]  # left, right: hip pitch range, max - min [deg]
    symmetry: float  # smaller hip swing / larger, 0..1 (NaN: neither hip moved)
    flight_share: float  # share of the ticks with both feet up, 0..1
    double_support_share: float  # share of the ticks with both feet down, 0..1
    steps: int  # alternating touch-downs (see the module's docstring)
    touchdowns: tuple[int, int]  # left, right: every closing of the foot's switch
    cadence_steps_min: float  # steps a minute [1/min]

    @property
    def empty(self) -> bool:
        return self.ticks == 0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (NaN as None, numbers unrounded), with the verdict (``walk``) and what fails
        it (``not_a_walk``)."""
        def number(value: float) -> float | None:  # unrounded: read back, the verdict is the same
            return None if math.isnan(value) else float(value)

        return {"skipped_s": self.skipped_s, "measured_s": self.measured_s, "ticks": self.ticks,
                "hip_swing_deg": {side: number(v) for side, v in zip(SIDES, self.hip_swing_deg)},
                "symmetry": number(self.symmetry), "flight_share": number(self.flight_share),
                "double_support_share": number(self.double_support_share), "steps": self.steps,
                "touchdowns": dict(zip(SIDES, self.touchdowns)),
                "cadence_steps_min": number(self.cadence_steps_min),
                "walk": is_a_walk(self), "not_a_walk": walk_faults(self)}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "GaitMeasures":
        """The measures back from :meth:`to_dict` (a report read back; the verdict is judged anew)."""
        def number(value: float | None) -> float:
            return float("nan") if value is None else float(value)

        return cls(float(d["skipped_s"]), float(d["measured_s"]), int(d["ticks"]),
                   (number(d["hip_swing_deg"]["left"]), number(d["hip_swing_deg"]["right"])),
                   number(d["symmetry"]), number(d["flight_share"]), number(d["double_support_share"]),
                   int(d["steps"]), (int(d["touchdowns"]["left"]), int(d["touchdowns"]["right"])),
                   number(d["cadence_steps_min"]))


def walk_faults(m: GaitMeasures) -> list[str]:
    """What keeps ``m`` from being a walk, one phrase each (empty: it is a walk)."""
    if m.empty:
        return [f"no ticks after the first {m.skipped_s:g} s"]
    faults = []
    if math.isnan(m.symmetry):
        faults.append("neither hip swings")
    elif m.symmetry < MIN_SYMMETRY:
        faults.append(f"hip swing symmetry {m.symmetry:.2f} < {MIN_SYMMETRY:g}")
    if m.flight_share > MAX_FLIGHT_SHARE:
        faults.append(f"both feet up in {m.flight_share:.0%} of the ticks > {MAX_FLIGHT_SHARE:.0%}")
    if m.steps < MIN_STEPS:
        faults.append(f"{m.steps} alternating steps < {MIN_STEPS}")
    return faults


def is_a_walk(m: GaitMeasures) -> bool:
    """Both legs swing alike, no flight phase, both feet step: the bar of :func:`walk_faults`."""
    return not walk_faults(m)


def describe(m: GaitMeasures, brief: bool = False) -> str:
    """One line for people: ``hip swing 37.9 / 37.4 deg (symmetry 0.99), flight 0 %, ...``;
    ``brief``: a picture's subtitle (the start-up skipped first, no step count or faults)."""
    if m.empty:
        return f"{'gait ' if brief else ''}not measured: no ticks after the first {m.skipped_s:g} s"
    left, right = m.hip_swing_deg
    swing = (f"hip swing {left:.1f} / {right:.1f} deg{'' if brief else ' left / right'} "
             f"(symmetry {m.symmetry:.2f}), both feet up {m.flight_share:.0%}, both down {m.double_support_share:.0%}, ")
    if brief:
        return (f"after {m.skipped_s:g} s: {swing}{m.cadence_steps_min:.0f} steps/min: "
                f"{'a walk' if is_a_walk(m) else 'not a walk'}")
    verdict = "a walk" if is_a_walk(m) else "not a walk (" + "; ".join(walk_faults(m)) + ")"
    return f"{swing}{m.steps} steps ({m.cadence_steps_min:.0f} /min) in {m.measured_s:.1f} s: {verdict}"


def hip_pitch_joints(robot: RobotSpec) -> tuple[str, str]:
    """The names of ``robot``'s left and right hip pitch joints, by their roles (location hip,
    axis pitch, first of that kind along the leg), however the robot names them."""
    found = {}
    for joint in robot.joints:
        if joint.location == "hip" and joint.axis == "pitch" and joint.index == 0 and joint.side in SIDES:
            found[joint.side] = joint.name
    missing = [side for side in SIDES if side not in found]
    if missing:
        raise ValueError(f"robot {robot.name} has no {' and no '.join(missing)} hip pitch joint: its gait cannot "
                         "be measured")
    return found["left"], found["right"]


class GaitMeter:
    """Gait measures of ``n`` episodes fed tick by tick (memory does not grow with the
    episode): ``add`` each tick's hip angles and foot contacts of the episodes still running,
    then ``measures``.  ``tick_s``: the control tick [s]; ``skip_s``: start-up left out [s]."""

    def __init__(self, n: int, tick_s: float, skip_s: float = SKIP_S):
        if n < 1:
            raise ValueError(f"n: at least one episode, not {n}")
        if not (math.isfinite(tick_s) and tick_s > 0):
            raise ValueError(f"tick_s: a positive number of seconds, not {tick_s}")
        if not (math.isfinite(skip_s) and skip_s >= 0):
            raise ValueError(f"skip_s: zero or more seconds, not {skip_s}")
        self.tick_s, self.skip_s = float(tick_s), float(skip_s)
        self.low = np.full((n, 2), np.inf)
        self.high = np.full((n, 2), -np.inf)
        self.ticks = np.zeros(n, dtype=int)
        self.flight = np.zeros(n, dtype=int)
        self.double = np.zeros(n, dtype=int)
        self.touchdowns = np.zeros((n, 2), dtype=int)
        self.steps = np.zeros(n, dtype=int)
        self.last_foot = np.full(n, -1)  # the foot of the last step: 0 left, 1 right, -1 none or both
        self.previous = np.zeros((n, 2), dtype=bool)  # each episode's feet on its last tick
        self.seen = np.zeros(n, dtype=bool)  # has it had a tick (its first cannot be a touch-down)

    def add(self, ids: np.ndarray, time_s: float, hips_rad: np.ndarray, feet: np.ndarray) -> None:
        """One tick at ``time_s`` [s from the start] of episodes ``ids`` (k,): their left and
        right hip pitch ``hips_rad`` (k, 2) [rad] and feet ``feet`` (k, 2) left, right, True down."""
        ids = np.asarray(ids, dtype=int)
        hips_rad, feet = np.asarray(hips_rad, dtype=float), np.asarray(feet, dtype=bool)
        if hips_rad.shape != (len(ids), 2) or feet.shape != (len(ids), 2):
            raise ValueError(f"hips_rad {hips_rad.shape} and feet {feet.shape}: each ({len(ids)}, 2) for "
                             f"{len(ids)} episodes (left, right)")
        if time_s >= self.skip_s - _TIME_TOLERANCE_S:
            self.low[ids] = np.minimum(self.low[ids], hips_rad)
            self.high[ids] = np.maximum(self.high[ids], hips_rad)
            self.ticks[ids] += 1
            self.flight[ids] += ~feet.any(axis=1)
            self.double[ids] += feet.all(axis=1)
            landed = feet & ~self.previous[ids] & self.seen[ids, None]
            self.touchdowns[ids] += landed
            count = landed.sum(axis=1)
            foot = np.argmax(landed, axis=1)
            one = count == 1
            step = (count == 2) | (one & (foot != self.last_foot[ids]))
            self.steps[ids] += step
            self.last_foot[ids] = np.where(count == 2, -1, np.where(one, foot, self.last_foot[ids]))
        self.previous[ids] = feet
        self.seen[ids] = True

    def measures(self) -> list[GaitMeasures]:
        """Each episode's measures so far, in episode order."""
        return [self._one(e) for e in range(len(self.ticks))]

    def _one(self, e: int) -> GaitMeasures:
        ticks = int(self.ticks[e])
        measured_s = ticks * self.tick_s
        if ticks == 0:
            nan = float("nan")
            return GaitMeasures(self.skip_s, 0.0, 0, (nan, nan), nan, nan, nan, 0, (0, 0), nan)
        swing = np.degrees(self.high[e] - self.low[e])
        larger = float(swing.max())
        return GaitMeasures(
            skipped_s=self.skip_s, measured_s=measured_s, ticks=ticks,
            hip_swing_deg=(float(swing[0]), float(swing[1])),
            symmetry=float(swing.min()) / larger if larger > 0 else float("nan"),
            flight_share=float(self.flight[e] / ticks), double_support_share=float(self.double[e] / ticks),
            steps=int(self.steps[e]), touchdowns=(int(self.touchdowns[e, 0]), int(self.touchdowns[e, 1])),
            cadence_steps_min=float(60.0 * self.steps[e] / measured_s))


def measure_gait(times_s: np.ndarray, hips_rad: np.ndarray, feet: np.ndarray, *, skip_s: float = SKIP_S,
                 tick_s: float | None = None) -> GaitMeasures:
    """One episode's measures: ``times_s`` (n,) [s from the start, increasing], left and right
    hip pitch ``hips_rad`` (n, 2) [rad], ``feet`` (n, 2) left, right, True down.  ``tick_s``
    [s]: the control tick (default: the median time between rows, for a trace's uneven clock)."""
    times_s = np.asarray(times_s, dtype=float)
    hips_rad, feet = np.asarray(hips_rad, dtype=float), np.asarray(feet)
    n = len(times_s)
    if times_s.ndim != 1 or n < (1 if tick_s is not None else 2):
        raise ValueError(f"times_s: a row (n,) of at least {1 if tick_s is not None else 2} ticks (two to tell "
                         f"the tick without tick_s), got shape {times_s.shape}")
    if not np.isfinite(times_s).all() or not (np.diff(times_s) > 0).all():
        raise ValueError("times_s: finite and increasing")
    if hips_rad.shape != (n, 2) or not np.isfinite(hips_rad).all():
        raise ValueError(f"hips_rad: ({n}, 2) finite angles (left, right hip pitch), got shape {hips_rad.shape}")
    if feet.shape != (n, 2):
        raise ValueError(f"feet: ({n}, 2) contacts (left, right), got shape {feet.shape}")
    meter = GaitMeter(1, float(np.median(np.diff(times_s))) if tick_s is None else tick_s, skip_s)
    one = np.zeros(1, dtype=int)
    for t, hips, down in zip(times_s, hips_rad, feet.astype(bool)):
        meter.add(one, float(t), hips[None], down[None])
    return meter.measures()[0]


def measure_recorded(gait: "Gait", skip_s: float = SKIP_S) -> GaitMeasures:
    """The measures of a :class:`~sim2real.figures.gait.Gait` - a replay's or a real robot's
    trace - with its robot's hip pitch joints; a clear ``ValueError`` when it has no foot
    contacts (a trace recorded without foot switches) or lacks the hips."""
    if gait.feet is None:
        raise ValueError(f"{gait.title}: no foot contacts recorded: the gait measures need them")
    left, right = hip_pitch_joints(gait.robot)
    missing = [j for j in (left, right) if j not in gait.joints]
    if missing:
        raise ValueError(f"{gait.title}: no angles of hip pitch joint {', '.join(missing)}")
    hips = np.stack([gait.angle(left), gait.angle(right)], axis=1)
    return measure_gait(gait.times_s, hips, gait.feet, skip_s=skip_s)
