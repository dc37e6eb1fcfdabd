"""``biped train ROBOT``: the command line of :mod:`evolve.train`."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from evolve.limits import MAX_THREADS
from evolve.train import CONTROLLER, DEFAULT_MINUTES, STAGES, TrainSettings, train
from sim2real.arg_types import int_within, positive_float_at_most, robot_name, seed
from sim2real.cli.args import output_dir
from sim2real.errors import UsageError

WEEK_MIN = 7 * 24 * 60.0


def add_command(sub: argparse._SubParsersAction) -> None:
    tr = sub.add_parser(
        "train", help="train a robust walker for a robot in one command (NEAT, CMA-ES polish, measures)",
        description="From nothing to a walker that walks straight on robots unlike the model: NEAT until a "
        "champion walks on 8 of 10 unseen randomized robots, a CMA-ES polish of its weights for the walk rate, "
        "one for speed, then the measures (walk rate on 50 unseen robots, 60 s walks, the transfer check through "
        "the simulated bus, a 90 deg turn).  Writes OUT/controller.json with its measures in its provenance; "
        "Ctrl-C leaves a folder that --resume continues.")
    tr.add_argument("robot", type=robot_name, help="a robot name from configs/robots/ (biped robot list) or a robot "
                    "YAML path, e.g. one that biped robot import wrote")
    tr.add_argument("--out", type=output_dir, help="training folder (default: runs/train-<robot>-seed<S>)")
    tr.add_argument("--minutes", type=positive_float_at_most(WEEK_MIN, "a week"), default=DEFAULT_MINUTES,
                    help=f"wall-time budget for every stage together (default {DEFAULT_MINUTES:g}): NEAT gets up to "
                    "45 %%, the walk-rate polish ends by 65 %%, the speed polish by the budget less 8 %% kept for "
                    "the measures")
    tr.add_argument("--seed", type=seed, default=1, help="seed of every stage's search (default 1)")
    tr.add_argument("--threads", type=int_within(0, MAX_THREADS, "each holds a simulation's memory"), default=2,
                    help="simulation threads in every stage, 0 = all cores (default 2)")
    tr.add_argument("--config", default="train", help="NEAT's evolution config: a name in configs/evolve/ or a "
                    "path (default: train, the recipe's)")
    tr.add_argument("--resume", action="store_true", help="continue the training cut in --out (same robot, seed "
                    "and config; --minutes and --threads may change)")
    tr.add_argument("--quiet", action="store_true", help="no progress lines")
    tr.set_defaults(func=cmd_train, check=check_train)


def check_train(args: argparse.Namespace) -> None:
    """Everything that can be checked before a folder is made: the flags, the robot, the config."""
    from evolve.config import config_path
    from evolve.train import TrainSettings, neat_config

    if args.resume and args.out is None:
        raise UsageError("--resume needs --out DIR: the training folder to continue")
    config_path(args.config)
    neat_config(args.robot, TrainSettings(seed=args.seed, threads=args.threads, config=args.config))


def cmd_train(args: argparse.Namespace) -> int:
    robot = args.robot
    if Path(robot).suffix in (".yaml", ".yml"):  # a file: kept by its full path, so a resume from elsewhere finds it
        robot = str(Path(robot).resolve())
    stem = Path(robot).stem if Path(robot).suffix in (".yaml", ".yml") else robot.replace(":", "_")
    out = args.out or Path("runs") / f"train-{stem}-seed{args.seed}"
    settings = TrainSettings(minutes=args.minutes, seed=args.seed, threads=args.threads, config=args.config)
    command = "biped " + shlex.join(sys.argv[1:]) if sys.argv[1:2] == ["train"] else "biped train " + args.robot
    try:
        state = train(robot, out, settings, resume=args.resume, command=command, quiet=args.quiet)
    except KeyboardInterrupt:
        print(f"\ninterrupted: the training in {out} keeps every finished stage and the cut one's checkpoint; "
              f"continue with: biped train {shlex.quote(args.robot)} --out {shlex.quote(str(out))} --resume",
              file=sys.stderr)
        return 130
    measure = state["stages"]["measure"]
    bar = measure["bar"]
    controller = out / CONTROLLER
    done = ", ".join(f"{name} {state['stages'][name]['wall_minutes']:.1f}" for name in STAGES
                     if name in state["stages"])  # (a record older than a stage lacks it)
    print(f"trained in {state['elapsed_s'] / 60:.1f} min ({done}) -> {controller}")
    print("bar: " + ", ".join(f"{k} {'met' if v else 'MISSED'}" for k, v in bar.items()))
    given = f" --robot {shlex.quote(robot)}" if robot != args.robot or Path(robot).suffix else ""
    print("next:")
    print(f"  biped eval {controller}{given} --randomize --episodes 20   # on robots unlike the model")
    print(f"  biped dry-run {controller}{given} --reality default   # the real runtime on the simulated bus")
    print(f"  biped run {controller}{given} --bus mock   # then --port /dev/ttyUSB0 on the robot, see the README")
    return 0
