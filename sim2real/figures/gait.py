"""A walk's joint angles over time and its hip-knee phase portraits (seed 000, figures 2-3).

The same picture from a simulated episode (``biped plot gait CONTROLLER``) or from a
trace a robot recorded (``--trace``), so a real walk and its simulation can be laid side
by side: :class:`Gait` is what both give.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim2real.figures import pyplot, save_figure
from sim2real.gait_measures import GaitMeasures, describe
from sim2real.hardware.trace import PRESENT, Trace
from sim2real.robot.spec import RobotSpec

# the sagittal joints a gait is read from, top to bottom; (location, axis)
SAGITTAL = (("hip", "pitch"), ("knee", "pitch"), ("ankle", "pitch"))
SIDE_COLOURS = {"left": "tab:blue", "right": "tab:red"}


@dataclass(frozen=True)
class Gait:
    """Joint angles of one walk of ``robot``: ``times_s`` (n,) [s]; ``angles_rad`` (n, joints)
    [rad] in the order of ``joints``; ``feet`` (n, 2) left, right touching, or None; ``fell_s``
    when it fell [s], or None; ``title`` what it is (a controller, a trace)."""

    robot: RobotSpec
    times_s: np.ndarray
    joints: tuple[str, ...]
    angles_rad: np.ndarray
    feet: np.ndarray | None
    fell_s: float | None
    title: str

    @classmethod
    def from_trace(cls, trace: Trace, robot: RobotSpec, title: str) -> "Gait":
        """The angles the servos reported (``present``) and the foot switches, if recorded."""
        joints = tuple(j for j in robot.joint_names if f"{j}{PRESENT}" in trace)
        if not joints:
            raise ValueError(f"{title}: the trace has no joint angles of robot {robot.name}")
        feet = trace.feet if not trace.missing(["foot_left", "foot_right"]) else None
        return cls(robot, trace.times - trace.times[0], joints, trace.present(joints), feet, None, title)

    def angle(self, joint: str) -> np.ndarray:
        return self.angles_rad[:, self.joints.index(joint)]


def sagittal_joints(gait: Gait) -> list[dict[str, str]]:
    """Per sagittal location (hip, knee, ankle), the joint of each side that the gait has."""
    rows = []
    for location, axis in SAGITTAL:
        row = {j.side: j.name for j in gait.robot.joints
               if j.location == location and j.axis == axis and j.index == 0 and j.side in SIDE_COLOURS
               and j.name in gait.joints}
        if row:
            rows.append({"location": location, **row})
    return rows


def plot_gait(gait: Gait, path: Path | str, dpi: int = 110, measures: GaitMeasures | None = None) -> None:
    """Left: each sagittal joint's angle over time [deg], both legs, with the feet's contacts
    below.  Right: the hip-knee phase portrait of each leg (knee against hip), the first
    second in a lighter line (the start from standing).  ``measures``: the walk's gait
    measures (:mod:`sim2real.gait_measures`), a line under the title."""
    plt = pyplot()
    rows = sagittal_joints(gait)
    if not rows:
        raise ValueError(f"{gait.title}: robot {gait.robot.name} has no hip, knee or ankle pitch joints to draw")
    n = len(rows) + (gait.feet is not None)
    fig = plt.figure(figsize=(11, 1.9 * n + 0.6), layout="constrained")
    grid = fig.add_gridspec(n, 2, width_ratios=(2.2, 1))
    t = gait.times_s
    first = None
    for k, row in enumerate(rows):
        ax = fig.add_subplot(grid[k, 0], sharex=first)
        first = first or ax
        for side in ("left", "right"):
            if side in row:
                ax.plot(t, np.degrees(gait.angle(row[side])), color=SIDE_COLOURS[side], lw=1.1, label=side)
        ax.set_ylabel(f"{row['location']} [deg]")
        ax.grid(alpha=0.3)
        _mark_fall(ax, gait)
        if k == 0:
            ax.legend(loc="upper right", fontsize=8, ncol=2)
            ax.set_title(gait.title + (f"\n{describe(measures, brief=True)}" if measures is not None else ""),
                         fontsize=10, loc="left")
    if gait.feet is not None:
        ax = fig.add_subplot(grid[len(rows), 0], sharex=first)
        for i, side in enumerate(("left", "right")):
            down = gait.feet[:, i].astype(bool)
            ax.fill_between(t, i + 0.1, i + 0.9, where=down, step="post", color=SIDE_COLOURS[side], alpha=0.7)
        ax.set_yticks([0.5, 1.5], ["left", "right"])
        ax.set_ylim(0, 2)
        ax.set_ylabel("foot down")
        _mark_fall(ax, gait)
    fig.axes[-1].set_xlabel("time [s]")

    portrait = fig.add_subplot(grid[:, 1])
    hip = next((r for r in rows if r["location"] == "hip"), None)
    knee = next((r for r in rows if r["location"] == "knee"), None)
    if hip and knee:
        start = t < min(1.0, t[-1] / 4)
        for side in ("left", "right"):
            if side in hip and side in knee:
                x, y = np.degrees(gait.angle(hip[side])), np.degrees(gait.angle(knee[side]))
                portrait.plot(x[start], y[start], color=SIDE_COLOURS[side], lw=0.8, alpha=0.35)
                portrait.plot(x[~start], y[~start], color=SIDE_COLOURS[side], lw=1.0, label=side)
        portrait.set_xlabel("hip pitch [deg]")
        portrait.set_ylabel("knee [deg]")
        portrait.set_title("phase portrait", fontsize=10)
        portrait.grid(alpha=0.3)
        portrait.legend(fontsize=8)
    else:
        portrait.axis("off")
    save_figure(fig, path, dpi=dpi)


def _mark_fall(ax, gait: Gait) -> None:
    if gait.fell_s is not None:
        ax.axvline(gait.fell_s, color="black", lw=1, ls="--")
