"""Recurrent sigmoid networks built from genomes (seed 000 eq. 1).

The activation itself - one synchronous, double-buffered update a call - is the
runtime's, :mod:`sim2real.controller.activation`, so that evolution and the robot compute
the same numbers by construction.  Here genomes become its graphs:
:class:`PopulationNetwork` activates many networks - a whole population, or two per genome
for bilateral symmetry - in one vectorized step; :class:`RecurrentNetwork` is the plain
per-node reference, the test oracle of that fast path.
"""

from __future__ import annotations

import math
from typing import Iterable, Sequence

import numpy as np

from evolve.neat.genome import Genome
from sim2real.controller.activation import Z_LIMIT, Graph, Networks, graph


def sigmoid(z: float) -> float:
    z = min(max(z, -Z_LIMIT), Z_LIMIT)
    return 1.0 / (1.0 + math.exp(-z))


def expressed(genome: Genome, disabled_modules: Iterable[str] = ()) -> tuple[list[int], list[tuple[int, int, float]]]:
    """Node ids and enabled connections ``(src, dst, weight)`` of the genome's network,
    without the hidden nodes and connections of switched-off modules."""
    off = set(disabled_modules)
    unknown = off - set(genome.modules)
    if unknown:
        raise ValueError(f"disabled_modules: unknown module(s) {sorted(unknown)} (have {list(genome.modules)})")
    off_idx = {i for i, name in enumerate(genome.modules) if name in off}
    layout = genome.layout
    nodes = list(range(layout.n_interface)) + [n for n, m in sorted(genome.hidden.items()) if m not in off_idx]
    present = set(nodes)
    conns = [(g.src, g.dst, g.weight) for g in genome.conns.values()
             if g.enabled and g.module not in off_idx and g.src in present and g.dst in present]
    return nodes, conns


class RecurrentNetwork:
    """One network, node by node in plain Python: the reference implementation."""

    def __init__(self, genome: Genome, steepness: float = 1.0, disabled_modules: Iterable[str] = (),
                 bias_values: Sequence[float] | None = None):
        layout = genome.layout
        self.steepness = steepness
        self.nodes, conns = expressed(genome, disabled_modules)
        self.incoming: dict[int, list[tuple[int, float]]] = {n: [] for n in self.nodes}
        for src, dst, w in conns:
            self.incoming[dst].append((src, w))
        self.input_ids, self.bias_ids, self.output_ids = layout.input_ids, layout.bias_ids, layout.output_ids
        self.bias_values = list(bias_values) if bias_values is not None else [1.0] * layout.n_bias
        self.computed = [n for n in self.nodes if n >= layout.n_inputs + layout.n_bias]
        self.reset()

    def reset(self) -> None:
        self.values = {n: 0.0 for n in self.nodes}

    def activate(self, inputs: Sequence[float]) -> list[float]:
        if len(inputs) != len(self.input_ids):
            raise ValueError(f"expected {len(self.input_ids)} inputs, got {len(inputs)}")
        current = dict(self.values)
        for n, v in zip(self.input_ids, inputs):
            current[n] = float(v)
        for n, v in zip(self.bias_ids, self.bias_values):
            current[n] = float(v)
        new = dict(current)
        for n in self.computed:
            total = 0.0
            for src, w in self.incoming[n]:
                total += w * current[src]
            new[n] = sigmoid(self.steepness * total)
        self.values = new
        return [new[n] for n in self.output_ids]


class PopulationNetwork(Networks):
    """Many genomes' networks activated at once (:class:`sim2real.controller.activation.Networks`).

    Args:
      genomes: one genome per network (a genome may appear several times).
      steepness: the sigmoid's slope.
      disabled_modules: modules switched off in every network.
      bias_values: (n_networks, n_bias) values of the bias nodes (default all 1).
    """

    def __init__(self, genomes: Sequence[Genome], steepness: float = 1.0,
                 disabled_modules: Iterable[str] = (), bias_values: np.ndarray | None = None):
        if not genomes:
            raise ValueError("genomes: need at least one genome")
        layout = genomes[0].layout
        off = tuple(disabled_modules)
        graphs: dict[int, Graph] = {}
        for i, genome in enumerate(genomes):
            if genome.layout != layout:
                raise ValueError(f"genomes[{i}]: layout {genome.layout} differs from {layout}")
            if id(genome) not in graphs:
                graphs[id(genome)] = graph(*expressed(genome, off))
        if bias_values is None:
            bias_values = np.ones((len(genomes), layout.n_bias))
        super().__init__([graphs[id(g)] for g in genomes], layout.n_inputs, layout.n_bias, layout.n_outputs,
                         steepness, bias_values)
