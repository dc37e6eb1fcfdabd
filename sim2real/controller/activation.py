"""The one activation of the project's networks: evolution runs it batched, the runtime per tick.

``y_i = sigmoid(steepness * sum_j w_ji y_j)`` (seed 000 eq. 1), one synchronous,
double-buffered update a call: every node reads the previous call's values, except that
inputs and biases are set first and read as this call's values; state is zero after
``reset``.  Self-loops and cycles are allowed, so a signal crosses one connection a call.

:class:`Networks` activates many networks in one vectorized step: all connections of all
networks form one block-diagonal sparse matrix, applied with one gather and one
``bincount`` (connections summed in their listed order, so the numbers do not depend on
how many networks share the step).  Evolution builds it from genomes, a whole population
at once (``evolve.neat.network.PopulationNetwork``); the runtime builds
:class:`ControllerNetworks` from a controller file, its right and left network.  The slow
per-node reference, the test oracle of both, is ``evolve.neat.network.RecurrentNetwork``.
No MuJoCo, no evolution code here.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Iterable, Sequence

import numpy as np

from sim2real.errors import UsageError

if TYPE_CHECKING:
    from sim2real.controller.file import Controller

Z_LIMIT = 60.0  # the sigmoid's argument is clipped here: within 1e-26 of 0 or 1, and exp never overflows


@dataclass(frozen=True)
class Graph:
    """One network in local node numbers: the interface (inputs, biases, outputs) first,
    hidden nodes after; connections in the order they are summed."""

    n_nodes: int
    src: np.ndarray  # (n_connections,) source node
    dst: np.ndarray  # (n_connections,) target node
    weight: np.ndarray  # (n_connections,)


def graph(nodes: Sequence[int], connections: Iterable[tuple[int, int, float]]) -> Graph:
    """The :class:`Graph` of node ids ``nodes`` (interface first) and connections
    ``(src id, dst id, weight)`` between them."""
    local = {n: k for k, n in enumerate(nodes)}
    conns = list(connections)
    return Graph(len(nodes), np.array([local[s] for s, _, _ in conns], dtype=np.intp),
                 np.array([local[d] for _, d, _ in conns], dtype=np.intp),
                 np.array([w for _, _, w in conns], dtype=float))


def exp_fingerprint() -> str:
    """A short hash of this machine's ``np.exp`` over a fixed grid of the sigmoid's arguments.

    NumPy's float64 ``exp`` is its own SIMD code on CPUs with AVX-512 and the C library's
    elsewhere; the two differ by an ulp on about 5 % of arguments (measured: 92,948 of 2,000,001
    on [-60, 60]).  A knife-edge gait evolved with one falls with the other, so a walker's
    file records this and its check compares it (``tests/test_human_walkers.py``)."""
    z = np.linspace(-Z_LIMIT, Z_LIMIT, 100_001)
    return hashlib.sha256(np.exp(-z).tobytes()).hexdigest()[:16]


def activate(values: np.ndarray, src: np.ndarray, dst: np.ndarray, weight: np.ndarray, computed: np.ndarray,
             steepness: float) -> None:
    """One synchronous update of the flat node ``values``, in place: every node in
    ``computed`` becomes the sigmoid of its weighted inputs' previous values."""
    total = np.bincount(dst, weights=weight * values[src], minlength=values.size)
    z = np.clip(steepness * total[computed], -Z_LIMIT, Z_LIMIT)
    values[computed] = 1.0 / (1.0 + np.exp(-z))


class Networks:
    """Networks of one interface activated at once.

    Args:
      graphs: one graph per network (a graph may appear several times).
      n_inputs, n_bias, n_outputs: the interface every graph starts with.
      steepness: the sigmoid's slope.
      bias_values: (n_networks, n_bias) values of the bias nodes.
    """

    def __init__(self, graphs: Sequence[Graph], n_inputs: int, n_bias: int, n_outputs: int, steepness: float,
                 bias_values: np.ndarray):
        if not graphs:
            raise ValueError("graphs: need at least one network")
        self.n_networks = len(graphs)
        self.n_inputs, self.n_bias, self.n_outputs = n_inputs, n_bias, n_outputs
        self.steepness = steepness
        interface = n_inputs + n_bias + n_outputs
        src, dst, weight, computed = [], [], [], []
        inputs = np.empty((self.n_networks, n_inputs), dtype=np.intp)
        biases = np.empty((self.n_networks, n_bias), dtype=np.intp)
        outputs = np.empty((self.n_networks, n_outputs), dtype=np.intp)
        offset = 0
        for i, g in enumerate(graphs):
            src.append(g.src + offset)
            dst.append(g.dst + offset)
            weight.append(g.weight)
            base = offset + np.arange(interface)
            inputs[i] = base[:n_inputs]
            biases[i] = base[n_inputs:n_inputs + n_bias]
            outputs[i] = base[n_inputs + n_bias:]
            computed.append(offset + np.arange(n_inputs + n_bias, g.n_nodes))
            offset += g.n_nodes
        self.n_nodes = offset
        self._node_network = np.repeat(np.arange(self.n_networks), [g.n_nodes for g in graphs])
        self._src = np.concatenate(src)
        self._dst = np.concatenate(dst)
        self._weight = np.concatenate(weight)
        self._computed = np.concatenate(computed)
        self._inputs, self._biases, self._outputs = inputs, biases, outputs
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
        """Node values of one network, in its graph's order (to continue it elsewhere)."""
        return self.values[self._node_network == network]

    def reset(self) -> None:
        """State to zero, as at the start of every episode."""
        self.values = np.zeros(self.n_nodes)

    def activate(self, inputs: np.ndarray) -> np.ndarray:
        """One update. inputs: (n_networks, n_inputs) -> outputs (n_networks, n_outputs) in [0, 1]."""
        y = self.values
        y[self._inputs] = inputs
        y[self._biases] = self._bias_values
        activate(y, self._src, self._dst, self._weight, self._computed, self.steepness)
        return y[self._outputs]


def check_disabled_modules(controller: "Controller", disabled_modules: Iterable[str]) -> tuple[str, ...]:
    """The names to switch off, each one of the controller's modules, else :class:`UsageError`
    naming them and the modules there are."""
    off = tuple(disabled_modules)
    unknown = sorted(set(off) - set(controller.modules))
    if unknown:
        raise UsageError(f"--disable-module: unknown module{'s' if len(unknown) > 1 else ''} "
                         f"{', '.join(map(repr, unknown))} (this controller has: {', '.join(controller.modules)})")
    return off


class ControllerNetworks(Networks):
    """A controller's right and left network (its two bias rows), stepped together; modules
    in ``disabled_modules`` take no part (their hidden nodes and connections)."""

    def __init__(self, controller: "Controller", disabled_modules: Iterable[str] = ()):
        off = set(check_disabled_modules(controller, disabled_modules))
        off_idx = {i for i, name in enumerate(controller.modules) if name in off}
        interface = len(controller.inputs) + len(controller.bias[0]) + len(controller.outputs)
        nodes = list(range(interface)) + sorted(n for n, m in controller.hidden if m not in off_idx)
        present = set(nodes)
        conns = [(s, d, float(w)) for s, d, w, m in controller.connections
                 if m not in off_idx and s in present and d in present]
        one = graph(nodes, conns)
        super().__init__([one] * len(controller.bias), len(controller.inputs), len(controller.bias[0]),
                         len(controller.outputs), float(controller.sigmoid_steepness), np.array(controller.bias))
