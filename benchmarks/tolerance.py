"""How small a change of its model knocks a walker over: each perturbation alone, at sizes
from a hundredth of a percent up.

    python -m benchmarks.tolerance configs/controllers/human_female_5.json --json
    python -m benchmarks.tolerance configs/controllers/*.json --episodes 20 --sizes 1e-4 1e-3 1e-2 0.1

A controller evolved on one exact model can be a knife-edge trajectory of it: for each
controller, and each perturbation of :data:`KINDS` alone, ``--episodes`` episodes draw it
uniformly within ``size`` of nominal (``1 +- size`` for a scale, per link or per joint as
``sim2real/simulation/reality/randomize.py`` draws it; joint-reading noise of ``size`` x
:data:`NOISE_DEG_AT_1` standard deviation), and the benchmark reports the share that stay
upright for the whole episode (``upright``) and their mean distance.  The nominal episode,
measured in the same call, is the baseline; ``tolerates`` is each perturbation's largest size
at which every episode stays upright (0 when none does; a controller that falls on its
nominal model tolerates nothing).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from benchmarks.common import parser, progress, report
from evolve.replay import evaluate_controller

# a scale drawn within 1 +- size; the noise is absolute, so size 1 is this many degrees
KINDS = ("mass_scale", "torque_scale", "kp_scale", "floor_friction_scale", "joint_noise_deg")
NOISE_DEG_AT_1 = 10.0
SIZES = (1e-4, 1e-3, 1e-2, 1e-1)


def perturbation(kind: str, size: float) -> dict[str, Any]:
    """A reality file's contents: ``kind`` alone, within ``size`` of nominal."""
    if kind == "joint_noise_deg":
        return {"description": f"{kind} {size * NOISE_DEG_AT_1:g}", kind: size * NOISE_DEG_AT_1}
    return {"description": f"{kind} 1 +- {size:g}", kind: [1.0 - size, 1.0 + size]}


def upright_share(walk: dict[str, Any]) -> float:
    """The share of ``walk``'s episodes (an :func:`evaluate_controller` result) upright for the
    whole episode: neither fallen nor ended early (by the stagnation stop or instability)."""
    full = [not e["fell"] and e["upright_s"] >= walk["seconds"] - 1e-9 for e in walk["per_episode"]]
    return sum(full) / len(full)


def measure(controller: Path, sizes: tuple[float, ...], episodes: int, seconds: float | None,
            quiet: bool) -> dict[str, Any]:
    """One controller's nominal walk, and its upright share and distance under each kind and size."""
    nominal = evaluate_controller(controller, seconds=seconds)
    out: dict[str, Any] = {"controller": str(controller), "seconds": nominal["seconds"],
                           "nominal_upright": upright_share(nominal) == 1.0, "nominal_m": nominal["distance_m"],
                           "by_kind": {}, "tolerates": {}}
    for kind in KINDS:
        rows = []
        for size in sizes:
            walk = evaluate_controller(controller, seconds=seconds, episodes=episodes,
                                       randomize=perturbation(kind, size), seed=0)
            rows.append({"size": size, "upright": upright_share(walk),
                         "distance_m": walk["distance_m"], "upright_s": walk["upright_s"]})
            progress(f"{controller.name} {kind} {size:g}: upright {rows[-1]['upright']:.0%}, "
                     f"{walk['distance_m']:.2f} m, {walk['upright_s']:.1f} s", quiet)
        out["by_kind"][kind] = rows
        # the largest size up to which every size tried kept every episode upright
        held = 0.0
        if out["nominal_upright"]:
            for row in rows:
                if row["upright"] < 1.0:
                    break
                held = row["size"]
        out["tolerates"][kind] = held
    return out


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("controllers", nargs="+", type=Path, help="controller files")
    p.add_argument("--sizes", nargs="+", type=float, default=list(SIZES),
                   help="perturbation sizes, ascending (a scale's relative half-width; the joint noise in "
                   f"units of {NOISE_DEG_AT_1:g} deg; default {' '.join(f'{s:g}' for s in SIZES)})")
    p.add_argument("--episodes", type=int, default=10, help="episodes per kind and size (default 10)")
    p.add_argument("--seconds", type=float, help="episode length (default: the controller's task)")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    if args.episodes < 1:
        p.error(f"--episodes must be at least 1, got {args.episodes}")
    if any(s <= 0 or s >= 1 for s in args.sizes) or list(args.sizes) != sorted(args.sizes):
        p.error(f"--sizes must be ascending and each in (0, 1), got {args.sizes}")
    for path in args.controllers:
        if not path.is_file():
            p.error(f"{path}: no such controller file")
    results = [measure(c, tuple(args.sizes), args.episodes, args.seconds, args.quiet) for c in args.controllers]
    report({"controllers": results, "kinds": list(KINDS), "sizes": args.sizes, "episodes": args.episodes,
            "noise_deg_at_1": NOISE_DEG_AT_1}, args.json)


if __name__ == "__main__":
    main()
