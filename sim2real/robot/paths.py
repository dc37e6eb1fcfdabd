"""Where the project's data lives: ``firmware_profiles/`` and ``configs/``.

A clone (or editable install) reads them beside the packages; a wheel install
reads them from ``<prefix>/share/biped``; ``BIPED_DATA_DIR`` overrides both.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path


def data_root() -> Path:
    """The folder holding ``firmware_profiles/`` and ``configs/``."""
    candidates = []
    if os.environ.get("BIPED_DATA_DIR"):
        candidates.append(Path(os.environ["BIPED_DATA_DIR"]))
    candidates.append(Path(__file__).resolve().parents[2])  # sim2real/robot/paths.py -> the clone
    candidates.append(Path(sys.prefix) / "share" / "biped")
    for root in candidates:
        if (root / "firmware_profiles").is_dir():
            return root
    raise FileNotFoundError(
        "cannot find the firmware_profiles/ folder; looked in "
        + ", ".join(str(c) for c in candidates)
        + " (set BIPED_DATA_DIR to the project folder)"
    )


def profiles_dir() -> Path:
    return data_root() / "firmware_profiles"


def robots_dir() -> Path:
    return data_root() / "configs" / "robots"


def shipped_controller(robot_name: str) -> Path:
    """Where the project's own walker for a robot lives (``configs/controllers/<robot>.json``;
    it may not exist: only robots with a robust walker have one)."""
    return data_root() / "configs" / "controllers" / f"{robot_name.replace(':', '_')}.json"
