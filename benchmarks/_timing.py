"""Timings that reproduce: contenders interleaved in rounds, minima, spreads.

Every contender is timed once per round, the contenders in turn (so slow
phases of a shared machine fall on all of them alike), for ``rounds`` rounds.
A contender's time is the minimum over the rounds (what the code costs when
nothing else interferes); its spread is ``median / min - 1`` (how much the
rounds scattered). :func:`winner` names a winner only where the intervals
``[min, median]`` of the contenders do not overlap.

CPU time, not wall time: ``time.thread_time`` for single-threaded code (other
processes on the machine do not count), ``time.process_time`` for code that
runs threads of its own (``clock="process"``). Code releasing work to other
processes (a cluster) needs ``clock="wall"``.
"""

from __future__ import annotations

import os
import statistics
import time

__all__ = ["CLOCKS", "Timing", "interleaved", "winner", "ratio_text",
           "optimized_modules_only"]

#: name -> clock function, seconds
CLOCKS = {"thread": time.thread_time, "process": time.process_time,
          "wall": time.perf_counter}


class Timing:
    """Per-call times of one contender over the rounds.

    Attributes
    ----------
    name : str
    times : list of float
        Seconds per call, one entry per round.
    """

    def __init__(self, name, times):
        self.name = name
        self.times = list(times)

    @property
    def best(self):
        """Minimum over the rounds, s per call."""
        return min(self.times)

    @property
    def median(self):
        """Median over the rounds, s per call."""
        return statistics.median(self.times)

    @property
    def spread(self):
        """``median / min - 1`` (0.05: the typical round was 5 % slower)."""
        return self.median / self.best - 1.0

    def __repr__(self):
        return f"Timing({self.name!r}, best={self.best:.3g} s, spread={self.spread:.1%})"


def _calls_for(func, clock, min_time):
    number = 1
    while True:
        start = clock()
        for _ in range(number):
            func()
        if clock() - start >= min_time or number >= 1 << 30:
            return number
        number *= 2


def interleaved(contenders, rounds=7, min_time=0.05, clock="thread", number=None,
                setup=None):
    """Time ``contenders`` interleaved in rounds.

    Parameters
    ----------
    contenders : dict
        ``{name: func}``; ``func()`` is timed (called without arguments).
    rounds : int
        Rounds; each times every contender once, in turn, the round ``r``
        starting with the ``r``-th contender (a fixed order biases: in fresh
        processes the second of two identical cold starts measured 0.05 s
        slower in minimum at 1.5 s).
    min_time : float
        Each timing calls its function often enough to last about this long
        (s of the chosen clock; calibrated once per contender before the
        rounds). 0: one call per timing.
    clock : {"thread", "process", "wall"} or dict
        ``time.thread_time``, ``time.process_time`` (code with threads of its
        own) or ``time.perf_counter``; or ``{name: clock}`` for each contender.
    number : dict, optional
        ``{name: calls per timing}`` instead of the calibration.
    setup : dict, optional
        ``{name: prepare}``: before each timing of that contender, untimed,
        ``arg = prepare()`` is called, and the timing is of one call
        ``func(arg)`` (fresh inputs per timing, e.g. a freshly built model
        for a derivation; no calibration for that contender).

    Returns
    -------
    dict
        ``{name: Timing}`` with seconds per call.
    """
    clocks = clock if isinstance(clock, dict) else dict.fromkeys(contenders, clock)
    for name in contenders:
        if clocks.get(name) not in CLOCKS:
            raise ValueError(f"clock of {name!r} must be one of {', '.join(CLOCKS)}, "
                             f"got {clocks.get(name)!r}")
    if rounds < 1:
        raise ValueError(f"rounds must be at least 1, got {rounds}")
    counts = {}
    setup = setup or {}
    for name in setup:
        if name not in contenders:
            raise ValueError(f"setup names {name!r}, which is not a contender")
    for name, func in contenders.items():
        if name in setup:
            counts[name] = 1
        elif number is not None and name in number:
            counts[name] = number[name]
        else:
            counts[name] = (_calls_for(func, CLOCKS[clocks[name]], min_time)
                            if min_time > 0 else 1)
    times = {name: [] for name in contenders}
    order = list(contenders.items())
    for r in range(rounds):
        k = r % len(order)
        for name, func in order[k:] + order[:k]:
            n, tick = counts[name], CLOCKS[clocks[name]]
            if name in setup:
                arg = setup[name]()
                start = tick()
                func(arg)
                times[name].append(tick() - start)
                continue
            start = tick()
            for _ in range(n):
                func()
            times[name].append((tick() - start) / n)
    return {name: Timing(name, t) for name, t in times.items()}


def winner(timings):
    """The fastest contender where it is clearly fastest, else ``None``.

    Parameters
    ----------
    timings : dict or iterable of Timing

    Returns
    -------
    str or None
        The name of the contender with the smallest minimum if its median is
        below every other contender's minimum (the intervals ``[min, median]``
        do not overlap); ``None`` when they do (no winner can be stated).
    """
    items = list(timings.values()) if isinstance(timings, dict) else list(timings)
    if len(items) < 2:
        return items[0].name if items else None
    ranked = sorted(items, key=lambda t: t.best)
    first = ranked[0]
    return first.name if all(first.median < other.best for other in ranked[1:]) else None


def ratio_text(slow, fast):
    """``slow / fast`` of the minima with both spreads, e.g. ``"3.10x (spreads 2%/5%)"``."""
    return (f"{slow.best / fast.best:.2f}x (spreads {slow.spread:.0%}/"
            f"{fast.spread:.0%})")


def optimized_modules_only():
    """Build every C model of this process (and of the processes it starts) with
    the optimizing compiler alone, so that the optimized modules are what is timed:
    a model's first module from the quick compiler (TinyCC) is what
    ``bench_first_use.py`` and ``bench_quick_module.py`` measure."""
    os.environ["KANEDYN_QUICK_CC"] = ""
