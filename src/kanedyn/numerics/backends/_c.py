"""The compiled backend: C from a straight-line program, built into an extension.

Code generation
    Every intermediate is one C statement.  Large programs are split into
    functions of at most ``CHUNK`` statements (compilers slow down
    superlinearly on huge functions); values crossing a split go through a
    work array.

Translation units
    The generated functions go into translation units of their own (the
    dynamics, the lane-wise dynamics, the tree pass, the rest), separate from
    the runtime with its Python headers; they are compiled in parallel and
    linked (:mod:`._c_build`, which also builds and caches the module).
"""

from __future__ import annotations

import hashlib
import re
from typing import NamedTuple

import numpy as np
import sympy as sm

from . import _c_contact, _c_ensemble, _c_integrator, _c_lanes, _c_runtime
from ._c_build import (COLD_UNIT, LIGHT_UNIT, NAME_TOKEN, STATS, UNIT_MARK, CompilerError,
                       cache_dir, compiler_command, load_module, missing_compiler_text,
                       prefetch)
from ._python import CodegenError
from ...engine import free_symbols_of, kd_dpow

__all__ = ["CompilerError", "generate_c", "generate_c_units", "eager_functions",
           "fingerprint", "load_module", "compiler_command", "missing_compiler_text",
           "CHUNK", "elimination_tree", "solver_source", "STATS", "cache_dir",
           "speed_tree_outputs", "TREE_MIN_SPEEDS", "lanes_wanted", "predicted_runtime_unit",
           "prefetch_runtime"]

CHUNK = 800  # statements per generated C function
#: a function (or part of one) of fewer characters shares a translation unit with
#: the other small ones
UNIT_MIN_CHARS = 20000
#: separates the parts of a long generated function (each may be a unit of its own)
PIECE_MARK = "/* ---- kanedyn: next part ---- */"


# ------------------------------------------------------------------ printing
class _CPrinter:
    """C text of the expressions :func:`_direct` leaves to SymPy's C printer
    (:class:`._c_printer.SymPyCPrinter`, imported and made on the first of them:
    SymPy's printing and code generation modules are 5 ms of a cold start that
    most models never use), with the names of symbols in ``names`` (read as it
    grows)."""

    def __init__(self, names):
        self._names = names
        self._printer = None

    def doprint(self, expr):
        """C text of the SymPy expression ``expr``."""
        if self._printer is None:
            from ._c_printer import SymPyCPrinter
            self._printer = SymPyCPrinter(self._names)
        return self._printer.doprint(expr)


class _Unusual(Exception):
    """An expression the direct printer leaves to SymPy's."""


_CALLS = {sm.sin: "sin", sm.cos: "cos", sm.tan: "tan", sm.exp: "exp", sm.log: "log",
          sm.asin: "asin", sm.acos: "acos", sm.atan: "atan", sm.sinh: "sinh",
          sm.cosh: "cosh", sm.tanh: "tanh", sm.Abs: "fabs", sm.sign: "kd_sign",
          sm.atan2: "atan2", kd_dpow: "kd_dpow"}
_SUM, _PRODUCT, _ATOM = 1, 2, 3  # binding of a printed expression


def _direct(expr, names):
    """``(C text, binding)`` of the sums, products, powers, numbers and
    elementary functions that make up nearly all generated statements, as
    :class:`_CPrinter` prints them but without SymPy's printing machinery
    (1.4 s of a 6 s build at chain3d n = 100); raises :class:`_Unusual` for
    anything else.  No SymPy expression is built on the way."""
    negative, text, binding = _signed(expr, names)
    if negative:
        return f"-{text}" if binding >= _PRODUCT else f"-({text})", _SUM
    return text, binding


def _signed(expr, names):
    """``(negative, text of the magnitude, its binding)``."""
    if expr.is_Symbol:
        try:
            return False, names[expr], _ATOM
        except KeyError:
            raise CodegenError(f"symbol {expr} has no value in the generated code") \
                from None
    if expr.is_Number:
        return _number(expr)
    if expr.is_Add:
        parts = []
        for k, term in enumerate(expr.args):
            negative, text, binding = _signed(term, names)
            if negative and binding < _PRODUCT:
                text = f"({text})"
            parts.append(("-" if negative else "") + text if k == 0
                         else (" - " if negative else " + ") + text)
        return False, "".join(parts), _SUM
    if expr.is_Mul:
        args = expr.args
        negative = False
        top, bottom = [], []
        if args[0].is_Number:
            negative, text, binding = _number(args[0])
            args = args[1:]
            if text != "1":
                top.append(text if binding >= _PRODUCT else f"({text})")
        for factor in args:  # negative powers below the line, as SymPy prints them
            if factor.is_Pow and factor.exp.is_Rational and factor.exp.is_negative:
                bottom.append(_root_or_power(factor.base, -factor.exp, names))
            else:
                top.append(_operand(factor, names, _PRODUCT))
        text = "*".join(top) if top else "1.0"
        if bottom:
            text += "/" + (bottom[0] if len(bottom) == 1 else f"({'*'.join(bottom)})")
        return negative, text, _PRODUCT
    if expr.is_Pow:
        base, exp = expr.args
        if exp == -sm.S.Half:
            return False, f"(1.0/sqrt({_direct(base, names)[0]}))", _ATOM
        return False, _root_or_power(base, exp, names), _ATOM
    call = _CALLS.get(expr.func)
    if call is not None:
        return False, f"{call}({', '.join(_direct(a, names)[0] for a in expr.args)})", _ATOM
    raise _Unusual


def _root_or_power(base, exp, names):
    """Text of ``base ** exp`` that binds as an atom."""
    if exp.is_Integer:
        return _power(base, int(exp), names)
    if exp == sm.S.Half:
        return f"sqrt({_direct(base, names)[0]})"
    return f"pow({_direct(base, names)[0]}, {_direct(exp, names)[0]})"


def _power(base, n, names):
    """Text of ``base ** n`` (integer ``n``) that binds as an atom."""
    b = _operand(base, names, _ATOM)
    if n == 1:
        return b
    if n == 2:
        return f"({b}*{b})"
    if n == 3:
        return f"({b}*{b}*{b})"
    if n == -1:
        return f"(1.0/{b})"
    if n == -2:
        return f"(1.0/({b}*{b}))"
    return f"kd_powi({_direct(base, names)[0]}, {n})"


def _operand(expr, names, binding):
    """Text of ``expr`` as an operand that binds at least as ``binding``."""
    text, own = _direct(expr, names)
    return text if own >= binding else f"({text})"


def _number_literal(rational):
    """A SymPy rational as one correctly rounded double literal (Python's division
    of integers), not ``p.0/q.0``: a compiler that folds that division in extended
    precision rounds twice (TinyCC does, about one constant in 10,000), and ``p``
    itself may not be exact."""
    try:
        return repr(int(rational.p) / int(rational.q))
    except OverflowError:
        raise CodegenError(f"the constant {rational} is beyond the range of a double") \
            from None


def _number(expr):
    """``(negative, text of the magnitude, binding)`` of a SymPy number."""
    if expr.is_Integer:
        value = int(expr)
        if abs(value) > 2 ** 53:  # beyond C's integer literals: a double
            return value < 0, repr(float(abs(value))), _ATOM
        return value < 0, str(abs(value)), _ATOM
    if expr.is_Rational:
        return expr.p < 0, _number_literal(abs(expr)), _ATOM
    if expr.is_Float:
        value = float(expr)
        if value != value or abs(value) == float("inf"):
            raise _Unusual
        return value < 0, repr(abs(value)), _ATOM
    if expr is sm.nan:  # an undeclared potential energy: as SymPy's C99 printer has it
        return False, "NAN", _ATOM
    raise _Unusual


def _print_c(printer, expr, what, describe=str):
    expr = sm.sympify(expr, strict=True)
    try:
        return _direct(expr, printer._names)[0]
    except _Unusual:
        pass
    try:
        return printer.doprint(expr)
    except CodegenError:
        raise
    except Exception as exc:  # noqa: BLE001  (the printer raises several kinds)
        raise CodegenError(
            f"the C backend cannot generate code for {describe(expr)} ({what}): {exc}; "
            "the numpy backend (backend='numpy') can evaluate it") from None


# ---------------------------------------------------------------- functions
_PARAMS = ("double t, const double *restrict y, const double *restrict p, "
           "const double *restrict r, double *restrict w")


def _signature(name, n_outputs):
    """The declaration of the generated ``kd_eval_<name>`` with ``n_outputs`` outputs."""
    outputs = "".join(f", double *restrict o{k}" for k in range(n_outputs))
    return f"KD_GEN void kd_eval_{name}({_PARAMS}{outputs})"


def _function_source(program, name, arguments, outputs, describe, cse, listing=None,
                     external=None, export=None, offset=0):
    """C source of ``kd_eval_<name>`` and the number of work slots it needs.

    ``listing``: the result of ``program.listing`` of the flattened outputs,
    when already computed (it is then not computed again).  ``external``:
    ``{symbol: slot}`` of values another function left in the work array
    (read as ``w[slot]``, not computed here); ``export``: ``{symbol: slot}``
    of this function's values stored there for another function
    (:func:`_shared_sources`); ``offset``: the first slot of the work array
    this function's own parts may use.
    """
    base = {program.t: "t"}
    for arg, symbols in arguments.items():
        for i, s in enumerate(symbols):
            base[s] = f"{arg}[{i}]"
    base.update((s, f"w[{slot}]") for s, slot in (external or {}).items())
    export = export or {}
    flat = [sm.sympify(e, strict=True) for _, exprs in outputs for e in exprs]
    assignments, flat = listing if listing is not None else program.listing(flat, cse=cse)
    needed = [s for s, _ in assignments]
    definition = dict(assignments)
    index = {s: k for k, s in enumerate(needed)}
    chunks = [needed[i:i + CHUNK] for i in range(0, len(needed), CHUNK)] or [[]]
    chunk_of = {s: c for c, members in enumerate(chunks) for s in members}
    split = len(chunks) > 1  # decided before any statement is emitted
    # the last chunk (len(chunks) = the output part) using each intermediate: what
    # a split function stores in the work array (one in a single chunk stores none)
    last_use = {}
    for s in needed if split else ():
        for parent in free_symbols_of(definition[s]):
            if parent in index:
                last_use[parent] = max(last_use.get(parent, -1), chunk_of[s])
    for e in flat if split else ():
        for s in free_symbols_of(e):
            if s in index:
                last_use[s] = len(chunks)
    params = _PARAMS
    lines = []
    stored = set()
    for c, members in enumerate(chunks):
        names = dict(base)
        for s in needed:
            if s in stored and chunk_of[s] < c:
                names[s] = f"w[{offset + index[s]}]"
        body = []
        printer = _CPrinter(names)  # reads ``names`` as it grows
        for s in members:
            names[s] = f"z{index[s]}"
            code = _print_c(printer, definition[s], f"in the intermediate {s.name}", describe)
            body.append(f"    const double z{index[s]} = {code};")
            if s in export:
                body.append(f"    w[{export[s]}] = z{index[s]};")
            if split and last_use.get(s, c) > c:
                body.append(f"    w[{offset + index[s]}] = z{index[s]};")
                stored.add(s)
        if split:  # each part may go to a translation unit of its own
            lines.append(f"KD_GEN void kd_{name}_part{c}({params}) {{")
            lines.extend(body or ["    (void)w;"])
            lines.extend(["}", PIECE_MARK])
        else:
            chunk_body = body
    if split:
        lines.extend(f"KD_GEN void kd_{name}_part{c}({params});" for c in range(len(chunks)))
    lines.append(_signature(name, len(outputs)) + " {")
    names = dict(base)
    if split:
        for c in range(len(chunks)):
            lines.append(f"    kd_{name}_part{c}(t, y, p, r, w);")
        for s in stored:
            names[s] = f"w[{offset + index[s]}]"
    else:
        lines.extend(chunk_body)
        for s in needed:
            names[s] = f"z{index[s]}"
    printer = _CPrinter(names)
    position = 0
    for k, (_, exprs) in enumerate(outputs):
        codes = []
        for j in range(len(exprs)):
            codes.append(_print_c(printer, flat[position], f"output {j} of {name}", describe))
            position += 1
        lines.extend(_output_lines(f"kd_{name}_o{k}", f"o{k}", codes))
    lines.append("    (void)t; (void)y; (void)p; (void)r; (void)w;")
    lines.append("}")
    work = offset + (len(needed) if split else 0)
    return "\n".join(lines), work


_COPY = re.compile(r"([wypr])\[(\d+)\]")
_COPY_MIN = 16  # copies from one array in a table loop, not one statement each
_ZEROS_MIN = 16  # zeros of an output cleared by one loop, not one statement each


def _output_lines(table, target, codes):
    """Statements setting ``target[j] = codes[j]``.

    Plain copies of array entries (``w[5]``, ``y[3]``) from one array, when
    there are many, become a loop over a table of index pairs: thousands of
    single stores in one function cost the compiler's alias analysis time
    quadratic in their number (2.8 s of gcc for the 1000 outputs of the
    tree pass at chain3d n = 100), for no gain at run time.  An output with
    as many zeros or more is cleared by a loop first.
    """
    copies = {}
    for j, code in enumerate(codes):
        found = _COPY.fullmatch(code)
        if found is not None:
            copies.setdefault(found.group(1), []).append((j, int(found.group(2))))
    looped = {a: pairs for a, pairs in copies.items() if len(pairs) >= _COPY_MIN}
    skip = {j for pairs in looped.values() for j, _ in pairs}
    zeros = [j for j, code in enumerate(codes) if code == "0"]
    lines = []
    if len(zeros) >= _ZEROS_MIN:  # the whole output cleared by a loop, then the rest set
        # (the derivatives of a chain of 100 speeds: 40,000 entries, nearly all zero,
        # were as many statements, a twelfth of the evaluation's time)
        skip.update(zeros)
        lines += [f"    for (int i = 0; i < {len(codes)}; i++)", f"        {target}[i] = 0;"]
    lines += [f"    {target}[{j}] = {code};" for j, code in enumerate(codes) if j not in skip]
    for array, pairs in looped.items():
        entries = ", ".join(f"{{{j}, {i}}}" for j, i in pairs)
        lines += [f"    static const int {table}_{array}[{len(pairs)}][2] = {{{entries}}};",
                  f"    for (int i = 0; i < {len(pairs)}; i++)",
                  f"        {target}[{table}_{array}[i][0]] = {array}[{table}_{array}[i][1]];"]
    return lines


def _function_table(functions, rows):
    """C table ``kd_function_table`` of the module's functions (``KdFunction``
    of :data:`_c_runtime.SHARED`: the generic runtime makes each a
    module-level Python function ``name(t, y, p, r)`` returning a tuple of its
    outputs), with a call of each taking its outputs as an array of pointers;
    ``rows``: names of the functions also given at every point of a
    trajectory (``name_rows(t, Y, p, R)``)."""
    lines, entries = [], []
    for name, (arguments, outputs) in functions.items():
        if len(outputs) > _c_runtime.MAX_OUTPUTS or any(len(s) > 2 for s, _ in outputs):
            raise CodegenError(f"function {name}: at most {_c_runtime.MAX_OUTPUTS} outputs "
                               "of at most two dimensions")
        pointers = ", ".join(f"o[{k}]" for k in range(len(outputs)))
        lines += [f"static void kd_call_{name}(double t, const double *y, const double *p, "
                  "const double *r, double *w, double *const *o) {",
                  f"    kd_eval_{name}(t, y, p, r, w{', ' if outputs else ''}{pointers});",
                  "}"]
        shapes = "NULL"
        if outputs:
            shapes = f"kd_shapes_{name}"
            dims = ", ".join(f"{{{len(shape)}, {', '.join(map(str, (*shape, 0, 0)[:2]))}}}"
                             for shape, _ in outputs)
            lines.append(f"static const long {shapes}[{len(outputs)}][3] = {{{dims}}};")
        nr = len(arguments.get("r", ()))
        for suffix, row in [("", 0)] + ([("_rows", 1)] if name in rows else []):
            entries.append(f'    {{"{name}{suffix}", kd_call_{name}, {len(outputs)}, {nr}, '
                           f"{row}, {shapes}}},")
    if len(entries) > _c_runtime.MAX_FUNCTIONS:
        raise CodegenError(f"at most {_c_runtime.MAX_FUNCTIONS} functions in one module")
    return "\n".join([*lines, "static const KdFunction kd_function_table[] = {", *entries,
                      "    {NULL, NULL, 0, 0, 0, NULL}", "};"])


def elimination_tree(nonzero):
    """Elimination tree of the ``L^T D L`` factorization (last index first).

    Parameters
    ----------
    nonzero : numpy.ndarray of bool, shape (n, n)
        Symmetric structure of the matrix (``True`` where an entry may be
        nonzero).

    Returns
    -------
    list of int
        ``parent[k]`` (``-1`` for a root), with ``parent[k] < k``: after the
        factorization, ``L[k, i]`` can be nonzero only for ``i`` an ancestor of
        ``k``.  For a kinematic tree whose coordinates are numbered parents
        first, the tree of the coordinates itself (no fill-in).
    """
    n = len(nonzero)
    lower = [{j for j in range(k) if nonzero[k, j] or nonzero[j, k]} for k in range(n)]
    parent = [-1] * n
    for k in range(n - 1, -1, -1):
        if lower[k]:
            parent[k] = top = max(lower[k])
            lower[top] |= lower[k] - {top}  # the fill-in of eliminating k
    return parent


def _solving_tree(functions, sizes):
    """``(parent, order)`` of the tree of speeds whose articulated-body pass solves
    the model (a ``tree`` function, :func:`speed_tree_outputs`, and no dependent
    speeds), else ``None``."""
    if "tree" in functions and not sizes["n_u_dep"]:
        return sizes["speed_tree"]
    return None


def solver_source(functions, sizes):
    """C definitions choosing the solve of ``M u' = f`` (``KD_SOLVE``).

    The structural zeros of the mass matrix (entries of the ``dynamics``
    output that are exactly zero) give its elimination tree: when that tree
    is a single path (a dense factor), ``KD_SOLVE 1`` (dense ``L^T D L``);
    otherwise ``KD_SOLVE 2`` and the parent array ``kd_parent`` (tree
    ``L^T D L``, no work on the structural zeros).  With a ``tree`` function
    (:func:`speed_tree_outputs`), ``KD_SOLVE 3``: the mass matrix is never
    formed; an articulated-body pass over the tree of speeds solves for u'.
    """
    n = sizes["n_u"]
    tree = _solving_tree(functions, sizes)
    if tree is not None:
        parent, order = tree
        return ["#define KD_SOLVE 3",
                f"static const int kd_tparent[{n}] = {{{', '.join(map(str, parent))}}};",
                f"static const int kd_torder[{n}] = {{{', '.join(map(str, order))}}};"]
    if sizes["n_u_dep"] or n < 3:
        return ["#define KD_SOLVE 1"]
    _, outputs = functions["dynamics"]
    shape, entries = outputs[1]
    nonzero = np.array([not (sm.sympify(e, strict=True) == 0) for e in entries], dtype=bool)
    parent = elimination_tree(nonzero.reshape(n, n))
    if all(parent[k] == k - 1 for k in range(n)):
        return ["#define KD_SOLVE 1"]
    return ["#define KD_SOLVE 2",
            f"static const int kd_parent[{n}] = {{{', '.join(map(str, parent))}}};"]


#: speeds from which a tree-structured model is solved by the articulated-body
#: pass (``KD_SOLVE 3``) instead of evaluating and factoring M: below, the
#: straight-line M (o^2 entries) costs less than the twists and inertias of the
#: pass (16 o values) and its set-up (measured on chain3d: the pass is 1.3x slower
#: at o = 2, 1.07x at 10, 0.91x at 15, 0.83x at 30)
TREE_MIN_SPEEDS = 12


def speed_tree_outputs(tree, qdot, force, sub):
    """Outputs of the ``tree`` function, or ``None`` below :data:`TREE_MIN_SPEEDS`.

    Parameters
    ----------
    tree : dict or None
        The mass matrix as a tree of speeds (``EquationsOfMotion._speed_tree``).
    qdot, force : sequence of expressions
        q' (n) and the forcing f (o) of the dynamics.
    sub : callable
        Substitution of the specified inputs into an expression.

    Returns
    -------
    (outputs, (parent, order)) or None
        ``outputs``: q' (n), f (o), the partial twists S (6 o) and the attached
        spatial inertias (10 o).
    """
    o = len(force)
    if tree is None or o < TREE_MIN_SPEEDS or len(tree["parent"]) != o:
        return None
    outputs = [((len(qdot),), [sub(e) for e in qdot]), ((o,), [sub(e) for e in force]),
               ((6 * o,), [sub(e) for twist in tree["S"] for e in twist]),
               ((10 * o,), [sub(e) for inertia in tree["inertia"] for e in inertia])]
    return outputs, (tuple(tree["parent"]), tuple(tree["order"]))


CODEGEN_VERSION = "kanedyn-c-10"  # change when generated code changes (bits, not only meaning)
# the runtime and integrator templates are part of every module: part of its key
_TEMPLATES_DIGEST = hashlib.sha256("".join(
    (_c_runtime.HEADER, _c_runtime.SIZE_MACROS, _c_runtime.SHARED, _c_runtime.RUNTIME,
     _c_integrator.INTEGRATOR, _c_ensemble.ENSEMBLE, _c_contact.CONTACT,
     _c_runtime.RUNTIME_FOOTER,
     _c_runtime.MODEL_SOLVE, _c_runtime.LANE_RUNTIME, _c_runtime.LANE_SOLVE,
     _c_runtime.INVERSE_POINT, _c_runtime.JACOBIAN_SOLVE, _c_runtime.JACOBIAN_INFO,
     _c_runtime.MODULE_FOOTER)
).encode()).hexdigest()[:16]


def fingerprint(program, functions, sizes, cse=None, lanes=True):
    """Deterministic text identifying what a module computes (its cache key).

    The C source itself is not deterministic across processes (SymPy's common
    subexpression elimination iterates over hash-ordered sets), so the key is
    the program before elimination, written with positional names by
    :func:`_structure` (a walk of the expression trees: no expression is
    rebuilt or printed by SymPy, which for large programs took seconds).
    """
    parts = [CODEGEN_VERSION, _TEMPLATES_DIGEST, repr(sorted(sizes.items())), f"cse={cse}",
             f"chunk={CHUNK}",
             f"lanes={_c_lanes.LANES if lanes_wanted(functions, sizes, lanes) else 0}"]
    for name, (arguments, outputs) in functions.items():
        names = {program.t: "t"}
        for arg, symbols in arguments.items():
            parts.append(f"{arg}:{len(symbols)}")
            names.update((s, f"{arg}{i}") for i, s in enumerate(symbols))
        flat = [sm.sympify(e, strict=True) for _, exprs in outputs for e in exprs]
        needed = program.needed(flat)
        names.update((s, f"z{k}") for k, s in enumerate(needed))
        memo = {}
        parts.append(f"function {name}")
        parts.extend(_structure(program.definition(s), names, memo) for s in needed)
        for shape, exprs in outputs:
            parts.append(repr(shape))
            parts.extend(_structure(sm.sympify(e, strict=True), names, memo) for e in exprs)
    return "\n".join(parts)


_ORDERLESS = (sm.Add, sm.Mul)


def _structure(expr, names, memo):
    """Text of an expression tree with the symbols in ``names`` renamed.

    Independent of the original symbols' names: the arguments of sums and
    products are listed in the order of their texts.  Numbers are exact
    (a Float's binary mantissa and exponent).
    """
    text = memo.get(expr)
    if text is not None:
        return text
    if expr in names:
        text = names[expr]
    elif isinstance(expr, sm.Float):
        text = f"F{expr._mpf_!r}"
    elif isinstance(expr, sm.Rational):
        text = f"Q{expr.p}/{expr.q}"
    elif not expr.args:
        text = f"{type(expr).__name__}:{expr}"
    else:
        args = [_structure(a, names, memo) for a in expr.args]
        if isinstance(expr, _ORDERLESS):
            args.sort()
        text = f"{type(expr).__name__}({','.join(args)})"
    memo[expr] = text
    return text


def generate_c(program, functions, sizes, describe=str, cse=None, units=True, lanes=True,
               plain=(), share=None):
    """C source template of an extension module (see :func:`load_module`).

    Parameters
    ----------
    program : Program
    functions : dict
        ``{name: (arguments, outputs)}`` as for
        :func:`kanedyn.numerics.backends.generate_python`; must contain
        ``"dynamics"`` with the six outputs of the right-hand side, or
        ``"tree"`` (:func:`speed_tree_outputs`) without dependent speeds:
        the right-hand side is then solved by the articulated-body pass, and
        the module can go without M (:func:`eager_functions`).
    sizes : dict
        ``n_q, n_u, n_q_dep, n_u_dep, n_p, n_r`` (inputs of the dynamics).
    describe : callable, optional
        ``describe(expr)``: text of an expression for error messages (in the
        model's own symbols).
    cse : bool or None
        Eliminate common subexpressions jointly first (:meth:`Program.listing`);
        ``None``: in every function but the articulated-body pass.
    units : bool
        Separate translation units (joined by :data:`UNIT_MARK`, see
        :func:`generate_c_units`).  ``False``: one C file (what
        :meth:`~kanedyn.NumericModel.c_source` shows).
    lanes : bool
        Add the lane-wise dynamics of ``rhs_batch`` where it applies
        (:func:`lanes_wanted`).
    plain, share : see :func:`generate_c_units`
    """
    if units:
        return UNIT_MARK.join(generate_c_units(program, functions, sizes, describe, cse,
                                               lanes, plain, share))
    lanes = lanes_wanted(functions, sizes, lanes)
    generic, model = _runtime_parts(functions, sizes, lanes, share)
    generated, work, lane_work = [], 0, 0
    for src, _, w, lw in _function_sources(program, functions, sizes, describe, cse, lanes,
                                           plain, share):
        generated.append(src)
        work, lane_work = max(work, w), max(lane_work, lw)
    sizes_known = [f"#define KD_NW {work}"] + ([f"#define KD_NWL {lane_work}"] if lanes else [])
    return "\n".join([_c_runtime.HEADER, *_size_defines(sizes), *generic.defines,
                      *model.defines, *sizes_known, *_lane_runtime(lanes),
                      _c_runtime.SIZE_MACROS, _c_runtime.SHARED, *model.declarations,
                      *generated, *generic.body, *model.body])


def generate_c_units(program, functions, sizes, describe=str, cse=None, lanes=True,
                     plain=(), share=None):
    """The translation units of a module, each yielded as soon as it is made.

    The runtime is in two units: the generic one (the Python entry points,
    batches, the integrator, see :func:`_generic_part`), first, and the
    model's (the solve of its mass matrix, the table of its functions, the
    module's entry point), after the long parts of the functions (it compiles
    in a fraction of their time).  The generic unit's text does not depend on
    the model's sizes (without contacts): it takes them as constants that the
    model's unit defines (``kd_nq`` ... ``kd_nr``, :func:`_size_variables`), so
    its object, cached under the hash of its text, is compiled once per
    variant and linked again into every later module of any size.  They need
    nothing of the generated code but its declarations (the work-array sizes
    are variables too, ``kd_nw`` and ``kd_nwl``, defined by the last unit), so
    the compiler works on the first while the functions are generated; at
    -O1 (:data:`~._c_build.LIGHT_UNIT`) unless they hold the lane-wise
    solve or the contact loop, whose loops the vectorizer of -O2 speeds up (the
    entry points and the integrator run as fast at -O1: chain3d n = 3 to 30,
    the pendulum, within 3 %, and compile in 0.46 s instead of 0.68 s at
    n = 10).  Every part of a
    generated function of :data:`UNIT_MIN_CHARS` or more characters is a
    unit of its own (with the C prelude, no Python headers), the small ones
    and the work sizes one last unit; the functions evaluated for outputs only
    (:data:`_COLD_FUNCTIONS`) are compiled at -O0, their small parts in a unit
    of their own.  Passed to
    :func:`load_module`, the compiler starts on each unit as soon as it comes.
    Arguments as for :func:`generate_c`; ``plain``: names of functions listed
    without common subexpressions whatever ``cse`` says (the same numbers:
    each expression is evaluated as written, its repeated parts again);
    ``share``: ``("dynamics", "jacobians")`` in a derivative module
    (``("tree", "jacobians")`` where the articulated-body pass solves it), whose
    solve (``KD_JAC_SHARED``) calls the derivatives' part that takes what the
    first computed (:func:`_shared_sources`).
    """
    lanes = lanes_wanted(functions, sizes, lanes)
    generic, model = _runtime_parts(functions, sizes, lanes, share)
    yield _runtime_unit(generic, sizes, lanes)
    small, small_preamble, cold, cold_preamble, work, lane_work = [], [], [], [], 0, 0
    for src, preamble, w, lw in _function_sources(program, functions, sizes, describe, cse,
                                                  lanes, plain, share):
        work, lane_work = max(work, w), max(lane_work, lw)
        for piece in src.split(PIECE_MARK):
            if len(piece) >= UNIT_MIN_CHARS:
                yield "\n".join([*preamble, piece])
            elif preamble[0] == COLD_UNIT:
                cold.append(piece)
                cold_preamble = preamble
            else:
                small.append(piece)
                small_preamble = max(small_preamble, preamble, key=len)  # lanes: longer
    yield _runtime_unit(model, sizes, lanes)  # short: after the long ones
    if cold:
        yield "\n".join([*cold_preamble, *cold])
    yield "\n".join([*(small_preamble or ["#define KD_GEN", _c_runtime.PRELUDE]), *small,
                     f"const int kd_nw = {work}, kd_nwl = {lane_work};"])


#: the sizes: their macros, keys in ``sizes`` and names of the constants the
#: model's unit defines for the generic one (:func:`_size_variables`)
_SIZES = (("KD_NQ", "n_q", "kd_nq"), ("KD_NU", "n_u", "kd_nu"),
          ("KD_NQDEP", "n_q_dep", "kd_nqdep"), ("KD_NUDEP", "n_u_dep", "kd_nudep"),
          ("KD_NP", "n_p", "kd_np"), ("KD_NR", "n_r", "kd_nr"))


def _size_defines(sizes):
    """The sizes as compile-time constants (the generated functions, the
    model's unit, the one-unit source)."""
    return [f"#define {macro} {sizes[key]}" for macro, key, _ in _SIZES]


def _size_variables(sizes):
    """The sizes in the generic runtime unit: constants defined by the model's
    unit (:func:`_size_constants`), so that its text is the same for every size;
    what the preprocessor decides on them, whether there are inputs, dependent
    coordinates or speeds, and dependent speeds (``KD_HAS_R``, ``KD_HAS_DEP``,
    ``KD_HAS_UDEP``), stays in the text (a handful of variants)."""
    return ["#if defined(__GNUC__)\n__attribute__((visibility(\"hidden\")))\n#endif",
            f"extern const int {', '.join(name for _, _, name in _SIZES)};",
            *(f"#define {macro} {name}" for macro, _, name in _SIZES),
            f"#define KD_HAS_R {int(sizes['n_r'] > 0)}",
            f"#define KD_HAS_DEP {int(sizes['n_q_dep'] + sizes['n_u_dep'] > 0)}",
            f"#define KD_HAS_UDEP {int(sizes['n_u_dep'] > 0)}"]


#: the definitions of :func:`_size_variables`' constants (the model's unit)
_SIZE_CONSTANTS = "const int " + ", ".join(f"{name} = {macro}" for macro, _, name in _SIZES) + ";"


def _lane_runtime(lanes):
    return [f"#define KD_LANES {_c_lanes.LANES}", _c_runtime.LANE_RUNTIME] if lanes else []


#: gcc's straight-line (SLP) vectorizer took a third to a half of the compile
#: time of long generated functions, and the second instruction scheduling
#: another 5-10 %, for no measured gain at run time (chain3d n = 10 to 100:
#: rhs within 2 %); the runtime unit (loops) keeps both
_STRAIGHT_LINE = ('#if defined(__GNUC__) && !defined(__clang__)\n'
                  '#pragma GCC optimize ("no-tree-slp-vectorize", "no-schedule-insns2")\n'
                  '#endif')


#: generated functions off every simulation's path, compiled at -O0
#: (:data:`~._c_build.COLD_UNIT`): the energies and the auxiliary equations
#: (constraint forces), evaluated for outputs only, once per output point
#: (chain3d n = 10: the energies in 0.04 s of gcc instead of 0.09-0.14 s; an
#: evaluation 1.6 microseconds slower at n = 60).  The integration loop
#: evaluates the energies twice every four steps for the energy check
#: (``_c_integrator``).  Evaluated at every step, at -O2 instead, they left the
#: loop as slow (chain3d n = 5, pendulum, four-bar, Whipple bicycle: the same
#: time within 4 %): what they cost is their sines and cosines
_COLD_FUNCTIONS = ("energy", "auxiliary")


def _function_sources(program, functions, sizes, describe, cse, lanes, plain=(),
                      share=None):
    """Yield ``(source, preamble, work, lane work)`` per generated function, the
    largest kinds first (the tree pass, the dynamics and its lane-wise copy);
    ``preamble``: what a translation unit of the function needs before it;
    ``work``: doubles of work array it needs (``lane work`` for the lanes).
    ``cse=None``: every function but the tree pass (:func:`_eliminates`);
    ``share``: a pair of functions listed together (:func:`_shared_sources`)."""
    preamble = ["#define KD_GEN", _c_runtime.PRELUDE, _STRAIGHT_LINE, *_size_defines(sizes)]
    first = [name for name in ("tree", "dynamics") if name in functions]
    done = set()
    for name in first + [name for name in functions if name not in first]:
        if name in done:
            continue
        if share is not None and name in share:
            for src, w in _shared_sources(program, functions, share, describe,
                                          [_eliminates(f, cse) and f not in plain
                                           for f in share]):
                yield src, preamble, w, 0
            done.update(share)
            continue
        arguments, outputs = functions[name]
        eliminate = _eliminates(name, cse) and name not in plain
        listing = None
        if lanes and name == "dynamics":  # one listing for both versions
            flat = [sm.sympify(e, strict=True) for _, exprs in outputs for e in exprs]
            listing = program.listing(flat, cse=eliminate)
            src, w = _c_lanes.lanes_source(program, arguments, outputs, listing, describe,
                                           CHUNK)
            yield src, preamble + _lane_runtime(lanes), 0, w
        src, w = _function_source(program, name, arguments, outputs, describe, eliminate,
                                  listing)
        yield src, [COLD_UNIT, *preamble] if name in _COLD_FUNCTIONS else preamble, w, 0


def _shared_sources(program, functions, pair, describe, eliminate):
    """``(source, work)`` of two functions whose second takes the values of the
    first from the work array instead of computing them again: the model's
    ``dynamics`` (M and the forcing, the accelerations solved from them) and the
    derivatives at those accelerations (``jacobians``), which share the
    kinematics, the sines and cosines.  Yields the first function
    (``kd_eval_<first>``, which also stores the shared values), the second's
    part after it (``kd_eval_<second>_shared``, to be called after the first
    with the same work array and ``t, y, p`` and the first's ``r`` leading its
    own), and ``kd_eval_<second>`` itself: both in turn, the first's outputs
    on the stack.

    ``eliminate``: whether each is listed with common subexpressions
    eliminated.  Both: one listing of both (their common subexpressions shared
    too); otherwise each listed on its own, sharing the program's
    intermediates the first computes."""
    one, two = pair
    (first_arguments, first_outputs), (arguments, outputs) = functions[one], functions[two]
    first_flat = [sm.sympify(e, strict=True) for _, exprs in first_outputs for e in exprs]
    flat = [sm.sympify(e, strict=True) for _, exprs in outputs for e in exprs]
    if all(eliminate):
        assignments, both = program.listing(first_flat + flat, cse=True)
        first_listing = (assignments, both[:len(first_flat)])
        second_listing = (assignments, both[len(first_flat):])
    else:  # no temporaries in common (kd_cseK of two listings would be equal symbols)
        first_listing = program.listing(first_flat, cse=eliminate[0])
        second_listing = program.listing(flat, cse=eliminate[1] and not eliminate[0])
    first_needed = _needed(*first_listing)
    needed = _needed(*second_listing, given=first_needed)
    first_assignments = [(s, e) for s, e in first_listing[0] if s in first_needed]
    assignments = [(s, e) for s, e in second_listing[0] if s in needed
                   and s not in first_needed]
    slots = {s: k for k, (s, _) in enumerate(
        (s, e) for s, e in first_assignments if s in needed)}
    src, first_work = _function_source(program, one, first_arguments, first_outputs, describe,
                                       None, (first_assignments, first_listing[1]),
                                       export=slots, offset=len(slots))
    yield src, first_work
    src, work = _function_source(program, two + "_shared", arguments, outputs, describe, None,
                                 (assignments, second_listing[1]), external=slots,
                                 offset=len(slots))
    args = "t, y, p, r, w"
    scratch = [f"a{k}" for k in range(len(first_outputs))]
    lines = [_signature(one, len(first_outputs)) + ";",
             _signature(two + "_shared", len(outputs)) + ";",
             _signature(two, len(outputs)) + " {",
             *(f"    double a{k}[{max(1, len(exprs))}];"
               for k, (_, exprs) in enumerate(first_outputs)),
             f"    kd_eval_{one}({args}{''.join(', ' + a for a in scratch)});",
             f"    kd_eval_{two}_shared({args}"
             f"{''.join(f', o{k}' for k in range(len(outputs)))});",
             "}"]
    yield src + "\n" + "\n".join(lines), max(first_work, work)


def _needed(assignments, outputs, given=()):
    """The symbols of ``assignments`` that ``outputs`` need, not looking past
    those ``given`` (included where needed)."""
    definition = dict(assignments)
    found, stack = set(), [s for e in outputs for s in free_symbols_of(e) if s in definition]
    while stack:
        s = stack.pop()
        if s in found:
            continue
        found.add(s)
        if s not in given:
            stack.extend(x for x in free_symbols_of(definition[s]) if x in definition)
    return found


def _eliminates(name, cse):
    """Whether function ``name`` is listed with common subexpressions
    eliminated: ``cse`` when given; by default (``None``) every function but
    the articulated-body pass, whose statements are the composite sums of a
    tree, their common parts intermediates already (measured on chain3d: the
    same run time without, and 1.65 s less of a 7 s build at n = 100)."""
    return cse if cse is not None else name != "tree"


class _RuntimePart(NamedTuple):
    """A runtime unit of a module before its preamble and sizes: its own
    ``#define`` lines, the declarations of generated functions it calls, and
    its templates."""
    defines: list
    declarations: list
    body: list
    light: bool
    model: bool  # the model's unit (C alone: no Python)
    generic_sizes: bool = False  # the sizes as run-time constants (_size_variables)


#: the work-array sizes, defined by the last unit of a module
_WORK_VARIABLES = ["extern const int kd_nw, kd_nwl;", "#define KD_NW kd_nw",
                   "#define KD_NWL kd_nwl"]


def _runtime_unit(part, sizes, lanes):
    """Text of a runtime unit (:func:`generate_c_units`); shared symbols
    hidden (``KD_GEN`` empty); the model's without Python's headers, defining
    the sizes the generic unit takes as constants (:func:`_size_variables`;
    one with contacts takes them as compile-time constants too)."""
    sizes_known = _size_variables(sizes) if part.generic_sizes else _size_defines(sizes)
    return "\n".join([*([LIGHT_UNIT] if part.light else []), "#define KD_GEN",
                      _c_runtime.PRELUDE if part.model else _c_runtime.HEADER,
                      *sizes_known, *part.defines, *_WORK_VARIABLES,
                      *_lane_runtime(lanes), _c_runtime.SIZE_MACROS, _c_runtime.SHARED,
                      *([_SIZE_CONSTANTS] if part.model else []),
                      *part.declarations, *part.body])


def _generic_part(sizes, lanes, declarations, n_contacts=0, inverse_point=False):
    """The generic runtime of a module: the same text for every model of the
    same variant, whatever its sizes (they are run-time constants there, see
    :func:`_size_variables`): its lanes, ``inverse_point``, whether it has
    inputs, dependent coordinates, dependent speeds, and the generated
    functions it calls.  With contacts (few models) the sizes and the number
    of contacts are compile-time constants in it, as in the model's unit.
    ``declarations``: of the generated functions it calls (``constraints``
    with dependent coordinates or speeds; ``dynamics`` and ``contacts`` with
    contacts; ``inverse`` with ``inverse_point``; ``energy`` always, for the
    integration loop's work)."""
    defines = ([f"#define KD_NC {n_contacts}"] if n_contacts else []) \
        + (["#define KD_INVERSE_POINT 1"] if inverse_point else [])
    body = [_c_runtime.RUNTIME, _c_integrator.INTEGRATOR, _c_ensemble.ENSEMBLE,
            *([_c_contact.CONTACT] if n_contacts else []),
            *([_c_runtime.INVERSE_POINT] if inverse_point else []), _c_runtime.RUNTIME_FOOTER]
    return _RuntimePart(defines, declarations, body, not (lanes or n_contacts), False,
                        not n_contacts)


#: outputs of the ``constraints`` and ``energy`` functions (built by
#: ``build_numeric_model``)
_CONSTRAINT_OUTPUTS = 4
_ENERGY_OUTPUTS = 2


def predicted_runtime_unit(sizes):
    """The generic runtime unit of the first module of a model of ``sizes``
    (``n_q, n_u, n_q_dep, n_u_dep, n_p, n_r``) without contacts: known before
    the model is derived, so that it can compile meanwhile
    (:func:`~._c_build.prefetch`).  The same text as :func:`generate_c_units`
    makes for such a model (a guess that turns out wrong costs only the
    compiler's time); it depends on ``sizes`` only through whether there are
    inputs, dependent coordinates and dependent speeds, so that a model of
    other sizes finds it compiled already."""
    dependent = sizes["n_q_dep"] + sizes["n_u_dep"]
    declarations = [_signature("constraints", _CONSTRAINT_OUTPUTS) + ";"] if dependent else []
    declarations.append(_signature("energy", _ENERGY_OUTPUTS) + ";")
    return _runtime_unit(_generic_part(sizes, False, declarations), sizes, False)


def prefetch_runtime(sizes):
    """Start compiling the generic runtime unit of a model of ``sizes`` (see
    :func:`predicted_runtime_unit`) before the model is derived: the compiler
    works on it while the equations are derived, and the module's build takes
    it over (:func:`~._c_build.prefetch`).  Nothing happens without a
    compiler or when the unit's object is cached already."""
    prefetch(predicted_runtime_unit(sizes))


def _runtime_parts(functions, sizes, lanes, share=None):
    """``(generic, model)``: the two runtime units of a module
    (:class:`_RuntimePart`), everything but the generated functions and the
    work-array sizes (``KD_NW``, ``KD_NWL``)."""
    declarations = {name: _signature(name, len(outputs)) + ";"
                    for name, (_, outputs) in functions.items()}
    contacts = functions.get("contacts")
    n_contacts = len(contacts[1][0][1]) if contacts else 0
    inverse_point = _inverse_at_a_point(functions, sizes)
    calls = (["constraints"] if sizes["n_q_dep"] + sizes["n_u_dep"] else []) \
        + (["dynamics", "contacts"] if contacts else []) + (["inverse"] if inverse_point else []) \
        + ["energy"]  # the work the integration loop sums (_c_integrator)
    generic = _generic_part(sizes, lanes, [declarations[name] for name in calls], n_contacts,
                            inverse_point)
    defines = [f"#define KD_HAS_DYNAMICS {int('dynamics' in functions)}",
               f"#define KD_MODULE_NAME_STR \"{NAME_TOKEN}\"",
               f"#define KD_INIT_FUNCTION PyInit_{NAME_TOKEN}",
               *solver_source(functions, sizes)]
    model_declarations = list(declarations.values())
    if share is not None:  # the part of the second that takes the first's values
        model_declarations.append(_signature(share[1] + "_shared",
                                             len(functions[share[1]][1])) + ";")
        defines.append("#define KD_JAC_SHARED 1")
    if lanes:
        model_declarations.append(_c_lanes.SIGNATURE + ";")
    # inverse dynamics of a trajectory: the function and the constraint terms at
    # every point in one call each; so the derivatives of many states and the
    # dynamics they start from
    rows = ("inverse", "constraints") if "inverse" in functions else ()
    if "jacobians" in functions:
        rows += ("jacobians", "dynamics")
    if "hessians" in functions:  # the exact Hessian's (_c_hessians)
        rows += ("hessians",)
    solved = _parameter_columns(functions, sizes) is not None
    if solved:  # its exact derivatives solved in C (solved_jacobians)
        defines.extend(jacobian_solve_defines(functions, sizes))
    body = [_c_runtime.MODEL_SOLVE, _c_runtime.LANE_SOLVE,
            *([_c_runtime.JACOBIAN_SOLVE, _c_runtime.JACOBIAN_INFO] if solved else []),
            _function_table(functions, rows), _c_runtime.MODULE_FOOTER]
    model = _RuntimePart(defines, model_declarations, body, not lanes, True)
    return generic, model


def _jacobian_groups(functions, sizes):
    """Column groups in the outputs of the ``jacobians`` function whose
    derivatives the module solves in C: its outputs ``g_x, E_x, a_x`` per group
    (the state, the inputs, and the constants when asked for: 2 or 3), then
    ``h_y, c_y``.  ``None`` without that function, or with more outputs (a
    stabilized scheme's parts: its derivatives are solved in NumPy)."""
    _, outputs = functions.get("jacobians", (None, ()))
    count = len(outputs) - (sizes.get("jacobian_tree") is not None)  # the tree's factors
    return {8: 2, 11: 3}.get(count)


def _parameter_columns(functions, sizes):
    """Columns of the constants in the outputs of the ``jacobians`` function
    (:func:`_jacobian_groups`; 0 where they were not asked for, or the model
    has none); ``None`` where the module does not solve its derivatives."""
    groups = _jacobian_groups(functions, sizes)
    return None if groups is None else (sizes["n_p"] if groups == 3 else 0)


def jacobian_solve_defines(functions, sizes):
    """C definitions of the solve of a derivative module's exact derivatives
    (:data:`_c_runtime.JACOBIAN_SOLVE`): the constants' columns ``KD_JP``, the
    tree whose derivatives come from their factors (:func:`jacobian_tree_source`)
    and, where the articulated-body pass solves them, ``KD_JAC_TREE_SOLVE``."""
    defines = [f"#define KD_JP {_parameter_columns(functions, sizes)}",
               f"#define KD_JAC_GROUPS {_jacobian_groups(functions, sizes)}",
               *jacobian_tree_source(sizes)]
    tree = _solving_tree(functions, sizes)
    if tree is not None:  # solved by the tree pass
        parent, order = tree
        chain = (list(parent) == list(range(-1, len(parent) - 1))
                 and list(order) == list(range(len(parent) - 1, -1, -1)))
        defines += ["#define KD_JAC_TREE_SOLVE 1", f"#define KD_TSOLVE_CHAIN {int(chain)}"]
    return defines


def jacobian_tree_source(sizes):
    """C definitions of the tree whose derivatives ``kd_tree_jacobian`` forms from
    their factors (the last output of the ``jacobians`` function,
    ``sizes["jacobian_tree"]``: the speed above each speed, -1 at a root):
    ``KD_TREE_JAC``, ``KD_TREE_CHAIN`` (each speed's parent the one before it)
    and ``kd_jparent``; ``KD_TREE_JAC 0`` without."""
    parent = sizes.get("jacobian_tree")
    if parent is None:
        return ["#define KD_TREE_JAC 0"]
    chain = all(p == k - 1 for k, p in enumerate(parent))
    return ["#define KD_TREE_JAC 1", f"#define KD_TREE_CHAIN {int(chain)}",
            f"static const int kd_jparent[{len(parent)}] = {{{', '.join(map(str, parent))}}};"]


def _inverse_at_a_point(functions, sizes):
    """Whether the module gets ``inverse_point`` (:data:`_c_runtime.INVERSE_POINT`):
    an ``inverse`` function returning tau alone, of a model without dependent
    coordinates or speeds whose only run-time inputs are the rates."""
    if "inverse" not in functions or sizes["n_q_dep"] or sizes["n_u_dep"]:
        return False
    arguments, outputs = functions["inverse"]
    return len(outputs) == 1 and len(arguments.get("r", ())) == sizes["n_u"]


def eager_functions(functions, sizes):
    """The functions of the module built first (without the lane-wise code,
    ``lanes=False``): all of them, except that a model whose right-hand side
    is solved by the articulated-body pass (``"tree"``, no dependent speeds,
    no contacts) leaves out ``"dynamics"`` (the mass matrix: most of the
    build at large n).  A second module with every function (and the lanes,
    :func:`lanes_wanted`) is built when first needed: ``NumericModel``'s
    mass matrix or linearization, or a large ``rhs_batch``."""
    if "tree" in functions and not sizes["n_u_dep"] and "contacts" not in functions:
        return {name: spec for name, spec in functions.items() if name != "dynamics"}
    return functions


def lanes_wanted(functions, sizes, lanes=True):
    """Whether a module of ``functions`` gets the lane-wise dynamics of
    ``rhs_batch`` (``_c_lanes``); never with ``lanes=False``.

    Not for dependent speeds (their reduced system is solved by LU; such
    batches go one row at a time), nor for models solved by the articulated-body
    pass (``"tree"``: rows of the pass cost about as much as lanes of M and its
    factorization, 1.17x at chain3d n = 30, for twice the compile time), nor
    with :data:`_c_lanes.LANES` = 0.
    """
    if not lanes or _c_lanes.LANES <= 0 or sizes.get("n_u_dep", 0) \
            or "dynamics" not in functions or "tree" in functions:
        return False
    arguments, outputs = functions["dynamics"]
    return set(arguments) <= {"y", "p", "r"} and len(outputs) >= 3
