"""What every benchmark shares: the machine description and the JSON last line."""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from typing import Any, Callable, Sequence, TypeVar

T = TypeVar("T")
R = TypeVar("R")


def machine() -> dict[str, Any]:
    import numpy

    return {
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "cpu": platform.processor() or platform.machine(),
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "date": time.strftime("%Y-%m-%d"),
    }


def parser(description: str) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--json", action="store_true", help="print only the JSON result line")
    return p


def report(result: dict[str, Any], as_json: bool) -> None:
    """Human-readable lines unless --json; the last line is always the JSON object."""
    result = {**result, "machine": machine()}
    if not as_json:
        for key, value in result.items():
            if not isinstance(value, (dict, list)):
                print(f"{key:>24}: {value}", file=sys.stderr)
    print(json.dumps(result))


def map_runs(function: Callable[[T], R], items: Sequence[T], workers: int = 1,
             on_result: Callable[[int, R, float], None] | None = None) -> list[R]:
    """``[function(x) for x in items]``, over ``workers`` processes when more than one.

    Each run is seeded by its item alone, so the results (in item order) do not depend on
    ``workers``; ``on_result(index, result, seconds)`` reports each run as it finishes.
    """
    results: list[R | None] = [None] * len(items)
    if workers <= 1:
        for i, item in enumerate(items):
            t = time.perf_counter()
            results[i] = function(item)
            if on_result:
                on_result(i, results[i], time.perf_counter() - t)
        return results  # type: ignore[return-value]
    from concurrent.futures import ProcessPoolExecutor, as_completed

    with ProcessPoolExecutor(max_workers=workers) as pool:
        started = time.perf_counter()
        futures = {pool.submit(function, item): i for i, item in enumerate(items)}
        for future in as_completed(futures):
            i = futures[future]
            results[i] = future.result()
            if on_result:
                on_result(i, results[i], time.perf_counter() - started)
    return results  # type: ignore[return-value]


def command_line(module: str, argv: Sequence[str] | None) -> str:
    """The shell command that ran benchmark ``module`` with ``argv`` (None: this process's)."""
    import shlex

    return f"python -m {module} " + shlex.join(sys.argv[1:] if argv is None else argv)


def progress(message: str, quiet: bool) -> None:
    if not quiet:
        print(message, file=sys.stderr, flush=True)
