"""The transfer check: does a controller keep its gait on a perturbed robot behind the bus?

    python -m benchmarks.transfer CONTROLLER --reality default --runs 3 --json

Measures the controller's distance in the nominal simulation (``biped eval``, the
evolution's own episode) and in dry runs of the same length through the real runtime on
the simulated Dynamixel bus under a reality profile (``biped dry-run --reality``), one per
seed of the profile's random parts.  It passes when the mean dry-run distance keeps at
least ``--keep`` (default 80 %) of the simulated one and no dry run falls.
"""

from __future__ import annotations

import statistics
from pathlib import Path

from benchmarks.common import parser, progress, report
from evolve.replay import evaluate_controller
from sim2real.dry_run import dry_run


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("controller", type=Path)
    p.add_argument("--reality", default="default", help="reality profile (default: configs/reality/default.yaml)")
    p.add_argument("--runs", type=int, default=3, help="dry runs, seeds 0..N-1 of the profile's noise")
    p.add_argument("--keep", type=float, default=0.8, help="share of the simulated distance to keep")
    args = p.parse_args(argv)

    sim = evaluate_controller(args.controller)
    progress(f"simulation: {sim['distance_m']:.3f} m in {sim['seconds']:.1f} s, fell={sim['fell']}", args.json)
    runs = []
    for seed in range(args.runs):
        r = dry_run(args.controller, duration_s=sim["seconds"], reality=args.reality, seed=seed,
                    log=lambda line: None)
        progress(f"dry run {seed} ({args.reality}): {r['distance_m']:.3f} m, fell={r['fell']}, "
                 f"stop: {r['stop_reason']}, bus errors {r['bus_errors']}, overruns {r['overruns']}", args.json)
        runs.append({k: r[k] for k in ("distance_m", "fell", "ticks", "overruns", "bus_errors", "stop_reason")})
    mean = statistics.mean(r["distance_m"] for r in runs)
    ratio = mean / sim["distance_m"] if sim["distance_m"] > 0 else 0.0
    report({
        "controller": str(args.controller), "reality": args.reality,
        "sim_distance_m": sim["distance_m"], "sim_fell": sim["fell"], "seconds": sim["seconds"],
        "dry_run_distance_m": mean, "dry_run_min_m": min(r["distance_m"] for r in runs),
        "ratio": ratio, "keep": args.keep,
        "passed": ratio >= args.keep and not any(r["fell"] for r in runs), "runs": runs,
    }, args.json)


if __name__ == "__main__":
    main()
