"""Heading commands in training: a share of episodes is told, at a drawn moment, to hold a new
heading, so that a network learns to steer back to the heading it is given (and a user can
steer the robot with ``biped run --heading``).

The heading input reads the torso's turn from the heading to hold (the start's, turned by the
command: :class:`sim2real.controller.channels.Heading`).  A commanded episode turns the
heading to hold once, by an angle drawn uniformly within ``+-max_deg``, at a time drawn
uniformly in ``[FIRST_TURN_S, episode - LAST_TURN_S)``.  Commands are a training exercise:
only selection's episodes get them (``task.heading_turn_share``), never validation, ``biped
eval`` or the robustness test.  Each simulation's command comes from its key alone, in a
stream of its own, so the robot drawn for the same key is unchanged.
"""

from __future__ import annotations

import numpy as np

FIRST_TURN_S = 1.0  # [s] no command before the robot has started walking
LAST_TURN_S = 3.0  # [s] and none in the last seconds: time to turn and walk on
TURN_STREAM = 0x5455_524E  # appended to a simulation's key: the commands' own random stream


def turn_schedule(keys: np.ndarray, n_ticks: int, tick_s: float, share: float, max_deg: float) -> np.ndarray:
    """(len(keys), n_ticks) each simulation's heading to hold at each tick, from the start's
    [rad]: 0 throughout, or (for a share ``share`` of them) a drawn turn from a drawn tick on."""
    keys = np.atleast_2d(np.asarray(keys, dtype=np.int64))
    out = np.zeros((len(keys), n_ticks))
    latest = n_ticks * tick_s - LAST_TURN_S
    if share <= 0 or latest <= FIRST_TURN_S:
        return out
    for row, key in enumerate(keys):
        rng = np.random.default_rng([*(int(k) for k in key), TURN_STREAM])
        commanded, when, angle = rng.random(), rng.uniform(FIRST_TURN_S, latest), rng.uniform(-max_deg, max_deg)
        if commanded < share:
            out[row, int(when / tick_s):] = np.radians(angle)
    return out
