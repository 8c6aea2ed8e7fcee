"""kanedyn's OC3-Hywind spar against OpenFAST: the cases, the files, both sides' runs.

Shared by ``benchmarks/openfast_oc3.py`` (runs OpenFAST, draws the figure) and
``tests/test_oc3_openfast.py`` (compares kanedyn with the committed OpenFAST
outputs).  The data live in ``tests/data/openfast_oc3`` (see its NOTICE.md):

* ``deck/``: the OpenFAST input files (OpenFAST v5 format);
* ``outputs/<case>.csv``: OpenFAST's response in each case, written by
  ``benchmarks/openfast_oc3.py run``.

Both codes get the same inputs where kanedyn's ``oc3-spar`` can take them: the
published platform mass and inertia, the constant added-mass matrix and the
linear hydrostatic matrix (HydroDyn reads them from the WAMIT-format files
:func:`write_wamit_files` writes from kanedyn's figures; no radiation memory, no
wave excitation), the OC3 linear damping and yaw spring, Morison drag
(Cd = 0.6), quasi-static catenary mooring (MAP++ against kanedyn's
``mooring="catenary"``), the flexible tower with 1 % structural damping (the
tower file of :func:`write_tower_file`: OC3's station table and mode shapes
fitted to kanedyn's clamped tower+RNA modes), a parked rotor (ElastoDyn's
blades and drivetrain rigid, rotor speed 0), still water, no wind.

The wave case ("waves") adds a regular Airy wave (OpenFAST's ``WaveMod`` 1P0,
no stretching) and its loads by strip theory on both sides: kanedyn's Morison
inertia force (1 + Ca) rho A a with Ca = 1 on strips wetted at rest, against
HydroDyn's strip theory on the same members with the transverse inertia
coefficient Ca + Cp = 0 + 2 and no strip added mass, buoyancy or axial terms
(``deck/NRELOffshrBsline5MW_OC3Hywind_HydroDyn_Waves.dat``); the added mass
and hydrostatics stay the WAMIT-format files' on the OpenFAST side and the
published matrices on kanedyn's.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "openfast_oc3"
DECK = DATA / "deck"
OUTPUTS = DATA / "outputs"

#: kanedyn's oc3-spar options that apply OpenFAST's inputs of the deck
KANEDYN_OPTIONS = dict(tower_modes=4, stiffening=True, tower_damping=0.01,
                       tower_damping_reference="isolated",
                       hydrostatics="linear", added_mass="sheet", linear_damping=True,
                       drag=True, mooring="catenary", rotor="rigid", wind_speed=0.0)

#: from this time on (s) the case released undisplaced ("still") is fitted for its offsets
SETTLED = 40.0

#: the regular wave of the "waves" case: height (m) and period (s)
WAVE_HEIGHT, WAVE_PERIOD = 6.0, 10.0

#: from this time on (s) the wave case's responses are compared (the waves start at t = 0)
WAVE_START = 60.0

#: the steady wind of the "wind" case (m/s, uniform, no shear) and its rotor's initial
#: state: kanedyn's BEM rotor settled in it (``oc3_spar(..., rotor="spinning",
#: aero="bem", controller="on")`` at its equilibrium, rounded)
WIND_SPEED = 18.0

#: from this time on (s) the wind case's means are taken (the surge offset is fitted)
WIND_START = 100.0

#: the wind case's rotor channels: OpenFAST channel -> (kanedyn quantity, factor to
#: kanedyn's units); see :func:`kanedyn_response`
WIND_CHANNELS = {"RotSpeed": ("rotor_speed", math.pi / 30), "BlPitch1": ("blade_pitch",
                                                                        math.pi / 180),
                 "GenPwr": ("electrical_power", 1e3), "RtAeroFxh": ("thrust", 1.0)}

#: OpenFAST channel -> (kanedyn state or output, factor to kanedyn's units)
CHANNELS = {"PtfmSurge": ("surge", 1.0), "PtfmSway": ("sway", 1.0),
            "PtfmHeave": ("heave", 1.0), "PtfmRoll": ("roll", math.pi / 180),
            "PtfmPitch": ("pitch", math.pi / 180), "PtfmYaw": ("yaw", math.pi / 180),
            "TTDspFA": ("top_deflection", 1.0)}


@dataclass(frozen=True)
class Case:
    """One OpenFAST run: the initial displacement, its length and output step.

    ``elastodyn``: ElastoDyn initial conditions changed from the deck
    (``PtfmSurge`` in m, angles in deg, ``TTDspFA`` in m); ``channel``: the
    response the decay is measured on.  A wave case also gives ``seastate``
    (SeaState values changed from the deck), ``hydrodyn`` (the HydroDyn file
    used instead of the deck's) and ``kanedyn`` (oc3-spar options added to
    :data:`KANEDYN_OPTIONS`); ``waves`` is then True.
    """

    name: str
    elastodyn: dict
    duration: float
    step: float
    channel: str
    title: str = ""
    seastate: dict = field(default_factory=dict)
    hydrodyn: str = ""
    kanedyn: dict = field(default_factory=dict)
    wind: float = 0.0
    settings: dict = field(default_factory=dict)

    @property
    def waves(self):
        return bool(self.seastate)


CASES = {c.name: c for c in (
    Case("still", {}, 120.0, 0.5, "PtfmPitch", "released undisplaced"),
    Case("surge", {"PtfmSurge": 5.0}, 200.0, 0.25, "PtfmSurge", "surge 5 m"),
    Case("heave", {"PtfmHeave": 1.0}, 120.0, 0.1, "PtfmHeave", "heave 1 m"),
    Case("pitch", {"PtfmPitch": 2.0}, 80.0, 0.1, "PtfmPitch", "pitch 2 deg"),
    Case("yaw", {"PtfmYaw": 5.0}, 40.0, 0.05, "PtfmYaw", "yaw 5 deg"),
    Case("tower", {"TTDspFA": 0.2}, 20.0, 0.025, "TTDspFA", "tower-top fore-aft 0.2 m"),
    Case("waves", {}, 120.0, 0.1, "PtfmPitch",
         f"regular waves H {WAVE_HEIGHT:g} m, T {WAVE_PERIOD:g} s",
         seastate={"WaveMod": "1P0", "WaveHs": f"{WAVE_HEIGHT:g}", "WaveTp": f"{WAVE_PERIOD:g}"},
         hydrodyn="NRELOffshrBsline5MW_OC3Hywind_HydroDyn_Waves.dat",
         kanedyn={"sea": "regular", "wave_height": WAVE_HEIGHT, "wave_period": WAVE_PERIOD}),
    Case("wind", {"PtfmSurge": 10.56, "PtfmSway": -0.26, "PtfmHeave": -0.145,
                  "PtfmRoll": 0.137, "PtfmPitch": 2.427, "PtfmYaw": -0.552, "TTDspFA": 0.218,
                  "RotSpeed": 12.1, "BlPitch(1)": 14.71},
         400.0, 0.2, "PtfmPitch", f"steady wind {WIND_SPEED:g} m/s, rotor turning, controller on",
         kanedyn={"rotor": "spinning", "aero": "bem", "controller": "on", "blades": "rigid",
                  "wind_speed": WIND_SPEED},
         wind=WIND_SPEED, settings={"GenDOF": "True", "PreCone(1)": "0", "PreCone(2)": "0",
                                    "PreCone(3)": "0"}),
)}


# ----------------------------------------------------------------- files written
def _write(path, text):
    """Write ``text`` to ``path`` unless it holds it already (runs may share the deck)."""
    path = Path(path)
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)


def _fit_mode(h, phi):
    """ElastoDyn's coefficients c2..c6 of sum c_k h^k fitted to phi(h), tip normalized to 1.

    Least squares with the constraint sum c = 1 (the shape is 1 at the tip),
    c6 = 1 - (c2 + ... + c5).
    """
    phi = np.asarray(phi, float) / phi[-1]
    powers = np.arange(2, 6)
    A = h[:, None] ** powers - h[:, None] ** 6
    c, *_ = np.linalg.lstsq(A, phi - h ** 6, rcond=None)
    return np.append(c, 1.0 - c.sum())


def tower_mode_coefficients(elements=40):
    """Polynomial coefficients of kanedyn's clamped tower+RNA modes, ElastoDyn's form.

    Returns
    -------
    dict
        ``{"TwFAM1Sh": c, "TwFAM2Sh": c, "TwSSM1Sh": c, "TwSSM2Sh": c}``, each
        shape (5,) for the powers 2..6 of the height fraction; fitted to the
        fore-aft (x) or side-side (y) node displacements of
        ``oc3_tower(elements, 4, rna=True)``.
    """
    from kanedyn.models._oc3_tower import oc3_tower
    tower = oc3_tower(elements, 4, rna=True, damping=0.0)
    nodes = range(tower.n_nodes)
    h = np.linspace(0.0, 1.0, tower.n_nodes)
    shapes = np.array([tower.node_modes(k)[0] for k in nodes])  # (nodes, 3, modes)
    out = {}
    for j, name in enumerate(tower.mode_names):
        plane, _, k = name.rpartition("_")
        axis, key = (0, "TwFAM") if plane == "fore_aft" else (1, "TwSSM")
        out[f"{key}{k}Sh"] = _fit_mode(h, shapes[:, axis, j])
    return out


def write_tower_file(path):
    """ElastoDyn's tower file from kanedyn's OC3 data (published stations, fitted modes)."""
    from kanedyn.models._oc3_data import TOWER, TOWER_STATIONS
    damping = 100.0 * TOWER["damping_ratio"].value
    lines = ["------- ELASTODYN V1.00.* TOWER INPUT FILE -------------------------------------",
             "OC3-Hywind tower: OC3's stations; mode shapes fitted to kanedyn's clamped "
             "tower+RNA FE modes",
             "---------------------- TOWER PARAMETERS ----------------------------------------",
             f"{len(TOWER_STATIONS['fraction']):11d}   NTwInpSt    - Number of input stations "
             "to specify tower geometry"]
    for name in ("TwrFADmp(1)", "TwrFADmp(2)", "TwrSSDmp(1)", "TwrSSDmp(2)"):
        lines.append(f"{damping:11g}   {name:11s} - Tower mode structural damping ratio (%)")
    lines.append("---------------------- TOWER ADJUSTMUNT FACTORS --------------------------------")
    for name in ("FAStTunr(1)", "FAStTunr(2)", "SSStTunr(1)", "SSStTunr(2)", "AdjTwMa",
                 "AdjFASt", "AdjSSSt"):
        lines.append(f"{1:11d}   {name:11s} - Tuner or adjustment factor (-)")
    lines += ["---------------------- DISTRIBUTED TOWER PROPERTIES ----------------------------",
              "  HtFract       TMassDen         TwFAStif       TwSSStif",
              "   (-)           (kg/m)           (Nm^2)         (Nm^2)"]
    for row in zip(TOWER_STATIONS["fraction"], TOWER_STATIONS["mass_per_length"],
                   TOWER_STATIONS["EI_fore_aft"], TOWER_STATIONS["EI_side_side"]):
        lines.append("  ".join(f"{v:.7E}" for v in row))
    coefficients = tower_mode_coefficients()
    for plane, title in (("FA", "FORE-AFT"), ("SS", "SIDE-TO-SIDE")):
        lines.append(f"---------------------- TOWER {title} MODE SHAPES " + "-" * 20)
        for mode in (1, 2):
            key = f"Tw{plane}M{mode}Sh"
            for power, c in zip(range(2, 7), coefficients[key]):
                lines.append(f"{c:15.7E}   {key}({power}) - Mode {mode}, coefficient of "
                             f"x^{power} term")
    _write(path, "\n".join(lines) + "\n")


def write_wamit_files(root):
    """``root.hst``, ``root.1``, ``root.3``: kanedyn's OC3 matrices in WAMIT's form.

    Hydrostatics: the published buoyancy and waterplane matrix (C33, C44, C55);
    added mass: the published constant matrix at every period (0: infinite
    frequency, -1: zero frequency, and 5, 20, 100 s), no radiation damping; the
    wave excitation is zero (still water only).  Nondimensionalized as HydroDyn
    expects with WAMITULEN = 1 m: C / (rho g), A / rho.
    """
    from kanedyn.models._oc3_data import ENVIRONMENT, added_mass_matrix, hydrostatic_matrix
    rho = ENVIRONMENT["water_density"].value
    rho_g = rho * ENVIRONMENT["gravity"].value
    C = hydrostatic_matrix(weight=False)
    A = added_mass_matrix()
    root = Path(root)
    nonzero = [(i, j) for i in range(6) for j in range(6)]
    _write(root.with_suffix(".hst"), "".join(
        f"{i + 1:6d}{j + 1:6d} {C[i, j] / rho_g:.8E}\n" for i, j in nonzero if C[i, j]))
    periods = (-1.0, 0.0, 100.0, 20.0, 5.0)
    text = []
    for period in periods:
        for i, j in nonzero:
            if A[i, j]:
                text.append(f"{period:12.4E}{i + 1:6d}{j + 1:6d} {A[i, j] / rho:.8E}"
                            + (f" {0.0:.8E}\n" if period > 0 else "\n"))
    _write(root.with_suffix(".1"), "".join(text))
    _write(root.with_suffix(".3"), "".join(
        f"{period:12.4E} {0.0:10.4E}{i:6d} {0.0:.6E} {0.0:.6E} {0.0:.6E} {0.0:.6E}\n"
        for period in periods if period > 0 for i in range(1, 7)))


# ----------------------------------------------------------------- OpenFAST side
def read_output_csv(path):
    """``(time, {channel: series})`` of one committed output CSV (OpenFAST's units)."""
    with open(path) as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    names = [h.split(" [")[0] for h in header]
    return data[:, 0], {n: data[:, k] for k, n in enumerate(names) if k}


# ----------------------------------------------------------------- kanedyn side
@functools.lru_cache(maxsize=2)
def kanedyn_model(backend="c", extra=()):
    """``(definition, numeric model, outputs)`` of oc3-spar with :data:`KANEDYN_OPTIONS`
    and the ``(option, value)`` pairs ``extra``."""
    from kanedyn.analysis._oc3_studies import oc3_outputs
    from kanedyn.models import oc3_spar
    d = oc3_spar(**{**KANEDYN_OPTIONS, **dict(extra)})
    eom = d.derive()
    needed = {str(x) for x in eom.specified}
    # inputs the equations do not contain (the strips' velocities without drag) are left out
    inputs = {k: v for k, v in d.specified.items() if str(k) in needed}
    model = eom.numeric(constants=dict(d.constants), specified=inputs, backend=backend)
    return d, model, oc3_outputs(d, model)


def initial_state(case, model, outputs, definition=None):
    """kanedyn's state for the case's ElastoDyn initial conditions (undisplaced otherwise).

    A wind case starts from the definition's initial state with the platform,
    tower, rotor speed and blade pitch of the case, the controller's filtered
    generator speed at the generator's speed and its integral at the value whose
    command is the blade pitch (as OpenFAST's controller library starts itself).
    """
    names = list(model.state_names)
    y0 = np.array(definition.initial(model), float) if case.wind else np.zeros(model.n_states)
    for channel, value in case.elastodyn.items():
        if channel == "RotSpeed":
            from kanedyn.models._oc3_data import DRIVETRAIN
            y0[names.index("rotor_speed")] = value * math.pi / 30
            y0[names.index("gen_speed_filtered")] = (value * math.pi / 30
                                                     * DRIVETRAIN["gear_ratio"].value)
            continue
        if channel == "BlPitch(1)":
            from kanedyn.models._oc3_rotor import oc3_controller
            controller, pitch = oc3_controller(), math.radians(value)
            y0[names.index("blade_pitch")] = pitch
            y0[names.index("speed_error_integral")] = pitch / (
                controller.gain_correction(pitch) * controller.ki)
            continue
        target, factor = CHANNELS[channel]
        if target == "top_deflection":
            row = outputs["top_deflection"][0]
            j = int(np.argmax(np.abs(row)))  # the modal coordinate carrying the deflection
            y0[j] = value / row[j]
        else:
            y0[names.index(target)] = value * factor
    return y0


def kanedyn_response(case, backend="c", rtol=1e-7, atol=1e-7, duration=None):
    """``(time, {channel: series})`` of kanedyn in ``case``, in OpenFAST's units
    (and ``Wave1Elev``, the wave elevation at the origin in m, in a wave case),
    over ``duration`` s (default: the case's)."""
    from kanedyn.simulation import simulate
    d, model, outputs = kanedyn_model(backend, tuple(sorted(case.kanedyn.items())))
    y0 = initial_state(case, model, outputs, d)
    end = case.duration if duration is None else duration
    t = np.arange(0.0, end + 0.5 * case.step, case.step)
    res = simulate(model, (0.0, t[-1]), y0, t_eval=t, rtol=rtol, atol=atol)
    if not res.success:
        raise RuntimeError(f"kanedyn's {case.name} decay failed: {res.message}")
    names = list(model.state_names)
    series = {}
    for channel, (target, factor) in CHANNELS.items():
        if target == "top_deflection":
            series[channel] = outputs["top_deflection"][0] @ res.y / factor
        else:
            series[channel] = res.y[names.index(target)] / factor
    if case.waves:   # the wave elevation at the platform's reference point (0, 0), m
        series["Wave1Elev"] = d.symbols["elements"]["morison"].waves.elevation_series(0.0, res.t)
    if case.wind:
        series.update(_rotor_series(model, res))
    return res.t, series


def _rotor_series(model, res):
    """The wind case's :data:`WIND_CHANNELS` of kanedyn's run, in OpenFAST's units.

    Rotor speed and blade pitch are states; the thrust is the BEM rotor's force
    along the shaft (the input ``Frotor_x``, solved again at each output
    time); the electrical power is the baseline controller's generator torque
    of the states times the generator speed (gear ratio times the rotor speed)
    times the generator efficiency.
    """
    import sympy as sm

    from kanedyn.models._oc3_data import DRIVETRAIN
    from kanedyn.models._oc3_rotor import oc3_controller
    names = list(model.state_names)
    states = [res.y[names.index(n)] for n in ("gen_speed_filtered", "speed_error_integral",
                                              "blade_pitch")]
    symbols = sm.symbols("w i p")
    torque = sm.lambdify(symbols, oc3_controller().generator_torque(symbols), "numpy")
    omega = res.y[names.index("rotor_speed")]
    power = (DRIVETRAIN["generator_efficiency"].value * DRIVETRAIN["gear_ratio"].value
             * omega * np.broadcast_to(torque(*states), omega.shape))
    k = list(model.input_names).index("Frotor_x(t)")
    thrust = np.array([model.input_values(t, y)[k] for t, y in zip(res.t, res.y.T)])
    values = {"rotor_speed": omega, "blade_pitch": states[2], "electrical_power": power,
              "thrust": thrust}
    return {channel: values[target] / factor
            for channel, (target, factor) in WIND_CHANNELS.items()}


# ----------------------------------------------------------------- comparison
@dataclass(frozen=True)
class Decay:
    """A free decay's measures, independent of the offset it decays about.

    Attributes
    ----------
    period : float
        Mean spacing of the maxima, s.
    damping : float
        Damping ratio from the mean logarithmic decrement of the successive
        double amplitudes (a maximum less the minimum after it).
    times, maxima, minima : ndarray, shape (n,)
        The maxima's times and values, and the minimum after each, every
        extremum refined by a parabola through the samples around it (so
        the output step limits neither).
    """

    period: float
    damping: float
    times: np.ndarray
    maxima: np.ndarray
    minima: np.ndarray

    @property
    def double_amplitudes(self):
        return self.maxima - self.minima

    @property
    def centres(self):
        """Midpoints of each maximum and the following minimum (the offset decayed about)."""
        return 0.5 * (self.maxima + self.minima)


def _extrema(t, y):
    """Times and values of the maxima of ``y``, refined by parabolas.

    The first sample counts as a maximum when the record starts there at rest
    (a decay released from a displacement): its value, at its time.
    """
    from scipy.signal import find_peaks
    k, _ = find_peaks(y)
    k = k[(k > 0) & (k < len(y) - 1)]
    a, b, c = y[k - 1], y[k], y[k + 1]
    shift = 0.5 * (a - c) / (a - 2 * b + c)          # the parabola's vertex, in steps
    times, values = t[k] + shift * (t[1] - t[0]), b - 0.25 * (a - c) * shift
    if len(y) > 1 and y[0] > y[1]:
        times, values = np.insert(times, 0, t[0]), np.insert(values, 0, y[0])
    return times, values


def decay_measures(t, x, count=None):
    """:class:`Decay` of the record ``x(t)`` from its first ``count`` cycles."""
    x = np.asarray(x, float)
    t_max, maxima = _extrema(t, x)
    t_min, minima = _extrema(t, -x)
    pairs = [(tm, m, -minima[np.argmax(t_min > tm)]) for tm, m in zip(t_max, maxima)
             if np.any(t_min > tm)][:count]
    times, maxima, minima = (np.array(v) for v in zip(*pairs))
    double = maxima - minima
    delta = float(np.mean(np.log(double[:-1] / double[1:])))
    return Decay(float(np.mean(np.diff(times))), delta / math.hypot(2 * math.pi, delta),
                 times, maxima, minima)


def settled_offset(t, x, period, start=SETTLED):
    """The value ``x(t)`` settles to: a damped cosine plus a constant fitted from ``start``.

    Parameters
    ----------
    t, x : ndarray
        A record released from rest away from its equilibrium.
    period : float
        A first guess of the oscillation's period, s.

    Returns
    -------
    float
        The fitted constant.
    """
    from scipy.optimize import curve_fit

    def decay(t, offset, amplitude, rate, period, phase):
        return offset + amplitude * np.exp(-rate * t) * np.cos(2 * math.pi * t / period + phase)

    keep = t >= start
    guess = [np.mean(x[keep]), np.ptp(x[keep]) / 2, 0.01, period, 0.0]
    p, _ = curve_fit(decay, t[keep] - start, x[keep], p0=guess, maxfev=20000)
    return float(p[0])


def wind_mean(t, series, channel, start=WIND_START):
    """The mean of ``series[channel]`` from ``start`` to the record's end."""
    return float(np.mean(np.asarray(series[channel])[np.asarray(t) >= start - 1e-9]))


@dataclass(frozen=True)
class Harmonic:
    """The wave-frequency part of a record in regular waves.

    Attributes
    ----------
    amplitude : float
        Amplitude of the component at the wave's frequency, in the record's units.
    phase : float
        Its phase, rad: the component is ``amplitude cos(omega t - phase)``.
    """

    amplitude: float
    phase: float


def wave_harmonic(t, x, period, start):
    """:class:`Harmonic` of ``x(t)`` at the frequency ``2 pi / period`` from ``start`` on.

    Least squares over the whole periods from ``start``: the harmonic and a cubic
    in time (the slow transient of the surge and pitch modes left by the
    waves' start, about 30 to 120 s periods).
    """
    omega = 2 * math.pi / period
    cycles = math.floor((t[-1] - start) / period + 1e-9)
    keep = (t >= start - 1e-9) & (t <= start + cycles * period + 1e-9)
    s = (t[keep] - start) / (cycles * period)
    basis = np.column_stack([np.cos(omega * t[keep]), np.sin(omega * t[keep]),
                             np.ones_like(s), s, s ** 2, s ** 3])
    (a, b, *_), *_ = np.linalg.lstsq(basis, np.asarray(x, float)[keep], rcond=None)
    return Harmonic(float(math.hypot(a, b)), float(math.atan2(b, a)))
