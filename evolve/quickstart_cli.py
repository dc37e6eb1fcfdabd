"""``biped quickstart``: the whole job once, on the default robot, in a few minutes.

The process and the result: a short evolution (``configs/evolve/walk.yaml``, fewer
generations) and its best controller exported; then the project's own walker for the robot
(``configs/controllers/<robot>.json``, evolved by the robust-walk benchmark) filmed,
dry-run through the real runtime on the simulated Dynamixel bus under a reality profile - a
robot that is not the model - and that trace compared with the simulation, ending with where
every file is and what to do next.  A short run does not walk yet: run ``biped evolve
--resume`` on its folder to continue it.  A robot without a shipped walker films and
dry-runs the short run's best instead.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from evolve.limits import MAX_GENERATIONS, MAX_POPULATION
from sim2real.cli.args import (
    holding_lock,
    int_within,
    output_dir,
    reality_name,
    require_module,
    run_failed,
    seed,
)


def add_command(sub: argparse._SubParsersAction) -> None:
    q = sub.add_parser("quickstart", help="evolve, export, film, dry-run and compare, once, in a few minutes",
                       description=__doc__.split("\n\n")[1].replace("\n", " ").replace("``", ""))
    q.add_argument("--out", type=output_dir, default="runs/quickstart",
                   help="folder for everything (default: runs/quickstart)")
    q.add_argument("--generations", type=int_within(1, MAX_GENERATIONS), default=12,
                   help="generations of the short evolution (default 12)")
    q.add_argument("--population", type=int_within(2, MAX_POPULATION, "memory grows with it"), default=48,
                   help="population size (default 48)")
    q.add_argument("--reality", type=reality_name, default="default", help="reality profile of the dry run (default: default)")
    q.add_argument("--seed", type=seed, default=1, help="seed of the short evolution (default 1)")
    q.add_argument("--no-video", action="store_true", help="skip the video (no offscreen GL here)")
    q.set_defaults(func=cmd_quickstart, check=check_quickstart)


def check_quickstart(args: argparse.Namespace) -> None:
    """What would fail only minutes in - the packages for the video and the plot - is
    checked before the evolution starts (the reality profile, by its converter)."""
    require_module("matplotlib", "the comparison plot")
    if not args.no_video:
        require_module("imageio", "the video (or give --no-video)")
        require_module("imageio_ffmpeg", "the .mp4 video (or give --no-video)")


@holding_lock("out", what="biped quickstart", folder=True, flag="--out")  # its run folder has its own
def cmd_quickstart(args: argparse.Namespace) -> int:
    from evolve.config import config_path
    from evolve.config import load_evolve_config
    from evolve.replay import evaluate_controller
    from evolve.run import Run
    from sim2real.controller.file import Controller
    from sim2real.hardware.realtime import RealtimeRequest
    from sim2real.robot.paths import shipped_controller
    from sim2real.simulation.transfer.compare import compare, plot
    from sim2real.simulation.transfer.dry_run import dry_run

    out: Path = args.out
    config = load_evolve_config(config_path("walk"))
    neat = config.neat.replace(population_size=args.population,
                               target_species=min(config.neat.target_species, max(1, args.population // 6)))
    config = config.replace(seed=args.seed, generations=args.generations, neat=neat)
    run_dir = out / "run"

    def step(n: int, text: str) -> None:
        print(f"\n[{n}/5] {text}", flush=True)

    step(1, f"evolving {args.generations} generations of {args.population} on {config.robot} -> {run_dir}")
    run = Run.resume(run_dir, log=print) if (run_dir / "checkpoint.json.gz").exists() else \
        Run.create(config, run_dir, log=print)
    run.evolve()

    step(2, "exporting the best controller")
    evolved = out / "controller.json"
    Controller.load(run_dir / "controller.json").save(evolved)
    sim = evaluate_controller(evolved)
    print(f"{evolved}: {sim['distance_m']:+.3f} m in {sim['seconds']:.1f} s in simulation, fell={sim['fell']} "
          f"(a short run; a walker takes longer)")
    controller, shipped = evolved, shipped_controller(config.robot)
    if shipped.exists():
        controller = out / "walker.json"
        Controller.load(shipped).save(controller)
        sim = evaluate_controller(controller)
        print(f"the project's walker for {config.robot} ({shipped}) -> {controller}: {sim['distance_m']:+.3f} m in "
              f"{sim['seconds']:.1f} s in simulation, fell={sim['fell']}; the next steps use it")

    video = out / "walk.mp4"
    if args.no_video:
        step(3, "video skipped (--no-video)")
        video = None
    else:
        step(3, f"filming it -> {video}")
        from evolve.replay import frames
        from sim2real.simulation.rendering import save_video

        images, frame_s = frames(controller, 640, 480)
        save_video(video, images, frame_s)

    step(4, f"dry run through the real runtime on the simulated Dynamixel bus, reality profile {args.reality!r}")
    trace = out / "dry_run.csv"
    result = dry_run(controller, duration_s=sim["seconds"], trace_path=trace, reality=args.reality,
                     log=lambda line: print("  " + line), realtime=RealtimeRequest())
    print(json.dumps({k: result[k] for k in ("distance_m", "fell", "ticks", "overruns", "bus_errors", "stop_reason")}))
    if result["stop_reason"] != "duration reached":
        return run_failed(f"the dry run stopped early: {result['stop_reason']}")
    if result["unstable"]:
        return run_failed(f"the dry run's simulated robot went {result['unstable']}: no result to compare")

    step(5, "comparing the dry-run trace with the nominal simulation")
    compared = compare(trace, controller_path=controller)
    plot_path = out / "compare.png"
    plot(compared, plot_path)
    worst = max(compared["joints"].items(), key=lambda kv: kv[1]["rmse_deg"])
    print(f"contact agreement {compared['contact_agreement']:.1%}; largest joint RMSE {worst[1]['rmse_deg']:.2f} deg "
          f"({worst[0]})")

    files = [("controller.json", "the short run's controller (versioned JSON; Controller.load / biped run)")]
    if controller != evolved:
        files.append(("walker.json", "the project's walker: filmed, dry-run and compared above"))
    files += [("run/", f"the evolution: stats.csv, fitness.png, checkpoints (continue: biped evolve --resume "
                       f"--out {run_dir} --generations 400)"),
              ("walk.mp4", f"{controller.name} in simulation") if video else ("(no video)", ""),
              ("dry_run.csv", "the dry run's trace (+ .json sidecar)"),
              ("compare.png", f"real-vs-simulated joint angles; the numbers: biped compare {trace} --json")]
    listing = "\n".join(f"  {name:<17} {what}" for name, what in files)
    print(f"""
done.  In {out}/:
{listing}
next: a robust walker (biped train xl430_biped --out runs/train; see the README for how long),
then biped dry-run runs/train/controller.json --reality default, then on the robot:
      biped run {controller} --port /dev/ttyUSB0 --trace real.csv && biped compare real.csv --plot real.png""")
    return 0
