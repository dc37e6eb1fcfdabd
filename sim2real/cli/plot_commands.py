"""``biped plot``: seed 000's pictures of a walk (``gait``) and a picture of a controller's
network (``network``).

A gait is drawn from a trace (``--trace``, a real robot's or a dry run's: no MuJoCo needed)
or from a simulated episode of a controller, which the evolution side replays (the
``replay`` handler :mod:`evolve.cli` passes in; this package never imports it).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, Callable, Mapping

from sim2real.cli.args import (
    MAX_REPLAY_S,
    check_output_file,
    positive_float_at_most,
    reality_name,
    require_module,
    robot_name,
)
from sim2real.errors import UsageError

PICTURE_SUFFIXES = (".png", ".svg", ".pdf")


def add_commands(sub: argparse._SubParsersAction,
                 replay: Mapping[str, Callable[..., Any]] | None = None) -> None:
    plot = sub.add_parser("plot", help="pictures: a walk's joint angles and phase portraits, a network, a reach",
                          description="Draw a walk's joint angles over time and its hip-knee phase portraits "
                          "(gait, as figures 2-3 of Allen & Faloutsos 2009), an evolved network (network), or a "
                          "reach: the hand's distance to its goal over time (reach).")
    psub = plot.add_subparsers(dest="plot_command", required=True, metavar="{gait,network,reach}")

    gait = psub.add_parser(
        "gait", help="joint angles over a walk and hip-knee phase portraits (Allen & Faloutsos 2009, figures 2-3)",
        description="Hip, knee and ankle pitch of both legs over time, the feet's contacts, and each leg's "
        "knee-against-hip phase portrait: from a simulated episode of CONTROLLER (no harness, until the "
        "episode ends or the robot falls) or from a recorded trace (--trace: a real robot's or a dry run's), "
        "so that the two draw the same way.")
    gait.add_argument("controller", nargs="?", type=Path, help="controller .json to simulate")
    gait.add_argument("--trace", type=Path, help="draw this trace CSV instead (its sidecar names the robot)")
    gait.add_argument("--robot", type=robot_name, help="robot (default: the controller's or the trace's)")
    gait.add_argument("--seconds", type=positive_float_at_most(MAX_REPLAY_S),
                      help=f"episode length, at most {MAX_REPLAY_S:g} s (default: the controller's task)")
    gait.add_argument("--reality", type=reality_name, metavar="PROFILE",
                      help="simulate the robot of this reality file (fixed values) instead of the nominal one")
    gait.add_argument("--disable-module", action="append", default=[], metavar="NAME",
                      help="simulate with this module switched off (repeatable)")
    gait.add_argument("-o", "--output", type=Path, default=Path("gait.png"), help="picture (.png, .svg, .pdf; "
                      "default gait.png)")
    gait.set_defaults(func=cmd_plot_gait, check=check_plot_gait, replay=replay or {})

    net = psub.add_parser(
        "network", help="draw a controller's network: nodes, links, weights, modules",
        description="Draw an evolved network: inputs left, outputs right, hidden nodes in columns by their "
        "distance from the inputs; line width the weight's size, colour its sign (red > 0, blue < 0); "
        "recurrent links arc, self-loops ring their node; hidden nodes in their module's colour, modules "
        "switched off (--disable-module) grey.  One network: the robot runs it as a right and a left copy.")
    net.add_argument("controller", type=Path, help="controller .json")
    net.add_argument("--disable-module", action="append", default=[], metavar="NAME",
                     help="draw this module as switched off (repeatable)")
    net.add_argument("--title", help="title (default: the robot, node and link counts)")
    net.add_argument("-o", "--output", type=Path, default=Path("network.svg"),
                     help="picture (.svg, .png, .pdf; default network.svg)")
    net.set_defaults(func=cmd_plot_network, check=check_plot_network)

    reach = psub.add_parser(
        "reach", help="a reach over time: the hand's distance to its goal, reaching and returning",
        description="The hand's distance to its goal over time with the reach state machine's phases shaded: "
        "from a simulated episode of a reaching CONTROLLER or from a trace (--trace: a real robot's or a dry "
        "run's, which records reach_state and hand_error).")
    reach.add_argument("controller", nargs="?", type=Path, help="reaching controller .json to simulate")
    reach.add_argument("--trace", type=Path, help="draw this trace CSV instead")
    reach.add_argument("--seconds", type=positive_float_at_most(MAX_REPLAY_S),
                       help=f"episode length, at most {MAX_REPLAY_S:g} s (default: the controller's task)")
    reach.add_argument("--disable-module", action="append", default=[], metavar="NAME",
                       help="simulate with this module switched off (repeatable)")
    reach.add_argument("-o", "--output", type=Path, default=Path("reach.png"),
                       help="picture (.png, .svg, .pdf; default reach.png)")
    reach.set_defaults(func=cmd_plot_reach, check=check_plot_reach, replay=replay or {})


# -- gait --------------------------------------------------------------------------------------
def check_plot_gait(args: argparse.Namespace) -> None:
    from sim2real.controller.activation import check_disabled_modules
    from sim2real.controller.file import Controller

    if _check_replay_or_trace(args, "gait", "a controller", (("--seconds", args.seconds), ("--reality", args.reality),
                                                               ("--disable-module", args.disable_module))):
        check_disabled_modules(Controller.load(args.controller), args.disable_module)


def _check_replay_or_trace(args: argparse.Namespace, replay: str, what: str,
                           episode_flags: tuple[tuple[str, Any], ...]) -> bool:
    """A picture drawn from a simulated episode of ``args.controller`` or from ``args.trace``,
    one of them: the output file and matplotlib checked, flags of an episode refused with a
    trace; True when a controller is to be simulated (by the evolve package's ``replay``)."""
    check_output_file(args.output, "-o/--output", PICTURE_SUFFIXES)
    require_module("matplotlib", "biped plot")
    if (args.controller is None) == (args.trace is None):
        raise UsageError(f"give {what} .json to simulate or --trace FILE to draw, one of them")
    if args.trace is not None:
        for flag, given in episode_flags:
            if given:
                raise UsageError(f"{flag} applies to a simulated episode, not to --trace")
        return False
    if replay not in args.replay:
        raise UsageError("simulating a controller needs the evolve package's replay (use `biped`)")
    return True


def cmd_plot_gait(args: argparse.Namespace) -> int:
    from sim2real.figures.gait import Gait, plot_gait

    if args.trace is not None:
        from sim2real.hardware.trace import Trace
        from sim2real.hardware.trace import sidecar_path
        from sim2real.robot import load_robot
        from sim2real.robot.names import load_named_robot

        trace = Trace.read(args.trace)
        name = trace.metadata.get("robot")
        if not args.robot and name is None:
            raise UsageError(f"--trace {args.trace}: its sidecar names no robot; give --robot")
        robot = (load_robot(args.robot) if args.robot else
                 load_named_robot(name, str(sidecar_path(args.trace)), "robot"))
        gait = Gait.from_trace(trace, robot, f"{args.trace.name} (trace, {robot.name})")
    else:
        gait = args.replay["gait"](args.controller, robot=args.robot, seconds=args.seconds, reality=args.reality,
                                   disabled_modules=tuple(args.disable_module))
    from sim2real.gait_measures import describe, measure_recorded

    try:
        measures = measure_recorded(gait)
    except ValueError as exc:  # a trace without foot switches, a robot without hip pitch joints: drawn all the same
        measures, line = None, f"not measured ({exc})"
    else:
        line = describe(measures)
    plot_gait(gait, args.output, measures=measures)
    print(f"wrote {args.output} ({gait.times_s[-1]:.1f} s{', fell' if gait.fell_s is not None else ''})")
    print(f"gait: {line}")
    return 0


# -- network -----------------------------------------------------------------------------------
def check_plot_network(args: argparse.Namespace) -> None:
    from sim2real.controller.activation import check_disabled_modules
    from sim2real.controller.file import Controller

    check_output_file(args.output, "-o/--output", PICTURE_SUFFIXES)
    require_module("matplotlib", "biped plot")
    require_module("networkx", "biped plot network")
    check_disabled_modules(Controller.load(args.controller), args.disable_module)


def cmd_plot_network(args: argparse.Namespace) -> int:
    from sim2real.controller.file import Controller
    from sim2real.figures.network import plot_network

    controller = Controller.load(args.controller)
    plot_network(controller, args.output, tuple(args.disable_module), args.title)
    print(f"wrote {args.output} ({len(controller.hidden)} hidden nodes, {len(controller.connections)} links)")
    return 0


# -- reach -------------------------------------------------------------------------------------
def check_plot_reach(args: argparse.Namespace) -> None:
    from sim2real.controller.activation import check_disabled_modules
    from sim2real.controller.file import Controller

    if not _check_replay_or_trace(args, "reach", "a reaching controller",
                                  (("--seconds", args.seconds), ("--disable-module", args.disable_module))):
        return
    controller = Controller.load(args.controller)
    if "reach" not in controller.input_channels:
        raise UsageError(f"{args.controller}: not a reaching controller (no reach_input)")
    check_disabled_modules(controller, args.disable_module)


def cmd_plot_reach(args: argparse.Namespace) -> int:
    from sim2real.figures.reach import Reach, plot_reach

    if args.trace is not None:
        from sim2real.hardware.trace import Trace

        try:
            reach = Reach.from_trace(Trace.read(args.trace), None, f"{args.trace.name} (trace)")
        except ValueError as exc:
            raise UsageError(f"--trace {args.trace}: {exc}") from None
    else:
        reach = args.replay["reach"](args.controller, seconds=args.seconds, disabled_modules=tuple(args.disable_module))
    plot_reach(reach, args.output)
    n = reach.reaches
    print(f"wrote {args.output} ({reach.times_s[-1]:.1f} s, {n} goal{'' if n == 1 else 's'} reached)")
    return 0
