"""What every benchmark shares: the machine description and the JSON last line."""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from typing import Any


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


def progress(message: str, quiet: bool) -> None:
    if not quiet:
        print(message, file=sys.stderr, flush=True)
