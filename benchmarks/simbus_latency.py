"""How long the simulated bus takes to answer, idle and under load: reply latency percentiles.

    python -m benchmarks.simbus_latency --json                    # idle, then 2 CPU hogs a core
    python -m benchmarks.simbus_latency --hogs-per-core 2 --seconds 20 --json

Drives the simulated bus (``python -m sim2real.simulation.simbus``, its own process, hung as for
``biped excite``) the way ``biped excite`` does each 10 ms tick: a sync write of goals, a sync
read of positions, a read of the sensor board's block and a sync read of velocity and load -
through ``DynamixelBus`` and the official SDK.  Each reply's latency is measured from the
request sent to the reply read, with a patient port (half a second), so that a late reply is
timed instead of lost; ``late`` counts replies later than the runtime's own packet timeout
(wire time + 2 x the adapter latency + the margin, :mod:`sim2real.hardware.dynamixel.sdk_bus`),
which the runtime would have counted as a failed read and retried.

Loads the machine on purpose (hogs: ``python -c 'while True: pass'``, ordinary scheduling,
nice 0): run nothing else meanwhile.  ``--no-realtime`` runs both sides under ordinary
scheduling (what a machine without the privilege gets).
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import time
from typing import Iterator

import numpy as np

from benchmarks.common import parser, progress, report
from sim2real.hardware import CommunicationError, ServoChain
from sim2real.hardware.dynamixel import sdk_bus
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.hardware.readings import MotionReadings
from sim2real.hardware.realtime import RealtimeRequest, ordinary_scheduling, request_realtime
from sim2real.simulation.model.physique import load_measured
from sim2real.simulation.transfer.dry_run import SimulatedBusProcess

TICK_S = 0.01  # biped excite's default tick
PATIENCE_US = 500_000.0  # added to every packet timeout: a late reply is measured, not lost


def _ordinary() -> None:
    os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    os.nice(0)


@contextlib.contextmanager
def hogs(count: int) -> Iterator[list[int]]:
    """``count`` CPU-bound processes (ordinary scheduling) while the block runs."""
    procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"], preexec_fn=_ordinary)
             for _ in range(count)]
    try:
        yield [p.pid for p in procs]
    finally:
        for proc in procs:
            proc.kill()
            proc.wait()


def runtime_timeout_ms(port: sdk_bus._Port, packet_length: int) -> float:
    """The packet timeout the runtime's port would allow this exchange [ms]."""
    return port.tx_time_per_byte * packet_length + 2 * sdk_bus.LATENCY_MS + sdk_bus.MARGIN_MS


def board_block_bytes(chain: ServoChain) -> int:
    """The size of the block ``ServoChain.read_board`` reads: its first to its last field [bytes]."""
    profile = chain.devices[chain.board_id]
    first = profile.register(Reg.FOOT_SWITCH_LEFT)
    present = [Reg.UP_VECTOR_Z, *(r for r in (Reg.HEADING, Reg.GYRO_X, Reg.GYRO_Y, Reg.GYRO_Z) if r in profile.control_table)]
    last = max((profile.register(r) for r in present), key=lambda reg: reg.address)
    return last.address + last.size - first.address


def measure(port_name: str, robot, seconds: float, realtime: bool) -> dict:
    bus = sdk_bus.DynamixelBus(port_name, robot.bus.baud, robot, return_delay_us=PATIENCE_US)
    bus.open()
    chain = ServoChain(bus, robot)
    motion = MotionReadings(chain, robot)
    for dxl_id in chain.servo_ids:  # as the runtime's start-up sets it
        chain.write(dxl_id, Reg.RETURN_DELAY_TIME, 0)
    goals = chain.sync_read(Reg.PRESENT_POSITION)
    n = len(chain.servo_ids)
    exchanges = {  # name -> (call, the runtime's timeout for it [ms])
        "positions": (lambda: chain.sync_read(Reg.PRESENT_POSITION, attempts=1),
                      runtime_timeout_ms(bus.port, 15 * n)),
        "board": (lambda: chain.read_board(attempts=1),
                  runtime_timeout_ms(bus.port, 11 + board_block_bytes(chain))),
        "motion": (lambda: motion.read(attempts=1), runtime_timeout_ms(bus.port, 19 * n)),
    }
    latencies: dict[str, list[float]] = {name: [] for name in exchanges}
    failed = dict.fromkeys(exchanges, 0)
    grant = request_realtime(RealtimeRequest(lock_memory=False)) if realtime else None
    try:
        deadline = time.monotonic()
        end = deadline + seconds
        while deadline < end:
            chain.sync_write(Reg.GOAL_POSITION, goals)
            for name, (call, _) in exchanges.items():
                t0 = time.perf_counter()
                try:
                    call()
                except CommunicationError:
                    failed[name] += 1
                    continue
                latencies[name].append(time.perf_counter() - t0)
            deadline += TICK_S
            time.sleep(max(0.0, deadline - time.monotonic()))
    finally:
        if grant is not None:
            ordinary_scheduling()
        bus.close()
    rows = {}
    for name, (_, timeout_ms) in exchanges.items():
        ms = np.array(latencies[name]) * 1e3
        rows[name] = {"replies": int(ms.size), "failed": failed[name], "timeout_ms": timeout_ms,
                      "late": int(np.sum(ms > timeout_ms)),
                      **{f"ms_p{q}": float(np.percentile(ms, q)) for q in (50, 99, 99.9)},
                      "ms_max": float(ms.max()) if ms.size else None}
    return rows


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=10.0, help="of each row (default 10)")
    p.add_argument("--hogs-per-core", type=int, default=2, help="CPU hogs per core in the loaded row (default 2)")
    p.add_argument("--robot", default="xl430_biped")
    p.add_argument("--no-realtime", action="store_true", help="both sides under ordinary scheduling")
    p.add_argument("--loaded-only", action="store_true", help="skip the idle row")
    args = p.parse_args(argv)
    robot = load_measured(args.robot)
    flags = ["--no-realtime"] if args.no_realtime else ["--no-mlock"]
    rows = {}
    n_hogs = args.hogs_per_core * (os.cpu_count() or 1)
    with SimulatedBusProcess(["--robot", args.robot, "--suspended", *flags], log=lambda line: None) as simbus:
        for count in ([n_hogs] if args.loaded_only else [0, n_hogs]):
            name = f"{count}_hogs"
            progress(f"{args.seconds:g} s with {count} hogs...", args.json)
            with hogs(count):
                rows[name] = measure(simbus.port, robot, args.seconds, not args.no_realtime)
    report({"robot": args.robot, "tick_ms": TICK_S * 1e3, "realtime": not args.no_realtime, **rows,
            "simbus_stalls": simbus.ground_truth.get("stalls"), "simbus_realtime": simbus.ground_truth.get("realtime")},
           args.json)


if __name__ == "__main__":
    main()
