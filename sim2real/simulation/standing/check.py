"""Does the robot stand?  Five seconds from its home pose, the servos holding home.

The robot is built as every simulation here builds it (:func:`~sim2real.simulation.model.builder.build_model`:
each joint a position servo with its profile's gain, stall torque, damping and friction, or a
PD character's gains), put at its ``home`` keyframe (soles just above the floor, feet level)
and left to stand for ``seconds`` with every actuator's target at home.  What is measured:

* the torso's up-vector z (the IMU's ``torso_up`` sensor: 1 upright), at the end and its worst;
* the sag: how far the root body's centre of mass sank from its start [m];
* the share of the robot's weight the feet carry: the floor's contact forces on the foot
  bodies (and bodies below them, such as toes), vertical, over m g, averaged over the last
  :data:`AVERAGE_S` (under 1: something else rests on the floor; over 1: still bouncing);
* each joint's holding torque at that pose (its actuator's force, averaged over the same
  window) against its limit - the servo's stall torque from its firmware profile, or a PD
  robot's torque cap - as a margin ``limit / holding`` (as ``robot show`` gives it);
* whether it fell (evolution's test: the root's centre of mass below :data:`FALL_HEIGHT` of
  its start, or the torso tilted past :data:`FALL_TILT_DEG`; or, at the end, tilted past
  :data:`STAND_TILT_DEG`, or resting on other parts than its feet) and whether its feet slid.

The verdict is ``stands``, ``stands with a warning`` or ``falls``, with every reason.

    report = check_stand(load_measured("op3"))    # sim2real.simulation.model.physique
    report.verdict, report.up_z_final, report.sag_m, report.reasons
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import mujoco
import numpy as np

from sim2real.robot import RobotSpec
from sim2real.robot.spec import GRAVITY
from sim2real.simulation.model.builder import build_model, instability
from sim2real.simulation.model.robot_model import RobotModel

STAND_S = 5.0  # [s] simulated from home
AVERAGE_S = 0.5  # [s] the final window the weight share and the holding torques are averaged over
# A fall, as evolution and the simulated bus call one (evolve/locomotion/task.py fall_height and
# fall_tilt_deg; sim2real/simulation/simbus/physics.py FALL_HEIGHT, FALL_TILT_DEG)
FALL_HEIGHT = 0.7  # the root's centre of mass below this share of its start height
FALL_TILT_DEG = 60.0  # or the torso tilted this far from upright [deg]
STAND_TILT_DEG = 45.0  # a torso tilted this far at the end does not stand, however still it rests [deg]
FEET_FALL_SHARE = 0.5  # the feet carry less than this share of the weight at the end: it rests on something else
# Warnings: it stands, but the stance is not one to start walking from
WARN_TILT_DEG = 15.0  # the torso tilted this far at some moment [deg]
WARN_SAG_SHARE = 0.05  # the root sank this share of the leg length
WARN_SLIDE_SHARE = 0.02  # a foot moved this share of the leg length over the floor
WARN_FEET_SHARE = 0.9  # the feet carry less than this share of the weight (a hand or a knee down)
WARN_MARGIN = 1.5  # a joint's limit under this many times its holding torque (robot show's threshold)
STALLED_MARGIN = 1.02  # a joint this close to its limit is stalled (the actuator saturates)
WORST_SHOWN = 4  # joints named in the text, lowest margin first

VERDICTS = ("stands", "stands with a warning", "falls")


@dataclass(frozen=True)
class JointHold:
    """One joint's holding torque at the stance and its limit."""

    joint: str
    holding_nm: float  # |actuator force| averaged over the final window [N m]
    limit_nm: float  # the servo's stall torque, or the PD torque cap [N m]
    limit_kind: str  # "stall" or "pd cap"

    @property
    def margin(self) -> float | None:
        """limit / holding; None when the joint holds (next to) nothing."""
        return self.limit_nm / self.holding_nm if self.holding_nm > 1e-6 else None


@dataclass(frozen=True)
class StandReport:
    """What :func:`check_stand` measured (SI units) and its verdict."""

    robot: str
    seconds: float  # simulated [s] (less when it fell: until the fall)
    up_z_final: float  # the torso's up-vector z at the end (1 upright)
    up_z_worst: float  # its lowest over the run
    sag_m: float  # start minus end height of the root's centre of mass [m] (negative: it rose)
    feet_weight_share: float  # vertical floor force on the feet / (m g), final window
    slide_m: float  # the larger of the two feet's horizontal travel [m]
    com_ahead_m: float  # at home: the centre of mass ahead (+) of the middle of the two soles [m]
    fell: bool
    fell_at_s: float | None  # when it fell [s]
    slid: bool
    holds: tuple[JointHold, ...]  # robot.joints order
    verdict: str  # one of VERDICTS
    reasons: tuple[str, ...]  # why, worst first (empty when it simply stands)

    @property
    def stands(self) -> bool:
        return self.verdict != "falls"

    @property
    def weakest(self) -> list[JointHold]:
        """The joints that carry a load, lowest margin first."""
        return sorted((h for h in self.holds if h.margin is not None), key=lambda h: h.margin)

    @property
    def reason(self) -> str:
        """The verdict's one-line reason."""
        if not self.reasons:
            return "upright, on its feet, still, every joint well within its torque"
        return self.reasons[0] + (f" (and {len(self.reasons) - 1} more)" if len(self.reasons) > 1 else "")

    def to_json(self) -> dict:
        """What ``biped robot stand --json`` prints."""
        out = asdict(self)
        out["holds"] = [dict(asdict(h), margin=h.margin) for h in self.holds]
        out["weakest"] = [h.joint for h in self.weakest[:WORST_SHOWN]]
        out["reasons"] = list(self.reasons)
        out["reason"] = self.reason
        return out

    def lines(self) -> list[str]:
        """The report as text, one fact a line."""
        tilt = _tilt_deg
        out = [f"{self.robot}: {self.seconds:g} s from home, the servos holding home",
               f"  torso up-vector z {self.up_z_final:.4f} at the end ({tilt(self.up_z_final):.1f} deg), "
               f"worst {self.up_z_worst:.4f} ({tilt(self.up_z_worst):.1f} deg)",
               f"  sag {self.sag_m * 1e3:.1f} mm (the root's centre of mass)",
               f"  the feet carry {100 * self.feet_weight_share:.1f} % of its weight; at home its centre of "
               f"mass is {1e3 * self.com_ahead_m:+.1f} mm ahead of the middle of the soles",
               f"  fell: {'yes, at %.2f s' % self.fell_at_s if self.fell else 'no'}; "
               f"slid: {'yes' if self.slid else 'no'} ({self.slide_m * 1e3:.1f} mm)"]
        weakest = self.weakest[:WORST_SHOWN]
        if weakest:
            out.append("  torque margin (limit / holding torque), lowest: " + ", ".join(
                f"{h.joint} {h.margin:.1f}x ({h.holding_nm:.3f} of {h.limit_nm:.2f} N m {h.limit_kind})"
                for h in weakest))
        out.append(f"verdict: {self.verdict}: {self.reason}")
        out += [f"  - {r}" for r in self.reasons[1:]]
        return out


def foot_bodies(model: mujoco.MjModel, parts: RobotModel) -> set[int]:
    """The bodies of both feet (each sole site's body) and every body below them (toes)."""
    feet = {int(model.site_bodyid[s]) for s in parts.soles}
    for body in range(1, model.nbody):  # parents precede children in MuJoCo
        if int(model.body_parentid[body]) in feet:
            feet.add(body)
    return feet


def floor_force_on(model: mujoco.MjModel, data: mujoco.MjData, bodies: set[int]) -> float:
    """The vertical force the world (floor) exerts on ``bodies`` through contacts [N]."""
    total, wrench = 0.0, np.zeros(6)
    for k in range(data.ncon):
        contact = data.contact[k]
        b1, b2 = int(model.geom_bodyid[contact.geom1]), int(model.geom_bodyid[contact.geom2])
        if not ((b1 == 0 and b2 in bodies) or (b2 == 0 and b1 in bodies)):
            continue
        mujoco.mj_contactForce(model, data, k, wrench)
        world = contact.frame.reshape(3, 3).T @ wrench[:3]  # the contact frame's rows are its axes
        total += abs(float(world[2]))
    return total


def _limits(robot: RobotSpec, model: mujoco.MjModel) -> list[tuple[float, str]]:
    """Each joint's torque limit [N m] and what it is, robot.joints order."""
    out = []
    for joint in robot.joints:
        if joint.servo is not None:
            out.append((joint.servo.profile.motor.stall_torque_nm, "stall"))
        else:
            out.append((float(model.actuator_forcerange[model.actuator(joint.name).id][1]), "pd cap"))
    return out


def forward_direction(model: mujoco.MjModel, data: mujoco.MjData, robot: RobotSpec) -> np.ndarray:
    """(3,) the robot's forward direction on the floor, unit (needs kinematics): a hip pitch
    joint's axis (+ is flexion, the thigh forward: :mod:`sim2real.robot.anatomy`) crossed into
    world up; the root body's x axis for a robot without one."""
    hips = [j.name for j in robot.joints if j.location == "hip" and j.axis == "pitch"]
    if hips:
        forward = np.cross([0.0, 0.0, 1.0], data.xaxis[model.joint(hips[0]).id])
    else:
        forward = data.xmat[model.body(robot.root_body).id].reshape(3, 3)[:, 0].copy()
    forward[2] = 0.0
    norm = float(np.linalg.norm(forward))
    return forward / norm if norm > 1e-9 else np.array([1.0, 0.0, 0.0])


def _com_ahead(model: mujoco.MjModel, data: mujoco.MjData, parts: RobotModel, robot: RobotSpec) -> float:
    """The whole robot's centre of mass ahead of the middle of its soles, along its forward
    direction (:func:`forward_direction`) [m] (needs kinematics)."""
    com = (model.body_mass[:, None] * data.xipos).sum(axis=0) / model.body_mass.sum()
    middle = parts.sole_positions(data.site_xpos).mean(axis=0)
    return float(np.dot(com - middle, forward_direction(model, data, robot)))


def check_stand(robot: RobotSpec, seconds: float = STAND_S, model: mujoco.MjModel | None = None) -> StandReport:
    """Simulate ``robot`` standing ``seconds`` from home with its servos holding home, and judge
    it (module docstring).  ``model``: its compiled model, if already built."""
    if not seconds > AVERAGE_S:
        raise ValueError(f"seconds: {seconds!r} must exceed the {AVERAGE_S:g} s averaging window")
    model = build_model(robot) if model is None else model
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    parts = RobotModel.of(model, robot)
    feet = foot_bodies(model, parts)
    weight = float(model.body_mass.sum()) * GRAVITY
    start_z = float(parts.root_com(data.xipos)[2])
    start_soles = parts.sole_positions(data.site_xpos)[:, :2].copy()
    com_ahead = _com_ahead(model, data, parts, robot)
    min_up_z = math.cos(math.radians(FALL_TILT_DEG))

    steps = int(round(seconds / model.opt.timestep))
    window = max(1, int(round(AVERAGE_S / model.opt.timestep)))
    up_worst, fell_at, fall, unstable = 1.0, None, "", None
    force_sum, torque_sum, averaged = 0.0, np.zeros(model.nu), 0
    for step in range(steps):
        mujoco.mj_step(model, data)
        unstable = instability(data)
        if unstable:
            fell_at = float(data.time)
            break
        up_z = float(parts.up(data.sensordata)[2])
        up_worst = min(up_worst, up_z)
        if parts.root_com(data.xipos)[2] < FALL_HEIGHT * start_z:
            fell_at = float(data.time)
            fall = f"the root's centre of mass sank below {FALL_HEIGHT:g} of its start height"
            break
        if up_z < min_up_z:
            fell_at, fall = float(data.time), f"the torso tilted past {FALL_TILT_DEG:g} deg"
            break
        if step >= steps - window:
            force_sum += floor_force_on(model, data, feet)
            torque_sum += np.abs(data.actuator_force)
            averaged += 1
    if averaged == 0:  # it fell before the final window: what it carried as it went down
        force_sum, torque_sum, averaged = floor_force_on(model, data, feet), np.abs(data.actuator_force), 1
    slide = float(np.linalg.norm(parts.sole_positions(data.site_xpos)[:, :2] - start_soles, axis=1).max())
    holds = tuple(JointHold(j.name, float(torque_sum[i] / averaged), limit, kind)
                  for i, (j, (limit, kind)) in enumerate(zip(robot.joints, _limits(robot, model))))
    share = force_sum / averaged / weight
    sag = start_z - float(parts.root_com(data.xipos)[2])
    up_final = float(parts.up(data.sensordata)[2]) if not unstable else float("nan")
    fell = fell_at is not None or share < FEET_FALL_SHARE or not _tilt_deg(up_final) <= STAND_TILT_DEG
    slid = not fell and slide > WARN_SLIDE_SHARE * robot.leg_length
    verdict, reasons = _verdict(robot, unstable, fell_at, fall, share, up_final, up_worst, sag, slide, slid, holds)
    return StandReport(robot.name, round(float(data.time), 6), up_final, up_worst, sag, share, slide, com_ahead, fell,
                       fell_at, slid, holds, verdict, tuple(reasons))


def _tilt_deg(up_z: float) -> float:
    """The torso's tilt from upright [deg] from its up-vector's z (NaN stays NaN)."""
    return math.degrees(math.acos(min(1.0, max(-1.0, up_z)))) if math.isfinite(up_z) else float("nan")


def _verdict(robot: RobotSpec, unstable: str | None, fell_at: float | None, fall: str, share: float,
             up_final: float, up_worst: float, sag: float, slide: float, slid: bool,
             holds: tuple[JointHold, ...]) -> tuple[str, list[str]]:
    """The verdict and its reasons, the deciding one first."""
    if unstable:
        return "falls", [f"the simulation went {unstable}"]
    falls = []
    if fell_at is not None:
        falls.append(f"it fell after {fell_at:.2f} s: {fall}")
    elif _tilt_deg(up_final) > STAND_TILT_DEG:
        falls.append(f"it ends with the torso tilted {_tilt_deg(up_final):.0f} deg, past {STAND_TILT_DEG:g}: "
                     "bent over or lying, not standing")
    elif share < FEET_FALL_SHARE:
        falls.append(f"its feet carry only {100 * share:.0f} % of its weight at the end: it rests on "
                     "another part")
    if falls:
        return "falls", falls
    warnings = []
    stalled = [h.joint for h in holds if h.margin is not None and h.margin < STALLED_MARGIN]
    if stalled:  # it stands in the simulation, but a real servo held at stall overheats
        warnings.append(f"{', '.join(stalled)} at the limit of their torque: the servo stalls")
    tilt = _tilt_deg(up_worst)
    if tilt > WARN_TILT_DEG:
        warnings.append(f"the torso tilted {tilt:.0f} deg (over {WARN_TILT_DEG:g})")
    if sag > WARN_SAG_SHARE * robot.leg_length:
        warnings.append(f"it sank {1e3 * sag:.0f} mm, over {100 * WARN_SAG_SHARE:g} % of its leg length")
    if slid:
        warnings.append(f"a foot slid {1e3 * slide:.0f} mm, over {100 * WARN_SLIDE_SHARE:g} % of its leg length")
    if share < WARN_FEET_SHARE:
        warnings.append(f"its feet carry only {100 * share:.0f} % of its weight: another part touches the floor")
    weak = [h for h in holds if h.margin is not None and h.margin < WARN_MARGIN]
    if weak:
        warnings.append("torque margin under " + f"{WARN_MARGIN:g}x at " + ", ".join(
            f"{h.joint} ({h.margin:.2f}x)" for h in sorted(weak, key=lambda h: h.margin)))
    return ("stands with a warning" if warnings else "stands"), warnings
