r"""The exact Hessian's weighted second derivatives as C (``backend="c"``).

:func:`kanedyn.numerics.weighted_hessians` forms, at each point,

.. math::

    H = \begin{bmatrix} I \\ W \end{bmatrix}^T \Phi
        \begin{bmatrix} I \\ W \end{bmatrix},\qquad
    \Phi = \sum_i c_i\, F_i'' ,

with :math:`F_i''` the second derivatives of the rows of :math:`[g; E]` in
:math:`v = (x, w)` (``nv`` columns, the last ``o`` those of the
accelerations :math:`w`), :math:`c` their weights and :math:`W` (o, nx) the
derivatives :math:`w_x`.  Here the weights and :math:`W` are run-time inputs
of a generated function that computes :math:`H` itself, the contraction
included: :math:`\Phi` (its lower triangle), then :math:`Z = \Phi [I; W]`
and :math:`H = Z_x + W^T Z_w` as intermediates of the straight-line program,
their structural zeros left out, so that a module of the model evaluates it
at every point of a trajectory in one call (``hessians_rows``) and NumPy only
hands arrays over.  The same module gives the mass matrix :math:`M` and
:math:`E_e` (``hessian_mass_rows``), from which the caller solves the weights
:math:`\nu = M^{-T}\lambda_u` and the columns :math:`-M^{-1}E_e` of
:math:`W`.  The module is built, cached and loaded like the model's others
(:func:`~._c_build.load_module`, from the quick compiler first).
"""

from __future__ import annotations

import sympy as sm

from ._c import fingerprint, generate_c_units, load_module

__all__ = ["contracted_hessian", "hessian_module"]

#: changes when the generated Hessian changes (part of the cache key)
_GENERATION = "hessians 1"


def contracted_hessian(program, second, n_rows, nx, o):
    """``(weights, W, H)``: the symbols of the run-time weights :math:`c`
    (``n_rows``) and of :math:`W` (``o * nx``, row-major), and the entries of
    :math:`H` (``nx * nx``, row-major, symmetric), named in ``program``.

    Parameters
    ----------
    program : Program
        Where the intermediates :math:`\\Phi` and :math:`Z` are added.
    second : sequence of Expr
        The second derivatives of the rows in ``v``, ``n_rows * nv * nv``
        entries (row, then the two columns), ``nv = nx + o``.
    """
    nv = nx + o
    weights = [sm.Dummy(f"kd_hessian_c{i}") for i in range(n_rows)]
    W = [sm.Dummy(f"kd_hessian_w{k}") for k in range(o * nx)]

    def phi(a, b):  # the lower triangle: the derivatives' own symmetry
        a, b = max(a, b), min(a, b)
        terms = [weights[i] * second[(i * nv + a) * nv + b] for i in range(n_rows)]
        return program.let(sm.Add(*terms))

    Phi = {(a, b): phi(a, b) for a in range(nv) for b in range(a + 1)}

    def Z(a, b):  # (Phi [I; W])_ab, a < nv, b < nx
        return program.let(Phi[max(a, b), min(a, b)] + sm.Add(*[
            Phi[max(a, nx + c), min(a, nx + c)] * W[c * nx + b] for c in range(o)]))

    Zw = {(c, b): Z(nx + c, b) for c in range(o) for b in range(nx)}
    H = {}
    for a in range(nx):
        for b in range(a + 1):
            H[a, b] = program.let(Z(a, b) + sm.Add(*[W[c * nx + a] * Zw[c, b]
                                                     for c in range(o)]))
    return weights, W, [H[max(a, b), min(a, b)] for a in range(nx) for b in range(nx)]


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
        ``specification()``: ``(program, {name: (arguments, outputs)})`` of
        the functions ``hessian_mass`` and ``hessians`` (evaluated at every
        point by ``_c``'s runtime, ``name_rows``), called only when the module is
        not cached (a cached one is loaded without differentiating anything).
        The module also carries the model's ``dynamics`` and ``energy``
        (which its runtime calls).
    """
    functions = {name: model._functions[name] for name in ("dynamics", "energy")}
    sizes = {k: v for k, v in model._sizes.items() if k != "speed_tree"}
    key = fingerprint(model._eom._program, functions, sizes, model._cse, lanes=False)
    table = model._eom._table

    def units():
        program, generated = specification()
        return generate_c_units(program, dict(functions, **generated), sizes,
                                describe=lambda e: str(table.external(e)), cse=model._cse,
                                lanes=False)
    return load_module(f"{key}\n{_GENERATION} {variant}", units, quick=True)
