"""Population-wide network activation: one vectorized step against network by network.

    python -m benchmarks.activation --json

Grows a population of 512 recurrent networks to about 300 enabled connections each (NEAT
structural mutation under random fitness, seed 000's 11 sensors + 2 biases in, 5 joints
out), then times one control tick for the whole population three ways, in one run:
``PopulationNetwork.activate`` (one gather + bincount), our per-network reference
``RecurrentNetwork``, and neat-python 2.0's ``RecurrentNetwork`` (if installed).
Also reports the GA's own cost a generation (reproduction and speciation of the grown
population).  neat-python's anchors: ~15 us a recurrent activation, ~0.7 s of GA overhead
a generation at population 512.
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks.common import parser, progress, report
from evolve.neat import (
    Layout,
    NeatConfig,
    Population,
    PopulationNetwork,
    RecurrentNetwork,
)
from evolve.neat.network import expressed

LAYOUT = Layout(11, 2, 5)


def grow(size: int, target_connections: float, seed: int) -> tuple[Population, float]:
    """Grow networks; also returns the GA's own time (reproduce + speciate) per generation
    over the last generations, at full size [s]."""
    config = NeatConfig(population_size=size, target_species=30, add_node_prob=0.15, add_link_prob=0.6,
                        new_link_tries=40)
    pop = Population(config, LAYOUT, seed=seed)
    rng = np.random.default_rng(seed)
    ga_times = []
    while True:
        stats = pop.evaluate(lambda genomes: 1.0 + np.array([g.n_enabled for g in genomes]) + rng.random(len(genomes)))
        if stats.mean_connections >= target_connections:
            return pop, float(np.mean(ga_times[-5:]))
        t0 = time.perf_counter()
        pop.reproduce()
        ga_times.append(time.perf_counter() - t0)


def neat_python_networks(genomes):
    import neat

    sigmoid = neat.activations.sigmoid_activation
    nets = []
    for genome in genomes:
        nodes, conns = expressed(genome)
        n_src = LAYOUT.n_inputs + LAYOUT.n_bias
        # neat-python numbers inputs -1..-n and outputs 0..m-1
        key = {n: -(n + 1) for n in range(n_src)}
        key.update({n: i for i, n in enumerate(LAYOUT.output_ids)})
        key.update({n: LAYOUT.n_outputs + i for i, n in enumerate(nodes[LAYOUT.n_interface:])})
        incoming = {key[n]: [] for n in nodes[n_src:]}
        for s, d, w in conns:
            incoming[key[d]].append((key[s], w))
        evals = [(k, sigmoid, sum, 0.0, 1.0, links) for k, links in incoming.items()]
        nets.append(neat.nn.RecurrentNetwork([key[n] for n in range(n_src)],
                                             [key[n] for n in LAYOUT.output_ids], evals))
    return nets


def time_per_tick(step, ticks: int) -> float:
    step()  # warm up
    t0 = time.perf_counter()
    for _ in range(ticks):
        step()
    return (time.perf_counter() - t0) / ticks


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--population", type=int, default=512)
    p.add_argument("--connections", type=float, default=300.0, help="mean enabled connections to grow to")
    p.add_argument("--ticks", type=int, default=200)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)

    progress("growing networks...", args.json)
    t0 = time.perf_counter()
    pop, ga_s = grow(args.population, args.connections, args.seed)
    genomes = pop.genomes
    grow_s = time.perf_counter() - t0
    rng = np.random.default_rng(1)
    inputs = rng.uniform(-1, 1, (len(genomes), LAYOUT.n_inputs))
    with_bias = np.hstack([inputs, np.ones((len(genomes), LAYOUT.n_bias))])

    fast = PopulationNetwork(genomes)
    t_build = time.perf_counter()
    PopulationNetwork(genomes)
    build_s = time.perf_counter() - t_build
    vectorized = time_per_tick(lambda: fast.activate(inputs), args.ticks)
    progress(f"vectorized: {vectorized * 1e3:.3f} ms a tick", args.json)

    slow = [RecurrentNetwork(g) for g in genomes]
    reference = time_per_tick(lambda: [n.activate(x) for n, x in zip(slow, inputs)], max(5, args.ticks // 20))
    progress(f"per-network reference: {reference * 1e3:.3f} ms a tick", args.json)

    result = {
        "population": len(genomes),
        "mean_connections": float(np.mean([len(expressed(g)[1]) for g in genomes])),
        "mean_hidden_nodes": float(np.mean([len(g.hidden) for g in genomes])),
        "vectorized_s_per_tick": vectorized,
        "reference_s_per_tick": reference,
        "speedup_vs_reference": reference / vectorized,
        "vectorized_us_per_network": vectorized / len(genomes) * 1e6,
        "build_s": build_s,
        "grow_s": round(grow_s, 2),
        "ga_s_per_generation": ga_s,
    }
    try:
        theirs = neat_python_networks(genomes)
    except ImportError:
        result.update(neat_python_s_per_tick=None, speedup_vs_neat_python=None)
    else:
        np_time = time_per_tick(lambda: [n.activate(x) for n, x in zip(theirs, with_bias)],
                                max(5, args.ticks // 20))
        progress(f"neat-python: {np_time * 1e3:.3f} ms a tick", args.json)
        result.update(neat_python_s_per_tick=np_time, speedup_vs_neat_python=np_time / vectorized,
                      neat_python_us_per_network=np_time / len(genomes) * 1e6)
    report(result, args.json)


if __name__ == "__main__":
    main()
