"""The human-gait arms' runs as a table (RESULTS.md, "Human gait"): one row per finished run.

    python benchmarks/records/human-gait/scripts/arms.py [RUNS]   (RUNS: default runs/human-gait)

A run is a folder ``RUNS/ARM/BODY-seedN/`` holding the ``result.json`` that
``benchmarks.human_walk`` writes; cut runs (no result yet) are listed as such.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path


def fmt(value: float | None, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def body_seed(folder: str) -> str:
    """``human_stepping_speed_female_50-seed2`` -> ``female_50 s2``."""
    found = re.search(r"((?:fe)?male_[^-]+)-seed(\d+)$", folder)
    return f"{found[1]} s{found[2]}" if found else folder


def rows(runs: Path) -> list[str]:
    out = ["| arm | run | walker (generation) | hip swing L / R [deg] | symmetry | flight | double support | "
           "steps /min | 60 s walk | minutes | a walk |", "|" + "---|" * 11]
    for arm in sorted(p for p in runs.iterdir() if p.is_dir()):
        for run in sorted(p for p in arm.iterdir() if p.is_dir()):
            result = run / "result.json"
            if not result.exists():
                out.append(f"| {arm.name} | {body_seed(run.name)} | cut | | | | | | | | |")
                continue
            r = json.loads(result.read_text())
            g = r["gait"]
            walker = f"yes ({r['generation']})" if r["generation"] is not None else "none in 200"
            swing = " / ".join(fmt(g["hip_swing_deg"][side], ".0f") for side in ("left", "right"))
            ended = f"fell at {r['sustained_s']:.1f} s" if r["fell"] else "upright"
            walk = f"{r['sustained_m']:.1f} m, {ended}"
            minutes = "" if r["minutes"] is None else f"{r['minutes']:.1f}"
            out.append(f"| {arm.name} | {body_seed(run.name)} | {walker} | {swing} | {fmt(g['symmetry'], '.2f')} | "
                       f"{fmt(g['flight_share'], '.0%')} | {fmt(g['double_support_share'], '.0%')} | "
                       f"{fmt(g['cadence_steps_min'], '.0f')} | "
                       f"{walk} | {minutes} | {'**yes**' if r['walked'] else 'no'} |")
    return out


if __name__ == "__main__":
    print("\n".join(rows(Path(sys.argv[1] if len(sys.argv) > 1 else "runs/human-gait"))))
