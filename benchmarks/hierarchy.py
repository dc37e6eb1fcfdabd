"""Developmental hierarchy against a single module (seed 002 table 5.1: standing took 36
generations on top of posing, 803 without).

    python -m benchmarks.hierarchy --seeds 5 --json

For each seed, ``configs/evolve/stand.yaml`` (pose -> stand) and
``configs/evolve/stand_baseline.yaml`` (stand from scratch) run until the stand threshold
or their budgets.  ``generations`` of the hierarchy is its stand stage's, as the thesis
counts them; ``total_generations`` and ``wall_s`` include its pose stage.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

from benchmarks.common import parser, progress, report
from evolve.config import config_path
from evolve.config import load_evolve_config
from evolve.run import Run
from sim2real.atomic_json import read_json
from sim2real.errors import UsageError


def staged_run(config_name: str, seed: int, out: Path, threads: int | None, quiet: bool) -> dict:
    """One staged run to its end, in ``out``: continued from its checkpoint if one is there,
    read back if it has ended (benchmarks of hours survive a stop)."""
    config = load_evolve_config(config_path(config_name)).replace(seed=seed)
    if threads is not None:
        config = config.replace(threads=threads)
    log = lambda line: progress(line, quiet)  # noqa: E731
    done = out / "stages.json"
    start = time.perf_counter()
    if done.exists() and len(read_json(done)) == len(config.stages):
        wall = read_json(done)[-1]["wall_s"]
    else:
        if (out / "checkpoint.json.gz").exists():
            saved = load_evolve_config(out / "config.yaml")
            if saved.replace(threads=config.threads) != config:
                raise UsageError(f"{out} holds another run than {config_name} seed {seed}: give another --out")
            run = Run.resume(out, threads=threads, log=log)
        else:
            run = Run.create(config, out, log=log)
        before = run.wall_s
        run.evolve()
        wall = before + time.perf_counter() - start
    stages = read_json(done)  # every stage, as it ended
    last = stages[-1]
    return {"seed": seed, "solved": last["solved"], "generations": last["generations"],
            "total_generations": sum(s["generations"] for s in stages), "stages": stages, "wall_s": wall,
            "best_fitness": last["best_fitness"], "max_fitness": last["max_fitness"]}


def summary(results: list[dict]) -> dict:
    solved = [r for r in results if r["solved"]]
    return {
        "solved": len(solved), "runs": len(results),
        "median_generations": statistics.median(r["generations"] for r in results),
        "median_total_generations": statistics.median(r["total_generations"] for r in results),
        "median_wall_s": statistics.median(r["wall_s"] for r in results),
        "per_seed": results,
    }


def pair_parser(description: str, hierarchy: str, baseline: str):
    """The command line of a hierarchy-against-baseline benchmark (this one, benchmarks.reach)."""
    p = parser(description)
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--first-seed", type=int, default=1)
    p.add_argument("--threads", type=int, help="simulation threads (default: the configs')")
    p.add_argument("--hierarchy", default=hierarchy, help=f"staged config (default: {hierarchy})")
    p.add_argument("--baseline", default=baseline, help=f"single-module config (default: {baseline})")
    p.add_argument("--out", type=Path, help="keep the runs here and continue them after a stop (default: a "
                   "temporary folder)")
    return p


def run_pairs(args, prefix: str) -> tuple[Path, dict[str, list]]:
    """Each seed's staged run, then each seed's baseline run (in ``--out`` or a temporary
    folder): the hierarchy's, which take minutes, before the baselines', which take hours."""
    root = args.out or Path(tempfile.mkdtemp(prefix=prefix))
    results: dict[str, list] = {"hierarchy": [], "baseline": []}
    for kind, name in (("hierarchy", args.hierarchy), ("baseline", args.baseline)):
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            r = staged_run(name, seed, root / f"{kind}-seed{seed}", args.threads, args.json)
            progress(f"{kind} seed {seed}: solved={r['solved']} generations={r['generations']} "
                     f"(total {r['total_generations']}) in {r['wall_s'] / 60:.1f} min", args.json)
            results[kind].append(r)
    return root, results


def main(argv=None) -> None:
    args = pair_parser(__doc__.splitlines()[0], "stand", "stand_baseline").parse_args(argv)
    root, results = run_pairs(args, "hierarchy-bench-")
    report({"seeds": args.seeds, "hierarchy": summary(results["hierarchy"]),
            "baseline": summary(results["baseline"]), "thesis": {"hierarchy_generations": 36, "baseline_generations": 803},
            "runs_dir": str(root)}, args.json)


if __name__ == "__main__":
    main()
