"""What a training's record (``DIR/train.json``) says, read back: which of its walkers ships,
which are the measure stage's fallbacks, and the short forms its stages and provenance keep.
Functions of the record's dictionary and the walker files it names (see :mod:`evolve.train` for the
stages that write it)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sim2real.input_files import file_sha256

STATE = "train.json"  # in the training folder: the settings and each finished stage
STATE_VERSION = 1


def new_record(robot_name: str, settings: dict[str, Any], command: str | None) -> dict[str, Any]:
    """A training's record before its first stage (``settings``: its TrainSettings as a dict)."""
    return {"version": STATE_VERSION, "robot": robot_name, "command": command or "biped train",
            "settings": settings, "stages": {}, "elapsed_s": 0.0, "cpu_s": 0.0}


def robust_walker(state: dict[str, Any]) -> str | None:
    """The newest walker that passed the robustness bar: the polish's, else NEAT's (None: none)."""
    stages = state["stages"]
    if stages.get("polish", {}).get("walker"):
        return stages["polish"]["walker"]
    return stages["neat"]["walker"] if stages["neat"]["robust"] else None


def latest_walker(state: dict[str, Any], skip_speed: bool = False) -> str:
    """The walker to ship: the transfer polish's walker, else the speed stage's, else the newest
    robust one; with none robust, the weights the walk-rate polish's validation kept, else NEAT's
    champion.  ``skip_speed``: the walker before the speed and transfer stages."""
    stages = state["stages"]
    for name in ("transfer", "speed") if not skip_speed else ():
        if stages.get(name, {}).get("walker"):
            return stages[name]["walker"]
    return robust_walker(state) or stages.get("polish", {}).get("kept") or stages["neat"]["walker"]


def earlier_walkers(state: dict[str, Any]) -> list[Path]:
    """Every robust walker the polish stages kept, newest first (the transfer polish's, the speed
    polish's, the faster gait clock it started from, then the walk-rate polish's), then NEAT's
    robust champion: where the measure stage looks when its walker misses the bar."""
    stages = state["stages"]
    speed = stages.get("speed", {})

    def kept(records: list[dict[str, Any]]) -> list[Path]:
        return [Path(r["walker"]).parent / f"robust_update{t['update']}.json"
                for r in records if r.get("walker") for t in reversed(r.get("tests", [])) if t["robust"]]

    found = kept([stages.get("transfer", {})])
    found += kept(list(reversed(speed.get("runs", []))))
    found += [Path(speed["cadence"]["walker"])] if (speed.get("cadence") or {}).get("walker") else []
    found += kept([stages.get("polish", {})])
    found += [Path(stages["neat"]["walker"])] if stages["neat"]["robust"] else []
    return [path for path in found if path.exists()]


def transfer_check_of(state: dict[str, Any], walker: Path) -> dict[str, Any]:
    """The transfer check the transfer stage made (of its source or of a walker it kept) of the
    same file as ``walker`` (by :func:`~sim2real.input_files.file_sha256`), for the measure stage to reuse; {} if none."""
    stage = state["stages"].get("transfer", {})
    made = [stage.get("source_check")] + [t.get("accepted") for t in stage.get("tests", [])]
    digest = file_sha256(walker)
    return next((c for c in made if c and c.get("sha256") == digest), {})


def short_test(test: dict[str, Any]) -> dict[str, Any]:
    """A robustness test (:func:`evolve.walk_measures.robustness`) as a stage's record keeps it."""
    return {"randomized_walked": test["randomized"]["walked"], "default_walked": test["default"]["walked"]}


def stage_summary(record: dict[str, Any]) -> dict[str, Any]:
    """A stage's record without its long lists (what a controller's provenance carries)."""
    return {k: v for k, v in record.items() if k not in ("tests", "history", "runs", "measures", "transfer")}
