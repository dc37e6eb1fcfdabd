"""Fitness as named terms: each objective's terms, weighted from the config, make its fitness
exactly; the registry names every objective; a genome's terms over several episodes."""

import numpy as np
import pytest
from neat_helpers import grown_population

from evolve.evaluation import Job, score_population
from evolve.locomotion.evaluator import LocomotionEvaluator, neat_layout
from evolve.locomotion.objectives import OBJECTIVES, Episodes, PoseObjective, WalkObjective
from evolve.locomotion.task import TaskConfig
from evolve.stages import parse_stages
from sim2real.controller.symmetry import symmetric_layout
from sim2real.errors import ConfigError
from sim2real.robot import load_robot

ROBOT = load_robot()
TASK = TaskConfig(episode_s=1.0, distance_coeff=2.0, time_coeff=0.25, progress_coeff=0.5)


@pytest.fixture(scope="module")
def evaluator():
    return LocomotionEvaluator(ROBOT, TASK, 10, threads=1)


@pytest.fixture(scope="module")
def genomes():
    layout = neat_layout(symmetric_layout(ROBOT, ROBOT.control_sets["walk"]))
    return grown_population(seed=7, generations=3, size=10, layout=layout).genomes


@pytest.mark.parametrize("harness", [0.0, 1.0])
def test_walk_fitness_is_eq_3_of_its_terms_with_the_task_coefficients(evaluator, genomes, harness):
    e = evaluator.evaluate(genomes, 1.0, harness=harness)
    assert tuple(e.terms) == WalkObjective.TERMS == OBJECTIVES["walk"].terms
    assert np.array_equal(e.fitness, 2.0 * e.terms["distance"] + 0.25 * e.terms["time"])
    assert np.array_equal(e.selection, e.fitness + 0.5 * e.terms["progress"])  # the tie-breaker
    assert np.all(e.terms["distance"] >= TASK.epsilon)
    # the time term is the time upright (none if unstable)
    assert e.terms["time"] == pytest.approx(np.where(e.unstable, 0.0, e.upright_s), abs=1e-9)


@pytest.mark.parametrize("objective", ["pose", "stand"])
def test_pose_and_stand_fitness_is_eq_4_1_of_their_terms_with_the_stage_weights(evaluator, genomes, objective):
    weights = {"rest_pose": 2.0, "rest_pose_end": 0.5, "com": 1.5, "feet": 0.25}
    stage, = parse_stages([{"name": "s", "objective": objective, "generations": 1, "weights": weights}], "x")
    e = evaluator.evaluate(genomes, 1.0, objective=stage.make_objective)
    assert tuple(e.terms) == PoseObjective.TERMS == OBJECTIVES[objective].terms
    for i in range(len(genomes)):  # the plain oracle: f = 100 (dt / T) prod (1 + w / (1 + x))
        expected = float(e.terms["survival"][i])
        for name, w in weights.items():
            expected *= 1.0 + w / (1.0 + float(e.terms[name][i]))
        assert e.fitness[i] == (0.0 if e.unstable[i] else expected)
    assert np.all((0.0 <= e.terms["survival"]) & (e.terms["survival"] <= 100.0))
    assert np.array_equal(e.selection, e.fitness)  # no tie-breaker


def test_the_registry_names_every_objective_a_stage_can_choose():
    for name, kind in OBJECTIVES.items():
        stage, = parse_stages([{"name": "s", "objective": name, "generations": 1}], "x")
        assert stage.kind is kind and stage.weights == kind.weights
        assert kind.harness == (name == "walk")  # the harness holds walkers only
    with pytest.raises(ConfigError, match="must be one of " + ", ".join(OBJECTIVES)):
        parse_stages([{"name": "s", "objective": "dance", "generations": 1}], "x")


class _Fixed:
    """A backend returning fixed per-simulation episodes."""

    def __init__(self, episodes: Episodes):
        self.episodes = episodes

    def run(self, job: Job) -> Episodes:
        assert len(job.genomes) == len(self.episodes.fitness)
        return self.episodes


@pytest.mark.parametrize("score", ["mean", "worst"])
def test_a_genomes_terms_over_episodes_are_their_mean_or_its_worst_episodes(genomes, score):
    fitness = np.array([3.0, 2.0, 1.0, 5.0, 4.0, 6.0])  # 2 genomes x 3 episodes
    a, b = np.arange(6.0), np.arange(6.0) * 10
    per_sim = Episodes(fitness, fitness, np.zeros(6), np.ones(6), np.zeros(6, bool), np.zeros(6, bool), 60,
                       {"a": a, "b": b})
    e = score_population(_Fixed(per_sim), genomes[:2], steepness=1.0, harness=0.0, stage=None, episodes=3,
                         score=score, intensity=1.0, key=(0, 0, 0))
    if score == "mean":
        assert e.fitness.tolist() == [2.0, 5.0] and e.terms["a"].tolist() == [1.0, 4.0]
    else:  # the terms of each genome's episode of lowest fitness: its 3rd, its 2nd
        assert e.fitness.tolist() == [1.0, 4.0] and e.terms["a"].tolist() == [2.0, 4.0]
        assert e.terms["b"].tolist() == [20.0, 40.0]


def test_a_selection_distance_cap_leaves_the_reported_fitness_alone(genomes):
    plain = TaskConfig(episode_s=1.0, harness_generations=0)
    capped = TaskConfig(episode_s=1.0, harness_generations=0, selection_distance_cap=0.01)
    a = LocomotionEvaluator(ROBOT, plain, len(genomes), threads=1).evaluate(genomes, 1.0, harness=1.0)
    b = LocomotionEvaluator(ROBOT, capped, len(genomes), threads=1).evaluate(genomes, 1.0, harness=1.0)
    assert np.array_equal(a.fitness, b.fitness)  # eq. 3 as reported
    excess = np.maximum(b.terms["distance"] - 0.01, 0.0)
    assert excess.any()
    assert b.selection == pytest.approx(b.fitness - plain.distance_coeff * excess)


def test_a_walk_bonus_counts_in_selection_for_the_episodes_that_walked():
    from evolve.locomotion.export import genome_from_controller
    from evolve.neat import Genome
    from sim2real.controller.file import Controller
    from sim2real.robot.paths import data_root

    walker = Controller.load(data_root() / "configs" / "controllers" / "xl430_biped_no_gyro.json")
    task = TaskConfig(episode_s=10.0, harness_generations=0, phase_period_s=walker.phase_period_s,
                      selection_walk_bonus=5.0)
    evaluator = LocomotionEvaluator(ROBOT, task, 2, threads=1)
    stander = Genome(0, evaluator.neat_layout)  # no links: it holds its pose
    e = evaluator.evaluate([genome_from_controller(walker), stander], 1.0, harness=0.0)
    walked = e.walked(ROBOT.leg_length, evaluator.episode_s)
    assert walked.tolist() == [True, False]
    assert np.array_equal(e.selection - e.fitness, 5.0 * walked)  # eq. 3 itself as reported


def test_with_a_heading_limit_only_walks_that_kept_their_heading_earn_the_bonus():
    from evolve.locomotion.export import genome_from_controller
    from sim2real.simulation.model.robot_model import heading_rad
    from sim2real.controller.file import Controller
    from sim2real.robot.paths import data_root

    assert heading_rad(np.array([[1.0, 1.0, 0.3], [1.0, 0.0, 0.0]])) == pytest.approx([np.pi / 4, 0.0])
    walker = Controller.load(data_root() / "configs" / "controllers" / "xl430_biped_no_gyro.json")
    bonus, headings = {}, []
    for limit in (150.0, 30.0):  # on the nominal robot it walks to the left, turning ~90 deg in 10 s
        task = TaskConfig(episode_s=10.0, harness_generations=0, phase_period_s=walker.phase_period_s,
                          selection_walk_bonus=5.0, selection_heading_deg=limit)
        evaluator = LocomotionEvaluator(ROBOT, task, 1, threads=1)
        e = evaluator.evaluate([genome_from_controller(walker)], 1.0, harness=0.0,
                               on_tick=lambda ev, alive: headings.append(np.degrees(ev.heading(alive, 0, None)[0])))
        assert e.walked(ROBOT.leg_length, evaluator.episode_s).tolist() == [True]
        bonus[limit] = float(e.selection[0] - e.fitness[0])
    assert 30.0 < np.abs(headings).max() < 150.0
    assert bonus == {150.0: 5.0, 30.0: 0.0}
    with pytest.raises(ConfigError, match="selection_heading_deg"):
        TaskConfig.from_mapping({"selection_heading_deg": 20.0})


@pytest.mark.parametrize("values, problem", [
    ({"heading_scale_deg": 45.0}, "heading_scale_deg: is the heading input's setting: give it only with heading_input"),
    ({"heading_input": True, "heading_scale_deg": 0.0}, r"heading_scale_deg: must be within \(0, 180\] deg, got 0"),
    ({"heading_input": True, "heading_scale_deg": 200.0}, r"heading_scale_deg: must be within \(0, 180\] deg, got 200"),
])
def test_a_heading_scale_is_a_turn_within_half_a_turn_and_needs_the_input(values, problem):
    with pytest.raises(ConfigError, match=problem):
        TaskConfig.from_mapping(values, "walk.yaml")
    assert TaskConfig.from_mapping({"heading_input": True, "heading_scale_deg": 45.0}).heading_scale_deg == 45.0


def test_the_replays_turn_is_unwrapped_and_its_largest_kept():
    from evolve.replay import TurnTracker

    class Spinning:  # an evaluator whose two torsos yaw along given paths [rad]
        def __init__(self, paths):
            self.paths, self.t = np.array(paths), 0

        def heading(self, ids, tick, p):
            return np.angle(np.exp(1j * self.paths[:, min(self.t, self.paths.shape[1] - 1)]))

    ev = Spinning([[0.0, 1.5, 3.0, 4.5, 6.0], [0.0, -0.5, -1.0, 0.2, 0.1]])  # one turns a full circle
    turn = TurnTracker(2)
    for ev.t in range(5):
        turn(ev, np.array([0, 1]) if ev.t < 4 else np.array([0]))  # the second fell before the last tick
    assert turn.turn == pytest.approx([6.0, 0.2]) and turn.max_turn == pytest.approx([6.0, 1.0])
