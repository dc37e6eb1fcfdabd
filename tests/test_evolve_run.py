"""`biped evolve` end to end: a short run, its folder, resume, eval, export and video."""

import csv
import functools
import json
import subprocess
import sys

import numpy as np
import pytest
import yaml

from evolve.cli import main
from evolve.evaluation import EvaluatorSpec, LocalBackend
from evolve.locomotion.task import TaskConfig
from evolve.ray_backend import WorkerEvaluator
from evolve.neat import Population
from evolve.run_stats import STATS_COLUMNS
from sim2real.controller.file import Controller
from sim2real.controller.symmetry import SIDE_BIAS
from sim2real.errors import ConfigError
from sim2real.robot import load_robot

SMALL = {
    "robot": "xl430_biped", "seed": 5, "generations": 4, "threads": 2, "checkpoint_every": 2,
    "task": {"episode_s": 1.0, "harness_generations": 2, "harness_fade_generations": 1},
    "neat": {"population_size": 10, "target_species": 3, "compat_threshold": 0.5,
             "add_node_prob": 0.2, "add_link_prob": 0.3},
}
DETERMINISTIC = ("generation", "best_fitness", "mean_fitness", "best_distance_m", "best_upright_s", "species",
                 "mean_connections", "mean_hidden", "evaluations", "harness", "threshold")


@pytest.fixture
def config_file(tmp_path):
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(SMALL))
    return path


def _stats(run_dir):
    with open(run_dir / "stats.csv", newline="") as f:
        return [{k: row[k] for k in DETERMINISTIC} for row in csv.DictReader(f)]


def test_evolve_writes_the_run_folder(config_file, tmp_path):
    out = tmp_path / "run"
    assert main(["evolve", str(config_file), "--out", str(out), "--quiet"]) == 0
    for name in ("config.yaml", "checkpoint.json.gz", "stats.csv", "fitness.png", "controller.json", "best.json"):
        assert (out / name).exists(), name
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == [
        "gen_00000.json.gz", "gen_00002.json.gz", "gen_00004.json.gz"]
    rows = _stats(out)
    assert [int(r["generation"]) for r in rows] == [0, 1, 2, 3]
    assert [float(r["harness"]) for r in rows] == [1.0, 0.5, 0.0, 0.0]
    resolved = yaml.safe_load((out / "config.yaml").read_text())
    assert resolved["neat"]["weight_sigma"] > 0  # every default written out
    controller = Controller.load(out / "controller.json", load_robot())
    assert controller.provenance["seed"] == 5
    assert len(controller.inputs) == 11 and controller.bias == ((1.0, 1.0), (1.0, -1.0))


def test_resumed_run_continues_exactly_as_an_uninterrupted_one(config_file, tmp_path):
    straight, split = tmp_path / "straight", tmp_path / "split"
    assert main(["evolve", str(config_file), "--out", str(straight), "--quiet"]) == 0
    assert main(["evolve", str(config_file), "--out", str(split), "--generations", "2", "--quiet"]) == 0
    assert main(["evolve", "--resume", "--out", str(split), "--generations", "4", "--quiet"]) == 0
    assert _stats(split) == _stats(straight)
    a = json.loads((straight / "controller.json").read_text())
    b = json.loads((split / "controller.json").read_text())
    assert a["connections"] == b["connections"] and a["hidden"] == b["hidden"]


def test_a_kill_between_checkpoints_resumes_from_the_older_one_exactly(config_file, tmp_path, monkeypatch):
    """The latest checkpoint is written at most every CHECKPOINT_INTERVAL_S (writing one every
    generation cost 13 % of a generation): a run stopped hard between two loses the
    generations since the last, and its resume reruns them to the same result."""
    import evolve.run_folder as run_module
    from evolve.run import Run
    from evolve.config import load_evolve_config

    monkeypatch.setattr(run_module, "CHECKPOINT_INTERVAL_S", 1e9)  # only stage starts and snapshots
    straight, killed = tmp_path / "straight", tmp_path / "killed"
    assert main(["evolve", str(config_file), "--out", str(straight), "--generations", "5", "--quiet"]) == 0
    config = load_evolve_config(config_file).replace(checkpoint_every=0)
    run = Run.create(config, killed, log=lambda line: None)

    def kill(run, row):
        if row["generation"] == 2:
            raise KeyboardInterrupt  # as a signal between generations would, before any save
        return False

    with pytest.raises(KeyboardInterrupt):
        run.evolve(stop=kill)
    assert run.checkpoint_generation == 0 and len(_stats(killed)) == 3
    assert main(["evolve", "--resume", "--out", str(killed), "--generations", "5", "--quiet"]) == 0
    assert _stats(killed) == _stats(straight)


def test_stats_log_the_champions_fitness_terms_by_name(config_file, tmp_path):
    out = tmp_path / "run"
    assert main(["evolve", str(config_file), "--out", str(out), "--quiet"]) == 0
    with open(out / "stats.csv", newline="") as f:
        reader = csv.DictReader(f)
        rows = list(reader)
    assert reader.fieldnames[-7:] == ["distance", "time", "progress", "velocity", "yaw_rate", "straight", "turn"]  # eq. 3, selection's terms
    task = TaskConfig()
    for row in rows:  # f = c_d distance + c_t time, to the 6 digits stats.csv keeps
        fitness = task.distance_coeff * float(row["distance"]) + task.time_coeff * float(row["time"])
        assert fitness == pytest.approx(float(row["best_fitness"]), rel=1e-5)


def test_a_run_from_before_the_term_columns_resumes_with_them(config_file, tmp_path):
    straight, split = tmp_path / "straight", tmp_path / "split"
    assert main(["evolve", str(config_file), "--out", str(straight), "--quiet"]) == 0
    assert main(["evolve", str(config_file), "--out", str(split), "--generations", "2", "--quiet"]) == 0
    with open(split / "stats.csv", newline="") as f:
        old = [{k: v for k, v in row.items() if k in STATS_COLUMNS} for row in csv.DictReader(f)]
    with open(split / "stats.csv", "w", newline="") as f:  # as a run before them wrote it
        writer = csv.DictWriter(f, STATS_COLUMNS)
        writer.writeheader()
        writer.writerows(old)
    assert main(["evolve", "--resume", "--out", str(split), "--generations", "4", "--quiet"]) == 0
    assert _stats(split) == _stats(straight)
    with open(split / "stats.csv", newline="") as f:
        assert [row["distance"] != "" for row in csv.DictReader(f)] == [False, False, True, True]


def test_each_backend_owns_its_evaluator():
    spec = EvaluatorSpec("xl430_biped", {"episode_s": 1.0}, "nominal", 2, threads=1)
    assert LocalBackend(spec).evaluator is not LocalBackend(spec).evaluator  # no batch shared unseen
    worker = WorkerEvaluator()  # a Ray worker's: one evaluator kept across the chunks of a spec
    first = worker.get(spec)
    assert worker.get(EvaluatorSpec("xl430_biped", {"episode_s": 1.0}, "nominal", 2, threads=1)) is first
    assert worker.get(EvaluatorSpec("xl430_biped", {"episode_s": 1.0}, "nominal", 3, threads=1)) is not first


def test_the_same_seed_gives_the_same_run_whatever_the_threads(config_file, tmp_path):
    assert main(["evolve", str(config_file), "--out", str(tmp_path / "a"), "--threads", "1", "--quiet"]) == 0
    assert main(["evolve", str(config_file), "--out", str(tmp_path / "b"), "--threads", "2", "--quiet"]) == 0
    assert _stats(tmp_path / "a") == _stats(tmp_path / "b")


def test_eval_export_and_render_a_controller(config_file, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["evolve", str(config_file), "--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["eval", str(out / "controller.json"), "--seconds", "1", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert set(report) >= {"distance_m", "upright_s", "fell", "leg_length_m"}
    assert report["leg_length_m"] == pytest.approx(load_robot().body.leg_length)
    assert main(["export", str(out), "-o", str(tmp_path / "c.json")]) == 0
    assert (tmp_path / "c.json").read_bytes() == (out / "controller.json").read_bytes()
    assert Controller.load(tmp_path / "c.json") == Controller.load(out / "controller.json")
    video = tmp_path / "walk.gif"
    result = subprocess.run([sys.executable, "-m", "evolve.cli", "render", str(out / "controller.json"),
                             "-o", str(video), "--seconds", "0.5", "--width", "160", "--height", "120"],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert video.stat().st_size > 1000


def test_a_controller_for_another_robot_or_a_broken_file_is_refused(config_file, tmp_path):
    out = tmp_path / "run"
    assert main(["evolve", str(config_file), "--out", str(out), "--quiet"]) == 0
    with pytest.raises(ConfigError, match="robot.joint_map_hash: made for robot 'xl430_biped'"):
        Controller.load(out / "controller.json", load_robot("op3_legs"))
    broken = tmp_path / "broken.json"
    broken.write_text((out / "controller.json").read_text()[:200])
    with pytest.raises(ConfigError, match="broken.json: not valid JSON"):
        Controller.load(broken)
    data = json.loads((out / "controller.json").read_text())
    data["connections"].append([0, 9999, 1.0, 0])
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(data))
    with pytest.raises(ConfigError, match=r"connections\[\d+\]: dst 9999 is not a node"):
        Controller.load(bad)


def test_an_existing_run_is_not_overwritten_and_bad_configs_are_named(config_file, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["evolve", str(config_file), "--out", str(out), "--generations", "1", "--quiet"]) == 0
    assert main(["evolve", str(config_file), "--out", str(out), "--quiet"]) == 2
    assert "already holds a run" in capsys.readouterr().err
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({**SMALL, "task": {"episode_seconds": 3}}))
    assert main(["evolve", str(bad), "--out", str(tmp_path / "x"), "--quiet"]) == 2
    assert "bad.yaml: task.episode_seconds: unknown task parameter" in capsys.readouterr().err


def test_ctrl_c_leaves_a_checkpoint_that_resumes_exactly(config_file, tmp_path):
    """A run far too long to finish is interrupted after a few generations; resumed to two
    generations past where it stopped, it matches a straight run of that length.  (With a
    short run the interrupt could land after its end: a race that skipped this test.)"""
    import signal
    import time

    long = tmp_path / "long.yaml"
    long.write_text(yaml.safe_dump({**SMALL, "generations": 100_000}))
    stopped, straight = tmp_path / "stopped", tmp_path / "straight"
    # SIGINT back to its default in the child: a test runner started in the background (`&`,
    # nohup) has it ignored, the child inherits that, and the interrupt would never land.
    proc = subprocess.Popen([sys.executable, "-m", "evolve.cli", "evolve", str(long), "--out", str(stopped), "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # a condition, not a time: a loaded machine takes minutes to start MuJoCo, and an interrupt
    # that landed during start-up would end in a traceback, not a checkpoint
    deadline = time.monotonic() + 900
    while proc.poll() is None:
        if (stopped / "stats.csv").exists() and len((stopped / "stats.csv").read_text().splitlines()) >= 3:
            break
        if time.monotonic() > deadline:
            proc.kill()
            pytest.fail("no two generations within 15 min")
        time.sleep(0.05)
    assert proc.poll() is None, proc.communicate()[1]
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "--resume" in err
    reached = len(_stats(stopped))
    target = str(reached + 2)
    assert main(["evolve", "--resume", "--out", str(stopped), "--generations", target, "--quiet"]) == 0
    assert main(["evolve", str(long), "--out", str(straight), "--generations", target, "--quiet"]) == 0
    assert len(_stats(stopped)) == reached + 2
    assert _stats(stopped) == _stats(straight)


def test_controller_matches_its_json_schema_and_stays_small(config_file, tmp_path):
    import json as _json
    from pathlib import Path

    import jsonschema

    import sim2real

    out = tmp_path / "run"
    assert main(["evolve", str(config_file), "--out", str(out), "--quiet"]) == 0
    schema = _json.loads((Path(sim2real.__file__).parent / "controller" / "schemas" / "controller-v1.schema.json").read_text())
    data = _json.loads((out / "controller.json").read_text())
    jsonschema.validate(data, schema)
    data["connections"] = [[0, 13 + (i % 4), 0.123456789012345 * i, 0] for i in range(300)]
    Controller.from_dict(data).save(tmp_path / "big.json")
    assert (tmp_path / "big.json").stat().st_size < 20_000


@pytest.mark.parametrize("shipped", [True, False], ids=["shipped-walker", "none-shipped"])
def test_quickstart_runs_the_whole_job(tmp_path, capsys, monkeypatch, grown_controller, shipped):
    """The short evolution, then the robot's shipped walker dry-run and compared (or, for a
    robot without one, the short run's best)."""
    import sim2real.robot.paths

    walker = tmp_path / "shipped.json"
    if shipped:
        grown_controller.save(walker)
    monkeypatch.setattr(sim2real.robot.paths, "shipped_controller", lambda robot: walker)
    out = tmp_path / "qs"
    assert main(["quickstart", "--out", str(out), "--generations", "1", "--population", "8", "--no-video"]) == 0
    for name in ("controller.json", "dry_run.csv", "dry_run.json", "compare.png", "run/stats.csv"):
        assert (out / name).exists(), name
    assert (out / "walker.json").exists() == shipped
    dry_run_of = json.loads((out / "dry_run.json").read_text())["controller_provenance"]
    assert ("run" not in dry_run_of) == shipped  # the shipped walker was dry-run, not the short run's best
    text = capsys.readouterr().out
    assert "[5/5]" in text and "contact agreement" in text and str(out) in text
    assert ("the project's walker" in text) == shipped


VALIDATED = {**SMALL, "generations": 5, "task": {**SMALL["task"], "harness_generations": 0},
             "randomize": {"reality": "randomize", "episodes": 2,
                           "validation": {"draws": 3, "every": 2, "candidates": 3}}}


def test_champions_are_chosen_on_validation_draws_selection_never_saw(tmp_path):
    from evolve.config import parse_evolve_config
    from evolve.evaluation import validation_episodes
    from evolve.run import Run

    config = parse_evolve_config(VALIDATED, "validated.yaml")
    run = Run.create(config, tmp_path / "run", log=lambda line: None)
    run.evolve()
    best = json.loads((tmp_path / "run" / "best.json").read_text())
    assert best["validation"]["draws"] == 3 and best["generation"] in (1, 3, 4)  # generations 2, 4 and the last
    with open(tmp_path / "run" / "stats.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [bool(r["validation_walked"]) for r in rows] == [False, True, False, True, True]
    # the recorded outcome is the champion's on those draws, measured again from its genome
    champion = run.best
    again = validation_episodes(run.backend, [champion.genome], steepness=config.neat.sigmoid_steepness, stage=None,
                                draws=3, seed=config.seed, stage_index=0, capacity=run.capacity)
    assert again.fitness.mean() == pytest.approx(best["validation"]["fitness"])
    # and validated champions are not replaced by a generation's lucky training score
    controller = Controller.load(tmp_path / "run" / "controller.json", load_robot())
    assert controller.provenance["validation"] == best["validation"]


def test_with_consistency_a_draw_counts_only_if_it_keeps_the_share_of_the_walk_on_the_model(tmp_path):
    from evolve.config import parse_evolve_config
    from evolve.evaluation import validation_episodes
    from evolve.run import Run

    doc = {**VALIDATED, "randomize": {**VALIDATED["randomize"],
                                      "validation": {**VALIDATED["randomize"]["validation"], "consistency": 0.5}}}
    config = parse_evolve_config(doc, "consistent.yaml")
    assert config.randomize.validation.to_dict()["consistency"] == 0.5
    run = Run.create(config, tmp_path / "run", log=lambda line: None)
    run.evolve()
    best = json.loads((tmp_path / "run" / "best.json").read_text())["validation"]
    episodes = functools.partial(validation_episodes, run.backend, [run.best.genome],
                                 steepness=config.neat.sigmoid_steepness, stage=None, draws=3, seed=config.seed,
                                 stage_index=0, capacity=run.capacity)
    draws, model = episodes(), episodes(on_model=True)
    assert model.distance_m.size == 1 and model.distance_m[0] == pytest.approx(best["model_distance_m"])
    assert model.distance_m[0] != pytest.approx(draws.distance_m[0])  # the model is not one of the draws
    leg, seconds = run.robot.leg_length, run.evaluator.episode_s
    counted = draws.walked(leg, seconds) & (draws.distance_m >= 0.5 * model.distance_m[0]) & model.walked(leg, seconds)
    assert best["walked"] == int(counted.sum())
    doc["randomize"]["validation"]["consistency"] = 1.5
    with pytest.raises(ConfigError, match="consistency.*<= 1"):
        parse_evolve_config(doc, "bad.yaml")


def test_validation_can_be_longer_than_training_and_refuse_walkers_that_turn(tmp_path):
    """validation.episode_s: validation's own, longer episodes; validation.heading_deg: a draw
    counts only if the torso never turned further than that from the start's heading."""
    from evolve.config import parse_evolve_config
    from evolve.evaluation import validation_episodes
    from evolve.run import Run

    doc = {**VALIDATED, "randomize": {**VALIDATED["randomize"], "validation": {
        **VALIDATED["randomize"]["validation"], "episode_s": 2.0, "heading_deg": 0.5}}}
    config = parse_evolve_config(doc, "long.yaml")
    assert config.randomize.validation.to_dict()["episode_s"] == 2.0
    run = Run.create(config, tmp_path / "run", log=lambda line: None)
    assert run.validation_backend is not run.backend and run.validation_episode_s > run.evaluator.episode_s
    run.evolve()
    best = json.loads((tmp_path / "run" / "best.json").read_text())["validation"]
    again = validation_episodes(run.validation_backend, [run.best.genome], steepness=config.neat.sigmoid_steepness,
                                stage=None, draws=3, seed=config.seed, stage_index=0, capacity=3)
    assert np.all(again.upright_s <= run.validation_episode_s + 1e-9) and again.upright_s.max() > run.evaluator.episode_s
    counted = again.walked(run.robot.leg_length, run.validation_episode_s) & (again.terms["turn"] <= 0.5)
    assert best["walked"] == int(counted.sum())
    for key, value in (("heading_deg", 200.0), ("episode_s", 0.0)):
        doc["randomize"]["validation"][key] = value
        with pytest.raises(ConfigError, match=f"validation.{key}"):
            parse_evolve_config(doc, "bad.yaml")
        doc["randomize"]["validation"][key] = 1.0


def test_validation_needs_ranges_to_draw_from(tmp_path):
    from evolve.config import parse_evolve_config

    doc = {**VALIDATED, "randomize": {"episodes": 2, "validation": {"draws": 3}}}
    with pytest.raises(ConfigError, match="randomize.validation.*randomize.reality"):
        parse_evolve_config(doc, "bad.yaml")
    doc = {**VALIDATED, "randomize": {"reality": "randomize", "validation": {"draws": 0}}}
    with pytest.raises(ConfigError, match="draws"):
        parse_evolve_config(doc, "bad.yaml")


def test_a_validated_champion_beats_any_unvalidated_one_and_walks_count_first():
    from evolve.champion import Best

    def best(fitness, validation=None, harness=0.0):
        return Best(fitness, 0.0, 0.0, 0, harness, genome=None, validation=validation)

    validated = best(1.0, {"draws": 10, "walked": 3, "fitness": 1.0, "distance_m": 0.1})
    assert validated.better_than(best(50.0)) and not best(50.0).better_than(validated)
    more_walks = best(0.5, {"draws": 10, "walked": 4, "fitness": 0.5, "distance_m": 0.1})
    assert more_walks.better_than(validated)
    on_more_robots = best(0.5, {"draws": 30, "walked": 11, "fitness": 0.5, "distance_m": 0.1})  # 37 % < 40 %
    assert more_walks.better_than(on_more_robots) and on_more_robots.better_than(validated)
    assert best(2.0).better_than(best(1.0)) and best(1.0).better_than(best(9.0, harness=1.0))


def test_randomization_starts_at_its_generation_and_ramps_from_there():
    from evolve.config import RandomizeConfig

    r = RandomizeConfig("randomize", 3, "mean", ramp_generations=4, start_generation=10)
    assert [r.intensity(g) for g in (0, 9, 10, 12, 14, 99)] == [0.0, 0.0, 0.0, 0.5, 1.0, 1.0]
    assert RandomizeConfig("randomize", 3, start_generation=5).intensity(5) == 1.0  # no ramp: at once


def test_nominal_episodes_are_simulated_once_and_counted_as_many_times():
    from evolve.evaluation import score_population
    from evolve.locomotion.evaluator import neat_layout
    from evolve.neat import NeatConfig, Population
    from sim2real.controller.symmetry import symmetric_layout

    robot = load_robot()
    spec = EvaluatorSpec("xl430_biped", {"episode_s": 1.0}, "randomize", 12, 1)
    backend = LocalBackend(spec)
    layout = neat_layout(symmetric_layout(robot, robot.control_sets["walk"]))
    genomes = Population(NeatConfig(population_size=4, target_species=2), layout, seed=3).genomes
    options = dict(steepness=1.0, harness=0.0, stage=None, score="mean", intensity=0.0, key=(1, 0, 0))
    once = score_population(backend, genomes, episodes=1, **options)
    thrice = score_population(backend, genomes, episodes=3, **options)
    # the mean of three equal numbers, to its last bit as when all three were simulated
    assert thrice.fitness == pytest.approx(once.fitness, rel=1e-15)
    assert thrice.distance_m == pytest.approx(once.distance_m, rel=1e-15)
    assert thrice.steps == once.steps  # not simulated three times


def test_shared_draws_put_every_genome_of_a_generation_on_the_same_robots():
    from evolve.evaluation import score_population
    from evolve.locomotion.evaluator import neat_layout
    from evolve.neat import NeatConfig, Population
    from sim2real.controller.symmetry import symmetric_layout

    robot = load_robot()
    backend = LocalBackend(EvaluatorSpec("xl430_biped", {"episode_s": 1.0}, "randomize", 12, 1))
    layout = neat_layout(symmetric_layout(robot, robot.control_sets["walk"]))
    genome = Population(NeatConfig(population_size=2, target_species=1), layout, seed=3).genomes[0]
    twins = [genome, genome.copy(genome.key + 1)]
    options = dict(steepness=1.0, harness=0.0, stage=None, episodes=2, score="mean", intensity=1.0, key=(1, 0, 7))
    own = score_population(backend, twins, **options)
    shared = score_population(backend, twins, shared=True, **options)
    assert own.distance_m[0] != own.distance_m[1]  # each twin on its own robots
    assert shared.distance_m[0] == shared.distance_m[1]  # both on the same ones
    assert shared.distance_m[0] == own.distance_m[0]  # genome 0's key is the shared one


def test_with_validation_a_stage_ends_when_its_validated_champion_reaches_the_threshold(tmp_path):
    """The module filed and built on is the validated champion, so that is what must solve the
    stage (a generation's training score once ended a stage whose filed module had not)."""
    from evolve.config import parse_evolve_config
    from evolve.run import Run

    doc = {**VALIDATED, "generations": None, "stages": [
        {"name": "pose", "objective": "pose", "generations": 6, "threshold": 0.05},
        {"name": "stand", "objective": "stand", "generations": 2}]}
    doc.pop("generations")
    config = parse_evolve_config(doc, "staged.yaml")
    run = Run.create(config, tmp_path / "run", log=lambda line: None)
    run.evolve()
    pose = json.loads((tmp_path / "run" / "stages.json").read_text())[0]
    filed = json.loads((tmp_path / "run" / "stages" / "pose" / "best.json").read_text())
    assert filed["validation"] is not None
    assert pose["solved"] == (filed["fitness"] >= 0.05 * pose["max_fitness"])
    assert pose["solved"] or pose["generations"] == 6


@pytest.mark.parametrize("side_bias", [True, False])
def test_no_link_ever_leaves_the_side_bias_node_when_the_config_says_so(tmp_path, side_bias):
    """``neat.side_bias: false``: the two networks of a genome differ only by what they sense
    (the human-gait ablation of the +1/-1 side input): neither the first genomes nor a mutation
    link from it, and a resumed run keeps the rule."""
    config = {**SMALL, "generations": 3, "neat": {**SMALL["neat"], "side_bias": side_bias, "add_link_prob": 0.9}}
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(config))
    out = tmp_path / "run"
    assert main(["evolve", str(path), "--out", str(out), "--quiet", "--generations", "2"]) == 0
    assert main(["evolve", "--resume", "--out", str(out), "--generations", "3", "--quiet"]) == 0
    population = Population.load(out / "checkpoint.json.gz")  # every genome after the resume
    side = population.layout.bias_ids[SIDE_BIAS]
    linked = [g.key for g in population.genomes if any(c.src == side for c in g.conns.values())]
    assert bool(linked) == side_bias
    assert population.generation == 3
