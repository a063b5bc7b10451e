"""The ``robocal`` command: a thin shell over the Python API.

Each subcommand lives in its own module of this package and is registered in ``COMMANDS``;
a module defines ``add_parser(subparsers)`` (which sets ``func``) and nothing else is needed.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from robocal.errors import RobocalError

# subcommand name -> module in robocal.cli (one file per command)
COMMANDS = {
    "robots": "robots", "demo": "demo",
    "report": "report", "export": "export",
    "import": "importer", "simulate": "simulate", "evaluate": "evaluate",
    "calibrate": "calibrate", "analyze": "analyze",
    "plan": "plan", "poses": "poses", "compensate": "compensate",
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="robocal",
        description="Kinematic calibration of serial industrial robots.",
        epilog="Example: robocal robots",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress output")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in COMMANDS.values():
        importlib.import_module(f"robocal.cli.{module}").add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from robocal.progress import set_quiet

    set_quiet(args.quiet)
    try:
        return int(args.func(args) or 0)
    except RobocalError as exc:
        print(f"robocal {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"robocal {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into e.g. head, which stopped reading
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
