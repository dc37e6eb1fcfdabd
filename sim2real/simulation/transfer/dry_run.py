"""A dry run: the real runtime (``drive`` over ``DynamixelBus`` and the official SDK) against
the simulated bus on a pseudo-terminal, with ground truth from the simulator.

Nothing in the loop knows it is not talking to hardware.  Faults end the way they would on
hardware: retried, or a safe stop with torque off.  The simulated bus is a child process
(:mod:`sim2real.simulation.simbus.service`), so this side imports no MuJoCo.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any, Callable

from sim2real.controller.file import Controller
from sim2real.controller.policy import refuse_commands
from sim2real.errors import BipedError
from sim2real.hardware.deploy import drive
from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus
from sim2real.hardware.loop import LOST_AFTER_S
from sim2real.hardware.realtime import RealtimeRequest
from sim2real.simulation.reality.file import load_reality  # reality files, read without MuJoCo
from sim2real.simulation.simbus.faults import END_OF_RUN, check_fault_times, parse_faults


class SimulatedBusProcess:
    """``python -m sim2real.simulation.simbus`` as a child process: ``port`` once started; its ground
    truth once stopped (by closing its standard input)."""

    def __init__(self, args: list[str], log: Callable[[str], None] = print):
        self.args, self.log = args, log
        self.port = ""
        self.ground_truth: dict[str, Any] = {}

    def __enter__(self) -> "SimulatedBusProcess":
        self._stderr = tempfile.TemporaryFile(mode="w+")
        # Its own session: a terminal's Ctrl-C (SIGINT to the whole foreground process group) or
        # hang-up must reach only this process, which stops the run safely and then the bus by
        # closing its standard input - a bus killed first leaves nothing to turn torque off on.
        self.proc = subprocess.Popen([sys.executable, "-m", "sim2real.simulation.simbus", *self.args,
                                      "--exit-on-stdin-eof", "--report"],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._stderr, text=True,
                                     start_new_session=True)
        self.port = self.proc.stdout.readline().strip()
        if not self.port:
            self.proc.wait(timeout=30)
            raise BipedError(f"the simulated bus did not start: {self._errors() or f'exit {self.proc.returncode}'}")
        return self

    def __exit__(self, *exc) -> None:
        try:
            out, _ = self.proc.communicate(timeout=30)  # closes the child's stdin: its signal to stop
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, _ = self.proc.communicate()
        lines = [line for line in out.splitlines() if line.strip()]
        try:
            self.ground_truth = json.loads(lines[-1]) if lines else {}
        except json.JSONDecodeError:
            self.ground_truth = {}
        for line in self._errors().splitlines():
            self.log(line)
        self._stderr.close()

    def mark_end_of_run(self) -> None:
        """Tell the simulated bus that the loop has ended: its ground truth is taken now,
        before the stop's ramp to rest and torque off."""
        try:
            self.proc.stdin.write(END_OF_RUN + "\n")
            self.proc.stdin.flush()
        except (OSError, ValueError):  # it is gone: its report says so
            pass

    def _errors(self) -> str:
        self._stderr.seek(0)
        return self._stderr.read().strip()


def dry_run(controller_path: Path | str, robot_name: str | None = None, duration_s: float = 10.0,
            trace_path: Path | str | None = None, faults: str | None = None,
            log: Callable[[str], None] = print, ramp_s: float = 2.0,
            disabled_modules: tuple[str, ...] = (), reality: str | None = None, seed: int = 0,
            realtime: RealtimeRequest | None = None, simbus_realtime: list[str] | None = None,
            heading: Callable[[float], float] | None = None,
            reach_target: tuple[float, float, float] | None = None,
            lost_after_s: float = LOST_AFTER_S) -> dict[str, Any]:
    """Run a controller through the real runtime on the simulated bus, the robot behind it
    perturbed by the reality profile ``reality`` (None: nominal); see ``biped dry-run``.

    The simulated bus runs in its own process.  ``realtime`` is the runtime's real-time
    request (None: none; this process keeps its scheduling); ``simbus_realtime`` the simulated
    bus's as its command-line flags (None: its default, real-time scheduling - a simulated
    robot starved of CPU would fall, or go silent, for the wrong reason); ``heading`` the
    heading to hold over time, ``reach_target`` where a reaching controller's hand reaches and
    ``lost_after_s`` [s] how long without a good read stops the loop
    (:func:`sim2real.hardware.deploy.drive`).
    """
    data, robot = Controller.load_for_robot(controller_path, robot_name)
    robot_arg = robot_name or data.robot_name
    profile = load_reality(reality)  # every input checked before anything starts
    refuse_commands(data.input_channels, heading=heading, reach_target=reach_target)
    check_fault_times(parse_faults(faults, robot), duration_s)
    args = ["--robot", robot_arg, "--seed", str(seed), "--fault-delay", str(ramp_s),
            *(["--reality", reality] if reality else []), *(["--faults", faults] if faults else []),
            *(simbus_realtime or [])]
    with SimulatedBusProcess(args, log) as simbus:
        report = drive(DynamixelBus(simbus.port, robot.bus.baud, robot), robot, data, duration_s=duration_s,
                       trace_path=trace_path, log=log, ramp_s=ramp_s, disabled_modules=disabled_modules,
                       realtime=realtime, on_loop_end=simbus.mark_end_of_run, heading=heading,
                       reach_target=reach_target, lost_after_s=lost_after_s)
    truth = simbus.ground_truth
    if "distance_m" not in truth:
        raise BipedError("the simulated bus ended without its report (it crashed?)")
    stalls = truth.get("stalls") or {"count": 0}
    if stalls["count"] and report.stop_reason.startswith("lost communication"):
        note = (f"the simulated bus, not the loop, fell behind: this computer held it up {stalls['count']} time(s), "
                f"up to {stalls['longest_ms']:.0f} ms (first at {stalls['first_at_s']:.1f} s after it started)")
        report.stop_notes.append(note)
        log(f"note: {note}")
    summary = report.summary()
    unstable = truth.get("unstable")  # the loop ran and stopped safely, but what the robot did is no result
    if unstable:
        log(f"the simulated robot went {unstable}: its distance and falls are no result (check the reality profile "
            f"{profile.name}'s values)")
    return {"distance_m": None if unstable else truth["distance_m"], "fell": None if unstable else truth["fell"],
            "heading_deg": None if unstable else truth["heading_deg"], "unstable": unstable,
            "ticks": report.ticks,
            "overruns": report.overruns, "bus_errors": report.bus_errors, "retries": report.retries,
            "missed_ticks": report.missed_ticks, "corrupt_replies": report.corrupt_replies,
            "stop_reason": report.stop_reason, "stop_signal": report.stop_signal, "stop_notes": report.stop_notes, "torque_off": summary["torque_off"],
            "reality": profile.name, "trace": str(trace_path) if trace_path and Path(trace_path).exists() else None,
            "simulated_s": truth["simulated_s"], "fell_after_stop": truth.get("fell_after_stop"),
            "simulated_s_after_stop": truth.get("simulated_s_after_stop"),
            **{k: v for k, v in summary.items() if k.startswith(("compute", "jitter"))},
            "realtime": summary["realtime"], "simbus_realtime": truth.get("realtime"), "simbus_stalls": stalls,
            **({"reach": summary["reach"]} if "reach" in summary else {})}
