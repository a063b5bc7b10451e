"""The ``robocal`` command: a thin shell over the Python API.

Each subcommand lives in its own module of this package and is registered in ``COMMANDS``;
a module defines ``add_parser(subparsers)`` (which sets ``func``) and nothing else is needed.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import threading
import traceback
import warnings

from robocal.core.errors import ListedError, RobocalError
from robocal.core.resources import out_of_memory
from robocal.core.version import __version__

DEBUG_ENV = "ROBOCAL_DEBUG"  # set to 1 to see the traceback of an internal error

# subcommand name -> module in robocal.cli (one file per command)
COMMANDS = {
    "robots": "robots", "demo": "demo",
    "report": "report", "export": "export",
    "import": "importer", "simulate": "simulate", "evaluate": "evaluate",
    "import-calibration": "import_calibration",
    "calibrate": "calibrate", "analyze": "analyze",
    "plan": "plan", "poses": "poses", "compensate": "compensate",
    "filter": "filter", "tool": "tool", "check": "check",
    "history": "history", "sample": "sample",
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


# numpy's floating-point warnings ("overflow encountered in matmul") become the one-line error they
# announce: a computation that overflowed or produced NaN from the input cannot be trusted
_FLOAT_WARNING = r"(overflow|invalid value|divide by zero) encountered"


MAX_MESSAGE = 2000  # characters of an error line (a message quoting a huge value is cut)


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc)[:100 * MAX_MESSAGE].split())
    return text if len(text) <= MAX_MESSAGE else text[:MAX_MESSAGE] + " ... (cut)"


class _Interrupts:
    """SIGINT raises KeyboardInterrupt as usual and is also remembered: a library that turns the
    interrupt into another exception (numpy's C extensions make an ImportError of it during their
    import) still ends as an interrupt. Main thread only, and only over Python's own handler
    (an ignored SIGINT stays ignored; another program's handler stays its own); Python's handler
    is put back on every path (``signal.signal`` runs a pending handler first, which may be this
    one raising: the swap is retried until done, the interrupt then raised)."""

    def __init__(self) -> None:
        self.seen = False
        self.installed = False

    def _handler(self, signum, frame):
        self.seen = True
        raise KeyboardInterrupt

    def __enter__(self):
        if threading.current_thread() is threading.main_thread() \
                and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            self.installed = True  # before the swap: an interrupt right after it still restores
            signal.signal(signal.SIGINT, self._handler)
        return self

    def __exit__(self, *exc) -> None:
        if not self.installed:
            return
        interrupt = None
        while signal.getsignal(signal.SIGINT) == self._handler:
            try:
                signal.signal(signal.SIGINT, signal.default_int_handler)
            except KeyboardInterrupt as caught:  # this handler ran first: put back, then raised
                interrupt = caught
        self.installed = False
        if interrupt is not None:
            raise interrupt


def main(argv: list[str] | None = None) -> int:
    """Run the command line; the exit code: 0 done, 2 the user's input refused (one line on
    stderr), 3 an internal error (a bug), 130 interrupted (Ctrl-C at any moment, also while the
    handlers are set up or put back)."""
    command = "robocal"
    interrupts = _Interrupts()
    try:
        with interrupts:
            parser = build_parser()
            argv = sys.argv[1:] if argv is None else list(argv)
            args = parser.parse_args(argv)
            command = f"robocal {args.command}"
            return _run(args, argv, interrupts)
    except KeyboardInterrupt:
        pass
    except Exception:
        if not interrupts.seen:
            raise
    print(f"{command}: interrupted", file=sys.stderr)
    return 130


def _run(args, argv: list[str], interrupts: _Interrupts) -> int:
    args.argv = argv  # the command line as given (the result's provenance)
    from robocal.core.progress import set_quiet

    set_quiet(args.quiet)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("error", message=_FLOAT_WARNING, category=RuntimeWarning)
            return int(args.func(args) or 0)
    except ListedError as exc:  # a headline, then one item a line
        lines = [" ".join(line.split()) for line in str(exc).splitlines() if line.strip()]
        print(f"robocal {args.command}: error: {lines[0]}", *(f"  {line}" for line in lines[1:]),
              sep="\n", file=sys.stderr)
        return 2
    except RobocalError as exc:  # one line, whatever the message holds (e.g. a YAML parser's)
        print(f"robocal {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except RuntimeWarning as exc:
        print(f"robocal {args.command}: error: a computation on the input overflowed or gave no number "
              f"({_one_line(exc)}): a value in the input is far beyond what a robot has",
              file=sys.stderr)
        return 2
    except MemoryError:  # what ran out is named; the traceback's arrays are freed by now
        print(f"robocal {args.command}: error: {out_of_memory('the command', args.command)}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into e.g. head, which stopped reading
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except Exception as exc:  # a bug: one line for the user, the traceback on request
        if interrupts.seen:  # an interrupt another library turned into its own exception
            raise KeyboardInterrupt from None
        if os.environ.get(DEBUG_ENV):
            traceback.print_exc()
        print(f"robocal {args.command}: internal error ({type(exc).__name__}: {_one_line(exc)}); "
              f"this is a bug in robocal: please report it with the command line (set {DEBUG_ENV}=1 for the "
              "traceback)", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
