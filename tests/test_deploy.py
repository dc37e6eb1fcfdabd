"""Deployment on the mock bus: start-up checks, the loop, and torque off on every exit path."""

import os
import signal
import time

import numpy as np
import pytest

from benchmarks.loop import random_controller
from sim2real.controller.mapping import ServoMapping
from sim2real.hardware import MockBus
from sim2real.hardware.deploy import drive
from sim2real.hardware.dynamixel.startup import StartupError
from sim2real.hardware.trace import TraceWriter
from sim2real.robot import load_robot
from sim2real.simulation.model.physique import load_measured

ROBOT = load_robot()


@pytest.fixture(scope="module")
def controller(grown_controller):
    return grown_controller


def torque(bus):
    return {i: d.get_named("torque_enable") for i, d in bus.devices.items() if d.profile.is_servo}


def goals_within_limits(bus):
    mapping = ServoMapping(ROBOT)
    goal_address = ROBOT.joints[0].servo.profile.register("goal_position").address
    for dxl_id, address, value in bus.writes:
        if address == goal_address:
            k = list(mapping.ids).index(dxl_id)
            assert mapping.tick_low[k] <= value <= mapping.tick_high[k], (dxl_id, value)


def run(bus, controller, **kw):
    kw.setdefault("ramp_s", 0.05)
    return drive(bus, ROBOT, controller, log=lambda s: None, **kw)


def test_a_normal_run_ends_with_torque_off_and_goals_inside_limits(controller, tmp_path):
    bus = MockBus(ROBOT)
    report = run(bus, controller, duration_s=0.4, trace_path=tmp_path / "run.csv")
    assert report.stop_reason == "duration reached"
    assert report.ticks == round(0.4 / controller.tick_s)
    assert all(v == 0 for v in torque(bus).values())
    goals_within_limits(bus)
    rows = (tmp_path / "run.csv").read_text().splitlines()
    assert len(rows) == report.ticks + 1 and rows[0].startswith("time_s,tick,waist_yaw_goal_rad")
    assert (tmp_path / "run.json").exists()
    assert not bus.is_open


def test_start_up_lists_every_missing_or_wrong_device_at_once(controller):
    bus = MockBus(ROBOT)
    bus.faults.silent.add(4)
    bus.devices[9].set_named("model_number", 1020)  # an XM430 where an XL430 belongs
    with pytest.raises(StartupError) as err:
        run(bus, controller, duration_s=0.2)
    message = str(err.value)
    assert "ID 4 (XL430-W250-T) does not answer" in message
    assert "ID 9 is model number 1020" in message
    assert all(v == 0 for v in torque(bus).values())


def test_start_up_refuses_a_latched_hardware_error(controller):
    bus = MockBus(ROBOT)
    bus.devices[6].set_named("hardware_error_status", 1 << 5)
    with pytest.raises(StartupError, match="ID 6: overload"):
        run(bus, controller, duration_s=0.2)


def test_start_up_configures_the_servos(controller):
    bus = MockBus(ROBOT)
    run(bus, controller, duration_s=0.1)
    mapping = ServoMapping(ROBOT)
    for k, dxl_id in enumerate(mapping.ids):
        device = bus.devices[int(dxl_id)]
        assert device.get_named("return_delay_time") == 0
        assert device.get_named("operating_mode") == 3
        assert device.get_named("min_position_limit") == mapping.tick_low[k]
        assert device.get_named("max_position_limit") == mapping.tick_high[k]
        assert device.get_named("bus_watchdog") == 5


def _after(n, action):
    calls = {"n": 0}

    def sleep(seconds):
        calls["n"] += 1
        if calls["n"] == n:
            action()
        time.sleep(min(seconds, 0.05))

    return sleep


def test_ctrl_c_ramps_to_rest_and_turns_torque_off(controller):
    bus = MockBus(ROBOT)

    def interrupt():
        raise KeyboardInterrupt

    report = run(bus, controller, duration_s=5, sleep=_after(12, interrupt))
    assert report.stop_reason == "interrupted (Ctrl-C)"
    assert all(v == 0 for v in torque(bus).values())


def test_sigterm_stops_safely(controller):
    bus = MockBus(ROBOT)
    report = run(bus, controller, duration_s=5, sleep=_after(12, lambda: os.kill(os.getpid(), signal.SIGTERM)))
    assert report.stop_reason == "terminated (SIGTERM)"
    assert all(v == 0 for v in torque(bus).values())


def test_lost_communication_names_the_servo_and_stops_safely(controller):
    bus = MockBus(ROBOT)
    report = run(bus, controller, duration_s=5, sleep=_after(12, lambda: bus.faults.silent.add(3)))
    assert report.stop_reason.startswith("lost communication: servo 3")
    assert all(v == 0 for i, v in torque(bus).items() if i != 3)


def test_a_missed_reply_is_retried(controller):
    """Servo 5 misses two replies in the loop: both reads are tried again within the tick (the
    mock answers at once, so the tick has time for both), no tick is lost, and the run ends as
    asked."""
    bus = MockBus(ROBOT)
    injected = []

    def miss_two_replies():
        bus.faults.timeouts[5] = 2
        injected.append(True)

    # the 8th sleep: the start's 0.05 s ramp sleeps 3 times, then the loop once a tick (not after
    # an overrun), so the misses come early in an 18-tick run even on a loaded machine
    report = run(bus, controller, duration_s=0.6, sleep=_after(8, miss_two_replies))
    assert injected and bus.faults.timeouts[5] == 0  # both misses were used up ...
    assert report.retries == 2 and report.missed_ticks == 0  # ... by the loop's reads, each tried again
    assert report.stop_reason == "duration reached" and report.ticks == round(0.6 / controller.tick_s)
    assert all(v == 0 for v in torque(bus).values())


def test_a_hardware_error_stops_with_the_servo_and_the_decoded_error(controller):
    bus = MockBus(ROBOT)
    report = run(bus, controller, duration_s=5, sleep=_after(12, lambda: bus.faults.alert.update({7: 1 << 5})))
    assert "servo 7" in report.stop_reason and "overload" in report.stop_reason
    assert all(v == 0 for v in torque(bus).values())


def test_a_non_finite_output_holds_the_last_goals_and_stops(controller, monkeypatch):
    from sim2real.controller.policy import Policy

    bus = MockBus(ROBOT)
    real_step = Policy.step
    calls = {"n": 0}

    def step(self, *args, **kwargs):
        calls["n"] += 1
        goal = real_step(self, *args, **kwargs)
        return goal * np.nan if calls["n"] == 5 else goal

    monkeypatch.setattr(Policy, "step", step)
    report = run(bus, controller, duration_s=5)
    assert report.stop_reason.startswith("non-finite goal at tick 4")
    assert report.ticks == 4
    assert all(v == 0 for v in torque(bus).values())
    goals_within_limits(bus)


def test_trace_rows_reach_the_disk_within_a_second(tmp_path):
    writer = TraceWriter(tmp_path / "t.csv", ["a"], {"robot": "x"})
    row = dict(goal=np.zeros(1), present=np.zeros(1), feet=np.array([True, False]), up=np.array([0, 0, 1.0]),
               compute_s=1e-4, bus_s=1e-3, overrun=False)
    writer.write(0.0, 0, **row)
    time.sleep(1.05)
    writer.write(1.05, 1, **row)  # not closed: a crash now would keep both rows
    assert len((tmp_path / "t.csv").read_text().splitlines()) == 3
    writer.close()


from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), robot_name=st.sampled_from(["xl430_biped", "op3_legs"]),
       readings=st.lists(st.floats(-1e9, 1e9, allow_nan=False), min_size=16, max_size=16),
       weight_scale=st.floats(0.01, 1e3))
def test_no_goal_outside_the_limits_whatever_the_network_or_readings(seed, robot_name, readings, weight_scale):
    from sim2real.controller.file import Controller
    from sim2real.controller.schema import MAX_WEIGHT
    from sim2real.controller.policy import Policy

    robot = load_robot(robot_name)
    data = random_controller(robot, connections=60, hidden=8, seed=seed).to_dict()
    for conn in data["connections"]:
        conn[2] = float(np.clip(conn[2] * weight_scale, -MAX_WEIGHT, MAX_WEIGHT))  # the format's bound
    policy = Policy(Controller.from_dict(data), robot)
    mapping = ServoMapping(robot)
    values = np.array(readings)
    n = len(robot.joints)
    angles, feet, up = values[:n], values[12:14] > 0, values[13:16]
    goal = policy.reset()
    for _ in range(3):
        goal = policy.step(angles, feet, up, goal)
        ticks = mapping.ticks(goal)
        assert np.all(ticks >= mapping.tick_low) and np.all(ticks <= mapping.tick_high)


def test_the_deploy_path_imports_without_mujoco():
    import subprocess
    import sys

    code = ("import sys; import sim2real.hardware.deploy, sim2real.hardware.dynamixel.sdk_bus, sim2real.controller.policy, sim2real.controller.file, "
            "sim2real.cli.deploy_commands, sim2real.simulation.simbus.service; "
            "print('mujoco' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


def test_biped_run_works_where_mujoco_cannot_be_imported(tmp_path):
    """The robot computer's lean install (no `sim` extra): `biped run` on the mock bus runs,
    and a command that needs MuJoCo says so in one line."""
    import json
    import subprocess
    import sys

    blocker = tmp_path / "blocked"
    blocker.mkdir()
    (blocker / "mujoco.py").write_text("raise ModuleNotFoundError(\"No module named 'mujoco'\", name='mujoco')\n")
    controller = tmp_path / "c.json"
    random_controller(ROBOT, connections=20, hidden=2, seed=0).save(controller)
    env = {**os.environ, "PYTHONPATH": f"{blocker}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    out = subprocess.run([sys.executable, "-m", "evolve.cli", "run", str(controller), "--bus", "mock", "--duration",
                          "0.3", "--json", "--no-realtime"], capture_output=True, text=True, timeout=120, env=env)
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout.splitlines()[-1])
    assert result["stop_reason"] == "duration reached" and result["torque_off"]["unconfirmed"] == []
    op3 = load_measured("op3")  # a robot from a model file (measured here for its tick): its deploy path needs no MuJoCo
    random_controller(op3, connections=20, hidden=2, seed=0, control_set="legs").save(tmp_path / "op3.json")
    out = subprocess.run([sys.executable, "-m", "evolve.cli", "run", str(tmp_path / "op3.json"), "--bus", "mock",
                          "--duration", "0.3", "--json", "--no-realtime"], capture_output=True, text=True, timeout=120,
                         env=env)
    assert out.returncode == 0, out.stderr
    assert len(json.loads(out.stdout.splitlines()[-1])["torque_off"]["confirmed"]) == 20
    out = subprocess.run([sys.executable, "-m", "evolve.cli", "robot", "mjcf"], capture_output=True, text=True,
                         timeout=120, env=env)
    assert out.returncode == 2 and "needs MuJoCo" in out.stderr and "[sim]" in out.stderr


def _heading_controller():
    """A controller whose only link runs from the heading input to the own hip roll."""
    from evolve.locomotion.evaluator import neat_layout
    from evolve.locomotion.export import controller_from_genome
    from evolve.locomotion.task import TaskConfig
    from evolve.neat import Genome
    from evolve.neat.genome import ConnectionGene
    from sim2real.controller.symmetry import symmetric_layout

    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"], TaskConfig(heading_input=True).inputs)
    genome = Genome(0, neat_layout(layout))
    genome.add_connection(ConnectionGene(0, layout.input_names.index("heading"), layout.n_inputs + layout.n_bias,
                                         3.0, True, genome.active_module))
    return controller_from_genome(genome, ROBOT, layout, TaskConfig(heading_input=True), 1.0, {})


def test_a_heading_controller_reads_the_boards_heading_and_traces_it(tmp_path):
    from sim2real.hardware.trace import Trace

    bus = MockBus(ROBOT)
    bus.devices[ROBOT.sensor_board.id].set_named("heading", 4096)  # 0.5 rad: the start, whatever it is
    report = run(bus, _heading_controller(), duration_s=0.2, trace_path=tmp_path / "run.csv")
    assert report.stop_reason == "duration reached" and all(v == 0 for v in torque(bus).values())
    assert Trace.read(tmp_path / "run.csv")["heading_rad"] == pytest.approx(0.5)


def test_a_heading_controller_is_refused_before_any_servo_moves_on_a_board_without_heading():
    import dataclasses

    from sim2real.errors import UsageError

    board = ROBOT.sensor_board
    table = {k: v for k, v in board.profile.control_table.items() if k != "heading"}
    robot = dataclasses.replace(ROBOT, sensor_board=dataclasses.replace(
        board, profile=dataclasses.replace(board.profile, control_table=table)))
    bus = MockBus(robot)
    with pytest.raises(UsageError, match="reads the torso's heading .* reports none"):
        drive(bus, robot, _heading_controller(), duration_s=0.2, ramp_s=0.05, log=lambda s: None)
    assert not bus.writes and not bus.is_open
