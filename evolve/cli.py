"""``biped``: the project's one command line, its subcommands from both packages.

Subcommands of the deployment side (robot, view, render) come from
:mod:`sim2real.cli`; the evolution side adds its own here.
"""

from __future__ import annotations

import argparse
import sys

from sim2real import cli as sim2real_cli
from sim2real.errors import BipedError


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="biped",
        description="Evolve neural controllers for servo-driven bipeds in MuJoCo and deploy "
        "them to Dynamixel hardware.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    sim2real_cli.add_commands(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (BipedError, FileNotFoundError, KeyError) as exc:
        message = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"biped: error: {message}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. `biped robot show | head`
        sys.stdout = None
        return 0
    except KeyboardInterrupt:
        print("biped: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
