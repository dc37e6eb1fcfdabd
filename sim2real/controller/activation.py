"""The controller's networks at run time: pure numpy, no MuJoCo, no evolution code.

A controller file holds one network; bilateral symmetry runs it twice, as a right and a
left network with their own bias values.  Each call is one synchronous, double-buffered
update (seed 000 eq. 1): inputs and biases are set, every other node becomes
``sigmoid(steepness * sum_j w_ji y_j)`` of the previous call's values.  Modules can be
switched off by name; their hidden nodes and connections then take no part.  The numbers
are those of the evolution's activation (``evolve.neat.network``), which a test checks.
"""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np

from sim2real.errors import UsageError

Z_LIMIT = 60.0  # the sigmoid's argument is clipped here, as in evolution


def check_disabled_modules(controller: dict[str, Any], disabled_modules: Iterable[str]) -> tuple[str, ...]:
    """The names to switch off, each one of the controller's modules, else :class:`UsageError`
    naming them and the modules there are."""
    names = [m["name"] for m in controller["modules"]]
    off = tuple(disabled_modules)
    unknown = sorted(set(off) - set(names))
    if unknown:
        raise UsageError(f"--disable-module: unknown module{'s' if len(unknown) > 1 else ''} "
                         f"{', '.join(map(repr, unknown))} (this controller has: {', '.join(names)})")
    return off


class ControllerNetworks:
    """Both side networks of a controller, stepped together. ``activate`` takes (2, n_inputs)."""

    def __init__(self, controller: dict[str, Any], disabled_modules: Iterable[str] = ()):
        names = [m["name"] for m in controller["modules"]]
        off = set(check_disabled_modules(controller, disabled_modules))
        off_idx = {i for i, n in enumerate(names) if n in off}
        self.n_inputs = len(controller["inputs"])
        self.n_bias = len(controller["bias"][0])
        self.n_outputs = len(controller["outputs"])
        interface = self.n_inputs + self.n_bias + self.n_outputs
        hidden = sorted(int(n) for n, m in controller["hidden"] if int(m) not in off_idx)
        nodes = list(range(interface)) + hidden
        index = {n: i for i, n in enumerate(nodes)}
        conns = [(index[s], index[d], float(w)) for s, d, w, m in controller["connections"]
                 if int(m) not in off_idx and s in index and d in index]
        self.n_nodes = len(nodes)
        self.steepness = float(controller["sigmoid_steepness"])
        self._src = np.array([c[0] for c in conns], dtype=np.intp)
        self._dst = np.array([c[1] for c in conns], dtype=np.intp)
        self._weight = np.array([c[2] for c in conns], dtype=float)
        first = self.n_inputs + self.n_bias
        self._computed = np.arange(first, self.n_nodes)
        self._outputs = np.arange(first, first + self.n_outputs)
        self._bias = np.asarray(controller["bias"], dtype=float)  # (networks, n_bias)
        self.n_networks = len(self._bias)
        # one block-diagonal matrix for both networks: node k of network s is s * n_nodes + k
        offsets = np.arange(self.n_networks)[:, None] * self.n_nodes
        self._src_all = (offsets + self._src).ravel()
        self._dst_all = (offsets + self._dst).ravel()
        self._w_all = np.tile(self._weight, self.n_networks)
        self._computed_all = (offsets + self._computed).ravel()
        self.reset()

    def reset(self) -> None:
        """State to zero, as at the start of every episode."""
        self.values = np.zeros((self.n_networks, self.n_nodes))

    def activate(self, inputs: np.ndarray) -> np.ndarray:
        """One update. inputs: (n_networks, n_inputs) -> outputs (n_networks, n_outputs) in [0, 1]."""
        y = self.values
        y[:, : self.n_inputs] = inputs
        y[:, self.n_inputs: self.n_inputs + self.n_bias] = self._bias
        flat = y.reshape(-1)
        total = np.bincount(self._dst_all, weights=self._w_all * flat[self._src_all], minlength=flat.size)
        z = np.clip(self.steepness * total[self._computed_all], -Z_LIMIT, Z_LIMIT)
        flat[self._computed_all] = 1.0 / (1.0 + np.exp(-z))
        return y[:, self._outputs]
