"""Mutation and crossover (seed 000 sections 5.1-5.2; Stanley & Miikkulainen 2002).

Every function takes the run's one ``numpy.random.Generator`` and draws from it in a fixed
order, so a seed fixes the result.  Only genes of the genome's active module are mutated;
new structure goes into the active module.
"""

from __future__ import annotations

import numpy as np

from evolve.neat.config import NeatConfig
from evolve.neat.genome import (
    BIAS,
    HIDDEN,
    INPUT,
    ConnectionGene,
    Genome,
    InnovationTracker,
    Layout,
)


def initial_genome(key: int, layout: Layout, config: NeatConfig, tracker: InnovationTracker,
                   rng: np.random.Generator, modules: tuple[str, ...] = ("main",),
                   silent: frozenset[int] = frozenset()) -> Genome:
    """A minimal genome: inputs and biases to every output (or nothing), random weights;
    none from the ``silent`` inputs (those the stage's networks read as 0)."""
    genome = Genome(key, layout, modules)
    if config.initial_connection == "full":
        r = config.initial_weight_range
        for src in layout.source_ids:
            if src in silent:
                continue
            for dst in layout.output_ids:
                genome.add_connection(ConnectionGene(tracker.link(src, dst), src, dst,
                                                     float(rng.uniform(-r, r)), True, genome.active_module))
    return genome


def mutate(genome: Genome, config: NeatConfig, tracker: InnovationTracker, rng: np.random.Generator,
           silent: frozenset[int] = frozenset()) -> None:
    """One round of mutation: a structural change, or else weights and enable toggles; no new
    link from the ``silent`` inputs."""
    if rng.random() < config.add_node_prob:
        mutate_add_node(genome, config, tracker, rng)
    elif rng.random() < config.add_link_prob:
        mutate_add_link(genome, config, tracker, rng, silent)
    else:
        if rng.random() < config.weight_mutate_prob:
            mutate_weights(genome, config, rng)
        if rng.random() < config.toggle_enable_prob:
            mutate_toggle_enable(genome, rng)
        if rng.random() < config.reenable_prob:
            mutate_reenable(genome, rng)


def _active_genes(genome: Genome) -> list[ConnectionGene]:
    return [g for g in genome.conns.values() if g.module == genome.active_module]


def mutate_weights(genome: Genome, config: NeatConfig, rng: np.random.Generator) -> None:
    """Gaussian steps (variance 0.1), sometimes replacement; newer genes replaced more often.

    Genes are in innovation order, so the last ``new_gene_fraction`` of them are the genome's
    newest structure (seed 000: "parameters that are relatively new features in the genome
    are more likely to be replaced than older ones").
    """
    genes = _active_genes(genome)
    if not genes:
        return
    n = len(genes)
    newest_from = n - max(1, int(round(config.new_gene_fraction * n)))
    choices = rng.random(n)
    steps = rng.normal(0.0, config.weight_sigma, n)
    fresh = rng.uniform(-config.weight_replace_range, config.weight_replace_range, n)
    limit = config.weight_limit
    for i, gene in enumerate(genes):
        replace_prob = config.weight_replace_prob_new if i >= newest_from else config.weight_replace_prob
        if choices[i] < replace_prob:
            gene.weight = float(fresh[i])
        else:
            gene.weight = float(min(max(gene.weight + steps[i], -limit), limit))


def mutate_add_node(genome: Genome, config: NeatConfig, tracker: InnovationTracker,
                    rng: np.random.Generator) -> bool:
    """Split an enabled connection: src -> new (weight 1), new -> dst (the old weight)."""
    candidates = [g for g in _active_genes(genome) if g.enabled]
    if not candidates:
        return False
    old = candidates[int(rng.integers(len(candidates)))]
    node, in_innovation, out_innovation = tracker.split(old.innovation)
    if node in genome.hidden:  # this genome already split it this generation
        return False
    old.enabled = False
    module = genome.active_module
    genome.hidden[node] = module
    genome.add_connection(ConnectionGene(in_innovation, old.src, node, 1.0, True, module))
    genome.add_connection(ConnectionGene(out_innovation, node, old.dst, old.weight, True, module))
    return True


def mutate_add_link(genome: Genome, config: NeatConfig, tracker: InnovationTracker,
                    rng: np.random.Generator, silent: frozenset[int] = frozenset()) -> bool:
    """Connect two unconnected nodes, or a node to itself, in the active module; never from a
    ``silent`` input (a try that draws one fails, as a taken pair does)."""
    layout = genome.layout
    nodes = genome.node_ids()
    targets = [n for n in nodes if layout.kind(n) not in (INPUT, BIAS)]
    existing = {(g.src, g.dst) for g in genome.conns.values()}
    forward = None if config.allow_recurrent else _depths(genome)
    r = config.new_link_weight_range
    for _ in range(config.new_link_tries):
        src = nodes[int(rng.integers(len(nodes)))]
        dst = targets[int(rng.integers(len(targets)))]
        if (src, dst) in existing or src in silent:
            continue
        if forward is not None and (src == dst or forward.get(src, 0) >= forward.get(dst, 0)):
            continue
        genome.add_connection(ConnectionGene(tracker.link(src, dst), src, dst,
                                             float(rng.uniform(-r, r)), True, genome.active_module))
        return True
    return False


def _depths(genome: Genome) -> dict[int, int]:
    """Longest path from the sources, for feed-forward-only runs (cycles are never created)."""
    depth = {n: 0 for n in genome.layout.source_ids}
    changed = True
    enabled = [g for g in genome.conns.values()]
    while changed:
        changed = False
        for g in enabled:
            if g.src in depth and depth.get(g.dst, -1) < depth[g.src] + 1:
                depth[g.dst] = depth[g.src] + 1
                changed = True
    for n in genome.node_ids():
        depth.setdefault(n, 1)
    return depth


def mutate_toggle_enable(genome: Genome, rng: np.random.Generator) -> None:
    genes = _active_genes(genome)
    if genes:
        gene = genes[int(rng.integers(len(genes)))]
        gene.enabled = not gene.enabled


def mutate_reenable(genome: Genome, rng: np.random.Generator) -> None:
    disabled = [g for g in _active_genes(genome) if not g.enabled]
    if disabled:
        disabled[int(rng.integers(len(disabled)))].enabled = True


def crossover(key: int, fitter: Genome, other: Genome, config: NeatConfig,
              rng: np.random.Generator) -> Genome:
    """Align genes by innovation: matching genes from either parent (or averaged), disjoint
    and excess genes from the fitter parent; a gene disabled in either parent stays disabled
    with probability ``disable_inherit_prob``.  Genes of frozen modules come from the fitter
    parent unchanged."""
    child = Genome(key, fitter.layout, fitter.modules)
    average = rng.random() < config.mate_average_prob
    for innovation, gene in fitter.conns.items():
        mate = other.conns.get(innovation)
        if mate is None or gene.module != fitter.active_module:  # frozen genes pass unchanged
            new = gene.copy()
        else:
            new = gene.copy() if rng.random() < 0.5 else mate.copy()
            if average:
                new.weight = 0.5 * (gene.weight + mate.weight)
            if not (gene.enabled and mate.enabled):
                new.enabled = not rng.random() < config.disable_inherit_prob
        child.conns[innovation] = new
    for gene in child.conns.values():
        for node in (gene.src, gene.dst):
            if fitter.layout.kind(node) == HIDDEN and node not in child.hidden:
                child.hidden[node] = fitter.hidden.get(node, other.hidden.get(node, gene.module))
    child.hidden = dict(sorted(child.hidden.items()))
    return child
