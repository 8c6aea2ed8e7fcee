r"""The exact Hessian's weighted second derivatives as C (``backend="c"``).

:func:`kanedyn.numerics.weighted_hessians` forms, at each point,

.. math::

    H = \begin{bmatrix} I \\ W \end{bmatrix}^T \Phi
        \begin{bmatrix} I \\ W \end{bmatrix},\qquad
    \Phi = \sum_i \lambda_{q,i}\, g_i'' - \sum_i \nu_i\, E_i'',\qquad
    \nu = M^{-1} \lambda_u ,

with :math:`g_i''`, :math:`E_i''` the second derivatives of the rows of
:math:`[g; E]` in :math:`v = (x, w)` (``nv`` columns, the last ``o`` those of
the accelerations :math:`w`), :math:`M` the (symmetric) mass matrix and
:math:`W = w_x` (o, nx), whose last ``ne`` columns (the chosen constants and
the time) are :math:`-M^{-1} E_e`.  Here all of it is one generated function
whose run-time inputs are the model's inputs, :math:`w`, the weights
:math:`\lambda` and the first columns of :math:`W` (those of the states and
inputs, which the caller has from :func:`~kanedyn.numerics.jacobians`): the
solves with :math:`M` by its :math:`LDL^T` factors written out (no pivoting:
:math:`M` is positive definite), then :math:`\Phi` (its lower triangle),
:math:`Z = \Phi [I; W]` and :math:`H = Z_x + W^T Z_w`, all intermediates of
the straight-line program, their structural zeros left out.  A module of the
model evaluates it at every point of a trajectory in one call
(``hessians_rows``), so NumPy only hands arrays over.  It is built, cached
and loaded like the model's other modules (:func:`~._c_build.load_module`,
from the quick compiler first).
"""

from __future__ import annotations

import sympy as sm

from ._c import fingerprint, generate_c_units, load_module

__all__ = ["contracted_hessian", "hessian_module"]

#: changes when the generated Hessian changes (part of the cache key)
_GENERATION = "hessians 3"


def _solver(program, mass, o):
    """``solve(columns)``: :math:`M^{-1} B` of columns ``B`` (lists of ``o``
    expressions), from the :math:`LDL^T` factors of ``mass`` (``o * o``
    entries, row-major; its lower triangle read) named in ``program``."""
    L, D, inverse_D = {}, [], []
    for j in range(o):
        D.append(program.let(mass[j * o + j] - sm.Add(*[L[j, k] ** 2 * D[k]
                                                        for k in range(j)])))
        inverse_D.append(program.let(1 / D[j]))
        for i in range(j + 1, o):
            L[i, j] = program.let((mass[i * o + j] - sm.Add(*[
                L[i, k] * L[j, k] * D[k] for k in range(j)])) * inverse_D[j])

    def solve(column):
        y = []
        for i in range(o):  # L y = b
            y.append(program.let(column[i] - sm.Add(*[L[i, k] * y[k] for k in range(i)])))
        x = [None] * o
        for i in reversed(range(o)):  # L^T x = D^-1 y
            x[i] = program.let(y[i] * inverse_D[i] - sm.Add(*[L[k, i] * x[k]
                                                               for k in range(i + 1, o)]))
        return x
    return solve


def contracted_hessian(program, mass, second, E_e, n, o, nx):
    """``(weights, W, H)``: the symbols of the run-time weights :math:`\\lambda`
    (``n + o``) and of the first columns of :math:`W` (``o * (nx - ne)``,
    row-major), and the entries of :math:`H` (``nx * nx``, row-major,
    symmetric), named in ``program``.

    Parameters
    ----------
    program : Program
        Where the intermediates are added.
    mass : sequence of Expr
        :math:`M`, ``o * o`` entries, row-major.
    second : sequence of Expr
        The second derivatives of the ``n + o`` rows of :math:`[g; E]` in
        ``v``, ``(n + o) * nv * nv`` entries (row, then the two columns),
        ``nv = nx + o``.
    E_e : sequence of Expr
        :math:`E_e`, ``o * ne`` entries, row-major (empty: ``ne = 0``).
    """
    nv, ne = nx + o, len(E_e) // o
    weights = [sm.Dummy(f"kd_hessian_lambda{i}") for i in range(n + o)]
    given = nx - ne
    W = [[sm.Dummy(f"kd_hessian_w{k}_{b}") for b in range(given)] for k in range(o)]
    solve = _solver(program, mass, o)
    for j in range(ne):  # w_e = -M^-1 E_e
        for k, value in enumerate(solve([-E_e[i * ne + j] for i in range(o)])):
            W[k].append(value)
    row_weights = weights[:n] + [-nu for nu in solve(weights[n:])]

    def phi(a, b):  # the lower triangle: the derivatives' own symmetry
        a, b = max(a, b), min(a, b)
        return program.let(sm.Add(*[row_weights[i] * second[(i * nv + a) * nv + b]
                                    for i in range(n + o)]))

    Phi = {(a, b): phi(a, b) for a in range(nv) for b in range(a + 1)}

    def Z(a, b):  # (Phi [I; W])_ab, a < nv, b < nx
        return program.let(Phi[max(a, b), min(a, b)] + sm.Add(*[
            Phi[max(a, nx + k), min(a, nx + k)] * W[k][b] for k in range(o)]))

    Zw = {(k, b): Z(nx + k, b) for k in range(o) for b in range(nx)}
    H = {(a, b): program.let(Z(a, b) + sm.Add(*[W[k][a] * Zw[k, b] for k in range(o)]))
         for a in range(nx) for b in range(a + 1)}
    return (weights, [s for row in W for s in row[:given]],
            [H[max(a, b), min(a, b)] for a in range(nx) for b in range(nx)])


def hessian_module(model, variant, specification):
    """The C module of ``model``'s contracted Hessian (built, or loaded from
    the cache, on first use).

    Parameters
    ----------
    model : NumericModel
        Of the C backend.
    variant : str
        What else sets the generated code (the extra columns chosen): part of
        the cache key.
    specification : callable
        ``specification()``: ``(program, arguments, outputs, pattern)`` of
        the function ``hessians`` (evaluated at every point by ``_c``'s
        runtime, ``hessians_rows``) and where its result can be nonzero
        ((nx, nx) bool, given back by the module's function
        ``hessian_pattern``, a table of constants), called only when the
        module is not cached (a cached one is loaded without differentiating
        anything).  The module also carries the model's ``dynamics`` and
        ``energy`` (which its runtime calls).
    """
    functions = {name: model._functions[name] for name in ("dynamics", "energy")}
    sizes = {k: v for k, v in model._sizes.items() if k != "speed_tree"}
    key = fingerprint(model._eom._program, functions, sizes, model._cse, lanes=False)
    table = model._eom._table

    def units():
        program, arguments, outputs, pattern = specification()
        shown = (pattern.shape, [sm.Integer(int(v)) for v in pattern.ravel()])
        return generate_c_units(program, dict(functions, hessians=(arguments, outputs),
                                              hessian_pattern=(dict(arguments, r=[]),
                                                               [shown])),
                                sizes, describe=lambda e: str(table.external(e)),
                                cse=model._cse, lanes=False)
    return load_module(f"{key}\n{_GENERATION} {variant}", units, quick=True)
