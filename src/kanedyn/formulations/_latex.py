"""LaTeX of equations of motion: explicit when small, compact otherwise."""

from __future__ import annotations

import sympy as sm
from sympy.physics.vector import vlatex

__all__ = ["equations_latex"]


def equations_latex(eom, explicit=None, max_ops=400):
    """LaTeX of ``q' = ...`` and ``M u' = F`` (SymPy convention)."""
    prog = eom._program
    compact_M = eom._compact_mass_matrix
    compact_F = eom._compact_forcing
    outputs = list(eom._qdot) + list(compact_M) + list(compact_F)
    if explicit is None:
        explicit = prog.count_ops(outputs) <= max_ops
    t = eom._table.t
    qdot = sm.Matrix([q.diff(t) for q in eom.q])
    udot = sm.Matrix([u.diff(t) for u in eom.u])
    if explicit:
        kin = eom.forcing_kin
        M, F = eom.mass_matrix, eom.forcing
        lines = [vlatex(qdot) + " = " + vlatex(kin),
                 vlatex(M) + vlatex(udot) + " = " + vlatex(F)]
        return r"\begin{aligned}" + r" \\ ".join(
            line.replace("=", "&=", 1) for line in lines) + r"\end{aligned}"
    table = eom._table
    needed = prog.needed(outputs)
    names = {s: sm.Symbol(f"z_{{{k}}}") for k, s in enumerate(needed)}

    def show(e):
        return vlatex(table.external(sm.sympify(e, strict=True).xreplace(names)))

    lines = [vlatex(qdot) + " &= " + vlatex(sm.Matrix(
        [table.external(sm.sympify(e, strict=True).xreplace(names)) for e in eom._qdot]))]
    lines += [f"{vlatex(names[s])} &= {show(prog.definition(s))}" for s in needed]
    lines.append(vlatex(compact_M.xreplace(names).applyfunc(table.external))
                 + vlatex(udot) + " &= "
                 + vlatex(compact_F.xreplace(names).applyfunc(table.external)))
    return r"\begin{aligned}" + r" \\ ".join(lines) + r"\end{aligned}"
