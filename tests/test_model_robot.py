"""Robots from a user's URDF or MJCF: a generated humanoid with arms and a gripper goes through
`biped robot import` -> `robot show` -> stands on its soles; mapped joints are anatomical
(a sign of -1 turns the model's axis over); unmapped joints are held; bad maps are refused by
name; evolution and the runtime run on it."""

import json
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml
from robots.urdf_humanoid import write_humanoid

from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome
from evolve.cli import main
from sim2real.errors import ConfigError
from sim2real.simulation.model.physique import load_measured
from sim2real.simulation.model.builder import build_model
from sim2real.simulation.model.robot_model import RobotModel

GRAVITY = 9.81


@pytest.fixture(scope="module")
def imported(tmp_path_factory) -> Path:
    """The generated humanoid, imported by the CLI as a user would: its robot YAML."""
    folder = tmp_path_factory.mktemp("humanoid")
    files = write_humanoid(folder)
    out = folder / "humanoid.yaml"
    assert main(["robot", "import", str(files.urdf), "--servo", "XM430-W350", "-o", str(out)]) == 0
    return out


def _stand(robot, seconds: float = 5.0):
    model = build_model(robot)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    parts = RobotModel.of(model, robot)
    start = parts.root_com(data.xipos).copy()
    for _ in range(int(round(seconds / model.opt.timestep))):
        mujoco.mj_step(model, data)
    return model, data, parts, start


def test_an_imported_urdf_robot_shows_and_stands_on_its_soles(imported, capsys):
    robot = load_measured(imported)
    assert len(robot.joints) == 20 and {j.location for j in robot.joints} >= {"shoulder", "elbow", "neck", "knee"}
    assert robot.mass == pytest.approx(2.83, rel=1e-6) and robot.leg_length == pytest.approx(0.24, abs=1e-3)
    assert main(["robot", "show", str(imported), "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert shown["model"]["root"] == "base_link" and shown["mass_kg"] == pytest.approx(2.83)
    assert len([j for j in shown["joints"] if j["servo_id"] is not None]) == 20
    model, data, parts, start = _stand(robot)
    assert parts.up(data.sensordata)[2] > 0.99
    assert start[2] - parts.root_com(data.xipos)[2] < 0.01  # sag [m]
    touch = data.sensordata[parts.touch]
    assert touch.sum() == pytest.approx(robot.mass * GRAVITY, rel=0.05) and parts.feet_touching(data.sensordata).all()
    assert not any(model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE for j in range(model.njnt))  # gripper held


def test_a_mapped_joint_is_anatomical_whatever_the_models_axis(imported):
    """Hip pitch flexes the leg forward and the knee bends it back on both sides, though the
    model turns one side's axes the other way (sign -1)."""
    robot = load_measured(imported)
    model = build_model(robot)
    data = mujoco.MjData(model)
    parts = RobotModel.of(model, robot)
    signs = {j.name: j.sign for j in robot.joints}
    assert -1 in signs.values() and 1 in signs.values()
    for side, prefix in (("left", "l"), ("right", "r")):
        sole = parts.soles[0 if side == "left" else 1]
        for joint, forward in ((f"{prefix}_hip_pitch_joint", True), (f"{prefix}_knee_joint", False)):
            mujoco.mj_resetData(model, data)
            mujoco.mj_kinematics(model, data)
            before = data.site_xpos[sole].copy()
            parts.angles.place(data.qpos, np.array([0.4 if j.name == joint else 0.0 for j in robot.joints]))
            mujoco.mj_kinematics(model, data)
            moved = data.site_xpos[sole][0] - before[0]
            assert (moved > 0.01) if forward else (moved < -0.01), (joint, moved)


def _edited(imported: Path, tmp_path: Path, edit) -> Path:
    doc = yaml.safe_load(imported.read_text())
    edit(doc)
    doc["model"]["file"] = str(imported.parent / doc["model"]["file"])
    out = tmp_path / "edited.yaml"
    out.write_text(yaml.safe_dump(doc, sort_keys=False))
    return out


@pytest.mark.parametrize("edit, problem", [
    (lambda d: (d["joints"][0].update(name="no_such_joint"),
                d["control_sets"]["all"].__setitem__(0, "no_such_joint")), "no_such_joint: no such joint in humanoid.urdf"),
    (lambda d: d["model"].update(root="nowhere"), "model.root: no body 'nowhere'"),
    (lambda d: d["model"]["feet"]["left"].update(body="l_nothing"), "model.feet.left.body: no body 'l_nothing'"),
    (lambda d: d["model"]["feet"]["left"].update(geoms=["nope"]), "model.feet.left.geoms: no geom 'nope'"),
    (lambda d: d["model"]["imu"].update(body="imu_nowhere"), "model.imu.body: no body 'imu_nowhere'"),
    (lambda d: d["model"].update(file="missing.urdf"), "model.file: .*missing.urdf.* does not exist"),
    (lambda d: d["joints"][2].update(sign=2), r"joints\[2\].sign: must be 1 or -1, got 2"),
    (lambda d: d.update(body={}), "give the robot's body .* or its model"),
], ids=["joint", "root", "foot", "foot-geom", "imu", "file", "sign", "body-and-model"])
def test_a_bad_map_is_refused_by_name(imported, tmp_path, edit, problem):
    with pytest.raises(ConfigError, match=problem):
        build_model(load_measured(_edited(imported, tmp_path, edit)))


def test_evolution_and_the_runtime_run_on_an_imported_robot(imported, tmp_path):
    robot = load_measured(imported)
    task = TaskConfig(control_set="legs", episode_s=0.5, gyro_input=True)
    ev = LocomotionEvaluator(robot, task, 4, threads=1)
    assert ev.layout.n_leg == 6 and "gyro_yaw" in ev.layout.input_names
    episodes = ev.evaluate([Genome(i, ev.neat_layout) for i in range(4)], 1.0, harness=1.0)
    assert np.isfinite(episodes.fitness).all() and not episodes.unstable.any()
    undriven = [j for j in robot.joints if j.name not in robot.control_sets["legs"]]
    assert all(math.isclose(ev.hold[robot.joint_names.index(j.name)], j.home_rad) for j in undriven)  # arms at home


def test_a_controller_for_an_imported_robot_runs_on_the_mock_bus_the_simulated_bus_and_compares(
        imported, tmp_path, capsys):
    """The deploy path end to end on a robot from a URDF: 20 XM430s and the board."""
    from evolve.locomotion.export import controller_from_genome
    from evolve.neat.genome import ConnectionGene

    robot = load_measured(imported)
    task = TaskConfig(control_set="legs", gyro_input=True)
    ev = LocomotionEvaluator(robot, task, 1, threads=1)
    genome = Genome(0, ev.neat_layout)
    out = ev.layout.n_inputs + ev.layout.n_bias
    genome.add_connection(ConnectionGene(0, ev.layout.input_names.index("gyro_roll"),
                                         out + ev.layout.output_names.index("own_hip_roll"), 2.0, True, 0))
    path = tmp_path / "humanoid.json"
    controller_from_genome(genome, robot, ev.layout, task, 1.0, {"note": "test"}).save(path)
    where = ["--robot", str(imported)]
    assert main(["run", str(path), *where, "--bus", "mock", "--duration", "0.3", "--json"]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert not report["torque_off"]["unconfirmed"] and len(report["torque_off"]["confirmed"]) == 20
    trace = tmp_path / "dry.csv"
    assert main(["dry-run", str(path), *where, "--duration", "1", "--trace", str(trace), "--json",
                 "--lost-after-ms", "2000"]) == 0  # a loaded machine can hold the simulated bus up ~100 ms
    dry = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    # (a network's resting output, 0.5, is the middle of each range: this robot's crouch, where it
    # falls; what matters here is that the loop ran on the simulated bus and stopped safely)
    assert dry["ticks"] >= 25 and dry["fell"] in (True, False) and not dry["torque_off"]["unconfirmed"]
    assert main(["compare", str(trace), *where, "--json"]) == 0
    compared = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert set(compared["joints"]) == set(robot.joint_names)


def test_standing_at_home_the_robot_touches_only_the_floor(imported):
    """Links that touch at the zero pose (CAD overlap at a joint) are excluded: a standing robot
    presses on nothing but the floor, and its soles carry all of it."""
    for robot in (load_measured(imported), load_measured("op3")):
        model, data, parts, _ = _stand(robot, seconds=0.5)
        bodies = {(int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])) for c in data.contact[:data.ncon]}
        assert bodies and all(0 in pair for pair in bodies), robot.name


def test_xacro_left_in_comments_is_not_xacro(tmp_path):
    """An expanded xacro keeps its commented-out properties: that is a plain URDF."""
    from sim2real.simulation.model.files import load_model_spec

    files = write_humanoid(tmp_path)
    text = files.urdf.read_text().replace("<robot ", '<robot xmlns:a="urn:x" ', 1)
    text = text.replace(">", '>\n  <!-- <xacro:property name="pi" value="3.14159"/> -->', 1)
    commented = tmp_path / "commented.urdf"
    commented.write_text(text)
    spec = load_model_spec(commented)
    assert any(j.name == "r_knee_joint" for j in spec.joints)


def test_a_model_robot_hangs_for_system_identification(imported):
    """Hung by its root (``biped excite``'s simulated bus), a URDF robot keeps its base as a
    body, though the base then has no joint (a compile fuses such a body into the world)."""
    for robot in (load_measured(imported), load_measured("op3")):
        model = build_model(robot, suspended=True)
        parts = RobotModel.of(model, robot)
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
        mujoco.mj_forward(model, data)
        assert model.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE
        assert parts.sole_positions(data.site_xpos)[:, 2].min() > 0.1  # feet well off the floor
