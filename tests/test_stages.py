"""Developmental hierarchies: stage configs, frozen lower modules, switching modules off."""

import csv
import json

import pytest
import yaml

from evolve.cli import main
from evolve.config import parse_evolve_config
from evolve.locomotion.objectives import OBJECTIVES
from evolve.neat import Population
from evolve.replay import evaluate_controller
from evolve.run import Run
from evolve.stages import parse_stages
from sim2real.controller.file import Controller
from sim2real.errors import ConfigError

STAGED = {
    "robot": "xl430_biped", "seed": 2, "threads": 1,
    "task": {"episode_s": 0.6},
    "neat": {"population_size": 8, "target_species": 2, "compat_threshold": 0.5,
             "add_node_prob": 0.3, "add_link_prob": 0.5},
    "stages": [{"name": "pose", "objective": "pose", "generations": 2},
               {"name": "stand", "objective": "stand", "generations": 3}],
}


def test_table_4_1_weights_are_the_defaults():
    pose, stand = parse_stages([{"name": "p", "objective": "pose", "generations": 1},
                                {"name": "s", "objective": "stand", "generations": 1, "threshold": 0.94}], "x")
    assert (pose.weights.rest_pose, pose.weights.rest_pose_end, pose.weights.com) == (3, 1, 0)
    assert pose.max_fitness == 100 * 4 * 2 and stand.max_fitness == 100 * 2 ** 4
    assert stand.solved(0.94 * 1600) and not stand.solved(0.93 * 1600) and not pose.solved(800)


@pytest.mark.parametrize("stages, key, problem", [
    ([{"name": "a", "objective": "run", "generations": 1}], "stages[0].objective", "must be one of"),
    ([{"name": "a", "objective": "pose"}], "stages[0].generations", "missing"),
    ([{"name": "a", "objective": "pose", "generations": 1}, {"name": "a", "objective": "stand", "generations": 1}],
     "stages[1].name", "used twice"),
    ([{"name": "w", "objective": "walk", "generations": 1, "threshold": 0.5}], "stages[0]", "no weights or threshold"),
    ([{"name": "a", "objective": "pose", "generations": 1, "weights": {"comm": 1.0}}], "stages[0].weights.comm", "unknown"),
])
def test_bad_stages_name_the_key(stages, key, problem):
    with pytest.raises(ConfigError) as err:
        parse_evolve_config({"stages": stages}, "h.yaml")
    assert err.value.key == key and problem in str(err.value)


@pytest.fixture(scope="module")
def staged_run(tmp_path_factory):
    root = tmp_path_factory.mktemp("staged")
    config = root / "staged.yaml"
    config.write_text(yaml.safe_dump(STAGED))
    out = root / "run"
    assert main(["evolve", str(config), "--out", str(out), "--quiet"]) == 0
    return out


def test_stages_run_in_order_and_are_filed(staged_run):
    finished = json.loads((staged_run / "stages.json").read_text())
    assert [s["name"] for s in finished] == ["pose", "stand"]
    assert [s["generations"] for s in finished] == [2, 3]
    rows = (staged_run / "stats.csv").read_text().splitlines()[1:]
    assert [r.split(",")[1] for r in rows] == ["pose"] * 2 + ["stand"] * 3
    assert [int(r.split(",")[0]) for r in rows] == [0, 1, 2, 3, 4]
    pose = Controller.load(staged_run / "stages" / "pose" / "controller.json")
    final = Controller.load(staged_run / "controller.json")
    assert pose.modules == ("pose",)
    assert final.modules == ("pose", "stand")


def test_each_stage_logs_its_objectives_terms_and_leaves_the_others_empty(tmp_path):
    doc = {**STAGED, "stages": [{"name": "pose", "objective": "pose", "generations": 1},
                                {"name": "walk", "objective": "walk", "generations": 1}]}
    Run.create(parse_evolve_config(doc, "staged"), tmp_path, log=lambda _: None).evolve()
    with open(tmp_path / "stats.csv", newline="") as f:
        reader = csv.DictReader(f)
        pose, walk = list(reader)
    terms = OBJECTIVES["pose"].terms + OBJECTIVES["walk"].terms
    assert tuple(reader.fieldnames[-len(terms):]) == terms
    assert [pose[t] != "" for t in terms] == [t in OBJECTIVES["pose"].terms for t in terms]
    assert [walk[t] != "" for t in terms] == [t in OBJECTIVES["walk"].terms for t in terms]


def test_lower_modules_stay_frozen(staged_run):
    pose = Controller.load(staged_run / "stages" / "pose" / "controller.json")
    frozen = sorted((s, d, w) for s, d, w, m in pose.connections)
    population = Population.load(staged_run / "checkpoint.json.gz")
    for genome in population.genomes:
        assert genome.modules == ("pose", "stand")
        lower = sorted((g.src, g.dst, g.weight) for g in genome.conns.values() if g.module == 0 and g.enabled)
        assert lower == frozen, genome.key
        assert all(genome.hidden[n] == 1 for n in genome.hidden if n not in dict(pose.hidden))


def test_switching_the_top_module_off_gives_the_lower_behaviour(staged_run):
    lower = evaluate_controller(staged_run / "stages" / "pose" / "controller.json")
    switched = evaluate_controller(staged_run / "controller.json", disabled_modules=("stand",))
    assert switched["fitness"] == lower["fitness"] and switched["upright_s"] == lower["upright_s"]
    both = evaluate_controller(staged_run / "controller.json")
    assert both["disabled_modules"] == [] and switched["disabled_modules"] == ["stand"]


def test_export_of_a_stage_and_of_a_missing_one(staged_run, tmp_path, capsys):
    out = tmp_path / "pose.json"
    assert main(["export", str(staged_run), "--stage", "pose", "-o", str(out)]) == 0
    assert Controller.load(out).modules == ("pose",)
    assert main(["export", str(staged_run), "--stage", "walk", "-o", str(out)]) != 0
    assert "no finished stage 'walk' (finished: pose, stand" in capsys.readouterr().err


def test_a_staged_run_resumes_exactly(staged_run, tmp_path):
    config = parse_evolve_config(STAGED, "staged")
    split = tmp_path / "split"
    Run.create(config, split, log=lambda _: None).evolve(stop=lambda run, row: row["generation"] == 3)
    assert json.loads((split / "stages.json").read_text())[0]["name"] == "pose"
    Run.resume(split, log=lambda _: None).evolve()

    def rows(out):
        return [r.split(",")[:4] for r in (out / "stats.csv").read_text().splitlines()]
    assert rows(split) == rows(staged_run)
    assert (split / "controller.json").read_bytes() != b"" and \
        Controller.load(split / "controller.json").connections == Controller.load(staged_run / "controller.json").connections


def test_a_target_pose_for_a_joint_not_driven_is_refused(tmp_path):
    doc = {**STAGED, "stages": [{"name": "pose", "objective": "pose", "generations": 1,
                                 "target_pose_deg": {"left_ankle_pitch": 5.0}}]}
    with pytest.raises(ConfigError) as err:
        Run.create(parse_evolve_config(doc, "staged"), tmp_path / "run", log=lambda _: None)
    assert err.value.key == "stages[0].target_pose_deg.left_ankle_pitch" and "not a driven joint" in str(err.value)
