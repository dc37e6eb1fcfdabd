"""Robot names read from files: looked up among the project's robots, never opened as paths.

A controller (``robot.name``), a trace's sidecar (``robot``) and an evolve config (``robot:``)
name the robot they belong to.  Such a file may come from anyone, so the name in it is only
ever a key into ``configs/robots/`` (``NAME.yaml``, a preset as ``NAME:PRESET``): a name with a
path separator, ``..``, a drive or a NUL, or one that is not a project robot, is refused with
the file and key named and the known robots listed - it is never resolved as a path, and no
byte of whatever file it points at is read.  A robot file elsewhere is given on the command
line (``--robot FILE``, where the command takes it), where the user chose it.

    robot = load_named_robot(data["robot"]["name"], "walker.json", "robot.name")
"""

from __future__ import annotations

import re
from pathlib import Path

from sim2real.errors import ConfigError
from sim2real.robot.loading import available_robots, parse_robot
from sim2real.robot.paths import robots_dir
from sim2real.robot.spec import RobotSpec
from sim2real.robot.validation import load_yaml, show

MAX_ROBOT_NAME = 128  # characters of NAME[:PRESET]; the project's longest is 22
# a robot's or a preset's name: a file stem in configs/robots/, no separator, no leading dot
_PART = re.compile(r"[A-Za-z0-9][A-Za-z0-9_+-]*(\.[A-Za-z0-9_+-]+)*")
ROBOT_FLAG = "--robot FILE"


def named_robot_path(name: object, source: str, key: str, *, flag: str | None = ROBOT_FLAG) -> tuple[Path, str | None]:
    """The project's robot file a name read from ``source`` at ``key`` stands for, and its
    preset: ``(configs/robots/NAME.yaml, PRESET or None)``.  :class:`ConfigError` naming the
    file and the key, listing the known robots (and, with ``flag``, how to give a robot file
    on the command line) for anything else."""
    known = available_robots()

    def refused(problem: str) -> ConfigError:
        hint = (f"; a robot file elsewhere is given on the command line ({flag})" if flag
                else "; this command takes the robot only from the file: put the robot's YAML in "
                f"{robots_dir()} to use it")
        return ConfigError(source, key, f"{problem} (known robots: {', '.join(known)}){hint}")

    if not isinstance(name, str):
        raise refused(f"must be a robot's name, a string, got {type(name).__name__}")
    if not name:
        raise refused("is empty: it must name a robot")
    if len(name) > MAX_ROBOT_NAME:
        raise refused(f"is {len(name)} characters long: a robot's name is at most {MAX_ROBOT_NAME}")
    if _path_like(name):
        raise refused(f"{show(name)} is a path, not a robot's name: a name read from a file is looked up among "
                      "the project's robots and never opened as a file")
    stem, _, preset = name.partition(":")
    if not _PART.fullmatch(stem) or (preset and not _PART.fullmatch(preset)) or name.count(":") > 1:
        raise refused(f"{show(name)} is not a robot's name (letters, digits, '_', '-', '+', '.'; a preset "
                      "after one ':')")
    if stem not in known:
        raise refused(f"names robot {show(stem)}, which is not one of the project's robots")
    return robots_dir() / f"{stem}.yaml", (preset or None)


def load_named_robot(name: object, source: str, key: str, *, flag: str | None = ROBOT_FLAG) -> RobotSpec:
    """The robot a name read from ``source`` at ``key`` stands for (:func:`named_robot_path`),
    read and validated."""
    path, preset = named_robot_path(name, source, key, flag=flag)
    return parse_robot(load_yaml(path), str(path), preset)


def _path_like(name: str) -> bool:
    """A name that a file system would read as a path: a separator (either kind, so a drive
    too), a parent or current folder, a home folder, a NUL or other control character."""
    return any(c in name for c in "/\\\0") or name.startswith(("~", ".")) or ".." in name or not name.isprintable()
