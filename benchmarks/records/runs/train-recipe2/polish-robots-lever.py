"""Issue 49, item 4's lever "fewer robots a candidate, with common random numbers": one walk-rate
polish of a recorded NEAT champion with the recipe's settings (evolve.train.POLISH: 16 candidates,
validation on 30 robots, sigma 0.1) but ROBOTS robots a candidate, then its kept walker's walk
rate on the 50 unseen robots of `biped train`'s measures (RESULTS.md, "fewer robots a candidate").
Every update already draws one set of robots for all its candidates (common random numbers), so
the lever is the set's size alone.

    python benchmarks/records/runs/train-recipe2/polish-robots-lever.py SEED ROBOTS UPDATES OUT
    python benchmarks/records/runs/train-recipe2/polish-robots-lever.py 2 8 20 /work/bench-runs/robots-lever

SEED names the champion (train-recipe2/seedSEED/neat/champion.json) and seeds the polish; one
thread.  Prints one JSON line: the validation walk rate at every fifth update, the polish's
minutes, and the kept walker's share of the 50 robots.  Run from the project root.
"""

import json
import sys
import time
from pathlib import Path

from evolve.polish import polish
from evolve.train import POLISH
from evolve.walk_measures import walk_rate

seed, robots, updates, out = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), Path(sys.argv[4])
source = Path(f"benchmarks/records/runs/train-recipe2/seed{seed}/neat/champion.json")
folder = out / f"seed{seed}-robots{robots}"
settings = {**POLISH, "robots": robots}
start = time.time()
result = polish(source, folder, updates=updates, seed=seed, test=0, threads=1, log=lambda s: None, **settings)
minutes = (time.time() - start) / 60.0
kept = folder / "polished.json"
rate = walk_rate(kept, threads=1)
print(json.dumps({"seed": seed, "robots": robots, "updates": updates, "polish_min": round(minutes, 2),
                  "validation": [(h["update"], round(h["walk_rate"], 2)) for h in result["history"]],
                  "walk_rate_50": rate["share"]}), flush=True)
