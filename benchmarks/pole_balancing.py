"""Double pole balancing with NEAT, with and without velocities (Stanley & Miikkulainen 2002).

    python -m benchmarks.pole_balancing --variant velocities --runs 50 --json
    python -m benchmarks.pole_balancing --variant no-velocities --runs 50 --workers 2 --json

``velocities`` (Markovian): the network sees all six state variables; fitness is the number
of control steps balanced; solved when a network balances 100,000 steps (30 minutes of
simulated time).  ``no-velocities``: only the cart position and the two angles, so the
network must be recurrent; fitness is Gruau's (0.1 t/1000 + 0.9 * 0.75 / wiggle over the
last 100 of 1,000 steps); each generation's champion is then tried for 100,000 steps and,
if it holds, on the 625 generalization start states (solved at >= 200 of them balanced for
1,000 steps).  Costs are networks evaluated.  The paper: 3,600 and 33,184 evaluations.
"""

from __future__ import annotations

import time
from functools import partial

import numpy as np

from benchmarks import double_pole as dp
from benchmarks.common import map_runs, parser, progress, report
from evolve.neat import (
    Layout,
    NeatConfig,
    Population,
    PopulationNetwork,
    RecurrentNetwork,
)
from evolve.neat.genome import Genome

SUCCESS_STEPS = 100_000
FEW = 4  # survivors continued one by one
GRUAU_STEPS = 1_000
PAPER = {"velocities": 3600, "no-velocities": 33184}
BASE = dict(target_species=15, compat_exponent=0.0, sigmoid_steepness=4.9, weight_sigma=1.5,
            weight_replace_range=2.0, weight_mutate_prob=0.8, add_link_prob=0.2,
            stagnation_generations=15, interspecies_mate_rate=0.001)
VARIANTS = {  # population and generation budget as in the paper's setups
    "velocities": dict(config=NeatConfig(population_size=150, **BASE), generations=200, layout=Layout(6, 1, 1)),
    "no-velocities": dict(config=NeatConfig(population_size=1000, **{**BASE, "target_species": 30}),
                          generations=100, layout=Layout(3, 1, 1)),
}


def balance(genomes: list[Genome], steepness: float, velocities: bool, max_steps: int,
            starts: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Steps each network balances (<= max_steps), and Gruau's wiggle over its last 100 steps.

    All carts run at once; finished ones leave the arrays, and the last few survivors (or a
    few carts from the start, such as a champion's 100,000-step test) continue one by one in
    plain floats: numpy's per-call overhead would dominate such a tail ~10 times over.
    """
    n = len(genomes)
    state = dp.start_states(n) if starts is None else starts.copy()
    net = PopulationNetwork(genomes, steepness)
    alive = np.arange(n)
    steps = np.zeros(n, dtype=np.int64)
    wiggle = np.zeros((100, n))
    if n <= FEW:
        for i in range(n):
            _finish_alone(genomes[i], net.state_of(i), state[i], velocities, steepness, 0, max_steps,
                          steps, wiggle, i)
        return steps, wiggle.sum(axis=0)
    for t in range(max_steps):
        out = net.activate(dp.observe(state, velocities))[:, 0]
        state = dp.control_step(state, out)
        down = dp.failed(state)
        wiggle[t % 100, alive] = np.abs(state[:, [0, 1, 2, 3]]).sum(axis=1)
        steps[alive[~down]] += 1
        if down.any():
            alive, state = alive[~down], state[~down]
            if not len(alive):
                break
            net.keep(np.flatnonzero(~down))
            if len(alive) <= FEW:
                for j, i in enumerate(alive):
                    _finish_alone(genomes[i], net.state_of(j), state[j], velocities, steepness,
                                  t + 1, max_steps, steps, wiggle, int(i))
                break
    return steps, wiggle.sum(axis=0)


def _finish_alone(genome, node_values, state, velocities, steepness, start, max_steps, steps, wiggle, i):
    """Continue one cart and its network (state carried over) with Python floats."""
    solo = RecurrentNetwork(genome, steepness)
    solo.values = dict(zip(solo.nodes, node_values.tolist()))
    scale = [4.8, 2.0, 0.52, 2.0, 0.52, 2.0]
    s = state.tolist()
    for t in range(start, max_steps):
        obs = [v / k for v, k in zip(s, scale)] if velocities else [s[0] / 4.8, s[2] / 0.52, s[4] / 0.52]
        s = dp.control_step_scalar(s, solo.activate(obs)[0])
        wiggle[t % 100, i] = abs(s[0]) + abs(s[1]) + abs(s[2]) + abs(s[3])
        if dp.failed_scalar(s):
            return
        steps[i] += 1


def gruau_fitness(steps: np.ndarray, wiggle: np.ndarray) -> np.ndarray:
    f1 = steps / GRUAU_STEPS
    f2 = np.where(steps < 100, 0.0, 0.75 / np.maximum(wiggle, 1e-9))
    return 0.1 * f1 + 0.9 * f2


def generalization(genome: Genome, steepness: float) -> int:
    """How many of the 625 start states the network balances for 1,000 steps."""
    starts = dp.generalization_starts()
    steps, _ = balance([genome] * len(starts), steepness, False, GRUAU_STEPS, starts)
    return int((steps >= GRUAU_STEPS).sum())


def run(variant: str, seed: int) -> dict:
    spec = VARIANTS[variant]
    config: NeatConfig = spec["config"]
    pop = Population(config, spec["layout"], seed=seed)
    s = config.sigmoid_steepness
    found: dict = {}

    def markov(genomes):
        steps, _ = balance(genomes, s, True, SUCCESS_STEPS)
        if (steps >= SUCCESS_STEPS).any() and not found:
            k = int(np.flatnonzero(steps >= SUCCESS_STEPS)[0])
            found.update(evaluations=pop.evaluations + k + 1, hidden=len(genomes[k].hidden))
        return steps.astype(float)

    def non_markov(genomes):
        steps, wiggle = balance(genomes, s, False, GRUAU_STEPS)
        fitness = gruau_fitness(steps, wiggle)
        champion = genomes[int(np.argmax(fitness))]
        long_run, _ = balance([champion], s, False, SUCCESS_STEPS)
        if long_run[0] >= SUCCESS_STEPS:
            score = generalization(champion, s)
            if score >= 200 and not found:
                found.update(evaluations=pop.evaluations + len(genomes), hidden=len(champion.hidden),
                             generalization=score)
        return fitness

    evaluate = markov if variant == "velocities" else non_markov
    for _ in range(spec["generations"]):
        pop.evaluate(evaluate)
        if found:
            return found
        pop.reproduce()
    return {}


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--variant", choices=sorted(VARIANTS), required=True)
    p.add_argument("--runs", type=int, default=50)
    p.add_argument("--seed", type=int, default=0, help="seed of the first run (run i uses seed + i)")
    p.add_argument("--workers", type=int, default=1,
                   help="runs in parallel processes (results do not depend on it)")
    args = p.parse_args(argv)

    t0 = time.perf_counter()
    done = []

    def report_run(i: int, result: dict, seconds: float) -> None:
        done.append(i)
        progress(f"run {i + 1}/{args.runs} ({len(done)} done): {result or 'failed'} ({seconds:.1f} s)",
                 args.json)

    results = map_runs(partial(run, args.variant), [args.seed + i for i in range(args.runs)],
                       args.workers, report_run)
    solved = [r for r in results if r]
    evals = [r["evaluations"] for r in solved]
    result = {
        "task": f"double_pole_{args.variant.replace('-', '_')}",
        "runs": args.runs,
        "mean_evaluations": float(np.mean(evals)) if evals else None,
        "median_evaluations": float(np.median(evals)) if evals else None,
        "failures": args.runs - len(solved),
        "mean_hidden_nodes": float(np.mean([r["hidden"] for r in solved])) if solved else None,
        "wall_s": round(time.perf_counter() - t0, 2),
        "population": VARIANTS[args.variant]["config"].population_size,
        "max_generations": VARIANTS[args.variant]["generations"],
        "paper": {"mean_evaluations": PAPER[args.variant]},
    }
    if args.variant == "no-velocities":
        result["mean_generalization"] = float(np.mean([r["generalization"] for r in solved])) if solved else None
    report(result, args.json)


if __name__ == "__main__":
    main()
