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
"""

from __future__ import annotations

import argparse
import signal
import sys

from .._errors import KanedynError
from .._signals import exit_status, interruption, last_received, taking_over
from .._version import __version__
from . import _compare, _demo, _derive, _inverse, _list, _run, _study, _sweep

__all__ = ["main"]

COMMANDS = (_list, _derive, _run, _compare, _demo, _sweep, _inverse, _study)


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

    Bad arguments give one line on stderr and exit code 2, never a traceback.
    SIGTERM stops a command as Ctrl-C does (a simulation keeps what it computed,
    ``kanedyn run`` and ``sweep`` write it); the exit code is then 128 + the
    signal's number: 130 for Ctrl-C, 143 for SIGTERM.
    """
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:  # --help, --version, or a bad argument (reported)
        return stop.code if isinstance(stop.code, int) else 2
    with taking_over():
        try:
            code = args.func(args)
        except KanedynError as exc:
            print(f"kanedyn: error: {' '.join(str(exc).split())}", file=sys.stderr)
            return 2
        except BrokenPipeError:  # output piped into e.g. head, which closed early
            sys.stderr.close()
            return 0
        except KeyboardInterrupt as stop:
            signum = getattr(stop, "signum", None) or last_received() or signal.SIGINT
            print(f"kanedyn: {interruption(signum)}", file=sys.stderr)
            return exit_status(signum)
        # a command that reports a Ctrl-C (130) itself: the status of the signal that came
        received = last_received()
        return exit_status(received) if code == 130 and received else code


if __name__ == "__main__":
    sys.exit(main())
