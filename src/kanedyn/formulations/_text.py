"""Plain text of equations of motion: compact (named intermediates) or explicit."""

from __future__ import annotations

import sympy as sm
from sympy.core.function import AppliedUndef

from ..engine import name_of

__all__ = ["equations_text"]


def equations_text(eom, explicit=False):
    """Text of ``q' = ...`` and ``mass_matrix * u' = forcing`` (SymPy convention).

    Parameters
    ----------
    eom : EquationsOfMotion
    explicit : bool
        Write every entry out in the model's symbols (can be very long for
        large models) instead of the compact form: the intermediates
        ``z0, z1, ...`` each defined once, then the equations in terms of them.

    Returns
    -------
    str
        One equation per line; lines starting with ``#`` are comments.
    """
    table, prog = eom._table, eom._program
    u_dots = ", ".join(name_of(u) + "'" for u in eom.u)
    names, plain = {}, {}

    def show(e):
        e = sm.sympify(e, strict=True)
        if not explicit:
            e = table.external(e.xreplace(names))
        for f in e.atoms(sm.Derivative, AppliedUndef):  # q(t) -> q
            plain.setdefault(f, sm.Symbol(name_of(f)))
        return sm.sstr(e.xreplace(plain))

    if explicit:
        kin = [(name_of(qd), rhs) for qd, rhs in eom.kindiffdict().items()]
        M, F = eom.mass_matrix, eom.forcing
        intermediates = []
    else:
        M, F = eom._compact_mass_matrix, eom._compact_forcing
        needed = prog.needed(list(eom._qdot) + list(M) + list(F))
        names.update((s, sm.Symbol(f"z{k}")) for k, s in enumerate(needed))
        t = table.t
        kin = [(name_of(q.diff(t)), e) for q, e in zip(eom.q, eom._qdot)]
        intermediates = [f"{names[s]} = {show(prog.definition(s))}" for s in needed]
    lines = ["# kinematic equations"] + [f"{qd} = {show(e)}" for qd, e in kin]
    if intermediates:
        lines.append(f"# intermediates ({len(intermediates)})")
        lines += intermediates
    lines.append(f"# mass_matrix * u' = forcing, with u' = [{u_dots}]")
    for i in range(M.rows):
        for j in range(M.cols):
            if M[i, j] != 0:
                lines.append(f"mass_matrix[{i}, {j}] = {show(M[i, j])}")
    lines += [f"forcing[{i}] = {show(F[i])}" for i in range(F.rows)]
    return "\n".join(lines)
