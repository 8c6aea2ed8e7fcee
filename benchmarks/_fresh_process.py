"""Fresh Python processes for cold-start timings.

A timed process imports the package from this checkout with its bytecode up to
date (as an installed package has it) and uses the cache directory it is given.
"""

from __future__ import annotations

import compileall
import os
import subprocess
import sys
from pathlib import Path

__all__ = ["SRC", "byte_compile_package", "run_python"]

#: the checkout's source folder, put on the timed processes' path
SRC = str(Path(__file__).resolve().parents[1] / "src")


def byte_compile_package(src=SRC):
    """Write the bytecode of every module of the package (in the source folder
    ``src``, this checkout's by default) that lacks it or is older than its
    source.  Installing the package writes it, and so does the first import of an
    edited module, unless ``PYTHONDONTWRITEBYTECODE`` is set (as on some
    machines): then each timed process would compile the edited modules from source
    again (0.04 s at first use after a day of edits)."""
    compileall.compile_dir(str(Path(src) / "kanedyn"), quiet=1)


def run_python(code, cache, quick=None, src=SRC):
    """Run ``code`` in a fresh interpreter with the package of the source folder
    ``src`` (this checkout's by default) and the cache directory ``cache``
    (``XDG_CACHE_HOME``; ``KANEDYN_CACHE_DIR`` removed); ``quick=False`` turns the
    quick compiler off (``KANEDYN_QUICK_CC`` empty), ``None`` leaves the
    environment's choice.

    Returns
    -------
    subprocess.CompletedProcess
        With the standard output and error as text.
    """
    env = dict(os.environ, PYTHONPATH=src, XDG_CACHE_HOME=cache)
    env.pop("KANEDYN_CACHE_DIR", None)
    if quick is False:
        env["KANEDYN_QUICK_CC"] = ""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env)
