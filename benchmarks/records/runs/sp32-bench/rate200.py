import json, sys
from evolve.replay import evaluate_controller
from benchmarks.robust_walk import TEST_SEED, EPISODE_S
out = {}
for name, path in [("seed4 before", "benchmarks/records/runs/rwp-bench/seed4/polish/robust_walker.json"),
                   ("seed4 after", "benchmarks/records/runs/sp32-bench/seed4/speed_polish/robust_walker.json"),
                   ("seed3 after", "benchmarks/records/runs/sp32-bench/seed3/speed_polish/robust_walker.json"),
                   ("seed1 shipped", "configs/controllers/xl430_biped.json")]:
    r = evaluate_controller(path, seconds=EPISODE_S, episodes=200, randomize="randomize", seed=TEST_SEED + 2)
    out[name] = {"walked": r["walked"], "of": 200}
    print(name, r["walked"], "/ 200", flush=True)
json.dump(out, sys.stdout)
