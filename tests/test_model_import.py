"""Reading a user's MJCF or URDF robot, and `biped robot import`, on a generated URDF humanoid
(tests/robots/urdf_humanoid.py): mirror pairs and signs from the geometry, the refusals, inertia
checks, and the YAML the command writes."""

import math
import os
import re

import mujoco
import numpy as np
import pytest
from robots.urdf_humanoid import STANDING_BASE_HEIGHT, write_humanoid

from evolve.cli import main
from sim2real.errors import ConfigError
from sim2real.robot.anatomy import ANATOMICAL_AXES, anatomical_axis
from sim2real.simulation.model.importing.joint_names import base_of, location_of, side_of, words
from sim2real.robot.validation import load_yaml
from sim2real.simulation.model.files import add_free_joint, compile_model, load_model_spec, missing_meshes, root_body
from sim2real.simulation.model.inertias import implausible_inertias, recompute_inertias
from sim2real.simulation.model.importing.mirror import mirror_pairs


@pytest.fixture(scope="module")
def humanoid(tmp_path_factory):
    return write_humanoid(tmp_path_factory.mktemp("humanoid"))


def floating(path, package_dirs=()):
    spec = load_model_spec(path, package_dirs)
    add_free_joint(spec)
    return compile_model(spec, str(path))


def refusal(path, package_dirs=()) -> str:
    with pytest.raises(ConfigError) as err:
        load_model_spec(path, package_dirs)
    assert str(path) in str(err.value)
    return str(err.value)


# -- mirror pairs ------------------------------------------------------------------------------
def test_mirror_pairs_of_the_humanoid_are_found_with_their_signs(humanoid):
    mirror = mirror_pairs(floating(humanoid.urdf))
    assert sorted((p.left, p.right, p.sign) for p in mirror.pairs) == sorted(humanoid.pairs)
    assert len(mirror.pairs) == 9
    # the head tilt sits 12 mm left of the plane, but its axis line and its head are centred
    assert set(mirror.centre) == {"head_pan", "head_tilt"}
    assert mirror.unpaired == () and mirror.conflicts == ()
    for name, role in humanoid.expected.items():
        assert mirror.sides[name] == role.side, name


def test_a_pair_whose_names_disagree_with_the_geometry_is_reported(tmp_path):
    files = write_humanoid(tmp_path, rename={"l_knee_joint": "l_shin_joint",
                                             "r_hip_roll_joint": "r_hip_pitch_joint",
                                             "r_hip_pitch_joint": "r_hip_roll_joint"})
    mirror = mirror_pairs(floating(files.urdf))
    assert ("l_shin_joint", "r_knee_joint") in {(p.left, p.right) for p in mirror.pairs}
    text = "\n".join(mirror.conflicts)
    assert "pairs l_shin_joint with r_knee_joint, whose names do not match" in text
    # the swapped hip names: geometry pairs l_hip_roll with the joint now called r_hip_pitch
    assert "pairs l_hip_roll_joint with r_hip_pitch_joint" in text
    assert "the names pair l_hip_roll_joint with r_hip_roll_joint but the geometry does not" in text


def test_a_hinge_without_a_mirror_image_is_reported_unpaired(tmp_path):
    files = write_humanoid(tmp_path, shift={"l_elbow_joint": (0.02, 0.0, 0.0)})
    mirror = mirror_pairs(floating(files.urdf))
    assert set(mirror.unpaired) == {"l_elbow_joint", "r_elbow_joint"}
    assert len(mirror.pairs) == 8
    assert mirror.sides["l_elbow_joint"] == "left" and mirror.sides["r_elbow_joint"] == "right"
    lines = [line for line in mirror.report() if line.startswith("unpaired: l_elbow_joint")]
    assert lines and "no hinge at its mirror image" in lines[0]
    assert any("names pair l_elbow_joint with r_elbow_joint but the geometry does not" in c
               for c in mirror.conflicts)


def test_joint_names_are_read_in_the_usual_styles():
    assert words("LHipYaw") == ["l", "hip", "yaw"] and words("r_hip_yaw_joint")[:3] == ["r", "hip", "yaw"]
    assert [side_of(n) for n in ("l_sho_pitch", "KNEE_R", "leftAnkle", "LHipYaw", "head_pan")] == \
        ["left", "right", "left", "left", None]
    assert [location_of(n) for n in ("l_el", "r_sho_roll", "l_ank_pitch", "RKnee", "head_tilt", "torso_yaw",
                                     "r_kn", "r_gripper_finger1_joint")] == \
        ["elbow", "shoulder", "ankle", "knee", "neck", "waist", "knee", None]
    assert base_of("l_hip_roll_joint") == base_of("r_hip_roll_joint") == "hip_roll_joint"


def test_anatomical_axes_agree_with_the_model_builder_for_the_leg_and_waist():
    from sim2real.simulation.model.builder import joint_axis

    class J:  # the fields joint_axis reads
        def __init__(self, side, location, axis):
            self.side, self.location, self.axis = side, location, axis

    for (location, axis) in ANATOMICAL_AXES:
        if location in ("waist", "hip", "knee", "ankle"):
            for side in (("center",) if location == "waist" else ("left", "right")):
                assert anatomical_axis(side, location, axis) == joint_axis(J(side, location, axis))


# -- loading and refusals ----------------------------------------------------------------------
def test_the_urdf_base_floats_only_with_a_free_joint_added_before_compiling(humanoid):
    spec = load_model_spec(humanoid.urdf)
    assert root_body(spec) == "base_link"
    fixed = compile_model(spec)
    assert fixed.nq == 24  # 20 hinges and 4 finger slides: the base hangs fixed
    assert spec.body("base_link") is not None  # compile_model compiled a copy: nothing fused away here
    add_free_joint(spec)
    model = compile_model(spec)
    assert model.nq == 31 and model.body("base_link").id == 1
    assert math.isclose(model.body_mass.sum(), humanoid.mass)


def test_visuals_are_kept_unless_dropped(humanoid):
    kept = compile_model(load_model_spec(humanoid.urdf))
    dropped = compile_model(load_model_spec(humanoid.urdf, drop_visuals=True))
    visual = lambda m: sum(1 for g in range(m.ngeom) if not (m.geom_contype[g] or m.geom_conaffinity[g]))  # noqa: E731
    assert visual(kept) == kept.ngeom // 2 and visual(dropped) == 0


def test_the_humanoid_stands_on_its_feet(humanoid):
    spec = load_model_spec(humanoid.urdf, drop_visuals=True)
    add_free_joint(spec)
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1, 1, 0.1])
    for joint in spec.joints:
        if joint.type in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            spec.add_actuator(target=joint.name, trntype=mujoco.mjtTrn.mjTRN_JOINT).set_to_position(kp=20.0)
    model = compile_model(spec)
    data = mujoco.MjData(model)
    data.qpos[2] = STANDING_BASE_HEIGHT + 0.001
    for _ in range(int(1.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    assert abs(data.qpos[2] - STANDING_BASE_HEIGHT) < 0.01  # on its soles, not sunk, not fallen
    up = data.xmat[model.body("base_link").id].reshape(3, 3)[:, 2]
    assert up[2] > 0.99


@pytest.mark.parametrize("how", ["suffix", "namespace", "substitution"])
def test_unexpanded_xacro_is_refused_with_how_to_expand_it(tmp_path, humanoid, how):
    text = humanoid.urdf.read_text()
    if how == "suffix":
        path = write_humanoid(tmp_path, xacro=True).urdf
    elif how == "namespace":
        path = tmp_path / "robot.urdf"
        path.write_text(text.replace('<robot name="humanoid">',
                                     '<robot name="humanoid" xmlns:xacro="http://www.ros.org/wiki/xacro">'))
    else:
        path = tmp_path / "robot.urdf"
        path.write_text(text.replace('filename="meshes/thigh.stl"', 'filename="$(find humanoid)/meshes/thigh.stl"'))
    message = refusal(path)
    assert "un-expanded xacro" in message
    assert "`xacro " in message and "pip install xacrodoc" in message
    assert {"suffix": ".xacro", "namespace": "namespace", "substitution": "$(find humanoid)"}[how] in message


def test_every_missing_mesh_is_listed_at_once_with_the_package_dir_hint(tmp_path):
    files = write_humanoid(tmp_path, package=True, missing=("thigh.stl", "head.stl"))
    message = refusal(files.urdf, [files.package_dir])
    assert "2 mesh files are missing" in message
    assert "package://humanoid_description/meshes/thigh.stl (used by bodies r_thigh_link, l_thigh_link)" in message
    assert "package://humanoid_description/meshes/head.stl (used by body head_link)" in message
    assert "--package-dir DIR" in message and "humanoid_description" in message
    # without --package-dir, the package's place in the usual ROS layout is suggested
    complete = write_humanoid(tmp_path / "ok", package=True)
    message = refusal(complete.urdf)
    assert f"try --package-dir {complete.package_dir}" in message
    spec = load_model_spec(complete.urdf, [complete.package_dir])
    assert all(mesh.file.startswith(str(complete.package_dir)) for mesh in spec.meshes)


def test_a_missing_visual_mesh_does_not_stop_a_load_without_visuals(tmp_path):
    files = write_humanoid(tmp_path, missing=("head.stl",))
    assert "1 mesh file is missing" in refusal(files.urdf)
    load_model_spec(files.urdf, drop_visuals=True)
    assert missing_meshes(files.urdf)[0].startswith("meshes/head.stl (used by body head_link)")


@pytest.mark.parametrize("text, problem", [
    ("name: robot\njoints: []\n", "not an XML model file"),
    ('<sdf version="1.7"><model name="x"/></sdf>', "not a robot model: the root element is <sdf>"),
    ("<html><body/></html>", "not a robot model: the root element is <html>"),
    ('<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaa">]><robot name="x"/>', "entity"),
    ('<robot name="x"><link name="a"/><link name="b"/><joint name="j" type="fixed"><parent link="a"/>'
     '<child link="b"/></joint></robot>', "no hinge (revolute) joint"),
    ('<mujoco><worldbody><body><freejoint/><geom size=".1"/><body><joint type="slide"/><geom size=".1"/>'
     "</body></body></worldbody></mujoco>", "no hinge (revolute) joint"),
])
def test_what_is_no_robot_is_refused_with_the_file_named(tmp_path, text, problem):
    path = tmp_path / "robot.xml"
    path.write_text(text)
    assert problem in refusal(path)


# -- inertias ------------------------------------------------------------------------------------
def test_implausible_inertias_are_flagged_and_recomputing_fixes_them(tmp_path, humanoid):
    assert implausible_inertias(load_model_spec(humanoid.urdf)) == []
    files = write_humanoid(tmp_path, inertia_scale={"r_thigh_link": 50.0, "head_link": 0.05},
                           unbalanced=("l_shin_link",))
    spec = load_model_spec(files.urdf)
    problems = {p.body: p for p in implausible_inertias(spec)}
    assert set(problems) == {"r_thigh_link", "head_link", "l_shin_link"}
    assert re.search(r"are [56]\dx those of its collision geometry", problems["r_thigh_link"].problem)
    assert "are 1/20 those" in problems["head_link"].problem
    assert "A + B < C" in problems["l_shin_link"].problem
    with pytest.raises(ConfigError, match="A \\+ B >= C"):
        compile_model(spec)  # MuJoCo refuses the unbalanced one as given
    masses = {b.name: b.mass for b in spec.bodies}
    recompute_inertias(spec)
    assert implausible_inertias(spec) == []
    assert {b.name: b.mass for b in spec.bodies} == masses
    model = compile_model(spec)
    good = compile_model(load_model_spec(humanoid.urdf))
    thigh = model.body("r_thigh_link").id
    assert np.allclose(np.sort(model.body_inertia[thigh]), np.sort(good.body_inertia[thigh]), rtol=0.5)


# -- biped robot import --------------------------------------------------------------------------
def test_robot_import_writes_the_yaml_of_the_humanoid(tmp_path, capsys):
    files = write_humanoid(tmp_path, package=True, inertia_scale={"r_thigh_link": 50.0})
    out = tmp_path / "robots" / "kit.yaml"
    out.parent.mkdir()
    assert main(["robot", "import", str(files.urdf), "--package-dir", str(files.package_dir),
                 "--servo", "xm430-w350", "-o", str(out)]) == 0
    report = capsys.readouterr().out
    doc = load_yaml(out)
    assert doc["name"] == "kit" and doc["actuation"] == "servo" and doc["servo_model"] == "XM430-W350"
    model = doc["model"]
    assert (out.parent / model["file"]).resolve() == files.urdf.resolve()
    assert [(out.parent / d).resolve() for d in model["package_dirs"]] == [files.package_dir.resolve()]
    assert model["root"] == "base_link" and model["imu"] == {"body": "base_link", "pos": [0.0, 0.0, 0.0]}
    assert model["feet"] == {"left": {"body": "l_foot_link"}, "right": {"body": "r_foot_link"}}
    assert model["hands"] == {"left": "l_forearm_link", "right": "r_forearm_link"}
    assert model["inertias"] == "as_given"
    joints = {j["name"]: j for j in doc["joints"]}
    assert set(joints) == set(files.expected)  # every hinge; the gripper's slides left out
    for name, role in files.expected.items():
        j = joints[name]
        assert (j["side"], j["location"], j["axis"], j["sign"]) == \
            (role.side, role.location, role.axis, role.sign), name
    for left, right, sign in files.pairs:
        assert joints[left]["sign"] * joints[right]["sign"] == sign
    assert [j["servo"]["id"] for j in doc["joints"]] == list(range(1, 21))
    # the URDF's knee range [0, 130] deg, centred on the stance the stand check proposed (knees at 30 deg)
    assert joints["r_knee_joint"]["range_deg"] == [0, 60] == joints["l_knee_joint"]["range_deg"]
    assert joints["r_knee_joint"]["home_deg"] == 30 == joints["l_knee_joint"]["home_deg"]
    assert joints["head_pan"]["range_deg"] == [-90, 90]  # continuous in the URDF
    assert len(doc["control_sets"]["legs"]) == 12 and len(doc["control_sets"]["all"]) == 20
    text = out.read_text()
    assert "the model's [0, 130] centred on it" in text
    assert "guessed: check" in text and "unlimited in the model" in text
    assert "r_gripper_finger1_joint: a slide (prismatic) joint" in text
    assert "9 mirror pairs" in report and "l_knee_joint <-> r_knee_joint: opposed (-1)" in report
    assert "held (not mapped): l_gripper_finger2_joint" in report
    assert "implausible inertia: body r_thigh_link" in report


def test_robot_import_computes_inertias_from_geometry_when_they_cannot_compile(tmp_path, capsys):
    files = write_humanoid(tmp_path, unbalanced=("l_shin_link",))
    assert main(["robot", "import", str(files.urdf), "-o", str(tmp_path / "a.yaml")]) == 0
    assert load_yaml(tmp_path / "a.yaml")["model"]["inertias"] == "from_geometry"
    assert "A + B < C" in capsys.readouterr().out
    good = write_humanoid(tmp_path / "good")
    assert main(["robot", "import", str(good.urdf), "--recompute-inertias", "-o", str(tmp_path / "b.yaml")]) == 0
    assert load_yaml(tmp_path / "b.yaml")["model"]["inertias"] == "from_geometry"


def test_robot_import_refuses_with_one_clear_line_and_exit_2(tmp_path, capsys):
    files = write_humanoid(tmp_path, xacro=True)
    out = tmp_path / "robot.yaml"
    assert main(["robot", "import", str(files.urdf), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"biped: error: {files.urdf}: an un-expanded xacro file") and not out.exists()
    with pytest.raises(SystemExit) as exc:
        main(["robot", "import", str(files.urdf), "--servo", "BIPED-FOOT-BOARD", "-o", str(out)])
    assert exc.value.code == 2 and "is no servo profile" in capsys.readouterr().err


def humanoid_mjcf(files, folder, quat=(1.0, 0.0, 0.0, 0.0), pos=(0.0, 0.0, 0.0), home=None):
    """The humanoid as MJCF (meshes by absolute path), its base turned by ``quat`` and placed
    at ``pos`` [m], with a keyframe 'home' setting the hinges in ``home`` [rad]."""
    spec = load_model_spec(files.urdf)
    base = spec.body("base_link")
    base.quat, base.pos = list(quat), list(pos)
    add_free_joint(spec)
    if home is not None:
        model = compile_model(spec)
        qpos = model.qpos0.copy()
        for name, angle in home.items():
            qpos[model.jnt_qposadr[model.joint(name).id]] = angle
        spec.add_key(name="home", qpos=qpos)
    path = folder / "humanoid.xml"
    path.write_text(spec.copy().to_xml())
    return path


def test_mirror_pairs_do_not_depend_on_where_the_robot_stands(tmp_path, humanoid):
    path = humanoid_mjcf(humanoid, tmp_path, pos=(1.0, 2.0, 0.3))
    mirror = mirror_pairs(compile_model(load_model_spec(path)))
    assert sorted((p.left, p.right, p.sign) for p in mirror.pairs) == sorted(humanoid.pairs)
    assert mirror.notes == ()


def test_a_model_facing_along_y_is_noted(tmp_path, humanoid):
    s = math.sqrt(0.5)
    path = humanoid_mjcf(humanoid, tmp_path, quat=(s, 0.0, 0.0, s))
    mirror = mirror_pairs(compile_model(load_model_spec(path)))
    assert len(mirror.pairs) < 9
    assert any("the model seems to face along y" in n for n in mirror.notes)


def test_robot_import_of_an_mjcf_reads_its_home_keyframe(tmp_path, humanoid, capsys):
    path = humanoid_mjcf(humanoid, tmp_path, home={"r_knee_joint": 0.5, "l_knee_joint": -0.5})
    assert main(["robot", "import", str(path), "--no-stand", "-o", str(tmp_path / "m.yaml")]) == 0
    assert "stand check" not in capsys.readouterr().out
    doc = load_yaml(tmp_path / "m.yaml")
    joints = {j["name"]: j for j in doc["joints"]}
    assert joints["r_knee_joint"]["home_deg"] == joints["l_knee_joint"]["home_deg"] == 28.6
    assert doc["model"]["file"] == "humanoid.xml" and doc["model"]["root"] == "base_link"
    assert "package_dirs" not in doc["model"]
    # knees bent with the hips and ankles straight: the shins lean back and it falls; the stand check
    # says so and proposes a home that stands, which replaces the keyframe's
    assert main(["robot", "import", str(path), "-o", str(tmp_path / "s.yaml")]) == 0
    report = capsys.readouterr().out
    assert "at the imported home: falls: " in report and "the home pose falls (it fell after" in report
    assert "as the YAML holds it: stands:" in report
    stood = {j["name"]: j for j in load_yaml(tmp_path / "s.yaml")["joints"]}
    assert stood["r_knee_joint"]["home_deg"] == stood["l_knee_joint"]["home_deg"] == 30
    assert main(["robot", "stand", str(tmp_path / "m.yaml")]) == 1  # the keyframe's home falls
    assert main(["robot", "stand", str(tmp_path / "s.yaml")]) == 0


def test_robot_import_of_a_model_facing_backwards_turns_it(tmp_path, humanoid, capsys):
    path = humanoid_mjcf(humanoid, tmp_path, quat=(0.0, 0.0, 0.0, 1.0))  # turned 180 deg about z
    assert main(["robot", "import", str(path), "-o", str(tmp_path / "b.yaml")]) == 0
    report = capsys.readouterr().out
    assert "facing -x (from the geometry)" in report and "AGAINST" not in report
    doc = load_yaml(tmp_path / "b.yaml")
    assert doc["model"]["forward"] == "-x"
    joints = {j["name"]: j for j in doc["joints"]}
    for name, role in humanoid.expected.items():  # the roles of the model as drawn facing +x
        assert (joints[name]["side"], joints[name]["location"], joints[name]["axis"], joints[name]["sign"]) == \
            (role.side, role.location, role.axis, role.sign), name


@pytest.mark.parametrize("kind", ["fifo", "directory", "missing", "empty", "binary"])
def test_robot_import_refuses_what_is_no_model_file_at_once(tmp_path, capsys, kind):
    path = tmp_path / "robot.urdf"
    if kind == "fifo":
        os.mkfifo(path)  # opening it for reading would wait for a writer: refused unopened
    elif kind == "directory":
        path.mkdir()
    elif kind == "empty":
        path.write_text("\n")
    elif kind == "binary":
        path.write_bytes(bytes(range(200, 256)) * 4)
    assert main(["robot", "import", str(path), "-o", str(tmp_path / "robot.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"biped: error: {path}: ") and err.count("\n") == 1
    assert {"fifo": "named pipe", "directory": "is a directory", "missing": "No such file", "empty": "is empty",
            "binary": "not UTF-8"}[kind] in err


def test_the_anchor_tolerance_grows_with_the_robot_not_with_where_it_stands(tmp_path, humanoid):
    here = mirror_pairs(floating(humanoid.urdf)).tolerance
    away = mirror_pairs(compile_model(load_model_spec(humanoid_mjcf(humanoid, tmp_path, pos=(5.0, 5.0, 5.0)))))
    assert 0.003 < here < 0.006 and math.isclose(away.tolerance, here)
