"""NEAT: NeuroEvolution of Augmenting Topologies, as in the seeds.

One module per concept: :mod:`config` (parameters), :mod:`genome` (genes, markers,
distance), :mod:`variation` (mutation, crossover), :mod:`species` (speciation),
:mod:`reproduction` (offspring), :mod:`population` (the loop, checkpoints) and
:mod:`network` (reference and population-wide activation).
"""

from evolve.neat.config import NeatConfig
from evolve.neat.genome import Genome, InnovationTracker, Layout
from evolve.neat.network import PopulationNetwork, RecurrentNetwork
from evolve.neat.population import GenerationStats, Population

__all__ = ["NeatConfig", "Genome", "InnovationTracker", "Layout", "PopulationNetwork",
           "RecurrentNetwork", "GenerationStats", "Population"]
