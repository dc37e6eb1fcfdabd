"""An evolution run's configuration: ``configs/evolve/*.yaml``, typed and validated.

    robot: xl430_biped        # a name from configs/robots/ or a path
    seed: 1
    generations: 400
    threads: 0                # 0: every core
    checkpoint_every: 25      # keep a numbered checkpoint this often (the latest is always kept)
    task: {...}               # evolve.locomotion.task.TaskConfig
    neat: {...}               # evolve.neat.NeatConfig
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from evolve.locomotion.task import TaskConfig
from evolve.neat import NeatConfig
from sim2real.errors import ConfigError
from sim2real.robot import DEFAULT_ROBOT
from sim2real.validation import load_yaml

TOP_KEYS = ("robot", "seed", "generations", "threads", "checkpoint_every", "task", "neat")


@dataclass(frozen=True)
class EvolveConfig:
    robot: str = DEFAULT_ROBOT
    seed: int = 1
    generations: int = 400
    threads: int = 0
    checkpoint_every: int = 25
    task: TaskConfig = field(default_factory=TaskConfig)
    neat: NeatConfig = field(default_factory=NeatConfig)

    def to_dict(self) -> dict[str, Any]:
        return {"robot": self.robot, "seed": self.seed, "generations": self.generations,
                "threads": self.threads, "checkpoint_every": self.checkpoint_every,
                "task": self.task.to_dict(), "neat": self.neat.to_dict()}

    def to_yaml(self) -> str:
        return yaml.safe_dump(self.to_dict(), sort_keys=False)

    def replace(self, **changes: Any) -> "EvolveConfig":
        return dataclasses.replace(self, **changes)


def parse_evolve_config(doc: Any, source: str) -> EvolveConfig:
    if doc is None:
        doc = {}
    if not isinstance(doc, dict):
        raise ConfigError(source, "", "must be a mapping")
    for key in doc:
        if key not in TOP_KEYS:
            raise ConfigError(source, str(key), f"unknown key {key!r} (allowed: {', '.join(TOP_KEYS)})")
    values: dict[str, Any] = {}
    for key in ("seed", "generations", "threads", "checkpoint_every"):
        if key in doc:
            value = doc[key]
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ConfigError(source, key, f"must be a non-negative integer, got {value!r}")
            values[key] = value
    if "robot" in doc:
        if not isinstance(doc["robot"], str):
            raise ConfigError(source, "robot", f"must be a robot name or path, got {doc['robot']!r}")
        values["robot"] = doc["robot"]
    values["task"] = TaskConfig.from_mapping(doc.get("task"), source, "task.")
    values["neat"] = NeatConfig.from_mapping(doc.get("neat"), source, "neat.")
    return EvolveConfig(**values)


def load_evolve_config(path: Path | str) -> EvolveConfig:
    return parse_evolve_config(load_yaml(Path(path)), str(path))
