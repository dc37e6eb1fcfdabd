"""The ROBOTIS OP3 as the project ships it (configs/robots/op3.yaml, the project's own MJCF of
ROBOTIS's numbers): what `robot show` says, standing on its soles from home, ROBOTIS's mirror
table found from the geometry, and evolution and the runtime on it."""

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

from evolve.cli import main
from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.export import controller_from_genome
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome
from sim2real.simulation.model.physique import load_measured
from sim2real.simulation.model.builder import build_model
from sim2real.simulation.model.files import add_free_joint, compile_model, load_model_spec
from sim2real.simulation.model.importing.mirror import mirror_pairs
from sim2real.simulation.model.robot_model import RobotModel

OP3 = load_measured("op3")
# ROBOTIS-OP3-Tools config_mirror_joint.yaml: IDs 1:2, 3:4, ... 17:18 (right odd, left even),
# mirrored by 4095 - w: equal model angles are opposite motions
ROBOTIS_MIRROR = [(k, k + 1) for k in range(1, 19, 2)]


def test_robot_show_op3(capsys):
    assert main(["robot", "show", "op3", "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert len(shown["joints"]) == 20 and len({j["servo_id"] for j in shown["joints"]}) == 20
    assert {j["servo_model"] for j in shown["joints"]} == {"XM430-W350"}
    assert shown["sensor_board"]["id"] == 200 and shown["bus"]["baud"] == 2_000_000
    assert shown["mass_kg"] == pytest.approx(3.15, rel=0.01)  # ROBOTIS's URDF: 3.147 kg
    assert shown["height_m"] == pytest.approx(0.51, abs=0.01) and shown["leg_length_m"] == pytest.approx(0.279, abs=0.002)
    assert shown["tick_s"] == pytest.approx(0.036) and "sqrt" in shown["tick_derivation"]["rule"]


def test_op3_stands_five_seconds_from_home_on_its_soles():
    model = build_model(OP3)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    parts = RobotModel.of(model, OP3)
    start = parts.root_com(data.xipos)[2]
    for _ in range(int(round(5.0 / model.opt.timestep))):
        mujoco.mj_step(model, data)
    # what README.md and RESULTS.md quote ("up-vector z 0.9944, 2.6 mm sag, its weight within 0.01 %")
    assert parts.up(data.sensordata)[2] == pytest.approx(0.9944, abs=0.0005)
    assert (start - parts.root_com(data.xipos)[2]) * 1e3 == pytest.approx(2.6, abs=0.1)  # sag [mm]
    weight = OP3.mass * 9.81
    assert data.sensordata[parts.touch].sum() == pytest.approx(weight, rel=1e-4)
    assert parts.feet_touching(data.sensordata).all()


def test_mirror_inference_finds_robotis_mirror_table():
    spec = load_model_spec(OP3.model.path)
    add_free_joint(spec, OP3.model.root)
    inferred = mirror_pairs(compile_model(spec))
    by_id = {j.servo.id: j.name for j in OP3.joints}
    want = {(by_id[left], by_id[right]) for right, left in ROBOTIS_MIRROR}  # even IDs are the left
    assert {(p.left, p.right) for p in inferred.pairs} == want and len(inferred.pairs) == 9
    assert all(p.sign == -1 for p in inferred.pairs)  # ROBOTIS mirrors by 4095 - w
    assert set(inferred.centre) == {"head_pan", "head_tilt"} and not inferred.unpaired and not inferred.conflicts


def test_evolution_and_the_runtime_run_on_op3(tmp_path, capsys):
    task = TaskConfig(control_set="legs", episode_s=0.5, gyro_input=True)
    ev = LocomotionEvaluator(OP3, task, 4, threads=1)
    episodes = ev.evaluate([Genome(i, ev.neat_layout) for i in range(4)], 1.0, harness=1.0)
    assert np.isfinite(episodes.fitness).all() and not episodes.unstable.any()
    path = tmp_path / "op3.json"
    controller_from_genome(Genome(0, ev.neat_layout), OP3, ev.layout, task, 1.0, {"note": "test"}).save(path)
    assert main(["run", str(path), "--bus", "mock", "--duration", "0.2", "--json"]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert len(report["torque_off"]["confirmed"]) == 20 and not report["torque_off"]["unconfirmed"]
    trace = tmp_path / "dry.csv"
    assert main(["dry-run", str(path), "--duration", "1", "--trace", str(trace), "--json",
                 "--lost-after-ms", "2000"]) == 0  # a loaded machine can hold the simulated bus up ~100 ms
    dry = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert dry["ticks"] >= 20 and not dry["torque_off"]["unconfirmed"]
    assert main(["compare", str(trace), "--json"]) == 0
    assert set(json.loads(capsys.readouterr().out.strip().splitlines()[-1])["joints"]) == set(OP3.joint_names)


def test_biped_evolve_runs_on_op3(tmp_path):
    out = tmp_path / "run"
    config = Path(__file__).resolve().parents[1] / "benchmarks" / "records" / "configs" / "walk_op3.yaml"
    assert main(["evolve", str(config), "--out", str(out), "--generations", "1",
                 "--population", "8", "--threads", "1", "--quiet"]) == 0
    controller = json.loads((out / "controller.json").read_text())
    assert controller["robot"]["name"] == "op3" and controller["gyro_input"] is True
    assert controller["inputs"][-3:] == ["gyro_roll", "gyro_pitch", "gyro_yaw"]
