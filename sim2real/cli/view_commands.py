"""``biped view`` and ``biped render``: a robot standing at its home pose, in the interactive
viewer or offscreen to a picture; or a controller's replay, which the evolution side handles.

Replaying a controller (a ``.json`` argument, and ``render --strip``) belongs to the evolution
side, which passes its handlers to :func:`add_commands`: this package never imports it.
:func:`check_render` refuses flags of the other kind of render, and an output of the wrong kind
or size, before anything is simulated.  MuJoCo is imported inside the commands.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Callable, Mapping

from sim2real.cli.args import (
    MAX_RENDER_PX,
    MAX_SETTLE_S,
    MAX_STRIP_FRAMES,
    MAX_VIDEO_S,
    check_output_file,
    float_within,
    int_within,
    positive_float_at_most,
    require_module,
)
from sim2real.cli.robot_commands import ROBOT_HELP, robot_arg
from sim2real.errors import UsageError
from sim2real.robot import DEFAULT_ROBOT, RobotSpec

# The evolution side's handlers of a controller file, by command ("view", "render", "strip").
Replay = Mapping[str, Callable[[argparse.Namespace], int]]


def _robot_or_controller(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("robot", nargs="?", default=DEFAULT_ROBOT, help=ROBOT_HELP + "; or a controller .json to replay")
    parser.add_argument("--disable-module", action="append", default=[], metavar="NAME",
                        help="replay a controller with this module switched off (repeatable)")


def _is_controller(arg: str) -> bool:
    return str(arg).endswith(".json")


def _replay(args: argparse.Namespace, command: str) -> int:
    if command not in args.replay:
        raise UsageError(f"{command} of a controller file needs the evolve package's replay (use `biped`)")
    return args.replay[command](args)


def add_commands(sub: argparse._SubParsersAction, replay: Replay | None = None) -> None:
    """``view`` and ``render``; ``replay`` handles ``view`` and ``render`` of a controller file
    (keys "view", "render", "strip"); without it those refuse one."""
    view = sub.add_parser("view", help="open the MuJoCo viewer on a robot or a controller",
                          description="Open the interactive MuJoCo viewer on the robot standing at "
                          "its home pose, held by its servos, or replaying a controller.json "
                          "(needs a display).")
    _robot_or_controller(view)
    view.set_defaults(func=cmd_view, check=check_view, replay=replay or {})

    render = sub.add_parser("render", help="render a robot (image) or a controller (video) offscreen",
                            description="Render the robot at its home pose to a PNG, or a controller.json's "
                            "replay to a video (.mp4 or .gif) with a camera that follows the robot "
                            "(offscreen: EGL by default, MUJOCO_GL=osmesa for software rendering).")
    _robot_or_controller(render)
    render.add_argument("-o", "--output", type=Path, default=None,
                        help="output file (default: robot.png, or walk.mp4 for a controller)")
    render.add_argument("--seconds", type=positive_float_at_most(MAX_VIDEO_S, "a video is held in memory"),
                        help=f"replay length for a controller, at most {MAX_VIDEO_S:g} s (default: its episode)")
    render.add_argument("--strip", nargs="+", type=Path, metavar="CONTROLLER",
                        help="a picture of these controllers' replays side by side over time (as figure 1 of "
                        "Allen & Faloutsos 2009): one row each, filmed from the right at --frames moments, all from the "
                        "same distance so that sizes compare (default output strip.png)")
    render.add_argument("--frames", type=int_within(1, MAX_STRIP_FRAMES),
                        help=f"moments of a --strip (default {STRIP_FRAMES}, at most {MAX_STRIP_FRAMES})")
    render.add_argument("--width", type=int_within(1, MAX_RENDER_PX[0], "the offscreen framebuffer's"), default=None,
                        help="pixels (default 960, a --strip frame 320; at most 1280)")
    render.add_argument("--height", type=int_within(1, MAX_RENDER_PX[1], "the offscreen framebuffer's"), default=None,
                        help="pixels (default 720, a --strip frame 400; at most 720)")
    render.add_argument("--settle", type=float_within(0.0, MAX_SETTLE_S, "a robot stands still within seconds"),
                        default=None,
                        help="simulated seconds to stand before the picture of a robot (default 1)")
    render.set_defaults(func=cmd_render, check=check_render, replay=replay or {})


def _standing(robot: RobotSpec, settle_s: float = 0.0):
    import mujoco

    from sim2real.simulation.model.builder import build_model

    model = build_model(robot)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    for _ in range(int(round(settle_s / model.opt.timestep))):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    return model, data


def cmd_view(args: argparse.Namespace) -> int:
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise UsageError("biped view needs a display; on a headless machine use `biped render -o robot.png` "
                         "(or -o walk.mp4 for a controller)")
    if _is_controller(args.robot):
        return _replay(args, "view")
    import mujoco.viewer

    model, data = _standing(robot_arg(args.robot))
    mujoco.viewer.launch(model, data)
    return 0


VIDEO_SUFFIXES = (".mp4", ".gif")
STRIP_FRAMES = 6  # moments of a --strip, by default
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")


def check_view(args: argparse.Namespace) -> None:
    if args.disable_module and not _is_controller(args.robot):
        raise UsageError(f"--disable-module applies to a controller replay, not to robot {args.robot}")


def check_render(args: argparse.Namespace) -> None:
    """Flags that apply to the other kind of render, the output's kind and size, up front."""
    from sim2real.simulation.model.parts import OFFSCREEN_SIZE

    if args.strip:
        _check_strip(args)
    elif args.frames is not None:
        raise UsageError("--frames applies to a --strip")
    elif _is_controller(args.robot):
        if args.settle is not None:
            raise UsageError("--settle applies to a picture of a robot, not to a controller replay")
        args.output = args.output or Path("walk.mp4")
        check_output_file(args.output, "-o/--output (a controller replay is a video)", VIDEO_SUFFIXES)
        require_module("imageio", "writing a video")
        if args.output.suffix.lower() == ".mp4":
            require_module("imageio_ffmpeg", "writing an .mp4 video")
    else:
        for flag, given in (("--seconds", args.seconds is not None), ("--disable-module", args.disable_module)):
            if given:
                raise UsageError(f"{flag} applies to a controller replay, not to a picture of robot {args.robot}")
        args.output = args.output or Path("robot.png")
        check_output_file(args.output, "-o/--output (a picture of a robot)", IMAGE_SUFFIXES)
        require_module("imageio", "writing a picture")
    default_width, default_height = (320, 400) if args.strip else (960, 720)
    args.width, args.height = args.width or default_width, args.height or default_height
    width, height = OFFSCREEN_SIZE
    if args.width > width or args.height > height:
        raise UsageError(f"--width {args.width} --height {args.height}: larger than the offscreen buffer "
                         f"({width} x {height})")


def _check_strip(args: argparse.Namespace) -> None:
    from sim2real.controller.file import Controller

    if args.robot != DEFAULT_ROBOT:
        raise UsageError(f"{args.robot}: with --strip, give every controller to --strip")
    for flag, given in (("--settle", args.settle is not None), ("--disable-module", args.disable_module)):
        if given:
            raise UsageError(f"{flag} does not apply to a --strip")
    for path in args.strip:
        Controller.load(path)  # each one whole, before anything is filmed
    args.output = args.output or Path("strip.png")
    args.frames = args.frames or STRIP_FRAMES
    check_output_file(args.output, "-o/--output (a --strip is a picture)", IMAGE_SUFFIXES)
    require_module("matplotlib", "a --strip")


def cmd_render(args: argparse.Namespace) -> int:
    if args.strip:
        return _replay(args, "strip")
    if _is_controller(args.robot):
        return _replay(args, "render")
    from sim2real.simulation.rendering import render_image, save_image

    model, data = _standing(robot_arg(args.robot), 1.0 if args.settle is None else args.settle)
    save_image(args.output, render_image(model, data, args.width, args.height))
    print(f"wrote {args.output}")
    return 0
