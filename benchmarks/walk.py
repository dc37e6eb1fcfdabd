"""Minutes to a walker: one evolution on the default robot, within a wall-time budget.

    python -m benchmarks.walk --minutes 30 --seed 1 --json

Runs ``configs/evolve/walk.yaml`` (or --config) and, after every generation, replays that
generation's champion without the harness.  "Walked" (the issue's criterion) means upright
at the end of the episode and at least 2.2 leg lengths forward (seed 000's 2 m for a human
leg of about 0.9 m).  Stops at the first walker or when the budget is spent, and saves
the walker as ``walker.json`` in the run folder (its ``controller.json`` may still hold a
champion of the harness generations).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from benchmarks.common import parser, progress, report
from evolve.config import config_path
from evolve.config import load_evolve_config
from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.objectives import WALK_LEG_LENGTHS
from evolve.run import Run


def walk_once(config_name: str, seed: int, minutes: float, out: Path, threads: int | None = None,
              quiet: bool = False, generations: int | None = None) -> dict:
    """One evolution until its first walker or the budget (wall minutes, and generations if
    given: on a shared machine a generation budget is the fair one); the result as below."""
    config = load_evolve_config(config_path(config_name)).replace(seed=seed, generations=10**6)
    if threads is not None:
        config = config.replace(threads=threads)
    run = Run.create(config, out, log=lambda line: progress(line, quiet))
    judge = LocomotionEvaluator(run.robot, config.task, 1, threads=1)
    leg = run.robot.leg_length
    budget = minutes * 60.0
    start = time.perf_counter()
    state = {"walked": False, "minutes_to_walk": None, "best_distance_m": 0.0, "generation": None}

    def stop(run: Run, row: dict) -> bool:
        champion = run.champion
        result = judge.evaluate([champion.genome], config.neat.sigmoid_steepness, harness=0.0)
        distance, upright = float(result.distance_m[0]), float(result.upright_s[0])
        full = upright >= judge.episode_s - 1e-9
        state["best_distance_m"] = max(state["best_distance_m"], distance if full else 0.0)
        if result.walked(leg, judge.episode_s)[0]:
            state.update(walked=True, minutes_to_walk=(time.perf_counter() - start) / 60.0,
                         generation=row["generation"], walk_distance_m=distance)
            run.controller(champion).save(out / "walker.json")  # judged without the harness
            return True
        over = generations is not None and row["generation"] + 1 >= generations
        return over or time.perf_counter() - start > budget

    run.evolve(stop=stop)
    return {
        "walked": state["walked"],
        "best_distance_m": state.get("walk_distance_m", state["best_distance_m"]),
        "leg_length_m": leg,
        "required_m": WALK_LEG_LENGTHS * leg,
        "minutes_to_walk": state["minutes_to_walk"],
        "generations": run.population.generation,
        "walk_generation": state["generation"],
        "seed": seed,
        "population": config.neat.population_size,
        "episode_s": config.task.episode_s,
        "wall_minutes": (time.perf_counter() - start) / 60.0,
        "run_dir": str(out),
    }


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--minutes", type=float, default=30.0, help="wall-time budget")
    p.add_argument("--generations", type=int, help="generation budget as well")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--config", default="walk")
    p.add_argument("--threads", type=int, help="simulation threads (default: the config's)")
    p.add_argument("--out", type=Path, help="keep the run folder here (default: a temporary folder)")
    args = p.parse_args(argv)
    out = args.out or Path(tempfile.mkdtemp(prefix="walk-bench-"))
    report(walk_once(args.config, args.seed, args.minutes, out, args.threads, args.json, args.generations), args.json)


if __name__ == "__main__":
    main()
