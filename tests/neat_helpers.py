"""Shared helpers for the NEAT tests: grown random genomes and the XOR task."""

import numpy as np

from evolve.neat import Layout, NeatConfig, Population, PopulationNetwork

XOR_INPUTS = np.array([[0, 0], [0, 1], [1, 0], [1, 1]], dtype=float)
XOR_TARGETS = np.array([0, 1, 1, 0], dtype=float)


def grown_population(seed: int, generations: int = 15, size: int = 40, layout=Layout(5, 2, 3),
                     modules=("main",)) -> Population:
    """A population grown by heavy structural mutation under random fitness: varied topologies,
    cycles and self-loops included."""
    config = NeatConfig(population_size=size, target_species=4, add_node_prob=0.3, add_link_prob=0.5,
                        toggle_enable_prob=0.05, new_link_weight_range=3.0)
    pop = Population(config, layout, seed=seed, modules=modules)
    rng = np.random.default_rng(seed + 1000)
    for _ in range(generations):
        pop.step(lambda genomes: rng.random(len(genomes)))
    return pop


def xor_evaluator(steepness: float):
    """Fitness (4 - sum |error|)^2; sets ``evaluate.solved`` per genome."""

    def evaluate(genomes):
        net = PopulationNetwork([g for g in genomes for _ in range(4)], steepness)
        inputs = np.tile(XOR_INPUTS, (len(genomes), 1))
        for _ in range(max(len(g.hidden) for g in genomes) + 1):  # settle a feed-forward net
            out = net.activate(inputs)
        out = out[:, 0].reshape(len(genomes), 4)
        evaluate.solved = np.all((out >= 0.5) == (XOR_TARGETS >= 0.5), axis=1)
        return (4 - np.abs(out - XOR_TARGETS).sum(axis=1)) ** 2

    return evaluate
