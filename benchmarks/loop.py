"""The real-time loop on an idle and on a busy computer: jitter, overruns, retries and stops.

    python -m benchmarks.loop --json                      # everything (about 10 minutes)
    python -m benchmarks.loop --parts mock --ticks 2000   # a quick look

It loads the machine on purpose: run nothing else meanwhile.  Parts:

* ``mock``: 10,000 ticks of a 300-connection controller at a 10 ms tick on the mock bus, with
  the real-time request (SCHED_FIFO, locked memory) and without it (the baseline), each on
  an idle machine and with a CPU-bound process on every core ("hogs");
* ``sim``: ``biped run --port <biped simbus's pty>`` for 60 s, idle and with the hogs: the
  runtime and the simulated bus as two processes, through the official SDK, no faults;
* ``dry``: the same dry run (``biped dry-run``) idle and with the hogs: the verdict (stop
  reason, fell) must not depend on the load.

``--memory-gb N`` adds a row to ``sim`` and ``dry``: beside a process that holds N GiB and keeps
touching it.  Each row reports how often the simulated bus itself was held up
(``simbus_stalls``).

Goals: with the hogs, jitter p99 <= 1 ms and overruns <= 0.1 % on the mock bus; no stop in
60 s on the simulated bus; the same dry-run verdict.  ``compute_us`` is the policy alone;
``jitter_ms`` is each tick's start against its deadline.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Iterator

import numpy as np

from benchmarks.common import parser, progress, report
from evolve.locomotion.evaluator import neat_layout
from evolve.locomotion.export import controller_from_genome
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome
from sim2real.controller.file import Controller
from sim2real.controller.symmetry import symmetric_layout
from sim2real.hardware import MockBus
from sim2real.hardware.deploy import drive
from sim2real.hardware.realtime import RealtimeRequest
from sim2real.robot import load_robot
from sim2real.simulation.transfer.dry_run import SimulatedBusProcess


def random_controller(robot, connections: int, hidden: int, seed: int, control_set: str = "walk") -> Controller:
    """A controller of the given size with random weights (recurrent, self-loops allowed),
    in an exported controller's frame (an unconnected genome's), driving ``control_set``."""
    rng = np.random.default_rng(seed)
    layout = symmetric_layout(robot, robot.control_sets[control_set])
    controller = controller_from_genome(Genome(0, neat_layout(layout)), robot, layout,
                                        TaskConfig(control_set=control_set), 1.0,
                                        {"seed": seed, "made_by": "benchmarks.loop.random_controller"}).to_dict()
    interface = layout.n_inputs + 2 + layout.n_outputs
    nodes = list(range(interface)) + list(range(interface, interface + hidden))
    targets = nodes[layout.n_inputs + 2:]
    pairs = set()
    while len(pairs) < connections:
        pairs.add((int(rng.choice(nodes)), int(rng.choice(targets))))
    controller["hidden"] = [[n, 0] for n in range(interface, interface + hidden)]
    controller["connections"] = [[s, d, float(rng.normal()), 0] for s, d in sorted(pairs)]
    return Controller.from_dict(controller, "benchmarks.loop.random_controller")


def standing_controller(robot) -> Controller:
    """No connections: every output 0.5, each driven joint at the centre of its range."""
    return random_controller(robot, 0, hidden=0, seed=0)


def _ordinary_scheduling() -> None:
    os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))


@contextlib.contextmanager
def hogs(enabled: bool) -> Iterator[int]:
    """A CPU-bound process on every core while the block runs."""
    procs = []
    if enabled:
        # ordinary scheduling whatever the caller's: a hog that inherited a real-time class
        # would starve the machine instead of loading it
        procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"], preexec_fn=_ordinary_scheduling)
                 for _ in range(os.cpu_count() or 1)]
    try:
        yield len(procs)
    finally:
        for proc in procs:
            proc.kill()
            proc.wait()


MEMORY_HOG = """
import sys, time
import numpy as np
gb = float(sys.argv[1])
blocks = []
while sum(b.nbytes for b in blocks) < gb * 2**30:  # touch every page as it comes: real memory, not a promise
    blocks.append(np.ones(2**27, dtype=np.uint8))
print("allocated", flush=True)
while True:  # keep the pages in use
    for b in blocks:
        b[::4096] += 1
    time.sleep(0.1)
"""


@contextlib.contextmanager
def memory_hog(gb: float) -> Iterator[float]:
    """A process that takes ``gb`` GiB of memory, page by page, and keeps touching it while the
    block runs (issue 31: a dry run lost its bus while another process allocated 11 GB)."""
    if gb <= 0:
        yield 0.0
        return
    proc = subprocess.Popen([sys.executable, "-c", MEMORY_HOG, str(gb)], stdout=subprocess.PIPE, text=True,
                            preexec_fn=_ordinary_scheduling)
    try:
        yield gb
    finally:
        proc.kill()
        proc.wait()


def mock_part(robot, ticks: int, tick_ms: float, connections: int, realtime: bool, busy: bool) -> dict:
    controller = dataclasses.replace(random_controller(robot, connections, hidden=40, seed=0), tick_s=tick_ms / 1000.0)
    request = RealtimeRequest() if realtime else None
    with hogs(busy) as n_hogs:
        result = drive(MockBus(robot), robot, controller, duration_s=ticks * controller.tick_s,
                       log=lambda s: None, ramp_s=0.1, realtime=request)
    s = result.summary()
    return {"realtime": realtime, "hogs": n_hogs, "ticks": s["ticks"], "compute_us_p50": s["compute_us_p50"],
            "compute_us_p99": s["compute_us_p99"], "jitter_ms_p99": s["jitter_ms_p99"],
            "jitter_ms_max": float(np.max(result.jitter_s) * 1e3), "overruns": s["overruns"],
            "overrun_share": s["overruns"] / max(1, s["ticks"]), "stop_reason": s["stop_reason"],
            "granted": s["realtime"]}


def sim_part(controller_path: Path, seconds: float, busy: bool, memory_gb: float = 0.0) -> dict:
    """``biped run --port`` against ``biped simbus``, two processes, as a user would."""
    with SimulatedBusProcess([]) as simbus, hogs(busy) as n_hogs, memory_hog(memory_gb):
        out = subprocess.run([sys.executable, "-m", "evolve.cli", "run", str(controller_path), "--port", simbus.port,
                              "--duration", str(seconds), "--json"], capture_output=True, text=True,
                             timeout=seconds + 120)
    s = json.loads(out.stdout.splitlines()[-1])
    return {"hogs": n_hogs, "memory_hog_gb": memory_gb, "seconds": seconds, "exit_code": out.returncode,
            "simbus_stalls": simbus.ground_truth.get("stalls"), "ticks": s["ticks"],
            "stop_reason": s["stop_reason"], "overruns": s["overruns"], "jitter_ms_p99": s["jitter_ms_p99"],
            "retries": s["retries"], "missed_ticks": s["missed_ticks"], "corrupt_replies": s["corrupt_replies"],
            "torque_off": s["torque_off"], "granted": s["realtime"]}


def dry_part(controller_path: Path, seconds: float, busy: bool, memory_gb: float = 0.0) -> dict:
    with hogs(busy) as n_hogs, memory_hog(memory_gb):
        out = subprocess.run([sys.executable, "-m", "evolve.cli", "dry-run", str(controller_path), "--duration",
                              str(seconds), "--json"], capture_output=True, text=True, timeout=seconds + 120)
    s = json.loads(out.stdout.splitlines()[-1])
    return {"hogs": n_hogs, "memory_hog_gb": memory_gb, "exit_code": out.returncode,
            "simbus_stalls": s["simbus_stalls"], "stop_reason": s["stop_reason"], "fell": s["fell"],
            "distance_m": s["distance_m"], "overruns": s["overruns"], "retries": s["retries"],
            "missed_ticks": s["missed_ticks"], "jitter_ms_p99": s["jitter_ms_p99"]}


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--parts", default="mock,sim,dry", help="comma-separated: mock, sim, dry (default: all)")
    p.add_argument("--ticks", type=int, default=10_000, help="mock-bus ticks per row (default 10,000)")
    p.add_argument("--tick-ms", type=float, default=10.0)
    p.add_argument("--connections", type=int, default=300)
    p.add_argument("--sim-seconds", type=float, default=60.0, help="length of the simulated-bus runs (default 60)")
    p.add_argument("--dry-seconds", type=float, default=10.0)
    p.add_argument("--controller", type=Path, help="controller for the sim and dry parts (default: a standing one)")
    p.add_argument("--memory-gb", type=float, default=0.0,
                   help="also run the sim and dry parts beside a process holding this many GiB (default: not)")
    args = p.parse_args(argv)
    parts = set(args.parts.split(","))
    robot = load_robot()
    result: dict = {"tick_ms": args.tick_ms, "connections": args.connections}
    with tempfile.TemporaryDirectory() as tmp:
        controller = args.controller
        if controller is None:
            controller = Path(tmp) / "stand.json"
            standing_controller(robot).save(controller)
        if "mock" in parts:
            rows = {}
            for busy in (False, True):
                for realtime in (True, False):
                    name = f"{'realtime' if realtime else 'baseline'}_{'hogs' if busy else 'idle'}"
                    progress(f"mock bus, {name}: {args.ticks} ticks at {args.tick_ms} ms...", args.json)
                    rows[name] = mock_part(robot, args.ticks, args.tick_ms, args.connections, realtime, busy)
            result["mock"] = rows
            base, rt = rows["baseline_hogs"], rows["realtime_hogs"]
            result["hogs_jitter_p99_ratio_baseline_over_realtime"] = base["jitter_ms_p99"] / max(rt["jitter_ms_p99"], 1e-9)
        for part, what, run_part, seconds in (
                ("sim", "biped run --port <simbus>", sim_part, args.sim_seconds),
                ("dry", "biped dry-run", dry_part, args.dry_seconds)):
            if part not in parts:
                continue
            rows = {}
            loads = [("idle", False, 0.0), ("hogs", True, 0.0)] + ([("memory", False, args.memory_gb)]
                                                                  if args.memory_gb > 0 else [])
            for name, busy, memory_gb in loads:
                progress(f"{what} for {seconds:.0f} s, {name}...", args.json)
                rows[name] = run_part(controller, seconds, busy, memory_gb)
            result[part] = rows
        if "dry" in parts:
            idle, busy = result["dry"]["idle"], result["dry"]["hogs"]
            result["dry_same_verdict"] = (idle["stop_reason"], idle["fell"]) == (busy["stop_reason"], busy["fell"])
    report(result, args.json)


if __name__ == "__main__":
    main()
