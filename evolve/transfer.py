"""The transfer check: does a controller keep its gait on a perturbed robot behind the bus?

The controller's distance in simulation (``biped eval``: the nominal robot, or the fixed
profile ``simulated`` - the robot it was evolved for) against dry runs of the same length
through the real runtime on the simulated Dynamixel bus under a reality profile (``biped
dry-run --reality``), one per seed of the profile's random parts.  It passes when the
controller walks in simulation (upright, 2.2 leg lengths), the mean dry-run distance keeps at
least ``keep`` (80 %) of the simulated one and no dry run falls.  ``python -m
benchmarks.transfer`` runs it from the command line; ``biped adapt`` asks it of its walker.
"""

from __future__ import annotations

import statistics
from pathlib import Path
from typing import Any, Callable

from evolve.replay import evaluate_controller
from sim2real.simulation.transfer.dry_run import dry_run


def transfer_check(controller: Path, reality: str = "default", runs: int = 3, keep: float = 0.8,
                   log: Callable[[str], None] = print, simulated: str | None = None,
                   robot: str | None = None) -> dict[str, Any]:
    """The controller's simulated distance (on the nominal robot, or on the fixed profile
    ``simulated``: the robot it was evolved for) against ``runs`` dry runs of the same length on
    the simulated bus under ``reality`` (noise seeds 0..runs-1); see the module docstring.
    ``robot``: its robot's name or file (None: the one the controller names)."""
    sim = evaluate_controller(controller, robot, randomize=simulated)
    log(f"simulation: {sim['distance_m']:.3f} m in {sim['seconds']:.1f} s, fell={sim['fell']}")
    dry = []
    for seed in range(runs):
        r = dry_run(controller, robot, duration_s=sim["seconds"], reality=reality, seed=seed, log=lambda line: None)
        if r["unstable"]:  # no distance to average
            raise RuntimeError(f"dry run {seed} ({reality}): the simulated robot went {r['unstable']}")
        log(f"dry run {seed} ({reality}): {r['distance_m']:.3f} m, facing {r['heading_deg']:+.0f} deg, "
            f"fell={r['fell']}, stop: {r['stop_reason']}, bus errors {r['bus_errors']}, overruns {r['overruns']}")
        dry.append({k: r[k] for k in ("distance_m", "heading_deg", "fell", "ticks", "overruns", "bus_errors",
                                      "stop_reason")})
    mean = statistics.mean(r["distance_m"] for r in dry)
    ratio = mean / sim["distance_m"] if sim["distance_m"] > 0 else 0.0
    walked = sim["walked_share"] == 1.0  # without a walk in simulation there is no distance to keep
    return {
        "controller": str(controller), "reality": reality, "simulated": simulated or "nominal",
        "sim_distance_m": sim["distance_m"], "sim_fell": sim["fell"], "seconds": sim["seconds"],
        "dry_run_distance_m": mean, "dry_run_min_m": min(r["distance_m"] for r in dry),
        "ratio": ratio, "keep": keep, "sim_walked": walked,
        "passed": walked and ratio >= keep and not any(r["fell"] for r in dry),
        "runs": dry,
    }
