"""A home pose that stands, for a robot whose home falls or is the straight-legged zero pose.

A model file is drawn at its zero pose, legs straight; a walker starts from a stance with
its knees bent (ROBOTIS's OP3 walks from a 64 deg knee, the project's box robots from 50 deg).
:func:`propose_home` searches a small set of knee bends (:data:`KNEE_BENDS_DEG`, slight first).
For each it solves the hip pitch and ankle pitch of both legs with the model's kinematics
(``mj_kinematics``; Newton's method on two equations) so that

* the feet stay flat with the trunk as the model draws it (each foot's up direction, seen from
  the root, as at the zero pose), and
* the whole robot's centre of mass is over the middle of the two soles, along the forward
  direction (the hip pitch axis crossed into the floor);

the other leg joints (yaw, roll) at 0, the arms, neck and waist at their home.  It centres
each leg joint's range on that stance, as ``configs/robots/op3.yaml`` centres OP3's on
ROBOTIS's walking stance: the networks drive the central 80 % of each range
(:mod:`sim2real.controller.mapping`), so a network at rest holds the stance it starts from.
Rolls and yaws get +-20 deg about it, knees 50 deg, hip and ankle pitch as wide as the
joint's limits allow; every range within the limits.  The first bend whose robot stands by
:func:`~sim2real.simulation.standing.check.check_stand` (no warning) is proposed; else the first
that stands with a warning; else :class:`NoStandingHome` says what each bend did.

    proposal = propose_home(robot)             # a RobotSpec loaded from a YAML
    print("\\n".join(proposal.report()))
    robot = proposal.apply(robot)              # the same robot with the new home and ranges
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from sim2real.errors import BipedError
from sim2real.robot import RobotSpec
from sim2real.robot.spec import LEG_LOCATIONS
from sim2real.simulation.model.builder import build_model
from sim2real.simulation.model.robot_model import JointAngles, RobotModel
from sim2real.simulation.standing.check import STAND_S, StandReport, check_stand, forward_direction

KNEE_BENDS_DEG = (30.0, 20.0, 40.0, 15.0, 50.0, 60.0)  # tried in this order: a slight bend first
STRAIGHT_KNEE_DEG = 5.0  # a home knee bent less than this is straight: no stance to walk from
# Half-widths of a leg range about the stance [deg] (configs/robots/op3.yaml's rule); None: as
# wide as the joint's limits allow on both sides of the stance
HALF_WIDTH_DEG = {("knee", "pitch"): 50.0, "roll": 20.0, "yaw": 20.0, "pitch": None}
NARROW_HALF_DEG = 10.0  # a centred range narrower than this either way is reported
ROUND_DEG = 0.1  # proposed angles are rounded so (as a YAML holds them), and checked so rounded
SOLVE_TOL = 1e-9  # Newton's residual (lean [rad], centre of mass [leg lengths]), squared norm
SOLVE_ITERATIONS = 30
FD_STEP_RAD = 1e-6  # finite-difference step for the Jacobian [rad]
MAX_STEP_RAD = 0.3  # Newton steps clipped to this [rad]


class NoStandingHome(BipedError):
    """No knee bend tried gave a home that stands; the message says what each one did."""


@dataclass(frozen=True)
class LegPitch:
    """The pitch joints of one leg that shape a stance: hip, knee, ankle."""

    side: str
    hip: str
    knee: str
    ankle: str


@dataclass(frozen=True)
class HomeProposal:
    """A home pose that stands and leg ranges centred on it."""

    home_rad: dict[str, float]  # every joint [rad]
    range_rad: dict[str, tuple[float, float]]  # every joint [rad]
    knee_deg: float  # the knee bend chosen
    legs: tuple[LegPitch, ...]
    centred: tuple[str, ...]  # the joints whose ranges are centred on the stance: the legs'
    stand: StandReport  # the 5 s check of the robot with this home and these ranges
    tried: tuple[str, ...]  # what each knee bend tried before it did
    notes: tuple[str, ...]  # ranges cut narrow by the joint's limits

    def apply(self, robot: RobotSpec) -> RobotSpec:
        """``robot`` with this home and these ranges."""
        return with_stance(robot, self.home_rad, self.range_rad)

    def to_json(self) -> dict:
        """The proposal as ``biped robot stand --propose-home --json`` prints it (degrees, as a
        robot YAML holds them)."""
        return {"knee_deg": self.knee_deg,
                "home_deg": {n: round(math.degrees(a), 1) for n, a in self.home_rad.items()},
                "range_deg": {n: [round(math.degrees(a), 1) for a in r] for n, r in self.range_rad.items()},
                "centred": list(self.centred), "stand": self.stand.to_json(),
                "tried": list(self.tried), "notes": list(self.notes)}

    def yaml_lines(self) -> list[str]:
        """Each changed joint's ``home_deg`` and ``range_deg``, to copy into the robot YAML."""
        return [f"  {name}: home_deg: {math.degrees(self.home_rad[name]):.1f}, range_deg: "
                f"[{math.degrees(lo):.1f}, {math.degrees(hi):.1f}]"
                for name, (lo, hi) in self.range_rad.items() if name in self.centred]

    def report(self) -> list[str]:
        """What the importer says about it, one fact a line."""
        deg = {name: math.degrees(a) for name, a in self.home_rad.items()}
        leg = self.legs[0]
        s = self.stand
        out = [f"home: proposed, knees bent {self.knee_deg:g} deg, hip pitch {deg[leg.hip]:.1f} and ankle pitch "
               f"{deg[leg.ankle]:.1f} deg so that the feet stay flat, the trunk upright as drawn and the centre "
               "of mass over the middle of the soles; the other leg joints at 0",
               f"  it {s.verdict} by the {s.seconds:g} s stand check: up-vector z {s.up_z_final:.4f}, sag "
               f"{1e3 * s.sag_m:.1f} mm, the feet carry {100 * s.feet_weight_share:.0f} % of its weight"
               + (f" ({s.reason})" if s.reasons else ""),
               f"  the ranges of the {len(self.centred)} leg joints centred on this stance (the networks drive the "
               "central 80 % of each range, so a network at rest holds it), within the joints' limits"]
        out += [f"  {t}" for t in self.tried]
        out += [f"  {n}" for n in self.notes]
        return out


def needs_home(robot: RobotSpec, stand: StandReport) -> str | None:
    """Why ``robot``'s home should be replaced by a proposed one (it falls, or its knees are
    straight), or None when it stands from a bent knee."""
    if not stand.stands:
        return f"the home pose falls ({stand.reason})"
    knees = [j for j in robot.joints if j.location == "knee" and j.axis == "pitch"]
    if knees and all(abs(math.degrees(j.home_rad)) < STRAIGHT_KNEE_DEG for j in knees):
        return "the home pose has straight knees: a walker starts from bent ones"
    return None


def leg_pitch_joints(robot: RobotSpec, model: mujoco.MjModel) -> tuple[LegPitch, ...]:
    """Each leg's hip, knee and ankle pitch joints (the hip nearest the root, the ankle nearest
    the foot where a leg has several); ``ValueError`` naming what a leg lacks."""
    def depth(name: str) -> int:
        body, d = int(model.jnt_bodyid[model.joint(name).id]), 0
        while body:
            body, d = int(model.body_parentid[body]), d + 1
        return d

    legs = []
    for side in ("left", "right"):
        found = {}
        for location in ("hip", "knee", "ankle"):
            names = [j.name for j in robot.joints if j.side == side and j.location == location and j.axis == "pitch"]
            if not names:
                raise ValueError(f"robot {robot.name}: the {side} leg has no {location} pitch joint: a standing "
                                 "home bends the knee with the hip and ankle pitch")
            found[location] = (min if location == "hip" else max)(names, key=depth)
        legs.append(LegPitch(side, found["hip"], found["knee"], found["ankle"]))
    return tuple(legs)


def with_stance(robot: RobotSpec, home_rad: dict[str, float],
                range_rad: dict[str, tuple[float, float]] | None = None) -> RobotSpec:
    """``robot`` with these home angles (and ranges) [rad]; joints not named keep theirs."""
    ranges = range_rad or {}
    joints = tuple(dataclasses.replace(j, home_rad=home_rad.get(j.name, j.home_rad),
                                       range_rad=tuple(ranges.get(j.name, j.range_rad))) for j in robot.joints)
    # a measured physique goes along: it is measured at the zero pose, which home and ranges leave alone
    return dataclasses.replace(robot, joints=joints)


def centred_ranges(robot: RobotSpec, home_rad: dict[str, float],
                   limits: dict[str, tuple[float, float]]) -> tuple[dict[str, tuple[float, float]], list[str]]:
    """Each leg joint's range centred on its home within its limits [rad] (module docstring),
    the others' as they are; and notes on ranges the limits cut narrow."""
    ranges, notes = {}, []
    for j in robot.joints:
        if j.location not in LEG_LOCATIONS:
            ranges[j.name] = j.range_rad
            continue
        low, high = limits[j.name]
        home = home_rad[j.name]
        half_deg = HALF_WIDTH_DEG.get((j.location, j.axis), HALF_WIDTH_DEG[j.axis])
        half = min(home - low, high - home)
        if half_deg is not None:
            half = min(half, math.radians(half_deg))
        ranges[j.name] = (_rounded(home - half), _rounded(home + half))
        if half < math.radians(NARROW_HALF_DEG):
            notes.append(f"{j.name}: its limits [{math.degrees(low):.1f}, {math.degrees(high):.1f}] deg leave only "
                         f"+-{math.degrees(half):.1f} deg about the stance")
    return ranges, notes


def _rounded(angle: float) -> float:
    step = math.radians(ROUND_DEG)
    return round(angle / step) * step


class _Stance:
    """The kinematics a stance is solved with: the model with its root as drawn."""

    def __init__(self, robot: RobotSpec, model: mujoco.MjModel, legs: tuple[LegPitch, ...]):
        self.model, self.legs, self.robot = model, legs, robot
        self.data = mujoco.MjData(model)
        self.angles = JointAngles.of(model, robot.joint_names)
        self.parts = RobotModel.of(model, robot)
        self.feet = [int(model.site_bodyid[s]) for s in self.parts.soles]
        self.mass = float(model.body_mass.sum())
        self.data.qpos[:] = model.qpos0  # zero pose, root as drawn
        self.root_qpos = model.qpos0.copy()
        mujoco.mj_kinematics(model, self.data)
        self.forward = forward_direction(model, self.data, robot)
        # each foot's direction that is up at the zero pose, in the foot's frame
        self.foot_up = [self.data.xmat[b].reshape(3, 3).T @ np.array([0.0, 0.0, 1.0]) for b in self.feet]

    def place(self, pose: dict[str, float]) -> None:
        self.data.qpos[:] = self.root_qpos
        self.angles.place(self.data.qpos, np.array([pose[n] for n in self.robot.joint_names]))
        mujoco.mj_kinematics(self.model, self.data)

    def residual(self, pose: dict[str, float]) -> np.ndarray:
        """(2,) the feet's forward tilt [rad, as a sine] and the centre of mass ahead of the
        middle of the soles [leg lengths], with the root as drawn."""
        self.place(pose)
        tilt = np.mean([float(self.data.xmat[b].reshape(3, 3) @ up @ self.forward)
                        for b, up in zip(self.feet, self.foot_up)])
        com = (self.model.body_mass[:, None] * self.data.xipos).sum(axis=0) / self.mass
        middle = self.parts.sole_positions(self.data.site_xpos).mean(axis=0)
        return np.array([tilt, float((com - middle) @ self.forward) / self.robot.leg_length])

    def solve(self, base: dict[str, float], knee: float) -> dict[str, float] | None:
        """The pose with both knees at ``knee`` and the hip and ankle pitch solved, or None
        when Newton's method does not converge."""
        x = np.array([knee / 2, knee / 2])  # hip, ankle: feet flat for a leg of straight links

        def pose_of(v: np.ndarray) -> dict[str, float]:
            pose = dict(base)
            for leg in self.legs:
                pose.update({leg.hip: float(v[0]), leg.knee: knee, leg.ankle: float(v[1])})
            return pose

        for _ in range(SOLVE_ITERATIONS):
            r = self.residual(pose_of(x))
            if r @ r < SOLVE_TOL:
                return pose_of(x)
            jac = np.empty((2, 2))
            for k in range(2):
                dx = np.zeros(2)
                dx[k] = FD_STEP_RAD
                jac[:, k] = (self.residual(pose_of(x + dx)) - r) / FD_STEP_RAD
            try:
                step = np.linalg.solve(jac, -r)
            except np.linalg.LinAlgError:
                return None
            x = x + np.clip(step, -MAX_STEP_RAD, MAX_STEP_RAD)
        return None


def propose_home(robot: RobotSpec, *, limits: dict[str, tuple[float, float]] | None = None,
                 knee_bends_deg: tuple[float, ...] = KNEE_BENDS_DEG, seconds: float = STAND_S) -> HomeProposal:
    """A home pose that stands and leg ranges centred on it (module docstring).

    ``limits``: each joint's mechanical limits [rad] (default: its range in ``robot``, as an
    import takes it from the model); the proposed ranges stay within them.  Raises
    :class:`NoStandingHome` when no bend stands, ``ValueError`` when a leg lacks a pitch joint.
    """
    model = build_model(robot)
    legs = leg_pitch_joints(robot, model)
    limits = {j.name: tuple(j.range_rad) for j in robot.joints} | dict(limits or {})
    shaping = {n for leg in legs for n in (leg.hip, leg.knee, leg.ankle)}
    base = {j.name: (min(max(0.0, limits[j.name][0]), limits[j.name][1]) if j.location in LEG_LOCATIONS
                     else j.home_rad) for j in robot.joints}
    stance = _Stance(robot, model, legs)
    tried, fallback = [], None
    for knee_deg in knee_bends_deg:
        pose = stance.solve(base, math.radians(knee_deg))
        if pose is None:
            tried.append(f"knees {knee_deg:g} deg: no hip and ankle pitch keep the feet flat under the centre of mass")
            continue
        pose = {n: _rounded(a) for n, a in pose.items()}
        outside = [n for n in shaping if not limits[n][0] <= pose[n] <= limits[n][1]]
        if outside:
            tried.append(f"knees {knee_deg:g} deg: " + ", ".join(
                f"{n} {math.degrees(pose[n]):.1f} deg" for n in sorted(outside)) + " outside the joint's limits")
            continue
        ranges, notes = centred_ranges(robot, pose, limits)
        report = check_stand(with_stance(robot, pose, ranges), seconds)
        centred = tuple(j.name for j in robot.joints if j.location in LEG_LOCATIONS)
        proposal = HomeProposal(pose, ranges, knee_deg, legs, centred, report, tuple(tried), tuple(notes))
        if report.verdict == "stands":
            return proposal
        tried.append(f"knees {knee_deg:g} deg: {report.verdict}: {report.reason}")
        if report.stands and fallback is None:
            fallback = proposal
    if fallback is not None:
        return dataclasses.replace(fallback, tried=tuple(tried))
    raise NoStandingHome(f"robot {robot.name}: no home found that stands; " + "; ".join(tried))
