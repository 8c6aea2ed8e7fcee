r"""The energy balance of a run, term by term: what changed the stored energy.

The stored energy :math:`E = T + V` (kinetic plus the declared potential
energy, :math:`V = 0` where none is declared) changes by the work of
everything it does not hold.  What :math:`V` holds is said by the caller
(``potential_loads``: the loads whose work it holds, as a model definition
declares them) or found by the gravity symbol (the loads' parts in it); no
term counts it a second time.  Each of the others is a named term
(:mod:`kanedyn.numerics._load_powers`): the work of each load (inputs,
dampers, drag, friction elements, constraint forces that auxiliary speeds
expose), of the constraint forces that drive prescribed motion, and of each
flexible body's damping.  The residual

.. math:: r(t) = E(t) - E(t_0) - \sum_j W_j(t)

is the balance's quality figure: zero along an exact solution, so that
what remains measures the integration's error (and any term the balance
does not know of).  It is given relative to the energy exchanged or moving,
:math:`S = \max_t \max(|E(t) - E(t_0)|,\ \sum_j |W_j(t)|,\ T(t))`.

The works are integrated along the run's continuous solution
(``dense_output=True``): Gauss-Legendre with :data:`_NODES` nodes on each of
the integrator's steps (cut at the output times), so that the quadrature's
error is far below the integration's.  The residual then is
:math:`\int \nabla E\cdot(\dot y - f(t, y))\,dt` along the continuous
solution: its defect.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import KanedynError
from ..numerics import load_powers

__all__ = ["EnergyBalance", "energy_balance"]

#: Gauss-Legendre nodes per step
_NODES = 5


@dataclass(frozen=True)
class EnergyBalance:
    r"""A run's energy balance (see :mod:`kanedyn.analysis._energy_balance`).

    Attributes
    ----------
    t : numpy.ndarray, shape (N,)
        The run's output times, s.
    energy_change : numpy.ndarray, shape (N,)
        :math:`E(t) - E(t_0)`, J.
    terms : dict
        ``{name: numpy.ndarray (N,)}``: the work of each term from the start, J.
    residual : numpy.ndarray, shape (N,)
        ``energy_change - sum(terms)``, J.
    scale : float
        The energy exchanged or moving, :math:`S`, J.
    notes : tuple of str
        What the balance leaves out or takes from elsewhere.
    """

    t: np.ndarray
    energy_change: np.ndarray
    terms: dict
    residual: np.ndarray
    scale: float
    notes: tuple = ()

    @property
    def relative_residual(self):
        """The largest ``|residual|`` over :attr:`scale` (0 where nothing is exchanged)."""
        largest = float(np.max(np.abs(self.residual))) if self.residual.size else 0.0
        return largest / self.scale if self.scale > 0 else largest

    def as_dict(self):
        """Final values, JSON-ready: ``energy_change``, ``terms``, ``residual`` (J),
        ``scale`` (J), ``relative_residual``, ``notes``."""
        return {"energy_change": float(self.energy_change[-1]),
                "terms": {name: float(w[-1]) for name, w in self.terms.items()},
                "residual": float(self.residual[-1]), "scale": self.scale,
                "relative_residual": self.relative_residual, "notes": list(self.notes)}

    def lines(self):
        """The balance at the end of the run, as lines of text."""
        rows = [("change of stored energy", self.energy_change[-1])]
        rows += [(f"work: {name}", w[-1]) for name, w in self.terms.items()]
        rows.append(("residual", self.residual[-1]))
        width = max(len(label) for label, _ in rows)
        out = [f"  {label:<{width}}  {value:+.6e} J" for label, value in rows]
        out[-1] += (f" (largest: {self.relative_residual:.3e} of the {self.scale:.6g} J "
                    "exchanged or moving)")
        return out + [f"  note: {note}" for note in self.notes]


def energy_balance(result, load_names=None, gravity="g", potential_loads=()):
    """The energy balance of ``result``, term by term.

    Parameters
    ----------
    result : SimulationResult
        A run with a continuous solution (``kd.simulate(..., dense_output=True)``)
        of a model derived by :func:`kanedyn.kane`.
    load_names : sequence of str or None, optional
        A name for each load, in the order of ``eom.loads``
        (:attr:`kanedyn.models.ModelDefinition.load_names`); loads that share a
        name are one term (their works added: the aerodynamic forces on a
        blade's nodes).  Default, for the whole sequence or an entry ``None``:
        where the load acts and the constants, inputs and constraint forces it
        holds.
    gravity : str or sympy.Symbol or None
        The gravity constant: where the model declares a potential energy, the
        loads' parts proportional to it are taken to be held by that potential
        (and are no term).  A name is looked up among the model's constants
        (none of that name: no gravity parts); ``None``: no gravity parts.
    potential_loads : sequence of int
        The indices (in the order of ``eom.loads``) of the loads whose work the
        declared potential energy holds
        (:attr:`kanedyn.models.ModelDefinition.potential_loads`: weights and
        springs where the constants are numbers): no term.  Default: none.

    Returns
    -------
    EnergyBalance
    """
    model = result.model
    sol = result.sol
    if sol is None:
        raise KanedynError("energy_balance needs the run's continuous solution: simulate "
                           "with dense_output=True")
    if model.contacts:
        raise KanedynError("energy_balance: a model with contacts has its own balance, "
                           "result.energy_balance()")
    eom = model._eom
    names = _term_names(eom, model, load_names)
    held = _held(potential_loads, len(names), model.has_potential)
    symbol = _gravity_symbol(eom, gravity) if model.has_potential else None
    grid = _grid(sol, result.t)
    a, b = grid[:-1], grid[1:]
    x, w = np.polynomial.legendre.leggauss(_NODES)
    nodes = (0.5 * (a + b)[:, None] + 0.5 * (b - a)[:, None] * x).ravel()
    powers = load_powers(model, nodes, sol(nodes), gravity=symbol)
    columns = {}
    for k, (name, power, weight) in enumerate(zip(names, powers.loads, powers.gravity)):
        if k in held:
            continue
        if np.any(power) or not np.any(weight):     # not wholly held by V
            columns[name] = columns[name] + power if name in columns else power
    notes = []
    if symbol is not None and np.any(powers.gravity):
        notes.append(f"the loads' parts in {symbol} (gravity) are held by the potential "
                     "energy")
    if held:
        notes.append(f"{len(held)} loads are held by the potential energy (no terms): "
                     + ", ".join(dict.fromkeys(names[k] for k in sorted(held))))
    if powers.prescribed is None:
        moved = ", ".join(powers.moved_flexible)
        notes.append(f"the work that drives the prescribed motion of {moved} is "
                     + (f"that of the constraint forces {', '.join(model.aux_names)}"
                        if model.aux_names else "not known here (no term): expose its "
                        "forces by auxiliary speeds"))
    elif np.any(powers.prescribed):
        columns["prescribed motion (the forces that drive it)"] = powers.prescribed
    columns.update({f"damping of {body}": p for body, p in powers.damping.items()})
    weights = (0.5 * (b - a)[:, None] * w).ravel()
    at = np.searchsorted(grid, result.t)
    terms = {}
    for name, power in columns.items():
        cumulative = np.concatenate([[0.0], np.cumsum(np.add.reduceat(
            power * weights, np.arange(0, power.size, _NODES)))])
        terms[name] = cumulative[at] - cumulative[at[0]]
    kinetic, potential = np.array([model.energies(t, y) for t, y in
                                   zip(result.t, result.y.T)]).T.reshape(2, -1)
    energy = kinetic + (potential if model.has_potential else 0.0)
    change = energy - energy[0]
    residual = change - sum(terms.values(), np.zeros_like(change))
    exchanged = sum((np.abs(v) for v in terms.values()), np.zeros_like(change))
    scale = float(np.max(np.maximum(np.maximum(np.abs(change), exchanged), kinetic))
                  if change.size else 0.0)
    return EnergyBalance(np.asarray(result.t), change, terms, residual, scale, tuple(notes))


def _held(potential_loads, count, has_potential):
    """The set of load indices held by the potential, checked."""
    held = set()
    for k in potential_loads or ():
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k < count:
            raise KanedynError(f"energy_balance: potential_loads must be indices of the "
                               f"{count} loads, got {k!r}")
        held.add(int(k))
    if held and not has_potential:
        raise KanedynError("energy_balance: potential_loads given, but the model declares "
                           "no potential energy to hold their work")
    return held


def _grid(sol, t_out):
    """The integrator's step ends (where the solution keeps them) and the output times."""
    pieces = getattr(sol, "pieces", [sol])
    steps = [np.asarray(p.ts, dtype=float) for p in pieces if hasattr(p, "ts")]
    grid = np.unique(np.concatenate(steps + [np.asarray(t_out, dtype=float)]))
    return grid[(grid >= t_out[0]) & (grid <= t_out[-1])]


def _gravity_symbol(eom, gravity):
    if gravity is None or not isinstance(gravity, str):
        return gravity
    return next((c for c in eom.constants if str(c) == gravity), None)


def _term_names(eom, model, load_names):
    """One name per load: given, or where it acts and the symbols it holds."""
    count = len(eom._load_vectors)
    if load_names is not None:
        load_names = [None if n is None else str(n) for n in load_names]
        if len(load_names) != count:
            raise KanedynError(f"energy_balance: {len(load_names)} load names for {count} "
                               "loads")
        if None not in load_names:
            return load_names
        defaults = _term_names(eom, model, None)
        return [given or default for given, default in zip(load_names, defaults)]
    from ..engine import name_of
    constants = {str(c) for c in eom.constants}
    forces = set(model.aux_names)
    inputs = {n.removesuffix("(t)") for n in model.input_names}
    names = []
    memo = {}
    for location, vector in eom.loads:
        kind = "torque on" if hasattr(location, "ang_vel_in") else "force at"
        symbols = set().union(*(_leaves(m, memo) for m, _ in vector.args))
        held = sorted({name_of(s) for s in symbols} & (constants | forces | inputs))
        text = f"{kind} {location.name}" + (f" [{', '.join(held)}]" if held else "")
        names.append(f"constraint {text}" if forces & set(held) else text)
    return [f"{n} ({k + 1})" if names.count(n) > 1 else n for k, n in enumerate(names)]



def _leaves(expr, memo):
    """The symbols and functions (of time) in ``expr``, each shared subexpression's found
    once (``memo``: subexpression -> its leaves, kept across calls).

    Loads built by recurrences (a rotor's Chebyshev series of the inflow) share
    subexpressions so deeply that a walk of the tree, as ``free_symbols`` and
    ``find_dynamicsymbols`` take, visits exponentially many nodes.
    """
    import sympy as sm
    stack = [(expr, False)]
    while stack:
        node, children_done = stack.pop()
        if node in memo:
            continue
        if isinstance(node, (sm.Symbol, sm.core.function.AppliedUndef)):
            memo[node] = frozenset((node,))
        elif children_done:
            memo[node] = frozenset().union(*(memo[a] for a in node.args))
        else:
            stack.append((node, True))
            stack.extend((a, False) for a in node.args if a not in memo)
    return memo[expr]
