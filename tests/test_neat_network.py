"""Network activation: the vectorized population network equals the per-network reference."""

import numpy as np
import pytest
from neat_helpers import grown_population

from evolve.neat import Layout, PopulationNetwork, RecurrentNetwork
from evolve.neat.genome import ConnectionGene, Genome
from evolve.neat.network import sigmoid


def test_population_activation_equals_reference_over_1000_ticks():
    pop = grown_population(seed=7)
    genomes = pop.genomes
    assert max(len(g.hidden) for g in genomes) >= 3  # the topologies really differ
    assert any(g.src == g.dst for genome in genomes for g in genome.conns.values() if g.enabled)
    rng = np.random.default_rng(1)
    steepness = 1.7
    bias = rng.uniform(-1, 1, (len(genomes), 2))
    fast = PopulationNetwork(genomes, steepness, bias_values=bias)
    slow = [RecurrentNetwork(g, steepness, bias_values=b) for g, b in zip(genomes, bias)]
    worst = 0.0
    for tick in range(1000):
        inputs = rng.uniform(-1, 1, (len(genomes), 5))
        got = fast.activate(inputs)
        want = np.array([net.activate(x) for net, x in zip(slow, inputs)])
        worst = max(worst, float(np.abs(got - want).max()))
    assert worst <= 1e-12


def test_update_is_synchronous_one_connection_per_tick():
    layout = Layout(1, 0, 1)
    g = Genome(0, layout)
    g.hidden = {2: 0}
    g.add_connection(ConnectionGene(0, 0, 2, 1.0))  # input -> hidden
    g.add_connection(ConnectionGene(1, 2, 1, 1.0))  # hidden -> output
    net = RecurrentNetwork(g)
    first = net.activate([5.0])
    assert first == [pytest.approx(0.5)]  # the output still sees the hidden node's old 0
    second = net.activate([5.0])
    assert second == [pytest.approx(sigmoid(sigmoid(5.0)))]
    net.reset()
    assert net.activate([5.0]) == first  # state is zero after reset


def test_self_loop_keeps_state():
    g = Genome(0, Layout(1, 1, 1))
    g.add_connection(ConnectionGene(0, 2, 2, 4.0))  # output feeds itself
    g.add_connection(ConnectionGene(1, 1, 2, -2.0))  # bias
    values = [RecurrentNetwork(g).activate([0.0])]
    net = RecurrentNetwork(g)
    values = [net.activate([0.0])[0] for _ in range(3)]
    assert values[0] == pytest.approx(sigmoid(-2.0))
    assert values[1] == pytest.approx(sigmoid(4.0 * values[0] - 2.0))


def test_switching_a_module_off_removes_its_nodes_and_connections():
    pop = grown_population(seed=3, generations=5, modules=("pose",))
    pop.add_module("stand")
    rng = np.random.default_rng(0)
    for _ in range(8):
        pop.step(lambda genomes: rng.random(len(genomes)))
    genome = max(pop.genomes, key=lambda g: sum(c.module == 1 for c in g.conns.values()))
    assert any(c.module == 1 and c.enabled for c in genome.conns.values())
    stripped = genome.copy(genome.key)
    stripped.conns = {i: c for i, c in genome.conns.items() if c.module == 0}
    stripped.hidden = {n: m for n, m in genome.hidden.items() if m == 0}
    stripped.modules = ("pose",)
    with_off = RecurrentNetwork(genome, disabled_modules=["stand"])
    lower_only = RecurrentNetwork(stripped)
    fast = PopulationNetwork([genome], disabled_modules=["stand"])
    for _ in range(50):
        x = rng.uniform(-1, 1, 5)
        a, b = with_off.activate(x), lower_only.activate(x)
        assert a == pytest.approx(b, abs=0)
        assert fast.activate(x[None])[0] == pytest.approx(a, abs=1e-12)
    with pytest.raises(ValueError, match="unknown module"):
        RecurrentNetwork(genome, disabled_modules=["walk"])


def test_keeping_a_subset_of_networks_continues_them_unchanged():
    genomes = grown_population(seed=8, generations=8).genomes
    rng = np.random.default_rng(3)
    full = PopulationNetwork(genomes)
    part = PopulationNetwork(genomes)
    keep = np.array([1, 4, 5, 17, 30])
    for tick in range(60):
        x = rng.uniform(-1, 1, (len(genomes), 5))
        want = full.activate(x)
        if tick == 20:
            part.keep(keep)
        got = part.activate(x if tick < 20 else x[keep])
        assert np.array_equal(got, want if tick < 20 else want[keep])
