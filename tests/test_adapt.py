"""Identify, then adapt (biped adapt): a population grown from a walker, evolved around an
identified robot, judged there."""

import json

import numpy as np
import pytest

from evolve.adapt import adapt
from evolve.locomotion.export import genome_from_controller
from evolve.neat import NeatConfig, Population
from evolve.neat.genome import Layout
from sim2real.controller.file import Controller
from sim2real.errors import ConfigError

WALKER = "configs/controllers/xl430_biped_no_gyro.json"


def test_a_population_grows_from_a_walker_its_copies_mutated_only_in_their_weights():
    controller = Controller.load(WALKER)
    genome = genome_from_controller(controller)
    layout = Layout(len(controller.inputs), len(controller.bias[0]), len(controller.outputs))
    pop = Population.from_genome(NeatConfig(population_size=6), layout, 3, genome)
    first = pop.genomes[0]
    assert [(g.src, g.dst, g.weight) for g in first.conns.values()] == \
        [(g.src, g.dst, g.weight) for g in genome.conns.values()]  # the walker itself, unchanged
    for child in pop.genomes[1:]:
        assert [(g.src, g.dst) for g in child.conns.values()] == [(g.src, g.dst) for g in genome.conns.values()]
    weights = np.array([[g.weight for g in child.conns.values()] for child in pop.genomes[1:]])
    assert (weights != weights[0]).any()
    assert pop.tracker.next_innovation > max(genome.conns) and pop.tracker.next_node > max(genome.node_ids())


def test_adapt_writes_the_adapted_walker_and_its_judgement(tmp_path):
    out = tmp_path / "adapt"
    result = adapt(WALKER, "default", out, ranges="randomize", generations=1, population=4, episodes=1,
                   validation=2, test=2, episode_s=1.0, transfer_runs=1, log=lambda line: None)
    assert Controller.load(out / "controller.json").robot_name == "xl430_biped"
    assert json.loads((out / "adapt.json").read_text()) == json.loads(json.dumps(result))
    assert set(result["walk_rate"]) == {"robots", "before", "after"} and "ratio" in result["transfer"]
    assert result["generations"] == 1


def test_adapt_refuses_ranges_as_the_identified_robot(tmp_path):
    with pytest.raises(ConfigError, match="fixed values"):
        adapt(WALKER, "randomize", tmp_path / "x", ranges="randomize", generations=1, population=4,
              log=lambda line: None)


def test_adapt_keeps_a_walker_evolved_without_the_side_bias_without_it():
    import dataclasses

    from evolve.adapt import evolved_with_side_bias

    walker = Controller.load(WALKER)
    config = dict(walker.provenance.get("config") or {})
    without = dataclasses.replace(walker, provenance={**walker.provenance,
                                                       "config": {**config, "neat": {"side_bias": False}}})
    assert evolved_with_side_bias(walker) and not evolved_with_side_bias(without)
    odd = dataclasses.replace(walker, provenance={"config": {"neat": "not a mapping"}})
    assert evolved_with_side_bias(odd)  # free-form provenance that does not say: the default
