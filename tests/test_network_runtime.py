"""The deploy-side network runtime gives the evolution's numbers for the same inputs, bit for bit."""

import numpy as np
import pytest

from evolve.locomotion.evaluator import neat_layout
from evolve.locomotion.export import controller_from_genome
from evolve.locomotion.task import TaskConfig
from evolve.neat import NeatConfig, Population, PopulationNetwork
from sim2real.controller.activation import ControllerNetworks
from sim2real.controller.file import Controller
from sim2real.controller.symmetry import bias_values, symmetric_layout
from sim2real.robot import load_robot


def _grown_controller(seed=4, modules=("main",), efference=False, heading=False):
    robot = load_robot()
    task = TaskConfig(efference_copy=efference, heading_input=heading)
    layout = symmetric_layout(robot, robot.control_sets["walk"], task.inputs)
    config = NeatConfig(population_size=20, target_species=3, add_node_prob=0.4, add_link_prob=0.6,
                        sigmoid_steepness=2.5)
    pop = Population(config, neat_layout(layout), seed=seed, modules=modules)
    rng = np.random.default_rng(seed)
    for _ in range(12):
        pop.step(lambda gs: rng.random(len(gs)))
    genome = max(pop.genomes, key=lambda g: len(g.conns))
    return genome, controller_from_genome(genome, robot, layout, task, 2.5, {"seed": seed})


def test_runtime_equals_evolution_activation_over_1000_ticks():
    genome, controller = _grown_controller()
    assert len(genome.hidden) >= 3
    evolution = PopulationNetwork([genome, genome], 2.5, bias_values=bias_values(1))
    runtime = ControllerNetworks(controller)
    rng = np.random.default_rng(0)
    for _ in range(1000):
        x = rng.uniform(-1, 1, (2, runtime.n_inputs))
        assert np.array_equal(runtime.activate(x), evolution.activate(x))  # one activation, the same sums


def test_switching_a_module_off_by_name():
    genome, controller = _grown_controller(modules=("pose", "walk"))
    data = controller.to_dict()
    data["modules"] = [{"name": "pose", "enabled": True}, {"name": "walk", "enabled": True}]
    for conn in data["connections"][::2]:
        conn[3] = 1  # put half of the connections into the upper module
    controller = Controller.from_dict(data)
    full = ControllerNetworks(controller)
    lower = ControllerNetworks(controller, disabled_modules=["walk"])
    x = np.full((2, full.n_inputs), 0.3)
    assert not np.allclose(full.activate(x), lower.activate(x))
    with pytest.raises(ValueError, match="unknown module"):
        ControllerNetworks(controller, disabled_modules=["run"])


@pytest.mark.parametrize("efference, heading", [(False, False), (True, False), (False, True), (True, True)],
                         ids=["plain", "efference-copy", "heading", "both"])
def test_policy_fast_path_equals_the_evolution_wiring(efference, heading):
    from sim2real.controller.mapping import (
        normalized_angle,
        output_to_angle,
        rate_limit,
    )
    from sim2real.controller.policy import Policy
    from sim2real.controller.symmetry import heading_input, joint_outputs, network_inputs

    genome, controller = _grown_controller(seed=6, efference=efference, heading=heading)
    robot = load_robot()
    policy = Policy(controller, robot)
    assert policy.layout.efference == efference and policy.layout.heading == heading
    reference = ControllerNetworks(controller)
    rng = np.random.default_rng(2)
    goal = ref_goal = policy.reset()
    start = None
    for _ in range(200):
        angles = rng.uniform(policy.low, policy.high)
        feet = rng.random(2) < 0.5
        up = rng.normal(size=3)
        up /= np.linalg.norm(up)
        sent = normalized_angle(goal, policy.low, policy.high)[None] if efference else None
        yaw = rng.uniform(-4.0, 4.0)  # [rad] a board's heading, the first one the start
        start = yaw if start is None else start
        goal = policy.step(angles, feet, up, goal, heading=yaw if heading else None)
        x = network_inputs(policy.layout, normalized_angle(angles, policy.low, policy.high)[None],
                           np.where(feet, -1.0, 1.0)[None], up[None], goals=sent,
                           heading=np.atleast_1d(heading_input(yaw, start)) if heading else None)
        out = joint_outputs(policy.layout, reference.activate(x), len(policy.low))[0]
        d = policy.driven
        ref_goal = ref_goal.copy()
        ref_goal[d] = rate_limit(output_to_angle(out[d], policy.low[d], policy.high[d]), ref_goal[d], policy.max_step[d])
        assert np.array_equal(goal, ref_goal)


def _clock_only_controller(period_s=0.6, weight=4.0):
    """A network whose only link runs from the clock's sine to the own hip pitch."""
    from evolve.neat import Genome
    from evolve.neat.genome import ConnectionGene

    robot = load_robot()
    task = TaskConfig(phase_period_s=period_s, episode_s=1.0)
    layout = symmetric_layout(robot, robot.control_sets["walk"], task.inputs)
    genome = Genome(0, neat_layout(layout))
    src = layout.input_names.index("phase_sin")
    dst = layout.n_inputs + layout.n_bias + layout.output_names.index("own_hip_pitch")
    genome.add_connection(ConnectionGene(0, src, dst, weight, True, genome.active_module))
    return robot, task, layout, genome, controller_from_genome(genome, robot, layout, task, 1.0, {})


def test_the_clock_drives_evolution_and_the_runtime_alike_and_the_legs_in_antiphase():
    from evolve.locomotion.evaluator import LocomotionEvaluator
    from sim2real.controller.policy import Policy

    robot, task, layout, genome, controller = _clock_only_controller()
    assert controller.inputs[-2:] == ("phase_sin", "phase_cos") and controller.phase_period_s == 0.6
    evaluator = LocomotionEvaluator(robot, task, 1, threads=1)
    goals = []
    evaluator.evaluate([genome], 1.0, harness=1.0, on_tick=lambda ev, alive: goals.append(ev.ctrl[0].copy()))
    policy = Policy(Controller.from_dict(controller.to_dict()), robot)
    goal = policy.reset()
    names = list(robot.joint_names)
    right, left = names.index("right_hip_pitch"), names.index("left_hip_pitch")
    for k, simulated in enumerate(goals):  # the clock alone moves the hips: the same goals, tick for tick
        goal = policy.step(np.zeros(len(names)), np.array([True, True]), np.array([0.0, 0.0, 1.0]), goal)
        assert goal[right] == simulated[right] and goal[left] == simulated[left], k
    swing = np.array(goals)[:, [right, left]] - policy.hold[[right, left]]
    assert np.corrcoef(swing[5:, 0], swing[5:, 1])[0, 1] < -0.9  # antiphase, one genome


def test_a_real_time_loop_that_skips_ticks_keeps_the_clock_on_the_wall():
    from sim2real.controller.policy import Policy
    from sim2real.controller.symmetry import phase_inputs

    robot, _, _, _, controller = _clock_only_controller()
    policy = Policy(controller, robot)
    seen = []
    activate = policy.networks.activate
    policy.networks.activate = lambda x: (seen.append(x.reshape(2, -1)[:, -2:].copy()), activate(x))[1]
    args = (np.zeros(len(robot.joints)), np.array([True, True]), np.array([0.0, 0.0, 1.0]))
    goal = policy.reset()
    goal = policy.step(*args, goal)  # tick 0
    goal = policy.step(*args, goal, tick=5)  # ticks 1-4 were missed by the loop
    goal = policy.step(*args, goal)  # then tick 6
    for clock, tick in zip(seen, (0, 5, 6)):
        right = phase_inputs(tick * controller.tick_s, controller.phase_period_s)
        assert np.array_equal(clock, [right, -right]), tick


def test_an_efference_copy_feeds_back_the_last_goals_in_evolution_and_the_runtime_alike():
    """Clock -> own knee, own knee's last goal -> own hip pitch: the hips follow the knees'
    goals one tick late, tick for tick the same in the evaluator and the policy."""
    from evolve.locomotion.evaluator import LocomotionEvaluator
    from evolve.neat import Genome
    from evolve.neat.genome import ConnectionGene
    from sim2real.controller.policy import Policy

    robot = load_robot()
    task = TaskConfig(phase_period_s=0.6, efference_copy=True, episode_s=1.0)
    layout = symmetric_layout(robot, robot.control_sets["walk"], task.inputs)
    assert layout.input_names[-len(layout.driven):][:2] == ("own_hip_roll_goal", "own_hip_pitch_goal")
    genome = Genome(0, neat_layout(layout))
    out = layout.n_inputs + layout.n_bias
    links = [("phase_sin", "own_knee", 4.0), ("own_knee_goal", "own_hip_pitch", 3.0)]
    for k, (src, dst, weight) in enumerate(links):
        genome.add_connection(ConnectionGene(k, layout.input_names.index(src), out + layout.output_names.index(dst),
                                             weight, True, genome.active_module))
    controller = Controller.from_dict(controller_from_genome(genome, robot, layout, task, 1.0, {}).to_dict())
    assert controller.efference_copy and controller.inputs == layout.input_names
    goals = []
    LocomotionEvaluator(robot, task, 1, threads=1).evaluate(
        [genome], 1.0, harness=1.0, on_tick=lambda ev, alive: goals.append(ev.ctrl[0].copy()))
    policy = Policy(controller, robot)
    goal = policy.reset()
    hip = robot.joint_names.index("right_hip_pitch")
    for k, simulated in enumerate(goals):
        goal = policy.step(np.zeros(len(goal)), np.array([True, True]), np.array([0.0, 0.0, 1.0]), goal)
        assert np.array_equal(goal[policy.driven], simulated[policy.driven]), k
    assert np.ptp(np.array(goals)[:, hip]) > 0.1  # the feedback moved the hip


def test_the_heading_drives_evolution_and_the_runtime_alike_drift_included():
    """Heading -> own hip roll only: the hips follow the board's heading (here mostly a
    gyro's drift), tick for tick the same in the evaluator and the policy; the start's
    heading reads zero, and the two networks see the turn mirrored."""
    from evolve.locomotion.evaluator import LocomotionEvaluator
    from evolve.neat import Genome
    from evolve.neat.genome import ConnectionGene
    from sim2real.controller.policy import Policy
    from sim2real.simulation.reality.file import load_reality

    robot = load_robot()
    task = TaskConfig(heading_input=True, heading_scale_deg=30.0, episode_s=1.0)  # saturates after 1/3 s
    layout = symmetric_layout(robot, robot.control_sets["walk"], task.inputs)
    assert layout.input_names[layout.input_names.index("up_sideways") + 1] == "heading"
    genome = Genome(0, neat_layout(layout))
    out = layout.n_inputs + layout.n_bias
    genome.add_connection(ConnectionGene(0, layout.input_names.index("heading"),
                                         out + layout.output_names.index("own_hip_roll"), 6.0, True,
                                         genome.active_module))
    controller = Controller.from_dict(controller_from_genome(genome, robot, layout, task, 1.0, {}).to_dict())
    assert controller.heading_input and controller.to_dict()["heading_input"] is True
    assert controller.input_channels["heading"]["heading_scale_deg"] == 30.0
    spinning = load_reality({"heading_drift_deg_s": 90.0})  # a gyro gone bad: a quarter turn a second
    evaluator = LocomotionEvaluator(robot, task, 1, threads=1, reality=spinning)
    p = evaluator.sample(np.array([[1, 0]]))
    goals, headings = [], [float(evaluator.heading(np.array([0]), 0, p)[0])]
    evaluator.evaluate([genome], 1.0, harness=1.0, perturbation=p, on_tick=lambda ev, alive: (
        goals.append(ev.ctrl[0].copy()), headings.append(float(ev.heading(alive, len(goals), p)[0]))))
    policy = Policy(controller, robot)
    goal = policy.reset()
    right, left = robot.joint_names.index("right_hip_roll"), robot.joint_names.index("left_hip_roll")
    for k, simulated in enumerate(goals):
        goal = policy.step(np.zeros(len(goal)), np.array([True, True]), np.array([0.0, 0.0, 1.0]), goal,
                           heading=headings[k])
        assert np.array_equal(goal[policy.driven], simulated[policy.driven]), k
    swing = np.array(goals)[:, [right, left]] - policy.hold[[right, left]]
    assert np.ptp(swing[:, 0]) > 0.05 and np.allclose(swing[:, 0], -swing[:, 1])  # mirrored: roll is anatomical
    with pytest.raises(ValueError, match="heading"):
        Policy(controller, robot).step(np.zeros(len(goal)), np.array([True, True]), np.array([0.0, 0.0, 1.0]),
                                       goal)
