"""Every simulation-to-robot convention has one owner: evolution, the runtime, the simulated
bus and compare read the same value from the same place (change it there, and all of them
change), so that a controller transfers by construction, not by care."""

import dataclasses
import json
from pathlib import Path

import numpy as np

from sim2real.controller.schema import FIELDS
import pytest
import yaml

import evolve.locomotion.evaluator as evaluator_module
import evolve.neat.network as neat_network
import sim2real.simulation.model.robot_model as robot_model
import sim2real.controller.activation as activation
import sim2real.controller.channels as channels
import sim2real.controller.file as controller_file
import sim2real.controller.mapping as mapping
import sim2real.controller.policy as policy_module
import sim2real.controller.schema as controller_schema
import sim2real.controller.symmetry as symmetry
import sim2real.hardware.dynamixel.chain as chain
import sim2real.hardware.mock as mock
import sim2real.simulation.transfer.compare as compare_module
import sim2real.simulation.model.builder as model_builder
import sim2real.simulation.simbus.physics as physics
from evolve.locomotion.evaluator import LocomotionEvaluator, neat_layout
from evolve.locomotion.export import controller_from_genome
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome, NeatConfig, Population, PopulationNetwork
from sim2real.controller.activation import ControllerNetworks, Networks
from sim2real.controller.file import Controller
from sim2real.controller.policy import Policy
from sim2real.errors import ConfigError
from sim2real.hardware.dynamixel.chain import ServoChain
from sim2real.hardware.mock import MockBus
from sim2real.robot import load_robot
from sim2real.robot.spec import DEFAULT_CONTACT_SHARE
from sim2real.simulation.reality.file import load_reality

ROOT = Path(__file__).resolve().parent.parent
ROBOT = load_robot()
LAYOUT = symmetry.symmetric_layout(ROBOT, ROBOT.control_sets["walk"])
V1_FILE = Path(__file__).parent / "data" / "controller_v1.json"  # written by the format-1 code before issue 13


def grown(seed: int = 5) -> Genome:
    pop = Population(NeatConfig(population_size=12, target_species=3, add_node_prob=0.4, add_link_prob=0.6),
                     neat_layout(LAYOUT), seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(6):
        pop.step(lambda gs: rng.random(len(gs)))
    return max(pop.genomes, key=lambda g: len(g.conns))


def robot_file(tmp_path: Path, **board) -> Path:
    """The default robot's config with its sensor board changed."""
    doc = yaml.safe_load((ROOT / "configs" / "robots" / "xl430_biped.yaml").read_text())
    doc["sensor_board"].update(board)
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def standing_trace(path: Path, feet: list[int]) -> Path:
    """A trace of the default robot at home, goals and angles, for ``len(feet)`` ticks with both
    foot switches at ``feet[k]``, and its sidecar."""
    names = ROBOT.joint_names
    home = [j.home_rad for j in ROBOT.joints]
    rows = [",".join(["time_s", "tick", *(f"{n}_goal_rad" for n in names), *(f"{n}_present_rad" for n in names),
                      "foot_left", "foot_right", "up_x", "up_y", "up_z", "compute_ms", "bus_ms", "overrun"])]
    for k, touching in enumerate(feet):
        rows.append(",".join(map(str, [k * 0.034, k, *home, *home, touching, touching, 0.0, 0.0, 1.0, 0.1, 0.1, 0])))
    path.write_text("\n".join(rows) + "\n")
    path.with_suffix(".json").write_text(json.dumps({"robot": ROBOT.name}))
    return path


# -- the activation --------------------------------------------------------------------------------
def test_one_activation_step_for_evolution_and_the_runtime(monkeypatch):
    assert neat_network.Z_LIMIT is activation.Z_LIMIT
    assert issubclass(PopulationNetwork, Networks) and issubclass(ControllerNetworks, Networks)
    assert PopulationNetwork.activate is ControllerNetworks.activate is Networks.activate
    genome = grown()
    controller = controller_from_genome(genome, ROBOT, LAYOUT, TaskConfig(), 1.0, {})
    calls = []
    step = activation.activate
    monkeypatch.setattr(activation, "activate", lambda *a: calls.append(len(a[0])) or step(*a))
    x = np.full((2, LAYOUT.n_inputs), 0.25)
    evolution = PopulationNetwork([genome, genome], 1.0, bias_values=symmetry.bias_values(1)).activate(x)
    runtime = Policy(controller, ROBOT).networks.activate(x)
    assert len(calls) == 2 and np.array_equal(evolution, runtime)
    monkeypatch.setattr(activation, "Z_LIMIT", 1e-9)  # the clip is read from the one owner by both
    assert np.allclose(PopulationNetwork([genome, genome], 1.0, bias_values=symmetry.bias_values(1)).activate(x), 0.5)
    assert np.allclose(ControllerNetworks(controller).activate(x), 0.5)


# -- wiring, the central-0.8 rule, normalization, the rate limit -----------------------------------
def test_evolution_and_the_runtime_wire_and_map_with_the_same_functions(monkeypatch):
    for name in ("output_to_angle", "rate_limit"):
        assert getattr(evaluator_module, name) is getattr(policy_module, name) is getattr(mapping, name), name
    assert channels.normalized_angle is mapping.normalized_angle  # the joint channels' normalization
    for name in ("InputWiring", "Readings"):  # every input, from the one channel registry
        assert getattr(evaluator_module, name) is getattr(policy_module, name) is getattr(channels, name), name
    assert evaluator_module.joint_outputs is symmetry.joint_outputs
    assert compare_module.Policy is Policy
    controller = controller_from_genome(grown(), ROBOT, LAYOUT, TaskConfig(), 1.0, {})
    angles, feet, up = np.zeros(len(ROBOT.joints)), np.array([True, False]), np.array([0.0, 0.0, 1.0])

    def goals() -> np.ndarray:
        policy = Policy(controller, ROBOT)
        previous = np.array([j.center_rad for j in ROBOT.joints])
        return policy.step(angles, feet, up, previous)[policy.driven]

    before = goals()
    monkeypatch.setattr(mapping, "OUTPUT_MARGIN", 0.3)  # the output rule's one constant
    assert not np.array_equal(goals(), before)
    assert controller_file.OUTPUT_RULES is mapping.OUTPUT_RULES  # what a file states, from the one owner
    assert mapping.OUTPUT_RULE == "central 0.8 of the range: 0.1 -> low, 0.9 -> high"
    assert list(mapping.OUTPUT_RULES.values()) == FIELDS["joints"]["properties"]["output_rule"]["enum"]


# -- the hold pose, the step per tick, the bias values ---------------------------------------------
def test_hold_pose_and_max_step_come_from_one_place(monkeypatch):
    assert evaluator_module.hold_pose is policy_module.hold_pose is controller_file.hold_pose is mapping.hold_pose
    monkeypatch.setattr(mapping, "max_step_per_tick", lambda profile, tick_s: 0.0123)  # the servo model's
    controller = controller_from_genome(grown(), ROBOT, LAYOUT, TaskConfig(), 1.0, {})
    policy = Policy(controller, ROBOT)
    ev = LocomotionEvaluator(ROBOT, TaskConfig(episode_s=0.1), 1, threads=1)
    assert np.all(policy.max_step == 0.0123) and np.all(ev.max_step == 0.0123)
    assert np.array_equal(policy.hold, ev.hold)
    assert np.array_equal(policy.reset(), mapping.hold_pose(ROBOT, LAYOUT.driven))
    held = {j.name: h for j, h in zip(ROBOT.joints, ev.hold) if j.name not in LAYOUT.driven}
    assert dict(controller.joints.hold_rad) == held  # what the file says is what evolution held


def test_the_bias_values_have_one_owner():
    controller = controller_from_genome(grown(), ROBOT, LAYOUT, TaskConfig(), 1.0, {})
    assert controller.bias == symmetry.BIAS  # exported, then read by the runtime
    assert np.array_equal(symmetry.bias_values(3), np.tile(symmetry.BIAS, (3, 1)))  # evolution's
    assert np.array_equal(ControllerNetworks(controller)._bias_values, np.array(symmetry.BIAS))


# -- joint angles: servo joint + gear play, read in one place -------------------------------------
def test_evolution_the_simulated_bus_and_compare_read_joint_angles_through_one_reader(monkeypatch, tmp_path):
    assert model_builder.JointAngles is robot_model.JointAngles  # the simulated bus reads RobotModel.angles
    assert evaluator_module.RobotModel is physics.RobotModel is compare_module.RobotModel is robot_model.RobotModel
    reality = load_reality({"backlash_deg": 2.0})
    now = [0.0]
    sim = physics.PhysicsChain(ROBOT, clock=lambda: now[0], reality=reality)
    for dxl_id in sim.ids:
        sim.devices[dxl_id].set_named("torque_enable", 1)
    now[0] = 0.5
    sim.advance()  # standing: loaded joints lean on one side of their 2-deg play
    play = sim.data.qpos[sim.angles.play_qpos]
    assert np.abs(play).max() > np.radians(0.9)
    present = [sim.devices[i].get_named("present_position") for i in sim.ids]
    assert present == list(sim._ticks(sim.angles.read(sim.data.qpos)))  # what the encoder sees: servo + play
    assert present != list(sim._ticks(sim.angles.servo(sim.data.qpos)))

    readers = []  # every reader goes through JointAngles.read
    read = model_builder.JointAngles.read
    monkeypatch.setattr(model_builder.JointAngles, "read", lambda self, qpos: readers.append(self) or read(self, qpos))
    ev = LocomotionEvaluator(ROBOT, TaskConfig(episode_s=0.1), 1, threads=1, reality=reality)
    ev.evaluate([Genome(0, ev.neat_layout)], 1.0, perturbation=ev.sample(np.zeros((1, 1))))
    assert any(r is ev.angles for r in readers) and ev.angles.has_play
    now[0] = 0.6
    sim.advance()
    assert any(r is sim.angles for r in readers)
    count = len(readers)
    compare_module.compare(standing_trace(tmp_path / "standing.csv", [1, 1, 1]))
    assert len(readers) == count + 3  # one read a tick


# -- the foot-contact threshold ------------------------------------------------------------------
def test_the_robots_sensor_board_decides_when_a_foot_touches_everywhere(tmp_path):
    assert ROBOT.contact_share == DEFAULT_CONTACT_SHARE == 0.05
    strict = load_robot(robot_file(tmp_path, contact_share=1.0))  # the whole weight on one sole
    assert strict.contact_share == 1.0 and strict.foot_contact_n == pytest.approx(ROBOT.foot_contact_n * 20)
    for robot, touching in ((ROBOT, 1), (strict, 0)):  # standing: about half the weight on each sole
        ev = LocomotionEvaluator(robot, TaskConfig(episode_s=0.1), 1, threads=1)  # evolution
        assert ev.parts.foot_contact_n == robot.foot_contact_n
        now = [0.0]
        sim = physics.PhysicsChain(robot, clock=lambda: now[0])  # the simulated bus's foot switches
        for dxl_id in sim.ids:
            sim.devices[dxl_id].set_named("torque_enable", 1)  # holding its start pose
        now[0] = 0.2
        sim.advance()  # the soles settle from their start clearance onto the floor
        board = sim.devices[robot.sensor_board.id]
        assert (board.get_named("foot_switch_left"), board.get_named("foot_switch_right")) == (touching, touching)
    # compare: a trace whose feet touch from the second tick on (the soles start 0.5 mm up) agrees with
    # the simulation on the nominal board, and on the strict one only where nothing touches
    trace = standing_trace(tmp_path / "standing.csv", [int(k > 0) for k in range(10)])
    assert compare_module.compare(trace)["contact_agreement"] == 1.0
    assert compare_module.compare(trace, str(robot_file(tmp_path, contact_share=1.0)))["contact_agreement"] == 0.1


def test_the_task_no_longer_owns_the_contact_threshold(tmp_path):
    assert "contact_threshold" not in TaskConfig().to_dict()
    assert TaskConfig.from_mapping({"contact_threshold": 0.05}) == TaskConfig()  # configs and controllers before
    with pytest.raises(ConfigError, match="task.contact_threshold: 0.1: when a foot touches is the robot's"):
        TaskConfig.from_mapping({"contact_threshold": 0.1})
    with pytest.raises(ConfigError, match="sensor_board.contact_share: must be > 0"):
        load_robot(robot_file(tmp_path, contact_share=0.0))


# -- the up-vector's and the heading's units and signed registers ---------------------------------
def test_the_board_profile_gives_the_up_vectors_unit_to_the_simulated_bus_and_the_runtime():
    board = ROBOT.sensor_board
    assert board.profile.units["up_vector_unit"] == 1 / 16384  # Q14, from foot_sensor_board.yaml
    assert board.profile.units["heading_unit"] == 1 / 8192  # Q13 [rad]
    coarse = dataclasses.replace(board.profile, units={"up_vector_unit": 1 / 1000, "heading_unit": 1 / 100,
                                                       "gyro_unit": 1 / 10})
    robot = dataclasses.replace(ROBOT, sensor_board=dataclasses.replace(board, profile=coarse))
    sim = physics.PhysicsChain(robot)  # writes the board's registers in the profile's unit
    assert abs(sim.devices[board.id].get_named("up_vector_z") - 1000) <= 2
    yaw = 0.7  # turn the robot left about world up: the heading follows
    w, z = np.cos(yaw / 2), np.sin(yaw / 2)
    q = sim.data.qpos[3:7].copy()
    sim.data.qpos[3:7] = [w * q[0] - z * q[3], w * q[1] - z * q[2], w * q[2] + z * q[1], w * q[3] + z * q[0]]
    physics.mujoco.mj_forward(sim.model, sim.data)
    sim._publish()
    assert abs(sim.devices[board.id].get_named("heading") - 70) <= 1
    bus = MockBus(robot)
    bus.devices = sim.devices  # the runtime's chain reads them in the same unit
    bus.open()
    feet, up, heading, _ = ServoChain(bus, robot).read_board()
    assert up == pytest.approx([0.0, 0.0, 1.0], abs=3e-3) and heading == pytest.approx(yaw, abs=0.011)


def test_signed_registers_are_decoded_by_one_function():
    assert mock.decode is physics.decode is chain.decode
    goal = ROBOT.joints[0].servo.profile.register("goal_position")
    assert chain.decode(goal, (1 << 32) - 5) == -5 and chain.decode(goal, 5) == 5


# -- the controller type ------------------------------------------------------------------------
def test_v1_files_load_and_save_byte_for_byte(tmp_path):
    controller = Controller.load(V1_FILE, ROBOT)
    controller.save(tmp_path / "again.json")
    assert (tmp_path / "again.json").read_bytes() == V1_FILE.read_bytes()
    assert Controller.from_dict(controller.to_dict()) == controller
    assert controller.modules == ("pose", "walk") and len(controller.hidden) == 4
    with pytest.raises(dataclasses.FrozenInstanceError):
        controller.tick_s = 0.01


def test_the_symmetry_block_is_what_the_runtime_wires(tmp_path):
    controller = Controller.load(V1_FILE)
    assert controller.layout(ROBOT) == LAYOUT == Policy(controller, ROBOT).layout
    data = controller.to_dict()
    legs = data["symmetry"]["leg_joints"]
    legs["right"], legs["left"] = legs["left"], legs["right"]  # consistent in itself, wrong for the robot
    swapped = Controller.from_dict(data)
    with pytest.raises(ConfigError, match="symmetry: the wiring differs from robot xl430_biped's"):
        Policy(swapped, ROBOT)


def test_the_published_schema_owns_the_formats_keys_and_bounds():
    schema = json.loads((Path(controller_schema.__file__).parent / "schemas" / "controller-v1.schema.json").read_text())
    assert controller_schema.SCHEMA == schema and controller_schema.REQUIRED == tuple(schema["required"])
    assert controller_schema.TICK_RANGE_S == (schema["properties"]["tick_s"]["minimum"],
                                              schema["properties"]["tick_s"]["maximum"])
    assert schema["properties"]["symmetry"]["properties"]["networks"]["const"] == list(symmetry.SIDES)
    assert Controller.load(V1_FILE).inputs[-4:] == ("own_foot", "other_foot", "up_forward", "up_sideways")


def test_export_writes_the_controller_through_the_one_type():
    controller = controller_from_genome(grown(), ROBOT, LAYOUT, TaskConfig(), 1.0, {"seed": 5})
    assert isinstance(controller, Controller) and controller.version == controller_schema.VERSION == 1
    assert controller.symmetry == controller_file.Symmetry.of(ROBOT, LAYOUT)
    assert controller.symmetry.center_output == symmetry.CENTER_OUTPUT
    assert list(controller.to_dict()) == list(controller_schema.REQUIRED)
