"""One model, many formulations: a slider-crank under Kane, Lagrange and their siblings.

What it shows: ``kd.formulate(method=..., **model)`` takes the same model
description as ``kd.kane`` and returns the same kind of equations of motion,
so one script can derive, count, evaluate and simulate a model under every
formulation (``kd.FORMULATIONS`` lists them): Kane's method, Lagrange's
equations with multipliers under several constraint schemes (elimination,
index 1, Baumgarte, penalty, augmented Lagrangian, Udwadia-Kalaba,
coordinate partitioning, Maggi's null space) and the natural orthogonal
complement.  The model is a slider-crank (crank, connecting rod, slider on
a horizontal guide) under gravity: two loop-closure constraints, one degree
of freedom.  Printed side by side:

* the operation counts of each formulation's equations (``eom.operation_counts()``);
* the accelerations at one state (the penalty method is exact only as its
  factor grows, the others agree to round-off);
* a simulation of each: the crank angle against Kane's, the drift off the
  constraints (projected, damped, or left to grow), the energy error, the
  number of evaluations.

Run it::

    python examples/formulations_compared.py
    python examples/formulations_compared.py --methods kane,lagrange,maggi --plot f.png
"""

import argparse
import time

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

METHODS = ("kane", "lagrange", "lagrange-index1", "lagrange-baumgarte", "penalty",
           "augmented-lagrangian", "udwadia-kalaba", "partitioning", "maggi",
           "orthogonal-complement")
#: crank and rod lengths (m), crank, rod and slider masses (kg), gravity (m/s^2)
CONSTANTS = {"r": 0.2, "l": 0.6, "m_1": 1.0, "m_2": 0.5, "m_3": 2.0, "g": 9.81}
#: crank angle (rad) and rate (rad/s); the rod angle and slider position follow
START = {"q1": 0.5, "u1": 4.0, "q2": -0.1, "q3": 0.7}


def slider_crank():
    """The slider-crank as ``kd.kane`` keywords; returns ``(keywords, {name: symbol})``.

    The crank (length ``r``, angle ``q1`` from ``N.x``) turns about ``O``; the
    connecting rod (``l``, angle ``q2``) joins its tip ``A`` to the slider
    ``B`` at ``x = q3`` on the ``N.x`` axis.  Crank and rod are uniform rods;
    the slider is a particle.  ``N.y`` is up; speeds are the coordinates'
    rates.  ``q2, q3`` and their rates are dependent.
    """
    q1, q2, q3 = me.dynamicsymbols("q1:4")
    u1, u2, u3 = me.dynamicsymbols("u1:4")
    r, l, m1, m2, m3, g = sm.symbols("r l m_1 m_2 m_3 g", positive=True)
    N = me.ReferenceFrame("N")
    crank = N.orientnew("C", "Axis", (q1, N.z))
    rod = N.orientnew("R", "Axis", (q2, N.z))
    crank.set_ang_vel(N, u1 * N.z)
    rod.set_ang_vel(N, u2 * N.z)

    O = me.Point("O")
    O.set_vel(N, 0)
    A = O.locatenew("A", r * crank.x)
    A.v2pt_theory(O, N, crank)
    crank_centre = O.locatenew("Gc", r / 2 * crank.x)
    crank_centre.v2pt_theory(O, N, crank)
    rod_centre = A.locatenew("Gr", l / 2 * rod.x)
    rod_centre.v2pt_theory(A, N, rod)
    rod_end = A.locatenew("E", l * rod.x)
    rod_end.v2pt_theory(A, N, rod)
    B = O.locatenew("B", q3 * N.x)                   # the slider, on its guide
    B.set_vel(N, u3 * N.x)

    bodies = [me.RigidBody("crank", crank_centre, crank, m1,
                           (me.inertia(crank, 0, 0, m1 * r ** 2 / 12), crank_centre)),
              me.RigidBody("rod", rod_centre, rod, m2,
                           (me.inertia(rod, 0, 0, m2 * l ** 2 / 12), rod_centre)),
              me.Particle("slider", B, m3)]
    gap = rod_end.pos_from(B)                        # the rod's end is on the slider
    slip = rod_end.vel(N) - B.vel(N)
    keywords = dict(
        frame=N, q_ind=[q1], q_dep=[q2, q3], u_ind=[u1], u_dep=[u2, u3],
        kd_eqs=[q1.diff() - u1, q2.diff() - u2, q3.diff() - u3],
        configuration_constraints=[gap.dot(N.x), gap.dot(N.y)],
        velocity_constraints=[slip.dot(N.x), slip.dot(N.y)],
        bodies=bodies,
        loads=[(crank_centre, -m1 * g * N.y), (rod_centre, -m2 * g * N.y)],
        potential_energy=g * (m1 * crank_centre.pos_from(O) + m2 * rod_centre.pos_from(O))
        .dot(N.y))
    return keywords, dict(zip("r l m_1 m_2 m_3 g".split(), (r, l, m1, m2, m3, g)))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", default=",".join(METHODS),
                        help="comma-separated formulations (keys of kd.FORMULATIONS)")
    parser.add_argument("--t-end", type=float, default=10.0, help="simulated time, s")
    parser.add_argument("--rtol", type=float, default=1e-6, help="integrator rtol")
    parser.add_argument("--atol", type=float, default=1e-8, help="integrator atol")
    parser.add_argument("--plot", metavar="FILE", help="save a plot (needs matplotlib)")
    args = parser.parse_args(argv)
    methods = args.methods.split(",")
    if "kane" not in methods:
        methods.insert(0, "kane")                    # the reference

    keywords, s = slider_crank()
    constants = {s[k]: v for k, v in CONSTANTS.items()}
    models, counts = {}, {}
    for method in methods:
        eom = kd.formulate(method=method, **keywords)
        models[method] = eom.numeric(constants=constants)
        counts[method] = eom.operation_counts()

    # accelerations at one state (every model's state is [q1, q2, q3, rates])
    y = models["kane"].state(START)
    reference = models["kane"].rhs(0.0, y)[3:]
    accelerations = {m: models[m].rhs(0.0, y)[3:] for m in methods}
    deviation = {m: float(np.max(np.abs(a - reference)) / np.max(np.abs(reference)))
                 for m, a in accelerations.items()}

    t_eval = np.linspace(0.0, args.t_end, 501)
    runs, rows = {}, {}
    for method in methods:
        start = time.process_time()
        res = kd.simulate(models[method], (0.0, args.t_end), y, rtol=args.rtol,
                          atol=args.atol, t_eval=t_eval)
        cpu = time.process_time() - start
        runs[method] = res
        n_config = res.model.n_q_dep
        rows[method] = dict(
            position_drift=float(np.max(np.abs(res.constraint_residuals[:n_config]))),
            energy_error=float(np.max(np.abs(res.energy - res.energy[0]))),
            crank_deviation=float(np.max(np.abs(res["q1"] - runs["kane"]["q1"]))),
            evaluations=int(res.nfev), cpu=cpu, success=bool(res.success))

    print(f"slider-crank, {args.t_end:g} s, RK45 at rtol {args.rtol:g}, atol {args.atol:g}; "
          "accelerations at q1 = 0.5 rad, q1' = 4 rad/s relative to Kane's")
    print(f"{'method':<22}{'ops (all, CSE)':>15}{'accel. dev.':>13}{'|q1 - kane|':>13}"
          f"{'max |h| (m)':>13}{'max |dE| (J)':>14}{'evals':>7}{'CPU s':>7}")
    for m in methods:
        row = rows[m]
        print(f"{m:<22}{counts[m]['all_cse']:>15}{deviation[m]:>13.1e}"
              f"{row['crank_deviation']:>13.1e}{row['position_drift']:>13.1e}"
              f"{row['energy_error']:>14.1e}{row['evaluations']:>7}{row['cpu']:>7.2f}")

    if args.plot:
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True, layout="constrained")
        axes[0].plot(t_eval, np.degrees(runs["kane"]["q1"]), "k")
        axes[0].set_ylabel("crank angle q1,\nKane (deg)")
        for k, m in enumerate(methods):
            res, style = runs[m], dict(color=f"C{k % 10}", ls=("-", "--", ":", "-.")[k % 4])
            n_config = res.model.n_q_dep
            if m != "kane":
                axes[1].semilogy(res.t, np.maximum(np.abs(res["q1"] - runs["kane"]["q1"]),
                                                   1e-16), **style)
            axes[2].semilogy(res.t, np.maximum(np.max(np.abs(
                res.constraint_residuals[:n_config]), axis=0), 1e-16), label=m, **style)
        axes[1].set_ylabel("|q1 - q1 Kane| (rad)")
        axes[2].set_ylabel("loop-closure\nerror (m)")
        axes[2].set_xlabel("t (s)")
        fig.legend(loc="outside right center", fontsize="small")
        for ax in axes:
            ax.grid(True, alpha=0.3)
        fig.suptitle(f"slider-crank under gravity: formulations side by side "
                     f"(RK45, rtol {args.rtol:g}, atol {args.atol:g})")
        fig.savefig(args.plot, dpi=120)
        plt.close(fig)
        print(f"plot saved to {args.plot}")

    return {"accelerations": {m: a.tolist() for m, a in accelerations.items()},
            "acceleration_deviation": deviation, "runs": rows,
            "operations": {m: c["all_cse"] for m, c in counts.items()},
            "state": y.tolist()}


if __name__ == "__main__":
    out = main()
    print({"acceleration_deviation": out["acceleration_deviation"],
           "operations": out["operations"]})
