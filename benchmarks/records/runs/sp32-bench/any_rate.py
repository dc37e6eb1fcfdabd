"""Walk rate (any heading and speed) of each sp32-bench seed's speed-polish source and result on
the speed polish's own 100 test robots ([seed, TEST_STREAM, 0, k])."""
import json, sys, filecmp
from pathlib import Path
import numpy as np
from evolve.polish import Judge, TEST_STREAM, _keys

root = Path(sys.argv[1])
out = {}
for s in map(int, sys.argv[2:]):
    d = root / f"seed{s}"
    src, res = d / "polish" / "robust_walker.json", d / "speed_polish" / "robust_walker.json"
    same = filecmp.cmp(res, d / "speed_polish" / "polished.json", shallow=False)
    keys = _keys(s, TEST_STREAM, 0, 100)
    rates = {}
    for name, path in (("source", src), ("speed_polished", res)):
        judge = Judge(path, ["randomize"], 100)
        _, _, walked_any = judge.run([judge.start], keys)
        rates[name] = float(walked_any.mean())
    out[s] = {**rates, "robust_walker_is_polished": same}
    print(s, out[s], flush=True)
print(json.dumps(out))
