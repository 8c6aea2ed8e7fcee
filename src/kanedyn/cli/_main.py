"""The ``kanedyn`` command line: one module per command.

::

    kanedyn list
    kanedyn derive MODEL [--latex] [--set name=value ...]
    kanedyn run MODEL [--t-end T] [--out DIR] [--set name=value ...]
    kanedyn demo [--out DIR]
    kanedyn compare nonholonomic|MODEL [--methods kane,lagrange,augmented] [--t-end T]
    kanedyn sweep MODEL --grid m=1:2:11 [--random m=1:2 --samples N] --out DIR
    kanedyn inverse MODEL [--trajectory quintic|sinusoid] [--t-end T] [--points N] [--out DIR]
    kanedyn study [NAME] [--set name=value ...] [--out DIR] [--quiet]
    kanedyn equilibrium MODEL [--hold STATE ...] [--moving COORDINATE ...]
    kanedyn identify MODEL --data FILE.csv --fit NAME [--fit NAME ...] [--set name=value]
    kanedyn optimize [MODEL] [--problem NAME] [--nodes N] [--method M] [--bound tau=-2:2]
    kanedyn export MODEL --fmu FILE.fmu [--fmi-version 2|3] [--set name=value ...]
                   [--nominal state=value ...]
"""

from __future__ import annotations

import argparse
import atexit
import signal
import sys

from .._errors import KanedynError
from .._signals import end_by, exit_status, interruption, last_received, taking_over
from .._version import __version__
from . import (_compare, _demo, _derive, _equilibrium, _export, _identify, _inverse, _list,
               _optimize, _run, _study, _sweep)
from ._streams import guarded

__all__ = ["main"]

COMMANDS = (_list, _derive, _run, _compare, _demo, _sweep, _inverse, _study, _equilibrium,
            _identify, _optimize, _export)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line on stderr (exit code 2)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} "
                     f"(see {self.prog} --help)\n")


def _parser():
    parser = _Parser(
        prog="kanedyn", description="Multibody dynamics by Kane's method.")
    parser.add_argument("--version", action="version", version=f"kanedyn {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        command.add_parser(sub)
    return parser


def main(argv=None):
    """Run the ``kanedyn`` command with the arguments ``argv``; the exit code.

    Bad arguments give one line on stderr and exit code 2, never a traceback;
    so does a file or stdout that cannot be written (a full disk).  SIGTERM
    stops a command as Ctrl-C does (a simulation keeps what it computed,
    ``kanedyn run`` and ``sweep`` write it).  The exit code is then 128 + the
    signal's number, 130 for Ctrl-C and 143 for SIGTERM; called without
    ``argv``, as the ``kanedyn`` program is, the process instead ends by the
    signal once the command has written what it has (at exit, after the
    process's exit hooks), so that a shell stops a loop over such commands and
    reports the same 130 or 143.
    """
    if argv is None:  # the program: registered first of the command's exit hooks,
        atexit.unregister(_end_by_signal)  # so that it runs after the others
        atexit.register(_end_by_signal)
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:  # --help, --version, or a bad argument (reported)
        return stop.code if isinstance(stop.code, int) else 2
    code, signum = _command(args)
    if signum is not None and argv is None:
        _ENDING["signum"] = signum
    return code


_ENDING = {"signum": None}  # the signal the program ends by (main without argv)


def _end_by_signal():
    if _ENDING["signum"] is not None:
        end_by(_ENDING["signum"])


def _command(args):
    """Run the command of ``args``: ``(exit code, the stop signal that ended it or
    None)``."""
    with taking_over(), guarded():
        try:
            code = args.func(args)
            if sys.stdout is not None:  # a stdout that cannot be written: reported here
                sys.stdout.flush()
        except KanedynError as exc:
            print(f"kanedyn: error: {' '.join(str(exc).split())}", file=sys.stderr)
            return 2, None
        except BrokenPipeError:  # output piped into e.g. head, which closed early
            sys.stderr.close()
            return 0, None
        except KeyboardInterrupt as stop:
            signum = getattr(stop, "signum", None) or last_received() or signal.SIGINT
            print(f"kanedyn: {interruption(signum)}", file=sys.stderr)
            return exit_status(signum), signum
        # a command that reports a stop signal itself (sweep: 130 for either)
        received = last_received()
        if received and code in (130, exit_status(received)):
            return exit_status(received), received
        return code, None


if __name__ == "__main__":
    sys.exit(main())
