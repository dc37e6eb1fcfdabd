import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")

from sim2real.robot import available_robots  # noqa: E402
from sim2real.robot.validation import load_yaml  # noqa: E402


def all_robot_names() -> list[str]:
    """Every robot config, and every preset of those that have presets."""
    names = []
    for name in available_robots():
        doc = load_yaml(ROOT / "configs" / "robots" / f"{name}.yaml")
        presets = (doc.get("anthropometry") or {}).get("presets")
        names += [f"{name}:{p}" for p in presets] if presets else [name]
    return names


@pytest.fixture
def robots_dir() -> Path:
    return ROOT / "configs" / "robots"
