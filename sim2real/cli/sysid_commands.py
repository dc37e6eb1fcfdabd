"""The ``biped`` subcommands of system identification: ``excite`` (drive an excitation
program through the bus and trace it) and ``sysid`` (fit the simulation to such traces)."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from sim2real.cli.args import (
    add_realtime_arguments,
    baud_rate,
    check_baud,
    holding_lock,
    output_dir,
    output_file,
    float_within,
    int_within,
    print_result,
    reality_name,
    realtime_flags,
    realtime_request,
    require_module,
    robot_name,
    seed,
)
from sim2real.cli.deploy_commands import TRACE_FILE
from sim2real.errors import UsageError
from sim2real.hardware.excitation import POSES
from sim2real.robot import DEFAULT_ROBOT, load_robot

EXCITE_TICK_MS = 10.0  # 100 Hz: ten goals a period of a 10 Hz chirp; a bus cycle of the default robot is ~3 ms
# What the excitation's numbers mean bounds them (refused at parse time, the flag named):
MIN_TICK_MS, MAX_TICK_MS = 1.0, 1000.0  # a bus cycle takes ~3 ms; past a second a 0.2-10 Hz chirp is not sampled
TICK_WHY = "no bus turns a tick around in under 1 ms; past a second the chirp is not sampled"
MAX_CHIRP_S = 600.0  # ten minutes a chirp: 120 periods of its lowest frequency (0.2 Hz), and it runs per joint
CHIRP_WHY = "ten minutes: 120 periods of the lowest frequency, for each joint"
MAX_STEP_DEG = 90.0  # a step of a quarter turn; each is cut to the joint's room around home anyway
STEP_WHY = "a quarter turn; each is cut to the joint's room"
MAX_ITERS = 10_000  # the optimizer's iterations: 30 is the default, a few hundred more than any fit took


def add_commands(sub: argparse._SubParsersAction) -> None:
    ex = sub.add_parser(
        "excite", help="move the servos through chirps and steps and trace them (for biped sysid)",
        description="Drive an excitation program through the same bus layer and safety as biped run (start-up "
        "checks, ramp, real-time loop, ramp to rest and torque off, read back): per joint or symmetric pair, a "
        "chirp (0.2-10 Hz) and steps of a few amplitudes around the home pose, every goal inside the joint "
        "limits.  Suspended (the default) means the robot hangs by its pelvis with both feet free of the floor: "
        "hang it so before you start; standing uses small, slow motions.  Without --port the simulated bus "
        "serves the robot, hung the same way.")
    ex.add_argument("--robot", type=robot_name, default=DEFAULT_ROBOT, help="robot (default: %(default)s)")
    where = ex.add_mutually_exclusive_group()
    where.add_argument("--port", help="serial port of the real bus, e.g. /dev/ttyUSB0")
    where.add_argument("--bus", choices=["sim"], help="sim (the default without --port): the simulated bus")
    ex.add_argument("--baud", type=baud_rate, help="baud rate of the real bus (default: the robot config's)")
    ex.add_argument("--joints", nargs="+", metavar="NAME",
                    help="joints or pairs to excite (e.g. knee hip_pitch waist_yaw; default: all)")
    ex.add_argument("--pose", choices=POSES, default="suspended", help="how the robot is held (default: %(default)s)")
    ex.add_argument("--tick-ms", type=float_within(MIN_TICK_MS, MAX_TICK_MS, TICK_WHY),
                    help=f"the program's tick (default {EXCITE_TICK_MS:g} ms, or the robot's bus time a tick if "
                    "longer: as fast as the bus allows, not the controller's tick)")
    ex.add_argument("--chirp-s", type=float_within(0.0, MAX_CHIRP_S, CHIRP_WHY, low_open=True), metavar="S",
                    help="seconds of each chirp (default 12; longer resolves low frequencies better)")
    ex.add_argument("--steps", type=float_within(0.0, MAX_STEP_DEG, STEP_WHY, low_open=True), nargs="+", metavar="DEG",
                    help="step amplitudes (default 2 5 10 20 deg hung, 1 2 4 standing; cut to the joint's room)")
    ex.add_argument("--trace", type=TRACE_FILE, required=True, help="trace CSV to write (+ JSON sidecar)")
    ex.add_argument("--reality", type=reality_name, metavar="PROFILE",
                    help="simulated bus only: the robot behind it, a configs/reality/ name or a path")
    ex.add_argument("--seed", type=seed, default=0, help="simulated bus only: seed of the reality's random parts (default: %(default)s)")
    ex.add_argument("--json", action="store_true", help="print the report as one JSON object")
    add_realtime_arguments(ex)
    ex.set_defaults(func=cmd_excite, check=check_excite)

    fit = sub.add_parser(
        "sysid", help="fit the servo model to excitation traces; write a reality file",
        description="Replay the traces' goals in the hung robot's model and fit, per servo model (or per joint), "
        "the gain, torque, damping, Coulomb friction, armature and backlash, and the bus's latency, with "
        "mujoco.sysid.  Reports each with its 95 % interval, says which the traces cannot identify, and the "
        "per-joint RMSE before and after.  The output is a reality file: use it with biped eval --reality, "
        "biped dry-run --reality, biped compare --reality and evolution.")
    fit.add_argument("traces", nargs="+", type=Path, metavar="TRACE", help="trace CSVs from biped excite")
    fit.add_argument("--robot", type=robot_name, help="robot (default: the traces')")
    fit.add_argument("-o", "--output", type=output_file(".yaml", ".yml"), help="reality file to write")
    fit.add_argument("--report", type=output_dir, metavar="DIR",
                     help="write mujoco.sysid's HTML report and an overlay plot (overlay.png) here")
    fit.add_argument("--per-joint", action="store_true", help="fit every joint on its own, not per servo model")
    fit.add_argument("--max-iters", type=int_within(1, MAX_ITERS, "each replays every trace"), default=30,
                     help="optimizer iterations at most (default 30)")
    fit.add_argument("--json", action="store_true", help="print the result as one JSON object")
    fit.set_defaults(func=cmd_sysid, check=check_sysid)


def _program(args: argparse.Namespace):
    from sim2real.hardware.excitation import ExcitationSettings, build_program

    robot = load_robot(args.robot)
    if robot.bus is None:
        raise UsageError(f"robot {robot.name} has no Dynamixel bus (a simulation-only character): "
                         "it cannot be excited through servos")
    settings = ExcitationSettings.for_pose(args.pose, (args.tick_ms or excite_tick_ms(robot)) / 1e3)
    if args.chirp_s is not None:
        settings = dataclasses.replace(settings, chirp_s=args.chirp_s)
    if args.steps:
        settings = dataclasses.replace(settings, step_deg=tuple(args.steps))
    return robot, build_program(robot, args.pose, args.joints, settings)


def excite_tick_ms(robot) -> float:
    """The default excitation tick [ms]: :data:`EXCITE_TICK_MS`, or the whole ms above the
    robot's bus time a tick - positions, board, goals and the traced velocity and load - where
    that is longer (a chain with servos read one by one, say)."""
    import math

    from sim2real.hardware.readings import traced_registers
    from sim2real.robot.bus_plan import bus_time

    needed = bus_time(robot, motion=traced_registers(robot)).total_s * 1e3
    return max(EXCITE_TICK_MS, float(math.ceil(needed)))


def check_excite(args: argparse.Namespace) -> None:
    robot, _ = _program(args)
    if args.baud is not None:
        if not args.port:
            raise UsageError("--baud applies to a real bus (--port); the simulated bus takes the robot's rate")
        check_baud(robot, args.baud)
    if args.port and args.reality:
        raise UsageError("--reality applies to the simulated bus; a real robot is its own reality")


@holding_lock("trace", what="biped excite", flag="--trace")  # the trace and its sidecar: one writer
def cmd_excite(args: argparse.Namespace) -> int:
    from sim2real.cli.deploy_commands import run_exit_code
    from sim2real.hardware.deploy import drive
    from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus

    robot, program = _program(args)
    log = lambda line: print(line, file=sys.stderr)  # noqa: E731
    log(program.describe())
    realtime = realtime_request(args)
    if args.port:
        log(f"the robot must be {'hung by its pelvis, feet free' if program.pose == 'suspended' else 'standing'}; "
            "Ctrl-C stops it safely at any time")
        report = drive(DynamixelBus(args.port, args.baud or robot.bus.baud, robot), robot, program,
                       duration_s=program.duration_s, trace_path=args.trace, log=log, realtime=realtime)
    else:
        from sim2real.simulation.transfer.dry_run import SimulatedBusProcess

        log("no --port: exciting the robot on the simulated bus (MuJoCo behind a pseudo-terminal)")
        simbus_args = ["--robot", args.robot, "--seed", str(args.seed),
                       *(["--suspended"] if program.pose == "suspended" else []),
                       *(["--reality", args.reality] if args.reality else []), *realtime_flags(args)]
        with SimulatedBusProcess(simbus_args, log) as simbus:
            report = drive(DynamixelBus(simbus.port, robot.bus.baud, robot), robot, program,
                           duration_s=program.duration_s, trace_path=args.trace, log=log, realtime=realtime)
    result = {**report.summary(), "trace": str(args.trace), "duration_s": program.duration_s,
              "pose": program.pose, "tick_ms": program.tick_s * 1e3}
    print_result(result, args.json)
    return run_exit_code(result, log)


def _sysid_robot(args: argparse.Namespace):
    """The robot named, else the one the first trace names."""
    from sim2real.hardware.trace import Trace

    from sim2real.hardware.trace import sidecar_path
    from sim2real.robot.names import load_named_robot

    if args.robot:
        return load_robot(args.robot)
    named = Trace.read(args.traces[0]).metadata.get("robot", DEFAULT_ROBOT)
    return load_named_robot(named, str(sidecar_path(args.traces[0])), "robot")


def check_sysid(args: argparse.Namespace) -> None:
    require_module("mujoco", "biped sysid", extra="sysid")
    require_module("scipy", "biped sysid", extra="sysid")
    from mujoco import sysid

    if not hasattr(sysid, "optimize"):
        raise UsageError("biped sysid needs mujoco.sysid's dependencies: pip install 'servo-biped-evolve[sysid]'")
    if args.report is not None:
        require_module("matplotlib", "--report")
    _sysid_robot(args)


@holding_lock("report", what="biped sysid", flag="--report", folder=True)
def cmd_sysid(args: argparse.Namespace) -> int:
    import yaml

    from sim2real.atomic_json import write_text_atomic
    from sim2real.simulation.identify import identify
    from sim2real.simulation.model.physique import measured

    robot = measured(_sysid_robot(args))
    log = lambda line: print(line, file=sys.stderr)  # noqa: E731
    found = identify(args.traces, robot, per_joint=args.per_joint, max_iters=args.max_iters,
                     report_dir=args.report, log=log)
    if args.output:
        description = (f"Identified by `biped sysid` from {', '.join(p.name for p in args.traces)} ({robot.name}, "
                       f"{'per joint' if args.per_joint else 'per servo model'}); RMSE "
                       f"{max(found.rmse_deg_before.values()):.2f} -> {max(found.rmse_deg_after.values()):.2f} deg "
                       "(worst joint). Latency includes the bus's own delay.")
        write_text_atomic(args.output, yaml.safe_dump({"description": description, **found.reality}, sort_keys=False))
    result = found.summary()
    if args.json:
        print(json.dumps(result))
    else:
        print(f"{robot.name}: {found.segments} segments, {found.iterations} iterations, {found.seconds:.0f} s")
        for name, p in found.parameters.items():
            note = "" if p["identifiable"] else "  NOT identifiable from these traces"
            print(f"  {name:<30} {p['value']:9.4f}  [{p['low']:.4f}, {p['high']:.4f}]{note}")
        print("  RMSE per joint [deg], nominal model -> identified:")
        for joint, before in found.rmse_deg_before.items():
            print(f"    {joint:<20} {before:6.2f} -> {found.rmse_deg_after[joint]:6.2f}")
        if args.output:
            print(f"wrote {args.output}")
        if args.report:
            print(f"report: {args.report / 'report.html'}, overlay: {args.report / 'overlay.png'}")
    return 0
