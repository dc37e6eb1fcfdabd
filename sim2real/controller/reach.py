"""Seed 002's reach state machine (section 4.1.1), the one evolution and the runtime run.

The right hand reaches for the target (state 1), then returns to its rest (state 0), and so
on.  A goal counts as reached when the hand is within ``tolerance`` of it (arm lengths) once
at least ``phase_s`` have passed since the last toggle - the thesis's "i frames", and its
pause at the target: a hand that arrives early waits there; then the state toggles.  The
network reads the state through :class:`sim2real.controller.channels.Reach`.

    cycle = ReachCycle(n, phase_s=1.0, tolerance=0.15)
    reached = cycle.update(ids, error, dt)   # error: each hand's distance to its goal [arm lengths]
"""

from __future__ import annotations

import numpy as np

REACHING, RETURNING = 1.0, 0.0


class ReachCycle:
    """The reach state of ``n`` robots, each from reaching at its start."""

    def __init__(self, n: int, phase_s: float, tolerance: float):
        if not phase_s > 0 or not tolerance > 0:
            raise ValueError(f"phase_s and tolerance must be > 0, got {phase_s:g} and {tolerance:g}")
        self.phase_s, self.tolerance = float(phase_s), float(tolerance)
        self.state = np.full(n, REACHING)
        self.since = np.zeros(n)  # [s] since the last toggle
        self.reached = np.zeros(n, dtype=np.int64)  # goals reached so far

    def update(self, ids: np.ndarray, error: np.ndarray, dt: float) -> np.ndarray:
        """After ``dt`` [s] more, with the hands of robots ``ids`` at ``error`` (arm lengths)
        from their goals: toggle the state of those that reached it; return which did (bool)."""
        self.since[ids] += dt
        # 1e-9: a sum of ticks lands a hair short of phase_s
        done = (np.asarray(error) <= self.tolerance) & (self.since[ids] >= self.phase_s - 1e-9)
        hit = ids[done]
        self.state[hit] = REACHING + RETURNING - self.state[hit]
        self.since[hit] = 0.0
        self.reached[hit] += 1
        return done
