"""Real against simulated: replay a trace's commanded goals in the simulation (nominal, or
perturbed by a reality file such as one ``biped sysid`` wrote) and measure how far the joints
drift apart.

For each joint: RMSE and MAE between the trace's present angles and the simulation's [deg],
and the lag of the real joint behind the simulated one, by cross-correlation [ms]; for the
feet, the share of ticks on which the trace's foot switches and the simulation agree.  With
a controller, the simulation can instead run it closed-loop (the policy reading simulated
sensors).  A trace from ``biped run`` on hardware and one from a dry run are read alike.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from sim2real.controller.file import Controller
from sim2real.controller.mapping import ServoMapping, quantize
from sim2real.controller.policy import Policy
from sim2real.errors import ConfigError
from sim2real.hardware.trace import TIMING, Trace, check_joint_angles, loop_channels, sidecar_path
from sim2real.robot import RobotSpec, load_robot
from sim2real.robot.names import load_named_robot
from sim2real.simulation.model.builder import instability, SimulationUnstable
from sim2real.simulation.model.physique import measured
from sim2real.simulation.model.robot_model import RobotModel
from sim2real.simulation.reality.file import Reality, load_reality
from sim2real.simulation.reality.randomize import perturbed_model

MAX_LAG_S = 0.5


def _simulate(robot: RobotSpec, times: np.ndarray, goals: np.ndarray, policy: Policy | None,
              model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """Joint angles (n, joints) [rad] and foot contacts (n, 2) of the simulation at the trace's
    ``times`` (n,) [s]: driven by ``goals`` (n, joints) [rad], or closed-loop by ``policy``."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    names = list(robot.joint_names)
    parts = RobotModel.of(model, robot)
    resolution = ServoMapping(robot).rad_per_tick
    angles = np.zeros((len(times), len(names)))
    feet = np.zeros((len(times), 2), dtype=bool)
    goal = policy.reset() if policy is not None else None
    for k, t in enumerate(times):
        angles[k] = quantize(parts.angles.read(data.qpos), resolution)
        feet[k] = parts.feet_touching(data.sensordata)
        if policy is not None:
            goal = policy.step(angles[k], feet[k], parts.up(data.sensordata), goal,
                               heading=float(parts.heading(data.sensordata)), gyro=parts.gyro(data.sensordata))
            data.ctrl[:] = goal
        else:
            data.ctrl[:] = goals[k]
        end = times[k + 1] - times[0] if k + 1 < len(times) else t - times[0] + (t - times[k - 1] if k else 0.0)
        while data.time < end - 1e-9:
            # all but the last step or two in one call (an hour's trace is millions of steps, and a
            # check after each took a third of the time); the last ones singly, to stop exactly
            # where one step at a time would
            mujoco.mj_step(model, data, max(1, int((end - 1e-9 - data.time) / model.opt.timestep) - 1))
            # MuJoCo resets an unstable simulation to time 0 and carries on: this loop would never
            # end, and nothing after it would be a result (its warning counts survive the reset)
            if (why := instability(data)) is not None:
                raise SimulationUnstable(f"the simulation went {why} at {t - times[0]:.2f} s of the trace: no "
                                         "comparison (check the reality profile's values)")
    return angles, feet


MIN_MOTION_RAD = np.radians(0.5)  # below this spread a joint's lag is not defined


def lag_s(real: np.ndarray, sim: np.ndarray, dt: float) -> float | None:
    """How long ``real`` trails ``sim`` (cross-correlation peak) [s]; None for a joint that
    hardly moves (its correlation would be the encoder's noise)."""
    a, b = real - real.mean(), sim - sim.mean()
    if a.std() < MIN_MOTION_RAD or b.std() < MIN_MOTION_RAD:
        return None
    max_lag = max(1, min(len(a) - 1, int(MAX_LAG_S / dt)))
    lags = np.arange(-max_lag, max_lag + 1)
    scores = [np.dot(a[max(0, l):len(a) + min(0, l)], b[max(0, -l):len(b) + min(0, -l)]) for l in lags]
    return float(lags[int(np.argmax(scores))] * dt)


def compare(trace_path: Path | str, robot_name: str | None = None,
            controller_path: Path | str | None = None, reality: str | Path | Reality | None = None) -> dict[str, Any]:
    """The trace against the simulation of its goals (or of ``controller_path`` closed-loop),
    on the nominal robot or one perturbed by ``reality`` (e.g. what ``biped sysid`` wrote);
    an excitation trace of the hung robot is replayed on the hung model."""
    profile = load_reality(reality)
    trace = Trace.read(trace_path)
    if not (robot_name or trace.metadata.get("robot")):
        raise ConfigError(str(trace_path), "", f"no robot: its sidecar {sidecar_path(trace_path).name} "
                          "is missing or names none; give --robot")
    robot = measured(load_robot(robot_name) if robot_name else
                     load_named_robot(trace.metadata["robot"], str(sidecar_path(trace_path)), "robot"))
    names = list(robot.joint_names)
    missing = trace.missing([c.name for c in loop_channels(names) if c.name not in TIMING])
    if missing:
        raise ConfigError(str(trace_path), "header", f"lacks {len(missing)} column(s) of a {robot.name} trace: "
                          f"{', '.join(missing[:4])}{', ...' if len(missing) > 4 else ''}")
    check_joint_angles(trace, [(j.name, j.range_rad) for j in robot.joints], str(trace_path))
    times = trace.times
    real = trace.present(names)
    feet_real = trace.feet
    policy = None
    if controller_path is not None:
        policy = Policy(Controller.load(controller_path, robot), robot)
    excitation = trace.metadata.get("excitation")
    suspended = isinstance(excitation, dict) and excitation.get("pose") == "suspended"
    profile.check_batchable()  # its simulation here steps the model only, as evolution's does
    model, _ = perturbed_model(robot, profile, suspended=suspended)  # seed 0, as the simulated bus draws it
    sim, feet_sim = _simulate(robot, times, trace.goals(names), policy, model)
    dt = float(np.median(np.diff(times))) if len(times) > 1 else 0.0
    joints = {}
    for j, name in enumerate(names):
        err = np.degrees(real[:, j] - sim[:, j])
        lag = lag_s(real[:, j], sim[:, j], dt) if dt else None
        joints[name] = {"rmse_deg": float(np.sqrt(np.mean(err ** 2))), "mae_deg": float(np.mean(np.abs(err))),
                        "lag_ms": None if lag is None else lag * 1e3}
    return {"robot": robot.name, "ticks": len(times), "mode": "closed-loop" if policy else "replayed goals",
            "reality": profile.name, "suspended": suspended,
            "joints": joints, "contact_agreement": float(np.mean(feet_real == feet_sim)), "notes": list(trace.notes),
            "_series": {"times": times, "real": real, "sim": sim, "names": names}}


def plot(result: dict[str, Any], path: Path | str) -> None:
    from sim2real.figures import pyplot, save_figure

    plt = pyplot()

    series = result["_series"]
    names = series["names"]
    cols = 3
    rows = int(np.ceil(len(names) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 2.2 * rows), sharex=True, squeeze=False)
    for j, name in enumerate(names):
        ax = axes[j // cols][j % cols]
        ax.plot(series["times"], np.degrees(series["real"][:, j]), label="trace (real)")
        ax.plot(series["times"], np.degrees(series["sim"][:, j]), label="simulation", alpha=0.8)
        stats = result["joints"][name]
        lag = "-" if stats["lag_ms"] is None else f"{stats['lag_ms']:.0f} ms"
        ax.set_title(f"{name}: RMSE {stats['rmse_deg']:.1f} deg, lag {lag}", fontsize=8)
        ax.tick_params(labelsize=7)
    for k in range(len(names), rows * cols):
        axes[k // cols][k % cols].axis("off")
    axes[0][0].legend(fontsize=7)
    fig.supxlabel("time [s]")
    fig.supylabel("joint angle [deg]")
    fig.tight_layout()
    save_figure(fig, path, dpi=90)
