"""The evolution side's ``biped`` subcommands: evolve, eval, export, and controller replay
for view and render."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from evolve.limits import MAX_EPISODE_S, MAX_EVAL_EPISODES, MAX_GENERATIONS, MAX_POPULATION, MAX_THREADS
from evolve.train import POLISH
from sim2real.cli.args import (
    int_within,
    float_within,
    output_dir,
    output_file,
    positive_float_at_most,
    print_result,
    reality_name,
    require_module,
    robot_name,
    seed,
)
from sim2real.arg_types import HEADING_HELP, cluster_address, heading_schedule
from sim2real.errors import UsageError

DEFAULT_CONFIG = "walk"
# A weight of one of selection's terms (polish --straight, --walk-bonus): the shipped recipe's are
# 8 and 20; a weight past a thousand drowns every other term, which is no longer a weighting.
MAX_SELECTION_WEIGHT = 1000.0
SELECTION_WEIGHT_WHY = "past it the term drowns all others"


def add_commands(sub: argparse._SubParsersAction) -> None:
    ev = sub.add_parser("evolve", help="evolve walking controllers in MuJoCo",
                        description="Evolve controllers with NEAT on the locomotion task of Allen & Faloutsos (2009), "
                        "Evolved Controllers for Simulated Locomotion. "
                        "Writes a run folder: config.yaml, checkpoints, stats.csv, fitness.png, controller.json.")
    ev.add_argument("config", nargs="?", default=None,
                    help="evolution config: a name from configs/evolve/ or a YAML path (default: walk)")
    ev.add_argument("--out", type=output_dir, help="run folder (default: runs/<config>-seed<S>)")
    ev.add_argument("--robot", type=robot_name, help="robot to evolve for: a name from configs/robots/ or a robot "
                    "YAML path (overrides the config's; with --resume, the run's robot file given again)")
    ev.add_argument("--set", type=config_override, action="append", default=[], metavar="KEY=VALUE",
                    help="change one config value, a dotted key and a YAML value, e.g. --set task.episode_s=20 "
                    "--set neat.population_size=256 (repeatable)")
    ev.add_argument("--seed", type=seed, help="random seed (overrides the config)")
    ev.add_argument("--generations", type=int_within(1, MAX_GENERATIONS),
                    help=f"generations to run, at most {MAX_GENERATIONS:,} (overrides the config)")
    ev.add_argument("--population", type=int_within(2, MAX_POPULATION, "memory grows with it"),
                    help=f"population size, 2-{MAX_POPULATION:,} (overrides the config)")
    ev.add_argument("--threads", type=int_within(0, MAX_THREADS, "each holds a simulation's memory"),
                    help=f"simulation threads, 0 = all cores, at most {MAX_THREADS} (overrides the config)")
    ev.add_argument("--resume", action="store_true", help="continue the run in --out from its checkpoint")
    ev.add_argument("--backend", choices=("local", "ray"), default="local",
                    help="where simulations run: local (this machine) or ray (a Ray cluster: pip install '.[cluster]'; default: %(default)s)")
    ev.add_argument("--address", type=cluster_address, help="Ray cluster address, HOST:PORT, e.g. 10.0.0.1:6379, "
                    "or auto (default: start a local Ray); checked to answer within a few seconds before the run")
    ev.add_argument("--quiet", action="store_true", help="no progress lines")
    ev.set_defaults(func=cmd_evolve, check=check_evolve)

    ex = sub.add_parser("export", help="write a run's best controller as JSON",
                        description="Write the best controller of a run folder as controller JSON.")
    ex.add_argument("run_dir", type=Path, help="run folder of biped evolve (holding checkpoint.json.gz)")
    ex.add_argument("-o", "--output", type=output_file(".json"), default="controller.json",
                    help="controller file to write (default: controller.json)")
    ex.add_argument("--stage", help="a staged run's finished stage (default: the latest best)")
    ex.set_defaults(func=cmd_export)

    ea = sub.add_parser("eval", help="measure a controller: distance, time upright, falls",
                        description="Run a controller on its robot in MuJoCo (no harness) and report "
                        "distance walked, time upright and whether it fell.")
    ea.add_argument("controller", type=Path, help="controller JSON to replay")
    ea.add_argument("--robot", type=robot_name, help="robot (default: the one the controller was made for)")
    ea.add_argument("--seconds", type=positive_float_at_most(MAX_EPISODE_S, "memory and time grow with it"),
                    help=f"episode length, at most {MAX_EPISODE_S:g} s (default: the controller's task)")
    ea.add_argument("--episodes", type=int_within(1, MAX_EVAL_EPISODES, "memory grows with it"),
                    help=f"episodes, at most {MAX_EVAL_EPISODES:,} (each its own draw when randomized; default 1, "
                    "3 with --ablate)")
    ea.add_argument("--randomize", type=reality_name, nargs="?", const="randomize", metavar="RANGES",
                    help="randomize every episode with these ranges (default configs/reality/randomize.yaml)")
    ea.add_argument("--reality", type=reality_name, metavar="PROFILE", help="a fixed reality profile (configs/reality/ name or path)")
    ea.add_argument("--seed", type=seed, default=0, help="seed of the randomized draws (default: %(default)s)")
    ea.add_argument("--ablate", action="store_true",
                    help="with --reality/--randomize: measure each perturbation alone too, to see which "
                    "one breaks the controller (default 3 episodes)")
    ea.add_argument("--by-perturbation", action="store_true",
                    help="with --randomize: the walk rate by third of each drawn perturbation (use 100 or more "
                    "--episodes), to see where the controller fails")
    ea.add_argument("--disable-module", action="append", default=[], metavar="NAME",
                    help="switch a module off to get the lower behaviour back (repeatable)")
    ea.add_argument("--heading", type=heading_schedule, metavar="DEG|T:DEG,...",
                    help=HEADING_HELP + "; each episode then reports how far it ends from that heading")
    ea.add_argument("--json", action="store_true", help="print one JSON object")
    ea.set_defaults(func=cmd_eval, check=check_eval)

    po = sub.add_parser("polish", help="tune a walker's weights with CMA-ES on many randomized robots",
                        description="Freeze the walker's topology and tune its weights with CMA-ES: every update "
                        "runs each candidate on the same freshly drawn robots; the search's mean is judged every "
                        "few updates on fixed validation robots, the best kept; at the end the kept weights and "
                        "the original are judged on fresh robots.  Writes OUT/polished.json and OUT/result.json, and "
                        "OUT/checkpoint.json after every update (--resume continues a cut polish).")
    po.add_argument("controller", type=Path, help="the walker whose weights to polish (controller JSON)")
    po.add_argument("--out", type=output_dir, required=True, help="folder for polished.json and result.json")
    po.add_argument("--updates", type=int_within(1, 100_000), default=60, help="CMA-ES updates (default 60)")
    # the defaults are biped train's walk-rate polish (evolve.train.POLISH)
    po.add_argument("--popsize", type=int_within(2, 1024), default=POLISH["popsize"],
                    help="candidates an update (default %(default)s)")
    po.add_argument("--robots", type=int_within(1, 1024), default=POLISH["robots"], help="robots each candidate "
                    "meets in an update, the same for all (default %(default)s)")
    po.add_argument("--sigma", type=positive_float_at_most(20.0, "weights are bounded by 20"), default=POLISH["sigma"],
                    help="CMA-ES's first step size in weight units (default %(default)s)")
    po.add_argument("--every", type=int_within(1, 100_000), default=5,
                    help="validate every this many updates (default 5)")
    po.add_argument("--validation", type=int_within(1, 10_000), default=POLISH["validation"],
                    help="validation robots (default %(default)s)")
    po.add_argument("--test", type=int_within(1, 10_000), default=100, help="fresh test robots (default 100)")
    po.add_argument("--randomize", type=reality_name, action="append", metavar="RANGES",
                    help="ranges the robots are drawn from (default configs/reality/randomize.yaml); given "
                    "more than once, the robots of every draw take turns at them (wide ranges for the walk "
                    "rate, narrow ones for a walk near the model)")
    po.add_argument("--seed", type=seed, default=0, help="seed of the search and every draw (default: %(default)s)")
    po.add_argument("--episode-s", type=positive_float_at_most(MAX_EPISODE_S), metavar="S",
                    help="episodes of this length [s] (default: the controller's task's); longer ones show circling")
    po.add_argument("--straight", type=float_within(0.0, MAX_SELECTION_WEIGHT, SELECTION_WEIGHT_WHY), metavar="C",
                    help="weigh selection's straight term so (selection_straight_coeff; default: the task's)")
    po.add_argument("--heading-deg", type=positive_float_at_most(180.0), metavar="DEG",
                    help="count a walk only if the torso never turned further than this (default: any)")
    po.add_argument("--speed-leg-s", type=positive_float_at_most(5.0, "leg lengths a second"), metavar="V",
                    help="the velocity kernel's target speed [leg lengths/s] (selection_speed_leg_s; default: "
                    "the task's); above the goal's speed so that selection pays for reaching it")
    po.add_argument("--min-speed", type=positive_float_at_most(5.0, "m/s"), metavar="M_S",
                    help="count a walk only if it averaged at least this speed [m/s] over its episode (default: any)")
    po.add_argument("--walk-bonus", type=float_within(0.0, MAX_SELECTION_WEIGHT, SELECTION_WEIGHT_WHY), metavar="B",
                    help="what selection pays an episode that walks (selection_walk_bonus; default: the task's); "
                    "a larger one trades speed for the walk rate")
    po.add_argument("--lr-adapt", action="store_true", help="CMA-ES with learning-rate adaptation (Nomura et "
                    "al. 2023), for a noisy walk rate")
    po.add_argument("--worst", type=positive_float_at_most(1.0, "a share of the robots"), default=1.0, metavar="SHARE",
                    help="rank candidates by their mean score on the worst SHARE of the update's robots (a CVaR: "
                    "the robots a walker fails on weigh more; default 1: the mean over all)")
    po.add_argument("--with-nominal", action="store_true",
                    help="every candidate meets the nominal robot too in each update (randomized draws seldom "
                    "resemble it)")
    po.add_argument("--resume", action="store_true", help="continue the polish cut in --out from its checkpoint "
                    "(the same walker and settings; --updates may grow)")
    po.add_argument("--json", action="store_true", help="print the result as one JSON object")
    po.set_defaults(func=cmd_polish)

    ad = sub.add_parser("adapt", help="continue evolving a walker on a robot biped sysid identified",
                        description="Grow a population from the walker and evolve it on robots drawn from narrow "
                        "ranges around the identified robot (no harness, full strength from the start, the champion "
                        "chosen on validation robots), until --generations or --minutes; then judge the champion on "
                        "fresh robots around it and with the transfer check through the simulated bus on the "
                        "identified profile.  The loop: excite -> sysid -> adapt -> dry-run -> run.")
    ad.add_argument("controller", type=Path, help="the walker to adapt (controller JSON)")
    ad.add_argument("--reality", type=reality_name, required=True, metavar="IDENTIFIED",
                    help="the identified robot: a reality file of fixed values, as biped sysid writes")
    ad.add_argument("--out", type=output_dir, required=True, help="run folder (controller.json, adapt.json)")
    ad.add_argument("--ranges", type=reality_name, default="narrow",
                    help="ranges drawn around the identified robot (default configs/reality/narrow.yaml)")
    ad.add_argument("--generations", type=int_within(1, MAX_GENERATIONS), default=100,
                    help="generations to evolve, unless --minutes ends it first (default %(default)s)")
    ad.add_argument("--minutes", type=positive_float_at_most(7 * 24 * 60, "a week"), help="stop after this many minutes of evolution (default: no limit but --generations)")
    ad.add_argument("--population", type=int_within(2, MAX_POPULATION, "memory grows with it"), default=64,
                    help="population size, grown from the walker and mutated copies of it (default %(default)s)")
    ad.add_argument("--episodes", type=int_within(1, 64), default=3,
                    help="robots each genome meets a generation (default %(default)s)")
    ad.add_argument("--validation", type=int_within(1, 1000), default=20, help="validation robots (default 20)")
    ad.add_argument("--test", type=int_within(1, 10_000), default=50, help="fresh robots to judge on (default 50)")
    ad.add_argument("--seed", type=seed, default=1, help="seed of the evolution and every draw (default %(default)s)")
    ad.add_argument("--threads", type=int_within(0, MAX_THREADS, "each holds a simulation's memory"), default=0,
                    help="simulation threads, 0 = all cores (default %(default)s)")
    ad.add_argument("--json", action="store_true", help="print the result as one JSON object")
    ad.set_defaults(func=cmd_adapt)


def cmd_render_controller(args: argparse.Namespace) -> int:
    from evolve.replay import frames
    from sim2real.simulation.rendering import save_video

    images, frame_s = frames(Path(args.robot), args.width, args.height, seconds=args.seconds,
                             every=2 if args.output.suffix.lower() == ".gif" else 1,
                             disabled_modules=tuple(args.disable_module))
    save_video(args.output, images, frame_s)
    print(f"wrote {args.output} ({len(images)} frames, {len(images) * frame_s:.1f} s)")
    return 0


def cmd_view_controller(args: argparse.Namespace) -> int:
    import time

    import mujoco
    import mujoco.viewer

    from evolve.replay import controller_setup

    data, _, evaluator, genome = controller_setup(Path(args.robot), None, None, keep_going=True,
                                        disabled_modules=tuple(args.disable_module), robot_flag=None)
    shown = mujoco.MjData(evaluator.model)
    with mujoco.viewer.launch_passive(evaluator.model, shown) as viewer:
        while viewer.is_running():
            start = time.monotonic()

            def show(ev, alive, t0=start):
                d = ev.batch.get_data(0)
                shown.qpos[:], shown.qvel[:] = d.qpos, d.qvel
                mujoco.mj_forward(ev.model, shown)
                viewer.sync()
                time.sleep(max(0.0, t0 + d.time - time.monotonic()))  # real time

            evaluator.evaluate([genome], data.sigmoid_steepness, on_tick=show,
                               disabled_modules=tuple(args.disable_module))
    return 0


def cmd_render_strip(args: argparse.Namespace) -> int:
    from evolve.replay import strip
    from sim2real.figures.strip import save_strip

    rows, times, labels = strip(args.strip, args.frames, args.seconds, args.width, args.height)
    save_strip(args.output, rows, times, labels)
    print(f"wrote {args.output} ({len(rows)} walkers x {len(times)} moments, {times[-1]:.1f} s)")
    return 0


def replay_gait(path: Path, **options):
    from evolve.replay import gait

    return gait(path, **options)


def replay_reach(path: Path, **options):
    from evolve.replay import reach

    return reach(path, **options)


# ``biped view``/``render`` of a controller file, ``render --strip``, ``plot gait`` and ``plot
# reach`` of a controller: replays, which sim2real's commands call through these
REPLAY = {"view": cmd_view_controller, "render": cmd_render_controller, "strip": cmd_render_strip,
          "gait": replay_gait, "reach": replay_reach}


def config_override(text: str) -> tuple[str, object]:
    """``--set KEY=VALUE``, checked as a config key and a YAML value."""
    from evolve.config import parse_override

    try:
        return parse_override(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def check_evolve(args: argparse.Namespace) -> None:
    if args.resume:
        if args.out is None:
            raise UsageError("--resume needs --out RUN_DIR")
        if args.seed is not None or args.population is not None:
            raise UsageError("--seed and --population cannot change when resuming")
        if args.config is not None or args.set:  # --robot FILE: the run's robot file, given again
            given = args.config or "--set"
            raise UsageError(f"--resume continues the run in --out with its own config.yaml; do not give a "
                             f"config or --set ({given})")
    if args.address is not None and args.backend != "ray":
        raise UsageError("--address is the Ray cluster's: it needs --backend ray")
    if args.backend == "ray":
        require_module("ray", "--backend ray", extra="cluster")
        if args.address is not None:
            from evolve.ray_backend import check_reachable

            check_reachable(args.address)  # before anything runs: Ray's own connect waits a minute or more


def cmd_evolve(args: argparse.Namespace) -> int:
    from evolve.config import config_path, load_evolve_config
    from evolve.run import Run

    log = (lambda s: None) if args.quiet else (lambda s: print(s, flush=True))
    if args.resume:
        run = Run.resume(args.out, generations=args.generations, threads=args.threads, log=log, robot=args.robot,
                         backend=args.backend, address=args.address)
        log(f"resuming {args.out} at generation {run.population.generation}")
    else:
        path = config_path(args.config or DEFAULT_CONFIG)
        overrides = dict(args.set)
        if args.robot is not None:
            overrides["robot"] = args.robot
        config = load_evolve_config(path, overrides)
        if args.generations is not None and config.stages:
            raise UsageError(f"--generations: {path} is a staged config; each stage has its own budget "
                             "(stages[].generations)")
        changes = {k: getattr(args, k) for k in ("seed", "generations", "threads") if getattr(args, k) is not None}
        if args.population is not None:
            neat = config.neat.replace(population_size=args.population,
                                       target_species=min(config.neat.target_species, max(1, args.population // 4)))
            changes["neat"] = neat
        config = config.replace(**changes)
        if args.population is not None:  # within its own bound, but with the config's episodes?
            from evolve.config import check_sizes
            from sim2real.errors import ConfigError
            from sim2real.simulation.model.physique import load_measured

            try:
                check_sizes(config, load_measured(config.robot), str(path))
            except ConfigError as exc:
                raise UsageError(f"--population {args.population}: {exc.problem}") from None
        out = args.out or Path("runs") / f"{path.stem}-seed{config.seed}"
        run = Run.create(config, out, log=log, backend=args.backend, address=args.address)
        log(f"evolving {config.robot} ({config.task.control_set} joints), population "
            f"{config.neat.population_size}, {config.generations} generations -> {out}")
    from evolve.config import robot_is_a_file

    again = f" --robot {run.config.robot}" if robot_is_a_file(run.config) else ""
    try:
        best = run.evolve()
    except KeyboardInterrupt:
        print(f"\ninterrupted: checkpoint of generation {run.checkpoint_generation} is in {run.out}; "
              f"continue with: biped evolve --resume --out {run.out}{again}", file=sys.stderr)
        return 130
    if best is not None:
        v = best.validation
        where = f"mean of {v['draws']} validation robots, walked on {v['walked']}; " if v else ""
        log(f"best: fitness {best.fitness:.3f}, {best.distance_m:.3f} m, upright {best.upright_s:.1f} s "
            f"({where}generation {best.generation}{', harness' if best.harness else ''}) -> {run.out / 'controller.json'}")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from sim2real.controller.file import Controller

    if not args.run_dir.is_dir():
        raise FileNotFoundError(f"{args.run_dir}: no such run folder")
    source = args.run_dir / "controller.json"
    if args.stage:
        source = args.run_dir / "stages" / args.stage / "controller.json"
        if not source.exists():
            done = sorted(p.name for p in (args.run_dir / "stages").glob("*")) if (args.run_dir / "stages").is_dir() else []
            raise FileNotFoundError(f"{args.run_dir}: no finished stage {args.stage!r} "
                                    f"(finished: {', '.join(done) or 'none'}; the running stage's best is controller.json)")
    if not source.exists():
        raise FileNotFoundError(f"{args.run_dir} has no controller.json yet (has the run finished a generation?)")
    Controller.load(source).save(args.output)
    print(f"wrote {args.output}")
    return 0


def check_eval(args: argparse.Namespace) -> None:
    if args.randomize and args.reality:
        raise UsageError("eval: give --randomize RANGES or --reality PROFILE, not both")
    if args.ablate and (args.randomize or args.reality or "nominal") == "nominal":
        raise UsageError("eval --ablate: give the reality to take apart, --reality PROFILE or --randomize")
    if args.by_perturbation and not args.randomize:
        raise UsageError("eval --by-perturbation: give --randomize (the draws to sort the episodes by)")
    if args.by_perturbation and args.ablate:
        raise UsageError("eval: --by-perturbation or --ablate, not both")
    if args.heading is not None and args.ablate:
        raise UsageError("eval: --heading or --ablate, not both")
    if args.ablate or args.by_perturbation:  # walk rates and distances: a walker's measures
        from sim2real.controller.file import Controller
        from sim2real.controller.purpose import require_walker

        flag = "--ablate" if args.ablate else "--by-perturbation"
        require_walker(Controller.load(args.controller), str(args.controller), f"biped eval {flag}",
                       "it sorts the robots that walk, and how far, by what was perturbed")


def cmd_adapt(args: argparse.Namespace) -> int:
    from evolve.adapt import adapt

    log = (lambda line: None) if args.json else (lambda line: print(line, file=sys.stderr, flush=True))
    result = adapt(args.controller, args.reality, args.out, ranges=args.ranges, generations=args.generations,
                   minutes=args.minutes, population=args.population, episodes=args.episodes,
                   validation=args.validation, test=args.test, seed=args.seed, threads=args.threads, log=log)
    if args.json:
        print(json.dumps(result))
    return 0


def cmd_polish(args: argparse.Namespace) -> int:
    require_module("cmaes", "biped polish", extra="sim")
    from evolve.polish import CHECKPOINT, polish

    log = (lambda line: None) if args.json else (lambda line: print(line, file=sys.stderr, flush=True))
    try:
        result = polish(args.controller, args.out, updates=args.updates, popsize=args.popsize, robots=args.robots,
                        sigma=args.sigma, every=args.every, validation=args.validation, test=args.test,
                        seed=args.seed, reality=args.randomize or "randomize", episode_s=args.episode_s,
                        straight=args.straight, heading_deg=args.heading_deg, speed_leg_s=args.speed_leg_s,
                        min_speed_m_s=args.min_speed, walk_bonus=args.walk_bonus, nominal=args.with_nominal,
                        lr_adapt=args.lr_adapt, worst=args.worst, resume=args.resume, log=log)
    except KeyboardInterrupt:
        if (args.out / CHECKPOINT).exists():
            print(f"\ninterrupted: the polish's checkpoint is in {args.out}; continue with the same command and "
                  "--resume", file=sys.stderr)
        return 130
    if args.json:
        print(json.dumps(result))
    return 0


def print_gaits(gaits: dict) -> None:
    """``biped eval``'s gait lines: how many episodes walk a walk, then each one's measures."""
    from sim2real.gait_measures import GaitMeasures, SKIP_S, describe

    if "unmeasured" in gaits:
        print(f"gait: not measured ({gaits['unmeasured']})")
        return
    episodes = gaits["per_episode"]
    print(f"gait: {gaits['walks']} of {len(episodes)} episodes walk a walk (first {SKIP_S:g} s skipped)")
    for e, measures in enumerate(episodes):
        print(f"  episode {e}: {describe(GaitMeasures.from_dict(measures))}")


def cmd_eval(args: argparse.Namespace) -> int:
    from evolve.replay import ablate_controller, evaluate_controller

    reality = args.randomize or args.reality
    options = {"robot": args.robot, "seconds": args.seconds, "disabled_modules": tuple(args.disable_module)}
    if not args.ablate:
        result = evaluate_controller(args.controller, episodes=args.episodes or 1, randomize=reality,
                                     seed=args.seed, by_perturbation=args.by_perturbation, heading=args.heading,
                                     gait_measures=True, **options)
        table = result.pop("by_perturbation", None)
        if args.json:
            print(json.dumps({**result, **({"by_perturbation": table} if table is not None else {})}))
            return 0
        gaits = result.pop("gait")
        print_result(result, False)
        print_gaits(gaits)
        if table is not None:
            print(f"{'walked in the low / middle / high third of':>44}  correlation")
            for key, row in sorted(table.items(), key=lambda item: -abs(item[1]["correlation"])):
                rates = " / ".join(f"{r:.2f}" for r in row["walked_by_third"])
                print(f"{key:>28} {rates:>18}  {row['correlation']:+.2f}")
        return 0
    try:
        report = ablate_controller(args.controller, reality, episodes=args.episodes or 3, seed=args.seed, **options)
    except UsageError:
        raise
    except ValueError as exc:
        raise UsageError(f"eval --ablate: {exc}") from None
    if args.json:
        print(json.dumps(report))
        return 0
    print(f"{args.controller} on {report['reality']}, {report['episodes']} episodes (seed {report['seed']}):")
    print(f"{'perturbation':>22} {'value':>14} {'distance m':>10} {'min m':>7} {'falls':>5} {'walked':>6}")
    rows = [("nominal", "", report["nominal"]), ("all together", "", report["all"])]
    rows += [(key, str(row.pop("value")), row) for key, row in report["only"].items()]
    for name, value, r in rows:
        print(f"{name:>22} {value:>14} {r['distance_m']:10.3f} {r['min_distance_m']:7.3f} {r['falls']:5d} "
              f"{r['walked_share']:6.0%}")
    return 0
