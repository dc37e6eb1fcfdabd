"""Every bad flag, config value and input file ends in one clear error and a non-zero exit.

The rule (issue 12): bad input exits 2 with one line ``biped: error: ...`` naming the flag,
key or file (argparse's own usage error for a flag's value, also exit 2); a run that started
but did not end as asked exits 1, its last line ``biped: error: ...``.  Nothing here runs
a simulation for more than a few ticks: the checks must come before anything starts.
"""

import json
from pathlib import Path
from typing import NamedTuple

import pytest

from evolve.cli import main
from evolve.locomotion.evaluator import neat_layout
from evolve.locomotion.export import controller_from_genome
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome
from sim2real.controller.symmetry import symmetric_layout
from sim2real.hardware.trace import TraceWriter
from sim2real.robot import load_robot

ROBOT = load_robot()


@pytest.fixture(scope="module")
def controller(tmp_path_factory):
    """A standing controller (no connections) for the default robot."""
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"])
    path = tmp_path_factory.mktemp("c") / "stand.json"
    controller_from_genome(Genome(0, neat_layout(layout)), ROBOT, layout, TaskConfig(episode_s=1.0), 1.0,
                           {"seed": 0}).save(path)
    return path


class Result(NamedTuple):
    code: int
    out: str
    err: str


def biped(argv, capsys) -> Result:
    """Exit status, stdout and stderr of ``biped argv``, in process."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    captured = capsys.readouterr()
    return Result(code, captured.out, captured.err)


def assert_usage_error(result: Result, *names: str) -> None:
    """Exit 2 and one error line naming ``names`` (argparse's usage lines may come before it)."""
    assert result.code == 2, result.err
    assert "Traceback" not in result.err
    lines = result.err.strip().splitlines()
    last = lines[-1]
    if last.startswith("biped: error:"):
        assert len(lines) == 1, result.err
    else:
        assert last.startswith("biped ") and ": error: argument " in last, result.err
    for name in names:
        assert name in last, (name, last)


# -- flag values: typed converters, refused by argparse before anything runs ---------------------
BAD_FLAGS = [
    (["evolve", "--generations", "-1"], "--generations"),
    (["evolve", "--generations", "0"], "--generations"),
    (["evolve", "--generations", "ten"], "--generations"),
    (["evolve", "--seed", "-1"], "--seed"),
    (["evolve", "--threads", "-1"], "--threads"),
    (["evolve", "--population", "1"], "--population"),
    (["run", "{c}", "--bus", "mock", "--duration", "-1"], "--duration"),
    (["run", "{c}", "--bus", "mock", "--duration", "nan"], "--duration"),
    (["run", "{c}", "--bus", "mock", "--lost-after-ms", "nan"], "--lost-after-ms"),
    (["run", "{c}", "--bus", "mock", "--lost-after-ms", "0"], "--lost-after-ms"),
    (["run", "{c}", "--bus", "mock", "--rt-priority", "0"], "--rt-priority"),
    (["run", "{c}", "--bus", "mock", "--rt-priority", "100"], "--rt-priority"),
    (["run", "{c}", "--bus", "mock", "--cpu", "9999"], "--cpu"),
    (["dry-run", "{c}", "--cpu", "-1"], "--cpu"),
    (["simbus", "--rt-priority", "x"], "--rt-priority"),
    (["run", "{c}", "--bus", "mock", "--duration", "inf"], "--duration"),
    (["run", "{c}", "--bus", "mock", "--duration", "0"], "--duration"),
    (["run", "{c}", "--bus", "mock", "--baud", "12345"], "--baud"),
    (["run", "{c}", "--port", ""], "--port"),
    (["run", "{c}", "--bus", "mock", "--duration", "1e308"], "--duration"),
    (["dry-run", "{c}", "--duration", "1e7"], "--duration"),
    (["run", "{c}", "--bus", "mock", "--lost-after-ms", "1e308"], "--lost-after-ms"),
    (["run", "{c}", "--port", "  "], "--port"),
    (["run", "{c}", "--bus", "mock", "--trace", "{tmp}/missing/t.csv"], "--trace"),
    (["run", "{c}", "--bus", "mock", "--trace", "{tmp}"], "--trace"),
    (["dry-run", "{c}", "--duration", "-1"], "--duration"),
    (["dry-run", "{c}", "--duration", "nan"], "--duration"),
    (["dry-run", "{c}", "--seed", "-1"], "--seed"),
    (["dry-run", "{c}", "--trace", "{tmp}/t.json"], "--trace"),
    (["dry-run", "{c}", "--trace", "{c}/t.csv"], "--trace"),  # the "directory" is a file
    (["simbus", "--baud", "12345"], "--baud"),
    (["simbus", "--seed", "-1"], "--seed"),
    (["eval", "{c}", "--episodes", "0"], "--episodes"),
    (["eval", "{c}", "--seconds", "-1"], "--seconds"),
    (["eval", "{c}", "--seconds", "nan"], "--seconds"),
    (["eval", "{c}", "--seed", "-1"], "--seed"),
    (["render", "--width", "0"], "--width"),
    (["render", "--height", "-5"], "--height"),
    (["render", "--settle", "nan"], "--settle"),
    (["render", "{c}", "--seconds", "0"], "--seconds"),
    (["quickstart", "--generations", "0"], "--generations"),
    (["quickstart", "--population", "1"], "--population"),
    (["quickstart", "--seed", "-1"], "--seed"),
    (["quickstart", "--out", "{c}"], "--out"),
    (["compare", "{c}", "--plot", "{tmp}/plot.txt"], "--plot"),
    (["compare", "{c}", "--robot", "nope"], "--robot"),
    (["dry-run", "{c}", "--robot", "nope"], "--robot"),
    (["run", "{c}", "--robot", "{tmp}/robot.yaml"], "--robot"),
    (["eval", "{c}", "--robot", "human:giant"], "--robot"),
    (["simbus", "--robot", "nope"], "--robot"),
    (["dry-run", "{c}", "--reality", "nope"], "--reality"),
    (["simbus", "--reality", "{tmp}/reality.yaml"], "--reality"),
    (["eval", "{c}", "--randomize", "nope"], "--randomize"),
    (["quickstart", "--reality", "nope"], "--reality"),
    (["export", "{tmp}", "-o", "{tmp}/missing/c.json"], "--output"),
    (["robot", "mjcf", "-o", "{tmp}/missing/robot.xml"], "--output"),
]


def ids(cases) -> list[str]:
    return [" ".join(case[0]).replace("{c}", "C").replace("{tmp}/", "").replace("{tmp}", "DIR") for case in cases]


@pytest.mark.parametrize("argv, flag", BAD_FLAGS, ids=ids(BAD_FLAGS))
def test_a_bad_flag_value_is_refused_naming_the_flag(argv, flag, controller, tmp_path, capsys):
    (tmp_path / "robot.yaml").write_text("name: x\nwings: 2\n")  # a robot and a reality file, both bad
    (tmp_path / "reality.yaml").write_text("kp_scale: [1.2, 0.8]\n")
    argv = [a.format(c=controller, tmp=tmp_path) for a in argv]
    assert_usage_error(biped(argv, capsys), flag)


# -- values that need the robot, the controller or another flag: checked before the run starts --
BAD_COMBINATIONS = [
    (["eval", "{c}", "--disable-module", "nope"], ["--disable-module", "'nope'", "main"]),
    (["run", "{c}", "--bus", "mock", "--disable-module", "nope"], ["--disable-module", "main"]),
    (["dry-run", "{c}", "--disable-module", "nope"], ["--disable-module", "main"]),
    (["render", "--disable-module", "main"], ["--disable-module"]),
    (["view", "--disable-module", "main"], ["--disable-module"]),
    (["run", "{c}", "--port", "/dev/null", "--baud", "500000"], ["--baud 500000", "xl430_biped"]),
    (["run", "{c}", "--bus", "mock", "--baud", "57600"], ["--baud", "--port"]),
    (["simbus", "--baud", "500000"], ["--baud 500000"]),
    (["simbus", "--robot", "human"], ["human", "bus"]),
    (["simbus", "--faults", "overload:200@1"], ["--faults", "200"]),
    (["dry-run", "{c}", "--faults", "silent:99@1"], ["--faults", "silent:99@1", "ID 99", "200"]),
    (["dry-run", "{c}", "--faults", "silent:4@20"], ["--faults", "--duration"]),
    (["dry-run", "{c}", "--faults", "silent:4@nan"], ["--faults"]),
    (["dry-run", "{c}", "--faults", "drop:2"], ["--faults", "drop:2"]),
    (["dry-run", "{c}", "--faults", "melt:3@1"], ["--faults", "melt:3@1"]),
    (["dry-run", "{c}", "--faults", "{tmp}/faults.yaml"], ["faults.yaml", "silent[0].id", "ID 42"]),
    (["dry-run", "{c}", "--trace", "{sibling}"], ["--trace", "controller"]),
    (["run", "{c}", "--bus", "mock", "--duration", "0.001"], ["--duration", "tick"]),
    (["eval", "{c}", "--seconds", "0.001"], ["--seconds", "tick"]),
    (["eval", "{c}", "--randomize", "--reality", "default"], ["--randomize", "--reality"]),
    (["eval", "{c}", "--ablate"], ["--ablate"]),
    (["eval", "{c}", "--by-perturbation"], ["--by-perturbation", "--randomize"]),
    (["excite", "--joints", "elbow", "--trace", "{tmp}/e.csv"], ["elbow", "knee"]),
    (["sysid", "{tmp}/missing.csv"], ["missing.csv"]),
    (["render", "--seconds", "2"], ["--seconds"]),
    (["render", "{c}", "-o", "{tmp}/walk.png"], ["--output", ".mp4"]),
    (["render", "-o", "{tmp}/robot.txt"], ["--output", ".png"]),
    (["render", "--width", "4000"], ["--width"]),
    (["evolve", "--address", "10.0.0.1:6379"], ["--address", "--backend ray"]),
    (["evolve", "--resume"], ["--resume", "--out"]),
    (["evolve", "walk", "--resume", "--out", "{tmp}/run"], ["--resume"]),
    (["evolve", "walk_hierarchy", "--generations", "5", "--out", "{tmp}/run"], ["--generations", "staged"]),
    (["evolve", "nope", "--out", "{tmp}/run"], ["'nope'"]),
]


@pytest.mark.parametrize("argv, names", BAD_COMBINATIONS, ids=ids(BAD_COMBINATIONS))
def test_a_value_the_robot_or_controller_refuses_is_one_line_before_anything_runs(argv, names, controller,
                                                                                   tmp_path, capsys):
    (tmp_path / "faults.yaml").write_text("silent: [{id: 42, at_s: 1}]\n")
    argv = [a.format(c=controller, tmp=tmp_path, sibling=controller.with_suffix(".csv")) for a in argv]
    assert_usage_error(biped(argv, capsys), *names)
    assert not (tmp_path / "run").exists() and not (tmp_path / "q").exists()  # nothing started


# -- evolve config files: file, key and problem ---------------------------------------------
BAD_CONFIGS = [
    ("task: {control_set: dance}", "task.control_set", "walk, balance, all"),
    ("task: {episode_s: .nan}", "task.episode_s", "finite"),
    ("task: {episode_s: .inf}", "task.episode_s", "finite"),
    ("task: {episode_s: 0}", "task.episode_s", "> 0"),
    ("task: {stagnation_s: 0}", "task.stagnation_s", "> 0"),
    ("task: {fall_tilt_deg: 270}", "task.fall_tilt_deg", "180"),
    ("task: {harness_generations: 1.5}", "task.harness_generations", "integer"),
    ("task: {control_set: ''}", "task.control_set", "string"),
    ("seed: -1", "seed", ">= 0"),
    ("seed: .nan", "seed", "integer"),
    ("generations: -1", "generations", ">= 1"),
    ("generations: 0", "generations", ">= 1"),
    ("threads: -2", "threads", ">= 0"),
    ("checkpoint_every: x", "checkpoint_every", "integer"),
    ("robot: nope", "robot", "'nope'"),
    ("robot: 5", "robot", "string"),
    ("neat: {weight_sigma: .nan}", "neat.weight_sigma", "finite"),
    ("neat: {population_size: 1}", "neat.population_size", "at least 2"),
    ("neat: {add_node_prob: 2}", "neat.add_node_prob", "[0, 1]"),
    ("neat: {initial_connection: some}", "neat.initial_connection", "full"),
    ("randomize: {reality: nope}", "randomize.reality", "'nope'"),
    ("randomize: {episodes: 0}", "randomize.episodes", ">= 1"),
    ("randomize: {score: best}", "randomize.score", "mean"),
    ("stages: [{name: a, objective: dance, generations: 1}]", "stages[0].objective", "pose"),
    ("stages: [{name: a, objective: pose, generations: 0}]", "stages[0].generations", ">= 1"),
    ("stages: [{name: a, objective: pose, generations: 1, threshold: .nan}]", "stages[0].threshold", "finite"),
    ("stages: [{name: a, objective: pose, generations: 1, weights: {com: -1}}]", "stages[0].weights.com", "negative"),
    ("stages: [{name: ../a, objective: pose, generations: 1}]", "stages[0].name", "letters"),
    ("stages: [{name: a, objective: pose, generations: 1, target_pose_deg: {tail: 3}}]",
     "stages[0].target_pose_deg.tail", "driven"),
    ("wings: 2", "wings", "unknown key"),
]


@pytest.mark.parametrize("text, key, problem", BAD_CONFIGS, ids=[k for _, k, _ in BAD_CONFIGS])
def test_a_bad_evolve_config_value_names_file_and_key(text, key, problem, tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text(text + "\n")
    assert_usage_error(biped(["evolve", path, "--out", tmp_path / "run", "--quiet"], capsys),
                       f"bad.yaml: {key}: ", problem)
    assert not (tmp_path / "run").exists()


# -- compare on what a killed run, a wrong file or a lost sidecar leaves ----------------------
def write_trace(path, rows: int = 6, sidecar: bool = True):
    """A trace of the default robot standing still, written by the runtime's own writer."""
    home = [j.home_rad for j in ROBOT.joints]
    writer = TraceWriter(path, ROBOT.joint_names, {"robot": ROBOT.name, "tick_s": 0.034})
    for k in range(rows):
        writer.write(k * 0.034, k, home, home, [1, 1], [0.0, 0.0, 1.0], 1e-4, 1e-3, False)
    writer.close()
    if not sidecar:
        path.with_suffix(".json").unlink()
    return path


def test_compare_drops_a_row_cut_short_with_a_note(tmp_path, capsys):
    path = write_trace(tmp_path / "t.csv")
    path.write_text(path.read_text()[:-25])  # killed mid-row: no end of line, too few fields
    result = biped(["compare", path, "--json"], capsys)
    assert result.code == 0, result.err
    report = json.loads(result.out)
    assert report["ticks"] == 5
    assert any("cut short" in note for note in report["notes"])
    assert "cut short" in result.err and "Traceback" not in result.err


BAD_TRACES = [
    ("binary", lambda p: p.write_bytes(bytes(range(256)) * 4), ["t.csv", "binary"]),
    ("empty", lambda p: p.write_text(""), ["t.csv", "empty"]),
    ("header only", lambda p: p.write_text(p.read_text().splitlines()[0] + "\n"), ["t.csv", "no rows"]),
    ("no sidecar", lambda p: p.with_suffix(".json").unlink(), ["t.csv", "t.json", "--robot"]),
    ("bad sidecar", lambda p: p.with_suffix(".json").write_text("{cut"), ["t.json"]),
    ("header unlike sidecar", lambda p: p.write_text(p.read_text().replace("time_s", "time", 1)),
     ["t.csv", "header", "time_s"]),
    ("text mid-file", lambda p: p.write_text(p.read_text().replace("\n0.068000,2,", "\n0.068000,two,", 1)),
     ["t.csv", "row 4", "tick"]),
    ("short row mid-file", lambda p: p.write_text(p.read_text().replace(",0\n", "\n", 2)), ["t.csv", "row 2"]),
    ("the sidecar given", lambda p: p.with_suffix(".json"), ["t.json", "CSV"]),
    ("another robot", lambda p: p.with_suffix(".json").write_text(json.dumps({"robot": "op3_legs"})),
     ["t.csv", "op3_legs"]),
]


@pytest.mark.parametrize("spoil, names", [(s, n) for _, s, n in BAD_TRACES], ids=[i for i, _, _ in BAD_TRACES])
def test_compare_on_a_bad_trace_is_one_line_naming_the_file(spoil, names, tmp_path, capsys):
    path = write_trace(tmp_path / "t.csv")
    given = spoil(path)  # spoils the trace, or names another file to give compare
    assert_usage_error(biped(["compare", given if isinstance(given, Path) else path], capsys), *names)


def test_compare_without_a_sidecar_works_with_robot_and_says_so(tmp_path, capsys):
    path = write_trace(tmp_path / "t.csv", sidecar=False)
    result = biped(["compare", path, "--robot", "xl430_biped", "--json"], capsys)
    assert result.code == 0, result.err
    report = json.loads(result.out)
    assert report["ticks"] == 6 and any("no sidecar" in note for note in report["notes"])
    assert "no sidecar" in result.err


# -- a run that started but did not end as asked: exit 1, its last line says why ---------------
def failed_dry_run(*args, **kwargs):
    return {"distance_m": 0.0, "fell": False, "ticks": 3, "overruns": 0, "bus_errors": 0,
            "stop_reason": "error: ZeroDivisionError: division by zero", "reality": "nominal",
            "trace": kwargs.get("trace_path"), "simulated_s": 0.1,
            "torque_off": {"confirmed": list(range(1, 12)), "unconfirmed": []}}


@pytest.mark.parametrize("argv", [["dry-run", "{c}", "--duration", "1"], ["run", "{c}", "--duration", "1"]],
                         ids=["dry-run", "run on the simulated bus"])
def test_a_dry_run_that_stopped_on_an_error_exits_1(argv, controller, monkeypatch, capsys):
    import sim2real.simulation.transfer.dry_run

    monkeypatch.setattr(sim2real.simulation.transfer.dry_run, "dry_run", failed_dry_run)
    result = biped([a.format(c=controller) for a in argv], capsys)
    assert result.code == 1, result.err
    assert result.err.strip().splitlines()[-1] == ("biped: error: the run stopped early: "
                                                   "error: ZeroDivisionError: division by zero")


def test_a_mock_run_that_stopped_on_an_error_exits_1(controller, monkeypatch, capsys):
    import sim2real.hardware.deploy
    import sim2real.hardware.run_report

    monkeypatch.setattr(sim2real.hardware.deploy, "drive",
                        lambda *a, **k: sim2real.hardware.run_report.RunReport(
                            ticks=2, stop_reason="lost communication: servo 4",
                            torque_off=sim2real.hardware.run_report.TorqueOff(confirmed=list(range(1, 12)))))
    result = biped(["run", controller, "--bus", "mock", "--duration", "1"], capsys)
    assert result.code == 1, result.err
    assert result.err.strip().splitlines()[-1] == "biped: error: the run stopped early: lost communication: servo 4"


def test_a_dry_run_that_ended_as_asked_exits_0(controller, monkeypatch, capsys):
    import sim2real.simulation.transfer.dry_run

    monkeypatch.setattr(sim2real.simulation.transfer.dry_run, "dry_run",
                        lambda *a, **k: {**failed_dry_run(), "stop_reason": "duration reached"})
    result = biped(["dry-run", controller, "--duration", "1"], capsys)
    assert (result.code, result.err) == (0, "")


def test_an_opengl_backend_mujoco_cannot_load_is_one_line_naming_the_variable(tmp_path):
    import os
    import subprocess
    import sys

    env = {**os.environ, "MUJOCO_GL": "no-such-backend"}
    done = subprocess.run([sys.executable, "-m", "evolve.cli", "render", "xl430_biped", "-o", str(tmp_path / "a.png")],
                          env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and not (tmp_path / "a.png").exists()
    assert done.stderr.startswith("biped: error: MuJoCo could not load its OpenGL backend MUJOCO_GL=no-such-backend")
    assert "Traceback" not in done.stderr



def test_an_evolution_config_name_too_long_for_the_system_is_unknown_not_an_os_error(capsys):
    result = biped(["evolve", "x" * 300], capsys)
    assert result.code == 2 and "unknown evolution config" in result.err
    # the name is cut, not echoed whole (the list of known configs after it grows with the project)
    assert len(result.err.split(" (known: ")[0]) < 120 and "x" * 100 not in result.err
