"""Servo model response: step responses, standing still, the firmware's D term.

    python -m benchmarks.servo_response --json

Measures the servo model of :mod:`sim2real.robot.servo_model` on the default robot:

* ``suspended_knee``: the robot hung by its pelvis (feet off the floor), every servo holding
  home; the right knee's goal steps +10 deg (and back): rise time (10-90 %), overshoot,
  steady error (the last 0.2 s) and settling time (within 0.5 deg of the final angle);
* ``standing_squat``: the robot standing on the floor; both legs squat by a step of knee
  +10 deg, hip and ankle pitch +5 deg (trunk and feet stay level); the right knee's response;
* ``standing``: ``tests/test_model.py``'s standing test (held at home for 5 s): pelvis drop,
  largest joint error from its goal and largest joint speed at the end;
* each of these with the firmware's D term as the actuators' ``kv`` at 0 and at its bounds
  (``--kv``).

Angles are what the encoder reports (unquantized).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from benchmarks.common import parser, progress, report
from sim2real.robot import RobotSpec, load_robot
from sim2real.simulation.model_builder import finished_spec

STEP_DEG = 10.0
STEP_S = 1.0  # each step is held this long
SETTLE_BAND_DEG = 0.5
SQUAT_DEG = {"knee": 10.0, "hip": 5.0, "ankle": 5.0}  # hip + ankle = knee keeps trunk and feet level


def d_term_kv(robot: RobotSpec, loop_hz: float) -> float:
    """The firmware's D term as a velocity gain at a loop rate [N m s/rad] (see servo_model)."""
    profile = robot.joints[0].servo.profile
    g = profile.gains.values
    kpd = g["position_d"] / g["d_divisor"]  # [PWM units per tick per loop period]
    return profile.motor.stall_torque_nm * kpd / profile.position.rad_per_tick / (loop_hz * g["pwm_limit"])


def _model(robot: RobotSpec, suspended: bool, kv: float) -> mujoco.MjModel:
    spec = finished_spec(robot)
    if suspended:  # hung by the pelvis, high enough that the feet swing free
        spec.delete(spec.joint("root"))
        spec.delete(spec.key("home"))
        spec.body("pelvis").pos = [0, 0, 2 * robot.body.leg_length]
    model = spec.compile()
    model.actuator_biasprm[:, 2] = -kv  # position actuator: force = kp (ctrl - q) - kv qdot
    return model


class Sim:
    """One robot simulation: goals in, encoder angles out."""

    def __init__(self, robot: RobotSpec, suspended: bool, kv: float):
        self.robot = robot
        self.model = _model(robot, suspended, kv)
        self.data = mujoco.MjData(self.model)
        names = list(robot.joint_names)
        self.qadr = np.array([self.model.jnt_qposadr[self.model.joint(n).id] for n in names])
        self.home = np.array([j.home_rad for j in robot.joints])
        if suspended:
            self.data.qpos[self.qadr] = self.home
        else:
            mujoco.mj_resetDataKeyframe(self.model, self.data, self.model.key("home").id)
        self.data.ctrl[:] = self.home
        mujoco.mj_forward(self.model, self.data)

    def angles(self) -> np.ndarray:
        return self.data.qpos[self.qadr].copy()

    def run(self, goal: np.ndarray, seconds: float, joint: int) -> tuple[np.ndarray, np.ndarray]:
        """Hold ``goal`` for ``seconds``; times [s] and joint ``joint``'s angle [rad]."""
        self.data.ctrl[:] = goal
        n = int(round(seconds / self.model.opt.timestep))
        t, q = np.empty(n), np.empty(n)
        for k in range(n):
            mujoco.mj_step(self.model, self.data)
            t[k], q[k] = self.data.time, self.angles()[joint]
        return t - t[0], q


def step_metrics(t: np.ndarray, q: np.ndarray, start: float, step: float) -> dict[str, float]:
    """Rise time from 10 to 90 % of the final angle [ms], overshoot past it [% of the step],
    steady error [deg] (the last 0.2 s's mean minus the goal, signed along the step: negative
    falls short) and settling time, within 0.5 deg of the final angle for good [ms]."""
    x = (q - start) / step  # 0 at the start, 1 at the goal
    final = float(np.mean(x[t >= t[-1] - 0.2]))
    t10, t90 = t[np.argmax(x >= 0.1 * final)], t[np.argmax(x >= 0.9 * final)]
    outside = np.flatnonzero(np.abs(x - final) > SETTLE_BAND_DEG / abs(math.degrees(step)))
    settle = 0.0 if not len(outside) else (t[outside[-1] + 1] if outside[-1] + 1 < len(t) else math.nan)
    return {"rise_ms": round(1e3 * (t90 - t10), 1), "overshoot_pct": round(100 * max(0.0, float(x.max()) - final), 1),
            "steady_error_deg": round(math.degrees(step) * (final - 1.0), 3), "settle_ms": None if math.isnan(settle) else round(1e3 * settle, 1)}


def suspended_knee(robot: RobotSpec, kv: float) -> dict[str, dict[str, float]]:
    sim = Sim(robot, suspended=True, kv=kv)
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


def standing_squat(robot: RobotSpec, kv: float) -> dict[str, float]:
    sim = Sim(robot, suspended=False, kv=kv)
    knee = list(robot.joint_names).index("right_knee")
    sim.run(sim.home, 1.0, knee)
    goal = sim.home.copy()
    for i, j in enumerate(robot.joints):
        if j.axis == "pitch":
            goal[i] += math.radians(SQUAT_DEG[j.location])
    t, q = sim.run(goal, STEP_S, knee)
    return step_metrics(t, q, sim.home[knee], math.radians(SQUAT_DEG["knee"]))


def standing(robot: RobotSpec, kv: float) -> dict[str, float]:
    sim = Sim(robot, suspended=False, kv=kv)
    start = sim.data.qpos[2]
    sim.run(sim.home, 5.0, 0)
    error = np.degrees(np.abs(sim.angles() - sim.home))
    return {"pelvis_drop_mm": round(1e3 * float(start - sim.data.qpos[2]), 3),
            "max_joint_error_deg": round(float(error.max()), 3),
            "max_speed_rad_s": float(f"{np.abs(sim.data.qvel).max():.2g}"),
            "upright": round(float(sim.data.sensor("torso_up").data[2]), 5)}


def measure(robot: RobotSpec, kv: float) -> dict[str, object]:
    return {"kv_nms": round(kv, 4), "suspended_knee": suspended_knee(robot, kv),
            "standing_squat": standing_squat(robot, kv), "standing": standing(robot, kv)}


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--robot", default="xl430_biped")
    p.add_argument("--loop-hz", type=float, nargs="*", default=[8000.0, 1000.0],
                   help="firmware loop rates bounding the D term's time base (default: 8 kHz and 1 kHz)")
    args = p.parse_args(argv)
    robot = load_robot(args.robot)
    kvs = {"none": 0.0, **{f"{hz / 1e3:g}kHz": d_term_kv(robot, hz) for hz in args.loop_hz}}
    results = {}
    for name, kv in kvs.items():
        progress(f"kv {name} = {kv:.4f} N m s/rad", args.json)
        results[name] = measure(robot, kv)
    report({"robot": robot.name, "d_term": results}, args.json)


if __name__ == "__main__":
    main()
