r"""Frequency responses of linearized models, and tuning of a TMD or TMDI.

A linear(ized) model :math:`\dot x = A x + B r`, :math:`z = C x + D r` has
the transfer function

.. math::

    H(\omega) = C\,(i\omega I - A)^{-1} B + D ,

evaluated here on a whole frequency grid at once (one batched
``numpy.linalg.solve`` of :math:`(i\omega_k I - A) X_k = B`).

A tuned mass damper (mass :math:`m_d`, spring :math:`k_d`, damper
:math:`c_d`) on a primary of modal mass :math:`M` and natural frequency
:math:`\omega_p` is described by the mass ratio :math:`\mu = m_d/M`, the
frequency ratio :math:`f = \omega_d/\omega_p` and the damping ratio
:math:`\zeta = c_d/(2 m_e \omega_d)`.  A TMDI adds an inerter of inertance
:math:`b` (inertance ratio :math:`\beta = b/M`); here the damper's frequency
and damping are taken with the effective mass :math:`m_e = m_d + b`
(:math:`\omega_d = \sqrt{k_d/m_e}`), so that a TMDI whose inerter is grounded
is the TMD of mass :math:`m_d + b` with the same :math:`f` and :math:`\zeta`.

Den Hartog's tuning of a TMD on an undamped primary under a force (fixed-point
theory) is :math:`f = 1/(1+\mu)`, :math:`\zeta = \sqrt{3\mu/(8(1+\mu)^3)}`.
:func:`tune_damper` starts there and minimizes, over :math:`(f, \zeta)`, the
H-infinity norm (the peak of :math:`|H|`) or the H2 norm of the response of a
kanedyn model whose damper stiffness, damping, mass and inertance are
constants: each trial sets them with :meth:`NumericModel.with_constants` (no
code generated again) and linearizes again.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.linalg as sla
from scipy.optimize import minimize, minimize_scalar

from .._errors import ModelError, OptionError

__all__ = ["den_hartog", "frequency_response", "model_frequency_response",
           "FrequencyResponse", "response_peaks", "h2_norm", "tune_damper", "DamperTuning",
           "plot_frequency_responses"]

#: relative size of the real part below which a pole counts as undamped
_UNDAMPED = 1e-10
#: largest condition number of the eigenvectors of A with which a grid of
#: :func:`response_peaks` is evaluated in modal form (beyond: one solve per frequency)
_MODAL_CONDITION = 1e8


def den_hartog(mass_ratio):
    r"""Den Hartog's optimal TMD tuning for an undamped primary under a force.

    Parameters
    ----------
    mass_ratio : float
        :math:`\mu = m_d/M` (positive).

    Returns
    -------
    frequency_ratio : float
        :math:`f = \omega_d/\omega_p = 1/(1+\mu)`.
    damping_ratio : float
        :math:`\zeta = \sqrt{3\mu/(8(1+\mu)^3)}`.
    """
    mu = float(mass_ratio)
    if not (mu > 0 and math.isfinite(mu)):
        raise OptionError(f"mass_ratio must be a positive number, got {mass_ratio!r}")
    return 1.0 / (1.0 + mu), math.sqrt(3.0 * mu / (8.0 * (1.0 + mu) ** 3))


def frequency_response(A, B, C, omega, D=None):
    r"""Transfer functions :math:`H(\omega) = C (i\omega I - A)^{-1} B + D`.

    Parameters
    ----------
    A : array_like, shape (n, n)
    B : array_like, shape (n, m)
        Input matrix (one column per input; a 1-D array is one input).
    C : array_like, shape (p, n)
        Output matrix (a 1-D array is one output).
    omega : array_like, shape (k,)
        Circular frequencies, rad/s.
    D : array_like, shape (p, m), optional
        Feedthrough (zero by default).

    Returns
    -------
    H : ndarray of complex, shape (k, p, m)
        Output per unit input (units of the output over those of the input).
    """
    A = np.atleast_2d(np.asarray(A, dtype=float))
    n = A.shape[0]
    if A.shape != (n, n):
        raise OptionError(f"A must be square, got shape {A.shape}")
    B = np.asarray(B, dtype=float)
    B = B.reshape(n, -1) if B.ndim < 2 else B
    C = np.atleast_2d(np.asarray(C, dtype=float))
    if B.shape[0] != n or C.shape[1] != n:
        raise OptionError(f"B has {B.shape[0]} rows and C {C.shape[1]} columns; "
                          f"both must match A's size {n}")
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    lhs = 1j * omega[:, None, None] * np.eye(n) - A
    rhs = np.broadcast_to(B.astype(complex), (omega.size, *B.shape))
    try:
        X = np.linalg.solve(lhs, rhs)
    except np.linalg.LinAlgError:  # a frequency on an undamped pole: infinite there
        X = np.empty(rhs.shape, dtype=complex)
        for k in range(omega.size):
            try:
                X[k] = np.linalg.solve(lhs[k], rhs[k])
            except np.linalg.LinAlgError:
                X[k] = np.inf
    H = C @ X
    if D is not None:
        H = H + np.asarray(D, dtype=float).reshape(C.shape[0], B.shape[1])
    return H


@dataclasses.dataclass(frozen=True)
class FrequencyResponse:
    """A transfer function of a linearized model on a frequency grid.

    Attributes
    ----------
    omega : ndarray, shape (k,)
        Circular frequencies, rad/s.
    response : ndarray of complex, shape (k,) or (k, p)
        Output per unit input (e.g. m/N for a displacement per force); one
        column per output when several were asked for.
    input : str
        Name of the input (a specified input of the model).
    outputs : tuple of str
        Names of the outputs (states, or ``"C"`` for a given output row).
    """

    omega: np.ndarray
    response: np.ndarray
    input: str
    outputs: tuple

    @property
    def magnitude(self):
        """:math:`|H|`, same shape as :attr:`response`."""
        return np.abs(self.response)


def _independent_state_names(model):
    names = list(model.state_names)
    nq, nu = model.n_q, model.n_u
    return names[:nq - model.n_q_dep] + names[nq:nq + nu - model.n_u_dep]


def _output_rows(model, output):
    """``(C, names)`` of an output: a state name, a list of them, or a C row."""
    states = _independent_state_names(model)
    if isinstance(output, str):
        output = [output]
    if all(isinstance(o, str) for o in output):
        rows = []
        for name in output:
            if name not in states:
                raise OptionError(f"output {name!r} is not an independent state of the "
                                  f"model; its states are {', '.join(states)}")
            row = np.zeros(len(states))
            row[states.index(name)] = 1.0
            rows.append(row)
        return np.array(rows), tuple(output)
    C = np.atleast_2d(np.asarray(output, dtype=float))
    if C.shape[1] != len(states):
        raise OptionError(f"an output row must have {len(states)} entries "
                          f"({', '.join(states)}), got {C.shape[1]}")
    return C, ("C",) * C.shape[0]


def _input_column(B, names, input):
    stripped = [n.removesuffix("(t)") for n in names]
    key = input.removesuffix("(t)") if isinstance(input, str) else input
    if key not in stripped:
        raise OptionError(f"input {input!r} is not a specified input of the model; "
                          f"its inputs are {', '.join(stripped) or 'none'}")
    return B[:, stripped.index(key)]


def _linear_system(model, y, t, input, output):
    A, B, names = model.linearize(y, t=t)
    b = _input_column(B, names, input)
    C, out_names = _output_rows(model, output)
    return A, b, C, out_names


def model_frequency_response(model, y, omega, input, output, t=0.0):
    r"""Frequency response of a :class:`NumericModel` linearized about ``y``.

    Parameters
    ----------
    model : NumericModel
    y : array_like, shape (n_q + n_u,)
        Operating point ``[q, u]`` (SI units).
    omega : array_like, shape (k,)
        Circular frequencies, rad/s.
    input : str
        Name of the specified input the excitation enters by (e.g. a force
        ``F(t)``, given as ``"F"`` or ``"F(t)"``).
    output : str, sequence of str, or array_like
        An independent state's name, several, or rows ``C`` over the
        independent states ``[q_ind; u_ind]`` (shape (p, n)).
    t : float
        Time of the operating point, s.

    Returns
    -------
    FrequencyResponse
    """
    A, b, C, names = _linear_system(model, y, t, input, output)
    H = frequency_response(A, b, C, omega)[:, :, 0]
    if isinstance(output, str):
        H = H[:, 0]
    return FrequencyResponse(np.atleast_1d(np.asarray(omega, dtype=float)), H,
                             str(input).removesuffix("(t)"), names)


def _magnitude(A, b, c, w):
    return abs(frequency_response(A, b, c, [w])[0, 0, 0])


def _grid_magnitudes(A, b, c, omega, eigen):
    r""":math:`|H(\omega)|` on the grid ``omega`` (one input ``b``, one output ``c``).

    With ``eigen = (lam, V)`` of ``A`` well conditioned (:data:`_MODAL_CONDITION`),
    in modal form, :math:`H = \sum_j (cV)_j (V^{-1}b)_j / (i\omega - \lambda_j)`:
    one factorization for the whole grid instead of one complex solve per
    frequency (relative error about the condition number times the rounding);
    otherwise (a defective or nearly defective ``A``) by :func:`frequency_response`."""
    lam, V = eigen
    if np.linalg.cond(V) <= _MODAL_CONDITION:
        left = (c @ V)[0]
        right = np.linalg.solve(V, b.astype(complex))[:, 0]
        return np.abs((1.0 / (1j * omega[:, None] - lam[None, :])) @ (left * right))
    return np.abs(frequency_response(A, b, c, omega)[:, 0, 0])


def response_peaks(A, B, C, omega):
    r"""Local maxima of :math:`|H(\omega)|` (one input, one output), refined.

    The grid's local maxima are refined by a bounded scalar search between
    their neighbours; an undamped, observable and controllable pole in the
    grid's range gives an infinite peak.  The grid is evaluated in modal form
    where ``A``'s eigenvectors are well conditioned (:func:`_grid_magnitudes`);
    each value reported comes from its own solve.

    Parameters
    ----------
    A : array_like, shape (n, n)
    B : array_like, shape (n,)
    C : array_like, shape (n,)
    omega : array_like, shape (k,)
        Increasing grid of circular frequencies, rad/s; peaks at its ends are
        reported at the end.

    Returns
    -------
    peaks : ndarray, shape (j, 2)
        ``[omega, |H|]`` of each local maximum, largest first; only the
        infinite ones when there are any.
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(B, dtype=float).reshape(-1, 1)
    c = np.asarray(C, dtype=float).reshape(1, -1)
    omega = np.asarray(omega, dtype=float)
    peaks = []
    eigen = np.linalg.eig(A)
    for lam in eigen[0]:
        w0 = lam.imag
        if w0 > 0 and abs(lam.real) <= _UNDAMPED * abs(lam) and omega[0] <= w0 <= omega[-1]:
            near = _magnitude(A, b, c, w0 * (1 + 1e-9))
            far = _magnitude(A, b, c, w0 * (1 + 1e-5))
            if near > 1e3 * far:  # grows as 1/distance: unbounded
                peaks.append((w0, np.inf))
    if peaks:
        return np.array(peaks, dtype=float)
    mag = _grid_magnitudes(A, b, c, omega, eigen)
    inner = np.flatnonzero((mag[1:-1] >= mag[:-2]) & (mag[1:-1] > mag[2:])) + 1
    for i in inner:  # the values reported: each from its own solve
        res = minimize_scalar(lambda w: -_magnitude(A, b, c, w), method="bounded",
                              bounds=(omega[i - 1], omega[i + 1]),
                              options={"xatol": 1e-12 * omega[i]})
        at = _magnitude(A, b, c, omega[i])
        peaks.append((res.x, -res.fun) if -res.fun >= at else (omega[i], at))
    for i in (0, -1):
        if mag[i] >= mag[1 if i == 0 else -2]:
            peaks.append((omega[i], _magnitude(A, b, c, omega[i])))
    out = np.array(peaks, dtype=float).reshape(-1, 2)
    return out[np.argsort(-out[:, 1], kind="stable")]


def h2_norm(A, B, C):
    r"""H2 norm :math:`\sqrt{\tfrac1{2\pi}\int_{-\infty}^{\infty}|H|^2 d\omega}`.

    From the Lyapunov equation :math:`A P + P A^T + B B^T = 0`,
    :math:`\|H\|_2^2 = C P C^T`: the variance of the output under a white
    noise input of unit two-sided spectral density (per rad/s, times
    :math:`2\pi`).  ``inf`` when ``A`` is not asymptotically stable.

    Parameters
    ----------
    A : array_like, shape (n, n)
    B : array_like, shape (n,)
    C : array_like, shape (n,)

    Returns
    -------
    float
    """
    A = np.asarray(A, dtype=float)
    if np.max(np.linalg.eigvals(A).real) >= 0:
        return math.inf
    b = np.asarray(B, dtype=float).reshape(-1, 1)
    c = np.asarray(C, dtype=float).reshape(1, -1)
    P = sla.solve_continuous_lyapunov(A, -b @ b.T)
    return float(np.sqrt(max((c @ P @ c.T)[0, 0], 0.0)))


@dataclasses.dataclass(frozen=True)
class DamperTuning:
    """The result of :func:`tune_damper`.

    Attributes
    ----------
    frequency_ratio, damping_ratio : float
        The optimum :math:`f` and :math:`\\zeta`.
    constants : dict
        ``{name: value}`` of the damper's constants at the optimum (mass kg,
        stiffness N/m, damping N s/m, inertance kg).
    criterion : str
        ``"hinf"`` or ``"h2"``.
    peak : float
        Peak of :math:`|H|` at the optimum (output unit per input unit).
    h2 : float
        H2 norm at the optimum (see :func:`h2_norm`).
    start : tuple of float
        The starting :math:`(f, \\zeta)` (Den Hartog's for :math:`\\mu + \\beta` by
        default).
    peak_start, h2_start : float
        Peak and H2 norm at the start.
    peak_without : float
        Peak without the damper (its stiffness, damping and inertance zero,
        so the damper mass is disconnected); ``inf`` for an undamped primary.
    peak_reduction : float
        ``1 - peak / peak_without`` (1 when the primary alone is unbounded).
    peak_reduction_start : float
        ``1 - peak / peak_start``: what the optimization gains over the start.
    iterations, evaluations : int
    success : bool
    message : str
    model : NumericModel
        The model with the optimal constants.
    """

    frequency_ratio: float
    damping_ratio: float
    constants: dict
    criterion: str
    peak: float
    h2: float
    start: tuple
    peak_start: float
    h2_start: float
    peak_without: float
    peak_reduction: float
    peak_reduction_start: float
    iterations: int
    evaluations: int
    success: bool
    message: str
    model: object = dataclasses.field(repr=False, compare=False)


def _constant_name(model, value, what):
    name = str(value)
    if name not in model.constants:
        raise OptionError(f"{what} {name!r} is not a constant of the model; its constants "
                          f"are {', '.join(model.constants)}")
    return name


def tune_damper(model, y, *, input, output, primary_frequency, primary_mass, mass_ratio,
                damper_mass, stiffness, damping, inertance=None, inertance_ratio=0.0,
                criterion="hinf", start=None, omega=None, t=0.0, tol=1e-9,
                max_iterations=1000):
    r"""Optimal frequency and damping ratios of a TMD or TMDI in a kanedyn model.

    For given mass and inertance ratios, minimizes over :math:`(f, \zeta)` the
    peak (``criterion="hinf"``) or the H2 norm (``"h2"``, the RMS response to
    white noise) of the transfer function from ``input`` to ``output`` of the
    model linearized about ``y``; Nelder-Mead (``scipy.optimize.minimize``)
    from Den Hartog's tuning for the mass ratio :math:`\mu + \beta`.  Each
    trial sets :math:`m_d = \mu M`, :math:`b = \beta M`,
    :math:`k_d = m_e (f\omega_p)^2`, :math:`c_d = 2\zeta m_e f\omega_p` with
    :math:`m_e = m_d + b`.

    Parameters
    ----------
    model : NumericModel
        A model whose damper mass, stiffness, damping (and inertance) are
        constants.
    y : array_like, shape (n_q + n_u,)
        Operating point (the linearization point; for a linear model any
        consistent state).
    input : str
        The specified input of the excitation (e.g. a force ``"F"``).
    output : str or array_like
        An independent state's name, or a row over the independent states.
    primary_frequency : float
        :math:`\omega_p`, rad/s (the mode the damper is tuned to).
    primary_mass : float
        :math:`M`, kg (the primary's modal mass).
    mass_ratio : float
        :math:`\mu = m_d/M`.
    damper_mass, stiffness, damping : str or sympy.Symbol
        The model's constants :math:`m_d` (kg), :math:`k_d` (N/m),
        :math:`c_d` (N s/m).
    inertance : str or sympy.Symbol, optional
        The model's constant :math:`b` (kg), for a TMDI.
    inertance_ratio : float
        :math:`\beta = b/M` (needs ``inertance``).
    criterion : {"hinf", "h2"}
    start : tuple of float, optional
        Starting :math:`(f, \zeta)`.
    omega : array_like, optional
        Increasing frequency grid for the peaks, rad/s; by default 4001
        points from :math:`0.2\,\omega_p` to :math:`5\,\omega_p` (geometric).
    t : float
        Time of the operating point, s.
    tol : float
        Tolerance on :math:`f`, :math:`\zeta` and the relative objective.
    max_iterations : int

    Returns
    -------
    DamperTuning
    """
    if criterion not in ("hinf", "h2"):
        raise OptionError(f"criterion must be 'hinf' or 'h2', got {criterion!r}")
    names = {"damper_mass": _constant_name(model, damper_mass, "damper_mass"),
             "stiffness": _constant_name(model, stiffness, "stiffness"),
             "damping": _constant_name(model, damping, "damping")}
    if inertance is not None:
        names["inertance"] = _constant_name(model, inertance, "inertance")
    elif inertance_ratio:
        raise OptionError("inertance_ratio is given but no inertance constant "
                          "(inertance=...) to set")
    for label, value in (("primary_frequency", primary_frequency),
                         ("primary_mass", primary_mass), ("mass_ratio", mass_ratio)):
        if not (float(value) > 0 and math.isfinite(float(value))):
            raise OptionError(f"{label} must be a positive number, got {value!r}")
    if not (float(inertance_ratio) >= 0 and math.isfinite(float(inertance_ratio))):
        raise OptionError(f"inertance_ratio must be non-negative, got {inertance_ratio!r}")
    wp, M = float(primary_frequency), float(primary_mass)
    md, b = float(mass_ratio) * M, float(inertance_ratio) * M
    me = md + b
    if omega is None:
        omega = wp * np.geomspace(0.2, 5.0, 4001)
    omega = np.asarray(omega, dtype=float)
    if omega.ndim != 1 or omega.size < 3 or np.any(np.diff(omega) <= 0):
        raise OptionError("omega must be an increasing grid of at least 3 frequencies")
    fixed = {names["damper_mass"]: md}
    if "inertance" in names:
        fixed[names["inertance"]] = b
    C, _ = _output_rows(model, output)
    if C.shape[0] != 1:
        raise OptionError("tune_damper needs one output (a state name or one row)")

    def constants(f, zeta):
        wd = f * wp
        return dict(fixed, **{names["stiffness"]: me * wd ** 2,
                              names["damping"]: 2.0 * zeta * me * wd})

    # each trial is a copy of the last one: a copy shares the derivative code
    # its model generated (copies of ``model`` itself would each generate it
    # again, 0.4 s a trial); every trial sets the same constants, so the copy
    # is the same whichever model it is made from
    last = [model]

    def system(values):
        m = last[0].with_constants(values)
        A, B, rnames = m.linearize(y, t=t)
        last[0] = m
        return m, A, _input_column(B, rnames, input)

    def measures(values):
        m, A, bcol = system(values)
        return m, response_peaks(A, bcol, C[0], omega)[0, 1], h2_norm(A, bcol, C[0])

    if start is None:
        start = den_hartog(float(mass_ratio) + float(inertance_ratio))
    start = (float(start[0]), float(start[1]))
    _, peak_start, h2_start = measures(constants(*start))
    scale = peak_start if criterion == "hinf" else h2_start
    if not (math.isfinite(scale) and scale > 0):
        raise ModelError(f"the response at the start {start} is unbounded "
                         f"(peak {peak_start}, H2 {h2_start}); give another start")

    def objective(p):
        f, zeta = p
        if f <= 0 or zeta <= 0:
            return math.inf
        m, A, bcol = system(constants(f, zeta))
        if criterion == "hinf":
            value = response_peaks(A, bcol, C[0], omega)[0, 1]
        else:
            value = h2_norm(A, bcol, C[0])
        return value / scale

    f0, z0 = start
    simplex = np.array([[f0, z0], [1.03 * f0, z0], [f0, 1.15 * z0]])
    res = minimize(objective, np.array(start), method="Nelder-Mead",
                   options={"xatol": tol, "fatol": tol, "maxiter": int(max_iterations),
                            "initial_simplex": simplex})
    f, zeta = (float(v) for v in res.x)
    best = constants(f, zeta)
    tuned, peak, h2 = measures(best)
    without = dict(fixed, **{names["stiffness"]: 0.0, names["damping"]: 0.0})
    if "inertance" in names:
        without[names["inertance"]] = 0.0
    m0, A0, b0 = system(without)
    peak_without = response_peaks(A0, b0, C[0], omega)[0, 1]
    return DamperTuning(
        frequency_ratio=f, damping_ratio=zeta, constants=best, criterion=criterion,
        peak=float(peak), h2=float(h2), start=start, peak_start=float(peak_start),
        h2_start=float(h2_start), peak_without=float(peak_without),
        peak_reduction=float(1.0 - peak / peak_without),
        peak_reduction_start=float(1.0 - peak / peak_start),
        iterations=int(res.nit), evaluations=int(res.nfev), success=bool(res.success),
        message=str(res.message), model=tuned)


def plot_frequency_responses(responses, labels, ax=None, title=None, unit="m/N",
                             frequency_unit="Hz", legend="best"):
    """Magnitudes of several frequency responses on log axes, in one panel.

    Parameters
    ----------
    responses : sequence of FrequencyResponse
        One output each.
    labels : sequence of str
        Legend text of each curve.
    ax : matplotlib.axes.Axes, optional
    title : str, optional
    unit : str
        Unit of the response (output per input), for the axis label.
    frequency_unit : {"Hz", "rad/s"}
    legend : str
        Matplotlib's legend location.

    Returns
    -------
    matplotlib.axes.Axes
    """
    from ._plotting import pyplot
    if len(responses) != len(labels):
        raise OptionError(f"{len(responses)} responses but {len(labels)} labels")
    if frequency_unit not in ("Hz", "rad/s"):
        raise OptionError(f"frequency_unit must be 'Hz' or 'rad/s', got {frequency_unit!r}")
    if ax is None:
        ax = pyplot().subplots(figsize=(7, 4.2))[1]
    for resp, label in zip(responses, labels):
        w = resp.omega / (2 * np.pi) if frequency_unit == "Hz" else resp.omega
        ax.loglog(w, np.abs(np.reshape(resp.response, (w.size, -1))[:, 0]), label=label)
    from matplotlib.ticker import ScalarFormatter
    for axis in (ax.xaxis.set_major_formatter, ax.xaxis.set_minor_formatter):
        axis(ScalarFormatter())  # 2, 3, 4 Hz rather than powers of ten
    ax.set_xlabel(f"frequency ({frequency_unit})")
    ax.set_ylabel(f"|H| ({unit})")
    if title:
        ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc=legend)
    return ax
