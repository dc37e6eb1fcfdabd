"""Pushes in training: their schedule, what they do to a robot, where they apply and where not."""

import numpy as np
import pytest
import yaml

from evolve.config import load_evolve_config
from evolve.evaluation import LocalBackend, EvaluatorSpec, score_population
from evolve.locomotion.evaluator import LocomotionEvaluator, neat_layout
from evolve.locomotion.pushes import FIRST_PUSH_S, Pushes, push_schedule
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome
from sim2real.controller.symmetry import symmetric_layout
from sim2real.errors import ConfigError
from sim2real.robot import load_robot

ROBOT = load_robot()
TICK = 0.034


def test_pushes_come_every_interval_after_the_start_within_the_speed():
    pushes = Pushes(speed_m_s=0.2, every_s=2.0)
    keys = np.array([[1, 0, 7, i, e] for i in range(20) for e in range(3)])
    schedule = push_schedule(pushes, keys, 294, TICK, intensity=0.5)
    assert schedule.shape == (60, 294, 2)
    speed = np.linalg.norm(schedule, axis=2)
    for row in speed:
        ticks = np.flatnonzero(row)
        assert ticks[0] * TICK >= FIRST_PUSH_S - TICK and ticks[0] * TICK < FIRST_PUSH_S + 2.0
        assert np.allclose(np.diff(ticks) * TICK, 2.0, atol=TICK)
    assert speed.max() <= 0.1 + 1e-12  # half strength: half the speed
    angles = np.arctan2(schedule[..., 1], schedule[..., 0])[speed > 0]
    assert (angles > np.pi / 2).any() and (angles < -np.pi / 2).any()  # every direction, backward too


def test_a_key_fixes_its_pushes():
    pushes = Pushes(0.15)
    a = push_schedule(pushes, np.array([[1, 0, 7, 3, 0], [1, 0, 7, 3, 1]]), 100, TICK)
    b = push_schedule(pushes, np.array([[1, 0, 7, 3, 0]]), 100, TICK)
    assert np.array_equal(a[:1], b) and not np.array_equal(a[0], a[1])


def test_a_push_is_the_impulse_of_its_speed_change_and_moves_the_robot():
    still = Genome(0, neat_layout(symmetric_layout(ROBOT, ROBOT.control_sets["walk"])))  # stands at mid-range
    evaluator = LocomotionEvaluator(ROBOT, TaskConfig(episode_s=1.0, stagnation_s=5.0), 2, threads=1)
    pushes = np.zeros((2, evaluator.n_ticks, 2))
    pushes[1, 10] = (0.1, 0.0)  # forward, at 0.34 s
    force, com = [], []

    def record(ev, alive):
        force.append(ev.xfrc[:2, ev.root, :3].copy())
        com.append(ev.subtree_com[:2, 0].copy())  # the whole robot's centre of mass

    evaluator.evaluate([still, still], 1.0, pushes=pushes, on_tick=record)
    force, com = np.array(force), np.array(com)  # (ticks, 2 simulations, 3)
    assert force[10, 1] * TICK == pytest.approx([evaluator.mass * 0.1, 0.0, 0.0])  # m dv over one tick
    assert not force[10, 0].any() and not force[9].any() and not force[11].any()
    assert np.array_equal(com[:10, 0], com[:10, 1])  # nothing before it
    # the feet's friction takes part of the impulse, but the robot moves forward of the unpushed one
    assert com[14, 1, 0] - com[14, 0, 0] > 1e-3


def test_no_pushes_and_zero_pushes_are_the_same_episode():
    genome = Genome(0, neat_layout(symmetric_layout(ROBOT, ROBOT.control_sets["walk"])))
    evaluator = LocomotionEvaluator(ROBOT, TaskConfig(episode_s=0.5), 1, threads=1)
    plain = evaluator.evaluate([genome], 1.0, harness=1.0)
    zero = evaluator.evaluate([genome], 1.0, harness=1.0, pushes=np.zeros((1, evaluator.n_ticks, 2)))
    assert plain.fitness[0] == zero.fitness[0] and plain.distance_m[0] == zero.distance_m[0]


def test_pushes_wait_for_the_randomization_and_reach_selection_only():
    genome = Genome(0, neat_layout(symmetric_layout(ROBOT, ROBOT.control_sets["walk"])))
    backend = LocalBackend(EvaluatorSpec(ROBOT.name, TaskConfig(episode_s=3.0, stagnation_s=5.0).to_dict(),
                                         "default", 2, 1))
    kwargs = dict(steepness=1.0, harness=0.0, stage=None, episodes=2, score="mean", key=(1, 0, 0))
    hard = Pushes(0.5, every_s=1.0)
    nominal = score_population(backend, [genome], intensity=0.0, **kwargs)
    assert score_population(backend, [genome], intensity=0.0, pushes=hard, **kwargs).distance_m == \
        nominal.distance_m  # the nominal phase: no pushes
    calm = score_population(backend, [genome], intensity=1.0, **kwargs)
    pushed = score_population(backend, [genome], intensity=1.0, pushes=hard, **kwargs)
    assert pushed.distance_m != calm.distance_m


def _config_with(tmp_path, randomize):
    doc = yaml.safe_load(open("benchmarks/records/configs/walk_robust.yaml"))
    doc["randomize"] = randomize
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_push_settings_round_trip_and_bad_ones_are_named(tmp_path):
    config = load_evolve_config(_config_with(tmp_path, {"reality": "randomize", "push": {"speed_m_s": 0.15}}))
    assert config.randomize.push == Pushes(0.15, 2.0)
    assert config.to_dict()["randomize"]["push"] == {"speed_m_s": 0.15, "every_s": 2.0}
    for push, where in (({"speed_m_s": 0}, "randomize.push.speed_m_s"), ({"speed_m_s": 3.0}, "randomize.push.speed_m_s"),
                        ({"every_s": 1.0}, "randomize.push"), ({"speed_m_s": 0.1, "every_s": -1}, "randomize.push.every_s"),
                        ({"speed_m_s": 0.1, "often": 2}, "randomize.push")):
        with pytest.raises(ConfigError, match=where.replace(".", r"\.")):
            load_evolve_config(_config_with(tmp_path, {"reality": "randomize", "push": push}))
    with pytest.raises(ConfigError, match="randomize.reality"):
        load_evolve_config(_config_with(tmp_path, {"push": {"speed_m_s": 0.1}}))
