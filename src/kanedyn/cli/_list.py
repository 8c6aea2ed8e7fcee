"""``kanedyn list``: the built-in models and their options."""

from __future__ import annotations

from ..models import REGISTRY

__all__ = ["add_parser", "cmd_list"]


def add_parser(sub):
    """Add the ``list`` sub-command to ``sub``."""
    p = sub.add_parser("list", help="list the built-in models")
    p.set_defaults(func=cmd_list)


def cmd_list(args):
    print(f"{'model':26s} description (options: --set NAME=VALUE)")
    for name, (builder, options) in REGISTRY.items():
        print(f"{name:26s} {builder().title}")
        if options:
            opts = ", ".join(f"{k}=<{t.__name__}>" for k, t in options.items())
            print(f"{'':26s}   options: {opts}")
    return 0
