"""`biped robot import` over the class of Dynamixel humanoids as their owners have them
(tests/robots/urdf_humanoid.py): names with no anatomical word or Darwin-OP's, any of four
facings, spines of three and five joints, five-joint legs, grippers and a wrist, a servo mix.
Roles come from the structure and are checked against the generator's ground truth; each
import loads, shows, writes MJCF and is built facing +x.  Also: ROBOTIS's OP3 imports to the
shipped map, --forward overrides, a knee limit against the geometry is named, and a robot
config's joint problems come in one error."""

import copy
import json
import re

import mujoco
import numpy as np
import pytest
import yaml
from conftest import ROOT
from robots.urdf_humanoid import VARIANTS, servo_args, variant_id, write_humanoid

from evolve.cli import main
from sim2real.controller.channels import angle_names
from sim2real.controller.symmetry import symmetric_layout
from sim2real.errors import ConfigError
from sim2real.robot import load_robot, parse_robot
from sim2real.simulation.model.physique import load_measured
from sim2real.simulation.model.importing.importer import import_robot
from sim2real.robot.validation import load_yaml
from sim2real.simulation.model.builder import build_model
from sim2real.simulation.model.robot_model import IMU_SITE


@pytest.mark.parametrize("variant", VARIANTS, ids=variant_id)
def test_each_humanoid_of_the_class_imports_with_its_roles_and_loads(tmp_path, capsys, variant):
    files = write_humanoid(tmp_path, **variant)
    out = tmp_path / "robot.yaml"
    servos = servo_args(variant)
    assert main(["robot", "import", str(files.urdf), *servos, "-o", str(out)]) == 0
    report = capsys.readouterr().out
    assert f"facing {files.forward} (from the geometry)" in report and "AGAINST" not in report
    doc = load_yaml(out)
    assert doc["model"].get("forward", "+x") == files.forward
    assert doc["model"]["feet"] == {side: {"body": body} for side, body in files.feet.items()}
    assert doc["model"]["hands"] == files.hands
    joints = {j["name"]: j for j in doc["joints"]}
    assert set(joints) == set(files.expected), set(joints) ^ set(files.expected)  # fingers held
    for name, role in files.expected.items():
        j = joints[name]
        assert (j["side"], j["location"], j["axis"], j["sign"], j.get("index", 0)) == \
            (role.side, role.location, role.axis, role.sign, role.index), name
    for left, right, sign in files.pairs:
        assert joints[left]["sign"] * joints[right]["sign"] == sign
    for name in files.held:
        assert f"held (not mapped): {name}: " in report
    assert "walk" in doc["control_sets"] and all(joints[n]["location"] in ("hip", "knee")
                                                 for n in doc["control_sets"]["walk"])

    robot = load_measured(out)
    if variant.get("mixed_servos"):
        assert {j.name: j.servo.profile.model for j in robot.joints} == files.servos
    assert main(["robot", "show", str(out), "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert shown["model"]["forward"] == files.forward and len(shown["joints"]) == len(files.expected)
    assert main(["robot", "mjcf", str(out), "-o", str(tmp_path / "robot.xml")]) == 0
    assert "<mujoco" in (tmp_path / "robot.xml").read_text()

    # built facing +x whatever the file's facing: the IMU's x forward, the left foot at +y
    model = build_model(robot)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    imu = data.site_xmat[model.site(IMU_SITE).id].reshape(3, 3)
    assert imu[:, 0] @ [1.0, 0.0, 0.0] > 0.999 and imu[:, 2] @ [0.0, 0.0, 1.0] > 0.999
    feet = {side: data.xpos[model.body(body["body"]).id] for side, body in doc["model"]["feet"].items()}
    assert feet["left"][1] - feet["right"][1] > 0.05


def test_the_op3_imports_to_the_shipped_map(tmp_path, capsys):
    out = tmp_path / "op3.yaml"
    assert main(["robot", "import", str(ROOT / "configs" / "robots" / "op3" / "op3.xml"), "--servo", "XM430-W350",
                 "-o", str(out)]) == 0
    assert "facing +x (from the geometry)" in capsys.readouterr().out
    shipped = {j.name: j for j in load_robot("op3").joints}
    imported = {j.name: j for j in load_robot(out).joints}
    assert set(imported) == set(shipped)
    for name, j in shipped.items():
        assert (imported[name].side, imported[name].location, imported[name].axis, imported[name].sign,
                imported[name].index) == (j.side, j.location, j.axis, j.sign, j.index), name
    assert load_yaml(out)["model"]["feet"] == {"left": {"body": "l_ank_roll_link"}, "right": {"body": "r_ank_roll_link"}}


def test_forward_overrides_the_geometry_and_the_cues_against_it_are_named(tmp_path, capsys):
    files = write_humanoid(tmp_path, names="numbered", forward="+y")
    assert main(["robot", "import", str(files.urdf), "--forward=-y", "-o", str(tmp_path / "a.yaml")]) == 0
    report = capsys.readouterr().out
    assert "facing -y (as --forward says)" in report
    assert re.search(r"foot b\d+: AGAINST", report) and re.search(r"knee limits j\d+: AGAINST", report)
    doc = load_yaml(tmp_path / "a.yaml")
    assert doc["model"]["forward"] == "-y"
    right_foot = doc["model"]["feet"]["right"]["body"]
    assert right_foot == files.feet["left"]  # facing the other way, left and right swap


def test_a_knee_limit_against_the_geometry_is_named_as_such(tmp_path, capsys):
    files = write_humanoid(tmp_path)
    text = files.urdf.read_text()
    flipped = re.sub(r'(<joint name="l_knee_joint".*?<limit lower=")([^"]+)(" upper=")([^"]+)"',
                     lambda m: f'{m[1]}{-float(m[4]):.6g}{m[3]}{-float(m[2]):.6g}"', text, flags=re.S)
    assert flipped != text
    files.urdf.write_text(flipped)  # the left knee's URDF limits let it bend only forward
    assert main(["robot", "import", str(files.urdf), "-o", str(tmp_path / "k.yaml")]) == 0
    report = capsys.readouterr().out
    assert "facing +x (from the geometry)" in report and "knee limits l_knee_joint: AGAINST" in report
    line = next(line for line in report.splitlines() if line.startswith("LIMIT AGAINST THE GEOMETRY: l_knee_joint"))
    assert "let this left knee bend only forward, against the geometry (facing +x" in line
    assert "fix: range_deg [0, 130]" in line and "face -x" not in report
    assert "LIMIT AGAINST THE GEOMETRY" in (tmp_path / "k.yaml").read_text()
    assert "from foot r_foot_link, knee limits r_knee_joint, foot l_foot_link)" in line  # its own cue left out


def test_no_two_legs_is_refused_naming_the_file(tmp_path):
    files = write_humanoid(tmp_path, shift={"l_hip_yaw_joint": (0.0, 0.0, 0.1)})  # the left foot off the floor
    with pytest.raises(ConfigError, match="no two legs found: only one branch of the body tree reaches the floor, "
                       "down to r_foot_link") as err:
        import_robot(files.urdf, tmp_path / "x.yaml")
    assert str(files.urdf) in str(err.value)


# -- several joints of one role; every problem of a robot config at once --------------------------
@pytest.fixture(scope="module")
def poppy_like(tmp_path_factory):
    """A 5-joint spine (two waist pitches, two rolls) on a robot facing +y: its robot YAML."""
    folder = tmp_path_factory.mktemp("poppy")
    files = write_humanoid(folder, names="numbered", forward="+y", spine=5, leg=5)
    result = import_robot(files.urdf, folder / "poppy.yaml", servo="XM430-W350")
    from sim2real.simulation.model.importing.robot_yaml import write_robot_yaml

    write_robot_yaml(result)
    return folder / "poppy.yaml"


def test_a_spine_of_five_drives_with_both_waist_pitches(poppy_like):
    from evolve.locomotion.evaluator import LocomotionEvaluator
    from evolve.locomotion.task import TaskConfig
    from evolve.neat import Genome

    robot = load_measured(poppy_like)
    waist = [j for j in robot.joints if j.location == "waist"]
    assert sorted((j.axis, j.index) for j in waist) == [("pitch", 0), ("pitch", 1), ("roll", 0), ("roll", 1),
                                                       ("yaw", 0)]
    layout = symmetric_layout(robot, robot.control_sets["legs"])
    assert set(layout.input_names) >= {j.name for j in waist}  # the centre joints by name
    assert list(layout.center_mirror) == [-1.0 if j.axis in ("yaw", "roll") else 1.0 for j in waist]
    ev = LocomotionEvaluator(robot, TaskConfig(control_set="legs", episode_s=0.3), 2, threads=1)
    episodes = ev.evaluate([Genome(i, ev.neat_layout) for i in range(2)], 1.0, harness=1.0)
    assert np.isfinite(episodes.fitness).all() and not episodes.unstable.any()


def test_sided_joints_of_one_role_are_indexed_in_symmetry_and_inputs(poppy_like):
    doc = yaml.safe_load(poppy_like.read_text())
    for j in doc["joints"]:  # the ankle pitches taken as second hip pitches: two sided joints of one role
        if j["location"] == "ankle":
            j.update(location="hip", index=1)
    robot = parse_robot(doc, str(poppy_like))
    hips = [j for j in robot.joints if j.side == "right" and j.location == "hip" and j.axis == "pitch"]
    assert sorted(j.index for j in hips) == [0, 1]
    layout = symmetric_layout(robot, tuple(j.name for j in robot.joints if j.side != "center"))
    assert "own_hip_pitch" in layout.input_names and "own_hip_pitch_2" in layout.input_names
    assert "other_hip_pitch_2" in layout.input_names
    assert angle_names([("knee", "pitch", 0), ("hip", "pitch", 1)], ["w"]) == \
        ["own_knee", "own_hip_pitch_2", "other_knee", "other_hip_pitch_2", "w"]


def test_an_index_is_a_model_robots_and_counts_from_zero(poppy_like):
    doc = yaml.safe_load(poppy_like.read_text())
    second = next(j for j in doc["joints"] if j.get("index") == 1)
    second.pop("index")
    with pytest.raises(ConfigError, match=r"repeats the center waist \w+ axis of .* \(fix: index: 1"):
        parse_robot(copy.deepcopy(doc), str(poppy_like))
    second["index"] = 2
    with pytest.raises(ConfigError, match="has index 2 but no center waist .* has index 1"):
        parse_robot(doc, str(poppy_like))
    box = yaml.safe_load((ROOT / "configs" / "robots" / "xl430_biped.yaml").read_text())
    box["joints"][0]["index"] = 0
    with pytest.raises(ConfigError, match="only for a robot with a model"):
        parse_robot(box, "box.yaml")


def test_every_joint_problem_comes_at_once_with_its_fix(poppy_like):
    doc = yaml.safe_load(poppy_like.read_text())
    joints = {j["name"]: j for j in doc["joints"]}
    knees = [n for n, j in joints.items() if j["location"] == "knee"]
    rolls = [n for n, j in joints.items() if j["location"] == "hip" and j["axis"] == "roll"]
    joints[knees[0]]["range_deg"] = [0, 200]  # beyond the XM430's reach
    joints[knees[1]]["servo"]["zero_offset_deg"] = 100 * joints[knees[1]]["servo"]["direction"]  # pushed past it
    joints[rolls[0]]["home_deg"] = 80  # outside its range
    neck = next(n for n, j in joints.items() if j["location"] == "neck" and j["axis"] == "pitch")
    joints[neck]["axis"] = "yaw"  # two neck yaws
    doc["joints"] = [j for j in doc["joints"] if j["name"] != rolls[1]] + [joints[rolls[1]]]
    doc["joints"][-1]["servo"]["id"] = doc["joints"][0]["servo"]["id"]  # a repeated ID
    with pytest.raises(ConfigError) as err:
        parse_robot(doc, str(poppy_like))
    message = str(err.value)
    assert err.value.key == "joints" and message.startswith(f"{poppy_like}: joints: 5 problems, each with its fix:")
    lines = message.splitlines()[1:]
    assert len(lines) == 5 and all("fix:" in line for line in lines), message
    assert any("joint range [0.0, 200.0] deg needs servo angles" in line and "(fix: range_deg [0, 1" in line
               for line in lines)
    assert sum("outside the XM430-W350's" in line for line in lines) == 2
    assert any(".home_deg: 80" in line for line in lines) and any("repeats the center neck yaw" in line
                                                                  for line in lines)
    assert any("duplicate ID" in line for line in lines)


def _without_facing_cues(files) -> None:
    """Feet centred under the ankles and knees without limits: no geometric cue to the facing."""
    text = re.sub(r'(<origin xyz=")0\.01 (-?0\.005 -0\.03")', r"\g<1>0 \2", files.urdf.read_text())
    text = re.sub(r'(<joint name="[^"]*(?:knee|tibia|j\d+)[^"]*" type=")revolute(".*?)<limit lower="[^"]*" '
                  r'upper="[^"]*"', lambda m: m[1] + "continuous" + m[2] + "<limit", text, flags=re.S)
    files.urdf.write_text(text)


@pytest.mark.parametrize("names, decided", [("darwin", "the geometry ties; the names' l_/r_ decide"),
                                            ("numbered", "NO CUE decided: taken as drawn; give --forward")])
def test_the_names_break_a_tie_of_the_geometry(tmp_path, names, decided):
    files = write_humanoid(tmp_path, names=names, forward="-x")
    _without_facing_cues(files)
    result = import_robot(files.urdf, tmp_path / "t.yaml")
    assert not result.facing.cues and f"({decided})" in result.facing.report()[0]
    # the names say the robot faces -x; with no names it is taken as drawn, +x (and the legs swap)
    assert result.forward == ("-x" if names == "darwin" else "+x")
    left_leg = {j.name for j in result.joints if j.side == "left" and j.location == "hip"}
    assert (left_leg == {n for n, r in files.expected.items() if r.side == "left" and r.location == "hip"}) == \
        (names == "darwin")


def test_a_joint_without_its_twin_is_held(tmp_path, capsys):
    files = write_humanoid(tmp_path)
    files.urdf.write_text(files.urdf.read_text().replace('<joint name="l_ankle_roll_joint" type="revolute">',
                                                         '<joint name="l_ankle_roll_joint" type="fixed">'))
    assert main(["robot", "import", str(files.urdf), "-o", str(tmp_path / "t.yaml")]) == 0
    report = capsys.readouterr().out
    assert "held (not mapped): r_ankle_roll_joint: " in report
    assert "no left twin of this right ankle roll" in (tmp_path / "t.yaml").read_text()
    robot = load_measured(tmp_path / "t.yaml")  # loads: the right ankle roll is welded
    assert "r_ankle_roll_joint" not in robot.joint_names and len(robot.joints) == 18
    # welded, the right foot fuses into the ankle as a URDF compiles: the foot is the ankle link, and it builds
    assert "the right foot r_foot_link has no mapped joint left, so the model's compile fuses it into " \
           "r_ankle_link" in report
    assert load_yaml(tmp_path / "t.yaml")["model"]["feet"]["right"] == {"body": "r_ankle_link"}
    assert "as the YAML holds it: stands" in report and build_model(robot).nu == 18
