"""One bus cycle on the simulated bus: sync write of goals + sync read of positions, on an
idle computer and with a CPU hog on every core.

    python -m benchmarks.bus --json

The default robot's servos at 1 Mbps, through ``DynamixelBus`` and the official SDK, on the
simulated bus (``python -m sim2real.simulation.simbus``, its own process, real-time
scheduling as by default) with wire pacing (bytes x 10 bits / baud + Return Delay Time 0).
Reports the cycle time against the wire time computed from packet sizes, failed cycles, and
the CPU this process (the runtime's side, real-time scheduling too) uses, most of it
waiting for replies.  Loads the machine on purpose: run nothing else meanwhile.
"""

from __future__ import annotations

import resource
import time

import numpy as np

from benchmarks.common import parser, progress, report
from benchmarks.loop import hogs
from sim2real.hardware import CommunicationError, ServoChain
from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus
from sim2real.hardware.realtime import (
    RealtimeRequest,
    ordinary_scheduling,
    request_realtime,
)
from sim2real.robot import load_robot
from sim2real.simulation.transfer.dry_run import SimulatedBusProcess


def cycles(port: str, baud: int, robot, n: int, busy: bool) -> dict:
    bus = DynamixelBus(port, baud, robot)
    bus.open()
    chain = ServoChain(bus, robot)
    for dxl_id in chain.servo_ids:
        chain.write(dxl_id, "return_delay_time", 0)
    goals = chain.sync_read("present_position")
    times, failed = [], 0
    grant = request_realtime(RealtimeRequest(lock_memory=False))
    try:
        with hogs(busy) as n_hogs:
            usage = resource.getrusage(resource.RUSAGE_SELF)
            wall0 = time.perf_counter()
            for _ in range(n):
                t0 = time.perf_counter()
                try:
                    chain.sync_write("goal_position", goals)
                    chain.sync_read("present_position", attempts=1)
                except CommunicationError:
                    failed += 1
                times.append(time.perf_counter() - t0)
            wall = time.perf_counter() - wall0
            after = resource.getrusage(resource.RUSAGE_SELF)
    finally:
        ordinary_scheduling()
        bus.close()
    cpu = (after.ru_utime + after.ru_stime - usage.ru_utime - usage.ru_stime) / wall
    return {"hogs": n_hogs, "cycle_ms_p50": float(np.percentile(times, 50) * 1e3),
            "cycle_ms_p99": float(np.percentile(times, 99) * 1e3), "cycle_ms_max": float(np.max(times) * 1e3),
            "failed_cycles": failed, "cpu_share_of_a_core_runtime": cpu, "granted": grant.summary()}


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--cycles", type=int, default=2000)
    p.add_argument("--baud", type=int, default=1_000_000)
    args = p.parse_args(argv)
    robot = load_robot()
    n = sum(1 for j in robot.joints if j.servo)
    write_bytes = 14 + n * 5  # SYNC_WRITE of 4-byte goals
    read_bytes = (14 + n) + n * 15  # SYNC_READ + a 4-byte status each
    wire_s = (write_bytes + read_bytes) * 10 / args.baud
    rows = {}
    with SimulatedBusProcess(["--baud", str(args.baud)]) as simbus:
        for busy in (False, True):
            name = "hogs" if busy else "idle"
            progress(f"{args.cycles} cycles, {name}...", args.json)
            rows[name] = cycles(simbus.port, args.baud, robot, args.cycles, busy)
    report({"servos": n, "baud": args.baud, "wire_ms": wire_s * 1e3, **rows,
            "ratio_idle": rows["idle"]["cycle_ms_p50"] / (wire_s * 1e3),
            "ratio_hogs": rows["hogs"]["cycle_ms_p50"] / (wire_s * 1e3)}, args.json)


if __name__ == "__main__":
    main()
