"""Faster physics, only if it changes nothing that matters: the physics step and the solver's
iterations against the default (2 ms, MuJoCo's 100 iterations), on one population.

    python -m benchmarks.physics_step --run runs/rwg-seed1 --json
    python -m benchmarks.physics_step --json                  # random genomes of walk.yaml's layout
    python -m benchmarks.physics_step --walker configs/controllers/xl430_biped.json --json   # a polish's

For each setting: the same genomes (a run's checkpointed population, or random ones) on the
same robots (the nominal one and ``--draws`` drawn from ``randomize.yaml``), ``--seconds``
episodes: how many went numerically unstable, the Spearman rank correlation of their fitness
with the default's (selection only needs the ranking), how many of the default's top 10 stay
in the setting's top 10, whether the same genomes walk, and physics steps per second (CPU
time) against the default's in the same run.  The control tick stays the robot's: a step is
the tick over a whole number of substeps (34 ms / 8 = 4.25 ms for the default robot).

With ``--walker`` the genomes are a CMA-ES polish's candidates instead (:mod:`evolve.polish`,
``biped train``'s polish stages): ``--updates`` updates of the polish's candidates around the
walker, each on its update's drawn robots (the walk-rate polish's population, robots and step
size by default, ``--speed`` the speed polish's, its gate at the goal's speed), the search told the default step's
ranking so later updates are a real polish's; per update, the rank correlation of the
candidates' ranking scores and how many of the default's better half (the candidates CMA-ES
recombines) stay in the setting's.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from benchmarks.common import parser, progress, report
import evolve.locomotion.evaluator as evaluator_module
from evolve.locomotion.evaluator import LocomotionEvaluator, neat_layout
from evolve.locomotion.task import TaskConfig
from evolve.neat import NeatConfig, Population
from sim2real.controller.symmetry import symmetric_layout
from sim2real.simulation.model.physique import load_measured
from sim2real.robot.timing import control_timing
from sim2real.simulation.reality.file import load_reality


def _ranks(values: np.ndarray) -> np.ndarray:
    order = np.argsort(values, kind="stable")
    ranks = np.empty(len(values))
    ranks[order] = np.arange(len(values))
    return ranks


def spearman(a: np.ndarray, b: np.ndarray) -> float:
    """Spearman's rank correlation (ties broken by order: fitness ties are rare)."""
    return float(np.corrcoef(_ranks(a), _ranks(b))[0, 1])


def _evaluator(robot, task, capacity: int, iterations: int | None) -> LocomotionEvaluator:
    """The evaluator, its model's solver iterations set before its batch is made."""
    if iterations is None:
        return LocomotionEvaluator(robot, task, capacity, threads=1, reality=load_reality("randomize"))
    built = evaluator_module.build_model

    def with_iterations(*args, **kwargs):
        model = built(*args, **kwargs)
        model.opt.iterations = iterations
        return model

    evaluator_module.build_model = with_iterations
    try:
        return LocomotionEvaluator(robot, task, capacity, threads=1, reality=load_reality("randomize"))
    finally:
        evaluator_module.build_model = built


def measure(robot, task, genomes, steepness, substeps: int, iterations: int | None, draws: int) -> dict:
    """The genomes on the nominal robot and ``draws`` drawn ones with ``substeps`` physics steps a
    control tick and ``iterations`` solver iterations (None: MuJoCo's default)."""
    tick = control_timing(robot).tick_s
    variant = dataclasses.replace(robot, physics_dt_s=tick / substeps, control_tick_s=tick)
    ev = _evaluator(variant, task, len(genomes) * max(draws, 1), iterations)
    started = time.process_time()
    nominal = ev.evaluate(genomes, steepness)
    steps = nominal.steps
    parts = [(nominal.fitness[:, None], nominal.walked(ev.leg, ev.episode_s)[:, None], nominal.unstable)]
    if draws:
        keys = np.array([[99_000, e] for _ in genomes for e in range(draws)])
        varied = ev.evaluate([g for g in genomes for _ in range(draws)], steepness, perturbation=ev.sample(keys))
        steps += varied.steps
        parts.append((varied.fitness.reshape(len(genomes), draws),
                      varied.walked(ev.leg, ev.episode_s).reshape(len(genomes), draws), varied.unstable))
    seconds = time.process_time() - started
    fitness = np.concatenate([f for f, _, _ in parts], axis=1).mean(axis=1)
    walked = np.concatenate([w for _, w, _ in parts], axis=1)
    return {"physics_dt_ms": round(1e3 * tick / substeps, 4), "substeps": substeps,
            "iterations": int(ev.model.opt.iterations), "unstable": int(sum(u.sum() for _, _, u in parts)),
            "fitness": fitness, "walked": walked, "steps_per_s": steps / max(seconds, 1e-9)}


def polish_candidates(walker: Path, speed: bool, updates: int, threads: int, log=lambda line: None) -> dict:
    """A polish's candidates (see the module docstring) at the robot's physics step (whose ranking
    the search is told) and at the step of half its substeps a tick."""
    from cmaes import CMA

    from evolve.polish import UPDATE_STREAM, WEIGHT_LIMIT, Judge, _keys, ranked_by
    from evolve.train import POLISH, SPEED, SPEED_GOAL_M_S

    stage = SPEED if speed else POLISH
    realities = stage.get("reality", "randomize")
    realities = [realities] if isinstance(realities, str) else list(realities)
    popsize, robots = stage["popsize"], stage["robots"]
    judge = Judge(walker, realities, popsize * robots, threads=threads,
                  selection={"selection_speed_leg_s": stage["speed_leg_s"]} if speed else None,
                  min_speed_m_s=SPEED_GOAL_M_S if speed else None)
    base, tick = judge.evaluator, judge.evaluator.tick_s
    default = control_timing(judge.robot).substeps
    substeps = [default, default // 2]
    evaluators = {n: LocomotionEvaluator(dataclasses.replace(judge.robot, physics_dt_s=tick / n, control_tick_s=tick),
                                         base.task, base.max_population, threads=threads, reality=base.reality)
                  for n in substeps}
    optimizer = CMA(mean=judge.start.copy(), sigma=stage["sigma"], population_size=popsize, seed=0,
                    bounds=np.tile([-WEIGHT_LIMIT, WEIGHT_LIMIT], (len(judge.start), 1)))
    rows = {n: {"cpu_s": 0.0, "steps": 0, "spearman": [], "better_half_kept": [], "walked_agree": [],
                "walk_rate": []} for n in substeps}
    for update in range(1, updates + 1):
        candidates = [optimizer.ask() for _ in range(popsize)]
        keys = _keys(0, UPDATE_STREAM, update, robots)
        ranked, walked = {}, {}
        for n in substeps:
            judge.evaluator, judge.steps = evaluators[n], 0
            started = time.process_time()
            score, walked[n], _ = judge.run(candidates, keys)
            rows[n]["cpu_s"] += time.process_time() - started
            rows[n]["steps"] += judge.steps
            ranked[n] = ranked_by(score, stage["worst"])
        first = substeps[0]
        half = set(np.argsort(-ranked[first])[:popsize // 2])
        for n in substeps:
            rows[n]["spearman"].append(spearman(ranked[first], ranked[n]))
            rows[n]["better_half_kept"].append(len(half & set(np.argsort(-ranked[n])[:popsize // 2])))
            rows[n]["walked_agree"].append(float((walked[first] == walked[n]).mean()))
            rows[n]["walk_rate"].append(float(walked[n].mean()))
        optimizer.tell([(x, -float(v)) for x, v in zip(candidates, ranked[first])])
        log(f"update {update}/{updates}: Spearman " + ", ".join(
            f"{tick / n * 1e3:.2f} ms {rows[n]['spearman'][-1]:.3f}" for n in substeps[1:]))
    out = []
    for n in substeps:
        r = rows[n]
        out.append({"physics_dt_ms": round(1e3 * tick / n, 4), "substeps": n,
                    "spearman_mean": round(float(np.mean(r["spearman"])), 4),
                    "spearman_min": round(float(np.min(r["spearman"])), 4),
                    "better_half_kept_mean": round(float(np.mean(r["better_half_kept"])), 2),
                    "walked_agree": round(float(np.mean(r["walked_agree"])), 4),
                    "walk_rate": round(float(np.mean(r["walk_rate"])), 4),
                    "cpu_s": round(r["cpu_s"], 1), "steps_per_s": round(r["steps"] / max(r["cpu_s"], 1e-9)),
                    "speed_ratio": round(rows[first]["cpu_s"] / max(r["cpu_s"], 1e-9), 3)})
    return {"walker": str(walker), "robot": judge.robot.name, "stage": "speed" if speed else "walk rate",
            "popsize": popsize, "robots": robots, "updates": updates, "reality": realities,
            "worst": stage["worst"], "settings": out}


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--run", type=Path, help="a run folder: its checkpointed population (default: random genomes)")
    p.add_argument("--genomes", type=int, default=64, help="random genomes without --run (default 64)")
    p.add_argument("--draws", type=int, default=3, help="randomized robots per genome besides the nominal one")
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--walker", type=Path, help="a walker: a CMA-ES polish's candidates around it (see above)")
    p.add_argument("--speed", action="store_true", help="with --walker: the speed polish's settings")
    p.add_argument("--updates", type=int, default=8, help="with --walker: polish updates (default 8)")
    p.add_argument("--threads", type=int, default=1, help="with --walker: simulation threads (default 1)")
    args = p.parse_args(argv)
    if args.walker:
        report(polish_candidates(args.walker, args.speed, args.updates, args.threads,
                                 lambda line: progress(line, args.json)), args.json)
        return
    if args.run:
        from evolve.config import load_evolve_config

        config = load_evolve_config(args.run / "config.yaml")
        robot, task, steepness = load_measured(config.robot), config.task, config.neat.sigmoid_steepness
        genomes = Population.load(args.run / "checkpoint.json.gz").genomes
    else:
        robot, task, steepness = load_measured(), TaskConfig(), NeatConfig().sigmoid_steepness
        layout = neat_layout(symmetric_layout(robot, robot.control_sets[task.control_set], task.inputs))
        genomes = Population(NeatConfig(population_size=args.genomes), layout, seed=7).genomes
    task = dataclasses.replace(task, episode_s=args.seconds)
    base_substeps = control_timing(robot).substeps
    settings = [(base_substeps, None), (base_substeps // 2, None), (base_substeps, 50), (base_substeps // 2, 50),
                (base_substeps, 20)]
    results = []
    for substeps, iterations in settings:
        progress(f"{substeps} substeps a tick, {iterations or 'default'} iterations...", args.json)
        results.append(measure(robot, task, genomes, steepness, substeps, iterations, args.draws))
    base = results[0]
    top = set(np.argsort(-base["fitness"])[:10])
    rows = []
    for r in results:
        rows.append({k: r[k] for k in ("physics_dt_ms", "substeps", "iterations", "unstable")} | {
            "spearman_fitness": round(spearman(base["fitness"], r["fitness"]), 4),
            "top10_kept": len(top & set(np.argsort(-r["fitness"])[:10])),
            "walked_agree": float((base["walked"] == r["walked"]).mean()),
            "walks": int(r["walked"].sum()),
            "steps_per_s": round(r["steps_per_s"]), "speed_ratio": round(r["steps_per_s"] / base["steps_per_s"], 3),
            "ticks_per_s_ratio": round((r["steps_per_s"] / r["substeps"]) / (base["steps_per_s"] / base["substeps"]), 3)})
    report({"robot": robot.name, "genomes": len(genomes), "draws": args.draws, "seconds": args.seconds,
            "source": str(args.run) if args.run else "random genomes", "settings": rows}, args.json)


if __name__ == "__main__":
    main()
