"""Steering: the heading a user commands a controller with a heading input to hold.

``biped run`` and ``biped dry-run`` take ``--heading DEG`` (hold the start's heading turned by
DEG, counter-clockwise seen from above: left is positive) or a schedule
``--heading 0:0,5:90,12:-45`` (from 5 s on 90 deg left of the start's, from 12 s on 45 deg right);
:class:`~sim2real.controller.policy.Policy` reads it as ``heading_command(t_s)`` [rad].  No
MuJoCo here.
"""

from __future__ import annotations

from typing import Callable

import numpy as np


MAX_SCHEDULE_S = 7 * 24 * 3600.0  # a schedule's last time [s]: a run's longest (a trace's MAX_TIME_S)


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


def schedule_command(schedule: list[tuple[float, float]]) -> Callable[[float], float]:
    """The heading to hold [rad] at a time [s] since the start: the schedule's last entry at or
    before it (0 before the first)."""
    times = np.array([t for t, _ in schedule])
    angles = np.radians([d for _, d in schedule])

    def command(t_s: float) -> float:
        k = int(np.searchsorted(times, t_s, side="right")) - 1
        return float(angles[k]) if k >= 0 else 0.0
    return command
