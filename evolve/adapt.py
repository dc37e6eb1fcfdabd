"""Identify, then adapt: continue evolving a walker on the robot ``biped sysid`` identified.

A walker evolved on the model meets a real robot that differs from it; ``biped sysid`` fits
the simulation to the robot's own traces and writes that robot as a reality profile.
``biped adapt`` then grows a population from the walker (itself and copies with their weights
mutated once: :meth:`evolve.neat.Population.from_genome`) and evolves it on robots drawn from
narrow ranges around the identified one (``configs/reality/narrow.yaml`` centred on it: the
ranges follow the identified robot, not the model) - every genome on ``episodes`` such robots,
at full strength from the first generation, no harness, the champion chosen on validation
robots - until the budget (generations or minutes).  Then its champion is judged as a walker
for that robot: the share of ``test`` fresh robots around it that it walks on, and the
transfer check through the simulated bus (``evolve/transfer.py``) on the identified profile
itself.  The README's loop: ``excite`` -> ``sysid`` -> ``adapt`` -> ``dry-run`` -> ``run``.

    result = adapt(Path("walker.json"), Path("identified.yaml"), Path("runs/adapt"), minutes=20)
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Any, Callable, Mapping

from evolve.config import EvolveConfig, RandomizeConfig, ValidationConfig
from evolve.locomotion.evaluator import neat_layout
from evolve.locomotion.export import genome_from_controller
from evolve.neat import NeatConfig, Population
from evolve.replay import controller_task, evaluate_controller
from evolve.run import Run
from evolve.transfer import transfer_check
from sim2real.atomic_json import write_json_atomic
from sim2real.controller.file import Controller
from sim2real.controller.purpose import require_walker
from sim2real.simulation.model.physique import measured
from sim2real.simulation.reality.file import centred, load_reality
from sim2real.run_lock import RunLock, holds_folder

TEST_SEED = 271_828  # the judging robots' episode seeds [TEST_SEED, e]: no training or validation key


def evolved_with_side_bias(data: Controller) -> bool:
    """Whether the run that made ``data`` let links leave the side bias node, as its provenance
    records (``config.neat.side_bias``; yes when it does not say): an adapted walker keeps the
    rule, so two networks that differed only by what they sense still do."""
    config = data.provenance.get("config")
    neat = config.get("neat") if isinstance(config, Mapping) else None
    return not (isinstance(neat, Mapping) and neat.get("side_bias") is False)


@holds_folder("out", what="biped adapt")  # held to adapt.json, past the run's own lock
def adapt(controller: Path, identified: str | Path, out: Path, *, ranges: str = "narrow", generations: int = 100,
          minutes: float | None = None, population: int = 64, episodes: int = 3, validation: int = 20,
          test: int = 50, seed: int = 1, threads: int = 0, episode_s: float | None = None, transfer_runs: int = 3,
          log: Callable[[str], None] = print, lock: RunLock | None = None) -> dict[str, Any]:
    """Adapt the walker in ``controller`` to the robot of the reality file ``identified`` (fixed
    values: what ``biped sysid`` writes); the run folder is ``out`` (``out/controller.json`` the
    adapted walker, ``out/adapt.json`` the result, also returned).  ``episode_s``: episodes of
    this length [s] (default the walker's task's); ``transfer_runs``: dry runs of the check.
    ``out`` is locked from start to end (a second adapt into it is refused, naming this
    process); ``lock``: that lock, handed down by :func:`~sim2real.run_lock.holds_folder`."""
    controller = Path(controller)
    data, robot = Controller.load_for_robot(controller, robot_flag=None)
    robot = measured(robot)
    require_walker(data, str(controller), "biped adapt", "it evolves a walk on robots around the identified one "
                   "and judges it by their walk rate and the transfer check's distance")
    centre = load_reality(identified)
    around = centred(load_reality(ranges), centre)  # refused here, with the file named, unless fixed values
    task = controller_task(data, str(controller))
    task = dataclasses.replace(task, harness_generations=0, harness_fade_generations=0,
                               episode_s=episode_s or task.episode_s)
    randomize = RandomizeConfig(reality=ranges, episodes=episodes, centre=str(identified),
                                validation=ValidationConfig(draws=validation, every=5, candidates=8, consistency=0.8))
    config = EvolveConfig(robot=data.robot_name, seed=seed,  # a project robot's name (load_for_robot)
                          generations=generations, threads=threads, task=task,
                          neat=NeatConfig(population_size=population, sigmoid_steepness=data.sigmoid_steepness,
                                          side_bias=evolved_with_side_bias(data)),
                          randomize=randomize)
    grown = Population.from_genome(config.neat, neat_layout(data.layout(robot)), seed, genome_from_controller(data))
    started = time.monotonic()
    run = Run.create(config, out, log=log, population=grown, lock=lock)
    log(f"adapting {controller.name} to {centre.name}: {population} genomes from it, {episodes} robots each "
        f"from {ranges} around the identified robot, {generations} generations"
        + (f" or {minutes:g} minutes" if minutes else ""))
    stop = None
    if minutes:
        stop = lambda run, row: time.monotonic() - started > 60.0 * minutes  # noqa: E731
    run.evolve(stop)
    walker = out / "controller.json"
    judged = evaluate_controller(walker, seconds=task.episode_s, episodes=test, randomize=around, seed=TEST_SEED)
    before = evaluate_controller(controller, seconds=task.episode_s, episodes=test, randomize=around, seed=TEST_SEED)
    transfer = transfer_check(walker, str(identified), transfer_runs, 0.8, log, simulated=str(identified))
    result = {"controller": str(controller), "identified": str(identified), "ranges": ranges,
              "walker": str(walker), "minutes": (time.monotonic() - started) / 60,
              "generations": run.population.generation,
              "walk_rate": {"robots": test, "before": before["walked_share"], "after": judged["walked_share"]},
              "transfer": {k: transfer[k] for k in ("ratio", "passed", "sim_walked", "sim_distance_m",
                                                    "dry_run_distance_m")}}
    write_json_atomic(out / "adapt.json", result)
    log(f"walks on {judged['walked_share']:.0%} of {test} robots around {centre.name} (the walker it came from: "
        f"{before['walked_share']:.0%}); transfer ratio {transfer['ratio']:.2f} "
        f"({'passed' if transfer['passed'] else 'not passed'})")
    return result
