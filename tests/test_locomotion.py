"""The locomotion task: symmetry wiring, batched evaluation, termination, harness."""

import dataclasses

import numpy as np
import pytest

from evolve.locomotion.evaluator import LocomotionEvaluator, neat_layout
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome, NeatConfig, Population
from sim2real.controller.symmetry import (
    bias_values,
    heading_input,
    joint_outputs,
    network_inputs,
    symmetric_layout,
)
from sim2real.robot import load_robot

ROBOT = load_robot()
TASK = TaskConfig(episode_s=1.5)


def random_genomes(n: int) -> list:
    """``n`` genomes grown for four generations on random fitness, seeded."""
    layout = neat_layout(symmetric_layout(ROBOT, ROBOT.control_sets["walk"]))
    pop = Population(NeatConfig(population_size=n, target_species=3, add_node_prob=0.3, add_link_prob=0.5),
                     layout, seed=3)
    rng = np.random.default_rng(0)
    for _ in range(4):
        pop.step(lambda gs: rng.random(len(gs)))
    return pop.genomes


@pytest.fixture(scope="module")
def genomes():
    return random_genomes(12)


def test_walk_preset_gives_seed_000s_eleven_inputs():
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"])
    assert len(layout.input_names) == 11  # 7 joint angles, 2 feet, 2 tilts
    assert layout.output_names == ("own_hip_roll", "own_hip_pitch", "own_knee", "waist_yaw")
    assert layout.n_bias == 2


def test_a_mirror_symmetric_state_reads_the_same_on_both_sides():
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"])
    joints = np.zeros((1, len(ROBOT.joints)))
    for side in ("right", "left"):
        joints[0, layout.leg_index[side]] = [0.1, -0.4, 0.7]  # the same anatomical pose
    feet = np.array([[-1.0, -1.0]])
    up = np.array([[-0.05, 0.0, 0.998]])  # leaning forward only (world up tilts back in the torso frame)
    right, left = network_inputs(layout, joints, feet, up)
    assert right == pytest.approx(left)
    # leaning toward the right reads as "toward me" on the right and "away" on the left
    right, left = network_inputs(layout, joints, feet, np.array([[0.0, 0.1, 0.995]]))
    assert right[-1] == pytest.approx(0.1) and left[-1] == pytest.approx(-0.1)
    # own foot first
    right, left = network_inputs(layout, joints, np.array([[1.0, -1.0]]), up)
    assert (right[-4], right[-3]) == (-1.0, 1.0) and (left[-4], left[-3]) == (1.0, -1.0)
    assert bias_values(1).tolist() == [[1.0, 1.0], [1.0, -1.0]]


def test_the_heading_reads_as_a_turn_toward_each_networks_own_side():
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"], TaskConfig(heading_input=True).inputs)
    joints, feet, up = np.zeros((1, len(ROBOT.joints))), np.array([[-1.0, -1.0]]), np.array([[0.0, 0.0, 1.0]])
    turned_left = heading_input(3.0 + 0.5, 3.0)  # yaw counter-clockwise from above: a turn to the left
    assert turned_left == pytest.approx(-0.5 / np.pi)
    right, left = network_inputs(layout, joints, feet, up, heading=np.atleast_1d(turned_left))
    column = layout.input_names.index("heading")
    assert right[column] == pytest.approx(-0.5 / np.pi) and left[column] == pytest.approx(0.5 / np.pi)
    assert heading_input(-3.0, 3.0) == pytest.approx(-(2 * np.pi - 6.0) / np.pi)  # wrapped: a small turn left
    assert abs(heading_input(np.pi, 0.0)) == pytest.approx(1.0)  # facing back
    assert heading_input(-0.2, 0.0, 45.0) == pytest.approx(0.2 / np.radians(45.0))  # a smaller scale ...
    assert heading_input(-1.0, 0.0, 45.0) == 1.0 and heading_input(2.0, 0.0, 45.0) == -1.0  # ... saturates
    with pytest.raises(ValueError, match="give the heading"):
        network_inputs(layout, joints, feet, up)


def test_waist_gets_the_mean_of_both_networks():
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"])
    outputs = np.array([[0.1, 0.2, 0.3, 0.8], [0.4, 0.5, 0.6, 0.2]])
    joints = joint_outputs(layout, outputs, len(ROBOT.joints))[0]
    names = list(ROBOT.joint_names)
    assert joints[names.index("waist_yaw")] == pytest.approx(0.5)
    assert joints[names.index("right_knee")] == 0.3 and joints[names.index("left_knee")] == 0.6
    assert np.isnan(joints[names.index("left_ankle_pitch")])  # not driven


def _same(a, b):
    for field in dataclasses.fields(a):
        x, y = getattr(a, field.name), getattr(b, field.name)
        if isinstance(x, dict):  # the fitness terms
            assert x.keys() == y.keys() and all(np.array_equal(x[k], y[k]) for k in x), field.name
        else:
            assert np.array_equal(x, y), field.name


def test_results_are_bit_identical_for_any_thread_count(genomes):
    one = LocomotionEvaluator(ROBOT, TASK, len(genomes), threads=1).evaluate(genomes, 1.0, harness=1.0)
    two = LocomotionEvaluator(ROBOT, TASK, len(genomes), threads=2).evaluate(genomes, 1.0, harness=1.0)
    _same(one, two)


def test_batched_evaluation_equals_evaluating_each_genome_alone(genomes):
    evaluator = LocomotionEvaluator(ROBOT, TASK, len(genomes), threads=2)
    together = evaluator.evaluate(genomes, 1.0)
    alone = LocomotionEvaluator(ROBOT, TASK, 1, threads=1)
    for i in range(0, len(genomes), 3):
        single = alone.evaluate([genomes[i]], 1.0)
        assert single.fitness[0] == together.fitness[i]
        assert single.distance_m[0] == together.distance_m[i]
        assert single.upright_s[0] == together.upright_s[i]


def test_a_network_without_connections_stands_still_and_stops_for_stagnation():
    layout = neat_layout(symmetric_layout(ROBOT, ROBOT.control_sets["walk"]))
    still = Genome(0, layout)  # every output sigmoid(0) = 0.5: the middle of each range
    task = TaskConfig(episode_s=6.0, stagnation_s=2.0)
    result = LocomotionEvaluator(ROBOT, task, 1, threads=1).evaluate([still], 1.0)
    assert not result.fell[0]
    assert 1.9 < result.upright_s[0] < 3.0  # ended by stagnation, not by the clock
    expected = task.distance_coeff * max(result.distance_m[0] / ROBOT.leg_length, task.epsilon) \
        + task.time_coeff * result.upright_s[0]
    assert result.fitness[0] == pytest.approx(expected)


def test_falls_end_the_trial_and_the_harness_holds_the_robot_up():
    # 48 controllers: over 12 the mean time upright with and without the harness was within a
    # few percent (random controllers also fall forward, which the harness does not stop)
    genomes = random_genomes(48)
    task = TaskConfig(episode_s=3.0)
    evaluator = LocomotionEvaluator(ROBOT, task, len(genomes), threads=2)
    free = evaluator.evaluate(genomes, 1.0)
    held = evaluator.evaluate(genomes, 1.0, harness=1.0)
    assert free.fell.sum() > len(genomes) // 2  # random controllers fall...
    assert held.upright_s.mean() > free.upright_s.mean()  # ...and the harness keeps them up longer
    assert np.all(free.upright_s[free.fell] < task.episode_s)


def test_a_clock_period_outside_the_formats_bounds_is_refused_in_the_config():
    from sim2real.errors import ConfigError

    assert TaskConfig.from_mapping({"phase_period_s": 0.6}).phase_period_s == 0.6
    with pytest.raises(ConfigError, match=r"task.phase_period_s: must be 0 \(no clock\) or within \[0.05, 10\] s"):
        TaskConfig.from_mapping({"phase_period_s": 0.01}, "walk.yaml")


def test_an_episode_upright_to_its_end_counts_as_upright_for_the_whole_episode():
    """Episodes are whole ticks (10 s at 34 ms is 9.996 s): "walked" is judged against that,
    or no episode could ever walk (validation once counted 0 walks for this reason)."""
    layout = neat_layout(symmetric_layout(ROBOT, ROBOT.control_sets["walk"]))
    task = TaskConfig(episode_s=1.0, stagnation_s=1e9)
    evaluator = LocomotionEvaluator(ROBOT, task, 1, threads=1)
    assert evaluator.episode_s < task.episode_s
    result = evaluator.evaluate([Genome(0, layout)], 1.0)
    assert result.upright_s[0] == pytest.approx(evaluator.episode_s) and not result.fell[0]
    assert result.walked(leg_length_m=-1.0, episode_s=evaluator.episode_s)[0]  # any distance counts here
    assert not result.walked(leg_length_m=-1.0, episode_s=task.episode_s)[0]
