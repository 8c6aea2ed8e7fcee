"""How long ``kanedyn run`` takes to stop: from the signal to the data on disk and
to the exit.

``kanedyn run four-bar --t-end 1e7`` (far longer than the wait) on each backend,
stopped ``--after`` seconds into the simulation by Ctrl-C (SIGINT), by SIGTERM,
or by Ctrl-C twice (0.3 s apart); wall time from the first signal until the
CSV and ``summary.json`` are in the output folder, and until the process has
exited, with its exit status.  One run each (a latency, not a cost: the machine's
load shows in it; the load average is printed).

    python benchmarks/bench_interrupt.py [--after 8] [--backends c,numpy]
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# _fresh_process lives next to this script (on sys.path when run directly)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _fresh_process import SRC, byte_compile_package  # noqa: E402

CASES = {"SIGINT": [signal.SIGINT], "SIGTERM": [signal.SIGTERM],
         "SIGINT twice": [signal.SIGINT, signal.SIGINT]}


def _terminal_child():
    """SIGINT and SIGTERM at their ordinary actions in the child (a parent started
    in the background passes SIGINT on ignored)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def stop_run(backend, signals, after, cache):
    """Seconds from the first signal to the data written and to the exit; the status."""
    out = Path(tempfile.mkdtemp(prefix="kanedyn-bench-interrupt-"))
    env = dict(os.environ, PYTHONPATH=SRC, KANEDYN_CACHE_DIR=cache)
    proc = subprocess.Popen([sys.executable, "-m", "kanedyn.cli", "run", "four-bar", "--t-end",
                             "1e7", "--backend", backend, "--out", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env=env, preexec_fn=_terminal_child)
    for line in proc.stderr:  # the simulation has started
        if "simulating 0.." in line:
            break
    time.sleep(after)
    start = time.perf_counter()
    for k, signum in enumerate(signals):
        if k:
            time.sleep(0.3)
        proc.send_signal(signum)
    data = None
    while proc.poll() is None:
        if data is None and (out / "summary.json").exists() and (out / "four-bar.csv").exists():
            data = time.perf_counter() - start
        time.sleep(0.01)
    proc.stderr.read()
    exited = time.perf_counter() - start
    if data is None and (out / "summary.json").exists():
        data = exited
    return data, exited, proc.returncode


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--after", type=float, default=8.0)
    parser.add_argument("--backends", default="c,numpy")
    args = parser.parse_args(argv)
    byte_compile_package()
    cache = tempfile.mkdtemp(prefix="kanedyn-bench-interrupt-cache-")
    # the four-bar's module built and cached first (not timed)
    subprocess.run([sys.executable, "-m", "kanedyn.cli", "run", "four-bar", "--t-end", "0.1",
                    "--backend", "c", "--quiet", "--out", tempfile.mkdtemp()],
                   env=dict(os.environ, PYTHONPATH=SRC, KANEDYN_CACHE_DIR=cache), check=True)
    print(f"load average before: {os.getloadavg()[0]:.1f} ({os.cpu_count()} cores)\n")
    print("| backend | signal | to CSV and summary written, s | to exit, s | exit status |")
    print("|---|---|---|---|---|")
    for backend in args.backends.split(","):
        for name, signals in CASES.items():
            data, exited, status = stop_run(backend, signals, args.after, cache)
            written = "not written" if data is None else f"{data:.2f}"
            print(f"| {backend} | {name} | {written} | {exited:.2f} | {status} |", flush=True)


if __name__ == "__main__":
    main()
