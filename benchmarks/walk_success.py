"""Success rate of independent walking runs on the default robot (seed 000: 28 of 30).

    python -m benchmarks.walk_success --seeds 10 --minutes 20 --out runs/walk-success --json
    python -m benchmarks.walk_success --seeds 10 --generations 130 --minutes 60 --out runs/ws --json  # shared machine
    python -m benchmarks.walk_success --seeds 10 --out runs/walk-success --randomize-episodes 20 --json

Each seed is one ``benchmarks.walk`` run (first walker or the budget).  With ``--out`` every
seed's folder and ``result.json`` are kept, and seeds already done there are not run again,
so a second call can add the randomized check: every walker replayed on
``--randomize-episodes`` randomized episodes (``biped eval --randomize``); it "still walks"
when it covers 2.2 leg lengths upright in at least ``--still-walks`` of them.
"""

from __future__ import annotations

import statistics
import tempfile
from pathlib import Path

from benchmarks.common import parser, progress, report
from benchmarks.walk import WALK_LEG_LENGTHS, walk_once
from sim2real.atomic_json import read_json, write_json_atomic


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=10, help="independent runs, seeds 1..N")
    p.add_argument("--first-seed", type=int, default=1)
    p.add_argument("--minutes", type=float, default=20.0, help="wall-time budget per run")
    p.add_argument("--generations", type=int, help="generation budget per run as well")
    p.add_argument("--config", default="walk")
    p.add_argument("--threads", type=int, help="simulation threads (default: the config's)")
    p.add_argument("--out", type=Path, help="keep every run here; seeds done there are reused")
    p.add_argument("--randomize-episodes", type=int, default=0,
                   help="also replay every walker on this many randomized episodes")
    p.add_argument("--reality", default="randomize", help="randomization config for that check")
    p.add_argument("--still-walks", type=float, default=0.5,
                   help="share of randomized episodes a walker must walk in to count")
    args = p.parse_args(argv)
    out = args.out or Path(tempfile.mkdtemp(prefix="walk-success-"))
    results = []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        folder = out / f"seed{seed}"
        if (folder / "result.json").exists():
            result = read_json(folder / "result.json")
        else:
            if folder.exists():  # an interrupted run: start it again
                import shutil

                shutil.rmtree(folder)
            progress(f"seed {seed}: evolving (budget {args.minutes:.0f} min)", args.json)
            result = walk_once(args.config, seed, args.minutes, folder, args.threads, quiet=True,
                               generations=args.generations)
            write_json_atomic(folder / "result.json", result)
        progress(f"seed {seed}: walked={result['walked']} minutes={result['minutes_to_walk']}", args.json)
        results.append(result)

    walked = [r for r in results if r["walked"]]
    summary = {
        "seeds": len(results),
        "walked": len(walked),
        "rate": len(walked) / len(results) if results else 0.0,
        "median_minutes_to_walk": statistics.median(r["minutes_to_walk"] for r in walked) if walked else None,
        "minutes_budget": args.minutes,
        "generations_budget": args.generations,
        "median_generations_to_walk": statistics.median(r["walk_generation"] + 1 for r in walked) if walked else None,
        "per_seed": [{k: r[k] for k in ("seed", "walked", "minutes_to_walk", "best_distance_m", "walk_generation")}
                     for r in results],
        "out": str(out),
    }
    if args.randomize_episodes:
        from evolve.replay import evaluate_controller

        still = []
        for r in walked:
            rep = evaluate_controller(Path(r["run_dir"]) / "walker.json", episodes=args.randomize_episodes,
                                      randomize=args.reality, seed=r["seed"])
            share = rep["walked_share"]
            progress(f"seed {r['seed']}: walks in {share:.0%} of {args.randomize_episodes} randomized episodes "
                     f"(mean {rep['distance_m']:.3f} m, min {rep['min_distance_m']:.3f} m)", args.json)
            still.append({"seed": r["seed"], "walked_share": share, "mean_distance_m": rep["distance_m"],
                          "min_distance_m": rep["min_distance_m"], "falls": rep["falls"]})
        summary["randomized"] = {
            "episodes": args.randomize_episodes, "reality": args.reality,
            "still_walk": sum(s["walked_share"] >= args.still_walks for s in still),
            "of_walkers": len(still), "per_seed": still,
            "required_leg_lengths": WALK_LEG_LENGTHS,
        }
    report(summary, args.json)


if __name__ == "__main__":
    main()
