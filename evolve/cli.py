"""``biped``: the project's one command line, its subcommands from both packages.

Subcommands of the deployment side (robot, view, render; run, dry-run, simbus, compare;
excite, sysid; plot) come from :mod:`sim2real.cli`; the evolution side's (evolve, eval, export) from
:mod:`evolve.cli_commands`, which also lets view and render replay a controller.
"""

from __future__ import annotations

import argparse
import os
import sys

# Offscreen rendering on a headless machine needs MUJOCO_GL before mujoco is first imported.
if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")

from evolve import cli_commands, quickstart_cli, train_cli  # noqa: E402
from sim2real.cli import deploy_commands, plot_commands, robot_commands, sysid_commands, view_commands  # noqa: E402
from sim2real.cli.args import NamedStdout  # noqa: E402
from sim2real.errors import BipedError  # noqa: E402


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="biped",
        description="Evolve neural controllers for servo-driven bipeds in MuJoCo and deploy "
        "them to Dynamixel hardware.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    robot_commands.add_commands(sub)  # robot
    view_commands.add_commands(sub, replay=cli_commands.REPLAY)  # view, render
    deploy_commands.add_commands(sub)  # run, dry-run, simbus, compare
    sysid_commands.add_commands(sub)  # excite, sysid
    plot_commands.add_commands(sub, replay=cli_commands.REPLAY)  # plot gait, plot network
    cli_commands.add_commands(sub)
    train_cli.add_command(sub)
    quickstart_cli.add_command(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run ``biped``; returns the exit status: 0 done as asked, 2 bad input (one line
    ``biped: error: ...`` on stderr; argparse's usage errors exit 2 too), 1 a run that
    started but did not end as asked, 130 Ctrl-C."""
    args = build_parser().parse_args(argv)
    stdout = sys.stdout
    named = sys.stdout = NamedStdout(stdout) if stdout is not None else None
    try:
        if getattr(args, "check", None) is not None:
            args.check(args)  # the checks that need more than one flag, before anything runs
        code = int(args.func(args) or 0)
        if sys.stdout is not None:
            sys.stdout.flush()  # a full disk behind `> FILE` is reported here, not ignored at exit
        return code
    except (BipedError, FileNotFoundError, FileExistsError, KeyError) as exc:
        message = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"biped: error: {message}", file=sys.stderr)
        return 2
    except ModuleNotFoundError as exc:
        if _opengl_failed(exc):
            return _opengl_error(exc)
        if exc.name != "mujoco":
            raise
        print(f"biped: error: biped {args.command} needs MuJoCo, which the robot's lean install leaves out: "
              "pip install 'servo-biped-evolve[sim]' (biped run does not need it)", file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. `biped robot show | head -1`: what the reader did not take is lost
        sys.stdout = None  # (else Python's own flush at exit fails again, with a traceback)
        print("biped: error: the standard output was closed before the output ended (a pipe whose reader "
              "stopped, e.g. | head): the rest is not written", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("biped: interrupted", file=sys.stderr)
        return 130
    except OSError as exc:  # the disk or the system refused mid-run (full, read-only, gone)
        print(f"biped: error: {exc}", file=sys.stderr)
        return 1
    except Exception as exc:  # a bug: still one line, unless asked for the traceback
        if _opengl_failed(exc):
            return _opengl_error(exc)
        if os.environ.get("BIPED_TRACEBACK"):
            raise
        print(f"biped: error: unexpected {type(exc).__name__}: {exc} "
              "(a bug; BIPED_TRACEBACK=1 shows where)", file=sys.stderr)
        return 1
    finally:
        if named is not None and sys.stdout is named:  # (a closed pipe sets it to None: leave that)
            sys.stdout = stdout


def _opengl_failed(exc: BaseException) -> bool:
    """Whether ``exc`` came from MuJoCo loading the OpenGL backend MUJOCO_GL names: it does that
    on ``import mujoco``, so a missing library surfaces as whatever PyOpenGL raises."""
    if "MUJOCO_GL" in str(exc):  # mujoco's own check of the variable's value
        return True
    tb = exc.__traceback__
    while tb is not None:
        if any(f"mujoco{os.sep}{gl}" in tb.tb_frame.f_code.co_filename for gl in ("egl", "osmesa", "glfw")):
            return True
        tb = tb.tb_next
    return False


def _opengl_error(exc: BaseException) -> int:
    print(f"biped: error: MuJoCo could not load its OpenGL backend MUJOCO_GL={os.environ.get('MUJOCO_GL')} "
          f"({type(exc).__name__}: {exc}). Install it (Debian: libegl1 libgl1-mesa-dri for egl, libosmesa6 for "
          "osmesa) or choose another with MUJOCO_GL", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
