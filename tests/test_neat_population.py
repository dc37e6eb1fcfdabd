"""The NEAT loop: determinism, checkpoints that resume exactly, speciation, configuration."""

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from neat_helpers import xor_evaluator

from evolve.neat import Layout, NeatConfig, Population
from evolve.neat.reproduction import offspring_counts
from sim2real.atomic_json import read_json
from sim2real.errors import ConfigError

XOR_CONFIG = NeatConfig(population_size=150, target_species=15, compat_exponent=0.0, sigmoid_steepness=4.9,
                        weight_sigma=1.5, weight_replace_range=2.0, add_link_prob=0.2,
                        allow_recurrent=False, weight_mutate_prob=0.8, stagnation_generations=15,
                        interspecies_mate_rate=0.001)


def _run(pop: Population, generations: int) -> list[dict]:
    evaluate = xor_evaluator(pop.config.sigmoid_steepness)
    return [pop.step(evaluate).to_dict() for _ in range(generations)]


def test_the_same_seed_gives_the_same_run():
    a, b = Population(XOR_CONFIG, Layout(2, 1, 1), seed=4), Population(XOR_CONFIG, Layout(2, 1, 1), seed=4)
    assert _run(a, 12) == _run(b, 12)
    assert json.dumps(a.to_dict()) == json.dumps(b.to_dict())
    c = Population(XOR_CONFIG, Layout(2, 1, 1), seed=5)
    assert _run(c, 12) != _run(Population(XOR_CONFIG, Layout(2, 1, 1), seed=4), 12)


@pytest.mark.parametrize("stop_at", [0, 3, 7])
def test_resuming_from_a_checkpoint_continues_exactly(tmp_path, stop_at):
    straight = Population(XOR_CONFIG, Layout(2, 1, 1), seed=9)
    expected = _run(straight, 12)

    first = Population(XOR_CONFIG, Layout(2, 1, 1), seed=9)
    head = _run(first, stop_at)
    path = tmp_path / "checkpoint.json.gz"
    first.save(path)
    del first
    resumed = Population.load(path)
    tail = _run(resumed, 12 - stop_at)
    assert head + tail == expected
    assert json.dumps(resumed.to_dict()) == json.dumps(straight.to_dict())


def test_a_checkpoint_written_before_the_restore_constructor_loads_and_resumes_exactly(tmp_path):
    # generation 5 of this XOR run, written by commit 24747d4; then the stats of its next 4 generations there
    data = Path(__file__).parent / "data" / "checkpoint_v1"
    config = NeatConfig(population_size=24, target_species=4, compat_exponent=0.0, sigmoid_steepness=4.9,
                        add_node_prob=0.2, add_link_prob=0.3, allow_recurrent=False)
    pop = Population.load(data / "checkpoint.json.gz")
    assert pop.config == config and pop.generation == 5
    old = read_json(data / "checkpoint.json.gz")
    added = {k: v for k, v in pop.to_dict()["config"].items() if k not in old["config"]}  # settings added since
    assert added == {k: getattr(NeatConfig(), k) for k in added}  # at their defaults, which the old run had
    assert pop.to_dict() == {**old, "config": {**old["config"], **added}}  # every field restored
    assert _run(pop, 4) == json.loads((data / "next_generations.json").read_text())


def test_checkpoint_is_data_and_written_atomically(tmp_path):
    pop = Population(XOR_CONFIG, Layout(2, 1, 1), seed=1)
    path = tmp_path / "run" / "checkpoint.json"
    pop.save(path)
    data = json.loads(path.read_text())
    assert data["format"] == "biped-neat-checkpoint" and data["version"] == 1
    assert [p.name for p in path.parent.iterdir()] == ["checkpoint.json"]  # no temp files left
    path.write_text(path.read_text()[:100])  # truncated
    with pytest.raises(ValueError, match="checkpoint.json: cannot read checkpoint"):
        Population.load(path)


def test_xor_is_solved():
    pop = Population(XOR_CONFIG, Layout(2, 1, 1), seed=0)
    evaluate = xor_evaluator(XOR_CONFIG.sigmoid_steepness)
    for _ in range(100):
        pop.evaluate(evaluate)
        if evaluate.solved.any():
            break
        pop.reproduce()
    assert evaluate.solved.any(), "XOR not solved in 100 generations"
    winner = pop.genomes[int(np.flatnonzero(evaluate.solved)[0])]
    assert len(winner.hidden) >= 1  # XOR needs a hidden node


def test_threshold_adapts_toward_the_target_species_count():
    config = XOR_CONFIG.replace(target_species=8)
    pop = Population(config, Layout(2, 1, 1), seed=3)
    stats = _run(pop, 60)
    counts = [s["species"] for s in stats]
    assert max(counts[:20]) > 12  # starts with too many species for the target...
    assert abs(np.mean(counts[-20:]) - 8) <= 2  # ...and the threshold brings it back
    assert stats[-1]["threshold"] > config.compat_threshold


def test_offspring_counts_add_up_and_stagnant_species_stop_reproducing():
    config = NeatConfig(population_size=20, stagnation_generations=5, young_species_age=0)
    pop = Population(config.replace(target_species=2, compat_threshold=0.01), Layout(2, 1, 1), seed=0)
    rng = np.random.default_rng(0)
    pop.evaluate(lambda genomes: rng.random(len(genomes)))
    species = list(pop.species.species.values())
    assert len(species) >= 3
    species[0].last_improved = -10  # stagnant, and (let it not hold the best genome)
    best = max((g for s in species for g in s.members), key=lambda g: g.fitness)
    if best in species[0].members:
        species[0], species[1] = species[1], species[0]
        species[0].last_improved = -10
    counts = offspring_counts(species, config, generation=0)
    assert sum(counts.values()) == 20
    assert counts[species[0].key] == 0


def test_champion_of_a_large_species_is_copied_unchanged():
    pop = Population(XOR_CONFIG, Layout(2, 1, 1), seed=2)
    evaluate = xor_evaluator(XOR_CONFIG.sigmoid_steepness)
    pop.evaluate(evaluate)
    champions = {
        s.key: max(s.members, key=lambda g: (g.fitness, -g.key)) for s in pop.species.species.values()
        if len(s.members) > 5
    }
    assert champions
    pop.reproduce()
    offspring = [json.dumps({k: v for k, v in g.to_dict().items() if k not in ("key", "fitness")})
                 for g in pop.genomes]
    for champion in champions.values():
        genes = json.dumps({k: v for k, v in champion.to_dict().items() if k not in ("key", "fitness")})
        assert genes in offspring


def test_config_from_yaml_rejects_unknown_keys_and_bad_types():
    doc = yaml.safe_load("population_size: 64\ntarget_species: 8\n")
    config = NeatConfig.from_mapping(doc, "evolve.yaml", "neat.")
    assert config.population_size == 64 and config.compat_exponent == 1.0
    with pytest.raises(ConfigError, match="evolve.yaml: neat.populaton_size: unknown NEAT parameter"):
        NeatConfig.from_mapping({"populaton_size": 10}, "evolve.yaml", "neat.")
    with pytest.raises(ConfigError, match="neat.add_node_prob: must be within"):
        NeatConfig.from_mapping({"add_node_prob": 1.5}, "evolve.yaml", "neat.")
    with pytest.raises(ConfigError, match="neat.population_size: must be an integer"):
        NeatConfig.from_mapping({"population_size": "many"}, "evolve.yaml", "neat.")


def test_defaults_follow_the_seeds():
    c = NeatConfig()
    assert (c.population_size, c.target_species, c.compat_exponent) == (512, 30, 1.0)
    assert c.weight_sigma ** 2 == pytest.approx(0.1)
    assert (c.add_node_prob, c.add_link_prob, c.survival_threshold) == (0.03, 0.05, 0.2)
    assert (c.young_species_bonus, c.disable_inherit_prob, c.elitism_min_size) == (1.2, 0.75, 6)


def test_fitness_must_be_finite_and_non_negative():
    pop = Population(XOR_CONFIG, Layout(2, 1, 1), seed=0)
    with pytest.raises(ValueError, match="finite and >= 0"):
        pop.evaluate(lambda genomes: [-1.0] * len(genomes))
