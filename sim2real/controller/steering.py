"""Steering: the heading a user commands a controller with a heading input to hold.

``biped run`` and ``biped dry-run`` take ``--heading DEG`` (hold the start's heading turned by
DEG, counter-clockwise seen from above: left is positive) or a schedule
``--heading 0:0,5:90,12:-45`` (from 5 s on toward 90 deg left of the start's, from 12 s on toward
45 deg right), each followed at :data:`TURN_RATE_DEG_S`; :class:`~sim2real.controller.policy.Policy`
reads it as ``heading_command(t_s)`` [rad].  No MuJoCo here.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from sim2real.controller.channels import turn_rad


MAX_SCHEDULE_S = 7 * 24 * 3600.0  # a schedule's last time [s]: a run's longest (a trace's MAX_TIME_S)
# [deg/s] how fast the heading to hold follows a step of the schedule: the walkers are trained on
# turns of at most 30 deg at once (configs/evolve/train.yaml), and the heading input reads 1 from
# 30 deg on.  Told a 90 deg step, biped train's seeds 1 and 3 fell (seed 2 ended 68 deg off);
# followed at 10 deg/s, seeds 1 and 3 end 2 deg off (benchmarks/RESULTS.md, "Steering at 10 deg/s")
TURN_RATE_DEG_S = 10.0


def parse_schedule(text: str) -> list[tuple[float, float]]:
    """A user's heading schedule, ``"0:0,5:90,12:-45"`` (seconds since the start : degrees from
    the start's heading, times increasing) or one angle ``"30"`` (from the start on), as
    [(t_s, deg)]; ``ValueError`` saying what is wrong."""
    items = [part.strip() for part in text.split(",") if part.strip()]
    if not items:
        raise ValueError("an empty heading schedule")
    out = []
    for item in items:
        t, sep, deg = item.partition(":")
        try:
            pair = (float(t), float(deg)) if sep else (0.0, float(t))
        except ValueError:
            raise ValueError(f"{item!r} is not SECONDS:DEGREES (or DEGREES)") from None
        if not all(np.isfinite(pair)) or not 0 <= pair[0] <= MAX_SCHEDULE_S or abs(pair[1]) > 360:
            raise ValueError(f"{item!r}: a time within [0, {MAX_SCHEDULE_S:g}] s (a week: the longest run) and a "
                             "heading within +-360 deg")
        if out and pair[0] <= out[-1][0]:
            raise ValueError(f"{item!r}: times must increase")
        out.append(pair)
    return out


def schedule_command(schedule: list[tuple[float, float]],
                     turn_rate_deg_s: float = TURN_RATE_DEG_S) -> Callable[[float], float]:
    """The heading to hold [rad] at a time [s] since the start: from 0, toward the schedule's
    last entry at or before it by the shorter way round, at most ``turn_rate_deg_s`` [deg/s]
    (``math.inf``: at once, as in training)."""
    if not (turn_rate_deg_s > 0):  # NaN too
        raise ValueError(f"turn_rate_deg_s: a positive rate or inf, not {turn_rate_deg_s}")
    times = np.array([t for t, _ in schedule], dtype=float)
    angles = np.radians([d for _, d in schedule])
    rate = np.radians(turn_rate_deg_s)

    def toward(heading: float, k: int, dt_s: float) -> float:
        """From ``heading``, ``dt_s`` seconds toward entry ``k``'s angle."""
        if not np.isfinite(rate):
            return float(angles[k])
        step = rate * dt_s
        return heading + float(np.clip(turn_rad(angles[k], heading), -step, step))

    reached = [0.0]  # the heading to hold when each entry comes into force
    for k in range(len(times) - 1):
        reached.append(toward(reached[k], k, times[k + 1] - times[k]))

    def command(t_s: float) -> float:
        k = int(np.searchsorted(times, t_s, side="right")) - 1  # the entry in force
        return toward(reached[k], k, t_s - times[k]) if k >= 0 else 0.0
    return command
