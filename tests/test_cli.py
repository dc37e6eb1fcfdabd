"""The `biped` command line: the commands the acceptance checks call, run as a user would."""

import json
import subprocess
import sys

import mujoco
import pytest

from evolve.cli import main


def run_biped(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "evolve.cli", *args], capture_output=True, text=True,
                          timeout=300)


def test_robot_show_json_has_the_documented_keys(capsys):
    assert main(["robot", "show", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    for key in ("name", "height_m", "mass_kg", "leg_length_m", "tick_s", "bus_cycle_s", "joints"):
        assert key in d
    assert d["name"] == "xl430_biped" and len(d["joints"]) == 11
    for joint in d["joints"]:
        for key in ("name", "servo_id", "servo_model", "range_rad"):
            assert key in joint
        assert joint["range_rad"][0] < joint["range_rad"][1]
    assert d["tick_s"] >= d["bus_cycle_s"]


def test_robot_show_table_explains_the_tick(capsys):
    assert main(["robot", "show", "op3_legs"]) == 0
    out = capsys.readouterr().out
    assert "0.07 s x sqrt(" in out and "bus cycle" in out and "margin" in out
    assert "right_hip_yaw" in out


def test_robot_mjcf_writes_a_loadable_file(tmp_path):
    path = tmp_path / "robot.xml"
    assert main(["robot", "mjcf", "human:female_95", "-o", str(path)]) == 0
    model = mujoco.MjModel.from_xml_path(str(path))
    assert model.key("home").id == 0 and model.nu == 15


def test_render_writes_a_picture_of_the_robot(tmp_path):
    path = tmp_path / "robot.png"
    result = run_biped("render", "-o", str(path), "--width", "320", "--height", "240")
    assert result.returncode == 0, result.stderr
    import imageio.v3 as iio

    image = iio.imread(path)
    assert image.shape == (240, 320, 3)
    assert image.std() > 5  # not a blank frame


def test_bad_robot_config_is_a_clear_error_not_a_traceback(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\ndescription: y\nbody: {}\njoints: []\ncontrol_sets: {}\nwings: 2\n")
    result = run_biped("robot", "show", str(bad))
    assert result.returncode == 2
    assert "bad.yaml: wings: unknown key 'wings'" in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize("command", [[], ["robot"], ["robot", "show"], ["robot", "mjcf"], ["view"], ["render"],
                                     ["plot"], ["plot", "gait"], ["plot", "network"]])
def test_every_command_has_help(command):
    result = run_biped(*command, "--help")
    assert result.returncode == 0 and "usage: biped" in result.stdout


def test_run_without_a_port_uses_the_simulated_bus(tmp_path):
    from evolve.locomotion.evaluator import neat_layout
    from evolve.locomotion.export import controller_from_genome
    from evolve.locomotion.task import TaskConfig
    from evolve.neat import Genome
    from sim2real.controller.symmetry import symmetric_layout
    from sim2real.robot import load_robot

    robot = load_robot()
    layout = symmetric_layout(robot, robot.control_sets["walk"])
    controller_from_genome(Genome(0, neat_layout(layout)), robot, layout, TaskConfig(), 1.0,
                           {"seed": 0}).save(tmp_path / "c.json")
    result = run_biped("run", str(tmp_path / "c.json"), "--duration", "0.5", "--json")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "simulated bus" in result.stderr
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["stop_reason"] == "duration reached" and not report["fell"]
