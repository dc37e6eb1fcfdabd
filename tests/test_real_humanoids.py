"""`biped robot import` on two real Dynamixel humanoids as their owners wrote them, re-created
by tests/robots/real_humanoids.py (names, frames, axes, limits, masses; boxes for meshes):
Darwin-OP (HumaRobotics' URDF with an owner's foot sensor pads; ankle frames with z forward)
and Poppy Humanoid (faces -y, five-joint spine, T-pose arms, a left knee whose limits are
against its geometry).  Each imports with its legs, feet and facing right and stands from the
home it proposes.  Also: a package folder and an output given relative to the working
directory (as a user types them) still let the stand check load the meshes."""

import math

import mujoco
import numpy as np
from robots.real_humanoids import write_real
from robots.urdf_humanoid import write_humanoid

from evolve.cli import main
from sim2real.simulation.model.physique import load_measured
from sim2real.robot.validation import load_yaml
from sim2real.simulation.model.builder import build_model
from sim2real.simulation.model.robot_model import sole_site

# Darwin-OP's walker (HumaRobotics darwin_gazebo scripts/walker.py, WFunc with its defaults):
# the ready pose, model angles [rad] of the left leg; the right mirrors them with opposite signs
DARWIN_READY = {"j_thigh2_l": 0.55, "j_tibia_l": -1.1, "j_ankle1_l": -0.55}
DARWIN_LEG = {"j_pelvis": ("hip", "yaw"), "j_thigh1": ("hip", "roll"), "j_thigh2": ("hip", "pitch"),
              "j_tibia": ("knee", "pitch"), "j_ankle1": ("ankle", "pitch"), "j_ankle2": ("ankle", "roll")}


def _import(tmp_path, capsys, robot: str, *servos: str) -> tuple[str, dict]:
    urdf = write_real(tmp_path, robot)
    out = tmp_path / f"{robot}.yaml"
    assert main(["robot", "import", str(urdf), *servos, "-o", str(out)]) == 0
    return capsys.readouterr().out, load_yaml(out)


def test_darwin_op_imports_its_legs_from_the_structure_and_stands_from_the_home_it_proposes(tmp_path, capsys):
    report, doc = _import(tmp_path, capsys, "darwin", "--servo", "MX-28")
    # the foot is all the ankle roll carries (its sole and four sensor pads): centred on the
    # ankle, it gives no vote; the names' _l/_r decide (a pad alone voted for its own end)
    assert "facing +x (the geometry ties; the names' l_/r_ decide)" in report
    joints = {j["name"]: j for j in doc["joints"]}
    for base, (location, axis) in DARWIN_LEG.items():
        for p, side in (("l", "left"), ("r", "right")):
            j = joints[f"{base}_{p}"]
            assert (j["side"], j["location"], j["axis"]) == (side, location, axis), j["name"]
    # the owner's walker's ready pose is a crouch by these signs: knee flexed, hip and ankle
    # pitched half as much, all positive (anatomical angle = sign * model angle)
    ready = {n: joints[n]["sign"] * a for n, a in DARWIN_READY.items()}
    assert ready["j_tibia_l"] > 1.0 and abs(ready["j_thigh2_l"] - ready["j_tibia_l"] / 2) < 1e-9
    assert abs(ready["j_ankle1_l"] - ready["j_tibia_l"] / 2) < 1e-9
    for n in DARWIN_READY:
        twin = n[:-1] + "r"
        assert joints[twin]["sign"] == -joints[n]["sign"]  # the walker mirrors with opposite model angles
    assert doc["model"]["feet"] == {"left": {"body": "MP_ANKLE2_L"}, "right": {"body": "MP_ANKLE2_R"}}
    for pad in ("left_foot_sensor_m0_j", "right_foot_sensor_m3_j", "j_gripper_l"):
        assert f"held (not mapped): {pad}: " in report
    assert "a home is proposed and written" in report
    assert "stand check with the proposed home, as the YAML holds it: stands" in report

    # the sole site lies under the ankle, across the foot's whole length (not at its heel:
    # the ankle link's frame has z forward, x vertical)
    robot = load_measured(tmp_path / "darwin.yaml")
    model = build_model(robot)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    for side, ankle in (("left", "j_ankle2_l"), ("right", "j_ankle2_r")):
        site = model.site(sole_site(side)).id
        ahead = float(data.site_xpos[site][0] - data.xanchor[model.joint(ankle).id][0])
        assert abs(ahead) < 0.015, (side, ahead)
        reach = np.abs(data.site_xmat[site].reshape(3, 3)) @ model.site_size[site]  # world half-extents
        assert reach[0] > 0.045 and reach[2] < 0.01, (side, reach)


def test_poppy_faces_minus_y_its_knee_limit_is_turned_and_it_stands(tmp_path, capsys):
    report, doc = _import(tmp_path, capsys, "poppy", "--servo", "MX-28", "--servo", "neck=AX-12A")
    assert "facing -y (from the geometry)" in report
    assert doc["model"]["forward"] == "-y"
    joints = {j["name"]: j for j in doc["joints"]}
    spine = [(joints[n]["location"], joints[n]["axis"], joints[n].get("index", 0))
             for n in ("abs_y", "abs_x", "abs_z", "bust_y", "bust_x")]
    assert spine == [("waist", "pitch", 0), ("waist", "roll", 0), ("waist", "yaw", 0), ("waist", "pitch", 1),
                     ("waist", "roll", 1)]
    assert {joints[n]["servo"].get("model") for n in ("head_z", "head_y")} == {"AX-12A"}
    # the left knee's limits turn it only forward: named, and written turned to its flexion side
    line = next(x for x in report.splitlines() if x.startswith("LIMIT AGAINST THE GEOMETRY: l_knee_y"))
    assert "fix: range_deg [0, 134], the flexion side, as its twin's; the YAML has it" in line
    assert joints["l_knee_y"]["range_deg"][0] >= 0.0 and joints["l_knee_y"]["home_deg"] > 10.0
    # held out sideways, the elbows fold the way their one-sided limits let them: no contradiction
    assert "LIMIT AGAINST THE GEOMETRY: l_elbow_y" not in report and "r_elbow_y: its limits" not in report
    for name in ("l_elbow_y", "r_elbow_y"):
        lo, hi = joints[name]["range_deg"]
        assert hi > 140.0 and lo > -2.0, name
    assert "a home is proposed and written" in report
    assert "stand check with the proposed home, as the YAML holds it: stands" in report
    knees = [joints[n]["home_deg"] for n in ("l_knee_y", "r_knee_y")]
    assert knees[0] == knees[1] and math.isclose(knees[0], 30.0)


def test_a_relative_package_folder_and_output_still_load_the_meshes(tmp_path, capsys, monkeypatch):
    files = write_humanoid(tmp_path, package=True)  # thighs of mesh, by package:// paths
    monkeypatch.chdir(tmp_path)
    urdf = files.urdf.relative_to(tmp_path)
    assert main(["robot", "import", str(urdf), "--package-dir", ".", "--servo", "XM430-W350",
                 "-o", "robot.yaml"]) == 0
    report = capsys.readouterr().out
    assert "stand check (5 s from home" in report and "STAND CHECK NOT RUN" not in (tmp_path / "robot.yaml").read_text()
    assert main(["robot", "stand", "robot.yaml"]) == 0
