"""The ``kanedyn`` command line (see :mod:`kanedyn.cli._main`)."""

from ._main import main

__all__ = ["main"]
