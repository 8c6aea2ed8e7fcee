"""Lane-wise C code of the dynamics: one straight-line program, ``W`` states at once.

``rhs_batch`` of the C backend evaluates its rows in blocks of ``W`` states
(the lanes).  Every intermediate of the program is then a group of ``W``
doubles, and the statements run inside loops over the lanes that the
compiler turns into SIMD instructions (AVX2: four doubles per instruction).

Statements are grouped into stages: a *vector* stage holds statements the
compiler can vectorize (arithmetic, ``sqrt``, ``fabs``), all inside one lane
loop; a *scalar* stage holds calls without a vector version in the C library
(``sin``, ``cos``, ``pow``, ...), evaluated lane by lane.  A statement goes
to the earliest stage of its kind after every stage it depends on, so a
typical mechanism has three: a few scalar trigonometric functions of the
coordinates, then one vector stage with everything else.  Values used
outside their own stage (or chunk of :data:`~._c.CHUNK` statements) go
through a work array of ``W`` lanes per value.

The generated function is::

    KD_GEN void kd_lanes_dynamics(const double *tl, const double *yl,
        const double *pl, const double *rl, double *w,
        double *o0, double *o1, double *o2)

with every argument in lane layout (entry ``i`` of lane ``l`` at
``[i * KD_W + l]``) and the outputs ``q'``, ``M`` (row-major) and ``f``.
The runtime (:data:`~._c_runtime.LANE_RUNTIME`) adds the lane-wise
``L^T D L`` solve and the gathering of rows.
"""

from __future__ import annotations

import sympy as sm

__all__ = ["LANES", "SIGNATURE", "vectorizable", "lanes_source"]

#: lanes of the vectorized batch evaluation (0: none); 4 doubles = one AVX2 register
LANES = 4

_PARAMS = ("const double *restrict tl, const double *restrict yl, "
           "const double *restrict pl, const double *restrict rl, double *restrict w")
#: the declaration of the generated lane-wise dynamics
SIGNATURE = (f"KD_LANES_FN KD_GEN void kd_lanes_dynamics({_PARAMS}, double *restrict o0, "
             "double *restrict o1, double *restrict o2)")

_SIMPLE_POWERS = {sm.Integer(2), sm.Integer(3), sm.Integer(-1), sm.Integer(-2),
                  sm.S.Half, -sm.S.Half}


def vectorizable(expr):
    """Whether the C text of ``expr`` vectorizes without a vector math library.

    Arithmetic, the small powers printed as products and ``sqrt``, and
    ``Abs`` (``fabs``) do; every other function call does not.
    """
    for node in sm.preorder_traversal(expr):
        if isinstance(node, sm.Abs):
            continue
        if isinstance(node, (sm.Function, sm.Piecewise)):
            return False
        if isinstance(node, sm.Pow) and node.exp not in _SIMPLE_POWERS:
            return False
    return True


def _stages(needed, definition, index):
    """Stage of every statement: even numbers vector stages, odd scalar ones."""
    stage = {}
    for s in needed:
        expr = definition[s]
        after = max((stage[d] for d in expr.free_symbols if d in index), default=0)
        if vectorizable(expr):
            stage[s] = after + (after % 2)  # the next even stage
        else:
            stage[s] = after + 1 - (after % 2)  # the next odd stage
    return stage


def lanes_source(program, arguments, outputs, listing, describe, chunk):
    """C source of ``kd_lanes_dynamics`` and its work size in values.

    Parameters
    ----------
    program : Program
    arguments : dict
        ``{"y": symbols, "p": symbols, "r": symbols}`` of the dynamics.
    outputs : list of (shape, list of Expr)
        The outputs of the dynamics; the first three (``q'``, ``M``, ``f``)
        are generated.
    listing : tuple
        ``program.listing`` of all the flattened outputs (assignments, outputs).
    describe : callable
        Text of an expression for error messages.
    chunk : int
        Statements per generated C function at most (``_c.CHUNK``).

    Returns
    -------
    source : str
    work : int
        Number of values kept in the work array (``KD_W`` doubles each).
    """
    from ._c import _CPrinter, _print_c

    base = {program.t: "tl[l]"}
    for arg, symbols in arguments.items():
        for i, s in enumerate(symbols):
            base[s] = f"{arg}l[{i} * KD_W + l]"
    assignments, flat = listing
    count = sum(len(exprs) for _, exprs in outputs[:3])
    flat = flat[:count]
    needed = [s for s, _ in assignments]
    definition = dict(assignments)
    index = {s: k for k, s in enumerate(needed)}
    stage = _stages(needed, definition, index)
    ordered = sorted(needed, key=lambda s: (stage[s], index[s]))
    groups = []  # (vector?, statements): a stage in chunks
    for s in ordered:
        if not groups or stage[groups[-1][1][-1]] != stage[s] or len(groups[-1][1]) >= chunk:
            groups.append((stage[s] % 2 == 0, []))
        groups[-1][1].append(s)
    group_of = {s: g for g, (_, members) in enumerate(groups) for s in members}
    shared = set()  # values used outside their group
    for s in needed:
        for d in definition[s].free_symbols:
            if d in index and group_of[d] != group_of[s]:
                shared.add(d)
    for e in flat:
        shared.update(d for d in e.free_symbols if d in index)
    slot = {s: k for k, s in enumerate(sorted(shared, key=index.get))}
    params = _PARAMS
    lines, calls = [], []
    for g, (vector, members) in enumerate(groups):
        names = dict(base)
        names.update((s, f"w[{slot[s]} * KD_W + l]") for s in shared)
        body = []
        printer = _CPrinter(names)  # reads ``names`` as it grows
        for s in members:
            names[s] = f"z{index[s]}"
            code = _print_c(printer, definition[s], f"in the intermediate {s.name}", describe)
            body.append(f"        const double z{index[s]} = {code};")
            if s in shared:
                body.append(f"        w[{slot[s]} * KD_W + l] = z{index[s]};")
        lines.append(f"KD_LANES_FN static void kd_lanes_part{g}({params}) {{")
        if vector:
            lines.append("    KD_LANE_LOOP")
        lines.append("    for (int l = 0; l < KD_W; ++l) {")
        lines.extend(body)
        lines.append("    }")
        lines.append("    (void)tl; (void)yl; (void)pl; (void)rl; (void)w;")
        lines.append("}")
        calls.append(f"    kd_lanes_part{g}(tl, yl, pl, rl, w);")
    names = dict(base)
    names.update((s, f"w[{slot[s]} * KD_W + l]") for s in shared)
    printer = _CPrinter(names)
    lines.append(SIGNATURE + " {")
    lines.extend(calls)
    vector = all(vectorizable(e) for e in flat)
    if vector:
        lines.append("    KD_LANE_LOOP")
    lines.append("    for (int l = 0; l < KD_W; ++l) {")
    position = 0
    for k, (_, exprs) in enumerate(outputs[:3]):
        for j in range(len(exprs)):
            code = _print_c(printer, flat[position], f"output {j} of the dynamics", describe)
            position += 1
            lines.append(f"        o{k}[{j} * KD_W + l] = {code};")
    lines.append("    }")
    lines.append("    (void)tl; (void)yl; (void)pl; (void)rl; (void)w;")
    lines.append("}")
    return "\n".join(lines), len(slot)
