"""Evaluation throughput: physics steps a second during evolution against bare batch stepping.

    python -m benchmarks.throughput --json

Same model (the default robot), same population, same threads, one process: first bare
``mujoco.batch`` stepping of every simulation with zero controls, one control tick a call;
then real evolution generations (networks, sensors, mapping, fitness, termination and the
support harness included), counting the physics steps actually simulated.  Goal: ratio >= 0.9.
With ``--reality`` (a reality file's name or path) every simulation is perturbed by its own
draw, as in randomized evolution, and the model is the one that reality needs (with backlash
joints if it draws backlash).
"""

from __future__ import annotations

import time

from benchmarks.common import parser, progress, report
from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.task import TaskConfig
from evolve.neat import NeatConfig, Population
from sim2real.simulation.model.physique import load_measured
from sim2real.simulation.reality.file import load_reality
from sim2real.simulation.reality.randomize import needs_backlash_joints


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--robot", default="xl430_biped")
    p.add_argument("--population", type=int, default=128)
    p.add_argument("--threads", type=int, default=0, help="0: every core")
    p.add_argument("--generations", type=int, default=4)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--reality", default="nominal", help="perturb each simulation by a draw of this reality file")
    args = p.parse_args(argv)

    robot = load_measured(args.robot)
    task = TaskConfig()
    reality = load_reality(args.reality)
    evaluator = LocomotionEvaluator(robot, task, args.population, args.threads, reality=reality)
    batch, n = evaluator.batch, args.population

    ticks = 100
    batch.reset(None, keyframe=0)
    batch.ctrl[:] = 0.0
    batch.step(None, evaluator.substeps)  # warm up
    t0 = time.perf_counter()
    for _ in range(ticks):
        batch.step(None, evaluator.substeps)
    bare = n * ticks * evaluator.substeps / (time.perf_counter() - t0)
    progress(f"bare stepping: {bare:,.0f} steps/s", args.json)

    config = NeatConfig(population_size=n, target_species=max(1, n // 10), compat_threshold=0.6)
    pop = Population(config, evaluator.neat_layout, seed=args.seed)
    steps, eval_s, ga_s = 0, 0.0, 0.0
    for generation in range(args.generations):
        t0 = time.perf_counter()
        holder = {}

        def evaluate(genomes):
            keys = [[args.seed, generation, i] for i in range(len(genomes))]
            perturbation = None if reality.is_nominal else evaluator.sample(keys)
            holder["e"] = evaluator.evaluate(genomes, config.sigmoid_steepness, harness=1.0, perturbation=perturbation)
            return holder["e"].selection

        pop.evaluate(evaluate)
        t1 = time.perf_counter()
        pop.reproduce()
        eval_s += t1 - t0
        ga_s += time.perf_counter() - t1
        steps += holder["e"].steps
    evolution = steps / eval_s
    progress(f"evolution: {evolution:,.0f} steps/s", args.json)
    report({
        "robot": robot.name,
        "reality": reality.name,
        "backlash_joints": needs_backlash_joints(reality),
        "population": n,
        "threads": batch.nthread,
        "substeps_per_tick": evaluator.substeps,
        "steps_per_s_evolution": evolution,
        "steps_per_s_bare": bare,
        "ratio": evolution / bare,
        "steps_per_s_with_ga": steps / (eval_s + ga_s),
        "ga_s_per_generation": ga_s / args.generations,
        "generations": args.generations,
    }, args.json)


if __name__ == "__main__":
    main()
