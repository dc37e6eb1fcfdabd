"""Physics speed of the project's robots: box trees against robots from model files.

    python -m benchmarks.robot_models --json
    python -m benchmarks.robot_models --robots xl430_biped op3 --steps 20000

For each robot: physics steps per second of one simulation on one core (``mj_step``, CPU
time, best of ``--repeats``), standing at its home keyframe with its actuators holding home,
and after a fall (lying on the floor: more contacts); each as a ratio against the first robot
measured in the same run (the default box robot), so the machine's speed cancels.  Also the
collision geometry each model carries (geoms by type), and ``mujoco.batch``'s throughput over
16 simulations, the way evolution steps them.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np

from benchmarks.common import parser, progress, report
from sim2real.simulation.model.physique import load_measured
from sim2real.simulation.model.builder import build_model
from sim2real.simulation.model.robot_model import is_collision_geom

DEFAULT_ROBOTS = ("xl430_biped", "op3_legs", "op3")


def _cpu_rate(model: mujoco.MjModel, data: mujoco.MjData, steps: int, repeats: int) -> float:
    """Physics steps per CPU second, the best of ``repeats`` runs from the same state."""
    start = (data.qpos.copy(), data.qvel.copy(), data.act.copy(), data.time)
    best = 0.0
    for _ in range(repeats):
        data.qpos[:], data.qvel[:], data.act[:] = start[0], start[1], start[2]
        data.time = start[3]
        mujoco.mj_forward(model, data)
        t = time.process_time()
        for _ in range(steps):
            mujoco.mj_step(model, data)
        best = max(best, steps / max(time.process_time() - t, 1e-9))
    return best


def _batch_rate(model: mujoco.MjModel, steps: int) -> float:
    from mujoco.batch import Batch

    batch = Batch(model, 16, 1)
    ids = np.arange(16)
    batch.reset(ids, keyframe=0)
    t = time.process_time()
    batch.step(ids, steps // 16)
    return 16 * (steps // 16) / max(time.process_time() - t, 1e-9)


def measure(name: str, steps: int, repeats: int) -> dict:
    robot = load_measured(name)
    model = build_model(robot)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    standing = _cpu_rate(model, data, steps, repeats)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    data.ctrl[:] = 0.0
    data.qvel[0] = 1.0  # a shove, the servos at zero: it falls and lies down
    for _ in range(int(3.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    lying = _cpu_rate(model, data, steps, repeats)
    kinds = {}
    for g in range(model.ngeom):
        if is_collision_geom(model.geom_contype[g], model.geom_conaffinity[g]):
            kind = mujoco.mjtGeom(model.geom_type[g]).name.removeprefix("mjGEOM_").lower()
            kinds[kind] = kinds.get(kind, 0) + 1
    return {"joints": len(robot.joints), "mass_kg": round(robot.mass, 4), "timestep_s": model.opt.timestep,
            "collision_geoms": kinds, "steps_per_s_standing": round(standing), "steps_per_s_lying": round(lying),
            "batch16_steps_per_s": round(_batch_rate(model, steps))}


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--robots", nargs="*", default=list(DEFAULT_ROBOTS), help="robot names or YAML paths")
    p.add_argument("--steps", type=int, default=10_000, help="physics steps a measurement (default 10000)")
    p.add_argument("--repeats", type=int, default=5, help="measurements; the best counts (default 5)")
    args = p.parse_args(argv)
    results = {}
    for name in args.robots:
        progress(f"{name}...", args.json)
        results[name] = measure(name, args.steps, args.repeats)
    base = results[args.robots[0]]
    for row in results.values():
        for key in ("steps_per_s_standing", "steps_per_s_lying", "batch16_steps_per_s"):
            row[key.replace("steps_per_s", "ratio")] = round(row[key] / base[key], 3)
    report({"baseline": args.robots[0], "robots": results, "steps": args.steps, "repeats": args.repeats}, args.json)


if __name__ == "__main__":
    main()
