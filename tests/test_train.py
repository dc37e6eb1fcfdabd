"""``biped train``: every stage on a robot with no config of its own, Ctrl-C and resume, the
provenance of what it ships, and bad input refused before anything runs.

The smoke training is small (a budget of 3 min: far too short for a walker, long enough on a
slow machine for its polish to begin before the cut): it checks the machinery - stages,
resume, provenance, progress - not the walker, which the benchmark
(``python -m benchmarks.robust_walk``) measures.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from evolve.locomotion.task import gait_period_s
from evolve.train import STAGES
from robots.urdf_humanoid import write_humanoid

ROOT = Path(__file__).resolve().parent.parent


def biped(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "evolve.cli", *args], capture_output=True, text=True,
                          timeout=kw.pop("timeout", 120), **kw)


@pytest.fixture(scope="module")
def imported(tmp_path_factory) -> Path:
    """The tests' URDF humanoid, imported as a user would: a robot with no config of its own."""
    folder = tmp_path_factory.mktemp("imported")
    files = write_humanoid(folder)
    out = biped("robot", "import", str(files.urdf), "--out", str(folder / "humanoid.yaml"))
    assert out.returncode == 0, out.stderr
    return folder / "humanoid.yaml"


@pytest.fixture(scope="module")
def trained(imported, tmp_path_factory) -> tuple[Path, str, str]:
    """A training cut by SIGINT in its polish stage, then resumed to the end: (folder, the first
    run's stderr, the resumed run's stdout + stderr)."""
    out = tmp_path_factory.mktemp("train") / "run"
    cmd = [sys.executable, "-m", "evolve.cli", "train", str(imported), "--out", str(out), "--minutes", "3",
           "--seed", "3", "--threads", "2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    first = []
    deadline = time.monotonic() + 600
    for line in proc.stderr:  # the progress lines
        first.append(line)
        if line.startswith("[polish") and "weights," in line:  # the polish has begun its search
            break
        assert time.monotonic() < deadline, "no polish stage within 10 min:\n" + "".join(first)
    else:  # NEAT overran the polish's share of the budget: nothing to cut
        proc.wait(timeout=600)
        pytest.fail("the training ended before its polish began:\n" + "".join(first))
    proc.send_signal(signal.SIGINT)
    rest_out, rest_err = proc.communicate(timeout=120)
    first.append(rest_err)
    assert proc.returncode == 130, "".join(first)
    assert "--resume" in rest_err
    resumed = biped("train", str(imported), "--out", str(out), "--minutes", "3", "--seed", "3", "--resume",
                    timeout=900)
    assert resumed.returncode == 0, resumed.stderr
    return out, "".join(first), resumed.stdout + resumed.stderr


def test_a_cut_training_resumes_without_redoing_a_finished_stage(trained):
    out, first, resumed = trained
    state = json.loads((out / "train.json").read_text())
    assert list(state["stages"]) == list(STAGES)
    assert "[neat" in first and "[neat" not in resumed  # NEAT finished before the cut: not run again
    # the cut polish goes on: from its checkpoint, or afresh when cut before its first update ended
    assert "[polish" in resumed and ("resumed at update" in resumed or "weights," in resumed)
    for name in STAGES:
        assert state["stages"][name]["wall_minutes"] >= 0 and state["stages"][name]["cpu_minutes"] >= 0
    assert state["elapsed_s"] > 0 and "cut" not in state
    first_session, second = state["sessions"]  # each session's command and budget
    assert "--resume" in second["command"] and "--resume" not in first_session["command"]
    assert first_session["from_minute"] == 0 and 0 < second["from_minute"] < state["elapsed_s"] / 60
    # the cut polish's minutes count both sessions: at least the polish's own clock, which resumes
    assert state["stages"]["polish"]["wall_minutes"] >= state["stages"]["polish"]["minutes"] * 0.99
    assert state["cpu_s"] / 60 >= sum(state["stages"][name]["cpu_minutes"] for name in STAGES) * 0.99
    assert state["elapsed_s"] / 60 >= sum(state["stages"][name]["wall_minutes"] for name in STAGES) * 0.99


def test_the_trained_controller_carries_its_command_stages_and_measures(trained, imported):
    out, _, resumed = trained
    provenance = json.loads((out / "controller.json").read_text())["provenance"]
    assert provenance["made_by"].startswith("biped train")
    made = provenance["trained"]
    assert made["robot"] == str(imported.resolve()) and made["settings"]["seed"] == 3
    assert set(made["stages"]) == set(STAGES) - {"measure"}  # (written by the measure stage itself)
    assert 0 <= provenance["walk_rate"]["share"] <= 1 and provenance["walk_rate"]["robots"] == 50
    assert set(provenance["sustained"]) == {"nominal", "default"}
    assert set(provenance["bar"]) == {"walk_rate", "straight", "speed", "transfer"}
    assert f"biped dry-run {out / 'controller.json'} --robot {imported.resolve()}" in resumed  # what to run next
    # the controller runs where a user takes it next: through the runtime on the mock bus
    ran = biped("run", str(out / "controller.json"), "--robot", str(imported), "--bus", "mock", "--duration", "0.5")
    assert ran.returncode == 0, ran.stderr


def test_progress_lines_name_the_stage_and_the_minutes_left(trained):
    _, first, resumed = trained
    lines = [line for line in (first + resumed).splitlines() if line.startswith("[")]
    stages = {line[1:].split()[0] for line in lines}
    assert {"neat", "polish", "measure"} <= stages
    assert all(" min, ~" in line and " left]" in line for line in lines)
    # the folder keeps them, both sessions' (the cut one's up to its last line before the signal)
    kept = (trained[0] / "log.txt").read_text().splitlines()
    assert lines[0] == kept[0] and lines[-1] == kept[-1] and set(lines) <= set(kept)


def test_the_gait_clock_follows_the_leg_length():
    assert gait_period_s(0.245) == 0.6
    assert gait_period_s(0.279) == pytest.approx(0.64, abs=0.005)  # the OP3 recipe's hand-scaled period
    assert gait_period_s(4 * 0.245) == pytest.approx(1.2)


@pytest.mark.parametrize("args, problem", [
    (["no_such_robot"], "no_such_robot"),
    (["xl430_biped", "--minutes", "0"], "--minutes"),
    (["xl430_biped", "--minutes", "nan"], "--minutes"),
    (["xl430_biped", "--threads", "-1"], "--threads"),
    (["xl430_biped", "--resume"], "--resume needs --out"),
    (["xl430_biped", "--config", "no_such_config", "--out", "{tmp}/x"], "no_such_config"),
])
def test_bad_flags_are_refused_before_anything_runs(tmp_path, args, problem):
    out = biped("train", *[a.format(tmp=tmp_path) for a in args])
    assert out.returncode == 2, out.stderr
    assert problem in out.stderr and "Traceback" not in out.stderr
    assert not (tmp_path / "x").exists()


def test_a_folder_in_use_or_full_is_refused_and_left_as_it_was(tmp_path):
    from sim2real.run_lock import RunLock

    busy = tmp_path / "busy"
    busy.mkdir()
    with RunLock.acquire(busy):
        out = biped("train", "xl430_biped", "--out", str(busy))
        assert out.returncode == 2 and "another biped train is working in this folder" in out.stderr
        assert sorted(p.name for p in busy.iterdir()) == [".lock"]  # nothing of its own written
    full = tmp_path / "full"
    full.mkdir()
    (full / "mine.txt").write_text("keep me")
    out = biped("train", "xl430_biped", "--out", str(full))
    assert out.returncode == 2 and "already holds files" in out.stderr
    assert (full / "mine.txt").read_text() == "keep me" and sorted(p.name for p in full.iterdir()) == ["mine.txt"]


def test_a_resume_with_other_settings_is_refused(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    state = {"version": 1, "robot": "xl430_biped", "command": "biped train xl430_biped", "elapsed_s": 12.0,
             "settings": {"minutes": 60.0, "seed": 1, "threads": 2, "config": "train"}, "stages": {}}
    (out / "train.json").write_text(json.dumps(state))
    for args, problem in ((["--seed", "2"], "seed"), ([], None)):
        robot = "op3" if problem is None else "xl430_biped"
        done = biped("train", robot, "--out", str(out), "--resume", *args)
        assert done.returncode == 2, done.stderr
        assert "Resume with the same robot" in done.stderr
    assert json.loads((out / "train.json").read_text()) == state  # nothing lost
    nothing = biped("train", "xl430_biped", "--out", str(tmp_path / "none"), "--resume")
    assert nothing.returncode == 2 and "does not exist" in nothing.stderr
    assert not (tmp_path / "none").exists()


def test_the_train_config_is_the_recipe_for_any_robot():
    """``configs/evolve/train.yaml`` loads for every shipped walking robot: the control set it
    names exists there, and its sizes pass the generation bound at each robot's tick."""
    from evolve.train import TrainSettings, neat_config

    for robot in ("xl430_biped", "op3"):
        config = neat_config(robot, TrainSettings(seed=5, threads=1))
        assert config.robot == robot and config.seed == 5 and config.threads == 1
        assert config.task.phase_period_s > 0

