"""Names that are names, role maps that make sense, inputs checked by meaning (issue 47,
items 1, 3 and 7; issue 48 item 6).

* A robot name read from a file - a controller's ``robot.name``, a trace sidecar's ``robot``,
  an evolve config's ``robot:`` - is looked up among the project's robots only: every command
  that reads one refuses a path of any shape (even one to a valid robot YAML) naming the file
  and the key and listing the known robots, and never prints a byte of the file it points at;
  a robot file is given on the command line (``--robot FILE``) instead, and that still works.
  A whole document that is not a mapping is reported by its type, never echoed.
* A robot YAML's ``model:`` roles are checked on the model's tree by ``robot show``, ``robot
  mjcf`` and the simulated bus alike: feet two distinct bodies, each below its own leg's hip
  and knee, neither the root; the IMU and hands on the robot; the root the kinematic root;
  a model file's repeated joint name refused by name.
* ``polish`` and ``adapt`` (and ``eval --ablate``/``--by-perturbation``) refuse a controller
  that is not a walker, saying what it is; ``sysid`` refuses one trace given twice.
"""

import json
import os
import shutil
from pathlib import Path

import pytest

from hang_guard import fails_after
import yaml
from robots.urdf_humanoid import write_humanoid

from evolve.cli import main
from sim2real.controller.file import Controller
from sim2real.controller.purpose import purpose_of
from sim2real.errors import ConfigError
from sim2real.robot import load_robot
from sim2real.simulation.model.physique import load_measured
from sim2real.robot.names import named_robot_path
from sim2real.robot.paths import data_root
from tests.test_cli_errors import assert_usage_error, biped
from tests.test_hostile_files import _walk

ROOT = data_root()
ROBOT = load_robot()
WALKER = ROOT / "configs" / "controllers" / "xl430_biped.json"
REACHERS = ["op3_reach.json", "human_arms_reach.json"]
TOKEN = "TOKEN-5f3a9c-never-printed"  # the content of files a name points at


@pytest.fixture(autouse=True)
def no_hang():
    """A command that blocks (a FIFO opened as a robot file) fails after 60 s instead."""
    with fails_after(60):
        yield


@pytest.fixture(scope="module")
def targets(tmp_path_factory) -> dict[str, Path]:
    """Files a hostile name points at: a valid robot YAML (opened, it would load and the
    command run on), a text file whose content is a secret, a FIFO (opened, it would hang)."""
    folder = tmp_path_factory.mktemp("targets")
    robot = folder / "robot.yaml"
    robot.write_text((ROOT / "configs" / "robots" / "xl430_biped.yaml").read_text())
    secret = folder / "secret.txt"
    secret.write_text(TOKEN + "\n")
    fifo = folder / "fifo.yaml"
    os.mkfifo(fifo)
    return {"robot": robot, "secret": secret, "fifo": fifo}


def _shapes(targets: dict[str, Path]) -> dict[str, object]:
    relative = os.path.relpath(targets["robot"], Path.cwd())
    return {
        "absolute path to a valid robot": str(targets["robot"]),
        "relative path to a valid robot": relative if ".." in relative else "../" * 12 + str(targets["robot"]),
        "absolute path to a secret": str(targets["secret"]),
        "a FIFO": str(targets["fifo"]),
        "parent folders": "../../../../etc/passwd",
        "a project robot by path": "configs/robots/op3.yaml",
        "dot-dot inside": "op3/../xl430_biped",
        "home folder": "~/robot.yaml",
        "backslashes": "C:\\robots\\x.yaml",
        "a NUL": "xl430_biped\x00.yaml",
        "overlong": "r" * 5000,
        "a path as preset": "human:../../etc/passwd",
        "a hidden name": ".xl430_biped",
        "an unknown robot": "no_such_robot",
        "not a string": ["xl430_biped"],
    }


SHAPES = list(_shapes({"robot": Path("/x/r.yaml"), "secret": Path("/x/s"), "fifo": Path("/x/f")}))
MAIN_SHAPES = ["absolute path to a valid robot", "relative path to a valid robot", "absolute path to a secret",
               "a project robot by path"]


def _controller(folder: Path, name: object, source: Path = WALKER) -> Path:
    doc = json.loads(source.read_text())
    doc["robot"]["name"] = name
    path = folder / "named.json"
    path.write_text(json.dumps(doc))
    return path


def _trace(folder: Path, name: object) -> Path:
    meta = {"robot": name, "tick_s": 0.034, "excitation": {"pose": "suspended", "segments": []}}
    return _walk(folder / "t.csv", meta)


def _evolve_config(folder: Path, name: object) -> Path:
    path = folder / "cfg.yaml"
    path.write_text(yaml.safe_dump({"robot": name, "generations": 1, "threads": 1,
                                    "neat": {"population_size": 4, "target_species": 1}}))
    return path


# command -> (how its input is written, argv with {f} and {d}, the file the error names, its key, --robot?)
COMMANDS = {
    "run": (_controller, ["run", "{f}", "--bus", "mock", "--duration", "0.2"], "named.json", "robot.name", True),
    "dry-run": (_controller, ["dry-run", "{f}", "--duration", "0.2"], "named.json", "robot.name", True),
    "eval": (_controller, ["eval", "{f}", "--seconds", "0.2"], "named.json", "robot.name", True),
    "plot gait": (_controller, ["plot", "gait", "{f}", "--seconds", "0.2", "-o", "{d}/g.png"], "named.json",
                  "robot.name", True),
    "render": (_controller, ["render", "{f}", "-o", "{d}/r.gif", "--seconds", "0.1"], "named.json",
               "robot.name", False),
    "polish": (_controller, ["polish", "{f}", "--out", "{d}/polish", "--updates", "1", "--popsize", "2",
                             "--robots", "1", "--validation", "1", "--test", "1"], "named.json", "robot.name", False),
    "adapt": (_controller, ["adapt", "{f}", "--reality", "nominal", "--out", "{d}/adapt", "--generations", "1",
                            "--population", "2", "--test", "1", "--validation", "1"], "named.json", "robot.name",
              False),
    "compare": (_trace, ["compare", "{f}"], "t.json", "robot", True),
    "plot gait --trace": (_trace, ["plot", "gait", "--trace", "{f}", "-o", "{d}/g.png"], "t.json", "robot", True),
    "sysid": (_trace, ["sysid", "{f}", "--max-iters", "1"], "t.json", "robot", True),
    "evolve": (_evolve_config, ["evolve", "{f}", "--out", "{d}/run"], "cfg.yaml", "robot", True),
}


def _run_named(command: str, name: object, folder: Path, capsys):
    write, argv, _, _, _ = COMMANDS[command]
    if command == "sysid":
        pytest.importorskip("scipy")
    if command.startswith("plot"):
        pytest.importorskip("matplotlib")
    path = write(folder, name)
    return biped([a.format(f=path, d=folder) for a in argv], capsys)


def _assert_refused(result, command: str) -> None:
    _, _, source, key, takes_robot = COMMANDS[command]
    assert_usage_error(result, source, f"{key}:", "known robots:", "xl430_biped")
    last = result.err.strip().splitlines()[-1]
    assert ("--robot FILE" in last) == takes_robot, last
    assert TOKEN not in result.err + result.out


@pytest.mark.parametrize("shape", MAIN_SHAPES)
@pytest.mark.parametrize("command", list(COMMANDS))
def test_a_robot_name_from_a_file_is_never_a_path(command, shape, targets, tmp_path, capsys):
    result = _run_named(command, _shapes(targets)[shape], tmp_path, capsys)
    _assert_refused(result, command)
    assert "is a path, not a robot's name" in result.err
    assert not any((tmp_path / d).exists() for d in ("polish", "adapt", "run"))  # nothing began


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("command", ["run", "compare"])
def test_every_shape_of_a_name_is_refused_by_a_controller_and_a_sidecar(command, shape, targets, tmp_path, capsys):
    result = _run_named(command, _shapes(targets)[shape], tmp_path, capsys)
    if command == "run" and shape == "not a string":  # the controller's own schema refuses it first
        assert_usage_error(result, "named.json", "robot.name: must be a non-empty string")
    else:
        _assert_refused(result, command)


@pytest.mark.parametrize("shape", SHAPES)
def test_a_name_that_is_not_a_project_robot_is_refused_by_the_lookup(shape, targets):
    with pytest.raises(ConfigError, match=r"^walker\.json: robot\.name: .*known robots: .*xl430_biped"):
        named_robot_path(_shapes(targets)[shape], "walker.json", "robot.name")


@pytest.mark.parametrize("name", ["xl430_biped", "op3", "human:female_50", "human_arms"])
def test_a_project_robots_name_is_found(name):
    path, preset = named_robot_path(name, "walker.json", "robot.name")
    assert path == ROOT / "configs" / "robots" / f"{name.split(':')[0]}.yaml"
    assert preset == (name.split(":")[1] if ":" in name else None)


def test_a_robot_file_given_on_the_command_line_still_drives_the_controller(targets, tmp_path, capsys):
    """The way to a robot outside configs/robots: --robot FILE, chosen by the user."""
    path = _controller(tmp_path, "/etc/hostname")
    result = biped(["run", path, "--robot", targets["robot"], "--bus", "mock", "--duration", "0.2", "--json"], capsys)
    assert result.code == 0, result.err


def test_a_run_for_a_robot_file_resumes_only_with_that_file_given_again(targets, tmp_path, capsys):
    """``biped evolve --robot FILE`` writes FILE into the run's config.yaml; resuming reads that
    file's path only when the command line names it again."""
    from evolve.config import parse_evolve_config
    from evolve.locomotion.evaluator import neat_layout
    from evolve.neat import NeatConfig, Population
    from evolve.run import Run
    from sim2real.controller.symmetry import symmetric_layout

    robot_file = str(targets["robot"])
    doc = {"robot": robot_file, "generations": 5, "threads": 1, "task": {"episode_s": 1.0},
           "neat": {"population_size": 4, "target_species": 1}}
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.yaml").write_text(parse_evolve_config(doc, "cfg", robot_file=robot_file).to_yaml())
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"])
    Population(NeatConfig(population_size=4, target_species=1), neat_layout(layout), seed=1).save(
        run / "checkpoint.json.gz")
    (run / "stats.csv").write_text("generation\n")
    result = biped(["evolve", "--resume", "--out", run], capsys)
    assert_usage_error(result, "config.yaml", "robot:", "is a path", "--robot FILE")
    other = tmp_path / "other.yaml"
    other.write_text(targets["robot"].read_text())
    with pytest.raises(ConfigError, match="config.yaml: robot: .*is a path"):
        Run.resume(run, robot=str(other), log=lambda _: None)
    resumed = Run.resume(run, robot=robot_file, log=lambda _: None)
    resumed.close()
    assert resumed.robot.source == robot_file


def test_a_project_robots_name_on_the_command_line_wins_over_a_folder_of_that_name(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "op3").mkdir()  # e.g. the user's own files about their OP3
    result = biped(["robot", "show", "op3", "--json"], capsys)
    assert result.code == 0, result.err
    assert json.loads(result.out)["name"] == "op3"


@pytest.mark.parametrize("write, argv, problem", [
    (lambda p: p.write_text(TOKEN + "\n"), ["robot", "show", "{p}"], "must be a mapping, got a str"),
    (lambda p: p.write_text(f"- {TOKEN}\n"), ["robot", "show", "{p}"], "must be a mapping, got a list"),
    (lambda p: p.write_text(json.dumps([TOKEN])), ["run", "{p}", "--bus", "mock"], "must hold a JSON object, got list"),
    (lambda p: p.write_text(f"{TOKEN}\n"), ["evolve", "{p}", "--out", "{d}/run"], "must be a mapping"),
], ids=["robot: a string", "robot: a list", "controller: a list", "evolve config: a string"])
def test_a_file_that_is_not_a_mapping_is_named_by_its_type_never_echoed(write, argv, problem, tmp_path, capsys):
    path = tmp_path / "not_a_config"
    write(path)
    result = biped([a.format(p=path, d=tmp_path) for a in argv], capsys)
    assert_usage_error(result, str(path), problem)
    assert TOKEN not in result.err + result.out


# -- role maps ------------------------------------------------------------------------------------
OP3_DOC = yaml.safe_load((ROOT / "configs" / "robots" / "op3.yaml").read_text())


def _feet(left: str | None = None, right: str | None = None):
    def edit(model: dict) -> None:
        if left:
            model["feet"]["left"]["body"] = left
        if right:
            model["feet"]["right"]["body"] = right
    return edit


ROLE_MAPS = {  # an edit of op3.yaml's model block -> the key refused, words of the problem
    "both feet one body": (_feet(right="l_ank_roll_link"), "model.feet.right.body", "the same body"),
    "a foot on the root": (_feet(left="body_link"), "model.feet.left.body", "is the root"),
    "feet swapped": (_feet("r_ank_roll_link", "l_ank_roll_link"), "model.feet.left.body", "swapped"),
    "a foot above its knee": (_feet(left="l_hip_pitch_link"), "model.feet.left.body", "left knee joint"),
    "a foot on an arm": (_feet(left="l_el_link"), "model.feet.left.body", "left hip joint"),
    "a foot below the other": (_feet("l_ank_pitch_link", "l_ank_roll_link"), "model.feet.right.body",
                               "below the left foot"),
    "a foot on the world": (_feet(left="world"), "model.feet.left.body", "is the world"),
    "the IMU on the world": (lambda m: m["imu"].update(body="world"), "model.imu.body", "is the world"),
    "a hand on the world": (lambda m: m["hands"].update(left={"body": "world"}), "model.hands.left", "is the world"),
    "the root not the kinematic root": (lambda m: m.update(root="l_hip_yaw_link"), "model.root",
                                        "not the robot's kinematic root"),
    "the root the world": (lambda m: m.update(root="world"), "model.root", "is the world"),
}


def _op3_edited(folder: Path, edit) -> Path:
    doc = json.loads(json.dumps(OP3_DOC))
    edit(doc["model"])
    doc["model"]["file"] = str(ROOT / "configs" / "robots" / "op3" / "op3.xml")
    path = folder / "op3_edited.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _built_three_ways(path: Path, folder: Path, capsys, source: Path | None = None) -> list[str]:
    """The error (naming ``source``, default the robot YAML) of ``robot show``, of ``robot
    mjcf`` and of the simulated bus's physics."""
    from sim2real.simulation.simbus.physics import PhysicsChain

    errors = []
    for argv in (["robot", "show", path], ["robot", "mjcf", path, "-o", folder / "out.xml"]):
        result = biped(argv, capsys)
        assert_usage_error(result, str(source or path))
        errors.append(result.err.strip().splitlines()[-1])
    assert not (folder / "out.xml").exists()
    with pytest.raises(ConfigError) as caught:
        PhysicsChain(load_measured(path))  # what `biped simbus` serves
    errors.append(str(caught.value))
    return errors


@pytest.mark.parametrize("case", list(ROLE_MAPS))
def test_a_role_map_that_makes_no_sense_is_refused_by_show_mjcf_and_the_simulated_bus(case, tmp_path, capsys):
    edit, key, words = ROLE_MAPS[case]
    for error in _built_three_ways(_op3_edited(tmp_path, edit), tmp_path, capsys):
        assert f"op3_edited.yaml: {key}: " in error and words in error, error


@pytest.fixture(scope="module")
def humanoid(tmp_path_factory) -> Path:
    """The tests' generated humanoid, imported: its robot YAML beside its URDF."""
    folder = tmp_path_factory.mktemp("humanoid")
    files = write_humanoid(folder)
    out = folder / "humanoid.yaml"
    assert main(["robot", "import", str(files.urdf), "--servo", "XM430-W350", "-o", str(out)]) == 0
    return out


def test_a_model_file_that_names_two_joints_alike_is_refused_naming_the_joint(humanoid, tmp_path, capsys):
    urdf = humanoid.parent / "twice.urdf"  # beside its meshes
    urdf.write_text((humanoid.parent / "humanoid.urdf").read_text().replace(
        '<joint name="r_hip_roll_joint"', '<joint name="r_hip_yaw_joint"'))
    doc = yaml.safe_load(humanoid.read_text())
    doc["model"]["file"] = str(urdf)
    path = tmp_path / "twice.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    for error in _built_three_ways(path, tmp_path, capsys, source=urdf):
        assert "twice.urdf: two joints are named 'r_hip_yaw_joint'" in error, error
    result = biped(["robot", "import", urdf, "-o", tmp_path / "imported.yaml"], capsys)
    assert_usage_error(result, "twice.urdf", "two joints are named 'r_hip_yaw_joint'")


# -- inputs checked by meaning ------------------------------------------------------------------------
@pytest.mark.parametrize("reacher", REACHERS)
@pytest.mark.parametrize("command", ["polish", "adapt"])
def test_polish_and_adapt_refuse_a_reaching_controller(command, reacher, tmp_path, capsys):
    argv = {"polish": ["polish", "{c}", "--out", "{d}/out", "--updates", "1", "--popsize", "2", "--robots", "1"],
            "adapt": ["adapt", "{c}", "--reality", "nominal", "--out", "{d}/out", "--generations", "1"]}[command]
    path = ROOT / "configs" / "controllers" / reacher
    result = biped([a.format(c=path, d=tmp_path) for a in argv], capsys)
    assert_usage_error(result, reacher, "task:", "a reaching controller", f"biped {command} needs a walker")
    assert not (tmp_path / "out").exists()


def test_polish_refuses_a_controller_evolved_to_stand(tmp_path, capsys):
    """A staged run's controller: its top module's stage had the stand objective."""
    doc = json.loads(WALKER.read_text())
    doc["provenance"]["config"]["stages"] = [{"name": "main", "objective": "stand", "generations": 1}]
    path = tmp_path / "stander.json"
    path.write_text(json.dumps(doc))
    result = biped(["polish", path, "--out", tmp_path / "out", "--updates", "1"], capsys)
    assert_usage_error(result, "stander.json", "a standing controller", "'main'", "needs a walker")


@pytest.mark.parametrize("flags", [["--ablate", "--reality", "randomize"], ["--by-perturbation", "--randomize",
                                                                             "randomize"]])
def test_eval_counts_walks_only_of_a_walker(flags, capsys):
    result = biped(["eval", ROOT / "configs" / "controllers" / REACHERS[0], *flags], capsys)
    assert_usage_error(result, REACHERS[0], "a reaching controller", f"biped eval {flags[0]} needs a walker")


def test_every_shipped_controller_says_what_it_was_evolved_for():
    for path in sorted((ROOT / "configs" / "controllers").glob("*.json")):
        assert purpose_of(Controller.load(path)).task == ("reach" if path.name in REACHERS else "walk"), path.name


@pytest.mark.parametrize("second", ["the same path", "another spelling", "a link", "a copy"])
def test_sysid_refuses_one_trace_given_twice(second, tmp_path, capsys, monkeypatch):
    pytest.importorskip("scipy")
    monkeypatch.chdir(tmp_path)
    first = _trace(tmp_path, ROBOT.name)
    other = {"the same path": lambda: first, "another spelling": lambda: "./t.csv",
             "a link": lambda: _linked(first), "a copy": lambda: _copied(first)}[second]()
    result = biped(["sysid", first, other, "--max-iters", "1", "-o", tmp_path / "fit.yaml"], capsys)
    assert_usage_error(result, "t.csv", "give each trace once", "a copy" if second == "a copy" else "given twice")
    assert not (tmp_path / "fit.yaml").exists()


def _linked(path: Path) -> Path:
    link = path.with_name("link.csv")
    link.symlink_to(path)
    shutil.copy(path.with_suffix(".json"), link.with_suffix(".json"))
    return link


def _copied(path: Path) -> Path:
    copy = path.with_name("copy.csv")
    shutil.copy(path, copy)
    shutil.copy(path.with_suffix(".json"), copy.with_suffix(".json"))
    return copy
