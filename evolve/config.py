"""An evolution run's configuration: ``configs/evolve/*.yaml``, typed and validated.

    robot: xl430_biped        # a name from configs/robots/ or a path
    seed: 1
    generations: 400
    threads: 0                # 0: every core
    checkpoint_every: 25      # keep a numbered checkpoint this often (the latest is always kept)
    task: {...}               # evolve.locomotion.task.TaskConfig (phase_period_s: auto = from the
                              # robot's leg length, evolve.locomotion.task.gait_period_s)
    neat: {...}               # evolve.neat.NeatConfig
    randomize:                # optional: score every genome on randomized episodes
      reality: randomize      # ranges: a name from configs/reality/, a path, or a mapping
      episodes: 4             # randomized episodes per genome
      score: mean             # mean | worst of them
      shared: false           # true: a generation's genomes all on the same drawn robots
      ramp_generations: 0     # ranges grow from nominal to full over this many generations
      start_generation: 0     # the nominal robot before this generation (the ramp starts here)
      strength: 1.0           # where the ramp stops: 1 = the reality file's ranges (validation is always at 1)
      validation:             # optional: choose the champion on fixed draws selection never sees
        draws: 10             # robots drawn once from the full ranges
        every: 5              # generations between validations (once the harness is off)
        candidates: 8         # that generation's best genomes by selection score
        consistency: 0.8      # optional: a draw counts as walked only if the walk keeps this share
                              # of the candidate's distance on the model (which it must walk too)
      centre: my_robot.yaml   # optional: the ranges around this robot (fixed values, e.g. from
                              # `biped sysid`) instead of the nominal model: scales multiply, the rest adds
      push:                   # optional: pushes in selection's episodes (evolve/locomotion/pushes.py)
        speed_m_s: 0.15       # the largest whole-body speed change of a push (times the ramp)
        every_s: 2.0          # between pushes
    stages: [...]             # optional: a developmental hierarchy (evolve.stages)
    extends: train            # optional: another config (a name in configs/evolve/ or a path beside
                              # this file) that this one changes: mappings merge key by key, this
                              # file's values win; ``extends`` chains up to MAX_EXTENDS deep

On the command line ``biped evolve CONFIG --robot R --set task.episode_s=20 --set neat.population_size=256``
changes a config the same way (:func:`load_evolve_config`'s ``overrides``): ``--set`` takes a dotted
key and a YAML scalar or flow value.

Sizes that allocate are bounded (:mod:`evolve.limits`): population_size <= 10,000,
generations (and a stage's) <= 1,000,000, threads <= 256, episodes <= 64, validation draws
<= 1,000 and candidates <= 64, task.episode_s <= 300 s, at most 16 stages, and a generation's
simulated control ticks (population x episodes x ticks an episode; validation's candidates x
draws x ticks) <= 10 million.  The harness's physical settings have plausible ranges too
(:data:`TASK_RANGES`).
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from evolve.limits import (
    MAX_CANDIDATES,
    MAX_EPISODE_S,
    MAX_EPISODES,
    MAX_GENERATION_TICKS,
    MAX_GENERATIONS,
    MAX_POPULATION,
    MAX_STAGES,
    MAX_THREADS,
    MAX_VALIDATION_DRAWS,
)
from evolve.locomotion.pushes import Pushes
from evolve.locomotion.task import AUTO, TaskConfig
from evolve.neat import NeatConfig
from evolve.stages import Stage, check_stage_joints, parse_stages, with_task
from sim2real.errors import ConfigError
from sim2real.robot import DEFAULT_ROBOT, RobotSpec
from sim2real.robot.names import load_named_robot
from sim2real.robot.spec import JOINT_ANGLE_DEG
from sim2real.robot.timing import control_timing
from sim2real.robot.validation import Node, load_yaml, show, show_key
from sim2real.simulation.model.physique import load_measured, measured
from sim2real.simulation.reality.file import load_reality

TOP_KEYS = ("robot", "seed", "generations", "threads", "checkpoint_every", "task", "neat", "randomize", "stages")
MAX_EXTENDS = 8  # configs a chain of ``extends`` may hold: a few layers are plenty, a loop is refused
INTEGER_KEYS = {"seed": (0, 2**32 - 1), "generations": (1, MAX_GENERATIONS), "threads": (0, MAX_THREADS),
                "checkpoint_every": (0, MAX_GENERATIONS)}
# The support harness's physical settings (task.*): key -> (low, high), both included.
TASK_RANGES: dict[str, tuple[float, float]] = {
    "harness_stiffness": (0.0, 1_000.0),  # body weights per leg length
    "harness_damping": (0.0, 100.0),  # damping ratio
    "harness_max_force": (0.0, 10.0),  # share of the weight, each axis
    "harness_sideways": (0.0, 10.0),  # times the sideways spring-damper
}
PUSH_EVERY_S = (0.05, MAX_EPISODE_S)  # randomize.push.every_s [s]


@dataclass(frozen=True)
class ValidationConfig:
    """Champions chosen on fixed randomized draws that selection never sees.

    With randomized episodes a generation's top score is mostly luck (issue 14 measured a
    run's best by mean of two draws, 2.69 m on its own draws, falling on 9 of 10 new ones),
    so ``best.json`` and the exported controller come from here instead.
    """

    draws: int = 0  # 0: no validation
    every: int = 5  # generations between validations
    candidates: int = 8  # a validated generation's best genomes by selection score
    # (0, 1]: a draw counts as walked only if the walk keeps this share of the distance the
    # candidate walks on the model (the robot the ranges are around), which it must walk too -
    # the transfer check's question (does the robot walk the way the model did?) on every
    # validation robot.  0: off.
    consistency: float = 0.0
    # > 0: a draw counts as walked only if its torso never turned further than this from the
    # start's heading [deg] - a walker that circles is no walker (issue 33)
    heading_deg: float = 0.0
    # > 0: validation episodes this long [s] instead of the task's: long enough to see circling
    episode_s: float = 0.0

    @property
    def active(self) -> bool:
        return self.draws > 0

    def due(self, generation: int, last: int) -> bool:
        """Whether generation ``generation`` (0-based) of a stage of ``last + 1`` is validated."""
        return self.active and ((generation + 1) % self.every == 0 or generation == last)

    def to_dict(self) -> dict[str, Any]:
        out = {"draws": self.draws, "every": self.every, "candidates": self.candidates}
        if self.consistency:
            out["consistency"] = self.consistency
        if self.heading_deg:
            out["heading_deg"] = self.heading_deg
        if self.episode_s:
            out["episode_s"] = self.episode_s
        return out


@dataclass(frozen=True)
class RandomizeConfig:
    reality: str | dict = "nominal"  # configs/reality/ name, path or inline mapping
    episodes: int = 1  # episodes per genome
    score: str = "mean"  # mean | worst
    ramp_generations: int = 0  # ranges grow from nominal to full over this many generations
    start_generation: int = 0  # the nominal robot before this generation; the ramp starts here
    # Where the ramp stops (0, 1]: training on ranges narrower than the test's.  Jakobi's point
    # (realistic noise transfers, maximal noise does not), measured in benchmarks/RESULTS.md.
    strength: float = 1.0
    validation: ValidationConfig = field(default_factory=ValidationConfig)
    centre: str | None = None  # a fixed reality file (e.g. `biped sysid`'s) the ranges are around
    # Common random numbers: every genome of a generation meets the same ``episodes`` robots
    # (new ones each generation), so selection compares genomes, not their luck of the draw.
    shared: bool = False
    # Pushes in selection's episodes (evolve/locomotion/pushes.py): speeds grow with the ramp.
    push: Pushes | None = None

    @property
    def active(self) -> bool:
        return self.reality != "nominal" or self.episodes > 1 or self.centre is not None

    @property
    def profile(self) -> str | dict:
        """What the evaluators draw from: ``reality``, around ``centre`` if one is given."""
        if self.centre is None:
            return self.reality
        return {**load_reality(self.reality).to_dict(), "centre": self.centre}

    def intensity(self, generation: int) -> float:
        """Randomization strength at ``generation`` of a stage: 0 (nominal) before
        ``start_generation``, then growing linearly from 0 to 1 (the reality file's ranges)
        over ``ramp_generations`` (at once without a ramp), up to ``strength``."""
        since = generation - self.start_generation
        if since < 0:
            return 0.0
        return self.strength if self.ramp_generations <= 0 else min(self.strength, since / self.ramp_generations)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"reality": self.reality, "episodes": self.episodes, "score": self.score}
        if self.ramp_generations:
            out["ramp_generations"] = self.ramp_generations
        if self.start_generation:
            out["start_generation"] = self.start_generation
        if self.strength != 1.0:
            out["strength"] = self.strength
        if self.validation.active:
            out["validation"] = self.validation.to_dict()
        if self.centre is not None:
            out["centre"] = self.centre
        if self.shared:
            out["shared"] = True
        if self.push is not None:
            out["push"] = self.push.to_dict()
        return out


def parse_randomize(doc: Any, source: str) -> RandomizeConfig:
    if doc is None:
        return RandomizeConfig()
    node = Node(doc, source, "randomize").mapping(optional=("reality", "episodes", "score", "ramp_generations",
                                                            "start_generation", "validation", "centre",
                                                            "shared", "strength", "push"))
    reality = node.value.get("reality", "nominal")
    if not isinstance(reality, (str, dict)):
        raise node["reality"].error(f"must be a reality name, path or mapping, got {show(reality)}")
    try:
        load_reality(reality)
    except FileNotFoundError as exc:
        raise node["reality"].error(str(exc)) from None
    episodes = node["episodes"].integer(1, MAX_EPISODES) if node.has("episodes") else 1
    score = node["score"].string(("mean", "worst")) if node.has("score") else "mean"
    ramp = node["ramp_generations"].integer(0, MAX_GENERATIONS) if node.has("ramp_generations") else 0
    start = node["start_generation"].integer(0, MAX_GENERATIONS) if node.has("start_generation") else 0
    strength = node["strength"].number(hi=1.0, positive=True) if node.has("strength") else 1.0
    validation = ValidationConfig()
    if node.has("validation"):
        v = node["validation"].mapping(required=("draws",), optional=("every", "candidates", "consistency",
                                                                       "heading_deg", "episode_s"))
        validation = ValidationConfig(
            draws=v["draws"].integer(1, MAX_VALIDATION_DRAWS),
            every=v["every"].integer(1, MAX_GENERATIONS) if v.has("every") else ValidationConfig.every,
            candidates=v["candidates"].integer(1, MAX_CANDIDATES) if v.has("candidates") else ValidationConfig.candidates,
            consistency=v["consistency"].number(hi=1.0, positive=True) if v.has("consistency") else 0.0,
            heading_deg=v["heading_deg"].number(hi=180.0, positive=True, unit="deg") if v.has("heading_deg") else 0.0,
            episode_s=v["episode_s"].number(hi=MAX_EPISODE_S, positive=True, unit="s") if v.has("episode_s") else 0.0)
        if reality == "nominal":
            raise v.error("validates on randomized draws: give randomize.reality (ranges to draw from)")
    centre = None
    if node.has("centre"):
        centre = node["centre"].string()
        try:
            load_reality(centre)
        except FileNotFoundError as exc:
            raise node["centre"].error(str(exc)) from None
    shared = node["shared"].boolean() if node.has("shared") else False
    push = None
    if node.has("push"):
        v = node["push"].mapping(required=("speed_m_s",), optional=("every_s",))
        push = Pushes(v["speed_m_s"].number(positive=True, hi=2.0, unit="m/s"),
                      v["every_s"].number(*PUSH_EVERY_S, unit="s") if v.has("every_s") else Pushes.every_s)
        if reality == "nominal":
            raise v.error("pushes come with the randomization's ramp: give randomize.reality (ranges to draw from)")
    config = RandomizeConfig(reality, episodes, score, ramp, start, strength=strength, validation=validation,
                             centre=centre, shared=shared, push=push)
    load_reality(config.profile)  # a centre of ranges, not fixed values, is refused here, by name
    return config


@dataclass(frozen=True)
class EvolveConfig:
    robot: str = DEFAULT_ROBOT
    seed: int = 1
    generations: int = 400
    threads: int = 0
    checkpoint_every: int = 25
    task: TaskConfig = field(default_factory=TaskConfig)
    neat: NeatConfig = field(default_factory=NeatConfig)
    randomize: RandomizeConfig = field(default_factory=RandomizeConfig)
    stages: tuple[Stage, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        out = {"robot": self.robot, "seed": self.seed, "generations": self.generations,
               "threads": self.threads, "checkpoint_every": self.checkpoint_every,
               "task": self.task.to_dict(), "neat": self.neat.to_dict()}
        if self.randomize.active:
            out["randomize"] = self.randomize.to_dict()
        if self.stages:
            out["stages"] = [s.to_dict() for s in self.stages]
        return out

    def to_yaml(self) -> str:
        return yaml.safe_dump(self.to_dict(), sort_keys=False)

    def replace(self, **changes: Any) -> "EvolveConfig":
        return dataclasses.replace(self, **changes)


def parse_evolve_config(doc: Any, source: str, robot_file: str | None = None) -> EvolveConfig:
    """A config document checked whole.  Its ``robot`` is a project robot's name - a config may
    come from anyone, and a name in it is never opened as a path - unless it is ``robot_file``,
    the robot (a name or a file) the user gave on the command line (``--robot``)."""
    if doc is None:
        doc = {}
    if not isinstance(doc, dict):
        raise ConfigError(source, "", "must be a mapping")
    for key in doc:
        if key not in TOP_KEYS:
            raise ConfigError(source, show_key(key), f"unknown key {show(key)} (allowed: {', '.join(TOP_KEYS)})")
    root = Node(doc, source)
    values: dict[str, Any] = {}
    for key, (lo, hi) in INTEGER_KEYS.items():
        if key in doc:
            values[key] = root[key].integer(lo, hi)
    if "robot" in doc:
        values["robot"] = root["robot"].string()
    try:
        robot = _config_robot(values.get("robot"), source, robot_file)
    except FileNotFoundError as exc:
        raise ConfigError(source, "robot", str(exc)) from None
    # ``phase_period_s: auto``: the gait clock's period from this robot's leg length (measured
    # on the compiled model for a robot from a model file: only when asked for)
    task = doc.get("task")
    auto = isinstance(task, dict) and task.get("phase_period_s") == AUTO
    values["task"] = TaskConfig.from_mapping(task, source, "task.", leg_length_m=robot.leg_length if auto else None)
    for key, (lo, hi) in TASK_RANGES.items():
        value = getattr(values["task"], key)
        if not lo <= value <= hi:
            raise ConfigError(source, f"task.{key}", f"must be within [{lo:g}, {hi:g}], got {value:g}")
    control_set = values["task"].control_set
    if control_set not in robot.control_sets:
        raise ConfigError(source, "task.control_set", f"robot {robot.name} has no control set {show(control_set)} "
                          f"(it has: {', '.join(robot.control_sets)})")
    values["neat"] = NeatConfig.from_mapping(doc.get("neat"), source, "neat.")
    if values["neat"].population_size > MAX_POPULATION:
        raise ConfigError(source, "neat.population_size", f"must be <= {MAX_POPULATION}, got "
                          f"{values['neat'].population_size} (memory grows with it)")
    values["randomize"] = parse_randomize(doc.get("randomize"), source)
    values["stages"] = parse_stages(doc.get("stages"), source)
    check_stage_joints(values["stages"], robot.control_sets[control_set], source)
    values["stages"] = with_task(values["stages"], values["task"], robot, source)
    _check_stages(values["stages"], source)
    config = EvolveConfig(**values)
    check_sizes(config, robot, source)
    return config


def _check_stages(stages: tuple[Stage, ...], source: str) -> None:
    if len(stages) > MAX_STAGES:
        raise ConfigError(source, "stages", f"at most {MAX_STAGES} stages (each a module and a folder), "
                          f"got {len(stages)}")
    lo, hi = JOINT_ANGLE_DEG
    for i, stage in enumerate(stages):
        if stage.generations > MAX_GENERATIONS:
            raise ConfigError(source, f"stages[{i}].generations", f"must be <= {MAX_GENERATIONS}, got "
                              f"{stage.generations}")
        for joint, angle in stage.target_pose_deg.items():
            if not lo <= angle <= hi:
                raise ConfigError(source, f"stages[{i}].target_pose_deg.{show(joint)}",
                                  f"must be within [{lo:g}, {hi:g}] deg, got {angle:g}")


def _config_robot(named: str | None, source: str, robot_file: str | None) -> RobotSpec:
    """The robot a config names, measured: the command line's ``robot_file`` if it names that
    (the same text or the same real path), else a project robot by name only."""
    if named is None:
        return load_measured(DEFAULT_ROBOT)
    if robot_file is not None and (named == robot_file or os.path.realpath(named) == os.path.realpath(robot_file)):
        return load_measured(robot_file)  # chosen by the user, on the command line
    return measured(load_named_robot(named, source, "robot"))


def robot_is_a_file(config: EvolveConfig) -> bool:
    """Whether the config's robot is a file given on the command line (not a project robot's
    name): resuming its run needs ``--robot FILE`` again."""
    from sim2real.robot import available_robots

    return config.robot.split(":", 1)[0] not in available_robots()


def check_sizes(config: EvolveConfig, robot: RobotSpec, source: str) -> None:
    """Refuse a generation that would simulate more than ``MAX_GENERATION_TICKS`` control
    ticks (population x episodes, or validation's candidates x draws, times an episode's
    ticks): its memory (noise drawn per tick) and time grow with it.  The command line
    calls it again after its flags change the config."""
    ticks = int(round(config.task.episode_s / control_timing(robot).tick_s))
    r = config.randomize
    sims = [(config.neat.population_size * r.episodes, f"population {config.neat.population_size} x "
             f"{r.episodes} episodes")]
    if r.validation.active:
        sims.append((r.validation.candidates * r.validation.draws, f"validation's {r.validation.candidates} "
                     f"candidates x {r.validation.draws} draws"))
    for n, what in sims:
        if n * ticks > MAX_GENERATION_TICKS:
            raise ConfigError(source, "", f"{what} x {ticks} ticks an episode (task.episode_s "
                              f"{config.task.episode_s:g} s) is {n * ticks:,} control ticks a generation; at most "
                              f"{MAX_GENERATION_TICKS:,} (memory and time grow with it)")


def load_evolve_config(path: Path | str, overrides: dict[str, Any] | None = None) -> EvolveConfig:
    """The config in ``path``, its ``extends`` chain merged under it, then ``overrides`` (dotted
    keys, as :func:`parse_override` gives them) set on top."""
    doc = _extended(Path(path), [])
    source = str(path)
    for key, value in (overrides or {}).items():
        doc = _set(doc, key.split("."), value, source, key)
        source = f"{path} with --set"
    given = (overrides or {}).get("robot")  # from the command line: may be a robot file
    return parse_evolve_config(doc, source, robot_file=given if isinstance(given, str) else None)


def config_path(name: str) -> Path:
    """A config's file: ``name`` as a path if it exists, else ``configs/evolve/<name>.yaml``;
    FileNotFoundError listing the known names (and, for an experiment config of the records,
    its path: those are given by path, they are not a user's)."""
    import os

    from sim2real.input_files import check_regular_file
    from sim2real.robot.paths import data_root
    from sim2real.robot.validation import show_name

    path = Path(name)
    if os.path.lexists(path):
        return check_regular_file(path)  # a FIFO would block the read, a device never end
    folder = data_root() / "configs" / "evolve"
    candidate = folder / f"{name}.yaml"
    if "/" not in name and os.path.exists(candidate):  # not Path.exists: a name too long for the system raises there
        return candidate
    known = ", ".join(sorted(p.stem for p in folder.glob("*.yaml")))
    record = data_root() / "benchmarks" / "records" / "configs" / f"{name}.yaml"  # in a clone only: not installed
    if "/" not in name and os.path.exists(record):
        here = Path(os.path.abspath("."))
        shown = record.relative_to(here) if record.is_relative_to(here) else record
        raise FileNotFoundError(f"{show_name(name)} is an experiment config of the benchmark records: give its "
                                f"path, {shown} (user configs: {known})")
    raise FileNotFoundError(f"unknown evolution config {show_name(name)} (known: {known}; or give a path)")


def parse_override(text: str) -> tuple[str, Any]:
    """``KEY=VALUE`` of ``--set``: a dotted key of known words and a YAML value; ValueError saying why."""
    from sim2real.robot.validation import parse_yaml

    key, sep, value = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ValueError(f"{text!r}: expected KEY=VALUE, e.g. task.episode_s=20")
    parts = key.split(".")
    if parts[0] not in TOP_KEYS or any(not p.replace("_", "").isalnum() for p in parts) or len(parts) > 4:
        raise ValueError(f"{key!r}: not a config key (top-level keys: {', '.join(TOP_KEYS)}; nested ones "
                         "with dots, e.g. task.phase_period_s)")
    try:
        parsed = parse_yaml(value, f"--set {key}") if value.strip() else ""
    except ConfigError as exc:
        raise ValueError(f"{key}: {exc.problem}") from None
    return key, parsed


def _extended(path: Path, chain: list[Path]) -> Any:
    """``path``'s document with the configs it ``extends`` merged under it."""
    doc = load_yaml(path)
    if not isinstance(doc, dict) or "extends" not in doc:
        return doc
    here = Path(path).resolve()
    if here in chain:
        raise ConfigError(str(path), "extends", "a loop: " + " -> ".join(str(p) for p in (*chain, here)))
    if len(chain) + 1 >= MAX_EXTENDS:
        raise ConfigError(str(path), "extends", f"more than {MAX_EXTENDS} configs in one chain of extends")
    parent_name = doc.pop("extends")
    if not isinstance(parent_name, str) or not parent_name:
        raise ConfigError(str(path), "extends", f"must name a config, got {type(parent_name).__name__}")
    beside = Path(path).parent / parent_name
    try:
        parent = beside if beside.suffix in (".yaml", ".yml") and beside.exists() else config_path(parent_name)
    except FileNotFoundError as exc:
        raise ConfigError(str(path), "extends", str(exc)) from None
    return _merged(_extended(parent, [*chain, here]), doc)


def _merged(base: Any, top: Any) -> Any:
    """``top`` over ``base``: mappings merge key by key; anything else, ``top`` wins."""
    if not isinstance(base, dict) or not isinstance(top, dict):
        return top
    out = dict(base)
    for key, value in top.items():
        out[key] = _merged(base.get(key), value)
    return out


def _set(doc: Any, parts: list[str], value: Any, source: str, key: str) -> dict[str, Any]:
    """``doc`` with ``value`` at the dotted key ``parts`` (mappings made where missing)."""
    doc = dict(doc) if isinstance(doc, dict) else {}
    if len(parts) == 1:
        doc[parts[0]] = value
        return doc
    inner = doc.get(parts[0])
    if inner is not None and not isinstance(inner, dict):
        raise ConfigError(source, key, f"{parts[0]} is not a mapping in this config; cannot set {key}")
    doc[parts[0]] = _set(inner or {}, parts[1:], value, source, key)
    return doc
