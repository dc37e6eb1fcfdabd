"""One walk-rate polish of seed 5's NEAT champion with one setting changed (RESULTS.md, "Can
another polish lift seed 5's champion?"): 25 updates, 16 candidates x 16 robots, validation on 30.

    python seed5-polish-levers.py NAME SEED SIGMA WORST LR_ADAPT [CONTROLLER|-] [WALK_BONUS]
    python seed5-polish-levers.py seed1005 1005 0.1 1.0 0          # another seed
    python seed5-polish-levers.py bonus20 5 0.1 1.0 0 - 20         # the walk bonus at 20

It writes runs/seed5-polish-levers/NAME (the session that measured them wrote
/work/bench-runs/s5lever/NAME) and prints the validation walk rate of every fifth update and the
minutes. Run from the project root.
"""

import json
import sys
import time
from pathlib import Path

from evolve.polish import polish

name, seed, sigma, worst, lr = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), sys.argv[5] == "1"
bonus = float(sys.argv[7]) if len(sys.argv) > 7 else None
src = Path(sys.argv[6]) if len(sys.argv) > 6 and sys.argv[6] != "-" else \
    Path("benchmarks/records/runs/train-recipe3/seed5/neat/champion.json")
out = Path("runs/seed5-polish-levers") / name
t = time.time()
r = polish(src, out, updates=25, popsize=16, robots=16, sigma=sigma, validation=30, worst=worst, seed=seed,
           lr_adapt=lr, walk_bonus=bonus, test=0, threads=1, log=lambda s: None)
print(name, json.dumps([(h["update"], round(h["walk_rate"], 2)) for h in r["history"]]),
      round((time.time() - t) / 60, 1), "min", flush=True)
