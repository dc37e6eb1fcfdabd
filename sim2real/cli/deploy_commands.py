"""The ``biped`` subcommands that drive a robot: ``run`` (real or mock bus), ``dry-run``
and ``simbus`` (the simulated bus), ``compare`` (a trace against the simulation)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from sim2real.cli.args import (
    add_realtime_arguments,
    baud_rate,
    check_baud,
    check_duration,
    holding_lock,
    output_file,
    positive_float_at_most,
    print_result,
    reality_name,
    realtime_flags,
    realtime_request,
    require_module,
    robot_name,
    run_failed,
    seed,
)
from sim2real.arg_types import HEADING_HELP, REACH_HELP, heading_schedule, reach_target
from sim2real.errors import UsageError
from sim2real.hardware.loop import LOST_AFTER_S
from sim2real.hardware.trace import MAX_TIME_S, sidecar_path
from sim2real.robot import DEFAULT_ROBOT, load_robot
from sim2real.simulation.simbus import service as simbus_service

TRACE_FILE = output_file(exclude=(".json",))  # a trace's sidecar takes its name with .json

# A run's length: at most what a trace's reader accepts as a loop's time (a week; longer is
# a slip of units, and 1e308 s overflowed the tick count); without --duration `run` goes on
# until stopped.
RUN_SECONDS = positive_float_at_most(MAX_TIME_S, "a week: run without --duration to go on until stopped")
# Communication counts as lost after at most a minute without one good reply: a robot left
# that long without a read is not being controlled.
LOST_AFTER_MS = positive_float_at_most(60_000.0, "a minute")


def add_lost_after_argument(parser: argparse.ArgumentParser) -> None:
    """``--lost-after-ms``, as ``biped run`` and ``biped dry-run`` take it."""
    parser.add_argument("--lost-after-ms", type=LOST_AFTER_MS, default=LOST_AFTER_S * 1e3, metavar="MS",
                        help="stop when no read has succeeded for this long (default %(default).0f ms; single "
                        "missed replies are retried and their ticks hold the last goals)")


def add_commands(sub: argparse._SubParsersAction) -> None:
    run = sub.add_parser("run", help="drive a robot with a controller (real bus or mock)",
                         description="Drive the robot with a controller: start-up checks, a slow ramp, "
                         "the real-time loop, and a safe stop (ramp to rest, torque off) however it ends.")
    run.add_argument("controller", type=Path, help="controller JSON (biped export, biped train or configs/controllers/)")
    run.add_argument("--robot", type=robot_name, help="robot (default: the one the controller was made for)")
    where = run.add_mutually_exclusive_group()
    where.add_argument("--port", help="serial port of the real bus, e.g. /dev/ttyUSB0")
    where.add_argument("--bus", choices=["mock", "sim"],
                       help="mock: an in-memory mock bus; sim (the default without --port): the simulated bus")
    run.add_argument("--baud", type=baud_rate, help="baud rate of the real bus (default: the robot config's)")
    run.add_argument("--duration", type=RUN_SECONDS,
                     help="seconds to run (default: until Ctrl-C; 10 on the simulated bus)")
    run.add_argument("--trace", type=TRACE_FILE, help="write a trace CSV (+ JSON sidecar) here")
    run.add_argument("--disable-module", action="append", default=[], metavar="NAME",
                     help="switch a control module off (repeatable)")
    add_lost_after_argument(run)
    run.add_argument("--heading", type=heading_schedule, metavar="DEG|T:DEG,...", help=HEADING_HELP)
    run.add_argument("--reach-target", type=reach_target, metavar="X,Y,Z", help=REACH_HELP)
    run.add_argument("--json", action="store_true", help="print the report as one JSON object")
    add_realtime_arguments(run)
    run.set_defaults(func=cmd_run, check=check_run)
    add_simulated_bus_commands(sub)
    add_compare_command(sub)


def add_simulated_bus_commands(sub: argparse._SubParsersAction) -> None:
    dry = sub.add_parser("dry-run", help="run a controller through the real loop on the simulated bus",
                         description="Start the simulated Dynamixel bus (MuJoCo physics behind a pseudo-terminal) "
                         "and run the same runtime as biped run on it, through the official SDK.  Distance and "
                         "falls come from the simulator's ground truth.")
    dry.add_argument("controller", type=Path, help="controller JSON (biped export, biped train or configs/controllers/)")
    dry.add_argument("--robot", type=robot_name, help="robot (default: the one the controller was made for)")
    dry.add_argument("--duration", type=RUN_SECONDS, default=10.0, help="seconds of the loop (default 10)")
    dry.add_argument("--faults", help="inject faults: silent:ID@SECONDS,overload:ID@SECONDS (seconds into the "
                     "loop, after the start ramp),drop:RATE,corrupt:RATE or a YAML file of them")
    dry.add_argument("--reality", type=reality_name, metavar="PROFILE",
                     help="perturb the simulated robot: a configs/reality/ name (e.g. default) or a path")
    dry.add_argument("--seed", type=seed, default=0, help="seed of the reality profile's random parts (default: %(default)s)")
    dry.add_argument("--trace", type=TRACE_FILE, help="trace CSV (+ JSON sidecar)")
    dry.add_argument("--disable-module", action="append", default=[], metavar="NAME",
                     help="switch a control module off (repeatable)")
    dry.add_argument("--heading", type=heading_schedule, metavar="DEG|T:DEG,...", help=HEADING_HELP)
    dry.add_argument("--reach-target", type=reach_target, metavar="X,Y,Z", help=REACH_HELP)
    add_lost_after_argument(dry)
    dry.add_argument("--json", action="store_true", help="print the report as one JSON object")
    add_realtime_arguments(dry)
    dry.set_defaults(func=cmd_dry_run, check=check_dry_run)

    simbus = sub.add_parser("simbus", help="serve a simulated Dynamixel bus on a pseudo-terminal",
                            description="Serve the robot's servos and sensor board, simulated by MuJoCo in real "
                            "time, on a pseudo-terminal.  Prints the port path as the first line, then serves "
                            "until Ctrl-C or SIGTERM; any Dynamixel tool can connect to it.")
    simbus_service.add_arguments(simbus)
    simbus.set_defaults(func=simbus_service.serve, check=check_simbus)


def add_compare_command(sub: argparse._SubParsersAction) -> None:
    cmp_ = sub.add_parser("compare", help="compare a trace with the simulation: per-joint error and lag",
                          description="Replay a trace's commanded goals in the nominal simulation (or, with "
                          "--controller, run the controller closed-loop) and report per joint the RMSE and MAE "
                          "[deg] and the lag [ms] of the real joint behind the simulated one, and foot-contact "
                          "agreement.")
    cmp_.add_argument("trace", type=Path, help="trace CSV of biped run, dry-run or excite (with its JSON sidecar)")
    cmp_.add_argument("--controller", type=Path, help="simulate this controller closed-loop instead")
    cmp_.add_argument("--robot", type=robot_name, help="robot (default: the trace's)")
    cmp_.add_argument("--reality", type=reality_name, metavar="PROFILE",
                      help="simulate the robot of this reality file (e.g. one biped sysid wrote) instead of the "
                      "nominal one")
    cmp_.add_argument("--json", action="store_true", help="print the comparison as one JSON object")
    cmp_.add_argument("--plot", type=output_file(".png", ".pdf", ".svg"),
                      help="PNG overlaying real and simulated angles per joint")
    cmp_.set_defaults(func=cmd_compare, check=check_compare)


# -- checks before anything runs (evolve.cli calls args.check, then args.func) ---------------
def _servo_robot(name: str | None, controller: Path | None = None):
    """(controller or None, robot): the robot named, else the controller's; it must have a bus."""
    from sim2real.controller.file import Controller

    if controller is not None:
        data, robot = Controller.load_for_robot(controller, name)
    else:
        data, robot = None, load_robot(name or DEFAULT_ROBOT)
    if robot.bus is None:
        raise UsageError(f"robot {robot.name} has no Dynamixel bus (a simulation-only character): "
                         "it cannot be driven through servos")
    return data, robot


def _check_trace(trace: Path | None, controller: Path) -> None:
    if trace is not None and sidecar_path(trace).resolve() == Path(controller).resolve():
        raise UsageError(f"--trace {trace}: its sidecar {sidecar_path(trace)} would overwrite the "
                         "controller")


def check_run(args: argparse.Namespace) -> None:
    from sim2real.controller.activation import check_disabled_modules

    data, robot = _servo_robot(args.robot, args.controller)
    if args.port is not None and not args.port.strip():
        raise UsageError("--port: empty; give the serial port of the real bus, e.g. /dev/ttyUSB0 (without --port "
                         "the run uses the simulated bus)")
    if args.baud is not None:
        if not args.port:
            raise UsageError("--baud applies to a real bus (--port); the mock and simulated buses take the "
                             "robot's rate")
        check_baud(robot, args.baud)
    check_duration(args.duration, float(data.tick_s))
    check_disabled_modules(data, args.disable_module)
    _check_trace(args.trace, args.controller)


def check_dry_run(args: argparse.Namespace) -> None:
    from sim2real.controller.activation import check_disabled_modules
    from sim2real.simulation.simbus.faults import check_fault_times, parse_faults

    data, robot = _servo_robot(args.robot, args.controller)
    check_duration(args.duration, float(data.tick_s))
    check_disabled_modules(data, args.disable_module)
    check_fault_times(parse_faults(args.faults, robot), args.duration)
    _check_trace(args.trace, args.controller)


def check_simbus(args: argparse.Namespace) -> None:
    from sim2real.simulation.simbus.faults import parse_faults

    _, robot = _servo_robot(args.robot)
    if args.baud is not None:
        check_baud(robot, args.baud)
    parse_faults(args.faults, robot)


def check_compare(args: argparse.Namespace) -> None:
    if args.controller is not None:  # the file on its own first; against the robot once the trace names it
        from sim2real.controller.file import Controller

        Controller.load(args.controller)
    if args.plot is not None:
        require_module("matplotlib", "--plot")


def cmd_compare(args: argparse.Namespace) -> int:
    from sim2real.simulation.transfer.compare import compare, plot

    result = compare(args.trace, args.robot, args.controller, args.reality)
    for note in result["notes"]:
        print(f"note: {note}", file=sys.stderr)
    if args.plot:
        plot(result, args.plot)
    result.pop("_series")
    if args.json:
        print(json.dumps(result))
    else:
        print(f"{result['robot']}, {result['ticks']} ticks, {result['mode']}, {result['reality']} robot"
              f"{' (hung)' if result['suspended'] else ''}")
        for name, s in result["joints"].items():
            lag = "     -" if s["lag_ms"] is None else f"{s['lag_ms']:6.0f}"
            print(f"  {name:<18} RMSE {s['rmse_deg']:6.2f} deg  MAE {s['mae_deg']:6.2f} deg  lag {lag} ms")
        print(f"  foot contact agreement {result['contact_agreement'] * 100:.1f} %")
    return 0


@holding_lock("trace", what="biped dry-run", flag="--trace")
def cmd_dry_run(args: argparse.Namespace) -> int:
    from sim2real.simulation.transfer.dry_run import dry_run

    log = lambda line: print(line, file=sys.stderr)  # noqa: E731
    result = dry_run(args.controller, args.robot, args.duration, args.trace, args.faults, log=log,
                     reality=args.reality, seed=args.seed, disabled_modules=tuple(args.disable_module),
                     realtime=realtime_request(args),
                     simbus_realtime=realtime_flags(args), heading=args.heading, reach_target=args.reach_target,
                     lost_after_s=args.lost_after_ms / 1e3)
    print_result(result, args.json)
    return run_exit_code(result, log)


@holding_lock("trace", what="biped run", flag="--trace")
def cmd_run(args: argparse.Namespace) -> int:
    from sim2real.controller.file import Controller
    from sim2real.hardware import MockBus
    from sim2real.hardware.deploy import drive

    data, robot = Controller.load_for_robot(args.controller, args.robot)
    log = lambda line: print(line, file=sys.stderr)  # noqa: E731
    realtime = realtime_request(args)
    if args.port is not None or args.bus == "mock":
        if args.port is not None:
            from sim2real.hardware.dynamixel.sdk_bus import DynamixelBus

            bus = DynamixelBus(args.port, args.baud or robot.bus.baud, robot)
        else:
            bus = MockBus(robot)
        report = drive(bus, robot, data, duration_s=args.duration, trace_path=args.trace,
                       disabled_modules=tuple(args.disable_module), log=log, lost_after_s=args.lost_after_ms / 1e3,
                       realtime=realtime, heading=args.heading, reach_target=args.reach_target)
        result = report.summary()
    else:  # neither: the simulated bus, as in a dry run
        from sim2real.simulation.transfer.dry_run import dry_run

        log("no --port: running on the simulated bus (MuJoCo behind a pseudo-terminal)")
        result = dry_run(args.controller, robot.name if args.robot else None, args.duration or 10.0,
                         args.trace, log=log, disabled_modules=tuple(args.disable_module), realtime=realtime,
                         simbus_realtime=realtime_flags(args), heading=args.heading, reach_target=args.reach_target,
                         lost_after_s=args.lost_after_ms / 1e3)
    print_result(result, args.json)
    return run_exit_code(result, log)


EXIT_TORQUE_UNCONFIRMED = 3


def run_exit_code(result: dict, log) -> int:
    """0: the run ended as asked (its duration, or a signal such as Ctrl-C); 1: it stopped on
    a fault, or (a dry run) its simulated robot went numerically unstable; 3: torque off was
    not confirmed on every servo (the most important message, so it wins)."""
    torque_off = result["torque_off"]
    if torque_off is None:
        log("biped: error: torque off was never read back: cut the power to the robot")
        return EXIT_TORQUE_UNCONFIRMED
    if torque_off["unconfirmed"]:
        log(f"biped: error: torque off NOT confirmed on servo {', '.join(map(str, torque_off['unconfirmed']))}: "
            "cut the power to the robot")
        return EXIT_TORQUE_UNCONFIRMED
    if result["stop_reason"] != "duration reached" and not result.get("stop_signal"):
        return run_failed(f"the run stopped early: {result['stop_reason']}")
    if result.get("unstable"):  # a dry run: the loop was fine, the simulation behind the bus was not
        return run_failed(f"the simulated robot went {result['unstable']}: its distance and falls are no result")
    return 0
