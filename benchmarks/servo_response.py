"""Servo model response: step responses and standing still, per servo-model variant.

    python -m benchmarks.servo_response --json

Measures the servo model of :mod:`sim2real.robot.servo_model` on the default robot, built
as evolution and the simulated bus build it (``build_model`` and a reality's perturbation):

* ``suspended_knee``: the robot hung by its pelvis (feet off the floor), every servo holding
  home; the right knee's goal steps +10 deg, then back: rise time (10-90 % of the final
  angle), overshoot past it, steady error (the last 0.2 s against the goal; negative falls
  short) and settling time (within 0.5 deg of the final angle for good);
* ``standing_squat``: the robot standing on the floor squats by a step of knee +10 deg, hip
  and ankle pitch +5 deg on both legs (trunk and feet stay level); the right knee's response;
* ``standing``: ``tests/test_model.py``'s standing test (held at home for 5 s): pelvis drop,
  largest joint error from its goal and largest speed at the end, torso up-vector z;

for the nominal model, the firmware's D term at loop rates from 8 to 1 kHz
(``derivative_ms``), backlash joints closed and at widths up to 1 deg (``backlash_deg``),
ToddlerBot v2's armature and the ``default`` reality as a whole.  Angles are what the encoders report (unquantized).  Also
``torque_speed``: the model's net torque at full duty against ToddlerBot v2's fitted
2XL430 envelope (docs/servo_model.md).
"""

from __future__ import annotations

import copy
import math

import mujoco
import numpy as np

from benchmarks.common import parser, progress, report
from sim2real.robot import RobotSpec
from sim2real.simulation.model.physique import load_measured
from sim2real.robot.servo_model import derivative_time, servo_physics
from sim2real.robot.timing import control_timing
from sim2real.simulation.model.builder import build_model
from sim2real.simulation.model.robot_model import JointAngles
from sim2real.simulation.model.robot_model import UP_SENSOR
from sim2real.simulation.reality.file import Reality, load_reality
from sim2real.simulation.reality.randomize import apply_to_model, needs_backlash_joints, sample

STEP_DEG = 10.0
STEP_S = 1.0  # each step is held this long
SETTLE_BAND_DEG = 0.5
SQUAT_DEG = {"knee": 10.0, "hip": 5.0, "ankle": 5.0}  # hip + ankle = knee keeps trunk and feet level
LOOP_HZ = (8000.0, 4000.0, 2000.0, 1000.0)  # the D term's unpublished time base, bounded
BACKLASH_DEG = (0.3, 0.6, 1.0)
# ToddlerBot v2.0.0's 2XL430 fit (tjacobs/toddlerbot@082c5b4:toddlerbot/descriptions/default.yml):
# driving torque limit tau_max [N m] up to q_dot_tau_max [rad/s], then linear to tau_q_dot_max at
# q_dot_max; joint damping [N m s/rad] and frictionloss [N m] outside it; armature [kg m^2]
TODDLERBOT_V2 = {"tau_max": 0.93, "q_dot_tau_max": 2.0, "tau_q_dot_max": 0.08, "q_dot_max": 5.97,
                 "damping": 0.0013, "frictionloss": 0.069, "armature": 0.0083}


class Sim:
    """The robot in one simulation, perturbed by ``reality``'s first draw: goals in, encoder
    angles out; ``suspended`` hangs it by the pelvis with its feet off the floor; its model
    has backlash joints if ``backlash``."""

    def __init__(self, robot: RobotSpec, reality: Reality, backlash: bool, suspended: bool):
        self.model = build_model(robot, backlash=backlash, suspended=suspended)
        apply_to_model(self.model, copy.copy(self.model),
                       sample(reality, np.zeros((1, 1)), self.model, 0, control_timing(robot).tick_s))
        self.data = mujoco.MjData(self.model)
        self.angles = JointAngles.of(self.model, robot.joint_names)
        self.home = np.array([j.home_rad for j in robot.joints])
        mujoco.mj_resetDataKeyframe(self.model, self.data, self.model.key("home").id)
        mujoco.mj_forward(self.model, self.data)

    def run(self, goal: np.ndarray, seconds: float, joint: int) -> tuple[np.ndarray, np.ndarray]:
        """Hold ``goal`` for ``seconds``; times [s] and joint ``joint``'s angle [rad]."""
        self.data.ctrl[:] = goal
        n = int(round(seconds / self.model.opt.timestep))
        t, q = np.empty(n), np.empty(n)
        for k in range(n):
            mujoco.mj_step(self.model, self.data)
            t[k], q[k] = self.data.time, self.angles.read(self.data.qpos)[joint]
        return t - t[0], q


def step_metrics(t: np.ndarray, q: np.ndarray, start: float, step: float) -> dict[str, float | None]:
    """Rise time from 10 to 90 % of the final angle [ms], overshoot past it [% of the step],
    steady error [deg] (the last 0.2 s's mean minus the goal, signed along the step: negative
    falls short) and settling time, within 0.5 deg of the final angle for good [ms]."""
    x = (q - start) / step  # 0 at the start, 1 at the goal
    final = float(np.mean(x[t >= t[-1] - 0.2]))
    t10, t90 = t[np.argmax(x >= 0.1 * final)], t[np.argmax(x >= 0.9 * final)]
    outside = np.flatnonzero(np.abs(x - final) > SETTLE_BAND_DEG / abs(math.degrees(step)))
    settle = 0.0 if not len(outside) else (t[outside[-1] + 1] if outside[-1] + 1 < len(t) else math.nan)
    return {"rise_ms": round(1e3 * (t90 - t10), 1), "overshoot_pct": round(100 * max(0.0, float(x.max()) - final), 1),
            "steady_error_deg": round(math.degrees(step) * (final - 1.0), 3),
            "settle_ms": None if math.isnan(settle) else round(1e3 * settle, 1)}


def suspended_knee(robot: RobotSpec, reality: Reality, backlash: bool) -> dict[str, dict[str, float | None]]:
    sim = Sim(robot, reality, backlash, suspended=True)
    knee = list(robot.joint_names).index("right_knee")
    sim.run(sim.home, 1.0, knee)  # let it hang still
    out = {}
    goal = sim.home.copy()
    for name, delta in (("up", STEP_DEG), ("down", -STEP_DEG)):
        start = goal[knee]
        goal[knee] += math.radians(delta)
        t, q = sim.run(goal, STEP_S, knee)
        out[name] = step_metrics(t, q, start, math.radians(delta))
    return out


def standing_squat(robot: RobotSpec, reality: Reality, backlash: bool) -> dict[str, float | None]:
    sim = Sim(robot, reality, backlash, suspended=False)
    knee = list(robot.joint_names).index("right_knee")
    sim.run(sim.home, 1.0, knee)
    goal = sim.home.copy()
    for i, j in enumerate(robot.joints):
        if j.axis == "pitch":
            goal[i] += math.radians(SQUAT_DEG[j.location])
    t, q = sim.run(goal, STEP_S, knee)
    return step_metrics(t, q, sim.home[knee], math.radians(SQUAT_DEG["knee"]))


def standing(robot: RobotSpec, reality: Reality, backlash: bool) -> dict[str, float]:
    sim = Sim(robot, reality, backlash, suspended=False)
    start = sim.data.qpos[2]
    sim.run(sim.home, 5.0, 0)
    error = np.degrees(np.abs(sim.angles.read(sim.data.qpos) - sim.home))
    return {"pelvis_drop_mm": round(1e3 * float(start - sim.data.qpos[2]), 3),
            "max_joint_error_deg": round(float(error.max()), 3),
            "max_speed_rad_s": float(f"{np.abs(sim.data.qvel).max():.2g}"),
            "upright": round(float(sim.data.sensor(UP_SENSOR).data[2]), 5)}


def measure(robot: RobotSpec, reality: Reality, backlash: bool) -> dict[str, object]:
    return {"reality": reality.to_dict(), "backlash_joints": backlash,
            **{name: f(robot, reality, backlash) for name, f in
               (("suspended_knee", suspended_knee), ("standing_squat", standing_squat), ("standing", standing))}}


def torque_speed(robot: RobotSpec) -> list[dict[str, float]]:
    """Net torque at full duty [N m] against speed [rad/s]: this model's (stall torque less
    back-EMF damping and Coulomb friction) and ToddlerBot v2's (driving limit less its damping
    and friction)."""
    phys = servo_physics(robot.joints[0].servo.profile)
    tb = TODDLERBOT_V2
    rows = []
    for w in (0.0, 1.0, 2.0, 3.0, 4.0, 5.0, phys.no_load_speed):
        taper = (w - tb["q_dot_tau_max"]) / (tb["q_dot_max"] - tb["q_dot_tau_max"])
        limit = tb["tau_max"] if w <= tb["q_dot_tau_max"] else tb["tau_max"] + taper * (tb["tau_q_dot_max"] - tb["tau_max"])
        rows.append({"speed_rad_s": round(w, 2),
                     "model_nm": round(phys.force_limit - phys.damping * w - phys.frictionloss, 3),
                     "toddlerbot_v2_nm": round(limit - tb["damping"] * w - tb["frictionloss"], 3)})
    return rows


def variants(robot: RobotSpec) -> dict[str, tuple[Reality, bool]]:
    """Name -> (reality, whether the model has backlash joints)."""
    profile = robot.joints[0].servo.profile
    realities = {"nominal": load_reality(None)}
    for hz in LOOP_HZ:
        realities[f"d_term_{hz / 1e3:g}kHz"] = load_reality({"derivative_ms": 1e3 * derivative_time(profile, hz)})
    for width in BACKLASH_DEG:
        realities[f"backlash_{width:g}deg"] = load_reality({"backlash_deg": width})
    armature = TODDLERBOT_V2["armature"] / profile.motor.armature_kgm2
    realities["armature_toddlerbot_v2"] = load_reality({"armature_scale": armature})
    realities["default"] = load_reality("default")
    out = {name: (reality, needs_backlash_joints(reality)) for name, reality in realities.items()}
    out["backlash_closed"] = (load_reality(None), True)  # the joints there, at width 0
    return out


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--robot", default="xl430_biped")
    p.add_argument("--only", nargs="*", help="measure only these variants (default: all)")
    args = p.parse_args(argv)
    robot = load_measured(args.robot)
    phys = servo_physics(robot.joints[0].servo.profile)
    results = {}
    for name, (reality, backlash) in variants(robot).items():
        if args.only and name not in args.only:
            continue
        progress(f"{name}: {reality.to_dict()}{', backlash joints' if backlash else ''}", args.json)
        results[name] = measure(robot, reality, backlash)
    report({"robot": robot.name, "servo": {"kp_nm_rad": round(phys.kp, 3), "damping_nms": round(phys.damping, 4),
                                           "frictionloss_nm": phys.frictionloss, "armature_kgm2": phys.armature},
            "variants": results, "torque_speed": torque_speed(robot)}, args.json)


if __name__ == "__main__":
    main()
