"""The transfer check: does a controller keep its gait on a perturbed robot behind the bus?

    python -m benchmarks.transfer CONTROLLER --reality default --runs 3 --json
    python -m benchmarks.transfer --select-from runs/robust --reality default --json
    python -m benchmarks.transfer CONTROLLER --parts --reality default --json

Measures the controller's distance in the nominal simulation (``biped eval``, the
evolution's own episode) and in dry runs of the same length through the real runtime on
the simulated Dynamixel bus under a reality profile (``biped dry-run --reality``), one per
seed of the profile's random parts.  It passes when the controller walks in simulation
(upright, 2.2 leg lengths), the mean dry-run distance keeps at least ``--keep`` (default
80 %) of the simulated one and no dry run falls.

``--select-from RUN`` first picks the controller from an evolution run's last population:
every genome is replayed on the nominal robot and on ``--episodes`` randomized ones, and the
one that walks (upright, 2.2 leg lengths) in the most of them wins, ties broken by its
worst distance; it is saved as ``RUN/robust_walker.json``.

``--parts`` asks where a walker's distance goes on a fixed profile: its distance in
``--seconds`` walks (no stagnation stop; one on the model, ``--episodes`` on the profile) with
each of the profile's keys alone, and with all but it - in simulation, without the bus.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.common import parser, progress, report
from evolve.champion import Best
from evolve.evaluation import EvaluatorSpec, build_evaluator
from evolve.neat import Population
from evolve.run import Run
from evolve.transfer import transfer_check


def select_robust(run_dir: Path, episodes: int, ranges: str = "randomize") -> tuple[Path, dict]:
    """The genome of ``run_dir``'s last population that walks on the most robots (see above)."""
    run = Run.resume(run_dir, log=lambda line: None)
    pop = Population.load(run_dir / "checkpoint.json.gz")
    genomes = pop.genomes
    n = len(genomes)
    config = run.config
    evaluator = build_evaluator(EvaluatorSpec(config.robot, config.task.to_dict(), ranges, n * episodes, 0))
    nominal = evaluator.evaluate(genomes, config.neat.sigmoid_steepness)
    keys = np.array([[10_000 + i, e] for i in range(n) for e in range(episodes)])
    sims = [g for g in genomes for _ in range(episodes)]
    varied = evaluator.evaluate(sims, config.neat.sigmoid_steepness, perturbation=evaluator.sample(keys))
    leg, seconds = run.robot.leg_length, evaluator.episode_s
    share = (nominal.walked(leg, seconds)[:, None].astype(float)
             + varied.walked(leg, seconds).reshape(n, episodes).sum(axis=1, keepdims=True)) / (episodes + 1)
    worst = np.minimum(nominal.distance_m, varied.distance_m.reshape(n, episodes).min(axis=1))
    best = int(np.lexsort((worst, share[:, 0]))[-1])
    genome = genomes[best]
    path = run_dir / "robust_walker.json"
    run.controller(Best(float(nominal.fitness[best]), float(nominal.distance_m[best]),
                        float(nominal.upright_s[best]), pop.generation, 0.0, genome)).save(path)
    return path, {"genome": genome.key, "walks_share": float(share[best, 0]), "worst_distance_m": float(worst[best]),
                  "population_walks_share_mean": float(share.mean()), "selected_from": n, "episodes": episodes + 1}


def profile_parts(controller: Path, reality: str, seconds: float, episodes: int, quiet: bool = False) -> dict:
    """The controller's distance [m] on the model, on ``reality``, and with each of its keys
    alone and all but it (see the module docstring); a key's share is the distance it keeps."""
    from evolve.replay import evaluate_controller
    from sim2real.robot.validation import load_yaml
    from sim2real.simulation.reality.file import load_reality, reality_path

    load_reality(reality)  # a clear error for an unknown or bad profile
    profile = {k: v for k, v in load_yaml(reality_path(reality)).items() if k != "description"}

    def distance(ranges: dict | None) -> float:
        r = evaluate_controller(controller, seconds=seconds, episodes=episodes if ranges is not None else 1,
                                randomize=ranges, seed=314_159, stagnation_stop=False)
        return r["distance_m"]

    model = distance(None)
    parts = {key: {"alone": distance({key: value}), "all_but": distance({k: v for k, v in profile.items() if k != key})}
             for key, value in profile.items()}
    for key, part in parts.items():
        progress(f"{key}: {part['alone']:.2f} m alone, {part['all_but']:.2f} m with all but it", quiet)
    return {"controller": str(controller), "reality": reality, "seconds": seconds, "episodes": episodes,
            "model_m": model, "profile_m": distance(profile),
            "parts": {k: {**v, "alone_keeps": v["alone"] / model} for k, v in parts.items()}}


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("controller", type=Path, nargs="?", help="controller JSON (or --select-from)")
    p.add_argument("--select-from", type=Path, metavar="RUN", help="pick the most robust walker of a run's population")
    p.add_argument("--episodes", type=int, default=8, help="randomized episodes per genome for --select-from")
    p.add_argument("--reality", default="default", help="reality profile (default: configs/reality/default.yaml)")
    p.add_argument("--runs", type=int, default=3, help="dry runs, seeds 0..N-1 of the profile's noise")
    p.add_argument("--keep", type=float, default=0.8, help="share of the simulated distance to keep")
    p.add_argument("--parts", action="store_true", help="the distance each of the profile's keys costs (no bus)")
    p.add_argument("--seconds", type=float, default=30.0, help="the walks' length for --parts [s]")
    args = p.parse_args(argv)
    if args.parts:
        if args.controller is None:
            p.error("--parts needs a CONTROLLER")
        report(profile_parts(args.controller, args.reality, args.seconds, args.episodes, args.json), args.json)
        return
    selection = None
    if args.select_from:
        args.controller, selection = select_robust(args.select_from, args.episodes)
        progress(f"selected {args.controller}: {selection}", args.json)
    elif args.controller is None:
        p.error("give a CONTROLLER or --select-from RUN")

    result = transfer_check(args.controller, args.reality, args.runs, args.keep, lambda line: progress(line, args.json))
    report({**result, "selection": selection}, args.json)

if __name__ == "__main__":
    main()
