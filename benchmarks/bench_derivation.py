"""Derivation speed, equation size and right-hand-side speed: kanedyn vs SymPy.

Every number in the printed table is measured in the same run, on the same
machine, for both tools, so the ratios are what matters (design rule 15).

For each model (the 3D chain of ``n`` rigid bodies, n = 2 .. ``--max-n``, and
the Whipple bicycle) the script measures

* derivation time: SymPy's ``KanesMethod(...)`` + ``kanes_equations(bodies,
  loads)`` + reading ``mass_matrix_full`` and ``forcing_full``, against
  :func:`kanedyn.kane` (which returns the equations in compact form, ready for
  numerics), and kanedyn's derivation plus numerical code generation;
* SymPy's ``lambdify`` time of ``[mass_matrix_full, forcing_full]``;
* operation counts (``sympy.count_ops``): SymPy's explicit matrices, the same
  after a joint ``sympy.cse``, and kanedyn's compact form
  (:meth:`kanedyn.EquationsOfMotion.operation_counts`);
* microseconds per right-hand-side call: SymPy's lambdified matrices followed
  by ``numpy.linalg.solve`` (the usual PyDy path) against kanedyn's
  ``model.rhs(t, y)`` with the numpy backend, and the relative difference of
  the two results at the same state.

A second table compares what code ported from SymPy reads: the explicit
``mass_matrix_full`` and ``forcing_full``.  For two chains, the one written as
SymPy's documentation writes models (:func:`_peers.sympy_docs_chain`:
``orient_axis`` about alternating x/y axes, ``v2pt_theory``, full inertia
dyadics, one set of parameters per link) and the built-in ``chain3d``, it
times ``kd.kane`` alone and ``kd.kane`` followed by reading
``mass_matrix_full`` and ``forcing_full``, against SymPy's ``KanesMethod`` +
``kanes_equations`` + reading the same two matrices, and optionally
(``--explicit-lambdify``) ``sm.lambdify(..., cse=True)`` of both tools'
matrices.

Usage::

    python benchmarks/bench_derivation.py              # full run, several minutes
    python benchmarks/bench_derivation.py --max-n 5 --no-bicycle   # a look
    python benchmarks/bench_derivation.py --quick      # smoke run (n <= 4)
    python benchmarks/bench_derivation.py --markdown   # table as markdown
    python benchmarks/bench_derivation.py --explicit-only --explicit-n 3 5 8

Progress goes to stderr, the table to stdout.
"""

from __future__ import annotations

import argparse
import datetime
import gc
import os
import platform
import subprocess
import sys
import time
import warnings

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me
from sympy.core.cache import clear_cache

import kanedyn as kd

# _peers lives next to this script (on sys.path when the script is run directly)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _peers import sympy_docs_chain  # noqa: E402
from _timing import interleaved, winner  # noqa: E402
from bench_numerics import cpu_name  # noqa: E402

#: Relative difference of the two right-hand sides above which a row is flagged.
DISAGREEMENT = 1e-6


# ----------------------------------------------------------------- helpers
def machine_info():
    """One line describing the machine and the versions measured.

    Returns
    -------
    str
    """
    cpu = cpu_name()
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "?"
    return (f"{datetime.date.today().isoformat()} | {platform.platform()} | "
            f"CPU {cpu} ({os.cpu_count()} logical, load {load}) | "
            f"Python {platform.python_version()} | SymPy {sm.__version__} | "
            f"NumPy {np.__version__} | kanedyn {kd.__version__}{source_revision()}")


def source_revision():
    """`` (git <hash>)`` of the kanedyn checkout, or ``""`` outside a git tree."""
    try:
        out = subprocess.run(["git", "describe", "--always", "--dirty"],
                             cwd=os.path.dirname(kd.__file__), capture_output=True,
                             text=True, timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return ""
    return f" (git {out.stdout.strip()})" if out.returncode == 0 and out.stdout.strip() else ""


def fresh_start():
    """Empty SymPy's global cache and collect garbage before a timing.

    Both tools build on SymPy; clearing its cache keeps one derivation from
    profiting from expressions built by an earlier one.
    """
    clear_cache()
    gc.collect()


def winner_text(timings):
    """The clear winner's name, or ``"none"`` where the spreads overlap."""
    return winner(timings) or "none"


def benchmark_state(definition, model, seed=0):
    """A generic, consistent state: the model's initial state, perturbed.

    The independent coordinates and speeds are moved by up to 0.2 (rad,
    rad/s, m or m/s) so that no velocity-dependent term vanishes; dependent
    ones are then completed from the constraints.

    Returns
    -------
    numpy.ndarray
        ``y = [q, u]`` in the order of ``model.state_names``.
    """
    rng = np.random.default_rng(seed)
    y = definition.initial(model)
    independent = np.r_[0:model.n_q_ind, model.n_q:model.n_q + model.n_u_ind]
    y[independent] += rng.uniform(-0.2, 0.2, independent.size)
    return model.consistent_state(0.0, y)


# ---------------------------------------------------------------- kanedyn
def derivations(name, options, rounds=3):
    """Time SymPy's ``KanesMethod``, :func:`kanedyn.kane` and kane + code generation.

    The three are timed interleaved in ``rounds`` rounds
    (:func:`_timing.interleaved`, thread CPU time), each timing on a freshly
    built model with SymPy's cache cleared (untimed), so nothing is reused.

    Parameters
    ----------
    name : str
        Built-in model name (``kanedyn list``).
    options : dict
        Model options, e.g. ``{"n": 8}``.
    rounds : int
        Number of rounds.

    Returns
    -------
    timings : dict
        ``{"sympy", "kanedyn", "kanedyn+codegen": Timing}``, s per derivation.
    ours : dict
        ``definition``, ``eom``, ``model`` of the last kanedyn timing.
    theirs : dict
        The last SymPy result (:func:`sympy_derivation`).
    """
    ours, theirs = {}, {}

    def prepare():
        definition = kd.models.build(name, **options)
        fresh_start()
        return definition

    def kane(definition):
        ours.update(definition=definition, eom=kd.kane(**definition.kane_args))

    def kane_codegen(definition):
        eom = kd.kane(**definition.kane_args)
        ours.update(definition=definition, eom=eom, model=definition.numeric(eom))

    def sympy(definition):
        theirs.update(sympy_kanes_method(definition))

    timings = interleaved({"sympy": sympy, "kanedyn": kane, "kanedyn+codegen": kane_codegen},
                          rounds=rounds, min_time=0,
                          setup=dict.fromkeys(("sympy", "kanedyn", "kanedyn+codegen"),
                                              prepare))
    if "model" not in ours or ours["model"] is None:
        ours["model"] = ours["definition"].numeric(ours["eom"])
    return timings, ours, theirs


def kanedyn_operation_counts(eom):
    """Operation counts of kanedyn's compact equations.

    Returns
    -------
    tuple of int
        ``(mass_matrix, forcing, all, all_cse)``; each counts the
        intermediates it needs; ``all`` is everything the right-hand side
        evaluates (mass matrix, forcing and, for constrained models, the
        constraint matrices), with shared intermediates counted once;
        ``all_cse`` the same after the joint common-subexpression elimination
        of the C code generator (the number to set beside SymPy+CSE).
    """
    counts = eom.operation_counts()
    return counts["mass_matrix"], counts["forcing"], counts["all"], counts["all_cse"]


# ------------------------------------------------------------------ SymPy
def sympy_derivation(name, options):
    """SymPy's ``KanesMethod`` on a freshly built model, wall time of one run.

    Returns
    -------
    dict
        As :func:`sympy_kanes_method`, plus ``derive_s``.
    """
    definition = kd.models.build(name, **options)
    fresh_start()
    start = time.perf_counter()
    out = sympy_kanes_method(definition)
    out["derive_s"] = time.perf_counter() - start
    return out


def sympy_kanes_method(definition):
    """SymPy's ``KanesMethod`` of ``definition``: what the SymPy timing covers.

    Constructing ``KanesMethod``, ``kanes_equations(bodies, loads)`` and
    reading ``mass_matrix_full`` and ``forcing_full``.

    Returns
    -------
    dict
        ``kane`` (the ``KanesMethod``), ``mass_matrix_full``, ``forcing_full``
        and ``definition``.
    """
    args = definition.kane_args
    with warnings.catch_warnings():
        # SymPy warns that a point's velocity could be found along several
        # paths (the bicycle); the warning is about SymPy's own bookkeeping.
        warnings.simplefilter("ignore", UserWarning)
        kane = me.KanesMethod(
            args["frame"], args["q_ind"], args["u_ind"], kd_eqs=args["kd_eqs"],
            q_dependent=args.get("q_dep") or None,
            u_dependent=args.get("u_dep") or None,
            configuration_constraints=args.get("configuration_constraints") or None,
            velocity_constraints=args.get("velocity_constraints") or None)
        kane.kanes_equations(args["bodies"], args["loads"])
        mass, forcing = kane.mass_matrix_full, kane.forcing_full
    return {"kane": kane, "mass_matrix_full": mass, "forcing_full": forcing,
            "definition": definition}


def sympy_operation_counts(mass, forcing):
    """Operation counts of SymPy's explicit matrices, without and with CSE.

    Parameters
    ----------
    mass, forcing : sympy.Matrix
        ``mass_matrix_full`` and ``forcing_full``.

    Returns
    -------
    tuple of int
        ``(mass_matrix, forcing, after_cse)``; ``after_cse`` counts the
        replacements and reduced expressions of one joint ``sympy.cse``.
    """
    n_mass, n_forcing = sm.count_ops(mass), sm.count_ops(forcing)
    replacements, reduced = sm.cse([mass, forcing])
    after_cse = (sum(sm.count_ops(expr) for _, expr in replacements)
                 + sum(sm.count_ops(expr) for expr in reduced))
    return int(n_mass), int(n_forcing), int(after_cse)


def sympy_rhs(sympy_result):
    """The PyDy-style right-hand side from SymPy's matrices.

    ``lambdify([q + u, constants], [M_full, F_full], cse=True)``, then
    ``numpy.linalg.solve``.

    Returns
    -------
    rhs : callable
        ``rhs(t, y) -> ydot``.
    seconds : float
        Time taken by ``lambdify``.
    """
    kane, definition = sympy_result["kane"], sympy_result["definition"]
    constants = list(definition.constants)
    values = np.array([float(definition.constants[c]) for c in constants])
    state = list(kane.q) + list(kane.u)
    start = time.perf_counter()
    matrices = sm.lambdify([state, constants], [sympy_result["mass_matrix_full"],
                                                sympy_result["forcing_full"]], cse=True)
    seconds = time.perf_counter() - start

    def rhs(t, y):
        mass, forcing = matrices(y, values)
        return np.linalg.solve(mass, forcing).ravel()

    return rhs, seconds


# -------------------------------------------------------------- one model
def benchmark_model(name, options, args, log):
    """All measurements of one model; returns one table row (a dict)."""
    label = name + "".join(f" {k}={v}" for k, v in options.items())
    times, ours, theirs = derivations(name, options, rounds=args.repeat)
    log(f"{label}: derive kanedyn {times['kanedyn'].best:.3f} s, "
        f"SymPy {times['sympy'].best:.2f} s")

    row = {"model": name, "n": options.get("n", "-"),
           "sympy": times["sympy"], "kanedyn": times["kanedyn"],
           "codegen": times["kanedyn+codegen"],
           "derive_winner": winner_text({k: times[k] for k in ("sympy", "kanedyn")}),
           "ops_kanedyn": kanedyn_operation_counts(ours["eom"])}
    row["ops_sympy"] = sympy_operation_counts(theirs["mass_matrix_full"],
                                              theirs["forcing_full"])
    log(f"{label}: operation counts done")

    model, eom = ours["model"], ours["eom"]
    state_sympy = [str(s) for s in list(theirs["kane"].q) + list(theirs["kane"].u)]
    if state_sympy != [str(s) for s in eom.state]:
        raise RuntimeError(f"{label}: state orders differ: {state_sympy} "
                           f"vs {[str(s) for s in eom.state]}")
    y = benchmark_state(ours["definition"], model)
    n = options.get("n", 0)
    if args.skip_sympy_rhs or n > args.sympy_rhs_max_n:
        row["rhs_kanedyn"] = interleaved({"kanedyn": lambda: model.rhs(0.0, y)},
                                         rounds=7, min_time=0.2)["kanedyn"]
        row["rhs_sympy"] = row["lambdify_s"] = row["rhs_diff"] = row["rhs_winner"] = None
    else:
        rhs, row["lambdify_s"] = sympy_rhs(theirs)
        rhs_times = interleaved({"kanedyn": lambda: model.rhs(0.0, y),
                                 "sympy": lambda: rhs(0.0, y)}, rounds=7, min_time=0.2)
        row["rhs_kanedyn"], row["rhs_sympy"] = rhs_times["kanedyn"], rhs_times["sympy"]
        row["rhs_winner"] = winner_text(rhs_times)
        ours_ydot, theirs_ydot = model.rhs(0.0, y), rhs(0.0, y)
        row["rhs_diff"] = float(np.max(np.abs(ours_ydot - theirs_ydot))
                                / max(np.max(np.abs(ours_ydot)), 1e-300))
    log(f"{label}: right-hand sides done")
    return row


# ------------------------------------------------------------------ table
COLUMNS = ("model", "n", "SymPy derive s", "kanedyn derive s", "speed-up",
           "faster (clear)", "kanedyn derive+codegen s", "SymPy lambdify s", "ops M/F SymPy",
           "ops SymPy+CSE", "ops M/F (joint) kanedyn", "ops kanedyn+CSE",
           "RHS µs SymPy lambdify+solve",
           "RHS µs kanedyn numpy", "RHS speed-up", "faster RHS (clear)", "RHS rel. diff")


def format_count(count):
    """``1,234``; ``56.8k``; ``2.61M``."""
    if count < 10_000:
        return f"{count:,}"
    if count < 1_000_000:
        return f"{count / 1e3:.1f}k"
    return f"{count / 1e6:.2f}M"


def format_seconds(seconds):
    """Three significant digits."""
    return f"{seconds:.3g}" if seconds < 100 else f"{seconds:.0f}"


def times_text(ratio):
    """``"3.4x"`` below 10, ``"68x"`` from 10 on."""
    return f"{ratio:.1f}x" if ratio < 10 else f"{ratio:.0f}x"


def with_spread(timing, scale=1.0, digits=None):
    """``"1.23 (4%)"``: a timing's minimum (times ``scale``) and its spread."""
    value = timing.best * scale
    text = format_seconds(value) if digits is None else f"{value:.{digits}f}"
    return f"{text} ({timing.spread:.0%})"


def row_cells(row):
    """The table cells of one row, as strings (column order of :data:`COLUMNS`)."""
    m, f, joint, joint_cse = row["ops_kanedyn"]
    sm_m, sm_f, sm_cse = row["ops_sympy"]
    measured = row["rhs_sympy"] is not None
    if measured:
        wrong = " (!)" if row["rhs_diff"] > DISAGREEMENT else ""
        lambdify = format_seconds(row["lambdify_s"])
        rhs_sympy = with_spread(row["rhs_sympy"], 1e6, 0) + wrong
        rhs_ratio = f"{row['rhs_sympy'].best / row['rhs_kanedyn'].best:.2f}x"
        rhs_diff = f"{row['rhs_diff']:.1e}"
        rhs_winner = row["rhs_winner"]
    else:
        lambdify = rhs_sympy = "skipped"
        rhs_ratio = rhs_diff = rhs_winner = "-"
    return [row["model"], str(row["n"]), with_spread(row["sympy"]),
            with_spread(row["kanedyn"]),
            times_text(row["sympy"].best / row["kanedyn"].best), row["derive_winner"],
            with_spread(row["codegen"]), lambdify,
            f"{format_count(sm_m)}/{format_count(sm_f)}", format_count(sm_cse),
            f"{format_count(m)}/{format_count(f)} ({format_count(joint)})",
            format_count(joint_cse),
            rhs_sympy, with_spread(row["rhs_kanedyn"], 1e6, 0), rhs_ratio, rhs_winner,
            rhs_diff]


def format_table(rows, markdown=False):
    """The results as a plain-text or markdown table.

    Parameters
    ----------
    rows : list of dict
        From :func:`benchmark_model`.
    markdown : bool
        Markdown table instead of aligned plain text.

    Returns
    -------
    str
    """
    return format_rows(COLUMNS, [row_cells(row) for row in rows], markdown=markdown)


NOTES = """\
Notes:
- speed-up = SymPy derive s / kanedyn derive s; RHS speed-up = SymPy µs / kanedyn µs.
- SymPy derive: KanesMethod(...) + kanes_equations(bodies, loads) + mass_matrix_full
  and forcing_full. kanedyn: kd.kane(...); derive+codegen adds
  definition.numeric(eom). The three interleaved in {repeat} rounds, each timing on
  a freshly built model with SymPy's global cache cleared (untimed); thread CPU
  time, minimum (spread = median / min - 1). "faster (clear)" names a winner
  only where the ranges [min, median] do not overlap.
- ops: sympy.count_ops. SymPy: mass_matrix_full / forcing_full as explicit trees;
  SymPy+CSE: replacements + reduced expressions of one joint sympy.cse of both.
  kanedyn+CSE: the joint count after the common-subexpression elimination the
  C code generator applies (comparable with SymPy+CSE).
  kanedyn: compact form, M / F each with the intermediates it needs, (joint):
  everything the right-hand side evaluates, shared intermediates counted once;
  for constrained models this includes the constraint matrices from which the
  dependent speeds are eliminated numerically (SymPy's counts include its
  symbolic elimination).
- RHS: minimum (spread) over 7 interleaved rounds of at least 0.2 s thread CPU
  time each, at one generic consistent state. SymPy:
  lambdify([q + u, constants], [M_full, F_full], cse=True) then numpy.linalg.solve.
  RHS rel. diff = max|ydot_SymPy - ydot_kanedyn| / max|ydot_kanedyn|; (!) marks
  a difference above {limit:g}: the two tools disagree at that state.{skipped}"""


# ------------------------------------------------- explicit matrices (ports)
#: Chains of the explicit-matrix comparison: name -> builder of kane() keywords.
EXPLICIT_CHAINS = ("sympy-docs", "chain3d")


def chain_arguments(kind, n):
    """Fresh ``kd.kane`` / ``KanesMethod`` keywords of a chain of ``n`` links.

    ``kind`` is "sympy-docs" (:func:`_peers.sympy_docs_chain`, written as
    SymPy's documentation writes models) or "chain3d" (the built-in model).
    """
    if kind == "sympy-docs":
        args = sympy_docs_chain(n)
        args.pop("constants")
        return args
    return dict(kd.models.build("chain3d", n=n).kane_args)


def explicit_derivations(kind, n, rounds):
    """SymPy's ``KanesMethod``, ``kd.kane``, ``kd.kane`` + the explicit matrices.

    Timed interleaved in ``rounds`` rounds (:func:`_timing.interleaved`,
    thread CPU time), each timing on freshly built arguments with SymPy's cache
    cleared (untimed).

    Returns
    -------
    timings : dict
        ``{"sympy", "kane", "kane+M/F": Timing}``: SymPy's ``KanesMethod`` +
        ``kanes_equations`` + reading ``mass_matrix_full`` and
        ``forcing_full``; ``kd.kane``; ``kd.kane`` then the same two matrices.
    eom, kane
        The last kanedyn equations and SymPy ``KanesMethod``.
    """
    last = {}

    def prepare():
        args = chain_arguments(kind, n)
        fresh_start()
        return args

    def sympy(args):
        kane = me.KanesMethod(args["frame"], args["q_ind"], args["u_ind"],
                              kd_eqs=args["kd_eqs"])
        kane.kanes_equations(args["bodies"], args["loads"])
        _ = kane.mass_matrix_full, kane.forcing_full
        last["kane"] = kane

    def kane(args):
        last["eom"] = kd.kane(**args)

    def kane_explicit(args):
        eom = kd.kane(**args)
        _ = eom.mass_matrix_full, eom.forcing_full  # built on first access
        last["eom"] = eom

    names = ("sympy", "kane", "kane+M/F")
    timings = interleaved(dict(zip(names, (sympy, kane, kane_explicit))), rounds=rounds,
                          min_time=0, setup=dict.fromkeys(names, prepare))
    return timings, last["eom"], last["kane"]


def lambdify_seconds(q, u, mass, forcing):
    """Time of ``sm.lambdify([q + u, parameters], [mass, forcing], cse=True)``."""
    params = sorted((mass.free_symbols | forcing.free_symbols) - {me.dynamicsymbols._t},
                    key=str)
    start = time.perf_counter()
    sm.lambdify([list(q) + list(u), params], [mass, forcing], cse=True)
    return time.perf_counter() - start


def benchmark_explicit(kind, n, args, log):
    """One row of the explicit-matrix table."""
    times, eom, km = explicit_derivations(kind, n, args.repeat)
    log(f"{kind} n={n}: kanedyn kane {times['kane'].best:.3f} s, "
        f"+ explicit {times['kane+M/F'].best:.3f} s, SymPy {times['sympy'].best:.2f} s")
    row = {"chain": kind, "n": n, "sympy": times["sympy"], "kane": times["kane"],
           "explicit": times["kane+M/F"],
           "winner": winner_text({k: times[k] for k in ("sympy", "kane+M/F")}),
           "lambdify_sympy_s": None, "lambdify_kanedyn_s": None}
    if args.explicit_lambdify:
        fresh_start()
        row["lambdify_sympy_s"] = lambdify_seconds(km.q, km.u, km.mass_matrix_full,
                                                   km.forcing_full)
        fresh_start()
        row["lambdify_kanedyn_s"] = lambdify_seconds(eom.q, eom.u, eom.mass_matrix_full,
                                                     eom.forcing_full)
        log(f"{kind} n={n}: lambdify SymPy {row['lambdify_sympy_s']:.2f} s, "
            f"kanedyn {row['lambdify_kanedyn_s']:.2f} s")
    return row


EXPLICIT_COLUMNS = ("chain", "n", "SymPy KanesMethod+M/F s", "kanedyn kane s",
                    "ratio", "kanedyn kane+M/F s", "ratio M/F", "faster M/F (clear)",
                    "lambdify s SymPy", "lambdify s kanedyn",
                    "SymPy total s", "kanedyn total s", "ratio total")


def explicit_cells(row):
    """Cells of one explicit-matrix row (order of :data:`EXPLICIT_COLUMNS`)."""
    sympy_s, kane_s, explicit_s = row["sympy"].best, row["kane"].best, row["explicit"].best
    cells = [row["chain"], str(row["n"]), with_spread(row["sympy"]),
             with_spread(row["kane"]), times_text(sympy_s / kane_s),
             with_spread(row["explicit"]), times_text(sympy_s / explicit_s), row["winner"]]
    if row["lambdify_sympy_s"] is None:
        return cells + ["-"] * 5
    total_sympy = sympy_s + row["lambdify_sympy_s"]
    total_ours = explicit_s + row["lambdify_kanedyn_s"]
    return cells + [format_seconds(row["lambdify_sympy_s"]),
                    format_seconds(row["lambdify_kanedyn_s"]), format_seconds(total_sympy),
                    format_seconds(total_ours), f"{total_sympy / total_ours:.1f}x"]


def format_rows(columns, body, markdown=False):
    """``body`` (lists of cells) under ``columns``, plain text or markdown."""
    if markdown:
        lines = ["| " + " | ".join(columns) + " |",
                 "|" + "|".join("---" if i < 2 else "--:" for i in range(len(columns))) + "|"]
        return "\n".join(lines + ["| " + " | ".join(cells) + " |" for cells in body])
    widths = [max([len(title)] + [len(cells[i]) for cells in body])
              for i, title in enumerate(columns)]

    def line(cells):
        return "  ".join(cell.ljust(w) if i < 2 else cell.rjust(w)
                         for i, (cell, w) in enumerate(zip(cells, widths)))
    return "\n".join([line(columns), line(["-" * w for w in widths])]
                     + [line(cells) for cells in body])


EXPLICIT_NOTES = """\
Notes (explicit matrices):
- SymPy: KanesMethod(N, q, u, kd_eqs) + kanes_equations(bodies, loads) + reading
  mass_matrix_full and forcing_full. kanedyn: kd.kane(...) ("kane s") and
  kd.kane(...) + reading eom.mass_matrix_full and eom.forcing_full ("kane+M/F s").
  The three interleaved in {repeat} rounds on freshly built models, thread CPU
  time: minimum (spread = median / min - 1). ratio = SymPy s / kanedyn s (minima);
  "faster (clear)" names a winner only where [min, median] do not overlap.
- sympy-docs: the chain of benchmarks/_peers.py sympy_docs_chain (orient_axis about
  alternating x/y axes, v2pt_theory, full inertia dyadics, parameters per link);
  chain3d: the built-in model (z/x axes, diagonal inertia, shared parameters).
- lambdify: sm.lambdify([q + u, parameters], [M_full, F_full], cse=True) of each
  tool's own matrices; total = derivation + reading + lambdify."""


# ------------------------------------------------------------------- main
def main(argv=None):
    """Run the benchmark and print the table.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default ``sys.argv[1:]``).
    """
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--max-n", type=int, default=10,
                        help="largest 3D chain, bodies (default 10; smallest is 2)")
    parser.add_argument("--bicycle", action=argparse.BooleanOptionalAction, default=True,
                        help="include the Whipple bicycle (default: yes)")
    parser.add_argument("--skip-sympy-rhs", action="store_true",
                        help="do not lambdify SymPy's equations (RHS timing of kanedyn only)")
    parser.add_argument("--sympy-rhs-max-n", type=int, default=10**6, metavar="N",
                        help="lambdify SymPy's equations only for chains up to N bodies "
                             "(default: all)")
    parser.add_argument("--repeat", type=int, default=3,
                        help="interleaved rounds of the derivations (minimum and spread; "
                             "default 3)")
    parser.add_argument("--quick", action="store_true",
                        help="chains n = 2..4, no bicycle, explicit n = 3, 2 rounds")
    parser.add_argument("--markdown", action="store_true", help="print a markdown table")
    parser.add_argument("--explicit-n", type=int, nargs="*", default=[3, 5, 8], metavar="N",
                        help="chain sizes of the explicit-matrix table (default 3 5 8; "
                             "none to skip it)")
    parser.add_argument("--explicit-lambdify", action="store_true",
                        help="also time sm.lambdify of both tools' explicit matrices")
    parser.add_argument("--explicit-only", action="store_true",
                        help="only the explicit-matrix table")
    args = parser.parse_args(argv)
    if args.quick:
        args.max_n, args.bicycle, args.explicit_n, args.repeat = 4, False, [3], 2

    def log(message):
        print(message, file=sys.stderr, flush=True)

    header = "kanedyn vs SymPy KanesMethod: " + machine_info()  # before code can change
    # Warm up both tools (imports, first-call caches) on a tiny model.
    kd.kane(**kd.models.build("chain3d", n=2).kane_args)
    sympy_derivation("chain3d", {"n": 2})

    explicit = [benchmark_explicit(kind, n, args, log)
                for kind in EXPLICIT_CHAINS for n in args.explicit_n]
    if args.explicit_only:
        print(header)
        print()
        print(format_rows(EXPLICIT_COLUMNS, [explicit_cells(r) for r in explicit],
                          markdown=args.markdown))
        print()
        print(EXPLICIT_NOTES.format(repeat=args.repeat))
        return
    cases = [("chain3d", {"n": n}) for n in range(2, args.max_n + 1)]
    if args.bicycle:
        cases.append(("whipple-bicycle", {}))
    rows = [benchmark_model(name, options, args, log) for name, options in cases]

    skipped = ""
    if args.skip_sympy_rhs:
        skipped = "\n- SymPy's RHS was not measured (--skip-sympy-rhs)."
    elif any(row["rhs_sympy"] is None for row in rows):
        skipped = (f"\n- SymPy's RHS was measured for chains up to n = "
                   f"{args.sympy_rhs_max_n} only (lambdify of larger ones is slow).")
    print(header)
    print()
    print(format_table(rows, markdown=args.markdown))
    print()
    print(NOTES.format(repeat=args.repeat, limit=DISAGREEMENT, skipped=skipped))
    if explicit:
        print()
        print(format_rows(EXPLICIT_COLUMNS, [explicit_cells(r) for r in explicit],
                          markdown=args.markdown))
        print()
        print(EXPLICIT_NOTES.format(repeat=args.repeat))


if __name__ == "__main__":
    main()
