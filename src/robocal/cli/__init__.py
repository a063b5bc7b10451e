"""The ``robocal`` command: a thin shell over the Python API.

Each subcommand lives in its own module of this package and is registered in ``COMMANDS``;
a module defines ``add_parser(subparsers)`` (which sets ``func``) and nothing else is needed.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import traceback

from robocal.errors import ListedError, RobocalError
from robocal.version import __version__

DEBUG_ENV = "ROBOCAL_DEBUG"  # set to 1 to see the traceback of an internal error

# subcommand name -> module in robocal.cli (one file per command)
COMMANDS = {
    "robots": "robots", "demo": "demo",
    "report": "report", "export": "export",
    "import": "importer", "simulate": "simulate", "evaluate": "evaluate",
    "calibrate": "calibrate", "analyze": "analyze",
    "plan": "plan", "poses": "poses", "compensate": "compensate",
    "filter": "filter", "tool": "tool",
}


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors: what is wrong and where the help is."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="robocal",
        description="Kinematic calibration of serial industrial robots.",
        epilog="Example: robocal robots",
    )
    parser.add_argument("--version", action="version", version=f"robocal {__version__}")
    parser.add_argument("--quiet", action="store_true", help="no progress output")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True,
                                parser_class=_Parser)
    for module in COMMANDS.values():
        importlib.import_module(f"robocal.cli.{module}").add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    args.argv = argv  # the command line as given (the result's provenance)
    from robocal.progress import set_quiet

    set_quiet(args.quiet)
    try:
        return int(args.func(args) or 0)
    except ListedError as exc:  # a headline, then one item a line
        lines = [" ".join(line.split()) for line in str(exc).splitlines() if line.strip()]
        print(f"robocal {args.command}: error: {lines[0]}", *(f"  {line}" for line in lines[1:]),
              sep="\n", file=sys.stderr)
        return 2
    except RobocalError as exc:  # one line, whatever the message holds (e.g. a YAML parser's)
        print(f"robocal {args.command}: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"robocal {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into e.g. head, which stopped reading
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except Exception as exc:  # a bug: one line for the user, the traceback on request
        if os.environ.get(DEBUG_ENV):
            traceback.print_exc()
        print(f"robocal {args.command}: internal error ({type(exc).__name__}: {exc}); this is a bug in "
              f"robocal: please report it with the command line (set {DEBUG_ENV}=1 for the traceback)",
              file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
