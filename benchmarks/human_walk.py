"""Seed 000's headline experiment on its own characters: humans of many sizes learn to walk.

    python -m benchmarks.human_walk --out runs/human-walk --json
    python -m benchmarks.human_walk --presets female_5 male_95 --seeds 1 2 --out runs/human-walk --hours 2 --json

The paper's protocol (``configs/evolve/walk_human.yaml``: population 512, 30 species, the
support harness for the first 100 generations, eq. 3, a 0.07 s tick) on each preset of the
``human`` character, one run per preset and seed, at most ``--generations``.  After every
generation without the harness the generation's champion is replayed without it; it
**walked** when it stays upright for the whole 10 s episode and goes more than 2 m (seed
000's criterion); its gait is measured as below.  A run stops ``--after-walker`` generations
after its first walker whose gait is a walk (so its best walker can improve a little) or at
the generation limit; its best walker (a walk's gait first, then the farthest:
:func:`better_walker`) then walks 60 s in simulation without a stagnation stop: seconds
upright, distance before toppling, speed.  (Before issue 51 a run stopped after its first
walker of any gait and kept its farthest: runs begun so keep the first walker's generation.)

A run **covers 2 m** (``covers_2m``, what ``walked`` meant before issue 51) when it found such a
walker; it **walked** only when its best walker's gait is also a walk (issue 51): measured over
a 10 s replay on the nominal body with the first 2 s skipped (:mod:`sim2real.gait_measures`:
both hips swing alike, no flight phase, both feet step).  The summary counts both.

Resumable: every run lives in ``--out/<preset>-seed<S>/`` (``<file>_<preset>-seed<S>/`` for a
``--robot FILE``; the evolution's run folder ``run/``, ``state.json`` with the first and best
walker, ``walker.json``, and ``result.json`` once finished).  A call does what is left,
finished runs are read back, and ``--hours`` bounds a call's wall time (a run cut off continues
from its checkpoint next time).  Wall minutes are the evolution's own, summed over calls.
``--ship DIR`` writes each preset's best walker that still walks when replayed on this machine
as ``DIR/human_<preset>.json`` (how ``configs/controllers/human_*.json`` were made: their
provenance has the command).
"""

from __future__ import annotations

import time
from pathlib import Path

import mujoco

from benchmarks.common import command_line, parser, progress, report
from evolve.config import config_path
from evolve.config import load_evolve_config
from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.replay import evaluate_controller, gait
from evolve.run import Run
from sim2real.atomic_json import read_json, write_json_atomic
from sim2real.controller.activation import exp_fingerprint
from sim2real.controller.file import Controller
from sim2real.gait_measures import GaitMeasures, describe, is_a_walk, measure_recorded

PRESETS = ("female_5", "female_50", "female_95", "male_5", "male_50", "male_95",
           "male_heavy_short", "female_heavy_short")
WALKED_M = 2.0  # seed 000: upright for more than 2 m
SUSTAINED_S = 60.0
GAIT_S = 10.0  # issue 51: a gait is judged over a 10 s replay on the nominal body (its first 2 s skipped)


def walked_by_seed_000(upright_s: float, distance_m: float, episode_s: float) -> bool:
    """Seed 000's test: upright for the whole ``episode_s`` [s] and more than :data:`WALKED_M`."""
    return upright_s >= episode_s - 1e-9 and distance_m > WALKED_M


def run_folder(out: Path, preset: str, seed: int, robot: str = "human") -> Path:
    """A run's folder; a variant body's runs are named after its file, so that they are never
    read back as (or resumed from) the human's in the same ``--out``."""
    body = "" if robot == "human" else f"{Path(robot).stem}_"
    return out / f"{body}{preset}-seed{seed}"


def body_file(robot: str, preset: str) -> str | None:
    """The body to replay a run's controllers on when ``robot`` is a variant's file (its
    controllers name the project robot its file is called after), else None: their own."""
    return f"{robot}:{preset}" if Path(robot).suffix in (".yaml", ".yml") else None


def evolve_preset(preset: str, seed: int, folder: Path, *, config_name: str, robot: str, generations: int,
                  after_walker: int, threads: int, deadline: float, quiet: bool) -> bool:
    """Evolve (or go on evolving) one run until it is finished or ``deadline`` (time.monotonic)
    passes; True when finished."""
    state_path = folder / "state.json"
    state = read_json(state_path) if state_path.exists() else {"first_walker": None, "best_walker": None}
    run_dir = folder / "run"
    log = lambda line: progress(f"{preset} seed {seed}: {line}", quiet)  # noqa: E731
    if (run_dir / "checkpoint.json.gz").exists():
        run = Run.resume(run_dir, threads=threads, log=log, robot=body_file(robot, preset))
    else:
        # the body given as an override, so that what follows from it (a gait clock's period from
        # its leg length, phase_period_s: auto) is this preset's
        config = load_evolve_config(config_path(config_name), {"robot": f"{robot}:{preset}"}).replace(
            seed=seed, generations=generations, threads=threads)
        run = Run.create(config, run_dir, log=log)
    task = run.config.task
    judge = LocomotionEvaluator(run.robot, task, 1, threads=1)

    def done(generation: int) -> bool:
        first = state.get("first_walk")
        return generation + 1 >= generations or (first is not None and generation >= first["generation"] + after_walker)

    def stop(run: Run, row: dict) -> bool:
        generation = int(row["generation"])
        if row["harness"] == 0:
            result = judge.evaluate([run.champion.genome], run.config.neat.sigmoid_steepness, harness=0.0)
            distance, upright = float(result.distance_m[0]), float(result.upright_s[0])
            if walked_by_seed_000(upright, distance, judge.episode_s):
                candidate = folder / "candidate.json"
                run.controller(run.champion).save(candidate)
                walk = is_a_walk(GaitMeasures.from_dict(gait_of(candidate, body_file(robot, preset))))
                walker = {"generation": generation, "minutes": run.wall_s / 60.0, "distance_m": distance,
                          "a_walk": walk}
                if state["first_walker"] is None:
                    state["first_walker"] = walker
                    log(f"first walker at generation {generation}: {distance:.2f} m in {judge.episode_s:.1f} s")
                if walk and state.get("first_walk") is None:
                    state["first_walk"] = walker
                    log(f"first walker with a walk's gait at generation {generation}: {distance:.2f} m")
                if state["best_walker"] is None or better_walker(walker, state["best_walker"]):
                    state["best_walker"] = walker
                    candidate.replace(folder / "walker.json")
                else:
                    candidate.unlink()
                write_json_atomic(state_path, state)
        return done(generation) or time.monotonic() > deadline

    last = run.population.generation - 1
    if last >= 0 and done(last):
        return True
    run.evolve(stop=stop)
    return done(run.population.generation - 1)


def better_walker(new: dict, best: dict) -> bool:
    """Is the walker ``new`` a better one to keep than ``best``?  A walk's gait first, then
    distance: the farthest of a run's walkers is most often its fastest gait, a run or a gallop
    (issue 51).  Walkers judged before the gait measures count as no walk."""
    return (new.get("a_walk", False), new["distance_m"]) > (best.get("a_walk", False), best["distance_m"])


def sustained_walk(controller: Path, body: str | None = None) -> dict:
    """``controller``'s walk of :data:`SUSTAINED_S` without the stagnation stop (on ``body``,
    :func:`body_file`): seconds upright, distance before toppling, speed, whether it fell, and its turn [deg]."""
    walk = evaluate_controller(controller, body, seconds=SUSTAINED_S, stagnation_stop=False)
    return {"sustained_s": walk["upright_s"], "sustained_m": walk["distance_m"],
            "speed_m_s": walk["distance_m"] / walk["upright_s"] if walk["upright_s"] > 0 else 0.0,
            "fell": walk["fell"], "turn_deg": walk["per_episode"][0]["turn_deg"]}


def gait_of(controller: Path, body: str | None = None) -> dict:
    """``controller``'s gait measures over a :data:`GAIT_S` replay on its nominal body (``body``,
    :func:`body_file`) (:func:`~sim2real.gait_measures.GaitMeasures.to_dict`)."""
    return measure_recorded(gait(controller, body, seconds=GAIT_S)).to_dict()


def walks_a_walk(covers_2m: bool, gait_measures: dict) -> bool:
    """Issue 51's count: a run walked when it covers 2 m upright (seed 000) and its gait is a walk."""
    return covers_2m and is_a_walk(GaitMeasures.from_dict(gait_measures))


def judged(run: dict, folder: Path, body: str | None = None) -> dict:
    """A finished run's result, read back: one finished before the gait measures (its
    ``walked`` was seed 000's test alone) gets ``covers_2m`` from that, its gait measured now
    and ``walked`` judged with it (the file is left as it was)."""
    if "covers_2m" in run:
        return run
    covers = bool(run["walked"])
    measures = gait_of(folder / "walker.json" if covers else folder / "run" / "controller.json", body)
    return {**run, "covers_2m": covers, "walked": walks_a_walk(covers, measures), "gait": measures}


def tally(runs: list[dict]) -> dict:
    """How many runs walked a walk and how many covered 2 m (the count before issue 51), and rates."""
    walked, covered = sum(r["walked"] for r in runs), sum(r["covers_2m"] for r in runs)
    return {"walked": walked, "rate": walked / len(runs) if runs else None,
            "covers_2m": covered, "covers_2m_rate": covered / len(runs) if runs else None}


def finish(preset: str, seed: int, folder: Path, quiet: bool, body: str | None = None) -> dict:
    """The run's result: its first walker, its best walker's gait and 60 s walk (on ``body``)."""
    state = read_json(folder / "state.json") if (folder / "state.json").exists() else {"first_walker": None}
    first = state["first_walker"]
    controller = folder / "walker.json" if first else folder / "run" / "controller.json"
    stats = (folder / "run" / "stats.csv").read_text().splitlines()
    measures = gait_of(controller, body)
    result = {
        "preset": preset, "seed": seed, "walked": walks_a_walk(first is not None, measures),
        "covers_2m": first is not None, "gait": measures,
        "generation": first["generation"] if first else None,
        "minutes": first["minutes"] if first else None,
        "first_walker_m": first["distance_m"] if first else None,
        # the first walker whose gait is a walk (issue 51; None in runs begun before)
        "walk_generation": state["first_walk"]["generation"] if state.get("first_walk") else None,
        "walk_minutes": state["first_walk"]["minutes"] if state.get("first_walk") else None,
        "generations_run": len(stats) - 1,
        "sustained_of": "best walker" if first else "best controller (no walker)",
        **sustained_walk(controller, body),
    }
    write_json_atomic(folder / "result.json", result)
    progress(f"{preset} seed {seed}: covers 2 m {result['covers_2m']} (generation {result['generation']}), "
             f"60 s walk: {result['sustained_m']:.1f} m upright {result['sustained_s']:.1f} s; gait over "
             f"{GAIT_S:g} s: {describe(GaitMeasures.from_dict(measures))}", quiet)
    return result


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--presets", nargs="+", default=list(PRESETS), help="human presets (default: all eight)")
    p.add_argument("--seeds", nargs="+", type=int, default=[1])
    p.add_argument("--out", type=Path, default=Path("runs/human-walk"), help="runs live here (resumable)")
    p.add_argument("--config", default="walk_human")
    p.add_argument("--robot", default="human", help="the human character's config, a name or a path (default: "
                   "configs/robots/human.yaml); a variant body with the same presets")
    p.add_argument("--generations", type=int, default=300, help="at most this many a run (default 300)")
    p.add_argument("--after-walker", type=int, default=25,
                   help="generations a run goes on after its first walker (default 25)")
    p.add_argument("--threads", type=int, default=1, help="simulation threads a run (default 1)")
    p.add_argument("--hours", type=float, default=1e6, help="wall-time budget of this call")
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--ship", type=Path, metavar="DIR", help="write each preset's best walker (farthest in its "
                   "60 s walk, over the seeds run, that still walks when replayed here) as "
                   "DIR/human_<preset>.json, with this command and its measures in its provenance")
    args = p.parse_args(argv)
    deadline = time.monotonic() + args.hours * 3600.0
    runs, unfinished = [], []
    for preset in args.presets:
        for seed in args.seeds:
            folder = run_folder(args.out, preset, seed, args.robot)
            if (folder / "result.json").exists():
                runs.append(judged(read_json(folder / "result.json"), folder, body_file(args.robot, preset)))
                continue
            if time.monotonic() > deadline:
                unfinished.append(folder.name)
                continue
            folder.mkdir(parents=True, exist_ok=True)
            if evolve_preset(preset, seed, folder, config_name=args.config, robot=args.robot,
                             generations=args.generations,
                             after_walker=args.after_walker, threads=args.threads, deadline=deadline,
                             quiet=args.quiet):
                runs.append(finish(preset, seed, folder, args.quiet, body_file(args.robot, preset)))
            else:
                unfinished.append(folder.name)
    result = {"runs": runs, **tally(runs), "unfinished": unfinished, "generations": args.generations,
              "after_walker": args.after_walker, "config": args.config, "robot": args.robot}
    if args.ship:
        result["shipped"] = ship(runs, args.out, args.robot, args.ship, argv, args.quiet)
    report(result, args.json)


def walks_here(walker: Path, body: str | None = None) -> bool:
    """Does ``walker`` still walk by seed 000's test when replayed on this machine (on ``body``)?"""
    walk = evaluate_controller(walker, body)
    return not walk["fell"] and walked_by_seed_000(walk["upright_s"], walk["distance_m"], walk["seconds"])


def ship(runs: list[dict], out: Path, robot: str, into: Path, argv: list[str] | None,
         quiet: bool = True) -> list[str]:
    """Each preset's best walker of ``runs`` - of the runs that walked (a walk's gait, not only
    2 m: :func:`walks_a_walk`) whose walker still walks by seed 000's test when replayed here,
    the farthest in its 60 s walk here - as ``into/human_<preset>.json``; presets without one
    get no file.

    These walkers replay exactly only on the numbers they were evolved on
    (``benchmarks.tolerance``), so a walker evolved on another machine or MuJoCo is judged and
    walked again before it ships (the provenance's ``human_walk`` has this machine's 60 s walk),
    and the provenance records the MuJoCo version and this machine's
    :func:`~sim2real.controller.activation.exp_fingerprint`."""
    into.mkdir(parents=True, exist_ok=True)
    made_by = command_line("benchmarks.human_walk", argv)
    numerics = {"mujoco": mujoco.__version__, "exp_fingerprint": exp_fingerprint()}
    shipped = []
    for preset in dict.fromkeys(r["preset"] for r in runs):
        here = []
        for run in (r for r in runs if r["preset"] == preset and r["walked"]):
            walker = run_folder(out, preset, run["seed"], robot) / "walker.json"
            if walks_here(walker, body_file(robot, preset)):
                here.append(({**run, **sustained_walk(walker, body_file(robot, preset))}, walker))
            else:
                progress(f"{preset} seed {run['seed']}: its walker falls when replayed here - not shipped", quiet)
        if here:
            best, walker = max(here, key=lambda pair: pair[0]["sustained_m"])
            path = into / f"human_{preset}.json"
            Controller.ship(walker, path, {"made_by": made_by, "human_walk": best, **numerics})
            shipped.append(str(path))
    return shipped


if __name__ == "__main__":
    main()
