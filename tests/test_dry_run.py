"""Dry runs on the simulated bus, biped simbus, and comparing traces with the simulation."""

import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import REPLY_ALLOWANCE_US

from evolve.locomotion.evaluator import neat_layout
from evolve.locomotion.export import controller_from_genome
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome
from sim2real.controller.symmetry import symmetric_layout
from sim2real.robot import load_robot
from sim2real.simulation.transfer.compare import compare, lag_s
from sim2real.simulation.transfer.dry_run import dry_run

ROBOT = load_robot()
# A loaded machine can hold the simulated bus up for ~100 ms, the runtime's default loss time:
# these runs are not about a lost bus (a silent servo still stops them, 2 s after it fell silent)
PATIENT = 2.0  # [s] lost_after_s


@pytest.fixture(scope="module")
def standing_controller(tmp_path_factory):
    """No connections: every output 0.5, the ranges' centres - the robot stands."""
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"])
    genome = Genome(0, neat_layout(layout))
    path = tmp_path_factory.mktemp("c") / "stand.json"
    controller_from_genome(genome, ROBOT, layout, TaskConfig(), 1.0, {"seed": 0}).save(path)
    return path


def test_a_short_dry_run_stands_and_ends_with_torque_off(standing_controller, tmp_path):
    result = dry_run(standing_controller, duration_s=1.0, trace_path=tmp_path / "t.csv", log=lambda s: None,
                     ramp_s=0.3, lost_after_s=PATIENT)
    assert result["stop_reason"] == "duration reached"
    assert not result["fell"] and abs(result["distance_m"]) < 0.02 and abs(result["heading_deg"]) < 2.0
    assert result["bus_errors"] == 0 and result["ticks"] == round(1.0 / 0.034)
    # the ground truth is the loop's end: start-up, the 0.3 s ramp and 1 s, not the stop's ramp after
    assert result["simulated_s"] >= 1.3 and result["fell_after_stop"] is False
    assert result["simulated_s_after_stop"] >= result["simulated_s"] + 0.25  # the 0.3 s ramp to rest came after


def test_a_silent_servo_mid_run_ends_in_a_safe_stop_not_a_hang(standing_controller):
    result = dry_run(standing_controller, duration_s=3.0, faults="silent:4@0.5", log=lambda s: None, ramp_s=0.3,
                     lost_after_s=PATIENT)
    assert result["stop_reason"].startswith("lost communication: servo 4")
    assert result["ticks"] < round(3.0 / 0.034)


def test_an_overload_stops_with_the_servo_and_the_error(standing_controller):
    result = dry_run(standing_controller, duration_s=3.0, faults="overload:9@0.3", log=lambda s: None, ramp_s=0.3,
                     lost_after_s=PATIENT)
    assert "servo 9" in result["stop_reason"] and "overload" in result["stop_reason"]


def test_compare_a_dry_run_trace_with_the_simulation(standing_controller, tmp_path):
    trace = tmp_path / "t.csv"
    dry_run(standing_controller, duration_s=1.0, trace_path=trace, log=lambda s: None, ramp_s=0.3, lost_after_s=PATIENT)
    result = compare(trace)
    assert set(result["joints"]) == set(ROBOT.joint_names)
    for stats in result["joints"].values():
        assert stats["rmse_deg"] < 2.0 and (stats["lag_ms"] is None or abs(stats["lag_ms"]) <= 100)
    assert result["contact_agreement"] > 0.9
    out = subprocess.run([sys.executable, "-m", "evolve.cli", "compare", str(trace), "--json", "--plot",
                          str(tmp_path / "c.png")], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert set(json.loads(out.stdout)) >= {"joints", "contact_agreement"}
    assert (tmp_path / "c.png").stat().st_size > 10_000


def test_cross_correlation_finds_a_known_lag():
    t = np.arange(0, 5, 0.01)
    sim = np.sin(2 * np.pi * 0.7 * t)
    real = np.sin(2 * np.pi * 0.7 * (t - 0.08))  # real trails by 80 ms
    assert lag_s(real, sim, 0.01) == pytest.approx(0.08, abs=0.011)


def test_simbus_prints_its_port_first_and_answers_the_sdk():
    from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus

    proc = subprocess.Popen([sys.executable, "-m", "evolve.cli", "simbus"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        port = proc.stdout.readline().strip()
        assert port.startswith("/dev/pts/")
        # the first replies of a process just started can be late on a busy host
        bus = DynamixelBus(port, 1_000_000, ROBOT, return_delay_us=REPLY_ALLOWANCE_US)
        bus.open()
        assert bus.ping(1) == 1060 and bus.ping(200) == 32512
        bus.close()
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    assert proc.returncode == 0


@pytest.mark.parametrize("faults", ["drop:0.02,corrupt:0.01", "corrupt:0.1", "drop:0.1"])
def test_a_noisy_bus_does_not_stop_the_robot(standing_controller, faults):
    """Lost and corrupt replies are retried within the tick; a tick without a good read holds
    the last goals; only 100 ms without one good read would stop the run."""
    result = dry_run(standing_controller, duration_s=1.5, faults=faults, log=lambda s: None, ramp_s=0.3,
                     lost_after_s=PATIENT)
    assert result["stop_reason"] == "duration reached"
    assert not result["fell"] and result["retries"] > 0
    assert result["torque_off"]["unconfirmed"] == []
    if "corrupt:0.1" in faults:
        assert result["corrupt_replies"] > 0


def test_the_simulated_bus_takes_a_reality_profile():
    from sim2real.simulation.reality.file import load_reality
    from sim2real.simulation.simbus.physics import PhysicsChain

    nominal, real = PhysicsChain(ROBOT), PhysicsChain(ROBOT, reality=load_reality("default"))
    assert real.model.body_mass[1:] == pytest.approx(nominal.model.body_mass[1:] * 1.08)
    assert real.kp == pytest.approx(nominal.kp * 0.9)
    assert real.model.actuator_delay == pytest.approx(0.5 * 0.034)
    assert real.perturbation.backlash_rad[0] == pytest.approx(np.radians(0.3))
    play = real.model.jnt_range[real.angles.play_joint]  # backlash joints, opened to the profile's width
    assert np.degrees(play[:, 1] - play[:, 0]) == pytest.approx(0.3) and not nominal.angles.has_play
    assert real.kv == pytest.approx(real.kp * 0.0125)  # the D term at derivative_ms 12.5
    now = [0.0]
    limp = PhysicsChain(ROBOT, clock=lambda: now[0], reality=load_reality("default"))
    now[0] = 0.01
    limp.advance()  # torque off (its power-on default): no force, the D term's included
    assert limp.model.actuator_gainprm[:, 0] == pytest.approx(0.0) and limp.model.actuator_biasprm[:, 2] == pytest.approx(0.0)
    assert limp.data.actuator_force == pytest.approx(0.0)


def test_faults_are_timed_from_the_first_torque_on_not_from_the_bus_start():
    """A runtime slow to open the port and check the bus (a loaded CI machine took over 0.6 s)
    must still meet the servos healthy: the fault clock starts when the run does."""
    from sim2real.hardware.dynamixel.registers import Reg
    from sim2real.simulation.simbus.physics import PhysicsChain

    now = [0.0]
    physics = PhysicsChain(ROBOT, clock=lambda: now[0])
    physics.overload_at[9], physics.silent_at[4] = 0.3, 0.5
    silenced = []
    physics.on_silent = silenced.append
    now[0] = 2.0
    physics.advance(max_s=10.0)  # two seconds of start-up checks, torque still off
    assert physics.devices[9].get_named(Reg.HARDWARE_ERROR_STATUS) == 0 and silenced == []
    for device in physics.devices.values():
        if Reg.TORQUE_ENABLE in device.profile.control_table:
            device.set_named(Reg.TORQUE_ENABLE, 1)
    now[0] = 2.2
    physics.advance(max_s=10.0)
    assert physics.devices[9].get_named(Reg.HARDWARE_ERROR_STATUS) == 0 and silenced == []
    now[0] = 2.4
    physics.advance(max_s=10.0)
    assert physics.devices[9].get_named(Reg.HARDWARE_ERROR_STATUS) != 0 and silenced == []
    now[0] = 2.6
    physics.advance(max_s=10.0)
    assert silenced == [4]


def test_a_dry_run_under_the_default_reality_profile(standing_controller):
    result = dry_run(standing_controller, duration_s=1.0, log=lambda s: None, ramp_s=0.3, reality="default",
                     lost_after_s=PATIENT)
    assert result["reality"] == "default" and result["stop_reason"] == "duration reached"
    assert not result["fell"] and result["bus_errors"] == 0


def test_current_sensing_servos_report_present_current():
    from sim2real.simulation.simbus.physics import PhysicsChain

    robot = load_robot("op3_legs")
    chain = PhysicsChain(robot)
    servo = next(j.servo for j in robot.joints if j.servo.profile.model.startswith("XM430"))
    device = chain.devices[servo.id]
    assert "present_current" in device.profile.control_table and "present_load" not in device.profile.control_table
    chain.data.actuator_force[:] = 1.0  # [N m]: 1.0 / (4.1 N m / 2.3 A) = 0.561 A = 209 LSB of 2.69 mA
    chain._publish()
    k = chain.ids.index(servo.id)
    value = device.get_named("present_current")
    value = value - (1 << 16) if value >= 1 << 15 else value
    assert value == round(chain.mapping.direction[k] * 1.0 * 2.3 / 4.1 * 1000 / 2.69)


def test_faults_from_a_flag_or_a_yaml_file(tmp_path):
    from sim2real.errors import ConfigError
    from sim2real.simulation.simbus.faults import parse_faults

    flag = parse_faults("silent:4@3,overload:7@5.5,drop:0.02")
    path = tmp_path / "faults.yaml"
    path.write_text("silent: [{id: 4, at_s: 3}]\noverload: [{id: 7, at_s: 5.5}]\ndrop: 0.02\n")
    assert parse_faults(str(path)) == flag == [("silent", 4, 3.0), ("overload", 7, 5.5), ("drop", 0, 0.02)]
    path.write_text("drop: 2\n")
    with pytest.raises(ConfigError, match="faults.yaml: drop"):
        parse_faults(str(path))
    with pytest.raises(ConfigError, match="kind must be silent or overload"):
        parse_faults("melt:3@1")


@pytest.mark.parametrize("command, problem", [
    ({"heading": lambda t_s: 0.5}, "no heading input"),
    ({"reach_target": (0.1, 0.0, 0.0)}, "no reach input"),
])
def test_a_command_the_controller_cannot_take_is_refused_before_the_bus_starts(command, problem, monkeypatch):
    from sim2real.errors import UsageError
    from sim2real.simulation.transfer import dry_run as module

    monkeypatch.setattr(module, "SimulatedBusProcess", lambda *a, **k: pytest.fail("the simulated bus was started"))
    with pytest.raises(UsageError, match=problem):
        dry_run("configs/controllers/xl430_biped_no_gyro.json", **command)
