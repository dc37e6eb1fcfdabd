"""Pushes in training: short shoves of the whole robot at drawn times, for gaits that recover.

ToddlerBot pushes its robot every 2 s in training, Open Duck Mini pushes too, and Haarnoja
et al. 2023 (arXiv 2304.13653, OP3 soccer) report that random impulses on the torso (5-15 N
for 0.05-0.15 s every 1-3 s, on a 3.5 kg robot) "substantially improved" robustness and
transfer.  Here a push is a horizontal impulse on the pelvis that changes the whole robot's
velocity by up to ``speed_m_s`` (the impulse is total mass times that speed), in a direction
drawn uniformly in the ground plane, lasting one control tick.  The first comes at a drawn
time in ``[1 s, 1 s + every_s)`` (the robot has started by then), the next every ``every_s``.

Pushes are a training disturbance, not a property of the robot: only selection's episodes
get them (``randomize.push`` of an evolution config), never validation, ``biped eval``, the
robustness test or the simulated bus.  Each simulation's pushes come from its key alone (a
stream of their own, so the robot drawn for the same key is unchanged), like every other draw.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FIRST_PUSH_S = 1.0  # [s] no push before the robot has started
PUSH_STREAM = 0x5055_5348  # appended to a simulation's key: the pushes' own random stream


@dataclass(frozen=True)
class Pushes:
    """How hard and how often training pushes the robot."""

    speed_m_s: float  # the largest whole-body speed change of a push [m/s]; each draws within [0, this]
    every_s: float = 2.0  # [s] between pushes

    def to_dict(self) -> dict[str, float]:
        return {"speed_m_s": self.speed_m_s, "every_s": self.every_s}


def push_schedule(pushes: Pushes, keys: np.ndarray, n_ticks: int, tick_s: float,
                  intensity: float = 1.0) -> np.ndarray:
    """Each simulation's pushes as the velocity change [m/s] (x, y) it gets at each tick,
    (len(keys), n_ticks, 2), zero between pushes; speeds scaled by ``intensity`` (the
    randomization ramp)."""
    keys = np.atleast_2d(np.asarray(keys, dtype=np.int64))
    out = np.zeros((len(keys), n_ticks, 2))
    episode_s = n_ticks * tick_s
    for row, key in enumerate(keys):
        rng = np.random.default_rng([*(int(k) for k in key), PUSH_STREAM])
        first = FIRST_PUSH_S + rng.uniform(0.0, pushes.every_s)
        times = np.arange(first, episode_s, pushes.every_s)
        ticks = np.minimum((times / tick_s).astype(int), n_ticks - 1)
        angle = rng.uniform(0.0, 2 * np.pi, len(ticks))
        speed = rng.uniform(0.0, pushes.speed_m_s * intensity, len(ticks))
        out[row, ticks, 0] = speed * np.cos(angle)
        out[row, ticks, 1] = speed * np.sin(angle)
    return out
