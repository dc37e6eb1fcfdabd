"""One bus cycle on the simulated bus: sync write of goals + sync read of positions.

    python -m benchmarks.bus --json

The default robot's servos at 1 Mbps, through ``DynamixelBus`` and the official SDK, on the
simulated bus (``biped simbus``, its own process) with wire pacing (bytes x 10 bits / baud +
Return Delay Time 0).  Reports the cycle time against the wire time computed from packet
sizes, and the CPU this process (the runtime's side) uses, most of it waiting for replies.
"""

from __future__ import annotations

import resource
import subprocess
import sys
import time

import numpy as np

from benchmarks.common import parser, progress, report
from sim2real.hardware import ServoChain
from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus
from sim2real.robot import load_robot


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--cycles", type=int, default=500)
    p.add_argument("--baud", type=int, default=1_000_000)
    args = p.parse_args(argv)
    robot = load_robot()
    n = sum(1 for j in robot.joints if j.servo)
    write_bytes = 14 + n * 5  # SYNC_WRITE of 4-byte goals
    read_bytes = (14 + n) + n * 15  # SYNC_READ + a 4-byte status each
    wire_s = (write_bytes + read_bytes) * 10 / args.baud
    server = subprocess.Popen([sys.executable, "-m", "evolve.cli", "simbus", "--baud", str(args.baud)],
                              stdout=subprocess.PIPE, text=True)
    try:
        port = server.stdout.readline().strip()
        bus = DynamixelBus(port, args.baud, robot)
        bus.open()
        chain = ServoChain(bus, robot)
        for dxl_id in chain.servo_ids:
            chain.write(dxl_id, "return_delay_time", 0)
        goals = chain.sync_read("present_position")
        cycles = []
        usage = resource.getrusage(resource.RUSAGE_SELF)
        wall0 = time.perf_counter()
        for _ in range(args.cycles):
            t0 = time.perf_counter()
            chain.sync_write("goal_position", goals)
            chain.sync_read("present_position")
            cycles.append(time.perf_counter() - t0)
        wall = time.perf_counter() - wall0
        after = resource.getrusage(resource.RUSAGE_SELF)
        bus.close()
    finally:
        server.terminate()
        server.wait(timeout=30)
    progress(f"{args.cycles} cycles", args.json)
    cpu = (after.ru_utime + after.ru_stime - usage.ru_utime - usage.ru_stime) / wall
    report({
        "servos": n, "baud": args.baud,
        "cycle_ms_p50": float(np.percentile(cycles, 50) * 1e3),
        "cycle_ms_p99": float(np.percentile(cycles, 99) * 1e3),
        "wire_ms": wire_s * 1e3,
        "ratio": float(np.percentile(cycles, 50)) / wire_s,
        "cpu_share_of_a_core_runtime": cpu,
    }, args.json)


if __name__ == "__main__":
    main()
