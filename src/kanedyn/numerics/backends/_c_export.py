"""Standalone C source of a numerical model: no Python, a documented interface.

The file holds the same generated evaluation functions and the same
right-hand-side assembly (``kd_rhs_core``: dependent speeds eliminated,
Cholesky with an LU fallback, or, for a tree of at least
``TREE_MIN_SPEEDS`` speeds without dependent ones, the articulated-body pass)
as the compiled extension module of the C backend, behind a small public
interface::

    int kanedyn_rhs(double t, const double *y, const double *p, const double *r,
                    double *ydot);
    int kanedyn_constraints(double t, const double *y, const double *p,
                            const double *r, double *residual);
    int kanedyn_energy(double t, const double *y, const double *p, const double *r,
                       double *energy);
    int kanedyn_project(double t, double *y, const double *p, const double *r);
    int kanedyn_advance(double t0, double t1, double *y, const double *p,
                        const double *r, const double *r_rate, double rtol,
                        double atol, double project_tol, double *step, long *steps);

``kanedyn_project`` and ``kanedyn_advance`` are the compiled integration loop's
projection onto the constraints and its Dormand-Prince 5(4) pair with SciPy's
step-size control (the same C text for the projection and the tableau), without
Python: what an FMU's co-simulation step runs.

It compiles as C99 on its own (``cc -c -std=c99 -Wall -Werror model.c``; link
with ``-lm``).
"""

from __future__ import annotations

from ..._version import __version__
from . import _c_runtime
from ._c import (PIECE_MARK, _function_source, _function_sources, _parameter_columns,
                 jacobian_solve_defines, solver_source)
from ._c_contact import SEGMENT
from ._c_contact_general import GENERAL
from ._c_hybrid import HYBRID
from ._c_impact_slide import SLIDE
from ._c_impacts import IMPACTS
from ._c_integrator import BRENT, DENSE_OUTPUT, DORMAND_PRINCE, PROJECTION

__all__ = ["standalone_c"]

#: pi for generated code that names it (``M_PI`` is POSIX, not C99)
_PI = "#ifndef M_PI\n#define M_PI 3.14159265358979323846\n#endif"

_PUBLIC = r"""
/* ------------------------------------------------------------ public interface */
const char *const kanedyn_state_names[KANEDYN_NSTATES] = {%(states)s};
const char *const kanedyn_parameter_names[KD_SZ(KANEDYN_NP)] = {%(parameters)s};
const double kanedyn_default_parameters[KD_SZ(KANEDYN_NP)] = {%(values)s};
const char *const kanedyn_input_names[KD_SZ(KANEDYN_NR)] = {%(inputs)s};

static double *kd_work(void) {
#if KD_NW > 0
    return (double *)malloc(sizeof(double) * KD_NW);
#else
    static double none[1];
    return none;
#endif
}

static void kd_free_work(double *w) {
#if KD_NW > 0
    free(w);
#else
    (void)w;
#endif
}

int kanedyn_rhs(double t, const double *y, const double *p, const double *r, double *ydot) {
    double *w = kd_work();
    if (w == NULL) return 2;
    (void)kd_lu_solve;  /* used only by some models */
    int status = kd_rhs_core(t, y, p, r, w, ydot);
    kd_free_work(w);
    return status;
}

int kanedyn_constraints(double t, const double *y, const double *p, const double *r,
                        double *residual) {
    double *w = kd_work();
    if (w == NULL) return 2;
    double h[KD_SZ(KD_NQDEP)], J[KD_SZ(KD_NQDEP * KD_NQ)];
    double B[KD_SZ(KD_NUDEP * KD_NU)], c[KD_SZ(KD_NUDEP)];
    kd_eval_constraints(t, y, p, r, w, h, J, B, c);
    kd_free_work(w);
    memcpy(residual, h, KD_NQDEP * sizeof(double));
    memcpy(residual + KD_NQDEP, c, KD_NUDEP * sizeof(double));
    return 0;
}

int kanedyn_project(double t, double *y, const double *p, const double *r) {
    double *w = kd_work();
    if (w == NULL) return 2;
    int status = kd_project_at(t, y, p, r, w);
    kd_free_work(w);
    return status;
}

/* the inputs at t: r + (t - t0) r_rate (r_rate NULL: r) */
static void kd_inputs_along(double t, double t0, const double *r, const double *r_rate,
                            double *ri) {
    for (int i = 0; i < KD_NR; ++i) ri[i] = r[i] + (r_rate ? (t - t0) * r_rate[i] : 0.0);
}

/* the derivative along inputs r + (t - t0) r_rate (a KdRhsFn): 0, 1 singular, 3 not finite */
typedef struct { const double *p, *r, *r_rate; double t0; double *w; } KdAlong;

static int kd_derivative(void *ctx, double t, const double *y, double *f) {
    const KdAlong *a = (const KdAlong *)ctx;
    double ri[KD_SZ(KD_NR)];
    kd_inputs_along(t, a->t0, a->r, a->r_rate, ri);
    if (kd_rhs_core(t, y, a->p, ri, a->w, f) != 0) return 1;
    for (int i = 0; i < KD_NX; ++i) if (!isfinite(f[i])) return 3;
    return 0;
}

/* Dormand-Prince 5(4) with the step-size control of SciPy's RK45 (safety 0.9,
   factors within [0.2, 10], RMS norm of err / (atol + max(|y|, |y_new|) rtol)) */
static int kd_advance(double t0, double t1, double *y, const double *p, const double *r,
                      const double *r_rate, double rtol, double atol, double project_tol,
                      double *step, long *steps, double *w) {
    double f[KD_NX], K[7 * KD_NX], y_new[KD_NX], atols[KD_NX];
    double B[KD_SZ(KD_NUDEP * KD_NU)];
    KdAlong along = {p, r, r_rate, t0, w};
    for (int i = 0; i < KD_NX; ++i) atols[i] = atol;
    double t = t0;
    int status = kd_derivative(&along, t, y, f);
    if (status != 0 || !(t1 > t0)) return status;
    double h = *step;
    if (!(h > 0.0) && (status = kd_first_step(kd_derivative, &along, t, y, f, 1.0, t1 - t0,
                                              rtol, atols, INFINITY, 4, &h)) != 0)
        return status;
    while (t < t1) {
        double min_step = 10 * (nextafter(t, INFINITY) - t);
        int rejected = 0;
        double err_norm, hs, factor;
        for (;;) {  /* attempts of one step */
            if (h < min_step) return 4;
            hs = t + h >= t1 ? t1 - t : h;
            status = kd_dopri_attempt(kd_derivative, &along, t, y, f, hs, rtol, atols, K,
                                      y_new, &err_norm);
            if (status != 0) return status;
            if (err_norm < 1.0) break;
            h = hs * fmax(0.2, 0.9 * pow(err_norm, -0.2));
            rejected = 1;
        }
        factor = err_norm == 0.0 ? 10.0 : fmin(10.0, 0.9 * pow(err_norm, -0.2));
        if (rejected) factor = fmin(1.0, factor);
        int clipped = hs < h;
        t = clipped ? t1 : t + hs;
        h = clipped ? fmax(h, hs * factor) : hs * factor;
        memcpy(y, y_new, sizeof(double) * KD_NX);
        memcpy(f, K + 6 * KD_NX, sizeof(double) * KD_NX);
        ++*steps;
        if (project_tol > 0.0 && KD_NQDEP + KD_NUDEP > 0) {
            double ri[KD_SZ(KD_NR)];
            kd_inputs_along(t, t0, r, r_rate, ri);
            if (kd_residual_at(t, y, p, ri, w, B) > project_tol) {
                if (kd_project_at(t, y, p, ri, w) != 0) return 1;
                if ((status = kd_derivative(&along, t, y, f)) != 0) return status;
            }
        }
    }
    *step = h;
    return 0;
}

int kanedyn_advance(double t0, double t1, double *y, const double *p, const double *r,
                    const double *r_rate, double rtol, double atol, double project_tol,
                    double *step, long *steps) {
    double *w = kd_work();
    if (w == NULL) return 2;
    int status = kd_advance(t0, t1, y, p, r, r_rate, rtol, atol, project_tol, step, steps, w);
    kd_free_work(w);
    return status;
}

int kanedyn_energy(double t, const double *y, const double *p, const double *r,
                   double *energy) {
    double *w = kd_work();
    if (w == NULL) return 2;
    double kinetic, potential;
    kd_eval_energy(t, y, p, r, w, &kinetic, &potential);
    kd_free_work(w);
    energy[0] = kinetic;
    energy[1] = potential;
    return 0;
}
"""


#: the exact derivatives in the standalone file (``c_source(jacobians=True)``):
#: :data:`_c_runtime.JACOBIAN_SOLVE`'s ``kd_jacobian_core`` behind a public function
_JACOBIANS = r"""
/* ------------------------------------------------------------ exact derivatives */
#define KANEDYN_JROWS (KD_NX + KD_NUDEP)
#define KANEDYN_JCOLS KD_JC
#define KANEDYN_NCON KD_NCON

int kanedyn_jacobians(double t, const double *y, const double *p, const double *r,
                      double *ydot, double *jacobian, double *constraint_jacobian) {
    static const double none[1] = {0.0};
    double *w = (double *)malloc(sizeof(double) * (KD_SZ(KD_NW) + KD_JAC_SCRATCH
                                                   + KD_SZ(KD_NCON * KD_NX)));
    if (w == NULL) return 2;
    double *C = w + KD_SZ(KD_NW) + KD_JAC_SCRATCH;
    (void)kd_eval_jacobians;  /* the derivatives without the dynamics: unused here */
#if KD_JAC_TREE_SOLVE
    (void)kd_index1_lu; (void)kd_lu_apply;
#endif
#if KD_TREE_JAC
    (void)kd_jparent;  /* not on a chain */
#endif
    int status = kd_jacobian_core(t, y, p, r != NULL ? r : none, w, w + KD_SZ(KD_NW), ydot,
                                  jacobian, C);
    if (status == 0 && constraint_jacobian != NULL)
        memcpy(constraint_jacobian, C, sizeof(double) * KD_NCON * KD_NX);
    free(w);
    return status;
}
"""


def _c_string(text):
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _list(items, fallback):
    return ", ".join(items) if items else fallback


def _contact_source(contacts):
    """C of the contacts' names, restitution laws and coefficients (expressions of
    the parameters ``p``), for the contact loop (:data:`._c_hybrid.HYBRID`)."""
    k = len(contacts)
    lines = [f"#define KD_NC {k}",
             "const char *const kanedyn_contact_names[KD_NC] = {"
             + ", ".join(_c_string(c["name"]) for c in contacts) + "};",
             "static const int kd_contact_law[KD_NC] = {"
             + ", ".join("1" if c["newton"] else "0" for c in contacts) + "};",
             "static void kd_contact_coefficients(const double *p, double *mu_k, double *mu_s,",
             "                                    double *visc, double *e) {",
             "    (void)p;"]
    for i, c in enumerate(contacts):
        lines += [f"    mu_k[{i}] = {c['mu_k']};", f"    mu_s[{i}] = {c['mu_s']};",
                  f"    visc[{i}] = {c['viscous']};", f"    e[{i}] = {c['restitution']};"]
    return "\n".join([*lines, "}"])


def standalone_c(program, functions, sizes, state_names, parameters, input_names=(),
                 title="", describe=str, cse=True, contacts=None, derivatives=None):
    """C99 source of a model's right-hand side, constraints and energies.

    Parameters
    ----------
    program : Program
    functions : dict
        The function specifications of the numerical model (``dynamics``,
        ``constraints``, ``energy``; others are left out).
    sizes : dict
        ``n_q, n_u, n_q_dep, n_u_dep, n_p, n_r``.
    state_names : sequence of str
        Names of the entries of ``y``, in order.
    parameters : dict
        ``{name: default value}`` in the order of ``p``.
    input_names : sequence of str
        Names of the specified inputs, in the order of ``r``.
    title : str
        What the model is (first line of the header comment).
    describe : callable, optional
        Text of an expression for error messages.
    cse : bool
        Common subexpression elimination of the generated code.
    contacts : sequence of dict, optional
        With the model's contacts (dependent speeds and specified inputs excluded):
        per contact ``name``, ``newton`` (bool: Newton's restitution law, else
        Poisson's) and the C expressions (of ``p[i]``) of ``mu_k``, ``mu_s``,
        ``viscous``, ``restitution``; the file then holds the contact kinematics
        and the contact loop (:mod:`._c_hybrid`: ``kanedyn_contact_*``).
    derivatives : dict, optional
        The model's derivative module as
        :func:`kanedyn.numerics._jacobians.standalone_derivatives` gives it; the
        file then adds ``kanedyn_jacobians``, the exact derivatives, and its
        functions are those of that module (``program``, ``functions`` and
        ``sizes`` are taken from it; ``cse`` is its own), so that the file
        computes what ``model.jacobians`` computes.  Not with ``contacts``.

    Returns
    -------
    str
    """
    if derivatives is not None:
        program, functions, sizes = (derivatives[key] for key in
                                     ("program", "functions", "sizes"))
    n, o = sizes["n_q"], sizes["n_u"]
    l, m = sizes["n_q_dep"], sizes["n_u_dep"]
    n_p, n_r = sizes["n_p"], sizes["n_r"]
    if derivatives is not None:
        parts, work, selected = _derivative_parts(program, functions, sizes, describe,
                                                  derivatives)
    else:
        selected = {name: functions[name] for name in ("dynamics", "constraints", "energy")}
        if "tree" in functions and not m:  # what the module runs: the articulated-body pass
            selected = {"tree": functions["tree"], **selected}
        if contacts:
            selected["contacts"] = functions["contacts"]
        parts, work = [], 0
        for name, (arguments, outputs) in selected.items():
            # the tree pass's statements are its composite sums: no elimination (as in
            # the module, see _c._eliminates)
            src, w = _function_source(program, name, arguments, outputs, describe,
                                      cse and name != "tree")
            parts.append(src)
            work = max(work, w)
    names = list(parameters)
    header = _header(title, state_names, parameters, input_names, sizes,
                     [c["name"] for c in contacts or ()],
                     None if derivatives is None
                     else bool(_parameter_columns(selected, sizes)))
    defines = [f"#define KD_NQ {n}", f"#define KD_NU {o}", f"#define KD_NQDEP {l}",
               f"#define KD_NUDEP {m}", f"#define KD_NP {n_p}", f"#define KD_NR {n_r}",
               f"#define KD_NW {work}",
               f"#define KANEDYN_NQ {n}", f"#define KANEDYN_NU {o}",
               f"#define KANEDYN_NQDEP {l}", f"#define KANEDYN_NUDEP {m}",
               f"#define KANEDYN_NSTATES {n + o}", f"#define KANEDYN_NP {n_p}",
               f"#define KANEDYN_NR {n_r}", *solver_source(selected, sizes)]
    solve = []
    if derivatives is not None:  # after the model's solve, on which it builds
        defines += ["#define KD_JAC_SHARED 1", *jacobian_solve_defines(selected, sizes)]
        solve = [_c_runtime.JACOBIAN_SOLVE, _JACOBIANS]
    public = _PUBLIC % {
        "states": _list([_c_string(s) for s in state_names], '""'),
        "parameters": _list([_c_string(s) for s in names], "NULL"),
        "values": _list([repr(float(parameters[k])) for k in names], "0.0"),
        "inputs": _list([_c_string(s.removesuffix("(t)")) for s in input_names], "NULL")}
    tail = ([_contact_source(contacts), DENSE_OUTPUT, "#define KD_GENERAL_CONTACTS 1", BRENT,
             SEGMENT, GENERAL, IMPACTS, SLIDE, HYBRID] if contacts else [])
    return "\n".join([header, _c_runtime.PRELUDE, "#include <stdlib.h>", _PI, *defines,
                      *parts, _c_runtime.LINALG, *solve, DORMAND_PRINCE, PROJECTION, public,
                      *tail])


def _derivative_parts(program, functions, sizes, describe, derivatives):
    """``(sources, work, selected)``: the generated functions of the file with the
    exact derivatives, listed as the derivative module lists them
    (:func:`~._c._function_sources`: the dynamics, or the articulated-body pass,
    with the derivatives that take its values), the work-array doubles they
    need and the functions selected (``{name: (arguments, outputs)}``)."""
    first = derivatives["share"][0]
    selected = {name: functions[name] for name in dict.fromkeys(
        (first, "jacobians", "dynamics", "constraints", "energy"))}
    parts, work = [], 0
    for src, _, w, _ in _function_sources(program, selected, sizes, describe,
                                          derivatives["cse"], False, derivatives["plain"],
                                          derivatives["share"]):
        parts.append(src.replace(PIECE_MARK, ""))
        work = max(work, w)
    return parts, work, selected


def _jacobian_lines(constants):
    """The header's description of ``kanedyn_jacobians`` (``constants``: whether
    its columns include the parameters')."""
    return ["  int kanedyn_jacobians(double t, const double *y, const double *p,",
            "                        const double *r, double *ydot, double *jacobian,",
            "                        double *constraint_jacobian);",
            "      The exact derivatives of ydot (as kanedyn's model.jacobians): ydot",
            "      itself, and jacobian, KANEDYN_JROWS x KANEDYN_JCOLS row by row: the",
            "      rows of ydot, then those of the KANEDYN_NUDEP multipliers of the",
            "      velocity constraints; the columns of the KANEDYN_NSTATES states,",
            "      then of the KANEDYN_NR inputs r"
            + (", then of the KANEDYN_NP parameters p." if constants else "."),
            "      constraint_jacobian (NULL: not wanted): the KANEDYN_NCON constraint",
            "      rows of kanedyn_constraints by the state, KANEDYN_NCON x",
            "      KANEDYN_NSTATES.", ""]


def _header(title, state_names, parameters, input_names, sizes, contacts=(),
            jacobian_parameters=None):
    n, o = sizes["n_q"], sizes["n_u"]
    l, m = sizes["n_q_dep"], sizes["n_u_dep"]
    lines = [f"{title or 'a kanedyn model'}", "",
             f"Generated by kanedyn {__version__}: standalone C99, no Python needed.",
             "Compile: cc -c -std=c99 -O2 model.c   (link the program with -lm;",
             "a program run only on the x86-64 CPU that compiles it, one with AVX, may",
             "add -mavx, as kanedyn builds its own modules: not an FMU or a library",
             "for other machines)", "",
             "Interface (every array is double, in the orders listed below):", "",
             "  int kanedyn_rhs(double t, const double *y, const double *p,",
             "                  const double *r, double *ydot);",
             "      The state derivative ydot = [q', u'] (KANEDYN_NSTATES entries) at",
             "      time t [s] and state y (KANEDYN_NSTATES entries).  Dependent speeds",
             "      are eliminated with the velocity constraints; their derivatives come",
             "      from the acceleration constraints (as kanedyn's model.rhs).",
             "  int kanedyn_constraints(double t, const double *y, const double *p,",
             "                          const double *r, double *residual);",
             "      Constraint residuals, zero when satisfied: KANEDYN_NQDEP",
             "      configuration constraints, then KANEDYN_NUDEP velocity constraints.",
             "  int kanedyn_energy(double t, const double *y, const double *p,",
             "                     const double *r, double *energy);",
             "      energy[0] kinetic, energy[1] potential [J] (NAN when the model",
             "      declares no potential energy).",
             "  int kanedyn_project(double t, double *y, const double *p, const double *r);",
             "      Projects y in place onto the constraints: the dependent coordinates,",
             "      then the dependent speeds, by Newton's method with the independent",
             "      ones fixed (as kanedyn's model.consistent_state).",
             "  int kanedyn_advance(double t0, double t1, double *y, const double *p,",
             "                      const double *r, const double *r_rate, double rtol,",
             "                      double atol, double project_tol, double *step,",
             "                      long *steps);",
             "      Integrates y in place from t0 to t1 > t0 [s]: Dormand-Prince 5(4)",
             "      with SciPy's RK45 step-size control (relative and absolute",
             "      tolerances rtol, atol); inputs r + (t - t0) r_rate (r_rate NULL:",
             "      held); after an accepted step whose largest constraint residual",
             "      exceeds project_tol (0: never) the state is projected as by",
             "      kanedyn_project.  *step: the step to try first (0: chosen), on",
             "      return the next one; *steps is increased by the steps taken.", "",
             *([] if jacobian_parameters is None else _jacobian_lines(jacobian_parameters)),
             "  p: the KANEDYN_NP parameters (kanedyn_default_parameters holds the",
             "     values the model was built with); r: the KANEDYN_NR specified",
             "     inputs at time t (NULL when KANEDYN_NR is 0).",
             "  Return codes: 0 success; 1 singular mass matrix or constraint",
             "  Jacobian (ydot unspecified); 2 out of memory (large models use a heap",
             "  work array); 3 a derivative not finite, 4 step size too small",
             "  (kanedyn_advance; y then holds the last accepted state).  The functions",
             "  are reentrant (no global state).",
             "  Data: kanedyn_state_names, kanedyn_parameter_names, kanedyn_input_names",
             "  (arrays of strings; a single unused entry when a count is 0).", "",
             f"States y (KANEDYN_NSTATES = {n + o}: {n} coordinates q, {l} of them "
             f"dependent, then {o} speeds u, {m} of them dependent):"]
    lines += [f"  y[{k}] = {name}" for k, name in enumerate(state_names)]
    lines.append(f"Parameters p (KANEDYN_NP = {len(parameters)}), default values:")
    lines += [f"  p[{k}] = {name} = {float(value)!r}"
              for k, (name, value) in enumerate(parameters.items())]
    lines.append(f"Specified inputs r (KANEDYN_NR = {len(input_names)}):")
    lines += [f"  r[{k}] = {name.removesuffix('(t)')}"
              for k, name in enumerate(input_names)] or ["  none"]
    if contacts:
        lines += [f"Contacts (KD_NC = {len(contacts)}): {', '.join(contacts)}.",
                  "  Their modes, events and impacts: kanedyn_contact_start,",
                  "  kanedyn_contact_advance (co-simulation), kanedyn_contact_derivatives,",
                  "  kanedyn_contact_indicators, kanedyn_contact_update (model exchange),",
                  "  on z = [y, work of friction, work of all contact forces] and a state",
                  "  of kanedyn_contact_state_size() bytes; kanedyn_contact_message says",
                  "  why a call returned 5."]
    body = "\n".join((" * " + line).rstrip() for line in lines)
    return "/*\n" + body.replace("*/", "* /") + "\n */"
