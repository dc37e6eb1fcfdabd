"""Evolution configs as changes to others: ``extends:``, ``--set KEY=VALUE`` and ``--robot``."""

from __future__ import annotations

import subprocess
import sys

import pytest

from evolve.config import MAX_EXTENDS, load_evolve_config, parse_override
from sim2real.errors import ConfigError


def test_a_config_extends_another_key_by_key(tmp_path):
    (tmp_path / "child.yaml").write_text("extends: train\nneat: {population_size: 16, target_species: 2}\n"
                                         "task: {episode_s: 4}\n")
    base = load_evolve_config("configs/evolve/train.yaml")
    child = load_evolve_config(tmp_path / "child.yaml")
    assert child.neat.population_size == 16 and child.task.episode_s == 4.0
    # everything it does not name comes from its parent, nested keys included
    assert child.task.phase_period_s == base.task.phase_period_s and child.neat.compat_threshold == 0.6
    assert child.randomize == base.randomize
    (tmp_path / "grandchild.yaml").write_text("extends: child.yaml\nseed: 9\n")  # a file beside it
    assert load_evolve_config(tmp_path / "grandchild.yaml").neat.population_size == 16


def test_a_loop_or_a_chain_too_long_is_refused(tmp_path):
    (tmp_path / "a.yaml").write_text("extends: b.yaml\n")
    (tmp_path / "b.yaml").write_text("extends: a.yaml\n")
    with pytest.raises(ConfigError, match="a loop"):
        load_evolve_config(tmp_path / "a.yaml")
    for i in range(MAX_EXTENDS + 1):
        (tmp_path / f"c{i}.yaml").write_text(f"extends: c{i + 1}.yaml\n" if i < MAX_EXTENDS else "seed: 1\n")
    with pytest.raises(ConfigError, match=f"more than {MAX_EXTENDS}"):
        load_evolve_config(tmp_path / "c0.yaml")
    (tmp_path / "d.yaml").write_text("extends: no_such_config\n")
    with pytest.raises(ConfigError, match="unknown evolution config"):
        load_evolve_config(tmp_path / "d.yaml")


def test_set_changes_one_value_and_robot_the_robot():
    config = load_evolve_config("configs/evolve/train.yaml", {"robot": "op3", "task.episode_s": 5.0,
                                                              "randomize.validation.draws": 12})
    assert config.robot == "op3" and config.task.episode_s == 5.0 and config.randomize.validation.draws == 12
    assert parse_override("neat.population_size=64") == ("neat.population_size", 64)
    assert parse_override("task.gyro_input=false") == ("task.gyro_input", False)
    for bad in ("nokey", "=3", "foo.bar=1", "task..x=1", "task.a.b.c.d=1"):
        with pytest.raises(ValueError):
            parse_override(bad)
    with pytest.raises(ConfigError, match="unknown task parameter"):
        load_evolve_config("configs/evolve/train.yaml", {"task.nope": 1})


@pytest.mark.parametrize("args, problem", [
    (["walk", "--set", "foo=1"], "not a config key"),
    (["walk", "--set", "task.episode_s=-1"], "task.episode_s"),
    (["walk", "--robot", "no_such_robot"], "no_such_robot"),
    (["--resume", "--out", "x", "--set", "seed=2"], "do not give a config or --set"),
])
def test_bad_overrides_are_refused_on_the_command_line(tmp_path, args, problem):
    out = subprocess.run([sys.executable, "-m", "evolve.cli", "evolve", *args], capture_output=True, text=True,
                         cwd=tmp_path, timeout=60)
    assert out.returncode == 2 and problem in out.stderr, out.stderr
    assert "Traceback" not in out.stderr


def test_phase_period_auto_is_the_gait_clock_of_the_robots_leg():
    """``phase_period_s: auto`` (train.yaml's) scales the XL430 biped's 0.6 s by the square root of
    the leg length: 0.64 s on OP3, what its recipe's configs set by hand; a number stays as given."""
    from evolve.locomotion.task import TaskConfig, gait_period_s
    from sim2real.simulation.model.physique import load_measured

    assert load_evolve_config("configs/evolve/train.yaml").task.phase_period_s == 0.6
    op3 = load_evolve_config("configs/evolve/train.yaml", {"robot": "op3"})
    assert op3.task.phase_period_s == 0.64 == gait_period_s(load_measured("op3").leg_length)
    assert op3.to_dict()["task"]["phase_period_s"] == 0.64  # a run's config.yaml holds the number
    walk = load_evolve_config("configs/evolve/walk.yaml", {"robot": "op3", "task.phase_period_s": "auto"})
    assert walk.task.phase_period_s == 0.64
    fixed = load_evolve_config("configs/evolve/walk.yaml", {"robot": "op3", "task.phase_period_s": 0.6})
    assert fixed.task.phase_period_s == 0.6
    with pytest.raises(ConfigError, match="task.phase_period_s: 'auto' needs a robot"):
        TaskConfig.from_mapping({"phase_period_s": "auto"}, "controller.json")  # a controller holds the number
    with pytest.raises(ConfigError, match="task.phase_period_s"):
        load_evolve_config("configs/evolve/walk.yaml", {"task.phase_period_s": "automatic"})
