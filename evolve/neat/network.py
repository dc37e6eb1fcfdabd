"""Recurrent sigmoid networks built from genomes, updated once per call (seed 000 eq. 1).

``y_i = sigma(sum_j w_ji y_j)``: every node reads the previous call's values
(synchronous, double-buffered), except that inputs and biases are set first and read as
this call's values; state is zero after ``reset``.  Self-loops and cycles are allowed, so
a signal crosses one connection per call.

:class:`RecurrentNetwork` is the plain per-network reference (the test oracle);
:class:`PopulationNetwork` activates many networks - a whole population, or two per genome
for bilateral symmetry - in one vectorized step: all connections of all networks form
one block-diagonal sparse matrix, applied with one gather and one ``bincount``.
The sigmoid's argument is clipped to +-60, where it is within 1e-26 of 0 or 1.
"""

from __future__ import annotations

import math
from typing import Iterable, Sequence

import numpy as np

from evolve.neat.genome import Genome

Z_LIMIT = 60.0


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


class PopulationNetwork:
    """Many networks activated at once.

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
        self.n_networks = len(genomes)
        self.steepness = steepness
        off = tuple(disabled_modules)
        src, dst, weight, computed = [], [], [], []
        inputs = np.empty((self.n_networks, layout.n_inputs), dtype=np.intp)
        biases = np.empty((self.n_networks, layout.n_bias), dtype=np.intp)
        outputs = np.empty((self.n_networks, layout.n_outputs), dtype=np.intp)
        offset = 0
        cache: dict[int, tuple] = {}
        for i, genome in enumerate(genomes):
            if genome.layout != layout:
                raise ValueError(f"genomes[{i}]: layout {genome.layout} differs from {layout}")
            if id(genome) not in cache:
                nodes, conns = expressed(genome, off)
                local = {n: k for k, n in enumerate(nodes)}
                cache[id(genome)] = (
                    len(nodes),
                    np.array([local[s] for s, _, _ in conns], dtype=np.intp),
                    np.array([local[d] for _, d, _ in conns], dtype=np.intp),
                    np.array([w for _, _, w in conns], dtype=float),
                )
            n_nodes, s, d, w = cache[id(genome)]
            src.append(s + offset)
            dst.append(d + offset)
            weight.append(w)
            base = offset + np.arange(layout.n_interface)
            inputs[i] = base[: layout.n_inputs]
            biases[i] = base[layout.n_inputs: layout.n_inputs + layout.n_bias]
            outputs[i] = base[layout.n_inputs + layout.n_bias:]
            computed.append(offset + np.arange(layout.n_inputs + layout.n_bias, n_nodes))
            offset += n_nodes
        self.n_nodes = offset
        self._node_network = np.repeat(np.arange(self.n_networks), [cache[id(g)][0] for g in genomes])
        self._src = np.concatenate(src)
        self._dst = np.concatenate(dst)
        self._weight = np.concatenate(weight)
        self._computed = np.concatenate(computed)
        self._inputs, self._biases, self._outputs = inputs, biases, outputs
        if bias_values is None:
            bias_values = np.ones((self.n_networks, layout.n_bias))
        bias_values = np.asarray(bias_values, dtype=float)
        if bias_values.shape != biases.shape:
            raise ValueError(f"bias_values: expected shape {biases.shape}, got {bias_values.shape}")
        self._bias_values = bias_values
        self.reset()

    def keep(self, networks: np.ndarray) -> None:
        """Keep only the listed networks (ascending indices into the current ones), with
        their state; the others - finished episodes - stop costing anything."""
        networks = np.asarray(networks, dtype=np.intp)
        if networks.size and np.any(np.diff(networks) <= 0):
            raise ValueError("networks: indices must be ascending and unique")
        kept = np.zeros(self.n_networks, dtype=bool)
        kept[networks] = True
        node_kept = kept[self._node_network]
        renumber = np.cumsum(node_kept) - 1
        conn_kept = node_kept[self._dst]  # a connection never leaves its network
        self._src = renumber[self._src[conn_kept]]
        self._dst = renumber[self._dst[conn_kept]]
        self._weight = self._weight[conn_kept]
        self._computed = renumber[self._computed[node_kept[self._computed]]]
        self._inputs = renumber[self._inputs[networks]]
        self._biases = renumber[self._biases[networks]]
        self._outputs = renumber[self._outputs[networks]]
        self._bias_values = self._bias_values[networks]
        self._node_network = np.cumsum(kept)[self._node_network[node_kept]] - 1
        self.values = self.values[node_kept]
        self.n_nodes = int(node_kept.sum())
        self.n_networks = len(networks)

    def state_of(self, network: int) -> np.ndarray:
        """Node values of one network, in :func:`expressed` order (to continue it elsewhere)."""
        return self.values[self._node_network == network]

    def reset(self) -> None:
        self.values = np.zeros(self.n_nodes)

    def activate(self, inputs: np.ndarray) -> np.ndarray:
        """One synchronous update. inputs: (n_networks, n_inputs) -> outputs (n_networks, n_outputs)."""
        y = self.values
        y[self._inputs] = inputs
        y[self._biases] = self._bias_values
        total = np.bincount(self._dst, weights=self._weight * y[self._src], minlength=self.n_nodes)
        z = np.clip(self.steepness * total[self._computed], -Z_LIMIT, Z_LIMIT)
        y[self._computed] = 1.0 / (1.0 + np.exp(-z))
        return y[self._outputs]
