"""Weights from the side-bias node (and the constant bias) to each output, per controller."""
import json, sys
for path in sys.argv[1:]:
    d = json.load(open(path))
    n_in = len(d['inputs']); b0, b1 = n_in, n_in + 1
    outs = {n_in + 2 + i: name for i, name in enumerate(d['outputs'])}
    hid = {h[0] for h in d['hidden']}
    side = [(t, w) for s, t, w, m in d['connections'] if s == b1]
    const = [(t, w) for s, t, w, m in d['connections'] if s == b0]
    name = lambda t: outs.get(t, f"h{t}" if t in hid else str(t))
    print(path.split('/')[-1], f"inputs {n_in}, hidden {len(hid)}, links {len(d['connections'])}")
    print("   side bias ->", ", ".join(f"{name(t)} {w:+.2f}" for t, w in side))
    print("   const bias ->", ", ".join(f"{name(t)} {w:+.2f}" for t, w in const))
