r"""Studies of the ``oc3-spar`` model: free decay, RAOs, an irregular sea, TMD/TMDI tuning.

Outputs (all linear in the state, small motions): ``surge`` (m), ``pitch``
(rad), the tower-top fore-aft *deflection* relative to the platform,
:math:`\delta = \sum_k \phi_{x,k}\,\eta_k` (m, from the kept tower modes),
the tower-top fore-aft *displacement* :math:`x + z_{top}\theta + \delta`
(m, :math:`z_{top}` = 87.6 m above the SWL), and the tower-base fore-aft
bending moment :math:`M = \sum_k c_k\eta_k` (N m), the elastic moment of the
finite-element stiffness at the clamped base node per unit modal coordinate.
The deflection is what a damper in the nacelle acts on; the displacement is
what the platform's slow surge and pitch dominate.

Every study takes ``tower_damping`` and ``tower_damping_reference`` (the
model's options: the published 1 % of critical of the isolated tower by
default, see :func:`kanedyn.models.oc3_spar`); ``tower_damping=0`` gives the
undamped tower of the studies before issue 36.

The linear models come from ``model.linearize`` at the static equilibrium
(:func:`kanedyn.models.oc3_settle`).  The wave input of the linear model is the
phasor of the Morison strips' fluid velocities and accelerations for a wave of
unit amplitude (the same :class:`~kanedyn.offshore.MorisonCylinder` strips, rebuilt
with an :class:`~kanedyn.offshore.AiryWave`); quadratic drag has no linear part at rest,
so the linear RAO carries no drag damping.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import re
import sys

import numpy as np

from .._errors import KanedynError
from .._output_files import save_figure
from ._studies import StudyOption, register_study

__all__ = ["oc3_linear_system", "oc3_outputs", "wave_input_phasor", "linear_rao",
           "decay_analysis", "simulated_rao", "tuned_damper_options", "sea_runs",
           "SEA_INPUT_STEP"]

_TOP_Z = 87.6  # tower top above the SWL, m
_WATER_DEPTH = 320.0  # OC3 water depth, m (only the fluid kinematics use it)


def _damping_options():
    """The tower-damping options every oc3 study takes (the model's defaults)."""
    return {
        "tower_damping": StudyOption(float, 0.01, "structural damping ratio of the tower "
                                     "modes, fraction of critical (0.01: the published "
                                     "1 %; 0: undamped tower)"),
        "tower_damping_reference": StudyOption(str, "isolated", "what tower_damping is a "
                                               "ratio of: the modes of the tower without "
                                               "the RNA (published, OpenFAST's) or with it",
                                               ("isolated", "with_rna")),
    }


def _say(quiet, text):
    if not quiet:
        print(text, file=sys.stderr, flush=True)


# ------------------------------------------------------------------ models
@functools.lru_cache(maxsize=16)
def _built(backend, options):
    """``(definition, eom, numeric model)`` of ``oc3_spar(**dict(options))``."""
    from ..models import oc3_spar
    d = oc3_spar(**dict(options))
    eom = d.derive()
    needed = {str(x) for x in eom.specified}
    # inputs the equations do not contain (the strips' velocities without drag) are left out
    inputs = {k: v for k, v in d.specified.items() if str(k) in needed}
    model = eom.numeric(constants=dict(d.constants), specified=inputs, backend=backend)
    return d, eom, model


@functools.lru_cache(maxsize=16)
def _settled(backend, options):
    """The still-water equilibrium state of ``_built(backend, options)``."""
    from ..models import oc3_settle
    d, _, model = _built(backend, options)
    return oc3_settle(d, model)


#: the options of a still sea, and their defaults in ``oc3_spar``
_STILL = dict(sea="still", wave_height=0.0, turbulence=0.0)


def _model(backend="c", **options):
    """``(definition, eom, numeric model, equilibrium state)``, cached by options.

    The equilibrium is found in still water (a model with waves settles at
    its still-water twin's state, which is built for it; a model in still
    water at its own).
    """
    key = tuple(sorted(options.items()))
    d, eom, model = _built(backend, key)
    if all(options.get(name, value) == value for name, value in _STILL.items()):
        return d, eom, model, _settled(backend, key)
    if options.get("turbulence", 0.0) == 0.0 and options.get("drag", True):
        return d, eom, model, _settled_at_rest(backend, key)
    return d, eom, model, _settled(backend, tuple(sorted({**options, **_STILL}.items())))


@functools.lru_cache(maxsize=16)
def _settled_at_rest(backend, options):
    """The still-water equilibrium of ``_built(backend, options)``, a model in waves with
    Morison drag and a steady wind: its equations are those of its still-water twin (the
    same loads; the sea enters through the strips' fluid kinematics, inputs), so it
    settles with those inputs at rest, the twin's (zero without a current), and finds
    the twin's state to the bit without building the twin (3 to 5 s of CPU each)."""
    from ..models import oc3_settle
    d, eom, model = _built(backend, options)
    morison = d.symbols["elements"]["morison"]
    if morison.current is not None or morison._wet:
        return _settled(backend, tuple(sorted({**dict(options), **_STILL}.items())))
    needed = {str(x) for x in eom.specified}
    return oc3_settle(d, model.with_inputs({k: 0.0 for k in morison.specified()
                                            if str(k) in needed}))


def _name(q):
    from ..engine import name_of
    return name_of(q)


def oc3_outputs(definition, model):
    """Output rows ``{name: c}`` with ``output = c @ y`` (shape (n_states,)) and their units.

    Returns
    -------
    dict
        ``{name: (row, unit, label)}`` for ``surge``, ``pitch``, ``top_deflection``,
        ``top_displacement`` and (flexible tower) ``base_moment``.
    """
    n = model.n_states
    names = list(model.state_names)

    def row(entries):
        c = np.zeros(n)
        for key, value in entries.items():
            c[names.index(key)] += value
        return c

    out = {"surge": (row({"surge": 1.0}), "m", "surge"),
           "pitch": (row({"pitch": 1.0}), "rad", "pitch")}
    tower = definition.symbols["tower"]
    deflection = {}
    if hasattr(tower, "member"):
        member = tower.member
        phi_top = member.node_modes(member.n_nodes - 1)[0][0]
        K = member.stiffness_matrix
        k0 = 6 * member.reference_node + 4          # rotation about body y at the base
        base = np.asarray(K[k0:k0 + 1] @ member.modes).ravel()
        sign = 1.0 if base @ phi_top >= 0 else -1.0
        deflection = {_name(q): float(p) for q, p in zip(tower.q, phi_top)}
        out["base_moment"] = (row({_name(q): sign * float(c) for q, c in zip(tower.q, base)}),
                              "N m", "tower-base fore-aft bending moment")
    out["top_deflection"] = (row(deflection), "m", "tower-top fore-aft deflection")
    out["top_displacement"] = (row({"surge": 1.0, "pitch": _TOP_Z, **deflection}), "m",
                               "tower-top fore-aft displacement")
    return out


def oc3_linear_system(model, y_eq):
    """``(A, B, input names)`` of ``model`` linearized at ``y_eq`` (all states independent)."""
    A, B, r = model.linearize(y_eq)
    return np.asarray(A), np.asarray(B), list(r)


@functools.lru_cache(maxsize=16)
def _linear_cached(backend, key):
    options = dict(key)
    lin = dict(options, drag=False, sea="regular", wave_height=1.0, wave_period=10.0,
               turbulence=0.0)
    # the twin is linearized at the state of ``options``: built, not settled (settling it
    # built its own still-water twin, a third model, for a state never used); on the
    # NumPy backend whatever the study's: it is linearized once, and a C twin cost more
    # CPU (its module and its derivatives' module, for gcc) for the same matrices (to
    # 1e-15, measured on the default oc3-decay options)
    d, _, model = _built("numpy", tuple(sorted(lin.items())))
    _, _, _, y_eq = _model(backend, **options)
    A, B, r = oc3_linear_system(model, y_eq)
    return d, model, y_eq, A, B, r


def _linear(backend="c", **options):
    """The linear model of ``oc3_spar(**options)`` at its still-water equilibrium.

    Quadratic drag has no linear part at rest (its Jacobian there is 0/0 in
    the generated code), so the linear twin is built with ``drag=False`` and
    with Morison strips whose fluid kinematics are the inputs ``B``; it is a
    NumPy model whatever ``backend`` (the equilibrium's model) is.

    Returns
    -------
    (definition, model, y_eq, A, B, input names)
    """
    return _linear_cached(backend, tuple(sorted(options.items())))


_STRIP = re.compile(r"^(?P<name>\w+)_(?P<kind>[va])(?P<c>[xyz])(?P<i>\d+)$")


_STRIPS = {}


def _unit_strips(definition):
    """``(model strips, strip kinematics)``: the strips rebuilt once per definition (drag off)."""
    from ..modeling import AiryWave, MorisonCylinder
    key = id(definition)
    if key in _STRIPS and _STRIPS[key][0] is definition:
        return _STRIPS[key][1:]
    s = definition.symbols
    old = s["elements"].get("morison")
    if old is None:
        raise KanedynError("oc3 studies: the model has no Morison strips (drag off and still "
                           "water); build it with drag=True or waves")
    rest = dict.fromkeys(s["q"][:6], 0.0)
    stations = list(zip(old.geometry.s, old.geometry.D))
    strips = MorisonCylinder(old.name, s["B"], s["P"], s["B"].z, stations, s["N"],
                             s["O"], rest, 1025.0, Ca=1.0, Cd=0.0,
                             n_strips=old.n_strips, waves=AiryWave(1.0, 10.0, _WATER_DEPTH))
    _STRIPS[key] = (definition, old, strips._cache)
    return old, strips._cache


def wave_input_phasor(definition, input_names, period, amplitude=1.0):
    r"""Complex amplitudes :math:`R` of the model's inputs for a regular wave.

    The Morison strips' fluid velocity and acceleration for an Airy wave of
    ``amplitude`` (m) and ``period`` (s) are :math:`\mathrm{Re}(R e^{i\omega t})`.
    Other inputs (thrust, wetted fractions) get 0.
    """
    from ..modeling import AiryWave
    wave = AiryWave(2 * amplitude, period, _WATER_DEPTH)
    old, kinematics = _unit_strips(definition)
    kinematics = copy.copy(kinematics)     # the strips' fluid kinematics, for this wave
    kinematics.waves, kinematics._t = wave, None
    v0, a0, _ = (x.copy() for x in kinematics(0.0))
    v1, a1, _ = kinematics(period / 4)
    R = np.zeros(len(input_names), complex)
    for j, name in enumerate(input_names):
        m = _STRIP.match(name)
        if m and m["name"] == old.name:
            i, c = int(m["i"]), "xyz".index(m["c"])
            first, quarter = (v0, v1) if m["kind"] == "v" else (a0, a1)
            R[j] = first[i, c] - 1j * quarter[i, c]
    return R


def linear_rao(A, B, R_of_period, C, periods):
    r"""Response amplitude operators :math:`C(i\omega I - A)^{-1}B R(\omega)`, per m of wave.

    Returns
    -------
    ndarray, complex, shape (len(periods), n_outputs)
        Complex amplitudes of the outputs (rows of ``C``).
    """
    n = A.shape[0]
    out = []
    for T in periods:
        w = 2 * math.pi / T
        x = np.linalg.solve(1j * w * np.eye(n) - A, B @ R_of_period(T))
        out.append(C @ x)
    return np.array(out)


def _state_phasor(A, B, R, period):
    w = 2 * math.pi / period
    return np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B @ R)


def decay_analysis(t, x):
    r"""Period and damping ratio of a free decay from its positive peaks (``find_peaks``).

    :math:`T` is the mean spacing of the peaks; :math:`\delta` the mean
    logarithmic decrement of successive peaks and
    :math:`\zeta = \delta/\sqrt{4\pi^2 + \delta^2}`.

    Returns
    -------
    (float, float, ndarray)
        Period (s), damping ratio, indices of the peaks used; NaN when fewer
        than two peaks are found.
    """
    from scipy.signal import find_peaks
    x = np.asarray(x, float)
    peaks, _ = find_peaks(x)
    peaks = peaks[x[peaks] > 0]
    if len(peaks) < 2:
        return math.nan, math.nan, peaks
    period = float(np.mean(np.diff(t[peaks])))
    ratios = x[peaks[:-1]] / x[peaks[1:]]
    ratios = ratios[ratios > 0]
    delta = float(np.mean(np.log(ratios))) if ratios.size else math.nan
    zeta = delta / math.sqrt(4 * math.pi ** 2 + delta ** 2)
    return period, zeta, peaks


def _modes_by_dof(A, model, y_eq, dofs):
    """For each dof name the linear eigenvalue whose mode it dominates (kinetic-energy weight)."""
    n_q = model.n_q
    names = list(model.state_names)
    lam, V = np.linalg.eig(A)
    keep = lam.imag > 1e-9
    lam, V = lam[keep], V[:, keep]
    M = np.asarray(model.mass_matrix(0.0, y_eq))
    w = np.sqrt(np.abs(np.diag(M)))
    share = np.abs(V[:n_q]) * w[:, None]
    share /= share.sum(axis=0, keepdims=True)
    out = {}
    for dof in dofs:
        j = names.index(dof)
        k = int(np.argmax(share[j]))
        out[dof] = lam[k]
    return out


# ------------------------------------------------------------------ plotting
def _pyplot():
    from ._plotting import pyplot
    return pyplot()


def _save(fig, path):
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    _pyplot().close(fig)
    return path


# ------------------------------------------------------------------ oc3-decay
_DECAY = {  # dof -> (state, initial offset, duration s, unit, label)
    "surge": ("surge", 5.0, 400.0, "m", "surge"),            # period ~125 s: 3 cycles
    "heave": ("heave", 1.0, 120.0, "m", "heave"),            # ~31 s
    "pitch": ("pitch", math.radians(2.0), 120.0, "rad", "pitch"),  # ~30 s
    "yaw": ("yaw", math.radians(5.0), 40.0, "rad", "yaw"),   # ~8 s
    "tower": (None, None, 12.0, "m", "tower-top fore-aft deflection"),  # ~2.2 s
}


def _decay_study(out, quiet, tower_modes, drag, backend, duration_scale, rtol, atol,
                 tower_damping, tower_damping_reference):
    from ..simulation import simulate
    options = dict(tower_modes=tower_modes, drag=drag, tower_damping=tower_damping,
                   tower_damping_reference=tower_damping_reference)
    d, _, model, y_eq = _model(backend, **options)
    outputs = oc3_outputs(d, model)
    A = _linear(backend, **options)[3]
    dofs = [k for k in _DECAY if k != "tower" or tower_modes > 0]
    c_top = outputs["top_deflection"][0]
    # the modal coordinate carrying most of the fore-aft tower-top deflection
    tower_state = list(model.state_names)[int(np.argmax(np.abs(c_top)))]
    state_of = {k: (tower_state if k == "tower" else _DECAY[k][0]) for k in dofs}
    linear = _modes_by_dof(A, model, y_eq, [state_of[k] for k in dofs])
    rows, data, series = [], {}, {}
    for dof in dofs:
        _, offset, duration, unit, label = _DECAY[dof]
        state = state_of[dof]
        y0 = y_eq.copy()
        if dof == "tower":
            j = list(model.state_names).index(state)
            y0[j] += 0.2 / c_top[j]               # 0.2 m tower-top deflection
            signal_row = c_top
        else:
            y0[list(model.state_names).index(state)] += offset
            signal_row = np.zeros(model.n_states)
            signal_row[list(model.state_names).index(state)] = 1.0
        _say(quiet, f"oc3-decay: {dof} ({duration * duration_scale:g} s)")
        t_eval = np.linspace(0.0, duration * duration_scale, 4001)
        res = simulate(model, (0.0, t_eval[-1]), y0, t_eval=t_eval, rtol=rtol, atol=atol)
        if not res.success:
            raise KanedynError(f"oc3-decay: the {dof} decay failed: {res.message}")
        x = signal_row @ (res.y - y_eq[:, None])
        period, zeta, peaks = decay_analysis(res.t, x)
        lam = linear[state]
        f_lin = abs(lam) / (2 * math.pi)
        zeta_lin = -lam.real / abs(lam)
        T_damped = 2 * math.pi / lam.imag
        rows.append((dof, round(1 / f_lin, 4), round(T_damped, 4), round(period, 4),
                     round(zeta_lin, 5), round(zeta, 5)))
        data[dof] = dict(period=period, zeta=zeta, linear_period=1 / f_lin,
                         linear_damped_period=T_damped, linear_zeta=zeta_lin)
        series[dof] = (res.t, x, peaks, unit, label)
    figures = []
    if out is not None:
        plt = _pyplot()
        fig, axes = plt.subplots(len(series), 1, figsize=(9, 2.2 * len(series)))
        for ax, (dof, (t, x, peaks, unit, label)) in zip(axes, series.items()):
            ax.plot(t, x, lw=1, label=f"{label} (simulation)")
            ax.plot(t[peaks], x[peaks], "o", ms=3, label="peaks used")
            ax.set_ylabel(("tower-top\ndeflection" if dof == "tower" else dof) + f" [{unit}]")
            ax.set_title(f"{dof}: decay period {data[dof]['period']:.3g} s, "
                         f"linearized {data[dof]['linear_damped_period']:.3g} s", fontsize=9)
            ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        axes[-1].set_xlabel("time [s]")
        fig.suptitle(f"oc3-spar free decay from the static equilibrium (tower damping "
                     f"{tower_damping:g}, {tower_damping_reference})", fontsize=10)
        figures.append(_save(fig, out / "oc3-decay.png"))
    columns = ("dof", "linear natural period [s]", "linear damped period [s]",
               "decay period [s]", "linear damping ratio [-]", "decay damping ratio [-]")
    summary = "\n".join(f"{r[0]:6s}: decay {r[3]:.4g} s (zeta {r[5]:.3g}); linear "
                        f"{r[2]:.4g} s (zeta {r[4]:.3g})" for r in rows)
    return dict(tables={"periods": (columns, rows)}, figures=figures, summary=summary,
                data=data)


register_study("oc3-decay", _decay_study, {
    "tower_modes": StudyOption(int, 2, "tower bending modes (0, 2 or 4)"),
    "drag": StudyOption(bool, True, "Morison quadratic drag on"),
    "backend": StudyOption(str, "c", "numerical backend (C: compiled once per model)",
                           ("numpy", "c")),
    "duration_scale": StudyOption(float, 1.0, "scale of the decay durations "
                                  "(surge 400 s, heave and pitch 120 s, yaw 40 s, tower 12 s: "
                                  "about 3 natural periods or more)"),
    "rtol": StudyOption(float, 1e-6, "relative integration tolerance"),
    "atol": StudyOption(float, 1e-6, "absolute integration tolerance (m, rad, m/s, rad/s)"),
    **_damping_options(),
}, "free decay of surge, heave, pitch, yaw and the tower fore-aft mode vs linearization")


# ------------------------------------------------------------------ oc3-rao
_RAO_OUT = ("surge", "pitch", "top_displacement", "top_deflection")
#: axis labels of the outputs in the plots
_SHORT = {"surge": "surge", "pitch": "pitch",
          "top_displacement": "tower-top fore-aft\ndisplacement",
          "top_deflection": "tower-top fore-aft\ndeflection (rel. platform)"}


def simulated_rao(options, period, wave_height, backend="c", cycles=8, fit_cycles=3,
                  rtol=1e-6):
    """Steady-state output amplitudes per unit wave amplitude from a regular-wave simulation.

    Starts from the linear steady state (to shorten the transients) and fits
    :math:`a + b\\cos\\omega t + c\\sin\\omega t` to the last ``fit_cycles``
    wave periods of ``cycles``.

    Returns
    -------
    dict
        ``{output: amplitude per m of wave amplitude}``.
    """
    from ..simulation import simulate
    opts = dict(options, sea="regular", wave_height=wave_height, wave_period=period)
    d, _, model, y_eq = _model(backend, **opts)
    d_lin, _, _, A, B, r = _linear(backend, **options)
    X = _state_phasor(A, B, wave_input_phasor(d_lin, r, period, wave_height / 2), period)
    y0 = y_eq + X.real
    t_end = cycles * period
    t_eval = np.linspace(t_end - fit_cycles * period, t_end, 40 * fit_cycles + 1)
    res = simulate(model, (0.0, t_end), y0, t_eval=t_eval, rtol=rtol, atol=rtol * 1e-2)
    if not res.success:
        raise KanedynError(f"oc3-rao: the simulation at T = {period} s failed: {res.message}")
    w = 2 * math.pi / period
    basis = np.column_stack([np.ones_like(res.t), np.cos(w * res.t), np.sin(w * res.t)])
    outputs = oc3_outputs(d, model)
    amp = {}
    for key in _RAO_OUT:
        sig = outputs[key][0] @ res.y
        coef = np.linalg.lstsq(basis, sig, rcond=None)[0]
        amp[key] = math.hypot(coef[1], coef[2]) / (wave_height / 2)
    return amp


def _period_list(text):
    items = [p.strip() for p in str(text).split(",") if p.strip()]
    try:
        values = [float(p) for p in items]
    except ValueError:
        raise KanedynError(f"oc3-rao: check_periods must be a comma list of periods in s, got "
                           f"{text!r}") from None
    if any(not (math.isfinite(v) and v > 0) for v in values):
        raise KanedynError(f"oc3-rao: check_periods must be positive, got {text!r}")
    return values


def _rao_study(out, quiet, period_min, period_max, n_periods, check_periods, wave_height,
               tower_modes, drag, backend, tower_damping, tower_damping_reference):
    opts = dict(tower_modes=tower_modes, drag=drag, tower_damping=tower_damping,
                tower_damping_reference=tower_damping_reference)
    d, model, y_eq, A, B, r = _linear(backend, **opts)
    outputs = oc3_outputs(d, model)
    C = np.array([outputs[k][0] for k in _RAO_OUT])
    periods = np.linspace(period_min, period_max, n_periods)
    H = np.abs(linear_rao(A, B, lambda T: wave_input_phasor(d, r, T), C, periods))
    dense = np.linspace(period_min, period_max, 400)
    H_dense = np.abs(linear_rao(A, B, lambda T: wave_input_phasor(d, r, T), C, dense))
    lam = _modes_by_dof(A, model, y_eq, ["surge", "heave", "pitch"])
    natural = {k: 2 * math.pi / v.imag for k, v in lam.items()}
    checks = _period_list(check_periods)
    sim_rows, sim = [], {}
    for T in checks:
        _say(quiet, f"oc3-rao: simulating T = {T:g} s")
        amp = simulated_rao(opts, T, wave_height, backend)
        lin = np.abs(linear_rao(A, B, lambda TT: wave_input_phasor(d, r, TT), C, [T]))[0]
        sim[T] = (amp, lin)
        sim_rows.append((T, *[round(amp[k], 6) for k in _RAO_OUT],
                         *[round(v, 6) for v in lin],
                         *[round(amp[k] / v - 1, 5) for k, v in zip(_RAO_OUT, lin)]))
    units = {"surge": "m/m", "pitch": "rad/m", "top_displacement": "m/m",
             "top_deflection": "m/m"}
    columns = ("wave period [s]", *[f"{k} RAO [{units[k]}]" for k in _RAO_OUT])
    rows = [(round(float(T), 4), *[float(f"{v:.6g}") for v in h]) for T, h in zip(periods, H)]
    sim_cols = ("wave period [s]", *[f"{k} simulated [{units[k]}]" for k in _RAO_OUT],
                *[f"{k} linear [{units[k]}]" for k in _RAO_OUT],
                *[f"{k} relative difference [-]" for k in _RAO_OUT])
    figures = []
    if out is not None:
        plt = _pyplot()
        fig, axes = plt.subplots(len(_RAO_OUT), 1, figsize=(7.5, 10), sharex=True)
        for i, (ax, key) in enumerate(zip(axes, _RAO_OUT)):
            ax.plot(dense, H_dense[:, i], lw=1.2, label="linearized model (no drag)")
            if sim:
                ax.plot(list(sim), [sim[T][0][key] for T in sim], "o",
                        label=f"simulation, H = {wave_height:g} m")
            for (name, Tn), style in zip(natural.items(), ("--", ":", "-.")):
                if period_min <= Tn <= period_max:
                    ax.axvline(Tn, ls=style, lw=0.9, color="grey",
                               label=f"{name} natural period {Tn:.1f} s")
            ax.set_ylabel(f"{_SHORT[key]}\n[{units[key]}]", fontsize=8)
            ax.legend(fontsize=6)
        axes[0].set_title(f"oc3-spar response amplitude operators (regular waves; tower "
                          f"damping {tower_damping:g}, {tower_damping_reference})",
                          fontsize=9)
        axes[-1].set_xlabel("wave period [s]")
        figures.append(_save(fig, out / "oc3-rao.png"))
    summary = ("natural periods: " + ", ".join(f"{k} {v:.2f} s" for k, v in natural.items())
               + "\n" + "\n".join(f"T = {row[0]:g} s: simulated / linear - 1 = "
                                  + ", ".join(f"{k} {v:+.2e}" for k, v in
                                              zip(_RAO_OUT, row[-len(_RAO_OUT):]))
                                  for row in sim_rows))
    return dict(tables={"rao": (columns, rows), "check": (sim_cols, sim_rows)},
                figures=figures, summary=summary,
                data={"periods": periods, "rao": H, "natural_periods": natural,
                      "check": sim})


register_study("oc3-rao", _rao_study, {
    "period_min": StudyOption(float, 4.0, "shortest wave period, s"),
    "period_max": StudyOption(float, 40.0, "longest wave period, s"),
    "n_periods": StudyOption(int, 8, "wave periods of the tabulated linear RAO (the plotted "
                             "curve is always 400 periods)"),
    "check_periods": StudyOption(str, "10,20", "wave periods (s, comma list; '' for "
                                 "none) simulated as a check of the linear RAO"),
    "wave_height": StudyOption(float, 0.5, "wave height of the simulated checks, m"),
    "tower_modes": StudyOption(int, 2, "tower bending modes (0, 2 or 4)"),
    "drag": StudyOption(bool, True, "Morison quadratic drag in the simulations"),
    "backend": StudyOption(str, "c", "numerical backend (C: compiled once per model)",
                           ("numpy", "c")),
    **_damping_options(),
}, "response amplitude operators of surge, pitch, tower-top displacement and tower-top "
   "deflection (relative to the platform) vs wave period")


# ------------------------------------------------------------------ oc3-tmdi
_M_REF = 599718.0  # tower + RNA mass, kg: the reference mass of the model's mass ratios


@functools.lru_cache(maxsize=8)
def _forced_model(backend, tmdi, inertance_ratio, inerter_height, tower_modes,
                  tower_damping=0.01, tower_damping_reference="isolated"):
    """The still-water model (no drag) with a fore-aft force ``F_top(t)`` (N) at the tower top.

    Returns ``(definition, numeric model, equilibrium state)``.
    """
    import sympy.physics.mechanics as me

    from ..models import oc3_settle, oc3_spar
    d = oc3_spar(tower_modes=tower_modes, drag=False, sea="still", tmdi=tmdi,
                 inertance_ratio=inertance_ratio, inerter_height=inerter_height,
                 tower_damping=tower_damping, tower_damping_reference=tower_damping_reference)
    s = d.symbols
    force = me.dynamicsymbols("F_top")
    d.kane_args["loads"] = list(d.kane_args["loads"]) + [(s["top"], force * s["A"].x)]
    if d.load_names:  # the added force is a term of its own in an energy balance
        d = dataclasses.replace(d, load_names=tuple(d.load_names) + ("tower-top force",))
    eom = d.derive()
    needed = {str(x) for x in eom.specified}
    inputs = {k: v for k, v in d.specified.items() if str(k) in needed}
    inputs[force] = 0.0
    model = eom.numeric(constants=dict(d.constants), specified=inputs, backend=backend)
    y = oc3_settle(d, model)
    model.linearize(y)  # builds the Jacobians once: copies by with_constants reuse them
    return d, model, y


def _tower_mode(model, y, c_top):
    """Natural frequency :math:`|\\lambda|` (rad/s) of the tower fore-aft mode of ``model``."""
    A = np.asarray(model.linearize(y)[0])
    lam = _modes_by_dof(A, model, y, [list(model.state_names)[int(np.argmax(np.abs(c_top)))]])
    return abs(next(iter(lam.values())))


@functools.lru_cache(maxsize=16)
def _tuned(backend, kind, mass_ratio, inertance_ratio, inerter_height, tower_modes, criterion,
           tower_damping, tower_damping_reference):
    """A TMD (``kind="tmd"``) or TMDI tuned on the tower fore-aft FRF (tower-top force to
    tower-top deflection), H-infinity or H2.

    Returns
    -------
    (DamperTuning, definition, equilibrium state, primary frequency rad/s)
    """
    from ._damper_tuning import tune_damper
    beta = inertance_ratio if kind == "tmdi" else 0.0
    d, model, y = _forced_model(backend, kind, beta, inerter_height, tower_modes,
                                tower_damping, tower_damping_reference)
    c_top = oc3_outputs(d, model)["top_deflection"][0]
    wp = _tower_mode(model.with_constants({"k_d": 0.0, "c_d": 0.0}), y, c_top)
    extra = dict(inertance="b", inertance_ratio=beta) if kind == "tmdi" else {}
    tuning = tune_damper(model, y, input="F_top", output=c_top, primary_frequency=wp,
                         primary_mass=_M_REF, mass_ratio=mass_ratio, damper_mass="m_d",
                         stiffness="k_d", damping="c_d", criterion=criterion, tol=1e-6,
                         **extra)
    return tuning, d, y, wp


def tuned_damper_options(kind, mass_ratio, inertance_ratio, inerter_height, backend,
                         tower_damping, tower_damping_reference):
    """``oc3_spar`` options of a TMD or TMDI tuned as ``oc3-tmdi`` tunes it.

    H-infinity on the still-water, parked FRF of the tower-top deflection
    (two tower modes), with these mass and inertance ratios and tower damping.

    Returns
    -------
    (dict, tuple)
        The model options (``tmd_mass_ratio``, ``tmd_frequency`` in Hz,
        ``tmd_damping``, and for the TMDI ``inertance_ratio``,
        ``inerter_height``), and ``(frequency ratio, damping ratio, tower mode
        rad/s)`` of the tuning.
    """
    beta = inertance_ratio if kind == "tmdi" else 0.0
    tuning, _, _, wp = _tuned(backend, kind, mass_ratio, inertance_ratio, inerter_height, 2,
                              "hinf", tower_damping, tower_damping_reference)
    f, zeta = tuning.frequency_ratio, tuning.damping_ratio
    scale = math.sqrt(1 + beta / mass_ratio)   # k_d = m_d w_d^2 = (m_d + b)(f w_p)^2
    options = dict(tmd_mass_ratio=mass_ratio, tmd_frequency=f * wp / (2 * math.pi) * scale,
                   tmd_damping=zeta * scale)
    if kind == "tmdi":
        options.update(inertance_ratio=beta, inerter_height=inerter_height)
    return options, (f, zeta, wp)


def _band_peaks(model, y, omega, rows):
    """``[(|H| peak, omega), ...]`` per output row: the largest local maximum inside the
    grid ``omega`` of the force-to-output FRF, refined (``response_peaks``)."""
    from ._damper_tuning import _linear_system, response_peaks
    A, b, C, _ = _linear_system(model, y, 0.0, "F_top", rows)
    out = []
    for c in C:
        peaks = response_peaks(A, b, c, omega)
        inside = peaks[(peaks[:, 0] > omega[0]) & (peaks[:, 0] < omega[-1])]
        best = (inside if len(inside) else peaks)[0]
        out.append((float(best[1]), float(best[0])))
    return out


def _tmdi_study(out, quiet, mass_ratio, inertance_ratio, inerter_height, tower_modes,
                criterion, backend, tower_damping, tower_damping_reference):
    from ._damper_tuning import model_frequency_response
    if tower_modes < 2:
        raise KanedynError("oc3-tmdi: the tower must be flexible (tower_modes 2 or 4)")
    results, curves, peaks = {}, {}, {}
    for kind in ("tmd", "tmdi"):
        _say(quiet, f"oc3-tmdi: building and tuning the {kind.upper()}")
        tuning, d, y, wp_kind = _tuned(backend, kind, mass_ratio, inertance_ratio,
                                       inerter_height, tower_modes, criterion, tower_damping,
                                       tower_damping_reference)
        if kind == "tmd":
            wp = wp_kind
            omega = wp * np.geomspace(0.5, 2.0, 1200)
        outputs = oc3_outputs(d, tuning.model)
        rows_c = np.array([outputs["top_deflection"][0], outputs["top_displacement"][0]])
        results[kind] = tuning
        models = {kind: tuning.model}
        if kind == "tmd":
            models["off"] = tuning.model.with_constants({"k_d": 0.0, "c_d": 0.0})
        for key, m in models.items():
            curves[key] = model_frequency_response(m, y, omega, "F_top", rows_c).magnitude
            # peaks on the plotted band (0.5 to 2 times the tower mode): the deflection's
            # is the tuning's objective; the displacement's there is the tower mode's part
            # of it (below the band the platform's surge and pitch dominate it)
            peaks[key] = _band_peaks(m, y, omega, rows_c)
    without = peaks["off"]
    columns = ("configuration", "frequency ratio f [-]", "damping ratio zeta [-]",
               "peak |H| deflection [m/MN]", "deflection peak reduction [-]",
               "peak |H| displacement [m/MN]", "displacement peak reduction [-]")
    rows = [("no damper", "", "", round(without[0][0] * 1e6, 6), 0.0,
             round(without[1][0] * 1e6, 6), 0.0)]
    for kind, label in (("tmd", f"TMD (mu = {mass_ratio:g})"),
                        ("tmdi", f"TMDI (mu = {mass_ratio:g}, beta = {inertance_ratio:g}, "
                                 f"inerter to {inerter_height:g} m)")):
        r, (defl, disp) = results[kind], peaks[kind]
        rows.append((label, round(r.frequency_ratio, 5), round(r.damping_ratio, 5),
                     round(defl[0] * 1e6, 6), round(1 - defl[0] / without[0][0], 5),
                     round(disp[0] * 1e6, 6), round(1 - disp[0] / without[1][0], 5)))
    damping_text = f"tower damping {tower_damping:g} ({tower_damping_reference})"
    figures = []
    if out is not None:
        plt = _pyplot()
        fig, axes = plt.subplots(2, 1, figsize=(7.5, 7.5), sharex=True)
        f_hz = omega / (2 * math.pi)
        for key, label, style in (("off", "no damper", "-"), ("tmd", rows[1][0], "--"),
                                  ("tmdi", rows[2][0], "-.")):
            for j, ax in enumerate(axes):
                ax.semilogy(f_hz, curves[key][:, j] * 1e6, style, lw=1.3, label=label)
        axes[0].set_ylabel("tower-top fore-aft deflection\n(relative to the platform)\n"
                           "/ tower-top force [m/MN]", fontsize=8)
        axes[1].set_ylabel("tower-top fore-aft displacement\n(absolute)\n"
                           "/ tower-top force [m/MN]", fontsize=8)
        axes[1].set_xlabel("frequency [Hz]")
        axes[0].set_title(f"oc3-spar tower fore-aft FRF, dampers tuned on the deflection "
                          f"({criterion}); {damping_text}", fontsize=9)
        for ax in axes:
            ax.legend(fontsize=7)
            ax.grid(True, which="both", lw=0.3)
        figures.append(_save(fig, out / "oc3-tmdi.png"))
    summary = (f"tower fore-aft mode {wp / (2 * math.pi):.4f} Hz, {damping_text}; peak |H| "
               f"without damper: deflection {without[0][0] * 1e6:.4g} m/MN, displacement "
               f"{without[1][0] * 1e6:.4g} m/MN\n" + "\n".join(
                   f"{r[0]}: f {r[1]}, zeta {r[2]}, deflection peak {r[3]:.4g} m/MN "
                   f"({100 * r[4]:.1f} % lower), displacement peak {r[5]:.4g} m/MN "
                   f"({100 * r[6]:.1f} % lower)" for r in rows[1:]))
    data = {"primary_frequency": wp, "peak_without": without[0][0],
            "displacement_peak_without": without[1][0],
            **{f"{k}_{a}": getattr(results[k], a) for k in results
               for a in ("frequency_ratio", "damping_ratio", "success")},
            **{f"{k}_peak": peaks[k][0][0] for k in results},
            **{f"{k}_displacement_peak": peaks[k][1][0] for k in results}}
    return dict(tables={"tuning": (columns, rows)}, figures=figures, summary=summary,
                data=data)


register_study("oc3-tmdi", _tmdi_study, {
    "mass_ratio": StudyOption(float, 0.02, "damper mass / (tower + RNA mass 599,718 kg)"),
    "inertance_ratio": StudyOption(float, 0.02, "TMDI inertance / (tower + RNA mass)"),
    "inerter_height": StudyOption(float, 60.0, "height of the inerter's tower end above "
                                  "the SWL, m"),
    "tower_modes": StudyOption(int, 2, "tower bending modes (2 or 4)"),
    "criterion": StudyOption(str, "hinf", "tuning criterion: peak or H2 norm",
                             ("hinf", "h2")),
    "backend": StudyOption(str, "c", "numerical backend (C: compiled once per model)",
                           ("numpy", "c")),
    **_damping_options(),
}, "TMD and TMDI of equal mass tuned on the tower fore-aft FRF (tower-top force to "
   "deflection): peaks and reductions of the deflection and of the displacement")


# ------------------------------------------------------------------ oc3-sea
#: time step of the fluid kinematics sampled for the ensemble's runs, s: linear between
#: the samples, they moved the tower-top and base outputs of 200 s runs (Hs 6 m, Tp
#: 10 s, seeds 1 and 2) by at most 7e-4 of their standard deviations, and those by at
#: most 1.3e-4 of themselves, against the kinematics evaluated at every step
#: (tests/test_oc3_sea_ensemble.py)
SEA_INPUT_STEP = 0.025


@functools.lru_cache(maxsize=8)
def _time_inputs_model(backend, options):
    """The model of ``_built(backend, options)`` whose inputs are all the Morison
    strips' fluid kinematics, functions of time that :func:`sea_runs` samples: its
    rotor's thrust under a steady wind given as its expression (compiled,
    :meth:`~kanedyn.offshore.RotorThrust.expression`; the model itself when there is
    none).  ``None`` where the ensemble cannot run it: not compiled, or an input
    that reads the state or the time otherwise (a turbulent wind, catenary lines, a
    spinning rotor's aerodynamics and controller)."""
    from ..modeling import RotorThrust
    d, eom, model = _built(backend, options)
    morison = d.symbols["elements"].get("morison")
    if getattr(model, "_c", None) is None or morison is None:
        return None
    needed = {str(x) for x in eom.specified}
    inputs = {k: v for k, v in d.specified.items() if str(k) in needed}
    rotor = d.symbols["elements"].get("rotor")
    thrust = isinstance(rotor, RotorThrust) and rotor.symbol in inputs
    if thrust:
        if callable(rotor.wind):
            return None
        inputs[rotor.symbol] = rotor.expression()
    if set(inputs) - set(morison.specified()) - ({rotor.symbol} if thrust else set()):
        return None
    if not thrust:
        return model
    return eom.numeric(constants=dict(d.constants), specified=inputs, backend=backend)


def sea_runs(seeds, duration, backend="c", ensemble=True, dt=0.1,
             input_step=SEA_INPUT_STEP, rtol=1e-6, atol=1e-6, **options):
    """Runs of the ``oc3-spar`` in irregular seas that differ by their phases' seeds,
    from its still-water equilibrium.

    Parameters
    ----------
    seeds : sequence of int
        Seeds of the sea's random phases, one run each.
    duration : float
        s.
    backend : {"c", "numpy"}
    ensemble : bool
        Integrate the runs together in C (:func:`kanedyn.simulate_many`) where the
        model allows it (see below); ``False``: one :func:`kanedyn.simulate` per
        seed, the fluid kinematics evaluated at every step.
    dt : float
        Output step, s.
    input_step : float
        Step of the sampled fluid kinematics of the ensemble, s.
    rtol, atol : float
    **options
        Of :func:`kanedyn.models.oc3_spar` (``sea="irregular"`` and the seed set here).

    Returns
    -------
    (definition, model, t, Y)
        The first seed's definition and model, the output times (m,), s, and the
        states, shape (len(seeds), m, n_states).

    Notes
    -----
    The ensemble's model is the same equations with the rotor's thrust under a steady
    wind compiled (:meth:`~kanedyn.offshore.RotorThrust.expression`, the same curve:
    outputs within 1e-12 of the Python thrust's), and each seed's fluid kinematics
    sampled every ``input_step`` s (:meth:`~kanedyn.offshore.MorisonCylinder.input_series`)
    and interpolated linearly between the samples.  Models it cannot run (see
    ``_time_inputs_model``), and the NumPy backend, go one :func:`kanedyn.simulate`
    per seed.
    """
    from ..simulation import simulate, simulate_many
    seeds = [int(seed) for seed in seeds]
    if not seeds:
        raise KanedynError("sea_runs: give at least one seed")
    options = dict(options, sea="irregular")
    first = dict(options, seed=seeds[0])
    d, _, model, y_eq = _model(backend, **first)
    t_eval = np.arange(0.0, duration + dt / 2, dt)
    fast = _time_inputs_model(backend, tuple(sorted(first.items()))) if ensemble else None
    if fast is not None:
        morison = d.symbols["elements"]["morison"]
        times = np.arange(0.0, duration + input_step, input_step)
        series = [morison.input_series(times, morison.waves.with_seed(seed)) for seed in seeds]
        names = {name.removesuffix("(t)") for name in fast.input_names}
        inputs = {symbol: np.stack([values[symbol] for values in series])
                  for symbol in series[0] if _name(symbol) in names}
        many = simulate_many(fast, y_eq, (0.0, duration), inputs=inputs, input_times=times,
                             t_eval=t_eval, rtol=rtol, atol=atol)
        for seed, success, message in zip(seeds, many.success, many.message):
            if not success:
                raise KanedynError(f"oc3 sea run, seed {seed}: {message}")
        return d, model, t_eval, many.y
    from ..models import oc3_spar
    names = {name.removesuffix("(t)") for name in model.input_names}
    runs = []
    for seed in seeds:  # the same equations: the seed's functions of time as the inputs
        sea = d if seed == seeds[0] else oc3_spar(**dict(options, seed=seed))
        run = model.with_inputs({k: v for k, v in sea.specified.items() if _name(k) in names})
        res = simulate(run, (0.0, duration), y_eq, t_eval=t_eval, rtol=rtol, atol=atol)
        if not res.success:
            raise KanedynError(f"oc3 sea run, seed {seed}: {res.message}")
        runs.append(res.y.T)
    return d, model, t_eval, np.array(runs)


def _sea_study(out, quiet, Hs, Tp, seed, seeds, wind_speed, duration, mass_ratio,
               inertance_ratio, inerter_height, backend, tower_damping,
               tower_damping_reference):
    from scipy.signal import welch
    if duration < 100:
        raise KanedynError(f"oc3-sea: duration must be at least 100 s, got {duration}")
    if seeds < 1:
        raise KanedynError(f"oc3-sea: seeds must be at least 1, got {seeds}")
    phases = list(range(seed, seed + seeds))
    rows, spectra, tuned = [], {}, {}
    for kind in ("off", "tmd", "tmdi"):
        opts = dict(tower_modes=2, drag=True, wave_height=Hs, wave_period=Tp,
                    wind_speed=wind_speed, tmdi=kind, tower_damping=tower_damping,
                    tower_damping_reference=tower_damping_reference)
        if kind != "off":
            _say(quiet, f"oc3-sea: tuning the {kind.upper()}")
            damper, tuned[kind] = tuned_damper_options(
                kind, mass_ratio, inertance_ratio, inerter_height, backend, tower_damping,
                tower_damping_reference)
            opts.update(damper)
        _say(quiet, f"oc3-sea: {kind} ({seeds} x {duration:g} s)")
        d, model, t, Y = sea_runs(phases, duration, backend, **opts)
        dt = t[1] - t[0]
        outputs = oc3_outputs(d, model)
        keep = t >= min(100.0, duration / 4)          # past the start-up transient
        series = [[outputs[name][0] @ y[keep].T for y in Y]
                  for name in ("top_displacement", "top_deflection", "base_moment")]
        means = [np.mean([np.mean(x) for x in runs]) for runs in series]
        stds = [np.array([np.std(x) for x in runs]) for runs in series]
        row = (kind, round(float(means[0]), 5), round(float(stds[0].mean()), 5),
               round(float(means[1]), 5), round(float(stds[1].mean()), 5),
               round(float(means[2]) / 1e6, 4), round(float(stds[2].mean()) / 1e6, 4))
        if seeds > 1:  # how much the standard deviations vary from sea to sea
            row += (round(float(stds[0].std()), 5), round(float(stds[1].std()), 5),
                    round(float(stds[2].std()) / 1e6, 4))
        rows.append(row)
        nper = min(int(200 / dt), int(keep.sum()))
        spectra[kind] = [(welch(runs[0], fs=1 / dt, nperseg=nper)[0],
                          np.mean([welch(x, fs=1 / dt, nperseg=nper)[1] for x in runs], axis=0))
                         for runs in series]
    columns = ("tmdi", "mean tower-top displacement [m]", "std tower-top displacement [m]",
               "mean tower-top deflection [m]", "std tower-top deflection [m]",
               "mean tower-base moment [MN m]", "std tower-base moment [MN m]")
    if seeds > 1:
        columns += ("spread of std tower-top displacement [m]",
                    "spread of std tower-top deflection [m]",
                    "spread of std tower-base moment [MN m]")
    damping_text = f"tower damping {tower_damping:g} ({tower_damping_reference})"
    seed_text = f"seed {seed}" if seeds == 1 else f"seeds {seed}-{seed + seeds - 1}"
    figures = []
    if out is not None:
        plt = _pyplot()
        fig, axes = plt.subplots(3, 1, figsize=(7.5, 9), sharex=True)
        labels = {"off": "no damper", "tmd": f"TMD (mu = {mass_ratio:g})",
                  "tmdi": f"TMDI (mu = {mass_ratio:g}, beta = {inertance_ratio:g})"}
        scales = (1.0, 1.0, 1e-12)
        for kind, curves in spectra.items():
            for ax, (f1, p1), scale in zip(axes, curves, scales):
                band = f1 <= 1.0                       # the platform and first tower modes
                ax.semilogy(f1[band], p1[band] * scale, lw=1, label=labels[kind])
        axes[0].set_ylabel("tower-top displacement\n(absolute) PSD [m^2/Hz]", fontsize=8)
        axes[1].set_ylabel("tower-top deflection\n(relative to the platform)\nPSD [m^2/Hz]",
                           fontsize=8)
        axes[2].set_ylabel("tower-base fore-aft moment\nPSD [(MN m)^2/Hz]", fontsize=8)
        axes[2].set_xlabel("frequency [Hz]")
        axes[2].set_xlim(0, 1.0)
        for ax in axes:
            ax.legend(fontsize=7)
            ax.grid(True, which="major", lw=0.3)   # minor lines of 10 decades read as bands
        axes[0].set_title(f"oc3-spar, JONSWAP Hs {Hs:g} m, Tp {Tp:g} s, {seed_text}, wind "
                          f"{wind_speed:g} m/s, {duration:g} s\n(Welch"
                          f"{', mean over the seeds' if seeds > 1 else ''}); {damping_text}",
                          fontsize=8)
        figures.append(_save(fig, out / "oc3-sea.png"))
    spread = (lambda r: f" (spread over the seeds {r[7]:.3g} m, {r[8]:.3g} m, "
              f"{r[9]:.3g} MN m)") if seeds > 1 else (lambda r: "")
    summary = "\n".join(f"{r[0]:5s}: std top displacement {r[2]:.4g} m, std top deflection "
                        f"{r[4]:.4g} m, std base moment {r[6]:.4g} MN m{spread(r)}"
                        for r in rows)
    summary += "\n" + "\n".join(f"{k.upper()} tuned: f {v[0]:.5f}, zeta {v[1]:.5f} on the "
                                f"{v[2] / (2 * math.pi):.4f} Hz tower mode"
                                for k, v in tuned.items())
    data = {r[0]: dict(std_top=r[2], std_deflection=r[4], std_moment=r[6] * 1e6)
            for r in rows}
    data["tuned"] = tuned
    return dict(tables={"std": (columns, rows)}, figures=figures, summary=summary, data=data)


register_study("oc3-sea", _sea_study, {
    "Hs": StudyOption(float, 6.0, "significant wave height, m"),
    "Tp": StudyOption(float, 10.0, "JONSWAP peak period, s"),
    "seed": StudyOption(int, 1, "seed of the sea's random phases (the first one)"),
    "seeds": StudyOption(int, 1, "seas to run, seeds seed, seed + 1, ... (statistics "
                         "averaged over them, with their spread)"),
    "wind_speed": StudyOption(float, 11.4, "steady hub-height wind, m/s (0: parked)"),
    "duration": StudyOption(float, 600.0, "simulated time, s (the first 100 s are dropped)"),
    "mass_ratio": StudyOption(float, 0.02, "damper mass / (tower + RNA mass)"),
    "inertance_ratio": StudyOption(float, 0.02, "TMDI inertance / (tower + RNA mass)"),
    "inerter_height": StudyOption(float, 60.0, "inerter's tower end above the SWL, m"),
    "backend": StudyOption(str, "c", "numerical backend", ("numpy", "c")),
    **_damping_options(),
}, "irregular sea with steady wind: std and spectra of tower-top displacement, tower-top "
   "deflection and tower-base moment without damper, with the TMD and TMDI tuned as "
   "oc3-tmdi tunes them")
