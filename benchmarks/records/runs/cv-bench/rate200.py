import json, sys
from evolve.replay import evaluate_controller
from benchmarks.robust_walk import TEST_SEED, EPISODE_S
for path in sys.argv[1:]:
    r = evaluate_controller(path, seconds=EPISODE_S, episodes=200, randomize="randomize", seed=TEST_SEED + 2)
    print(path, r["walked"], "/ 200", flush=True)
