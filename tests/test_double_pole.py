"""The double-pole benchmark's physics: the fast paths agree with each other and with physics."""

import numpy as np
import pytest

from benchmarks import double_pole as dp
from benchmarks.pole_balancing import balance
from evolve.neat import Layout, NeatConfig, Population


def test_scalar_step_equals_vectorized_step():
    rng = np.random.default_rng(0)
    states = rng.uniform(-0.5, 0.5, (20, 6))
    outputs = rng.uniform(0, 1, 20)
    vector = dp.control_step(states, outputs)
    for s, out, want in zip(states, outputs, vector):
        assert dp.control_step_scalar(s.tolist(), float(out)) == pytest.approx(want.tolist(), abs=1e-12)


def test_unpushed_poles_fall_and_upright_poles_stay():
    state = dp.start_states(1)
    for _ in range(200):
        state = dp.control_step(state, np.array([0.5]))
    assert dp.failed(state)[0]  # a 4 degree lean with no force topples
    upright = np.zeros((1, 6))
    for _ in range(200):
        upright = dp.control_step(upright, np.array([0.5]))
    assert np.abs(upright).max() < 1e-9  # an unstable equilibrium, but an equilibrium


def test_lone_survivor_path_matches_the_vectorized_path():
    config = NeatConfig(population_size=60, target_species=5, sigmoid_steepness=4.9, add_node_prob=0.2)
    pop = Population(config, Layout(6, 1, 1), seed=1)
    rng = np.random.default_rng(0)
    for _ in range(3):
        pop.step(lambda genomes: rng.random(len(genomes)))
    genomes = pop.genomes
    together, wig_together = balance(genomes, 4.9, True, 300)
    for i in np.argsort(-together)[:5]:
        alone, wig_alone = balance([genomes[i]], 4.9, True, 300)  # one cart: plain floats from the start
        assert alone[0] == together[i]
        assert wig_alone[0] == pytest.approx(wig_together[i], rel=1e-9)


def _square(x: int) -> int:
    return x * x


def test_parallel_runs_return_the_same_results_in_the_same_order():
    from benchmarks.common import map_runs

    seen = []
    parallel = map_runs(_square, [3, 1, 2, 5], workers=2, on_result=lambda i, r, s: seen.append(i))
    assert parallel == map_runs(_square, [3, 1, 2, 5]) == [9, 1, 4, 25]
    assert sorted(seen) == [0, 1, 2, 3]
