"""``biped train`` timed end to end over seeds, and the walkers it makes measured.

    python -m benchmarks.robust_walk --robot xl430_biped --seeds 5 --minutes 60 --threads 2 --out runs/train-bench --json
    python -m benchmarks.robust_walk --measure CONTROLLER [--ship configs/controllers/xl430_biped.json] --json

Per seed, one ``biped train ROBOT --seed S`` (:func:`evolve.train.train`) into ``OUT/seedS``, from
nothing to its final walker: its minutes are the training's own, every stage and the measuring
counted (wall minutes, and CPU minutes of this process's threads and the dry runs' simulated
bus).  A cut seed resumes (``--resume``) where it stopped; a finished one is read back, so a
record comes from one training per seed.  The summary gives each seed's measures (walk rate on
50 unseen robots, 60 s walks on the nominal and ``default.yaml`` robots, the transfer check
through the simulated bus, the 90 deg turn), whether it met the bar, and the medians.
Run it with nothing else on the machine: the minutes are the point.

``--measure CONTROLLER`` measures a controller the same way without training (the robustness
test too); ``--ship FILE`` writes it - or the best trained walker - with the command and its
measures in its provenance.
"""

from __future__ import annotations

import statistics
import tempfile
from pathlib import Path
from typing import Any

from benchmarks.common import command_line, parser, progress, report
from evolve.train import CONTROLLER, STATE, TrainSettings, train
from evolve.walk_measures import heading_deg_per_min, is_robust, kept, measure_walker, meets_bar, robustness
from sim2real.arg_types import int_within, positive_float_at_most
from sim2real.atomic_json import read_json
from sim2real.controller.file import Controller


def seed_record(folder: Path) -> dict[str, Any]:
    """One finished training's numbers, from its ``train.json``."""
    state = read_json(folder / STATE)
    measure = state["stages"]["measure"]
    m = measure["measures"]
    return {
        "seed": state["settings"]["seed"], "folder": str(folder), "controller": str(folder / CONTROLLER),
        "wall_minutes": state["elapsed_s"] / 60.0,
        # every session's CPU, every stage and the measuring (a training from before cpu_s: its stages')
        "cpu_minutes": state["cpu_s"] / 60.0 if "cpu_s" in state else sum(
            stage["cpu_minutes"] for stage in state["stages"].values()),
        "stage_minutes": {name: round(stage["wall_minutes"], 2) for name, stage in state["stages"].items()},
        "neat_robust": state["stages"]["neat"]["robust"], "neat_generations": state["stages"]["neat"]["generations"],
        "walk_rate": m["rate"]["share"], "transfer": kept(measure["transfer"]),
        "transfer_passed": measure["transfer"]["passed"],
        "speed_m_s": {k: s["speed_m_s"] for k, s in m["sustained"].items()},
        "falls_60s": {k: s["falls"] for k, s in m["sustained"].items()},
        "heading_deg_per_min": heading_deg_per_min(m),
        "turn_reached": bool((m.get("steering") or {}).get("reached")),
        "bar": measure["bar"], "met_bar": all(measure["bar"].values()),
    }


def summary(runs: list[dict[str, Any]]) -> dict[str, Any]:
    def median(values):
        values = [v for v in values if v is not None]
        return statistics.median(values) if values else None

    return {
        "seeds": len(runs), "met_bar": sum(r["met_bar"] for r in runs),
        "wall_minutes_median": median(r["wall_minutes"] for r in runs),
        "cpu_minutes_median": median(r["cpu_minutes"] for r in runs),
        "walk_rate_median": median(r["walk_rate"] for r in runs),
        "transfer_median": median(r["transfer"] for r in runs),
        "speed_m_s_median": median(min(r["speed_m_s"].values()) for r in runs),
        "heading_deg_per_min_median": median(r["heading_deg_per_min"] for r in runs),
        "turn_reached": sum(r["turn_reached"] for r in runs),
        "runs": runs,
    }


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--robot", default="xl430_biped", help="robot to train (default xl430_biped)")
    p.add_argument("--seeds", type=int_within(1, 1000), default=5, help="trainings, seeds --first-seed.. (default 5)")
    p.add_argument("--first-seed", type=int_within(0, 2**32 - 1000), default=1)
    p.add_argument("--minutes", type=positive_float_at_most(7 * 24 * 60.0), default=60.0,
                   help="each training's budget, every stage together (default 60)")
    p.add_argument("--threads", type=int_within(0, 256), default=2, help="simulation threads (default 2)")
    p.add_argument("--config", default="train", help="NEAT's config (default: train, the recipe's)")
    p.add_argument("--out", type=Path, help="keep every training here; finished seeds are read back, cut ones resumed")
    p.add_argument("--measure", type=Path, metavar="CONTROLLER", help="no training: measure this controller")
    p.add_argument("--ship", type=Path, metavar="FILE", help="write the best walker (one that meets the bar, then "
                   "the highest walk rate, then transfer) - or the --measure'd controller - here, with its measures "
                   "in its provenance")
    args = p.parse_args(argv)
    log = lambda line: progress(line, args.json)  # noqa: E731
    if args.measure:
        test = robustness(args.measure)
        measured = {"controller": str(args.measure), "robust": is_robust(test), "test": test,
                    **measure_walker(args.measure, log, threads=args.threads)}
        measured["bar"] = meets_bar(measured)
        if args.ship:
            made = {"made_by": command_line("benchmarks.robust_walk", argv), "walk_rate": measured["rate"],
                    "transfer_ratio": measured["transfer"]["ratio"], "bar": measured["bar"],
                    "sustained": {k: {x: y for x, y in s.items() if x != "per_episode"}
                                  for k, s in measured["sustained"].items()}}
            measured["shipped"] = Controller.ship(args.measure, args.ship, made)
        report(measured, args.json)
        return
    out = args.out or Path(tempfile.mkdtemp(prefix="train-bench-"))
    runs = []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        folder = out / f"seed{seed}"
        state = read_json(folder / STATE) if (folder / STATE).exists() else None
        if state is None or "measure" not in state["stages"]:
            settings = TrainSettings(minutes=args.minutes, seed=seed, threads=args.threads, config=args.config)
            train(args.robot, folder, settings, resume=state is not None, quiet=args.json,
                  command=f"biped train {args.robot} --seed {seed} --minutes {args.minutes:g} --threads "
                  f"{args.threads} --out {folder}")
        else:
            log(f"seed {seed}: trained before ({folder / STATE})")
        runs.append(seed_record(folder))
        r = runs[-1]
        log(f"seed {seed}: {r['wall_minutes']:.1f} wall min, {r['cpu_minutes']:.1f} CPU min, walk rate "
            f"{r['walk_rate']:.2f}, transfer {r['transfer']:.2f}, bar {'met' if r['met_bar'] else 'missed'}")
    result = summary(runs)
    if args.ship:
        best = max(runs, key=lambda r: (r["met_bar"], r["walk_rate"], r["transfer"]))
        result["shipped"] = Controller.ship(best["controller"], args.ship, {
            "made_by": read_json(Path(best["folder"]) / STATE)["command"],
            "benchmark": command_line("benchmarks.robust_walk", argv)})
    report(result, args.json)


if __name__ == "__main__":
    main()
