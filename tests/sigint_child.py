"""The process that ``tests/test_signals.py`` interrupts at random moments: runs on emulated
servos, one per line ``run K`` on its standard input.

    python -m tests.sigint_child CONTROLLER TRACE_FOLDER

For each ``run K`` it prints ``start K``, drives the default robot's emulated servos (through
the official SDK on a pseudo-terminal, tracing to ``TRACE_FOLDER/tK.csv``) and prints one JSON
line: the report's stop reason and torque read-back, and Torque Enable read straight from
the emulated servos.  Outside a run SIGINT is ignored, so a signal that comes after a run has
ended lands nowhere instead of ending this process; inside one the runtime's own handlers
take it.  The test sends the signals from its process to this one: never to pytest's.
"""

from __future__ import annotations

import json
import signal
import sys
from pathlib import Path

from sim2real.controller.file import Controller
from sim2real.hardware import MockBus
from sim2real.hardware.deploy import drive
from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus
from sim2real.robot import load_robot
from sim2real.simulation.simbus.server import EmulatedChain, PtyServer

ROBOT = load_robot()
SERVOS = [j.servo.id for j in ROBOT.joints]
RUN = {"duration_s": 0.6, "ramp_s": 0.1,
       "lost_after_s": 2.0}  # 2 s: what is tested is the stop, not whether a loaded host stalls 100 ms


def main(argv: list[str]) -> int:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    controller = Controller.load(argv[0], ROBOT)
    traces = Path(argv[1])
    chain = EmulatedChain(MockBus(ROBOT).devices)
    with PtyServer(chain, baud=1_000_000) as server:
        for line in sys.stdin:
            k = int(line.split()[1])
            print(f"start {k}", flush=True)
            report = drive(DynamixelBus(server.port, 1_000_000, ROBOT), ROBOT, controller, log=lambda s: None,
                           trace_path=traces / f"t{k}.csv", **RUN)
            torque = {i: chain.devices[i].get_named("torque_enable") for i in SERVOS}
            print(json.dumps({"run": k, "stop_reason": report.stop_reason, "confirmed": report.torque_off.confirmed,
                              "unconfirmed": report.torque_off.unconfirmed, "torque": list(torque.values())}),
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
