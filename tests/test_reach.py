"""Seed 002's reaching: the reach input, the state machine, the objective and its stages."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from evolve.config import load_evolve_config, parse_evolve_config
from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.objectives import PoseWeights
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome
from sim2real.controller.channels import InputWiring, Readings
from sim2real.controller.file import Controller
from sim2real.controller.reach import REACHING, RETURNING, ReachCycle
from sim2real.controller.symmetry import network_inputs, symmetric_layout
from sim2real.errors import ConfigError
from sim2real.simulation.model.physique import load_measured

OP3 = load_measured("op3")
CONFIG = load_evolve_config("configs/evolve/reach_op3.yaml")


def test_only_the_right_network_is_told_to_reach_and_where():
    layout = symmetric_layout(OP3, OP3.control_sets["reach"], CONFIG.task.inputs)
    assert layout.input_names[-4:] == ("reach_control", "target_forward", "target_left", "target_up")
    low = np.array([j.range_rad[0] for j in OP3.joints])
    high = np.array([j.range_rad[1] for j in OP3.joints])
    rng = np.random.default_rng(2)
    n = 3
    angles = rng.uniform(low, high, (n, len(low)))
    feet = rng.random((n, 2)) < 0.5
    up = np.array([[0.1, -0.2, 0.97]] * n)
    state = np.array([1.0, 0.0, 1.0])
    target = rng.uniform(-1, 1, (n, 3))
    fast = InputWiring(layout, low, high).inputs(Readings(angles=angles, feet=feet, up=up, reach_state=state,
                                                          reach_target=target))
    normalized = 2 * (angles - low) / (high - low) - 1
    plain = network_inputs(layout, normalized, np.where(feet, -1.0, 1.0), up,
                           reach=np.concatenate([state[:, None], target], axis=1))
    assert np.allclose(fast, plain, atol=1e-12)
    reach = fast[:, -4:]
    assert np.array_equal(reach[1::2], np.zeros((n, 4)))  # the left network: nothing
    assert np.allclose(reach[0::2], np.concatenate([state[:, None], state[:, None] * target], axis=1))
    with pytest.raises(ValueError, match="reach state"):
        InputWiring(layout, low, high).inputs(Readings(angles=angles, feet=feet, up=up))


def test_the_state_toggles_once_a_goal_is_reached_but_not_sooner_than_its_phase():
    cycle = ReachCycle(2, phase_s=1.0, tolerance=0.1)
    ids = np.arange(2)
    for _ in range(9):  # 0.9 s within tolerance: too soon
        assert not cycle.update(ids, np.array([0.05, 0.5]), 0.1).any()
    assert list(cycle.update(ids, np.array([0.05, 0.5]), 0.1)) == [True, False]  # 1.0 s: reached
    assert list(cycle.state) == [RETURNING, REACHING] and list(cycle.reached) == [1, 0]
    assert cycle.since[0] == 0.0
    with pytest.raises(ValueError, match="must be > 0"):
        ReachCycle(1, phase_s=0.0, tolerance=0.1)


def test_a_goal_touched_early_counts_when_its_phase_is_over():
    """Seed 002 toggles once the phase is over "on the condition that the character has
    actually reached its target by then": a hand that passed the goal and drifted off still
    toggles, one that never came near does not, and a touch counts for its own phase only."""
    cycle = ReachCycle(2, phase_s=1.0, tolerance=0.1)
    ids = np.arange(2)
    assert not cycle.update(ids, np.array([0.05, 0.5]), 0.5).any()  # at the goal at 0.5 s: too soon
    assert list(cycle.update(ids, np.array([0.3, 0.5]), 0.5)) == [True, False]  # off it at 1 s: reached
    assert list(cycle.state) == [RETURNING, REACHING] and not cycle.touched[0]
    for _ in range(3):  # the new goal never touched: no toggle however long
        assert not cycle.update(ids, np.array([0.3, 0.5]), 1.0).any()
    assert list(cycle.reached) == [1, 0]


def test_the_reach_objective_scores_table_41s_terms_and_the_bonus():
    reach = CONFIG.stages[-1]
    assert reach.weights == PoseWeights(1.0, 1.0, 1.0, 1.0, 2.0, 1.0)
    assert reach.max_fitness == pytest.approx(100 * 2 ** 5 * 3 + reach.bonus_max)
    ev = LocomotionEvaluator(OP3, dataclasses.replace(CONFIG.task, episode_s=2.0), 1, threads=1)
    genome = Genome(0, ev.neat_layout)
    e = ev.evaluate([genome], CONFIG.neat.sigmoid_steepness, objective=reach.make_objective)
    score = ev.objective
    assert set(e.terms) == {"survival", "rest_pose", "rest_pose_end", "com", "feet", "reaching", "torque", "reaches",
                            "other_arm"}
    assert score.thorax_rule[0]  # the elbow is outside the torso at home: the rule applies
    assert 0.1 < score.control.arm_length < 0.3  # OP3's shoulder to forearm [m]
    assert e.terms["reaches"][0] == 0 and e.terms["reaching"][0] > 0 and e.terms["torque"][0] > 0
    product = e.terms["survival"][0]
    for name, w in dataclasses.asdict(reach.weights).items():
        product *= 1 + w / (1 + e.terms[name][0])
    assert e.fitness[0] == pytest.approx(product)
    # the right arm is left out of the rest pose, reaching or returning: its place is eq. 4.6's
    arm = np.isin(np.array(ev.layout.driven), ev.arm.joints)
    assert arm.sum() == 3
    assert np.array_equal(score._counted(np.array([0])), np.where(arm, 0.0, 1.0))


def test_a_hand_at_its_target_earns_the_bonus():
    """Under the range rule a network without connections moves the arm to the middle of its
    ranges; a target there is reached after the first phase (and the rest, where the hand is
    not, is not)."""
    reach = CONFIG.stages[-1]
    task = dataclasses.replace(CONFIG.task, episode_s=3.0, output_centre="range")
    ev = LocomotionEvaluator(OP3, task, 1, threads=1)
    genome = Genome(0, ev.neat_layout)
    ev.evaluate([genome], CONFIG.neat.sigmoid_steepness, objective=reach.make_objective)
    control = ev.objective.control
    offset = (ev.objective.hand(np.array([0]))[0] - control.shoulder) / control.arm_length
    there = dataclasses.replace(task, reach_forward=offset[0], reach_left=offset[1], reach_up=offset[2])
    ev = LocomotionEvaluator(OP3, there, 1, threads=1)
    e = ev.evaluate([genome], CONFIG.neat.sigmoid_steepness, objective=reach.make_objective)
    assert e.terms["reaches"][0] == 1
    assert e.fitness[0] > ev.objective.bonus > 0


def test_a_reach_stage_needs_the_reach_input_and_a_right_hand():
    doc = {"robot": "op3", "task": {"control_set": "reach"},
           "stages": [{"name": "reach", "objective": "reach", "generations": 5}]}
    with pytest.raises(ConfigError, match=r"stages\[0\]\.objective: a reach stage needs task.reach_input"):
        parse_evolve_config(doc, "reach.yaml")
    doc = {"robot": "xl430_biped", "task": {"reach_input": True},
           "stages": [{"name": "reach", "objective": "reach", "generations": 5}]}
    with pytest.raises(ConfigError, match="robot xl430_biped has no right hand"):
        parse_evolve_config(doc, "reach.yaml")


@pytest.mark.parametrize("values, problem", [
    ({"reach_forward": 0.5}, "reach_forward: is the reach input's setting: give it only with reach_input: true"),
    ({"reach_input": True, "reach_tolerance": 0.0}, r"reach_tolerance: must be within \(0, 1\]"),
    ({"reach_input": True, "reach_left": -3.0}, r"reach_left: must be within \[-2, 2\]"),
])
def test_reach_settings_are_checked(values, problem):
    with pytest.raises(ConfigError, match=problem):
        TaskConfig.from_mapping(values, "reach.yaml")


def _reacher(task: TaskConfig) -> tuple[Genome, Controller]:
    """Reach control -> own shoulder pitch and elbow: the right arm swings up while reaching."""
    from evolve.locomotion.evaluator import neat_layout
    from evolve.locomotion.export import controller_from_genome
    from evolve.neat.genome import ConnectionGene
    layout = symmetric_layout(OP3, OP3.control_sets["reach"], task.inputs)
    genome = Genome(0, neat_layout(layout))
    out = layout.n_inputs + layout.n_bias
    for k, (src, dst, weight) in enumerate([("reach_control", "own_shoulder_pitch", 6.0),
                                            ("reach_control", "own_elbow_pitch", -4.0)]):
        genome.add_connection(ConnectionGene(k, layout.input_names.index(src), out + layout.output_names.index(dst),
                                             weight, True, genome.active_module))
    data = controller_from_genome(genome, OP3, layout, task, 1.0, {}).to_dict()
    return genome, Controller.from_dict(data)


@pytest.mark.parametrize("name", ["op3", "human_arms"])  # the human: three hinges in one body (shoulder, lumbar)
def test_the_arms_chain_finds_the_hand_where_the_simulation_has_it(name):
    import mujoco
    from sim2real.controller.kinematics import ArmChain
    from sim2real.simulation.model.builder import build_model
    from sim2real.simulation.model.robot_model import Arm, arm_chain

    robot = load_measured(name)
    model = build_model(robot)
    data = mujoco.MjData(model)
    arm = Arm.of(model, robot)
    chain = ArmChain.from_dict(arm_chain(model, robot, arm), robot.joint_names)
    rng = np.random.default_rng(5)
    root = model.body(robot.root_body).id
    for _ in range(5):
        q = np.array([rng.uniform(*j.range_rad) for j in robot.joints])
        for name, angle in zip(robot.joint_names, q):
            data.qpos[model.jnt_qposadr[model.joint(name).id]] = angle
        data.qpos[3:7] = rng.normal(size=4) / np.linalg.norm(rng.normal(size=4))
        data.qpos[3:7] /= np.linalg.norm(data.qpos[3:7])
        mujoco.mj_kinematics(model, data)
        rotation = data.xmat[root].reshape(3, 3)
        assert chain.hand(q)[0] == pytest.approx((data.xipos[arm.hand] - data.xpos[root]) @ rotation, abs=1e-12)
        assert chain.shoulder(q)[0] == pytest.approx((data.xpos[arm.shoulder] - data.xpos[root]) @ rotation,
                                                     abs=1e-12)

def _aimed(task: TaskConfig) -> tuple[Genome, TaskConfig]:
    """The hand-made reacher, and ``task`` with its target where that reacher's swing takes the
    hand (found by one evaluation)."""
    genome, _ = _reacher(task)
    probe = LocomotionEvaluator(OP3, task, 1, threads=1)
    probe.evaluate([genome], 1.0, objective=CONFIG.stages[-1].make_objective)
    control = probe.objective.control
    offset = (probe.objective.hand(np.array([0]))[0] - control.shoulder) / control.arm_length
    return genome, dataclasses.replace(task, reach_forward=offset[0], reach_left=offset[1], reach_up=offset[2])



def test_a_reaching_controller_runs_the_state_machine_in_the_runtime_as_in_evolution(tmp_path):
    from sim2real.controller.policy import Policy

    _, task = _aimed(dataclasses.replace(CONFIG.task, episode_s=4.0))
    genome, controller = _reacher(task)
    path = tmp_path / "reach.json"
    controller.save(path)
    assert Controller.load(path, OP3).reach_arm == controller.reach_arm  # the chain rides in the file
    ev = LocomotionEvaluator(OP3, task, 1, threads=1)
    seen, goals = [], []
    readings = ev.readings

    def recorded(*args, **kwargs):  # what the networks read, tick by tick
        r = readings(*args, **kwargs)
        seen.append(r)
        return r

    ev.readings = recorded
    ev.evaluate([genome], 1.0, objective=CONFIG.stages[-1].make_objective,
                on_tick=lambda ev, alive: goals.append(ev.ctrl[0].copy()))
    states = [float(r.reach_state[0]) for r in seen]
    assert states[0] == 1.0 and 0.0 in states  # it reached its goal and toggled
    policy = Policy(controller, OP3)
    goal = policy.reset()
    for k, r in enumerate(seen):
        goal = policy.step(r.angles[0], r.feet[0], r.up[0], goal)
        assert policy.reach.cycle.state[0] == r.reach_state[0], k
        assert np.array_equal(goal[policy.driven], goals[k][policy.driven]), k
    arm = [OP3.joint_names.index("r_sho_pitch")]
    assert np.ptp(np.array(goals)[:, arm]) > 0.3  # the arm swung


@pytest.fixture(scope="module")
def reacher_file(tmp_path_factory) -> Path:
    """A reaching controller whose target is where its arm swings (found by one evaluation)."""
    _, task = _aimed(dataclasses.replace(CONFIG.task, episode_s=4.0))
    path = tmp_path_factory.mktemp("reach") / "reacher.json"
    _reacher(task)[1].save(path)
    return path


def test_biped_run_reaches_where_it_is_told_and_traces_the_state(reacher_file, tmp_path, capsys):
    import json

    from evolve.cli import main
    from sim2real.hardware.trace import Trace

    trace = tmp_path / "reach.csv"
    assert main(["run", str(reacher_file), "--bus", "mock", "--duration", "0.5", "--reach-target", "0.05,-0.1,0.1",
                 "--trace", str(trace), "--json", "--no-realtime"]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["reach"]["target_m"] == [0.05, -0.1, 0.1] and not report["torque_off"]["unconfirmed"]
    rows = Trace.read(trace)
    assert "reach_state" in rows and "hand_error" in rows
    assert np.all(rows["reach_state"] == 1.0)  # the mock robot never moves: still reaching


def test_a_reach_target_out_of_reach_is_refused_before_anything_moves(reacher_file, capsys):
    from evolve.cli import main

    args = ["run", str(reacher_file), "--bus", "mock", "--duration", "0.2", "--no-realtime", "--reach-target"]
    assert main(args + ["2,0,0"]) == 2
    assert "arm lengths from the right shoulder" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:
        main(args + ["0,0"])
    assert exit_.value.code == 2 and "three numbers X,Y,Z in metres" in capsys.readouterr().err


def test_a_walker_takes_no_reach_target(capsys):
    from evolve.cli import main

    assert main(["run", "configs/controllers/xl430_biped_no_gyro.json", "--bus", "mock", "--duration", "0.2",
                 "--reach-target", "0.1,0,0", "--no-realtime"]) == 2
    assert "no reach input" in capsys.readouterr().err


@pytest.mark.parametrize("path, reaches", [("hand-made", 1), ("configs/controllers/op3_reach.json", 2)])
def test_a_dry_run_reaches_through_the_simulated_bus(path, reaches, reacher_file):
    from sim2real.simulation.transfer.dry_run import dry_run

    result = dry_run(reacher_file if path == "hand-made" else path, duration_s=4.0, log=lambda s: None, ramp_s=0.3,
                     lost_after_s=2.0)  # a loaded machine can hold the simulated bus up ~100 ms
    assert result["reach"]["reaches"] >= reaches and not result["fell"]
    assert not result["torque_off"]["unconfirmed"]


def test_biped_eval_reports_reaches_and_a_disabled_reach_module_gives_them_back(reacher_file, tmp_path):
    """The reacher's one module is its base here; a hierarchy's reach module switched off
    leaves the modules below it - which, in this hand-made one, is none: nothing reaches."""
    from evolve.replay import evaluate_controller

    reached = evaluate_controller(reacher_file, seconds=4.0)
    assert reached["reaches"] >= 1 and 0 < reached["hand_error"] < 2 and not reached["fell"]
    data = Controller.load(reacher_file).to_dict()
    data["modules"] = [{"name": "stand", "enabled": True}, {"name": "reach", "enabled": True}]
    data["connections"] = [[s, d, w, 1] for s, d, w, _ in data["connections"]]  # the reach genes in module 1
    staged = tmp_path / "staged.json"
    Controller.from_dict(data).save(staged)
    assert evaluate_controller(staged, seconds=4.0)["reaches"] == reached["reaches"]
    standing = evaluate_controller(staged, seconds=4.0, disabled_modules=("reach",))
    assert standing["reaches"] == 0


def test_biped_plot_reach_draws_a_replay_and_a_trace(reacher_file, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    from evolve.cli import main

    assert main(["plot", "reach", str(reacher_file), "--seconds", "3", "-o", str(tmp_path / "replay.png")]) == 0
    assert "2 goals reached" in capsys.readouterr().out  # there and back: the home rule rests the arm at home
    assert (tmp_path / "replay.png").stat().st_size > 10_000
    trace = tmp_path / "run.csv"
    assert main(["run", str(reacher_file), "--bus", "mock", "--duration", "0.3", "--trace", str(trace),
                 "--no-realtime"]) == 0
    assert main(["plot", "reach", "--trace", str(trace), "-o", str(tmp_path / "trace.png")]) == 0
    assert (tmp_path / "trace.png").exists()
    assert main(["plot", "reach", "configs/controllers/xl430_biped_no_gyro.json", "-o", str(tmp_path / "x.png")]) == 2
    assert "not a reaching controller" in capsys.readouterr().err


def test_the_strip_draws_the_target_and_the_hands_path(reacher_file):
    pytest.importorskip("imageio")
    from evolve.replay import strip

    rows, times, _ = strip([reacher_file], columns=3, seconds=2.0, width=200, height=240)
    red = [int(((f[..., 0] > 170) & (f[..., 1] < 90) & (f[..., 2] < 90)).sum()) for f in rows[0]]
    blue = [int(((f[..., 2] > 170) & (f[..., 0] < 110) & (f[..., 1] < 170)).sum()) for f in rows[0]]
    assert all(r > 5 for r in red), red  # the goal, every frame (the hand at it hides part of it)
    assert blue[0] < blue[-1] and blue[-1] > 20, blue  # the hand's path grows from nothing


@pytest.mark.parametrize("change, problem", [
    (lambda d: d.pop("reach_arm"), "reach_arm: missing: a reach_input controller carries its arm's chain"),
    (lambda d: d["reach_arm"]["links"][0].update(quat=[1.0, 0.5, 0.0, 0.0]), r"links\[0\]\.quat: must have length 1"),
    (lambda d: d["reach_arm"]["links"][0]["joints"][0].update(name="tail"), "is not one of the controller's joints"),
    (lambda d: d["reach_arm"]["links"][0].update(pos=[0.0, 1e3, 0.0]), r"links\[0\]\.pos\[1\]: must be within"),
    (lambda d: d["reach_arm"].update(shoulder_link=7), "shoulder_link: must be a link's index"),
    (lambda d: d["reach_arm"].update(links=[]), "reach_arm.links: must be a list of 1 to 32 bodies"),
])
def test_a_bad_arm_chain_is_refused_naming_the_field(reacher_file, change, problem):
    import json

    data = json.loads(reacher_file.read_text())
    change(data)
    with pytest.raises(ConfigError, match=problem):
        Controller.from_dict(data, "reacher.json")


def test_an_arm_chain_without_the_reach_input_is_refused(reacher_file):
    import json

    walker = json.loads(Path("configs/controllers/xl430_biped_no_gyro.json").read_text())
    walker["reach_arm"] = json.loads(reacher_file.read_text())["reach_arm"]
    with pytest.raises(ConfigError, match="reach_arm: only with reach_input: true"):
        Controller.from_dict(walker, "walker.json")


def test_under_the_home_rule_a_network_at_rest_holds_home():
    """The human's anatomical ranges put home at an end (straight knees, arms at the sides): the
    range rule sends a network without connections to the middles, the home rule keeps home."""
    from sim2real.controller.policy import Policy

    human = load_measured("human_arms")
    config = load_evolve_config("configs/evolve/reach.yaml")
    assert config.task.output_centre == "home"
    pose = config.stages[0]
    scores = {}
    for rule in ("range", "home"):
        task = dataclasses.replace(config.task, output_centre=rule)
        ev = LocomotionEvaluator(human, task, 1, threads=1)
        e = ev.evaluate([Genome(0, ev.neat_layout)], 1.0, objective=pose.make_objective)
        scores[rule] = e.fitness[0] / pose.max_fitness
    assert scores["home"] > 0.9 > 0.3 > scores["range"], scores
    from evolve.locomotion.export import controller_from_genome

    layout = symmetric_layout(human, human.control_sets["reach"], config.task.inputs)
    controller = controller_from_genome(Genome(0, ev.neat_layout), human, layout, config.task, 1.0, {})
    assert controller.joints.output_rule.startswith("central 0.8 about home")
    policy = Policy(Controller.from_dict(controller.to_dict()), human)
    home = np.array([j.home_rad for j in human.joints])
    goal = policy.step(home, np.array([True, True]), np.array([0.0, 0.0, 1.0]), home)
    assert np.allclose(goal, home)


def test_modules_below_reaching_never_link_from_the_reach_inputs(tmp_path):
    """The reach inputs read 0 below a reach stage: a weight from them would never matter there,
    and frozen, it would disturb the module once reaching makes them speak."""
    from evolve.run import Run

    config = dataclasses.replace(CONFIG, neat=dataclasses.replace(CONFIG.neat, population_size=8, target_species=2,
                                                                  add_link_prob=0.9),
                                 stages=tuple(dataclasses.replace(s, generations=2, threshold=0.0)
                                              for s in CONFIG.stages),
                                 task=dataclasses.replace(CONFIG.task, episode_s=0.5))
    run = Run.create(config, tmp_path / "run", log=lambda s: None)
    layout = run.evaluator.layout
    reach_ids = {layout.input_names.index(n) for n in ("reach_control", "target_forward", "target_left",
                                                       "target_up")}
    assert run.population.silent_inputs == reach_ids
    run.evolve()
    genome = Controller.load(tmp_path / "run" / "controller.json")
    modules = genome.modules
    by_module = {m: {c[0] for c in genome.connections if c[3] == modules.index(m)} for m in modules}
    assert modules == ("pose", "stand", "reach")
    assert not (by_module["pose"] | by_module["stand"]) & reach_ids
    # the reach module starts as a reach module evolved alone starts: its inputs linked to every output
    reach_links = [c for c in genome.connections if c[3] == 2 and c[0] in reach_ids]
    assert len(reach_links) >= 0.9 * len(reach_ids) * len(layout.output_names)


@pytest.mark.parametrize("path", ["configs/evolve/reach.yaml", "configs/evolve/reach_op3.yaml"])
def test_the_largest_bonus_is_what_a_hand_always_at_its_goal_earns(path):
    from sim2real.robot.timing import control_timing

    config = load_evolve_config(path)
    task, stage = config.task, config.stages[-1]
    tick_s = control_timing(load_measured(config.robot)).tick_s
    cycle, ids = ReachCycle(1, task.reach_phase_s, task.reach_tolerance), np.zeros(1, dtype=np.intp)
    for t in range(int(round(task.episode_s / tick_s))):  # as the evaluator's readings
        cycle.update(ids, np.zeros(1), tick_s if t else 0.0)
    n_ticks = int(round(task.episode_s / tick_s))
    assert cycle.reached[0] == ReachCycle.max_goals(n_ticks, tick_s, task.reach_phase_s) > 0
    assert stage.bonus_max == pytest.approx(stage.weights.max_fitness())  # every goal doubles the maximum


def test_a_reset_policy_reads_the_target_offset_it_was_evolved_with():
    from evolve.locomotion.evaluator import neat_layout
    from evolve.locomotion.export import controller_from_genome
    from sim2real.controller.channels import Reach
    from sim2real.controller.policy import Policy

    task = dataclasses.replace(CONFIG.task, reach_forward=0.3, reach_left=-0.45, reach_up=0.6)
    layout = symmetric_layout(OP3, OP3.control_sets["reach"], task.inputs)
    policy = Policy(controller_from_genome(Genome(0, neat_layout(layout)), OP3, layout, task, 1.0, {}), OP3)
    evolved = Reach.target(layout.inputs["reach"])
    assert np.array_equal(policy.reach.offset, evolved)
    policy.reset()
    assert np.array_equal(policy.reach.offset, evolved)


def test_stage_weights_are_the_objectives_own_over_its_defaults():
    from evolve.stages import parse_stages

    with pytest.raises(ConfigError, match="a stand stage does not score reaching"):
        parse_stages([{"name": "s", "objective": "stand", "generations": 5, "weights": {"reaching": 2.0}}], "x.yaml")
    (stage,) = parse_stages([{"name": "r", "objective": "reach", "generations": 5, "weights": {"torque": 0.5}}],
                            "x.yaml")
    assert stage.weights == PoseWeights(1.0, 1.0, 1.0, 1.0, 2.0, 0.5)  # table 4.1's, torque changed


def test_a_reach_stage_needs_a_control_set_with_the_right_arm():
    doc = {"robot": "op3", "task": {"control_set": "legs", "reach_input": True},
           "stages": [{"name": "reach", "objective": "reach", "generations": 5}]}
    with pytest.raises(ConfigError, match="task.control_set: 'legs' drives none of the right arm's joints"):
        parse_evolve_config(doc, "reach.yaml")


def test_the_reach_benchmark_runs_pairs_and_continues_from_its_folder(tmp_path, capsys):
    """Tiny budgets: one generation a stage; a second call reads the finished runs back."""
    import json

    import yaml

    from benchmarks import reach as bench

    doc = load_evolve_config("configs/evolve/reach_op3.yaml").to_dict()  # resolved: it extends reach.yaml
    doc["task"]["episode_s"] = 1.0
    doc["neat"] = {"population_size": 4, "target_species": 2}
    doc["stages"] = [dict(s, generations=1) for s in doc["stages"]]
    hierarchy = tmp_path / "h.yaml"
    hierarchy.write_text(yaml.safe_dump(doc))
    doc["stages"] = [{"name": "reach", "objective": "reach", "generations": 2, "threshold": 0.55}]
    baseline = tmp_path / "b.yaml"
    baseline.write_text(yaml.safe_dump(doc))
    args = ["--hierarchy", str(hierarchy), "--baseline", str(baseline), "--seeds", "1", "--threads", "1",
            "--out", str(tmp_path / "runs"), "--json"]
    bench.main(args)
    first = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    stages = first["hierarchy"]["per_seed"][0]["stages"]
    assert [s["name"] for s in stages] == ["pose", "stand", "reach"]
    assert first["hierarchy"]["per_seed"][0]["total_generations"] == sum(s["generations"] for s in stages)
    assert first["baseline"]["per_seed"][0]["total_generations"] == 2
    bench.main(args)  # read back, not run again
    again = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert again["hierarchy"]["per_seed"][0]["total_generations"] == first["hierarchy"]["per_seed"][0]["total_generations"]


def test_reaching_every_goal_beats_standing_still_across_table_41s_threshold():
    """The measure behind the objective's means over ticks (see ReachObjective): a hand-made
    reacher whose target is where its arm swings, against a network that stands still."""
    genome, there = _aimed(dataclasses.replace(CONFIG.task, episode_s=5.0))
    stage = CONFIG.stages[-1]
    ev = LocomotionEvaluator(OP3, there, 2, threads=1)
    e = ev.evaluate([genome, Genome(1, ev.neat_layout)], 1.0, objective=stage.make_objective)
    share = e.fitness / stage.max_fitness
    assert e.terms["reaches"][0] == 4 and e.terms["reaches"][1] == 0
    assert share[0] > stage.threshold > share[1], share


def test_eval_scores_with_the_weights_of_the_stage_a_controller_was_evolved_in(reacher_file, tmp_path):
    from evolve.replay import _objective

    data = Controller.load(reacher_file).to_dict()
    baseline = [{"name": "reach", "objective": "reach", "generations": 5,
                 "weights": {"rest_pose": 2.0, "rest_pose_end": 1.0, "com": 1.0, "feet": 1.0, "reaching": 2.0,
                             "torque": 1.0}}]
    data["provenance"] = {"config": {"stages": baseline}}
    path = tmp_path / "baseline.json"
    Controller.from_dict(data).save(path)
    ev = LocomotionEvaluator(OP3, dataclasses.replace(CONFIG.task, episode_s=0.2), 1, threads=1)
    ev.evaluate([Genome(0, ev.neat_layout)], 1.0, objective=_objective(Controller.load(path)))
    assert ev.objective.weights.rest_pose == 2.0
    ev.evaluate([Genome(0, ev.neat_layout)], 1.0, objective=_objective(Controller.load(reacher_file)))
    assert ev.objective.weights.rest_pose == 1.0  # no stages recorded: table 4.1's


SHIPPED_REACHERS = ["configs/controllers/human_arms_reach.json", "configs/controllers/op3_reach.json"]


@pytest.mark.parametrize("path", SHIPPED_REACHERS)
def test_a_shipped_reacher_reaches_three_times_in_10_s_and_stands_without_its_reach_module(path):
    """Issue 34's bar for the shipped reachers (`biped eval` reports the same numbers)."""
    from evolve.replay import evaluate_controller

    reached = evaluate_controller(path, seconds=10.0)
    assert reached["reaches"] >= 3 and not reached["fell"], reached
    # Every goal the phase rule leaves room for (README: "reaches 9 times in 10 s"), and no more:
    # a state that toggled the moment the hand arrived, without waiting out reach_phase_s,
    # gave 4 (human_arms) and 34 (op3) here.
    controller = Controller.load(path)
    phase_s = controller.to_dict()["task"]["reach_phase_s"]
    assert reached["reaches"] == ReachCycle.max_goals(int(round(10.0 / controller.tick_s)), controller.tick_s,
                                                       phase_s) == 9, reached
    assert reached["other_arm_deg"] < 5.0  # one-handed: the left arm keeps its rest
    standing = evaluate_controller(path, seconds=10.0, disabled_modules=("reach",))
    assert standing["reaches"] == 0 and not standing["fell"]


def test_the_reach_benchmark_draws_each_runs_curve_from_where_its_reaching_began(tmp_path):
    from benchmarks.reach import plot, reach_curve
    from sim2real.atomic_json import read_json

    runs = Path(__file__).resolve().parents[1] / "benchmarks" / "records" / "runs" / "reach-bench2"
    hierarchy = {"seed": 1, "solved": True, "stages": read_json(runs / "hierarchy-seed1" / "stages.json")}
    x, y = reach_curve(hierarchy, runs / "hierarchy-seed1")
    below = sum(s["generations"] for s in hierarchy["stages"][:-1])  # posing's and standing's
    reach = hierarchy["stages"][-1]
    assert x == list(range(below + 1, below + reach["generations"] + 1))
    assert y == sorted(y) and y[-1] == pytest.approx(reach["best_fitness"] / reach["max_fitness"], rel=1e-5)
    baseline = {"seed": 1, "solved": False, "stages": read_json(runs / "baseline-seed1" / "stages.json")}
    assert reach_curve(baseline, runs / "baseline-seed1")[0][0] == 1
    plot(runs, {"hierarchy": [hierarchy], "baseline": [baseline]}, 0.55, tmp_path / "reach.png")
    assert (tmp_path / "reach.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
