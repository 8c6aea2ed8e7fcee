"""Draw docs/img/damper_tuning.png: a primary's FRF without damper, with a TMD
tuned by Den Hartog, with the H-infinity optimum and with a TMDI.

    python docs/make_damper_tuning_figure.py
"""

from pathlib import Path

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

OUT = Path(__file__).resolve().parent / "img" / "damper_tuning.png"


def primary_with_tmdi():
    """Primary m on a spring k (light damping c), damper mass md on (kd, cd), an
    inerter b from the damper mass to the ground, a force F on the primary."""
    x, xd, u, ud = me.dynamicsymbols("x xd u ud")
    F = me.dynamicsymbols("F")
    m, k, c, md, kd_, cd, b = sm.symbols("m k c md kd cd b", nonnegative=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", 3 * N.x)
    G.set_vel(N, 0)
    P = O.locatenew("P", (1 + x) * N.x)
    P.set_vel(N, u * N.x)
    D = O.locatenew("D", (2 + xd) * N.x)
    D.set_vel(N, ud * N.x)
    bodies = [me.Particle("primary", P, m), me.Particle("damper", D, md),
              kd.Inerter("inerter", D, G, b, N)]
    loads = (kd.SpringDamper("support", O, P, k, c, 1, N).to_loads()
             + kd.SpringDamper("tmd", P, D, kd_, cd, 1, N).to_loads() + [(P, F * N.x)])
    eom = kd.kane(frame=N, q_ind=[x, xd], u_ind=[u, ud],
                  kd_eqs=[x.diff() - u, xd.diff() - ud], bodies=bodies, loads=loads)
    M, K = 1000.0, 4.0e5  # kg, N/m: f_p = 3.18 Hz
    return eom.numeric(constants={"m": M, "k": K, "c": 0.01 * 2 * np.sqrt(K * M),
                                  "md": 20.0, "kd": 0.0, "cd": 0.0, "b": 0.0},
                       specified={"F": lambda t, y: 0.0})


def main():
    model = primary_with_tmdi()
    y0 = np.zeros(4)
    M, wp = 1000.0, np.sqrt(4.0e5 / 1000.0)
    w = wp * np.geomspace(0.6, 1.6, 3000)
    common = dict(input="F", output="x", primary_frequency=wp, primary_mass=M,
                  damper_mass="md", stiffness="kd", damping="cd", inertance="b")
    tmd = kd.tune_damper(model, y0, mass_ratio=0.02, **common)
    tmdi = kd.tune_damper(model, y0, mass_ratio=0.02, inertance_ratio=0.02, **common)
    f, z = kd.den_hartog(0.02)
    dh = {"md": 20.0, "b": 0.0, "kd": 20.0 * (f * wp) ** 2, "cd": 2 * z * 20.0 * f * wp}
    curves = [
        (model, "no damper"),
        (model.with_constants(dh), f"TMD, Den Hartog (f = {f:.4f}, ζ = {z:.4f})"),
        (tmd.model, f"TMD, H∞ optimum (f = {tmd.frequency_ratio:.4f}, "
                    f"ζ = {tmd.damping_ratio:.4f})"),
        (tmdi.model, f"TMDI grounded, β = 0.02, H∞ optimum (f = {tmdi.frequency_ratio:.4f}, "
                     f"ζ = {tmdi.damping_ratio:.4f})"),
    ]
    responses = [kd.model_frequency_response(m, y0, w, "F", "x") for m, _ in curves]
    ax = kd.plot_frequency_responses(
        responses, [label for _, label in curves],
        title="Primary (1000 kg, 3.18 Hz, 1 % damping) under a force: "
              "TMD μ = 0.02 and TMDI", unit="m/N", legend="lower center")
    ax.figure.set_size_inches(8, 4.8)
    ax.title.set_fontsize(10)
    ax.figure.tight_layout()
    ax.figure.savefig(OUT, dpi=100)
    for (_, label), r in zip(curves, responses):
        print(f"{label}: peak {np.max(r.magnitude):.4g} m/N")


if __name__ == "__main__":
    main()
