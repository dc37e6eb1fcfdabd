"""The gyro input channel: mirrored as an angular rate is, computed alike by evolution and the
runtime (bit for bit), served by the simulated bus in the board's unit, refused on a board
without it, and the channel registry as the one owner of every input."""

import dataclasses

import numpy as np
import pytest

from evolve.locomotion.evaluator import LocomotionEvaluator, neat_layout
from evolve.locomotion.export import controller_from_genome
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome
from evolve.neat.genome import ConnectionGene
from sim2real.controller import channels
from sim2real.controller.file import Controller
from sim2real.controller.mapping import normalized_angle
from sim2real.controller.policy import Policy
from sim2real.controller.symmetry import network_inputs, symmetric_layout
from sim2real.errors import ConfigError, UsageError
from sim2real.hardware.deploy import drive
from sim2real.hardware.dynamixel.chain import ServoChain
from sim2real.hardware.mock import MockBus
from sim2real.robot import load_robot
from sim2real.simulation.reality.file import load_reality
from sim2real.simulation.simbus import physics

ROBOT = load_robot()
TASK = TaskConfig(gyro_input=True, gyro_scale_dps=90.0, episode_s=1.0)


def _gyro_controller(task: TaskConfig = TASK) -> tuple[Genome, Controller]:
    """Roll rate -> own hip roll, yaw rate -> own hip pitch: nothing else."""
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"], task.inputs)
    genome = Genome(0, neat_layout(layout))
    out = layout.n_inputs + layout.n_bias
    for k, (src, dst, weight) in enumerate([("gyro_roll", "own_hip_roll", 8.0), ("gyro_yaw", "own_hip_pitch", 5.0)]):
        genome.add_connection(ConnectionGene(k, layout.input_names.index(src), out + layout.output_names.index(dst),
                                             weight, True, genome.active_module))
    return genome, Controller.from_dict(controller_from_genome(genome, ROBOT, layout, task, 1.0, {}).to_dict())


def test_the_gyro_comes_after_the_sensors_and_is_mirrored_as_an_angular_rate():
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"], TaskConfig(gyro_input=True, heading_input=True).inputs)
    names = layout.input_names
    assert names[names.index("up_sideways") + 1:][:4] == ("heading", "gyro_roll", "gyro_pitch", "gyro_yaw")
    n = 5
    rng = np.random.default_rng(3)
    readings = channels.Readings(angles=rng.uniform(-0.3, 0.3, (n, len(ROBOT.joints))), feet=rng.random((n, 2)) < 0.5,
                                 up=rng.normal(0, 0.1, (n, 3)) + [0, 0, 1], heading=rng.uniform(-3, 3, n),
                                 target_heading=rng.uniform(-3, 3, n), gyro=rng.normal(0, 2.0, (n, 3)))
    low, high = (np.array([j.range_rad[k] for j in ROBOT.joints]) for k in (0, 1))
    fast = channels.InputWiring(layout, low, high).inputs(readings)
    scale = np.radians(180.0)
    turn = np.angle(np.exp(1j * (readings.heading - readings.target_heading)))
    oracle = network_inputs(layout, normalized_angle(readings.angles, low, high), np.where(readings.feet, -1.0, 1.0),
                            readings.up, heading=np.clip(-turn / np.pi, -1, 1),
                            gyro=np.clip(readings.gyro / scale, -1, 1))
    assert np.array_equal(fast, oracle)  # the registry's gather and the plain reference, bit for bit
    right, left = fast[0::2], fast[1::2]
    column = {name: names.index(name) for name in ("gyro_roll", "gyro_pitch", "gyro_yaw")}
    assert np.array_equal(left[:, column["gyro_roll"]], -right[:, column["gyro_roll"]])  # odd under the mirror
    assert np.array_equal(left[:, column["gyro_yaw"]], -right[:, column["gyro_yaw"]])
    assert np.array_equal(left[:, column["gyro_pitch"]], right[:, column["gyro_pitch"]])  # even
    assert np.abs(fast[:, list(column.values())]).max() == 1.0  # clipped at the scale (rates of 2 rad/s)


def test_the_gyro_drives_evolution_and_the_runtime_alike_bias_and_noise_included():
    genome, controller = _gyro_controller()
    assert controller.to_dict()["gyro_input"] is True and controller.to_dict()["gyro_scale_dps"] == 90.0
    assert channels.sensors_needed(controller.input_channels) == ("gyro",)
    shaky = load_reality({"gyro_bias_dps": [-40.0, 40.0], "gyro_noise_dps": 5.0})
    evaluator = LocomotionEvaluator(ROBOT, TASK, 1, threads=1, reality=shaky)
    p = evaluator.sample(np.array([[4, 0]]))
    assert np.abs(p.gyro_bias_rad_s).max() > np.radians(5) and p.gyro_noise_rad_s.std() > 0
    zero_goal = np.zeros((1, len(evaluator.driven)))
    goals, rates = [], [evaluator.readings(np.array([0]), 0, p, zero_goal, None).gyro[0]]
    def record(ev, alive):
        goals.append(ev.ctrl[0].copy())
        if len(goals) < ev.n_ticks:  # the next tick's reading, as the evaluator will take it
            rates.append(ev.readings(alive, len(goals), p, zero_goal, None).gyro[0])

    evaluator.evaluate([genome], 1.0, harness=1.0, perturbation=p, on_tick=record)
    policy = Policy(controller, ROBOT)
    seen, activate = [], policy.networks.activate
    policy.networks.activate = lambda x: activate(seen.append(x.copy()) or x)  # what the two networks read
    goal = policy.reset()
    for k, simulated in enumerate(goals):
        goal = policy.step(np.zeros(len(goal)), np.array([True, True]), np.array([0.0, 0.0, 1.0]), goal,
                           gyro=rates[k])
        assert np.array_equal(goal[policy.driven], simulated[policy.driven]), k
    # Against the convention itself, not the other path: the right network reads the rates over
    # the scale, the left (the mirror image) the roll and yaw rates negated, the pitch rate as it is.
    names = symmetric_layout(ROBOT, ROBOT.control_sets["walk"], TASK.inputs).input_names
    gyro = [names.index(name) for name in ("gyro_roll", "gyro_pitch", "gyro_yaw")]
    assert len(seen) == len(rates) and np.abs(rates).min(axis=0).min() > 0  # every axis turns: each sign is seen
    for x, rate in zip(seen, rates):
        right, left = x[0, gyro], x[1, gyro]
        assert right == pytest.approx(np.clip(rate / np.radians(90.0), -1, 1), abs=1e-12)
        assert left == pytest.approx(right * [-1.0, 1.0, -1.0], abs=1e-12)
    hips = np.array(goals)[:, [ROBOT.joint_names.index("right_hip_roll"), ROBOT.joint_names.index("left_hip_roll")]]
    assert np.ptp(hips) > 0.01  # the rates moved the hips
    moved = hips - hips[0]
    assert np.corrcoef(moved[:, 0], moved[:, 1])[0, 1] < -0.9  # in opposite directions: a roll is odd
    with pytest.raises(ValueError, match="gyro"):
        Policy(controller, ROBOT).step(np.zeros(len(goal)), np.array([True, True]), np.array([0.0, 0.0, 1.0]), goal)


def test_the_simulated_bus_serves_the_torsos_rates_in_the_boards_unit_with_its_bias():
    board = ROBOT.sensor_board
    assert board.profile.units["gyro_unit"] == pytest.approx(1 / 900)  # BNO055's Rps unit
    sim = physics.PhysicsChain(ROBOT, reality=load_reality({"gyro_bias_dps": 10.0}))
    sim.data.qvel[3:6] = [0.5, -0.25, 1.0]  # the root's angular velocity in its own frame [rad/s]
    physics.mujoco.mj_forward(sim.model, sim.data)
    sim._publish()
    bus = MockBus(ROBOT)
    bus.devices = sim.devices  # the runtime's chain reads what the simulated bus serves
    bus.open()
    gyro = ServoChain(bus, ROBOT).read_board().gyro
    truth = sim.parts.gyro(sim.data.sensordata)
    assert truth == pytest.approx([0.5, -0.25, 1.0], abs=1e-9)  # the IMU sits on the trunk, the waist at rest
    assert gyro == pytest.approx(truth + np.radians(10.0), abs=1 / 900)


def test_a_gyro_controller_is_refused_before_any_servo_moves_on_a_board_without_a_gyro():
    board = ROBOT.sensor_board
    table = {k: v for k, v in board.profile.control_table.items() if not k.startswith("gyro_")}
    robot = dataclasses.replace(ROBOT, sensor_board=dataclasses.replace(
        board, profile=dataclasses.replace(board.profile, control_table=table)))
    bus = MockBus(robot)
    with pytest.raises(UsageError, match="reads the torso's gyro .* reports none"):
        drive(bus, robot, _gyro_controller()[1], duration_s=0.2, ramp_s=0.05, log=lambda s: None)
    assert not bus.writes and not bus.is_open


def test_a_gyro_controller_runs_on_the_mock_bus_and_traces_the_rates(tmp_path):
    from sim2real.hardware.trace import GYRO_CHANNELS, Trace

    bus = MockBus(ROBOT)
    bus.devices[ROBOT.sensor_board.id].set_named("gyro_x", 450)
    report = drive(bus, ROBOT, _gyro_controller()[1], duration_s=0.2, ramp_s=0.05, log=lambda s: None,
                   trace_path=tmp_path / "run.csv")
    assert report.stop_reason == "duration reached"
    trace = Trace.read(tmp_path / "run.csv")
    assert trace[GYRO_CHANNELS[0]] == pytest.approx(0.5)


@pytest.mark.parametrize("values, problem", [
    ({"gyro_scale_dps": 90.0}, "gyro_scale_dps: is the gyro input's setting: give it only with gyro_input: true"),
    ({"gyro_input": True, "gyro_scale_dps": 0.0}, r"gyro_scale_dps: must be within \(0, 2000\] deg/s, got 0"),
    ({"gyro_input": True, "gyro_scale_dps": 5000.0}, r"gyro_scale_dps: must be within \(0, 2000\] deg/s"),
])
def test_a_task_configs_gyro_settings_are_checked_by_the_registry(values, problem):
    with pytest.raises(ConfigError, match=problem):
        TaskConfig.from_mapping(values, "walk.yaml")


def test_every_channel_key_is_in_the_controller_schema_and_back():
    from sim2real.controller.schema import FIELDS, OPTIONAL

    keys = {k for c in channels.CHANNELS for k in ((c.switch,) if c.switch else ()) + tuple(s.key for s in c.settings)}
    assert keys | {"reach_arm"} == set(OPTIONAL)  # the schema's options: the channels' keys, and the reach arm
    for channel in channels.CHANNELS:
        for setting in channel.settings:
            field = FIELDS[setting.key]
            assert setting.high == field["maximum"] and setting.low_open == ("exclusiveMinimum" in field)
    every = {"heading": {"heading_scale_deg": 30.0}, "gyro": {"gyro_scale_dps": 250.0},
             "clock": {"phase_period_s": 0.8}, "efference": {}}
    assert channels.selection(channels.selection_keys(every)) == every
    assert channels.selection(channels.every_key(every)) == every
    assert channels.selection(channels.every_key({})) == {}


def test_the_network_drawing_names_the_gyro_inputs():
    from sim2real.figures.network import network_graph

    graph = network_graph(_gyro_controller()[1])
    labels = {label for _, label in graph.nodes(data="label")}
    assert {"gyro_roll", "gyro_pitch", "gyro_yaw"} <= labels
