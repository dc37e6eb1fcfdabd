"""What a generation of seed 000's human costs, and what a larger physics step changes.

    python -m benchmarks.human_generation --json
    python -m benchmarks.human_generation --dts 0.002 0.005 --controller human_walker.json --json

For each physics step in ``--dts`` (the first is the reference), ``walk_human.yaml``
(population 512, the harness on: every episode runs its full 10 s, the expensive case)
evolves ``--generations`` generations from the same seed on one thread: seconds a
generation and physics steps a second.  Then fidelity: one set of genomes (the reference
run's last population) is scored at every step, with the harness and without it, and
compared with the reference: the rank correlation of their fitness, the mean change of their
distance, and how many of the reference's top tenth stay in the top tenth.  With
``--controller`` (a human walker), its 10 s walk at every step: distance, time upright and the
joint angles' RMSE against the reference's.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import yaml

from benchmarks.common import parser, progress, report
from evolve.config import config_path
from evolve.config import load_evolve_config
from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.run import Run
from evolve.run_stats import read_stats
from sim2real.robot import load_robot
from sim2real.robot.paths import data_root
from sim2real.robot.validation import load_yaml


def robot_with_step(folder: Path, dt: float, preset: str) -> str:
    """The human character with physics step ``dt`` [s]: a copy of its config beside."""
    doc = load_yaml(data_root() / "configs" / "robots" / "human.yaml")  # the one bounded reader of YAML
    doc["physics_dt_s"] = dt
    path = folder / f"human_dt{dt * 1e3:g}ms.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return f"{path}:{preset}"


def ranks(values: np.ndarray) -> np.ndarray:
    order = np.argsort(values, kind="stable")
    out = np.empty(len(values))
    out[order] = np.arange(len(values))
    return out


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--dts", nargs="+", type=float, default=[0.002, 0.005, 0.007, 0.01],
                   help="physics steps [s], the first the reference (default 0.002 0.005 0.007 0.01)")
    p.add_argument("--generations", type=int, default=4, help="generations timed at each step (default 4)")
    p.add_argument("--preset", default="female_50")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--controller", type=Path, help="a human walker to replay at every step")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="human-generation-"))
    base = load_evolve_config(config_path("walk_human"))
    steps, genomes, reference = [], None, {}
    for dt in args.dts:
        robot = robot_with_step(work, dt, args.preset)
        config = base.replace(robot=robot, seed=args.seed, generations=args.generations, threads=1)
        run = Run.create(config, work / f"run_dt{dt * 1e3:g}", log=lambda line: progress(line, args.quiet))
        run.evolve()
        rows = read_stats(run.out / "stats.csv")
        timed = rows[1:] or rows  # the first generation also builds the model and warms up
        gen_s = [float(b["wall_s"]) - float(a["wall_s"]) for a, b in zip(rows, rows[1:])] or [float(rows[0]["wall_s"])]
        entry = {"dt_s": dt, "substeps": run.evaluator.substeps, "seconds_per_generation": float(np.mean(gen_s)),
                 "steps_per_s": float(np.mean([float(r["steps_per_s"]) for r in timed])),
                 "best_fitness_last": float(rows[-1]["best_fitness"])}
        if genomes is None:
            genomes = run.population.genomes  # the reference's genomes, scored at every step below
        spec = load_robot(robot)
        evaluator = LocomotionEvaluator(spec, config.task, len(genomes), threads=1)
        for harness in (1.0, 0.0):
            e = evaluator.evaluate(genomes, config.neat.sigmoid_steepness, harness=harness)
            key = "harness" if harness else "free"
            if dt == args.dts[0]:
                reference[key] = e
            ref = reference[key]
            top = int(max(1, len(genomes) // 10))
            ref_top = set(np.argsort(-ref.fitness)[:top])
            entry[key] = {
                "rank_correlation": float(np.corrcoef(ranks(ref.fitness), ranks(e.fitness))[0, 1]),
                "mean_abs_distance_change_m": float(np.mean(np.abs(e.distance_m - ref.distance_m))),
                "mean_fitness": float(e.fitness.mean()), "falls": int(e.fell.sum()),
                "top_tenth_kept": len(ref_top & set(np.argsort(-e.fitness)[:top])) / top,
            }
        if args.controller is not None:
            from evolve.replay import gait

            g = gait(args.controller, robot=robot)
            if dt == args.dts[0]:
                reference["gait"] = g
            ref_g = reference["gait"]
            n = min(len(g.times_s), len(ref_g.times_s))
            entry["walker"] = {"upright_s": float(g.times_s[-1]) if g.fell_s is None else g.fell_s,
                               "angle_rmse_deg": float(np.degrees(np.sqrt(np.mean(
                                   (g.angles_rad[:n] - ref_g.angles_rad[:n]) ** 2))))}
        steps.append(entry)
        progress(f"dt {dt * 1e3:g} ms: {entry['seconds_per_generation']:.1f} s a generation, "
                 f"{entry['steps_per_s'] / 1e3:.0f}k steps/s", args.quiet)
    first = steps[0]
    for entry in steps:
        entry["speedup"] = first["seconds_per_generation"] / entry["seconds_per_generation"]
    report({"preset": args.preset, "population": base.neat.population_size, "generations": args.generations,
            "steps": steps}, args.json)


if __name__ == "__main__":
    main()
