"""How a walker is measured before anyone ships it: robots it never met, long walks, the bus.

Every measure runs the controller file as ``biped eval`` does (:func:`evolve.replay.evaluate_controller`),
on robots no training or validation ever drew (episode seeds ``[TEST_SEED, e]`` and
``[TEST_SEED + 1, e]``, a key shape evolution's and the polish's draws never take):

* :func:`robustness` - the bar a champion must pass to count as a robust walker: in 10 s
  episodes it stays upright and walks at least 2.2 leg lengths on ``need`` (8) of ``draws`` (10)
  robots drawn from ``configs/reality/randomize.yaml``, and on 3 of 3 ``default.yaml`` robots;
* :func:`walk_rate` - the share of 50 more randomized robots it walks on;
* :func:`sustained` - 60 s walks without the stagnation stop: seconds upright, speed and how
  fast the torso turns (deg/min), on the nominal and on ``default.yaml`` robots;
* :func:`steering` - told at 2 s to hold a heading 90 deg to the left, is it there 12 s later;
* the transfer check (:func:`evolve.transfer.transfer_check`): dry runs through the real
  runtime on the simulated Dynamixel bus keep at least 80 % of the simulated distance.

:func:`measure_walker` gathers them; ``biped train``, ``python -m benchmarks.robust_walk`` and the
shipped controllers' provenance all use these functions, so their numbers are the same numbers.
"""

from __future__ import annotations

import statistics
from pathlib import Path
from typing import Any, Callable

from evolve.replay import evaluate_controller
from evolve.transfer import transfer_check
from sim2real.controller.steering import TURN_RATE_DEG_S

TEST_SEED = 314_159  # the robustness test's episode seeds are [TEST_SEED, e]
EPISODE_S = 10.0  # [s] the robustness test's and the walk rate's episodes
SUSTAINED_S = 60.0  # [s] the long walks
SUSTAINED_DEFAULT_ROBOTS = 3  # the long walks on default.yaml (one on the model)
RATE_ROBOTS = 50  # more robots for a walker's walk rate than the bar's 10
DRAWS, NEED = 10, 8  # the robustness bar: walks on NEED of DRAWS unseen randomized robots ...
DEFAULT_EPISODES = 3  # ... and on every one of these default.yaml robots
# the turn test: told at 2 s to hold 90 deg to the left, within 15 deg of it 12 s after the command; the
# heading to hold gets there at steering.TURN_RATE_DEG_S (9 s), which leaves the walker 3 s to follow
STEER_DEG, STEER_AT_S, STEER_TOLERANCE_DEG = 90.0, 2.0, 15.0
STEER_WITHIN_S = STEER_DEG / TURN_RATE_DEG_S + 3.0
TRANSFER_RUNS, TRANSFER_KEEP = 3, 0.8  # dry runs, and the share of the simulated distance they must keep


def robustness(controller: Path, draws: int = DRAWS, default_episodes: int = DEFAULT_EPISODES,
               threads: int = 1, robot: str | None = None) -> dict[str, Any]:
    """The controller on ``draws`` unseen randomized robots and on ``default.yaml``.  ``robot``
    (here and below): its robot's name or file (None: the one the controller names)."""
    keep = ("walked", "distance_m", "min_distance_m", "falls", "upright_s")
    randomized = evaluate_controller(controller, robot, seconds=EPISODE_S, episodes=draws, randomize="randomize",
                                     seed=TEST_SEED, threads=threads)
    default = evaluate_controller(controller, robot, seconds=EPISODE_S, episodes=default_episodes, randomize="default",
                                  seed=TEST_SEED, threads=threads)
    return {"randomized": {k: randomized[k] for k in keep}, "default": {k: default[k] for k in keep},
            "draws": draws, "default_episodes": default_episodes}


def is_robust(test: dict[str, Any], need: int = NEED) -> bool:
    """Whether a :func:`robustness` test passed the bar."""
    return test["randomized"]["walked"] >= need and test["default"]["walked"] == test["default_episodes"]


def sustained(controller: Path, reality: str | None, episodes: int, threads: int = 1,
              robot: str | None = None) -> dict[str, Any]:
    """A 60 s walk without the stagnation stop: seconds upright, distance, speed, and how fast
    it turns (the torso's net turn per minute upright, unwrapped) - means over the episodes."""
    r = evaluate_controller(controller, robot, seconds=SUSTAINED_S, episodes=episodes, randomize=reality,
                            seed=TEST_SEED, stagnation_stop=False, threads=threads)
    per_minute = [abs(e["turn_deg"]) / (e["upright_s"] / 60.0) for e in r["per_episode"] if e["upright_s"] > 0]
    return {"upright_s": r["upright_s"], "distance_m": r["distance_m"], "falls": r["falls"],
            "speed_m_s": r["distance_m"] / r["upright_s"] if r["upright_s"] > 0 else 0.0,
            "heading_deg_per_min": statistics.mean(per_minute) if per_minute else None,
            "per_episode": r["per_episode"]}


def sustained_walks(controller: Path, threads: int = 1, robot: str | None = None) -> dict[str, dict[str, Any]]:
    """The bar's 60 s walks (:func:`sustained`): one on the model (``nominal``) and
    ``SUSTAINED_DEFAULT_ROBOTS`` of ``default.yaml`` (``default``)."""
    return {"nominal": sustained(controller, None, 1, threads=threads, robot=robot),
            "default": sustained(controller, "default", SUSTAINED_DEFAULT_ROBOTS, threads=threads, robot=robot)}


def walk_rate(controller: Path, robots: int = RATE_ROBOTS, threads: int = 1,
              robot: str | None = None) -> dict[str, Any]:
    """The share of ``robots`` more randomized robots (seeds ``[TEST_SEED + 1, e]``) it walks on:
    ten robots are few for a walker that walks on about half of them."""
    r = evaluate_controller(controller, robot, seconds=EPISODE_S, episodes=robots, randomize="randomize",
                            seed=TEST_SEED + 1, threads=threads)
    return {"robots": robots, "walked": r["walked"], "falls": r["falls"], "share": r["walked"] / robots}


def steering(controller: Path, robot: str | None = None) -> dict[str, Any] | None:
    """Told at 2 s to hold a heading 90 deg to the left (the heading to hold turns there at
    :data:`~sim2real.controller.steering.TURN_RATE_DEG_S`), does it get there within 12 s without
    a fall (within 15 deg of it at the end)?  None for a controller without a heading input."""
    from sim2real.controller.file import Controller
    from sim2real.controller.steering import schedule_command

    if not Controller.load(controller).heading_input:
        return None
    command = schedule_command([(0.0, 0.0), (STEER_AT_S, STEER_DEG)])
    r = evaluate_controller(controller, robot, seconds=STEER_AT_S + STEER_WITHIN_S, heading=command, stagnation_stop=False)
    error = r["per_episode"][0]["heading_error_deg"]
    return {"turn_deg": STEER_DEG, "fell": r["fell"], "heading_error_deg": error,
            "reached": not r["fell"] and abs(error) <= STEER_TOLERANCE_DEG}


def measure_walker(walker: Path, log: Callable[[str], None], threads: int = 1,
                   robot: str | None = None, transfer: dict[str, Any] | None = None) -> dict[str, Any]:
    """What is measured of a robust walker: its walk rate on 50 more robots, the transfer check
    (``transfer``: one already made of this walker, whose dry runs are not run again), the 60 s
    walks and (with a heading input) a commanded 90 deg turn."""
    if transfer is None:
        transfer = transfer_check(walker, "default", TRANSFER_RUNS, TRANSFER_KEEP, log, robot=robot)
    return {"rate": walk_rate(walker, threads=threads, robot=robot), "transfer": transfer,
            "sustained": sustained_walks(walker, threads, robot),
            "steering": steering(walker, robot)}


def kept(transfer: dict[str, Any]) -> float:
    """The transfer check's ratio, or 0 when the nominal simulation did not walk: a share kept
    of a walk that never was (a fall on the model) is no transfer."""
    return transfer["ratio"] if transfer["sim_walked"] else 0.0


def heading_deg_per_min(measured: dict[str, Any]) -> float:
    """The worse of the nominal and the default.yaml robots' 60 s walks' turn rates [deg/min]."""
    return max(measured["sustained"][k].get("heading_deg_per_min") or 0.0 for k in ("nominal", "default"))


def meets_bar(measured: dict[str, Any], rate: float = 0.9, max_deg_per_min: float = 30.0,
              min_speed_m_s: float = 0.15, keep: float = TRANSFER_KEEP) -> dict[str, bool]:
    """Each part of the sim-to-real bar a shipped walker must meet: walks on ``rate`` of 50
    unseen robots; over 60 s on the nominal and the default.yaml robots no fall, at most
    ``max_deg_per_min`` of turn and at least ``min_speed_m_s``; keeps ``keep`` through the bus."""
    walks = measured["sustained"].values()
    return {"walk_rate": measured["rate"]["share"] >= rate,
            "straight": all(not w["falls"] and (w.get("heading_deg_per_min") or 0.0) <= max_deg_per_min
                            for w in walks),
            "speed": all(w["speed_m_s"] >= min_speed_m_s for w in walks),
            "transfer": kept(measured["transfer"]) >= keep and bool(measured["transfer"]["passed"])}
