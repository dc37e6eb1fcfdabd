"""Both feet unloaded at every physics step, not once a control tick (RESULTS.md, "Human gait,
round four"): a controller's 10 s replay on a body, each foot switch (the robot's own threshold,
:meth:`RobotModel.feet_touching`) and sole force read after every physics step, the first 2 s skipped.

    python benchmarks/records/human-gait/scripts/unloaded.py CONTROLLER [BODY]
    python benchmarks/records/human-gait/scripts/unloaded.py configs/controllers/human_female_50.json human_stepping:female_50

Prints the share of physics steps with both feet unloaded, the spells of such steps (count,
median and longest [ms], a histogram over 0-4-10-20-40-80-200-1000 ms) and percentiles of the
total sole force in body weights.  Run from the project root.
"""

import sys

import numpy as np

from evolve.replay import controller_setup
from sim2real.robot.spec import GRAVITY

path, body = sys.argv[1], (sys.argv[2] if len(sys.argv) > 2 else None)
data, spec, ev, genome = controller_setup(path, body, 10.0, stagnation_stop=False)
step_once, forces, touching = ev.batch.step, [], []


def step(alive, n):
    """The evaluator's tick of ``n`` physics steps, one at a time, keeping robot 0's sole forces and switches."""
    for _ in range(n):
        step_once(alive, 1)
        forces.append(ev.sensordata[0, ev.parts.touch].copy())
        touching.append(ev.parts.feet_touching(ev.sensordata[0]))


ev.batch.step = step
result = ev.evaluate([genome], data.sigmoid_steepness, harness=0.0)
dt = ev.tick_s / ev.substeps  # [s] one physics step
weight = ev.mass * GRAVITY  # [N]
skip = int(2.0 / dt)
f = np.array(forces)[skip:]
unloaded = ~np.array(touching)[skip:].any(axis=1)
spells, run = [], 0
for x in unloaded:
    if x:
        run += 1
    elif run:
        spells.append(run)
        run = 0
ms = np.array(spells) * dt * 1000.0
print(f"{path} on {body or 'its robot'}: {result.distance_m[0]:.2f} m, upright {result.upright_s[0]:.1f} s")
print(f"both feet unloaded in {unloaded.mean():.1%} of the physics steps; {len(ms)} spells, "
      f"median {np.median(ms) if len(ms) else 0:.0f} ms, longest {ms.max() if len(ms) else 0:.0f} ms, "
      f"histogram {np.histogram(ms, bins=[0, 4, 10, 20, 40, 80, 200, 1000])[0].tolist()}")
print("total sole force / weight, percentiles 1 5 25 50 75 95 99:",
      np.round(np.percentile(f.sum(axis=1) / weight, [1, 5, 25, 50, 75, 95, 99]), 2).tolist())
