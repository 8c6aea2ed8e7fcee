r"""Physical plausibility of bodies: masses and inertias.

A body's mass must be positive and its central inertia matrix symmetric and
positive semidefinite; when all three principal moments are positive they
must satisfy the triangle inequality :math:`I_1 + I_2 \ge I_3` (a solid's
moments do).  Planar shorthand such as ``inertia(A, 0, 0, Izz)``, with a
principal moment of zero, is accepted: only the triangle check is skipped.

Checks run twice: on the numbers written into the model when it is derived
(:func:`check_declared_bodies`), and on the values of the constants when a
numerical model is made (:func:`body_values`).
"""

from __future__ import annotations

import numpy as np

from .._errors import ModelError

__all__ = ["check_declared_bodies", "body_parameters", "body_values", "BodyValues",
           "principal_moments", "inertia_violation"]

_RTOL = 1e-9  # relative tolerance of the symmetry and triangle checks


def _kind(body):
    import sympy.physics.mechanics as me
    return "particle" if isinstance(body, me.Particle) else "rigid body"


def check_declared_bodies(bodies):
    """Refuse bodies listed twice and impossible numbers in masses and inertias.

    Raises
    ------
    ModelError
        Naming the body.
    """
    seen_ids, seen_names = set(), {}
    for body in bodies:
        if id(body) in seen_ids:
            raise ModelError(f"body {body.name!r} is listed twice in bodies")
        seen_ids.add(id(body))
        if body.name in seen_names:
            raise ModelError(f"two bodies are named {body.name!r}; give each body its own "
                             "name (results and reports refer to bodies by name)")
        seen_names[body.name] = body
    for name, kind, mass, inertia in body_parameters(bodies):
        m = _number(mass)
        if m is not None:
            _check_mass(name, kind, m, declared=True)
        if inertia is not None and all(_number(e) is not None for e in inertia):
            _check_inertia(name, np.array([[float(e) for e in row]
                                           for row in inertia.tolist()]))


def body_parameters(bodies):
    """``[(name, kind, mass, central inertia)]`` of the rigid bodies and particles.

    The central inertia is a 3 x 3 ``sympy.Matrix`` in the body's frame
    (``None`` for particles).  Plain SymPy data, so it pickles.
    """
    import sympy as sm
    import sympy.physics.mechanics as me
    out = []
    for body in bodies:
        if not isinstance(body, (me.RigidBody, me.Particle)):
            continue  # flexible bodies: their members' matrices are checked when built
        mass = sm.sympify(body.mass, strict=True)
        inertia = None
        if isinstance(body, me.RigidBody):
            try:
                inertia = _matrix_in(body.central_inertia, body.frame)
            except (ValueError, TypeError):  # inertia point unrelated to the mass centre
                inertia = None
        out.append((body.name, _kind(body), mass, inertia))
    return out


def _matrix_in(dyadic, frame):
    """The 3 x 3 matrix of ``dyadic`` in ``frame``.

    A dyadic written with ``frame``'s own unit vectors (the usual inertia) is
    read term by term; otherwise ``Dyadic.to_matrix`` expresses it (nine
    dot products with frame changes: seconds for long chains).
    """
    import sympy as sm
    entries = [[sm.S.Zero] * 3 for _ in range(3)]
    for coefficient, first, second in dyadic.args:
        parts = first.args + second.args
        if len(first.args) != 1 or len(second.args) != 1 \
                or any(part[1] is not frame for part in parts):
            return sm.Matrix(dyadic.to_matrix(frame))
        a, b = first.args[0][0], second.args[0][0]
        for i in range(3):
            if a[i] != 0:
                for j in range(3):
                    if b[j] != 0:
                        entries[i][j] += coefficient * a[i] * b[j]
    return sm.Matrix(entries)


class BodyValues:
    """Numerical mass and principal moments of one body.

    Attributes
    ----------
    name : str
    kind : {"particle", "rigid body"}
    mass : float or None
        kg; ``None`` when it depends on more than constants.
    moments : ndarray, shape (3,), or None
        Principal central moments of inertia, kg m^2, ascending.
    """

    __slots__ = ("name", "kind", "mass", "moments")

    def __init__(self, name, kind, mass, moments):
        self.name, self.kind, self.mass, self.moments = name, kind, mass, moments

    def __getstate__(self):
        return (self.name, self.kind, self.mass, self.moments)

    def __setstate__(self, state):
        self.name, self.kind, self.mass, self.moments = state

    @property
    def massless(self):
        """True when the body has no mass and no inertia to give the motion."""
        no_mass = self.mass is not None and self.mass == 0.0
        no_inertia = self.moments is None or bool(np.all(self.moments == 0.0))
        return no_mass and no_inertia

    def __repr__(self):
        return f"BodyValues({self.name!r}, mass={self.mass}, moments={self.moments})"


def body_values(parameters, values):
    """Evaluate and check masses and inertias at given constants.

    Parameters
    ----------
    parameters : list
        From :func:`body_parameters`.
    values : dict
        ``{Symbol: float}`` of the constants.

    Returns
    -------
    list of BodyValues

    Raises
    ------
    ModelError
        A negative mass, or an inertia that is not symmetric, is indefinite or
        violates the triangle inequality; the message names the body and the
        constants it depends on.
    """
    out = []
    for name, kind, mass, inertia in parameters:
        m = _number(mass.xreplace(values))
        matrix = None
        if inertia is not None:
            entries = [_number(e) for e in inertia.xreplace(values)]
            if all(e is not None for e in entries):
                matrix = np.array(entries).reshape(3, 3)
        try:
            moments = _checked(name, kind, m, matrix, "")
        except ModelError:  # again, naming the constants the body depends on
            depends = sorted({str(s) for s in _symbols_of(mass, inertia) if s in values})
            shown = ", ".join(f"{s} = {values[_by_name(values, s)]:g}" for s in depends)
            given = f" (with {shown})" if depends else ""
            _checked(name, kind, m, matrix, given)
            raise
        out.append(BodyValues(name, kind, m, moments))
    return out


def _checked(name, kind, mass, matrix, given):
    """Check a body's mass and inertia; its principal moments (or ``None``)."""
    if mass is not None:
        _check_mass(name, kind, mass, given=given)
    return None if matrix is None else _check_inertia(name, matrix, given)


def _by_name(values, name):
    return next(s for s in values if str(s) == name)


def _symbols_of(mass, inertia):
    found = set(mass.free_symbols)
    if inertia is not None:
        found |= inertia.free_symbols
    return found


def _number(expr):
    """The float value of a constant expression, else ``None``."""
    import sympy as sm
    expr = sm.sympify(expr, strict=True)
    if expr.is_Number and expr.is_finite and expr.is_extended_real:
        return float(expr)  # the common case, without evalf
    if expr.free_symbols or expr.has(sm.Function):
        return None
    try:
        value = complex(expr)
    except (TypeError, ValueError):
        return None
    return value.real if value.imag == 0 else None


def _check_mass(name, kind, mass, declared=False, given=""):
    """A mass must be finite and not negative; a particle declared with a mass of
    exactly zero adds nothing but a singular mass matrix."""
    if not np.isfinite(mass):
        raise ModelError(f"{kind} {name!r}: its mass is {mass}{given}; give a finite mass")
    if mass < 0:
        raise ModelError(f"{kind} {name!r} has a negative mass, {mass:g} kg{given}")
    if declared and mass == 0 and kind == "particle":
        raise ModelError(f"particle {name!r} is declared with zero mass: it adds nothing to "
                         "the equations of motion except a speed without inertia; give it "
                         "a mass or leave it out of bodies")


def principal_moments(matrix):
    """Principal moments of a 3 x 3 inertia matrix, ascending, shape (3,), kg m^2.

    The matrix is symmetrized and scaled to a largest entry of 1 before its
    eigenvalues are computed, so that entries near the largest float (1e308) do
    not overflow; a moment beyond that range comes back as ``inf``.
    """
    matrix = np.asarray(matrix, dtype=float)
    scale = float(np.max(np.abs(matrix)))
    if scale == 0.0:
        return np.zeros(3)
    unit = matrix / scale
    with np.errstate(over="ignore"):
        return np.linalg.eigvalsh(0.5 * (unit + unit.T)) * scale


def inertia_violation(moments):
    """By how much principal moments break a solid's rules beyond round-off.

    Parameters
    ----------
    moments : array_like, shape (3,)
        Ascending principal moments (:func:`principal_moments`), kg m^2, finite.

    Returns
    -------
    amount : float
        kg m^2: minus the smallest moment when it is negative, else the amount by
        which ``I3`` exceeds ``I1 + I2`` (checked only when all three are positive:
        planar shorthand such as ``inertia(A, 0, 0, Izz)`` passes); 0.0 when
        neither rule is broken by more than 1e-9 of the largest moment.
    rule : str or None
        ``"not positive semidefinite"``, ``"triangle inequality"`` or None.
    """
    moments = np.asarray(moments, dtype=float)
    scale = float(np.max(np.abs(moments)))
    if moments[0] < -_RTOL * scale:
        return float(-moments[0]), "not positive semidefinite"
    moments = np.where(np.abs(moments) <= _RTOL * scale, 0.0, moments)
    with np.errstate(over="ignore"):  # I1 + I2 may pass 1e308: no violation then
        if moments[0] > 0 and moments[0] + moments[1] < moments[2] * (1 - _RTOL):
            return float(moments[2] - moments[0] - moments[1]), "triangle inequality"
    return 0.0, None


def _check_inertia(name, matrix, given=""):
    """Principal moments of a checked central inertia matrix."""
    scale = max(float(np.max(np.abs(matrix))), 1e-300)
    if not np.all(np.isfinite(matrix)):
        raise ModelError(f"rigid body {name!r}: its inertia has non-finite entries{given}")
    with np.errstate(over="ignore"):
        asymmetry = np.max(np.abs(matrix - matrix.T))
    if asymmetry > _RTOL * scale:
        raise ModelError(f"rigid body {name!r}: its inertia dyadic is not symmetric "
                         f"({np.round(matrix, 6).tolist()}){given}")
    moments = principal_moments(matrix)
    if not np.all(np.isfinite(moments)):
        raise ModelError(f"rigid body {name!r}: its principal moments of inertia are "
                         f"beyond the range of floating point (entries up to {scale:.6g} "
                         f"kg m^2){given}")
    _, rule = inertia_violation(moments)
    if rule == "not positive semidefinite":
        raise ModelError(f"rigid body {name!r}: its central inertia is not positive "
                         f"semidefinite (principal moments {_fmt(moments)} kg m^2){given}")
    if rule is not None:
        raise ModelError(f"rigid body {name!r}: its principal moments of inertia "
                         f"{_fmt(moments)} kg m^2 violate the triangle inequality "
                         f"(I1 + I2 >= I3 for every solid){given}")
    return np.where(np.abs(moments) <= _RTOL * scale, 0.0, moments)


def _fmt(values):
    return "(" + ", ".join(f"{v:.6g}" for v in values) + ")"
