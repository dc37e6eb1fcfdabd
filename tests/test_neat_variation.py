"""Mutation, crossover, innovation markers and frozen modules."""

import numpy as np
import pytest
from neat_helpers import grown_population

from evolve.neat import InnovationTracker, Layout, NeatConfig, Population
from evolve.neat.genome import ConnectionGene, Genome, distance
from evolve.neat.variation import (
    crossover,
    initial_genome,
    mutate_add_link,
    mutate_add_node,
    mutate_weights,
)

LAYOUT = Layout(2, 1, 1)


def _fresh(seed=0, config=NeatConfig()):
    tracker = InnovationTracker(next_node=LAYOUT.n_interface)
    rng = np.random.default_rng(seed)
    return initial_genome(0, LAYOUT, config, tracker, rng), tracker, rng


def test_initial_genome_connects_inputs_and_bias_to_outputs():
    genome, _, _ = _fresh()
    assert sorted((g.src, g.dst) for g in genome.conns.values()) == [(0, 3), (1, 3), (2, 3)]
    assert all(-1 < g.weight < 1 for g in genome.conns.values())


def test_add_node_splits_a_connection_weight_1_in_old_weight_out():
    genome, tracker, rng = _fresh()
    before = {i: (g.src, g.dst, g.weight) for i, g in genome.conns.items()}
    assert mutate_add_node(genome, NeatConfig(), tracker, rng)
    (node,) = genome.hidden
    split = next(i for i, g in genome.conns.items() if i in before and not g.enabled)
    src, dst, weight = before[split]
    into = next(g for g in genome.conns.values() if g.dst == node)
    out = next(g for g in genome.conns.values() if g.src == node)
    assert (into.src, into.weight) == (src, 1.0)
    assert (out.dst, out.weight) == (dst, weight)


def test_same_innovation_in_one_generation_gets_the_same_marker():
    config = NeatConfig()
    tracker = InnovationTracker(next_node=LAYOUT.n_interface)
    rng = np.random.default_rng(0)
    a = initial_genome(0, LAYOUT, config, tracker, rng)
    b = initial_genome(1, LAYOUT, config, tracker, rng)
    assert list(a.conns) == list(b.conns)  # same initial links, same markers
    target = next(iter(a.conns))
    for genome in (a, b):  # split the same connection in both genomes
        for g in genome.conns.values():
            g.enabled = g.innovation == target
        mutate_add_node(genome, config, tracker, rng)
    assert a.hidden == b.hidden and set(a.conns) == set(b.conns)
    tracker.new_generation()
    c = initial_genome(2, LAYOUT, config, tracker, rng)
    for g in c.conns.values():
        g.enabled = g.innovation == target
    mutate_add_node(c, config, tracker, rng)
    assert set(c.hidden) != set(a.hidden)  # a later generation's split is a new innovation


def test_add_link_connects_unconnected_nodes_or_a_self_loop():
    config = NeatConfig(new_link_tries=50)
    genome, tracker, rng = _fresh(config=config)
    mutate_add_node(genome, config, tracker, rng)
    links = {(g.src, g.dst) for g in genome.conns.values()}
    for _ in range(30):
        mutate_add_link(genome, config, tracker, rng)
    new = [(g.src, g.dst) for g in genome.conns.values() if (g.src, g.dst) not in links]
    assert len(new) == len(set(new)) > 0
    assert all(LAYOUT.kind(d) in ("hidden", "output") for _, d in new)
    assert any(s == d for s, d in new)  # self-loops happen


def test_feed_forward_runs_never_create_cycles():
    config = NeatConfig(allow_recurrent=False, add_node_prob=0.3, add_link_prob=0.6)
    pop = Population(config.replace(population_size=30, target_species=3), LAYOUT, seed=2)
    rng = np.random.default_rng(0)
    for _ in range(20):
        pop.step(lambda genomes: rng.random(len(genomes)))
    for genome in pop.genomes:
        edges = [(g.src, g.dst) for g in genome.conns.values()]
        assert all(s != d for s, d in edges)
        seen = set()
        # Kahn's algorithm: a DAG drains completely
        indeg = {n: 0 for n in genome.node_ids()}
        for _, d in edges:
            indeg[d] += 1
        ready = [n for n, k in indeg.items() if k == 0]
        while ready:
            n = ready.pop()
            seen.add(n)
            for s, d in edges:
                if s == n:
                    indeg[d] -= 1
                    if indeg[d] == 0:
                        ready.append(d)
        assert len(seen) == len(indeg)


def test_weight_mutation_steps_are_small_and_newest_genes_replaced_more_often():
    config = NeatConfig(weight_replace_prob=0.05, weight_replace_prob_new=0.5, weight_replace_range=0.1)
    genome = Genome(0, Layout(20, 0, 5))
    for i in range(100):
        genome.add_connection(ConnectionGene(i, i % 20, 20 + i % 5, 5.0))
    rng = np.random.default_rng(0)
    replaced = np.zeros(100)
    steps = []
    for _ in range(200):
        for g in genome.conns.values():
            g.weight = 5.0
        mutate_weights(genome, config, rng)
        w = np.array([g.weight for g in genome.conns.values()])
        replaced += np.abs(w) < 0.1
        steps += list(w[np.abs(w) >= 0.1] - 5.0)
    assert np.var(steps) == pytest.approx(0.1, rel=0.1)
    assert replaced[80:].mean() / 200 == pytest.approx(0.5, abs=0.08)
    assert replaced[:80].mean() / 200 == pytest.approx(0.05, abs=0.03)


def test_crossover_takes_disjoint_genes_from_the_fitter_parent():
    config = NeatConfig()
    genomes = grown_population(seed=11, generations=6).genomes
    fitter, other = genomes[0], genomes[1]
    rng = np.random.default_rng(0)
    child = crossover(99, fitter, other, config, rng)
    assert list(child.conns) == list(fitter.conns)  # exactly the fitter parent's markers
    for innovation, gene in child.conns.items():
        mate = other.conns.get(innovation)
        choices = {fitter.conns[innovation].weight} | ({mate.weight, 0.5 * (mate.weight + fitter.conns[innovation].weight)} if mate else set())
        assert any(gene.weight == pytest.approx(c) for c in choices)
    needed = {n for g in child.conns.values() for n in (g.src, g.dst) if n >= LAYOUT.n_interface}
    assert needed <= set(child.hidden) | set(range(fitter.layout.n_interface))


def test_gene_disabled_in_a_parent_stays_disabled_three_times_in_four():
    config = NeatConfig()
    a = Genome(0, LAYOUT)
    b = Genome(1, LAYOUT)
    a.add_connection(ConnectionGene(0, 0, 3, 1.0, enabled=False))
    b.add_connection(ConnectionGene(0, 0, 3, 1.0, enabled=True))
    rng = np.random.default_rng(0)
    disabled = np.mean([not crossover(2, a, b, config, rng).conns[0].enabled for _ in range(4000)])
    assert disabled == pytest.approx(0.75, abs=0.03)


def test_distance_counts_unmatched_genes_over_size_plus_weight_difference():
    a, b = Genome(0, LAYOUT), Genome(1, LAYOUT)
    for i in range(4):
        a.add_connection(ConnectionGene(i, 0, 3, 1.0))
    for i in range(2, 6):
        b.add_connection(ConnectionGene(i, 0, 3, 1.5))
    # 4 unmatched of 4 genes (k=1), matching genes 2 and 3 differ by 0.5
    assert distance(a, b, 1.0, 0.4, 1.0) == pytest.approx(4 / 4 + 0.4 * 0.5)
    assert distance(a, b, 1.0, 0.4, 0.0) == pytest.approx(4 + 0.4 * 0.5)


def test_lower_modules_stay_frozen_while_a_new_module_evolves():
    base = grown_population(seed=5, generations=6, modules=("pose",))
    ancestor = max(base.genomes, key=lambda g: len(g.conns))
    config = NeatConfig(population_size=30, target_species=3, add_node_prob=0.2, add_link_prob=0.4,
                        toggle_enable_prob=0.2, reenable_prob=0.2)
    pop = Population.on_top_of(config, ancestor, "stand", seed=1)
    rng = np.random.default_rng(2)
    for _ in range(15):
        pop.step(lambda genomes: rng.random(len(genomes)))
    frozen = {i: (g.src, g.dst, g.weight, g.enabled) for i, g in ancestor.conns.items()}
    grew = 0
    for genome in pop.genomes:
        assert genome.modules == ("pose", "stand")
        lower = {i: (g.src, g.dst, g.weight, g.enabled) for i, g in genome.conns.items() if g.module == 0}
        assert lower == frozen  # never mutated, always expressed
        assert {n: m for n, m in genome.hidden.items() if m == 0} == ancestor.hidden
        grew += sum(g.module == 1 for g in genome.conns.values())
    assert grew > 0  # and new structure went into the active module
