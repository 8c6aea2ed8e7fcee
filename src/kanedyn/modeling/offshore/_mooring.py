r"""Mooring systems: the linearized 6x6 matrix, and quasi-static catenary lines.

``LinearMooring``    a 6x6 stiffness about the undisplaced position plus the
                     mean (pretension) load; ``LinearMooring.oc3(...)`` with the
                     OC3-Hywind figures
``CatenaryMooring``  several :class:`CatenaryLine` s; the fairlead forces are
                     specified inputs computed at runtime from the state
``state_function``   numeric function of ``(t, y)`` from expressions in the
                     coordinates and speeds (used by the rotor, too)
"""

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from ..._errors import ModelError
from .._springs import MatrixSpringDamper
from ._catenary import CatenaryLine

__all__ = ["LinearMooring", "CatenaryMooring", "state_function", "OC3_MOORING"]

#: OC3-Hywind mooring figures (Jonkman, NREL/TP-500-47535, 2010, as in the
#: project's data sheet ``oc3_hywind.md``).  Stiffness about the undisplaced
#: position, reference point on the spar axis at the still water line; yaw
#: includes the delta connection's additional 98,340,000 N m/rad.
OC3_MOORING = {
    "K11": 41_180.0, "K33": 11_940.0, "K44": 311_100_000.0,
    "K66": 11_560_000.0 + 98_340_000.0, "K15": -2_821_000.0, "K51": -2_816_000.0,
    "anchor_radius": 853.87, "anchor_depth": 320.0, "fairlead_radius": 5.2,
    "fairlead_depth": 70.0, "length": 902.2, "diameter": 0.09,
    "mass_per_length": 77.7066, "weight_in_water": 698.094, "EA": 384.243e6,
}


def oc3_stiffness():
    """The OC3-Hywind 6x6 mooring stiffness (N/m, N/rad, N m/rad), a numpy array."""
    d = OC3_MOORING
    K = np.diag([d["K11"], d["K11"], d["K33"], d["K44"], d["K44"], d["K66"]])
    K[0, 4], K[1, 3] = d["K15"], -d["K15"]
    K[4, 0], K[3, 1] = d["K51"], -d["K51"]
    return K


class LinearMooring(MatrixSpringDamper):
    r"""A 6x6 mooring stiffness about the undisplaced position and the mean load.

    Loads: :math:`[F, M] = F_0 - K x` (:class:`MatrixSpringDamper` with no
    damping, plus a constant :math:`F_0`), where :math:`F_0` is the mooring
    load at the undisplaced position; for a symmetric spread mooring it is the
    downward vertical load :math:`-V_0\,e_z` at the reference point.

    Parameters
    ----------
    name, body_frame, point, frame, reference
        As :class:`MatrixSpringDamper`.
    K : 6x6 array_like
        Stiffness, N/m, N/rad, N m/m, N m/rad blocks.
    vertical_load : float or sympy.Expr
        :math:`V_0`, the total downward vertical mooring load at the
        undisplaced position, N (the lines' pretension's vertical part).
    """

    def __init__(self, name, body_frame, point, frame, K, vertical_load, reference):
        super().__init__(name, body_frame, point, frame, K, np.zeros((6, 6)), reference)
        if isinstance(vertical_load, (int, float)):
            vertical_load = sm.Float(vertical_load)
        elif not isinstance(vertical_load, sm.Basic):
            raise ModelError(f"LinearMooring {name!r}: vertical_load must be a number or "
                             f"SymPy expression, got {type(vertical_load).__name__}")
        self.vertical_load = vertical_load

    @classmethod
    def oc3(cls, body_frame, point, frame, reference, name="oc3_mooring",
            vertical_load=None):
        """The OC3-Hywind matrix (:data:`OC3_MOORING`) about ``point`` at the SWL.

        ``vertical_load`` defaults to the three OC3 lines' quasi-static
        vertical load at the undisplaced position, solved by
        :func:`solve_catenary` (1.607 MN).
        """
        if vertical_load is None:
            from ._catenary import solve_catenary
            d = OC3_MOORING
            _, V = solve_catenary(d["anchor_radius"] - d["fairlead_radius"],
                                  d["anchor_depth"] - d["fairlead_depth"], d["length"],
                                  d["weight_in_water"], d["EA"], name="OC3 line")
            vertical_load = 3 * V
        return cls(name, body_frame, point, frame, oc3_stiffness(), vertical_load,
                   reference)

    def to_loads(self):
        loads = super().to_loads()
        return [(loads[0][0], loads[0][1] - self.vertical_load * self.frame.z), loads[1]]


def _state_symbols(states):
    if hasattr(states, "q") and hasattr(states, "u"):
        states = [*states.q, *states.u]
    states = list(states)
    for s in states:
        if not isinstance(s, sm.Basic):
            raise ModelError(f"states must be SymPy dynamic symbols, got {s!r}")
    return states


def state_function(exprs, states, constants=None, what="expression"):
    """Numeric ``f(y) -> ndarray`` of SymPy ``exprs`` in the coordinates and speeds.

    Parameters
    ----------
    exprs : sequence of sympy.Expr
    states : EquationsOfMotion or sequence of sympy dynamic symbols
        The state vector's symbols in the order of ``y`` (``[*eom.q, *eom.u]``).
    constants : dict, optional
        ``{symbol: number}`` for the constants in ``exprs``.
    what : str
        Named in errors.
    """
    states = _state_symbols(states)
    constants = dict(constants or {})
    dummies = [sm.Dummy(str(s)) for s in states]
    mapping = dict(zip(states, dummies))
    exprs = [sm.sympify(e, strict=True).xreplace(constants).xreplace(mapping) for e in exprs]
    derivatives = set().union(*(e.atoms(sm.Derivative) for e in exprs))
    if derivatives:
        raise ModelError(f"{what}: contains {sorted(map(str, derivatives))}, not states; "
                         "write the kinematics in terms of the speeds")
    left = set().union(*(e.free_symbols for e in exprs)) - set(dummies)
    functions = set().union(*(e.atoms(sm.core.function.AppliedUndef) for e in exprs))
    if left or functions:
        names = sorted(map(str, left | functions))
        raise ModelError(f"{what}: no value for {', '.join(names)}; give the states in "
                         "order and constants={symbol: number}")
    # common subexpressions once (the kinematics of a rotor's blades share most of theirs:
    # 15 times faster for the flexible blades' BEM)
    func = sm.lambdify(dummies, exprs, modules="numpy", cse=True)

    def evaluate(y):
        return np.array(func(*np.asarray(y, dtype=float)), dtype=float)
    return evaluate


class CatenaryMooring:
    r"""Quasi-static catenary lines acting on their fairleads.

    Each line's force on its fairlead, :math:`(H e_h, -V)` with :math:`e_h`
    the horizontal unit vector toward the anchor, enters the equations of
    motion as three specified inputs ``F{name}_x(t)``, ``_y``, ``_z``
    (``frame`` components, N) applied at the fairlead (:meth:`to_loads`);
    :meth:`specified` returns their values as callables of ``(t, y)`` that
    solve the catenaries at the fairlead positions of the state ``y``.

    Parameters
    ----------
    name : str
    lines : sequence of CatenaryLine
    frame : sympy.physics.mechanics.ReferenceFrame
        The inertial frame (z up) of the anchors.
    origin : sympy.physics.mechanics.Point
        The point fixed in ``frame`` the anchor coordinates are measured from.

    Examples
    --------
    >>> loads = mooring.to_loads()                                # doctest: +SKIP
    >>> eom = kd.kane(..., loads=[*other_loads, *loads])          # doctest: +SKIP
    >>> model = eom.numeric(constants, specified=mooring.specified(eom))  # doctest: +SKIP
    """

    def __init__(self, name, lines, frame, origin):
        if not isinstance(name, str) or not name:
            raise ModelError(f"CatenaryMooring needs a non-empty name, got {name!r}")
        self.name = name
        lines = list(lines)
        if not lines or not all(isinstance(ln, CatenaryLine) for ln in lines):
            raise ModelError(f"CatenaryMooring {name!r}: lines must be a non-empty sequence "
                             "of CatenaryLine")
        if not isinstance(frame, me.ReferenceFrame) or not isinstance(origin, me.Point):
            raise ModelError(f"CatenaryMooring {name!r}: frame must be a ReferenceFrame and "
                             "origin a Point")
        for i, line in enumerate(lines, 1):
            if line.name is None:
                line.name = f"{name}_line{i}"
        self.lines, self.frame, self.origin = lines, frame, origin
        t = me.dynamicsymbols._t
        self.symbols = [tuple(sm.Function(f"F{line.name}_{c}")(t) for c in "xyz")
                        for line in lines]

    def fairlead_positions(self):
        """Fairlead coordinates in ``frame`` from ``origin`` (n_lines x 3 expressions)."""
        e = (self.frame.x, self.frame.y, self.frame.z)
        return [[line.fairlead.pos_from(self.origin).dot(ei) for ei in e]
                for line in self.lines]

    def forces(self, positions):
        """Forces on the fairleads (n_lines x 3, N) at fairlead ``positions`` (m)."""
        positions = np.asarray(positions, dtype=float).reshape(len(self.lines), 3)
        return np.array([line.force(p) for line, p in zip(self.lines, positions)])

    def wrench(self, positions, about=(0.0, 0.0, 0.0)):
        """Total force (N) and moment about ``about`` (N m) at fairlead ``positions``."""
        positions = np.asarray(positions, dtype=float).reshape(len(self.lines), 3)
        f = self.forces(positions)
        moment = np.cross(positions - np.asarray(about, dtype=float), f).sum(axis=0)
        return np.concatenate([f.sum(axis=0), moment])

    def to_loads(self):
        """``[(fairlead_i, F_i)]`` with ``F_i`` made of the input symbols."""
        e = (self.frame.x, self.frame.y, self.frame.z)
        return [(line.fairlead, sum((s * ei for s, ei in zip(syms, e)), me.Vector(0)))
                for line, syms in zip(self.lines, self.symbols)]

    def specified(self, states, constants=None):
        """``{input symbol: callable(t, y)}`` for ``eom.numeric(specified=...)``.

        Parameters
        ----------
        states : EquationsOfMotion or sequence of dynamic symbols
            The order of ``y`` (``[*eom.q, *eom.u]``).
        constants : dict, optional
            Values of constants in the fairlead positions.
        """
        positions = state_function([c for p in self.fairlead_positions() for c in p],
                                   states, constants, f"CatenaryMooring {self.name!r}")
        cache = {"key": None, "forces": None}

        def all_forces(t, y):
            y = np.asarray(y, dtype=float)
            key = y.tobytes()
            if cache["key"] != key:
                cache["forces"] = self.forces(positions(y))
                cache["key"] = key
            return cache["forces"]

        out = {}
        for i, syms in enumerate(self.symbols):
            for j, s in enumerate(syms):
                out[s] = _Component(all_forces, i, j)
        return out

    def __repr__(self):
        return f"CatenaryMooring({self.name!r}, {len(self.lines)} lines)"


class _Component:
    """One entry of a shared function's array: callable ``(t, y) -> float``."""

    def __init__(self, function, i, j):
        self.function, self.i, self.j = function, i, j

    def __call__(self, t, y):
        return float(self.function(t, y)[self.i, self.j])

    @property
    def input_source(self):
        """The shared function: a model reads its entries with one call of it."""
        return self.function

    @property
    def input_index(self):
        """This entry's index in :attr:`input_source`'s array."""
        return (self.i, self.j)
