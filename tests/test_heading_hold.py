"""Heading hold: training's heading commands, the heading input against the heading to hold,
evolution and the runtime alike under a command, a user steering `biped run`, and selection's
terms for a steady, straight walk."""

import dataclasses
import json
import math

import numpy as np
import pytest

from evolve.cli import main
from evolve.locomotion.evaluator import LocomotionEvaluator, neat_layout
from evolve.locomotion.export import controller_from_genome
from evolve.locomotion.heading_commands import FIRST_TURN_S, LAST_TURN_S, turn_schedule
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome
from evolve.neat.genome import ConnectionGene
from sim2real.controller.file import Controller
from sim2real.controller.policy import Policy
from sim2real.controller.steering import parse_schedule, schedule_command
from sim2real.controller.symmetry import symmetric_layout
from sim2real.errors import ConfigError
from sim2real.robot import load_robot

ROBOT = load_robot()


def test_a_share_of_episodes_is_commanded_one_turn_within_bounds_from_its_key():
    keys = np.array([[1, 0, g, i, 0] for g in range(4) for i in range(100)])
    tick = 0.034
    turns = turn_schedule(keys, 300, tick, share=0.5, max_deg=30.0)
    commanded = np.abs(turns).max(axis=1) > 0
    assert 0.35 < commanded.mean() < 0.65
    assert np.abs(turns).max() <= np.radians(30.0) + 1e-12
    for row in turns[commanded]:
        start = int(np.flatnonzero(row)[0])
        assert FIRST_TURN_S <= start * tick + tick and start * tick < 300 * tick - LAST_TURN_S
        assert np.all(row[start:] == row[start]) and not row[:start].any()  # one turn, then held
    again = turn_schedule(keys[::-1], 300, tick, share=0.5, max_deg=30.0)[::-1]
    assert np.array_equal(turns, again)  # each row from its key alone
    assert not turn_schedule(keys, 300, tick, share=0.0, max_deg=30.0).any()


def _heading_genome(task: TaskConfig):
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"], task.inputs)
    genome = Genome(0, neat_layout(layout))
    genome.add_connection(ConnectionGene(0, layout.input_names.index("heading"),
                                         layout.n_inputs + layout.n_bias + layout.output_names.index("own_hip_roll"),
                                         6.0, True, genome.active_module))
    return genome, Controller.from_dict(controller_from_genome(genome, ROBOT, layout, task, 1.0, {}).to_dict())


def test_a_commanded_turn_drives_evolution_and_the_runtime_alike():
    """Told at a tick to hold a heading 20 deg to the left, both networks read the turn still
    to go - the same numbers in the evaluator and in the policy that a user steers."""
    task = TaskConfig(heading_input=True, heading_scale_deg=30.0, episode_s=1.0)
    genome, controller = _heading_genome(task)
    evaluator = LocomotionEvaluator(ROBOT, task, 1, threads=1)
    turns = np.zeros((1, evaluator.n_ticks))
    turns[0, 10:] = np.radians(20.0)
    goals, headings = [], [float(evaluator.heading(np.array([0]), 0, None)[0])]
    evaluator.evaluate([genome], 1.0, harness=1.0, turns=turns, on_tick=lambda ev, alive: (
        goals.append(ev.ctrl[0].copy()), headings.append(float(ev.heading(alive, len(goals), None)[0]))))
    policy = Policy(controller, ROBOT)
    policy.heading_command = schedule_command([(0.0, 0.0), (10 * controller.tick_s - 1e-9, 20.0)], math.inf)
    goal = policy.reset()
    for k, simulated in enumerate(goals):
        goal = policy.step(np.zeros(len(goal)), np.array([True, True]), np.array([0.0, 0.0, 1.0]), goal,
                           heading=headings[k])
        assert np.array_equal(goal[policy.driven], simulated[policy.driven]), k
    hip = ROBOT.joint_names.index("right_hip_roll")
    assert abs(goals[12][hip] - goals[8][hip]) > 0.01  # the command moved the hips


def test_steering_schedules_are_read_and_refused_clearly():
    steps = schedule_command(parse_schedule("0:0, 5:90, 12:-45"), math.inf)
    assert steps(4.9) == 0.0 and steps(5.0) == pytest.approx(np.pi / 2) and steps(30) == pytest.approx(-np.pi / 4)
    assert schedule_command(parse_schedule("30"), math.inf)(0.0) == pytest.approx(np.radians(30))
    # as a user steers: each step followed at TURN_RATE_DEG_S (10 deg/s), also when a new one cuts it short
    ramp = schedule_command(parse_schedule("0:0, 5:90, 12:-45"))
    degrees = [np.degrees(ramp(t)) for t in (4.9, 5.0, 6.0, 12.0, 14.0, 30.0)]
    assert degrees == pytest.approx([0.0, 0.0, 10.0, 70.0, 50.0, -45.0])
    assert np.degrees(schedule_command(parse_schedule("30"))(1.5)) == pytest.approx(15.0)
    # the shorter way round, as the heading input reads a turn: 350 deg is 10 deg right, 170 -> -170 is 20 deg left
    assert np.degrees(schedule_command(parse_schedule("350"))(5.0)) == pytest.approx(-10.0)
    across = schedule_command(parse_schedule("0:170, 20:-170"))
    assert np.degrees(across(21.0)) == pytest.approx(180.0) and np.degrees(across(30.0)) == pytest.approx(190.0)
    for rate in (0.0, -10.0, float("nan")):
        with pytest.raises(ValueError, match="turn_rate_deg_s"):
            schedule_command(parse_schedule("30"), rate)
    for text, problem in [("", "empty"), ("5:x", "SECONDS:DEGREES"), ("5:0,3:10", "increase"), ("0:720", "360")]:
        with pytest.raises(ValueError, match=problem):
            parse_schedule(text)


def test_biped_run_takes_a_heading_for_a_heading_controller_only(tmp_path, capsys):
    _, controller = _heading_genome(TaskConfig(heading_input=True))
    path = tmp_path / "heading.json"
    controller.save(path)
    assert main(["run", str(path), "--bus", "mock", "--duration", "0.3", "--heading", "0:0,0.1:45", "--json",
                 "--no-realtime"]) == 0
    assert not json.loads(capsys.readouterr().out.strip().splitlines()[-1])["torque_off"]["unconfirmed"]
    plain = tmp_path / "plain.json"
    Controller.load("configs/controllers/xl430_biped_no_gyro.json").save(plain)
    assert main(["run", str(plain), "--bus", "mock", "--duration", "0.3", "--heading", "30", "--no-realtime"]) == 2
    assert "no heading input" in capsys.readouterr().err


def test_selection_pays_a_steady_straight_walk_by_its_terms():
    task = TaskConfig(episode_s=1.0)
    ev = LocomotionEvaluator(ROBOT, task, 2, threads=1)
    still = ev.evaluate([Genome(0, ev.neat_layout), Genome(1, ev.neat_layout)], 1.0, harness=1.0)
    # standing still: no speed along the heading (the kernel's tail), no turning (its top)
    assert np.all(still.terms["velocity"] < 0.05) and np.all(still.terms["yaw_rate"] > 0.95)
    assert np.all(still.terms["straight"] <= still.terms["velocity"])  # facing the heading pays no standing
    weighted = LocomotionEvaluator(ROBOT, TaskConfig(episode_s=1.0, selection_velocity_coeff=2.0,
                                                     selection_yaw_coeff=3.0, selection_straight_coeff=4.0), 2, threads=1)
    paid = weighted.evaluate([Genome(0, ev.neat_layout), Genome(1, ev.neat_layout)], 1.0, harness=1.0)
    assert np.array_equal(paid.fitness, still.fitness)  # eq. 3 as reported is unchanged
    assert np.allclose(paid.selection, still.selection + 2.0 * still.terms["velocity"] + 3.0 * still.terms["yaw_rate"]
                       + 4.0 * still.terms["straight"])


def test_the_shipped_walker_is_paid_for_its_speed_and_less_for_its_turning():
    """The shipped walker (``configs/controllers/xl430_biped.json``, selected with the straight
    term, coefficient 8) walks its 10 s episode on the nominal robot near the target speed
    (velocity kernel 0.75) and turns at most 6.6 deg: the heading kernel (sigma 15 deg) takes
    a little of its pay, and the selection pays it what is left."""
    from evolve.locomotion.export import genome_from_controller
    from evolve.replay import controller_task

    controller = Controller.load("configs/controllers/xl430_biped.json")
    task = controller_task(controller, "xl430_biped.json")
    assert task.selection_straight_coeff > 0
    ev = LocomotionEvaluator(ROBOT, task, 1, threads=1)
    walk = ev.evaluate([genome_from_controller(controller)], controller.sigmoid_steepness)
    velocity, straight = walk.terms["velocity"][0], walk.terms["straight"][0]
    assert velocity > 0.5 and walk.terms["yaw_rate"][0] < 0.95
    assert 0 < walk.terms["turn"][0] < 10.0  # [deg] it holds its heading, not perfectly
    assert 0.9 * velocity < straight < velocity  # paid less for the little it turns
    unpaid = LocomotionEvaluator(ROBOT, dataclasses.replace(task, selection_straight_coeff=0.0), 1, threads=1).evaluate(
        [genome_from_controller(controller)], controller.sigmoid_steepness)
    assert walk.selection[0] - unpaid.selection[0] == pytest.approx(task.selection_straight_coeff * straight)


@pytest.mark.parametrize("values, problem", [
    ({"heading_turn_share": 0.5}, "heading_turn_share: commands a heading to hold: give heading_input: true"),
    ({"heading_input": True, "heading_turn_share": 1.5}, "heading_turn_share: is a share"),
    ({"heading_input": True, "heading_turn_max_deg": 0.0}, r"heading_turn_max_deg: must be within \(0, 180\]"),
    ({"selection_speed_leg_s": 0.0}, "selection_speed_leg_s: must be > 0"),
])
def test_heading_commands_and_selection_terms_are_checked(values, problem):
    with pytest.raises(ConfigError, match=problem):
        TaskConfig.from_mapping(values, "walk.yaml")


def test_biped_eval_steers_and_reports_how_far_from_the_heading_it_ends(tmp_path):
    from evolve.replay import evaluate_controller

    _, controller = _heading_genome(TaskConfig(heading_input=True))
    path = tmp_path / "heading.json"
    controller.save(path)
    told = schedule_command([(0.0, 0.0), (0.5, 40.0)], math.inf)
    walk = evaluate_controller(path, seconds=1.0, heading=told, stagnation_stop=False)
    episode = walk["per_episode"][0]
    # still standing where it started, it is 40 deg off the heading it was told to hold
    assert abs(abs(episode["heading_error_deg"]) - 40.0) < 5.0
    with pytest.raises(Exception, match="no heading input"):
        evaluate_controller("configs/controllers/xl430_biped_no_gyro.json", seconds=1.0, heading=told)


def test_the_shipped_walker_walks_straight_on_the_model_and_turns_when_told():
    """``configs/controllers/xl430_biped.json`` (issue 33's recipe, then a speed polish; its provenance has
    the measures): on the nominal robot 20 s straight ahead, and a 90 deg turn told at 2 s."""
    from evolve.replay import evaluate_controller
    from evolve.walk_measures import STEER_TOLERANCE_DEG, steering

    shipped = "configs/controllers/xl430_biped.json"
    assert {"heading", "gyro"} <= set(Controller.load(shipped).input_channels)
    straight = evaluate_controller(shipped, seconds=20.0)["per_episode"][0]
    assert not straight["fell"] and straight["distance_m"] > 3.0 and abs(straight["turn_deg"]) < 10.0
    # the steering goal, as biped train measures it: told at 2 s, there 12 s later
    turned = steering(shipped)
    assert turned["reached"] and not turned["fell"] and abs(turned["heading_error_deg"]) < STEER_TOLERANCE_DEG
