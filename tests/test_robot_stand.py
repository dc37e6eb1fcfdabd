"""Does it stand? `biped robot stand` (sim2real/simulation/standing/check.py) on the shipped robots
and on homes that fall, and the home :func:`propose_home` (stand_home.py) gives a robot whose
home falls, checked on the generated URDF humanoid imported as a user would; and the importer's
stand step (import_stand.py) where no home stands or the robot does not load yet."""

import json
import math

import mujoco
import pytest
import yaml
from robots.urdf_humanoid import write_humanoid

from evolve.cli import main
from sim2real.simulation.model.physique import load_measured
from sim2real.robot.validation import load_yaml
from sim2real.simulation.model.robot_model import RobotModel
from sim2real.simulation.standing.check import VERDICTS, check_stand, floor_force_on, foot_bodies
from sim2real.simulation.standing.home import NoStandingHome, leg_pitch_joints, needs_home, propose_home, with_stance
from sim2real.simulation.model.builder import build_model

JSON_KEYS = {"robot", "seconds", "up_z_final", "up_z_worst", "sag_m", "feet_weight_share", "slide_m", "com_ahead_m",
             "fell", "fell_at_s", "slid", "holds", "weakest", "verdict", "reasons", "reason"}
HOLD_KEYS = {"joint", "holding_nm", "limit_nm", "limit_kind", "margin"}


def _pitch_home(robot_doc: dict, hip: float, knee: float, ankle: float) -> dict:
    """A robot YAML's document with its leg pitch joints' home at these angles [deg]."""
    for joint in robot_doc["joints"]:
        if joint.get("axis") == "pitch" and joint.get("location") in ("hip", "knee", "ankle"):
            joint["home_deg"] = {"hip": hip, "knee": knee, "ankle": ankle}[joint["location"]]
    return robot_doc


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    """The generated humanoid imported by `biped robot import --no-stand`: its YAML (home: the
    zero pose, ranges the model's)."""
    folder = tmp_path_factory.mktemp("kit")
    files = write_humanoid(folder)
    out = folder / "kit.yaml"
    assert main(["robot", "import", str(files.urdf), "--no-stand", "-o", str(out)]) == 0
    return out


# -- the shipped robots stand, with the README's numbers ---------------------------------------
def test_op3_stands_with_the_numbers_the_readme_quotes():
    report = check_stand(load_measured("op3"))
    assert report.verdict == "stands" and not report.reasons and report.stands
    assert report.up_z_final == pytest.approx(0.9944, abs=0.002)  # README: up-vector z 0.994
    assert report.sag_m == pytest.approx(0.0026, abs=0.001)  # README: 2.6 mm sag
    assert report.feet_weight_share == pytest.approx(1.0, abs=0.01)  # README: feet carry its weight
    assert not report.fell and not report.slid and report.seconds == pytest.approx(5.0)
    assert report.com_ahead_m == pytest.approx(0.018, abs=0.003)  # ROBOTIS's stance leans 7 deg forward
    assert {h.joint for h in report.weakest[:2]} == {"l_knee", "r_knee"}  # the knees carry the most
    assert all(h.limit_nm == pytest.approx(4.1) and h.limit_kind == "stall" for h in report.holds)  # XM430-W350
    assert 3.0 < report.weakest[0].margin < 15.0


def test_xl430_biped_stands_upright_on_its_feet():
    report = check_stand(load_measured("xl430_biped"))
    assert report.verdict == "stands"
    assert report.up_z_final > 0.999 and report.up_z_worst > 0.999
    assert 0.0 < report.sag_m < 0.003  # 1.7 mm measured
    assert report.feet_weight_share == pytest.approx(1.0, abs=0.01)
    assert report.slide_m < 1e-3 and report.weakest[0].joint in ("left_knee", "right_knee")


# -- homes that fall ---------------------------------------------------------------------------
@pytest.mark.parametrize("pose, why", [
    ((0, 100, 0), "a deep crouch: knees at 100 deg, hips and ankles straight"),
    ((60, 0, 0), "leaning far forward: hips bent 60 deg, knees straight"),
])
def test_a_home_that_falls_gets_the_falls_verdict_and_exit_1(tmp_path, robots_dir, capsys, pose, why):
    doc = _pitch_home(load_yaml(robots_dir / "xl430_biped.yaml"), *pose)
    path = tmp_path / "bent.yaml"
    path.write_text(yaml.safe_dump(doc))
    assert main(["robot", "stand", str(path)]) == 1, why
    out = capsys.readouterr().out
    assert "verdict: falls: it fell after" in out and "fell: yes" in out


def test_a_model_robot_bent_over_at_the_hips_falls_though_it_rests_still():
    """On a model robot the home keyframe levels the feet, so hips bent far forward tilt the
    torso over them: it does not topple, yet it does not stand either."""
    op3 = load_measured("op3")
    bent = with_stance(op3, {n: math.radians(60) for n in ("r_hip_pitch", "l_hip_pitch")}
                       | {n: math.radians(14.3) for n in ("r_knee", "l_knee")}
                       | {n: 0.0 for n in ("r_ank_pitch", "l_ank_pitch")})
    report = check_stand(bent)
    assert report.verdict == "falls" and report.fell_at_s is None and report.fell
    assert "torso tilted" in report.reason and "not standing" in report.reason


def test_a_stance_tilted_past_fifteen_degrees_stands_with_a_warning(imported):
    robot = load_measured(str(imported))
    hips = [j.name for j in robot.joints if j.location == "hip" and j.axis == "pitch"]
    bent = with_stance(robot, {n: math.radians(20) for n in hips})
    report = check_stand(bent)
    assert report.verdict == "stands with a warning" and report.stands
    assert report.reasons[0].startswith("the torso tilted") and not report.fell


def test_feet_that_slide_are_reported():
    """On ice (friction 0.05) tilted by a slope's share of gravity (0.5 m/s^2 along x)."""
    robot = load_measured("xl430_biped")
    model = build_model(robot)
    model.opt.gravity[:] = (0.5, 0.0, -9.81)
    model.geom_friction[:, 0] = 0.05
    report = check_stand(robot, model=model)
    assert report.slid and report.slide_m > 0.05 and not report.fell
    assert report.verdict == "stands with a warning" and "a foot slid" in report.reason


def test_the_weight_share_counts_only_the_floor_under_the_feet():
    """A robot lying on its back: the floor carries its weight, on its trunk and pelvis as well as
    its heels; the feet's share is the heels' alone."""
    robot = load_measured("xl430_biped")
    model = build_model(robot)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    data.qpos[2], data.qpos[3:7] = 0.1, (math.cos(math.pi / 4), 0.0, -math.sin(math.pi / 4), 0.0)  # on its back
    for _ in range(int(1.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    weight = model.body_mass.sum() * 9.81
    parts = RobotModel.of(model, robot)
    everything = set(range(1, model.nbody))
    feet = foot_bodies(model, parts)
    assert feet == {model.body("left_foot").id, model.body("right_foot").id}
    assert floor_force_on(model, data, everything) == pytest.approx(weight, rel=0.02)
    rest = floor_force_on(model, data, everything - feet)
    assert rest > 0.3 * weight
    assert floor_force_on(model, data, feet) == pytest.approx(weight - rest, rel=0.02)


# -- the command and its JSON ------------------------------------------------------------------
def test_robot_stand_json_keys_and_exit_status(capsys):
    assert main(["robot", "stand", "xl430_biped", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert set(d) == JSON_KEYS
    assert d["verdict"] in VERDICTS and d["verdict"] == "stands" and d["fell"] is False and d["fell_at_s"] is None
    assert len(d["holds"]) == 11 and all(set(h) == HOLD_KEYS for h in d["holds"])
    assert len(d["weakest"]) == 4 and d["weakest"][0] in ("left_knee", "right_knee")


def test_robot_stand_text_names_the_weakest_joints(capsys):
    assert main(["robot", "stand", "op3"]) == 0
    out = capsys.readouterr().out
    assert "torso up-vector z 0.994" in out and "sag 2.6 mm" in out and "the feet carry 100.0 %" in out
    assert "torque margin" in out and "r_knee" in out and "verdict: stands:" in out


# -- a proposed home that stands ---------------------------------------------------------------
def test_the_imported_zero_pose_stands_but_its_straight_knees_ask_for_a_home(imported):
    robot = load_measured(str(imported))
    assert all(j.home_rad == 0.0 for j in robot.joints)
    report = check_stand(robot)
    assert report.verdict == "stands"
    assert "straight knees" in needs_home(robot, report)


def test_the_proposed_home_stands_where_the_bent_forward_one_falls(imported, capsys):
    robot = load_measured(str(imported))
    hips = [j.name for j in robot.joints if j.location == "hip" and j.axis == "pitch"]
    bent = with_stance(robot, {n: math.radians(60) for n in hips})
    falling = check_stand(bent)
    assert falling.verdict == "falls" and "falls" in needs_home(bent, falling)

    proposal = propose_home(bent)
    assert proposal.stand.verdict == "stands" and proposal.knee_deg == 30
    home = proposal.home_rad
    for leg in proposal.legs:  # knees bent, hip and ankle pitch sharing the bend: feet flat
        assert math.degrees(home[leg.knee]) == pytest.approx(30)
        assert math.degrees(home[leg.hip] + home[leg.ankle]) == pytest.approx(30, abs=1.0)
    assert abs(proposal.stand.com_ahead_m) < 0.005 and proposal.stand.up_z_worst > 0.999
    for joint in robot.joints:  # leg ranges centred on the stance, within the model's limits
        low, high = proposal.range_rad[joint.name]
        assert joint.range_rad[0] - 1e-9 <= low <= home[joint.name] <= high <= joint.range_rad[1] + 1e-9
        if joint.name in proposal.centred:
            assert home[joint.name] - low == pytest.approx(high - home[joint.name], abs=math.radians(0.11))
        else:
            assert (low, high) == joint.range_rad and home[joint.name] == 0.0  # arms and head as they were
    assert len(proposal.centred) == 12
    text = "\n".join(proposal.report())
    assert "central 80 %" in text and "knees bent 30 deg" in text and "stands by the 5 s stand check" in text

    # written into the imported YAML as the importer will, the command agrees
    doc = load_yaml(imported)
    for joint in doc["joints"]:
        joint["home_deg"] = round(math.degrees(home[joint["name"]]), 1)
        joint["range_deg"] = [round(math.degrees(a), 1) for a in proposal.range_rad[joint["name"]]]
    fixed = imported.with_name("kit_home.yaml")
    fixed.write_text(yaml.safe_dump(doc))
    assert main(["robot", "stand", str(fixed), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["verdict"] == "stands"


def test_robot_stand_proposes_a_home_for_an_imported_yaml_that_falls(imported, capsys):
    doc = _pitch_home(load_yaml(imported), 60, 0, 0)
    bent = imported.with_name("kit_bent.yaml")
    bent.write_text(yaml.safe_dump(doc))
    assert main(["robot", "stand", str(bent), "--propose-home", "--json"]) == 1  # its own home falls
    d = json.loads(capsys.readouterr().out)
    assert d["verdict"] == "falls" and set(d["proposed_home"]) == {"knee_deg", "home_deg", "range_deg", "centred",
                                                                    "stand", "tried", "notes"}
    proposed = d["proposed_home"]
    assert proposed["stand"]["verdict"] == "stands" and proposed["home_deg"]["l_knee_joint"] == 30.0
    assert main(["robot", "stand", str(bent), "--propose-home"]) == 1
    out = capsys.readouterr().out
    assert "verdict: falls" in out and "home: proposed, knees bent 30 deg" in out
    assert "  r_knee_joint: home_deg: 30.0, range_deg: [0.0, 60.0]" in out


def test_no_standing_home_says_what_each_knee_bend_did(imported):
    robot = load_measured(str(imported))
    with pytest.raises(NoStandingHome) as err:
        propose_home(robot, knee_bends_deg=(140.0,))  # past the knee's 130 deg limit
    assert "knees 140 deg" in str(err.value) and "outside the joint's limits" in str(err.value)


def test_a_leg_without_a_knee_is_named():
    robot = load_measured("xl430_biped")
    model = build_model(robot)
    kneeless = with_stance(robot, {})
    object.__setattr__(kneeless, "joints", tuple(j for j in robot.joints if j.name != "left_knee"))
    with pytest.raises(ValueError, match="the left leg has no knee pitch joint"):
        leg_pitch_joints(kneeless, model)


def test_a_bad_robot_file_is_refused_with_the_file_named(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\ndescription: y\nbody: {}\njoints: []\ncontrol_sets: {}\nwings: 2\n")
    assert main(["robot", "stand", str(bad)]) == 2
    assert main(["robot", "stand", str(tmp_path / "none.yaml")]) == 2


# -- the importer's stand step (sim2real/simulation/standing/imported.py) ----------------------------
def test_an_import_whose_knees_cannot_bend_to_a_stance_keeps_its_home_and_says_why(tmp_path, capsys):
    files = write_humanoid(tmp_path)
    text = files.urdf.read_text()
    assert text.count('2.26893"') == 2  # the knees' 130 deg
    narrow = text.replace('upper="2.26893"', 'upper="0.174533"').replace('lower="-2.26893"', 'lower="-0.174533"')
    files.urdf.write_text(narrow)
    out = tmp_path / "stiff.yaml"
    assert main(["robot", "import", str(files.urdf), "-o", str(out)]) == 0  # the YAML is written all the same
    report = capsys.readouterr().out
    assert "straight knees: a walker starts from bent ones; NO HOME PROPOSED: robot stiff: no home found" in report
    assert "knees 30 deg: " in report and "outside the joint's limits" in report
    assert "as the YAML holds it" not in report and "NO HOME PROPOSED" in out.read_text()
    knees = [j for j in load_yaml(out)["joints"] if j["location"] == "knee"]  # 10 deg: less than any bend tried
    assert [(j["home_deg"], j["range_deg"]) for j in knees] == [(0, [0, 10])] * 2  # the model's, as imported


def test_an_import_that_does_not_load_yet_is_written_without_its_stand_check(tmp_path):
    from sim2real.simulation.model.importing.robot_yaml import write_robot_yaml
    from sim2real.simulation.model.importing.importer import import_robot
    from sim2real.simulation.standing.imported import stand_imported

    files = write_humanoid(tmp_path)
    result = import_robot(files.urdf, tmp_path / "footless.yaml")
    result.feet.pop("left")  # as when no left leg was recognised: the user names the foot
    result = stand_imported(result)
    assert result.stand.before is None and result.stand.verdict is None
    assert result.report()[-1].startswith("stand check: not run (") and "model.feet" in result.report()[-1]
    write_robot_yaml(result)
    assert "# STAND CHECK NOT RUN: " in (tmp_path / "footless.yaml").read_text()
