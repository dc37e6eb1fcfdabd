"""A polish stage of ``biped train`` (:mod:`evolve.train`): CMA-ES on a walker's weights
(:func:`evolve.polish.polish`) until a plateau or its share of the training's budget, each
walker its validation keeps tested against the robustness bar, the robust ones kept as the
measure stage's fallbacks.  The walk-rate polish and the speed polish and its restart are each
one of these."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from evolve.train_record import short_test
from sim2real.atomic_json import copy_file_atomic, read_json, write_json_atomic

if TYPE_CHECKING:  # pragma: no cover
    from evolve.train import Budget, TrainSettings

MAX_UPDATES = 100_000  # a stage's update cap; the budget ends it long before
PATIENCE = 4  # validations (5 updates each) without a kept walker before a polish stage stops


def polish_stage(source: Path, folder: Path, settings: TrainSettings, budget: Budget,
                 until: float | Callable[[], float], log: Callable[[str], None], stage: dict[str, Any],
                 robot: str | None = None,
                 patience: int | Callable[[], int | None] | None = PATIENCE,
                 accept: Callable[[Path], dict[str, Any]] | None = None) -> dict[str, Any]:
    """Polish ``source`` in ``folder`` until a plateau (``patience`` validations keeping nothing;
    None: none; a function: asked at each validation) or ``until`` (a share of the budget, or a
    function giving it) is spent, testing each walker its validation keeps against the robustness
    bar and then ``accept`` (its measures, ``passed`` among them: the first walker that passes
    both ends the stage); ``walker``: the last that passed (None: none), ``kept``: the weights
    validation kept.
    A cut stage resumes from the polish's checkpoint and ``folder/tests.json``."""
    from evolve import walk_measures as wm
    from evolve.polish import polish

    share = until if callable(until) else (lambda: until)
    folder.mkdir(parents=True, exist_ok=True)
    tests_file, walker = folder / "tests.json", folder / "walker.json"
    resume = begun(folder)
    tests: dict[str, Any] = read_json(tests_file) if resume and tests_file.exists() else {"tests": []}
    if not resume:
        walker.unlink(missing_ok=True)
    # a cut stage resumes even past its share: its checkpoint finishes it where the uncut one
    # stopped (a stopped polish only writes its result), and its kept walker is not lost
    if not resume and budget.until(share()) <= 0:
        log(f"no budget left for {folder.name}")
        return {"source": str(source), "walker": str(walker) if walker.exists() else None, "skipped": True,
                **tests}

    def on_best(kept: Path, entry: dict[str, Any]) -> bool:
        done = [t for t in tests["tests"] if t["update"] == entry["update"]]
        if not done:
            test = wm.robustness(kept, threads=settings.threads, robot=robot)
            robust = wm.is_robust(test)
            log(f"{folder.name}: kept walker of update {entry['update']}: walks on {test['randomized']['walked']}"
                f"/{wm.DRAWS} unseen robots, {test['default']['walked']}/{test['default_episodes']} default"
                f"{' - robust' if robust else ''}")
            accepted = accept(kept) if robust and accept is not None else None
            done = [{"update": entry["update"], **short_test(test), "robust": robust and (accepted or {}).get(
                "passed", True), **({"accepted": accepted} if accepted is not None else {})}]
            tests["tests"].append(done[0])
            write_json_atomic(tests_file, tests)
        if done[0]["robust"]:  # the last one is the stage's walker; the ones before, the measure's fallbacks
            copy_file_atomic(kept, walker)
            copy_file_atomic(kept, folder / f"robust_update{entry['update']}.json")
        # a stage with a goal of its own stops at it: the search went on from OP3's first walker that
        # transferred to ones that kept less or fell in the 60 s walk (benchmarks/RESULTS.md)
        return accept is not None and done[0]["robust"]

    options = {k: v for k, v in stage.items() if k != "popsize"}
    record = polish(source, folder, updates=MAX_UPDATES, popsize=stage["popsize"], seed=settings.seed,
                    on_best=on_best, resume=resume, patience=patience, threads=settings.threads, test=0,
                    should_stop=lambda: budget.until(share()) <= 0, robot=robot, log=log, **options)
    return {"source": str(source), "walker": str(walker) if walker.exists() else None,
            "kept": record["polished"] if record["kept_update"] else None,
            **{k: v for k, v in record.items() if k in ("kept_update", "history", "physics_steps", "minutes")},
            "updates": len(record["history"]) and record["history"][-1]["update"], **tests}


def begun(folder: Path) -> bool:
    """Whether a polish stage in ``folder`` has begun: its checkpoint is there to resume from."""
    from evolve.polish import CHECKPOINT

    return (folder / CHECKPOINT).exists()
