import sys, numpy as np
from evolve.replay import gait
g = gait(sys.argv[1], seconds=3.0)
n = list(g.joints)
A = np.degrees(g.angles_rad)
cols = ["left_hip_pitch", "right_hip_pitch", "left_knee", "right_knee", "left_ankle_pitch", "right_ankle_pitch"]
print("t     " + " ".join(f"{c[:14]:>14s}" for c in cols) + "  feet(L,R)")
for i in range(0, len(g.times_s), 2):
    print(f"{g.times_s[i]:4.2f} " + " ".join(f"{A[i, n.index(c)]:14.1f}" for c in cols) + f"  {g.feet[i].astype(int)}")
