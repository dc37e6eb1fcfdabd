"""Minutes to a robust walker on the default robot, and how it does behind the bus.

    python -m benchmarks.robust_walk --seeds 5 --out runs/robust_walk --json
    python -m benchmarks.robust_walk --seeds 5 --out runs/robust_walk --minutes 60 --config walk_robust
    python -m benchmarks.robust_walk --seeds 5 --config walk_straight3_p512 --minutes 45 --polish 40 --speed-polish 40 --out runs/cv --json
    python -m benchmarks.robust_walk --measure CONTROLLER [--ship configs/controllers/xl430_biped.json] --json

Per seed, one evolution of ``--config`` (the robust-walk recipe by default) until its first
*robust* walker or the budget.  Whenever the run's champion (``best.json``: with validation
draws, chosen on them) changes, it is tested on robots that neither selection nor
validation ever saw; it is robust when, in 10 s episodes,

* on ``--draws`` (10) robots drawn from ``configs/reality/randomize.yaml`` (episode seeds
  ``[TEST_SEED, e]``, a key shape no training or validation draw has), it stays upright and
  walks at least 2.2 leg lengths in ``--need`` (8) or more, and
* on ``configs/reality/default.yaml`` (3 noise seeds) it does so in 3 of 3.

Then, for each robust walker: its walk rate on 50 more randomized robots, the transfer check (``benchmarks.transfer``: 3 dry runs on the
simulated bus under ``default.yaml``, distance kept against the simulation) and a 60 s walk
in simulation without the stagnation stop, on the nominal and on the ``default.yaml`` robot
(seconds upright, distance, speed).

Wall minutes are the evolution's own (``stats.csv``'s ``wall_s``: every generation with its
validation), measured with nothing else running; the tests of champions come on top and are
reported apart (``test_s``).  With ``--out`` each seed keeps its folder and ``result.json``:
a finished seed is not run again, an interrupted one resumes from its checkpoint (a seed
fixes the run, so the resumed run is the one that was cut).

With ``--polish UPDATES`` each seed goes on, whatever NEAT found, to a weight polish of its
walker (``biped polish``'s CMA-ES, :func:`polish_once`): every walker the polish keeps is
tested the same way, and the seed's final walker is the last robust one.  A seed robust only
after the polish counts NEAT's minutes plus the polish's up to its first robust walker.
NEAT's result waits in ``result.json`` until the polish's replaces it (a cut polish resumes
from its checkpoint).  With ``--speed-polish UPDATES`` each robust seed's final walker is polished once more
for speed (:func:`speed_polish_once`), and a robust walker kept there becomes the seed's; then
``--speed-polish-restarts`` more times (default 1) from the walker it kept, each with a fresh
CMA-ES, while each keeps a robust walker.  The summary's
``transfer_ratio_median`` counts a walker that falls on the nominal model as keeping 0 (there
is no walk to keep), and ``transfer_passed`` counts the checks passed.  ``--measure CONTROLLER`` measures
one controller the same way, without evolving; ``--ship FILE`` writes the walker with the
command and its measures in its provenance (``robust`` says whether it met the bar).
"""

from __future__ import annotations

import shutil
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

from benchmarks.common import command_line, parser, progress, report, ship_controller
from evolve.transfer import transfer_check
from evolve.cli_commands import resolve_config
from evolve.config import load_evolve_config
from evolve.replay import evaluate_controller
from evolve.run import Run
from sim2real.arg_types import int_within, positive_float_at_most
from sim2real.atomic_json import read_json, write_json_atomic

TEST_SEED = 314_159  # the robustness test's episode seeds are [TEST_SEED, e]
EPISODE_S = 10.0
SUSTAINED_S = 60.0
RATE_ROBOTS = 50  # more robots for a walker's walk rate than the bar's 10


def robustness(controller: Path, draws: int, default_episodes: int = 3) -> dict[str, Any]:
    """The controller on ``draws`` unseen randomized robots and on ``default.yaml``."""
    keep = ("walked", "distance_m", "min_distance_m", "falls", "upright_s")
    randomized = evaluate_controller(controller, seconds=EPISODE_S, episodes=draws, randomize="randomize",
                                     seed=TEST_SEED)
    default = evaluate_controller(controller, seconds=EPISODE_S, episodes=default_episodes, randomize="default",
                                  seed=TEST_SEED)
    return {"randomized": {k: randomized[k] for k in keep}, "default": {k: default[k] for k in keep},
            "draws": draws, "default_episodes": default_episodes}


def sustained(controller: Path, reality: str | None, episodes: int) -> dict[str, Any]:
    """A 60 s walk without the stagnation stop: seconds upright, distance, speed, and how fast
    it turns (the torso's net turn per minute upright, unwrapped) - means over the episodes."""
    r = evaluate_controller(controller, seconds=SUSTAINED_S, episodes=episodes, randomize=reality,
                            seed=TEST_SEED, stagnation_stop=False)
    per_minute = [abs(e["turn_deg"]) / (e["upright_s"] / 60.0) for e in r["per_episode"] if e["upright_s"] > 0]
    return {"upright_s": r["upright_s"], "distance_m": r["distance_m"], "falls": r["falls"],
            "speed_m_s": r["distance_m"] / r["upright_s"] if r["upright_s"] > 0 else 0.0,
            "heading_deg_per_min": statistics.mean(per_minute) if per_minute else None,
            "per_episode": r["per_episode"]}


def is_robust(test: dict[str, Any], need: int) -> bool:
    return test["randomized"]["walked"] >= need and test["default"]["walked"] == test["default_episodes"]


def walk_rate(controller: Path, robots: int = RATE_ROBOTS) -> dict[str, Any]:
    """The share of ``robots`` more randomized robots (seeds ``[TEST_SEED + 1, e]``) it walks on:
    ten robots are few for a walker that walks on about half of them."""
    r = evaluate_controller(controller, seconds=EPISODE_S, episodes=robots, randomize="randomize",
                            seed=TEST_SEED + 1)
    return {"robots": robots, "walked": r["walked"], "falls": r["falls"], "share": r["walked"] / robots}


STEER_DEG, STEER_AT_S, STEER_WITHIN_S, STEER_TOLERANCE_DEG = 90.0, 2.0, 10.0, 15.0


def steering(controller: Path) -> dict[str, Any] | None:
    """Told at 2 s to hold a heading 90 deg to the left, does it get there within 10 s without
    a fall (within 15 deg of it at the end)?  None for a controller without a heading input."""
    from sim2real.controller.file import Controller
    from sim2real.controller.steering import schedule_command

    if not Controller.load(controller).heading_input:
        return None
    command = schedule_command([(0.0, 0.0), (STEER_AT_S, STEER_DEG)])
    r = evaluate_controller(controller, seconds=STEER_AT_S + STEER_WITHIN_S, heading=command, stagnation_stop=False)
    error = r["per_episode"][0]["heading_error_deg"]
    return {"turn_deg": STEER_DEG, "fell": r["fell"], "heading_error_deg": error,
            "reached": not r["fell"] and abs(error) <= STEER_TOLERANCE_DEG}


def after_test(walker: Path, log: Callable[[str], None]) -> dict[str, Any]:
    """What is measured of a robust walker: its walk rate on 50 more robots, the transfer check,
    the 60 s walks and (with a heading input) a commanded 90 deg turn."""
    return {"rate": walk_rate(walker), "transfer": transfer_check(walker, "default", 3, 0.8, log),
            "sustained": {"nominal": sustained(walker, None, 1), "default": sustained(walker, "default", 3)},
            "steering": steering(walker)}


def robust_once(config_name: str, seed: int, folder: Path, minutes: float, draws: int, need: int,
                quiet: bool = False, threads: int | None = None, generations: int | None = None) -> dict[str, Any]:
    """One seed: evolve until a robust walker or the budget (``minutes`` of evolution, or
    ``generations`` in all, whichever ends first), then measure it.  ``threads``: simulation
    threads (None: the config's)."""
    log = lambda line: progress(line, quiet)  # noqa: E731
    if (folder / "checkpoint.json.gz").exists():
        run = Run.resume(folder, threads=threads, log=log)
        log(f"seed {seed}: resuming {folder} at generation {run.population.generation}")
    else:
        config = load_evolve_config(resolve_config(config_name)).replace(seed=seed)
        if threads is not None:
            config = config.replace(threads=threads)
        run = Run.create(config, folder, log=log)
    state: dict[str, Any] = {"robust": False, "tests": [], "test_s": 0.0}
    tested: set[tuple[int, int]] = set()
    candidate = folder / "champion.json"

    def stop(run: Run, row: dict) -> bool:
        best = run.best
        if best is not None and not best.harness and (best.generation, best.genome.key) not in tested:
            tested.add((best.generation, best.genome.key))
            t0 = time.perf_counter()
            run.controller(best).save(candidate)
            test = robustness(candidate, draws)
            state["test_s"] += time.perf_counter() - t0
            robust = is_robust(test, need)
            state["tests"].append({"generation": best.generation, **test, "robust": robust})
            log(f"seed {seed}: champion of generation {best.generation}: walked on {test['randomized']['walked']}"
                f"/{draws} unseen robots, {test['default']['walked']}/{test['default_episodes']} default"
                f"{' - robust' if robust else ''}")
            if robust:
                candidate.replace(folder / "robust_walker.json")
                state.update(robust=True, generation=best.generation, minutes=run.wall_s / 60.0,
                             generations=row["generation"] + 1)
                return True
        return run.wall_s > minutes * 60.0 or (generations is not None and row["generation"] + 1 >= generations)

    run.evolve(stop=stop)
    result: dict[str, Any] = {
        "seed": seed, "robust": state["robust"], "minutes": state.get("minutes"),
        "generations": state.get("generations"), "champion_generation": state.get("generation"),
        "evolution_minutes": run.wall_s / 60.0, "generations_run": run.generation_offset + run.population.generation,
        "test_s": state["test_s"], "tests": state["tests"], "run_dir": str(folder),
    }
    if state["robust"]:
        result.update(after_test(folder / "robust_walker.json", log))
    write_json_atomic(folder / "result.json", result)
    return result


POLISH_POPSIZE, POLISH_ROBOTS, POLISH_SIGMA, POLISH_VALIDATION = 16, 16, 0.1, 30  # the polish that made the 98 % walker
# The speed polish starts from a robust walker, where candidates differ by a few robots in a
# hundred and 16 robots give a rate near 0.85 a standard error of 0.09: at 32 robots and a first
# step of 0.05 (changed together) seed 3 reached 47 of 50 where 16 and 0.1 reached 42.  30
# validation robots read 0.90-0.93 for walkers that then walked on 84-88 % of 50; 100 read
# closer (eighth session, benchmarks/RESULTS.md).
SPEED_POLISH_ROBOTS, SPEED_POLISH_SIGMA, SPEED_POLISH_VALIDATION = 32, 0.05, 100
# Ranked on each candidate's worst quarter of its robots (a CVaR) the speed polish lifted all four
# robust seeds' walk rate on 200 further robots (98 -> 99, 99.5 -> 99.5, 85.5 -> 87, 88 -> 96 %)
# and all four then reached the 90 deg turn (ninth session, benchmarks/RESULTS.md).
SPEED_POLISH_WORST = 0.25
# After its 40 updates the speed polish starts once more from the walker it kept, with a fresh
# CMA-ES (its step and covariance reset, as restart strategies do; Auger & Hansen, CEC 2005):
# seed 3's walker, stuck at 84 % of 50 robots, walked on 96 % after the restart (tenth session).
SPEED_POLISH_RESTARTS = 1
SPEED_GOAL_M_S = 0.15  # issue 33's straight-walk goal: the speed polish's gate asks no more than it
SPEED_POLISH_LEG_S = 0.8  # [leg lengths/s] the speed polish's kernel target: the task's 0.6 is 0.147 m/s on the
                          # XL430 biped, the goal's own speed, so nothing paid a faster walk (sixth session)


def polish_stage(source: Path, out: Path, seed: int, updates: int, draws: int, need: int,
                 log: Callable[[str], None], **settings: Any) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """Polish ``source`` into ``out`` for up to ``updates`` CMA-ES updates
    (:func:`evolve.polish.polish`, POLISH_POPSIZE candidates an update, seeded by the seed;
    ``settings``: its other keywords, e.g. ``robots`` (POLISH_ROBOTS), ``validation``
    (POLISH_VALIDATION), ``sigma``, ``speed_leg_s``, ``min_speed_m_s``, ``nominal``,
    ``walk_bonus``), giving every walker its validation keeps the robustness test; the last
    robust one is copied to ``out/robust_walker.json``.  Returns the polish's record (with its
    tests, their seconds, and ``first_robust_s``: the polish's own seconds to its first robust
    walker, the tests aside) and the robust walker's test (None: no robust walker).
    A cut stage resumes: the polish from its checkpoint, the tests from ``out/tests.json``."""
    from evolve.polish import CHECKPOINT, polish

    out.mkdir(parents=True, exist_ok=True)
    walker, tests = out / "robust_walker.json", out / "tests.json"
    resume = (out / CHECKPOINT).exists()
    if resume and tests.exists():
        state: dict[str, Any] = read_json(tests)
        log(f"seed {seed}: resuming the polish in {out}")
    else:
        walker.unlink(missing_ok=True)
        state = {"tests": [], "test_s": 0.0, "first_robust_s": None, "walker_test": None}

    def on_best(kept: Path, entry: dict[str, Any]) -> bool:
        done = [t for t in state["tests"] if t["update"] == entry["update"]]
        if done:  # cut after this test, before the polish's checkpoint: the update was done again
            if done[0]["robust"]:
                shutil.copyfile(kept, walker)
            return False
        t0 = time.perf_counter()
        test = robustness(kept, draws)
        robust = is_robust(test, need)
        state["tests"].append({"update": entry["update"], **test, "robust": robust})
        log(f"seed {seed}: polished walker of update {entry['update']}: walked on {test['randomized']['walked']}"
            f"/{draws} unseen robots, {test['default']['walked']}/{test['default_episodes']} default"
            f"{' - robust' if robust else ''}")
        if robust:
            shutil.copyfile(kept, walker)
            state["walker_test"] = state["tests"][-1]
            if state["first_robust_s"] is None:
                state["first_robust_s"] = entry["elapsed_s"] - state["test_s"]
        state["test_s"] += time.perf_counter() - t0
        write_json_atomic(tests, state)
        return False

    polished = polish(source, out, updates=updates, popsize=POLISH_POPSIZE, seed=seed, on_best=on_best, log=log,
                      resume=resume,
                      **{"robots": POLISH_ROBOTS, "sigma": POLISH_SIGMA, "validation": POLISH_VALIDATION, **settings})
    record = {**polished, "tests": state["tests"], "test_s": state["test_s"], "first_robust_s": state["first_robust_s"]}
    return record, state["walker_test"]


def polish_once(neat: dict[str, Any], folder: Path, updates: int, draws: int, need: int, quiet: bool = False,
                **settings: Any) -> dict[str, Any]:
    """The recipe's second phase: the seed's NEAT walker (its robust walker, or else its last
    champion) polished by :func:`polish_stage` in ``folder/polish`` (with its ``settings``).
    The seed's minutes to a robust walker are NEAT's, or NEAT's budget plus the polish's search
    up to its first robust walker.  The final walker is the last robust one kept, measured as :func:`robust_once`'s;
    the NEAT phase's result rides along as ``neat``."""
    log = lambda line: progress(line, quiet)  # noqa: E731
    seed = neat["seed"]
    source = folder / ("robust_walker.json" if neat["robust"] else "champion.json")
    result: dict[str, Any] = {**{k: neat[k] for k in ("seed", "robust", "minutes", "generations", "champion_generation",
                                                     "evolution_minutes", "generations_run", "run_dir")},
                              "neat": neat, "polish": None}
    if not source.exists():  # no champion off the harness: nothing to polish
        log(f"seed {seed}: no champion to polish")
        return result
    result["polish"], walker_test = polish_stage(source, folder / "polish", seed, updates, draws, need, log,
                                                 **settings)
    walker = folder / "polish" / "robust_walker.json"
    if walker_test is not None:
        if not neat["robust"]:  # its generations: all NEAT's, then the polish
            minutes = neat["evolution_minutes"] + result["polish"]["first_robust_s"] / 60.0
            result.update(robust=True, minutes=minutes, generations=neat["generations_run"])
        result.update(walker=str(walker), walker_test=walker_test, **after_test(walker, log))
    elif neat["robust"]:  # the polish kept no robust walker: NEAT's stays the seed's
        result.update(walker=str(folder / "robust_walker.json"), walker_test=neat["tests"][-1],
                      **{k: neat[k] for k in ("rate", "transfer", "sustained", "steering")})
    return result


def speed_polish_once(result: dict[str, Any], folder: Path, updates: int, draws: int, need: int,
                      quiet: bool = False, speed_leg_s: float = SPEED_POLISH_LEG_S,
                      min_speed_m_s: float | None = None, robots: int = SPEED_POLISH_ROBOTS,
                      sigma: float = SPEED_POLISH_SIGMA, validation: int = SPEED_POLISH_VALIDATION,
                      worst: float = SPEED_POLISH_WORST, restart: int = 0, **settings: Any) -> dict[str, Any]:
    """The recipe's third phase: a robust seed's final walker polished again by
    :func:`polish_stage` in ``folder/speed_polish``, its velocity kernel centred on
    ``speed_leg_s`` and no walk slower than ``min_speed_m_s`` counted (None: the walker's own
    speed, the lower of its 60 s walks', so the polish keeps no slower walker - but at most
    SPEED_GOAL_M_S: a gate at a fast walker's 60 s speed is one no 10 s episode, start-up
    included, passes, and validation then has no walk rate to keep walkers by).  ``robots``
    each candidate meets an update, CMA-ES's first step ``sigma``, ``validation`` robots,
    candidates ranked on their ``worst`` share of the robots;
    ``settings``: the stage's others (e.g. ``nominal``: the model itself among every update's
    robots, which drawn robots alone let a walker fall on).
    A robust walker it keeps becomes the seed's final walker (measured again); the seed's
    minutes to robustness stay as they were.  The stage's record is ``speed_polish`` (None
    for a seed that is not robust).  ``restart`` k > 0: the same stage once more, in
    ``folder/speed_polish_restartK``, from the walker the one before kept (see
    :func:`next_speed_polish`); its record is appended to ``speed_polish_restarts``.  The seed stays
    the seed's, so a restart meets the same robots update for update: only its start differs."""
    log = lambda line: progress(line, quiet)  # noqa: E731
    if not result["robust"]:
        return {**result, "speed_polish": None}
    if restart:
        source = folder / speed_polish_folder(restart - 1) / "robust_walker.json"
    else:
        polished = folder / "polish" / "robust_walker.json"  # the polish's, when it kept one, else NEAT's
        source = polished if polished.exists() else folder / "robust_walker.json"
    if min_speed_m_s is None:
        min_speed_m_s = min(SPEED_GOAL_M_S, *(walk["speed_m_s"] for walk in result["sustained"].values()))
    out = folder / speed_polish_folder(restart)
    record, walker_test = polish_stage(source, out, result["seed"], updates, draws, need, log,
                                       speed_leg_s=speed_leg_s, min_speed_m_s=min_speed_m_s, robots=robots,
                                       sigma=sigma, validation=validation, worst=worst, **settings)
    # (the polish's record names its source and settings already)
    record["before"] = {k: result[k] for k in ("walker_test", "rate", "transfer", "sustained", "steering") if k in result}
    result = {**result, **with_last_speed_polish(result, record, restart)}
    if walker_test is not None:
        walker = out / "robust_walker.json"
        result.update(walker=str(walker), walker_test=walker_test, **after_test(walker, log))
    return result


def speed_polish_folder(restart: int) -> str:
    return f"speed_polish_restart{restart}" if restart else "speed_polish"


def last_speed_polish(result: dict[str, Any]) -> dict[str, Any] | None:
    """The record of the seed's latest speed polish: its last restart's, else the first's."""
    restarts = result.get("speed_polish_restarts") or []
    return restarts[-1] if restarts else result.get("speed_polish")


def with_last_speed_polish(result: dict[str, Any], record: dict[str, Any], restart: int) -> dict[str, Any]:
    """The result's keys that hold ``record`` as its speed polish ``restart`` (0: the first)."""
    if not restart:
        return {"speed_polish": record}
    return {"speed_polish_restarts": [*(result.get("speed_polish_restarts") or [])[:restart - 1], record]}


def next_speed_polish(result: dict[str, Any], restarts: int) -> int | None:
    """The speed polish the seed needs next: 0 the first, k its restart k, None no more (all
    ``restarts`` done, or the latest kept no robust walker that stands - from an unchanged start
    and with the same seed a restart would repeat that polish exactly; or the seed is not robust)."""
    if "speed_polish" not in result:
        return 0
    stage, done = last_speed_polish(result), len(result.get("speed_polish_restarts") or [])
    keeps = bool(stage) and stage.get("first_robust_s") is not None and not stage.get("rejected")
    return done + 1 if keeps and done < restarts else None


def keep_the_model_walk(result: dict[str, Any]) -> dict[str, Any]:
    """The seed's result with its latest speed polish undone if that polish's walker falls on
    the nominal model within the 60 s walk where the walker it started from did not: drawn
    robots alone can tune a walk off the model (the OP3's and seeds 3 and 4's in the seventh and
    eighth sessions), and the model is what the transfer check and a user start from.  The
    speed polish's record stays, marked ``rejected``; applying this twice changes nothing."""
    stage = last_speed_polish(result)
    if not stage or stage.get("rejected") or result.get("walker") == stage["controller"] or "before" not in stage:
        return result
    before, after = stage["before"]["sustained"]["nominal"], result["sustained"]["nominal"]
    if before["falls"] or not after["falls"]:
        return result
    undone = {**stage, "rejected": f"falls on the nominal model at {after['upright_s']:.1f} s; "
              "the walker it started from walks the 60 s", "after": {k: result[k] for k in stage["before"]}}
    restart = len(result.get("speed_polish_restarts") or [])
    return {**result, **stage["before"], "walker": stage["controller"], **with_last_speed_polish(result, undone, restart)}


def ship_rank(result: dict[str, Any]) -> tuple[bool, float, float]:
    """How a robust seed's walker ranks for shipping: one that walks the 60 s on the nominal
    model first (a user starts from the model), then the higher walk rate on 50 robots (a user's
    robot is not the model), then the larger share of its walk kept through the bus."""
    return result["sustained"]["nominal"]["falls"] == 0, result["rate"]["share"], kept(result["transfer"])


def kept(transfer: dict[str, Any]) -> float:
    """The transfer check's ratio, or 0 when the nominal simulation did not walk: a share kept
    of a walk that never was (a fall on the model) is no transfer."""
    return transfer["ratio"] if transfer["sim_walked"] else 0.0


def summary(runs: list[dict[str, Any]]) -> dict[str, Any]:
    robust = [r for r in runs if r["robust"]]

    def median(values):
        values = list(values)
        return statistics.median(values) if values else None

    return {
        "seeds": len(runs), "robust_seeds": len(robust),
        "median_minutes": median(r["minutes"] for r in robust),
        "median_generations": median(r["generations"] for r in robust),
        "transfer_ratio_median": median(kept(r["transfer"]) for r in robust),
        "transfer_passed": sum(r["transfer"]["passed"] for r in robust),
        "sustained_s_median": median(r["sustained"]["default"]["upright_s"] for r in robust),
        "sustained_m_median": median(r["sustained"]["default"]["distance_m"] for r in robust),
        "speed_m_s_median": median(r["sustained"]["nominal"]["speed_m_s"] for r in robust),
        "walk_rate_median": median(r["rate"]["share"] for r in robust),
        "walk_rate_50_median": median(r["rate"]["share"] for r in robust if r["rate"].get("robots") == RATE_ROBOTS),
        # the worse of the nominal and the default.yaml robot's 60 s walks
        "heading_deg_per_min_median": median(max(r["sustained"][k].get("heading_deg_per_min") or 0.0
                                                 for k in ("nominal", "default")) for r in robust),
        "steering_reached": sum(bool((r.get("steering") or {}).get("reached")) for r in robust),
        "runs": runs,
    }


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=5, help="independent runs, seeds --first-seed.. (default 5)")
    p.add_argument("--first-seed", type=int, default=1)
    p.add_argument("--minutes", type=float, default=60.0, help="evolution wall-time budget per seed (default 60)")
    p.add_argument("--generations", type=int_within(1, 1_000_000), metavar="G", help="also stop a seed's evolution "
                   "after G generations (a budget that does not depend on the robot's cost per generation)")
    p.add_argument("--config", default="walk_robust", help="evolution config (default: the robust-walk recipe)")
    p.add_argument("--threads", type=int, help="simulation threads (default: the config's)")
    p.add_argument("--draws", type=int, default=10, help="unseen randomized robots a champion is tested on")
    p.add_argument("--need", type=int, default=8, help="of them it must walk on")
    p.add_argument("--out", type=Path, help="keep every run here; finished seeds are reused, cut ones resumed")
    p.add_argument("--measure", type=Path, metavar="CONTROLLER", help="no evolution: measure this controller "
                   "as a champion is measured (robustness test, transfer check, 60 s walks)")
    p.add_argument("--ship", type=Path, metavar="FILE", help="write the best robust walker (one that walks the "
                   "60 s on the model, then the highest walk rate, then transfer) - or the --measure'd controller - "
                   "here, with this command and its measures in its provenance")
    p.add_argument("--polish", type=int_within(0, 100_000), default=0, metavar="UPDATES", help="then polish each seed's walker (its "
                   "robust walker, or else its last champion) for up to UPDATES CMA-ES updates, testing every "
                   "walker the polish keeps (default 0: no polish)")
    p.add_argument("--polish-speed-leg-s", type=positive_float_at_most(5.0), metavar="V", help="the polish's velocity kernel target "
                   "[leg lengths/s] (default: the task's)")
    p.add_argument("--polish-min-speed", type=positive_float_at_most(5.0), metavar="M_S", help="the polish counts no walk slower "
                   "than this [m/s] (default: any)")
    p.add_argument("--polish-walk-bonus", type=positive_float_at_most(1000.0), metavar="B", help="what the polish's "
                   "selection pays an episode that walks (default: the task's)")
    p.add_argument("--polish-validation", type=int_within(1, 10_000), default=POLISH_VALIDATION, metavar="N",
                   help=f"robots the polish judges its search's mean on (default {POLISH_VALIDATION})")
    p.add_argument("--polish-robots", type=int_within(1, 1024), default=POLISH_ROBOTS, metavar="N",
                   help=f"randomized robots every candidate of one polish update walks on (default {POLISH_ROBOTS})")
    p.add_argument("--polish-sigma", type=positive_float_at_most(20.0), default=POLISH_SIGMA, metavar="S",
                   help=f"the polish's first CMA-ES step [weight units] (default {POLISH_SIGMA})")
    p.add_argument("--speed-polish", type=int_within(0, 100_000), default=0, metavar="UPDATES", help="then polish each "
                   "robust seed's final walker again for up to UPDATES updates, paying speed (default 0: no speed polish)")
    p.add_argument("--speed-polish-leg-s", type=positive_float_at_most(5.0), default=SPEED_POLISH_LEG_S, metavar="V",
                   help=f"its velocity kernel target [leg lengths/s] (default {SPEED_POLISH_LEG_S})")
    p.add_argument("--speed-polish-min-speed", type=positive_float_at_most(5.0), metavar="M_S", help="it counts no walk "
                   "slower than this [m/s] (default: the walker's own, the lower of its two 60 s walks', "
                   f"at most {SPEED_GOAL_M_S})")
    p.add_argument("--speed-polish-robots", type=int_within(1, 1024), default=SPEED_POLISH_ROBOTS, metavar="N",
                   help=f"robots each of its candidates meets an update (default {SPEED_POLISH_ROBOTS})")
    p.add_argument("--speed-polish-sigma", type=positive_float_at_most(20.0), default=SPEED_POLISH_SIGMA,
                   metavar="S", help=f"its first step size [weight units] (default {SPEED_POLISH_SIGMA})")
    p.add_argument("--speed-polish-validation", type=int_within(1, 10_000), default=SPEED_POLISH_VALIDATION,
                   metavar="N", help=f"its validation robots (default {SPEED_POLISH_VALIDATION}; "
                   "the seventh session's runs: --speed-polish-robots 16 --speed-polish-sigma 0.1 "
                   "--speed-polish-validation 30)")
    p.add_argument("--speed-polish-walk-bonus", type=positive_float_at_most(1000.0), metavar="B", help="what its "
                   "selection pays an episode that walks (default: the task's)")
    p.add_argument("--polish-worst", type=positive_float_at_most(1.0), default=1.0, metavar="SHARE", help="the polish "
                   "ranks candidates by their mean score on the worst SHARE of an update's robots (default 1: the mean "
                   "over all)")
    p.add_argument("--speed-polish-worst", type=positive_float_at_most(1.0), default=SPEED_POLISH_WORST,
                   metavar="SHARE", help=f"the same for the speed polish (default {SPEED_POLISH_WORST}; 1: the mean, "
                   "as before the ninth session)")
    p.add_argument("--speed-polish-restarts", type=int_within(0, 100), default=SPEED_POLISH_RESTARTS, metavar="K",
                   help="then start the speed polish again from the walker it kept, up to K times, each with a fresh "
                   f"CMA-ES, while each keeps a robust walker (default {SPEED_POLISH_RESTARTS}; 0: as before the tenth "
                   "session)")
    p.add_argument("--speed-polish-with-nominal", action="store_true", help="the model itself among every update's "
                   "robots of the speed polish (a walker tuned to drawn robots alone can fall on it)")
    args = p.parse_args(argv)
    if args.measure:
        test = robustness(args.measure, args.draws)
        measured = {"controller": str(args.measure), "robust": is_robust(test, args.need), "test": test,
                    **after_test(args.measure, lambda line: progress(line, args.json))}
        if args.ship:
            measured["shipped"] = ship(args.measure, measured, args.ship, argv)
        report(measured, args.json)
        return
    if not 0 < args.need <= args.draws:
        p.error(f"--need {args.need}: must be within 1..--draws ({args.draws})")
    out = args.out or Path(tempfile.mkdtemp(prefix="robust-walk-"))
    runs = []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        folder = out / f"seed{seed}"
        done = folder / "result.json"
        r = read_json(done) if done.exists() else None
        if r is not None and (not args.polish or "polish" in r) and (
                not args.speed_polish or next_speed_polish(r, args.speed_polish_restarts) is None):
            progress(f"seed {seed}: done before ({done})", args.json)
        elif r is None:
            r = robust_once(args.config, seed, folder, args.minutes, args.draws, args.need, args.json, args.threads,
                            args.generations)
        # each phase's result stays in result.json until the next one's replaces it
        if args.polish and "polish" not in r:
            r = polish_once(r, folder, args.polish, args.draws, args.need, args.json,
                            speed_leg_s=args.polish_speed_leg_s, min_speed_m_s=args.polish_min_speed,
                            walk_bonus=args.polish_walk_bonus, validation=args.polish_validation,
                            robots=args.polish_robots, sigma=args.polish_sigma, worst=args.polish_worst)
            write_json_atomic(done, r)
        while args.speed_polish and (restart := next_speed_polish(r, args.speed_polish_restarts)) is not None:
            r = speed_polish_once(r, folder, args.speed_polish, args.draws, args.need, args.json,
                                  args.speed_polish_leg_s, args.speed_polish_min_speed,
                                  args.speed_polish_robots, args.speed_polish_sigma, args.speed_polish_validation,
                                  nominal=args.speed_polish_with_nominal, walk_bonus=args.speed_polish_walk_bonus,
                                  worst=args.speed_polish_worst, restart=restart)
            write_json_atomic(done, r)
            r = settle(r, done, seed, args.json)
        r = settle(r, done, seed, args.json)  # a result written before the rule
        runs.append(r)
        progress(f"seed {seed}: robust={r['robust']} minutes={r['minutes']}", args.json)
    result = summary(runs)
    robust = [r for r in runs if r["robust"]]
    if args.ship and robust:
        best = max(robust, key=ship_rank)
        walker = Path(best.get("walker") or Path(best["run_dir"]) / "robust_walker.json")
        result["shipped"] = ship(walker, {"robust": True, "test": best.get("walker_test") or best["tests"][-1],
                                          **best}, args.ship, argv)
    elif args.ship:
        progress("--ship: no robust walker to ship", args.json)
    report(result, args.json)


def settle(r: dict[str, Any], done: Path, seed: int, quiet: bool) -> dict[str, Any]:
    """``r`` after :func:`keep_the_model_walk`, written to ``done`` if that changed it."""
    if (settled := keep_the_model_walk(r)) is not r:
        progress(f"seed {seed}: the speed polish's walker {last_speed_polish(settled)['rejected']}: undone", quiet)
        write_json_atomic(done, settled)
    return settled


def ship(walker: Path, measured: dict[str, Any], path: Path, argv: list[str] | None) -> str:
    """``walker`` as ``path``, with this command and its measures (robustness test, transfer,
    60 s walks) in its provenance."""
    made = {"made_by": command_line("benchmarks.robust_walk", argv), "robust": measured["robust"],
            "robustness": measured["test"], "walk_rate": measured["rate"],
            "transfer_ratio": measured["transfer"]["ratio"], "sustained": {
                where: {k: v for k, v in s.items() if k != "per_episode"} for where, s in measured["sustained"].items()}}
    return ship_controller(walker, path, made)


if __name__ == "__main__":
    main()
