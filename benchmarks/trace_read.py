"""Large traces: the time and peak memory of reading a long trace, and of ``biped compare`` on it.

    python -m benchmarks.trace_read --json                       # an hour at the robot's tick
    python -m benchmarks.trace_read --minutes 60 --tick-ms 10    # an hour of excite's 100 Hz
    python -m benchmarks.trace_read --code /path/to/other/checkout --json   # the same, older code

Writes a valid trace of ``--minutes`` of the robot (every joint, through
:class:`~sim2real.hardware.trace.TraceWriter`, as a run writes it: goals swinging around home,
the present angles a tick behind, the feet taking turns), then measures in fresh processes
(with the code in ``--code`` first on the path) ``Trace.read`` alone and ``biped compare --json``:
wall seconds, CPU seconds (steadier on a shared machine) and peak resident memory
(``ru_maxrss`` of that process) [MB].
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.common import parser, report
from sim2real.hardware.trace import TraceWriter
from sim2real.robot import DEFAULT_ROBOT
from sim2real.simulation.model.physique import load_measured
from sim2real.robot.timing import control_timing

CHILD = """
import json, resource, sys, time
t = time.perf_counter()
{body}
usage = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({{"seconds": time.perf_counter() - t, "cpu_s": usage.ru_utime + usage.ru_stime,
                  "peak_rss_mb": usage.ru_maxrss / 1024}}), file=sys.stderr)
"""
READ = "from sim2real.hardware.trace import Trace\ntrace = Trace.read(sys.argv[1])"
COMPARE = "from evolve.cli import main\ncode = main(['compare', sys.argv[1], '--json'])\nassert code == 0, code"


def write_trace(path: Path, robot_name: str, minutes: float, tick_s: float) -> int:
    """A valid trace of ``minutes`` at ``tick_s`` [s] into ``path``; returns its rows."""
    robot = load_measured(robot_name)
    names = list(robot.joint_names)
    home = np.array([j.home_rad for j in robot.joints])
    low = np.array([j.range_rad[0] for j in robot.joints])
    high = np.array([j.range_rad[1] for j in robot.joints])
    amplitude = np.minimum(0.15, 0.5 * np.minimum(home - low, high - home))
    writer = TraceWriter(path, names, {"robot": robot.name, "tick_s": tick_s, "software": "benchmark"})
    rows = int(round(minutes * 60 / tick_s))
    previous = home
    for k in range(rows):
        t = k * tick_s
        goal = home + amplitude * math.sin(2 * math.pi * 0.8 * t)
        left = math.sin(2 * math.pi * 0.8 * t) > 0
        writer.write(t, k, goal, previous, np.array([left, not left]), np.array([0.0, 0.0, 1.0]), 2e-4, 1e-3, False)
        previous = goal
    writer.close()
    return rows


def measure(body: str, trace: Path, code: Path) -> dict[str, float]:
    """Seconds and peak RSS [MB] of ``body`` in a fresh process with ``code`` first on the path."""
    env = {**os.environ, "PYTHONPATH": str(code)}
    done = subprocess.run([sys.executable, "-c", CHILD.format(body=body), str(trace)], env=env, cwd=trace.parent,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"the measured process failed: {done.stderr.strip().splitlines()[-1:]}")
    return json.loads(done.stderr.strip().splitlines()[-1])


def main() -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--robot", default=DEFAULT_ROBOT)
    p.add_argument("--minutes", type=float, default=60.0, help="length of the trace (default an hour)")
    p.add_argument("--tick-ms", type=float, help="the trace's tick (default: the robot's control tick)")
    p.add_argument("--code", type=Path, default=Path(__file__).resolve().parents[1],
                   help="the checkout whose reader and compare to measure (default: this one)")
    p.add_argument("--no-compare", action="store_true", help="measure the reading only")
    args = p.parse_args()
    tick_s = args.tick_ms / 1e3 if args.tick_ms else control_timing(load_measured(args.robot)).tick_s
    with tempfile.TemporaryDirectory() as folder:
        trace = Path(folder) / "long.csv"
        t = time.perf_counter()
        rows = write_trace(trace, args.robot, args.minutes, tick_s)
        result = {"robot": args.robot, "minutes": args.minutes, "tick_ms": tick_s * 1e3, "rows": rows,
                  "trace_mb": trace.stat().st_size / 2**20, "write_s": time.perf_counter() - t,
                  "code": str(args.code), "read": measure(READ, trace, args.code)}
        if not args.no_compare:
            result["compare"] = measure(COMPARE, trace, args.code)
    report(result, args.json)


if __name__ == "__main__":
    main()
