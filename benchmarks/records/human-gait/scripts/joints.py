"""Replay one controller 10 s (nominal) and print per-joint angle stats after 2 s."""
import sys, json
import numpy as np
from evolve.replay import gait
path = sys.argv[1]
g = gait(path, seconds=10.0)

print(g.title)
names = g.joints
A = np.degrees(np.asarray(g.angles_rad))
T = np.asarray(g.times_s)
F = np.asarray(g.feet)
m = T >= 2.0
spec = g.robot
for i, n in enumerate(names):
    j = [x for x in spec.joints if x.name == n][0]
    lo, hi = np.degrees(j.range_rad)
    a = A[m, i]
    if len(a) == 0: continue
    atlo = np.mean(a < lo + 1.0); athi = np.mean(a > hi - 1.0)
    print(f"{n:18s} range [{lo:6.1f},{hi:6.1f}] min {a.min():6.1f} max {a.max():6.1f} mean {a.mean():6.1f}  at-low {atlo:.2f} at-high {athi:.2f}")
print("feet (left,right) down share:", F[m].mean(axis=0))
