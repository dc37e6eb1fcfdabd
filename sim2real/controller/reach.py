"""Seed 002's reach state machine (section 4.1.1), the one evolution and the runtime run.

The right hand reaches for the target (state 1), then returns to its rest (state 0), and so
on.  A goal counts as reached once the hand has come within ``tolerance`` of it (arm lengths)
since the last toggle, and the state toggles once ``phase_s`` have passed since that toggle
(the thesis's "i frames"): seed 002 toggles "once every one or two seconds ... on the
condition that the character has actually reached its target by then".  Its pause at the
target is eq. 4.6's to pay, which counts every tick the hand spends away from its goal.  The
network reads the state through :class:`sim2real.controller.channels.Reach`.

    cycle = ReachCycle(n, phase_s=1.0, tolerance=0.15)
    reached = cycle.update(ids, error, dt)   # error: each hand's distance to its goal [arm lengths]

:class:`ReachControl` runs it on the hand's position from joint angles (the arm's chain);
:func:`aim_reach` points it where a user tells a run to reach (``--reach-target``), before
any servo moves.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Sequence

import numpy as np

from sim2real.controller.kinematics import ArmChain
from sim2real.errors import UsageError

REACHING, RETURNING = 1.0, 0.0
# a target farther from the shoulder than this many arm lengths (shoulder to hand at home, where
# an elbow may be bent, so that a stretched arm reaches a little farther) is refused
MAX_REACH_ARM_LENGTHS = 1.5
NO_REACH = "--reach-target: the controller has no reach input (reach_input): it does not reach"


def metres(point: np.ndarray) -> str:
    """A point for a message: ``(x, y, z) m``."""
    return "(" + ", ".join(f"{v:.3f}" for v in point) + ") m"


class ReachCycle:
    """The reach state of ``n`` robots, each from reaching at its start."""

    def __init__(self, n: int, phase_s: float, tolerance: float):
        if not phase_s > 0 or not tolerance > 0:
            raise ValueError(f"phase_s and tolerance must be > 0, got {phase_s:g} and {tolerance:g}")
        self.phase_s, self.tolerance = float(phase_s), float(tolerance)
        self.state = np.full(n, REACHING)
        self.since = np.zeros(n)  # [s] since the last toggle
        self.reached = np.zeros(n, dtype=np.int64)  # goals reached so far
        self.touched = np.zeros(n, dtype=bool)  # the hand has been at its goal since the last toggle

    @staticmethod
    def max_goals(n_ticks: int, tick_s: float, phase_s: float) -> int:
        """The most goals an episode of ``n_ticks`` readings ``tick_s`` apart can reach (the
        first reading is at time 0; a phase takes whole ticks): seed 002's T / i, in ticks."""
        per_goal = math.ceil(phase_s / tick_s - 1e-9)
        return (n_ticks - 1) // per_goal

    def update(self, ids: np.ndarray, error: np.ndarray, dt: float) -> np.ndarray:
        """After ``dt`` [s] more, with the hands of robots ``ids`` at ``error`` (arm lengths)
        from their goals: toggle the state of those that have reached it and whose phase is
        over; return which did (bool)."""
        self.since[ids] += dt
        self.touched[ids] |= np.asarray(error) <= self.tolerance
        # 1e-9: a sum of ticks lands a hair short of phase_s
        done = self.touched[ids] & (self.since[ids] >= self.phase_s - 1e-9)
        hit = ids[done]
        self.state[hit] = REACHING + RETURNING - self.state[hit]
        self.since[hit] = 0.0
        self.touched[hit] = False
        self.reached[hit] += 1
        return done


class ReachControl:
    """The state machine on what a robot knows, its joint angles, for ``n`` robots: the hand
    and shoulder from the arm's chain, the goals fixed in the root's frame - the rest where
    the hand is at the home pose, the target ``offset`` arm lengths from the shoulder there
    (``arm_length``: shoulder to hand at home [m]).  Evolution steps it on the encoder
    readings its networks get, the runtime on the servos' own, so both decide alike."""

    def __init__(self, chain: ArmChain, home_rad: np.ndarray, n: int, offset: np.ndarray, phase_s: float,
                 tolerance: float):
        self.chain = chain
        hand, self.shoulder = chain.hand(home_rad)[0], chain.shoulder(home_rad)[0]
        self.arm_length = float(np.linalg.norm(hand - self.shoulder))
        if not self.arm_length > 0:
            raise ValueError("the arm's chain puts the hand on the shoulder at home: no arm to reach with")
        self.rest = hand
        self.cycle = ReachCycle(n, phase_s, tolerance)
        self.error = np.full(n, np.nan)  # [arm lengths] each hand's distance to its goal at its last step
        self.set_offset(offset)

    def restart(self) -> None:
        """From reaching again, every robot, toward the same target."""
        self.cycle = ReachCycle(len(self.error), self.cycle.phase_s, self.cycle.tolerance)
        self.error[:] = np.nan

    def set_offset(self, offset: np.ndarray) -> None:
        """Reach ``offset`` (3,) arm lengths from the shoulder (x forward, y left, z up)."""
        self.offset = np.asarray(offset, dtype=float)
        self.target = self.shoulder + self.arm_length * self.offset

    def set_target(self, target_m: np.ndarray) -> None:
        """Reach a point of the root's frame [m] (what a user gives on the command line)."""
        self.set_offset((np.asarray(target_m, dtype=float) - self.shoulder) / self.arm_length)

    def aim(self, target_m: np.ndarray) -> None:
        """:meth:`set_target`, refused (``ValueError``) for a point that is not finite or lies
        beyond :data:`MAX_REACH_ARM_LENGTHS` of the shoulder."""
        target = np.asarray(target_m, dtype=float)
        distance = float(np.linalg.norm(target - self.shoulder)) / self.arm_length
        if not np.all(np.isfinite(target)) or not distance <= MAX_REACH_ARM_LENGTHS:
            raise ValueError(f"{distance:.2f} arm lengths from the right shoulder at {metres(self.shoulder)}; its arm "
                             f"({self.arm_length:.3f} m, shoulder to hand) reaches at most {MAX_REACH_ARM_LENGTHS:g}")
        self.set_target(target)

    def goals(self, ids: np.ndarray) -> np.ndarray:
        """(len(ids), 3) each hand's goal now, root frame [m]."""
        return np.where((self.cycle.state[ids] == REACHING)[:, None], self.target, self.rest)

    def step(self, ids: np.ndarray, angles: np.ndarray, dt: float) -> np.ndarray:
        """``dt`` [s] after the last step, the robots ``ids`` at joint angles (len(ids), joints)
        [rad]: advance their state machines; returns each hand's distance to the goal it had
        [arm lengths]."""
        error = np.linalg.norm(self.chain.hand(angles) - self.goals(ids), axis=1) / self.arm_length
        self.error[ids] = error
        self.cycle.update(ids, error, dt)
        return error

    def inputs(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The reach state and target offset the networks of ``ids`` read (channels.Reach)."""
        return self.cycle.state[ids], np.broadcast_to(self.offset, (len(ids), 3))

    def report(self) -> dict[str, Any]:
        """What a run on one robot reports: goals reached, the target (root frame [m], to 0.1 mm)
        and the arm's length [m]."""
        return {"reaches": int(self.cycle.reached[0]), "target_m": [round(float(v), 4) for v in self.target],
                "arm_length_m": round(self.arm_length, 4)}


def aim_reach(reach: ReachControl | None, target_m: Sequence[float], log: Callable[[str], None]) -> None:
    """Point a reaching controller's hand at ``target_m`` (root frame [m]); refused
    (:class:`UsageError`, before any servo moves) for a controller without the reach input
    (``reach`` None) or a target beyond the arm's reach; ``log`` notes a target far from the one
    it was evolved for."""
    if reach is None:
        raise UsageError(NO_REACH)
    evolved = reach.target.copy()
    try:
        reach.aim(target_m)
    except ValueError as exc:
        raise UsageError(f"--reach-target {', '.join(f'{v:g}' for v in target_m)}: {exc}") from None
    if np.linalg.norm(reach.target - evolved) > 0.5 * reach.cycle.tolerance * reach.arm_length:
        log(f"note: the controller was evolved to reach {metres(evolved)}; a network that learned one target may "
            f"miss {metres(reach.target)}")
