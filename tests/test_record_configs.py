"""The experiment configs beside the benchmark records resolve to the configs their runs used.

Issue 49 moved them out of ``configs/evolve/`` (which keeps what a user needs, and ships) into
``benchmarks/records/configs/``, each rewritten as an ``extends:`` of a user config or of another
record config.  ``tests/data/record_configs.json`` holds what each one resolved to before the
move (``load_evolve_config(...).to_dict()``); a record config must keep resolving to it, or
RESULTS.md's commands no longer start the runs it reports.  A field added to the task or NEAT
settings since, at its default, changes nothing and is allowed.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from evolve.config import EvolveConfig, config_path, load_evolve_config

ROOT = Path(__file__).resolve().parent.parent
RECORDS = ROOT / "benchmarks" / "records" / "configs"
USER = ROOT / "configs" / "evolve"
RESOLVED = json.loads((ROOT / "tests" / "data" / "record_configs.json").read_text())
MAX_USER_CONFIGS = 10  # issue 49: configs/evolve/ keeps at most 10 files


def _with_defaults(stored, defaults):
    """``stored`` over today's defaults: a key added since, at its default, is expected too."""
    if isinstance(stored, dict) and isinstance(defaults, dict):
        return {**defaults, **{key: _with_defaults(value, defaults.get(key)) for key, value in stored.items()}}
    return stored


@pytest.mark.parametrize("name", sorted(RESOLVED))
def test_a_record_config_resolves_to_the_config_its_runs_used(name):
    resolved = load_evolve_config(RECORDS / f"{name}.yaml").to_dict()
    expected = _with_defaults(RESOLVED[name], EvolveConfig().to_dict())
    changed = sorted(key for key in expected.keys() | resolved.keys() if expected.get(key) != resolved.get(key))
    assert resolved == expected, (f"{name}.yaml no longer resolves to the config its runs used; it differs in "
                                  f"{changed}: a config it extends changed? pin those keys in the record config")


def test_every_record_config_is_checked_and_none_is_a_user_config():
    here = {p.stem for p in RECORDS.glob("*.yaml")}
    assert here == set(RESOLVED)  # a new record config gets its resolved config stored too
    user = {p.stem for p in USER.glob("*.yaml")}
    assert len(user) <= MAX_USER_CONFIGS and not user & here
    assert {"walk", "train", "stand", "stand_baseline", "reach", "reach_baseline", "walk_hierarchy",
            "walk_human"} <= user


def test_the_package_ships_the_user_configs_only():
    pyproject = (ROOT / "pyproject.toml").read_text()
    shipped = re.findall(r'^"share/biped/configs/evolve" = \[(.*)\]$', pyproject, re.M)
    assert shipped == ['"configs/evolve/*.yaml"'] and "benchmarks/records" not in pyproject


def test_a_record_config_is_not_a_known_name_but_the_error_gives_its_path(monkeypatch):
    monkeypatch.chdir(ROOT)
    with pytest.raises(FileNotFoundError) as caught:
        config_path("walk_straight3")
    message = str(caught.value)
    assert "benchmarks/records/configs/walk_straight3.yaml" in message
    assert "walk_straight3," not in message and "walk_straight3)" not in message  # not among the known names
    assert config_path(str(RECORDS / "walk_straight3.yaml")) == RECORDS / "walk_straight3.yaml"
    with pytest.raises(FileNotFoundError, match="unknown evolution config 'no_such_config'"):
        config_path("no_such_config")
