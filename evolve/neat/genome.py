"""Genomes: node genes and connection genes with historical markers.

A genome is a directed graph.  Node ids ``0 .. n_inputs+n_bias+n_outputs-1`` are the
fixed interface (inputs, then bias nodes, then outputs), shared by every genome of a run;
hidden nodes get ids from the :class:`InnovationTracker`.  Each connection carries its
innovation number (its historical marker); crossover aligns genes by it.

Every hidden node and connection belongs to a *module* (seed 002): an index into
``genome.modules``.  Only the last module is active - new structure goes into it and only
its genes are mutated; the others are frozen but still expressed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

INPUT, BIAS, OUTPUT, HIDDEN = "input", "bias", "output", "hidden"


@dataclass(frozen=True)
class Layout:
    """The fixed interface of every genome in a run."""

    n_inputs: int
    n_bias: int
    n_outputs: int

    @property
    def n_interface(self) -> int:
        return self.n_inputs + self.n_bias + self.n_outputs

    def kind(self, node_id: int) -> str:
        if node_id < self.n_inputs:
            return INPUT
        if node_id < self.n_inputs + self.n_bias:
            return BIAS
        if node_id < self.n_interface:
            return OUTPUT
        return HIDDEN

    @property
    def input_ids(self) -> list[int]:
        return list(range(self.n_inputs))

    @property
    def bias_ids(self) -> list[int]:
        return list(range(self.n_inputs, self.n_inputs + self.n_bias))

    @property
    def output_ids(self) -> list[int]:
        return list(range(self.n_inputs + self.n_bias, self.n_interface))

    @property
    def source_ids(self) -> list[int]:
        """Nodes whose value is set from outside: inputs and biases."""
        return list(range(self.n_inputs + self.n_bias))


class ConnectionGene:
    __slots__ = ("innovation", "src", "dst", "weight", "enabled", "module")

    def __init__(self, innovation: int, src: int, dst: int, weight: float, enabled: bool = True,
                 module: int = 0):
        self.innovation = innovation
        self.src = src
        self.dst = dst
        self.weight = weight
        self.enabled = enabled
        self.module = module

    def copy(self) -> "ConnectionGene":
        return ConnectionGene(self.innovation, self.src, self.dst, self.weight, self.enabled, self.module)

    def to_list(self) -> list:
        return [self.innovation, self.src, self.dst, self.weight, self.enabled, self.module]

    @classmethod
    def from_list(cls, values: list) -> "ConnectionGene":
        innovation, src, dst, weight, enabled, module = values
        return cls(int(innovation), int(src), int(dst), float(weight), bool(enabled), int(module))


class Genome:
    """Hidden nodes (id -> module) and connections (innovation -> gene), plus bookkeeping."""

    __slots__ = ("key", "layout", "hidden", "conns", "modules", "fitness")

    def __init__(self, key: int, layout: Layout, modules: tuple[str, ...] = ("main",)):
        self.key = key
        self.layout = layout
        self.hidden: dict[int, int] = {}  # hidden node id -> module index
        self.conns: dict[int, ConnectionGene] = {}  # innovation -> gene, kept in ascending order
        self.modules = tuple(modules)
        self.fitness: float | None = None

    @property
    def active_module(self) -> int:
        return len(self.modules) - 1

    def copy(self, key: int) -> "Genome":
        child = Genome(key, self.layout, self.modules)
        child.hidden = dict(self.hidden)
        child.conns = {i: g.copy() for i, g in self.conns.items()}
        return child

    def node_ids(self) -> list[int]:
        return list(range(self.layout.n_interface)) + sorted(self.hidden)

    def add_connection(self, gene: ConnectionGene) -> None:
        """Insert keeping innovation order (genes usually arrive newest last)."""
        if self.conns and gene.innovation < next(reversed(self.conns)):
            self.conns[gene.innovation] = gene
            self.conns = dict(sorted(self.conns.items()))
        else:
            self.conns[gene.innovation] = gene

    @property
    def n_enabled(self) -> int:
        return sum(g.enabled for g in self.conns.values())

    def to_dict(self) -> dict[str, Any]:
        return {
            "key": self.key,
            "modules": list(self.modules),
            "hidden": [[n, m] for n, m in sorted(self.hidden.items())],
            "conns": [g.to_list() for g in self.conns.values()],
            "fitness": self.fitness,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any], layout: Layout) -> "Genome":
        genome = cls(int(data["key"]), layout, tuple(data["modules"]))
        genome.hidden = {int(n): int(m) for n, m in data["hidden"]}
        genome.conns = {int(c[0]): ConnectionGene.from_list(c) for c in data["conns"]}
        genome.conns = dict(sorted(genome.conns.items()))
        genome.fitness = None if data.get("fitness") is None else float(data["fitness"])
        return genome


class InnovationTracker:
    """Hands out innovation numbers and node ids; one structural change, one marker a generation.

    Within a generation, the same new link ``(src, dst)`` anywhere in the population gets the
    same innovation number, and splitting the same connection gets the same node id and the
    same two innovation numbers (Stanley & Miikkulainen 2002, section 3.2).
    """

    def __init__(self, next_innovation: int = 0, next_node: int = 0):
        self.next_innovation = next_innovation
        self.next_node = next_node
        self._links: dict[tuple[int, int], int] = {}
        self._splits: dict[int, tuple[int, int, int]] = {}

    def new_generation(self) -> None:
        self._links.clear()
        self._splits.clear()

    def link(self, src: int, dst: int) -> int:
        key = (src, dst)
        if key not in self._links:
            self._links[key] = self.next_innovation
            self.next_innovation += 1
        return self._links[key]

    def split(self, innovation: int) -> tuple[int, int, int]:
        """(new node id, innovation of src->node, innovation of node->dst)."""
        if innovation not in self._splits:
            self._splits[innovation] = (self.next_node, self.next_innovation, self.next_innovation + 1)
            self.next_node += 1
            self.next_innovation += 2
        return self._splits[innovation]

    def to_dict(self) -> dict[str, Any]:
        return {
            "next_innovation": self.next_innovation,
            "next_node": self.next_node,
            "links": [[s, d, i] for (s, d), i in self._links.items()],
            "splits": [[c, *v] for c, v in self._splits.items()],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "InnovationTracker":
        tracker = cls(int(data["next_innovation"]), int(data["next_node"]))
        tracker._links = {(int(s), int(d)): int(i) for s, d, i in data["links"]}
        tracker._splits = {int(c): (int(n), int(a), int(b)) for c, n, a, b in data["splits"]}
        return tracker


def distance(a: Genome, b: Genome, gene_coeff: float, weight_coeff: float, exponent: float) -> float:
    """Compatibility ``delta = gene_coeff * G / N^k + weight_coeff * W`` (seed 000 section 5.3).

    G counts connection genes without a homologue in the other genome (disjoint and excess),
    N is the gene count of the larger genome, W the mean weight difference of matching genes.
    """
    ca, cb = a.conns, b.conns
    if len(ca) > len(cb):
        ca, cb = cb, ca
    matching = 0
    weight_diff = 0.0
    for innovation, gene in ca.items():
        other = cb.get(innovation)
        if other is not None:
            matching += 1
            weight_diff += abs(gene.weight - other.weight)
    unmatched = len(ca) + len(cb) - 2 * matching
    n = max(len(ca), len(cb), 1)
    w = weight_diff / matching if matching else 0.0
    return gene_coeff * unmatched / n**exponent + weight_coeff * w
