"""The IMU's delay (reality key ``imu_delay_ms``): evolution's boards and the simulated bus
report the up vector, heading and gyro that old, between their samples."""

import numpy as np
import pytest

from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.task import TaskConfig
from sim2real.controller.channels import turn_rad
from sim2real.robot import load_robot
from sim2real.simulation.reality.file import load_reality
from sim2real.simulation.model.robot_model import imu_between
from sim2real.simulation.simbus import physics
from tests.test_gyro import _gyro_controller

ROBOT = load_robot()
TASK = TaskConfig(gyro_input=True, heading_input=True, episode_s=1.0)


def test_imu_between_interpolates_the_yaw_the_short_way_round():
    newer = np.array([0, 0, 1, 0, 0, 1.0, np.pi - 0.1])
    older = np.array([0, 0, 1, 0, 0, 3.0, -np.pi + 0.1])
    half = imu_between(newer, older, 0.5)
    assert half[5] == pytest.approx(2.0)
    assert abs(turn_rad(half[6], np.pi)) == pytest.approx(0.0, abs=1e-12)  # through pi, not through 0
    assert np.array_equal(imu_between(newer, older, 0.0), newer)


def test_the_evaluators_boards_report_the_imu_a_tick_and_a_half_late():
    genome, _ = _gyro_controller(TASK)
    evaluator = LocomotionEvaluator(ROBOT, TASK, 1, threads=1)
    late = load_reality({"imu_delay_ms": 1.5 * evaluator.tick_s * 1e3})
    evaluator = LocomotionEvaluator(ROBOT, TASK, 1, threads=1, reality=late)
    p = evaluator.sample(np.array([[3, 0]]))
    assert p.imu_delay_s[0] == pytest.approx(1.5 * evaluator.tick_s)
    goal = np.zeros((1, len(evaluator.driven)))
    truth, reported = [None], [None]  # by tick; tick 0's is read inside evaluate

    def record(ev, alive):  # after tick t's step: the readings of tick t + 1, as the evaluator will take them
        truth.append(ev.parts.imu(ev.sensordata[0]))
        if len(truth) < ev.n_ticks:
            reported.append(ev.readings(alive, len(truth) - 1, p, goal, np.zeros(1)))

    evaluator.evaluate([genome], 1.0, harness=1.0, perturbation=p, on_tick=record)
    assert np.ptp(np.array(truth[1:])[:, 3:6], axis=0).max() > 0.05  # the torso moved: a delay can show
    for t in range(3, len(reported)):
        expected = imu_between(truth[t - 1], truth[t - 2], 0.5)
        assert reported[t].up[0] == pytest.approx(expected[:3], abs=1e-12), t
        assert reported[t].gyro[0] == pytest.approx(expected[3:6], abs=1e-12), t
        assert turn_rad(reported[t].heading[0], expected[6]) == pytest.approx(0.0, abs=1e-12), t


def test_no_delay_reports_what_the_model_reads_now():
    genome, _ = _gyro_controller(TASK)
    evaluator = LocomotionEvaluator(ROBOT, TASK, 1, threads=1, reality=load_reality({"imu_delay_ms": 0.0}))
    p = evaluator.sample(np.array([[3, 0]]))
    reading = evaluator.readings(np.array([0]), 0, p, np.zeros((1, len(evaluator.driven))), np.zeros(1))
    assert np.array_equal(reading.gyro[0], evaluator.parts.gyro(evaluator.sensordata[0]))


@pytest.mark.parametrize("delay_ms", [10.0, 11.0])  # whole physics steps of 2 ms, and between two
def test_the_simulated_bus_serves_the_imu_as_it_was_its_delay_ago(delay_ms):
    now = [0.0]
    sim = physics.PhysicsChain(ROBOT, clock=lambda: now[0], reality=load_reality({"imu_delay_ms": delay_ms}))
    sim.data.qvel[3:6] = [1.0, -0.5, 2.0]  # the robot set spinning and tipping
    physics.mujoco.mj_forward(sim.model, sim.data)
    step = sim.model.opt.timestep
    history = []
    for k in range(1, 21):
        now[0] = k * step
        sim.advance()
        history.append(sim.parts.imu(sim.data.sensordata).copy())
    served = sim._imu()
    lag = delay_ms / 1e3 / step  # [physics steps]
    whole = int(np.floor(lag + 1e-9))
    expected = imu_between(history[-1 - whole], history[-2 - whole], lag - whole)
    assert served == pytest.approx(expected, abs=1e-12)
    assert np.abs(served[3:6] - history[-1][3:6]).max() > 1e-3  # and not what it reads now
