"""The compiled kernel of the solve of
:class:`~kanedyn.modeling.offshore.BladeElementMomentum` (``modeling`` calls up into
this layer for it, on its first solve: ``FACADES`` in ``tests/test_architecture.py``).

One fixed source, compiled once and cached like the models' modules
(:func:`~._c_build.load_fixed_module`), loaded on the first solve.  It runs the
solver of ``modeling/offshore/_blade_element_momentum.py`` (the residual of Ning's one
equation, the brackets, the safeguarded Newton steps) on each annulus in turn
as scalars, where NumPy runs it on all annuli at once: the same steps, one
call instead of a NumPy call per operation and step (the cost of a solve in an
integration, where about 150 annuli are solved at every right-hand side).  Its
angles agree with NumPy's within the solver's tolerance (both end where two
points 0.8e-10 rad apart bracket the root; ``tests/test_oc3_bem.py``).

``solve(phi, a, kp, cn, ct, ratio, theta, guess, annulus, solidity,
tip_exponent, hub_exponent, grid, lift, drag, lift_slope, drag_slope, flags)``
    for each of the M inflows (``float64`` arrays of M: ``ratio`` the
    inflow's :math:`V_x/V_y`, ``theta`` twist plus pitch, rad, ``guess`` the
    angles to start from, read when ``flags & 4``; ``annulus`` its annulus,
    ``int32``), writes the inflow angle and, at it, the axial induction, the
    tangential :math:`k'` and the normal and tangential coefficients (M each,
    in ``phi, a, kp, cn, ct``).  Per annulus (n each): the local solidity and
    Prandtl's exponents; the polars as ``grid`` (G angles of attack, rad) and
    the n rows of G values of the lift and drag coefficients and of their
    slopes on each interval (n x G, C order).  ``flags``: 1 the tip loss, 2
    the hub loss, 4 a guess.  Returns the number of inflows with no bracket
    (their outputs are NaN).
"""

from __future__ import annotations

from ._c_build import load_fixed_module

__all__ = ["kernel"]

#: changes whenever the source's meaning changes (part of the cache key)
_GENERATION = "kanedyn BEM solve 1"

_SOURCE = r"""
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>

#define KD_PI 3.14159265358979323846
#define KD_EPS 1e-6          /* the brackets keep this far from phi = 0 and pi */
#define KD_TOLERANCE 1e-10   /* on the inflow angle */
#define KD_HALF_GAP (0.4 * KD_TOLERANCE)
#define KD_MAX_ITERATIONS 100

typedef struct {
    const double *solidity, *tip, *hub, *grid, *lift, *drag, *lift_slope, *drag_slope;
    Py_ssize_t G;
    int tip_loss, hub_loss;
} kd_rotor;

typedef struct { double residual, a, kp, cn, ct; } kd_state;

/* the residual and what goes with it at inflow angle phi (NumPy's _state) */
static kd_state kd_evaluate(const kd_rotor *r, Py_ssize_t i, double phi, double ratio,
                            double theta) {
    kd_state out;
    double s = sin(phi), c = cos(phi);
    double alpha = fmod(phi - theta + KD_PI, 2 * KD_PI);
    if (alpha < 0) alpha += 2 * KD_PI;
    alpha -= KD_PI;
    /* the grid's interval: numpy.searchsorted(grid, alpha) - 1, within 0 .. G - 2 */
    Py_ssize_t lo = 0, hi = r->G;
    while (lo < hi) {
        Py_ssize_t mid = (lo + hi) / 2;
        if (r->grid[mid] < alpha) lo = mid + 1; else hi = mid;
    }
    Py_ssize_t j = lo - 1;
    if (j < 0) j = 0;
    if (j > r->G - 2) j = r->G - 2;
    Py_ssize_t at = i * r->G + j;
    double offset = alpha - r->grid[j];
    double cl = r->lift[at] + r->lift_slope[at] * offset;
    double cd = r->drag[at] + r->drag_slope[at] * offset;
    double cn = cl * c + cd * s, ct = cl * s - cd * c;
    double F = 1.0;
    if (r->tip_loss || r->hub_loss) {
        double inverse = 1.0 / fmax(fabs(s), 1e-12);
        if (r->tip_loss) F = 2.0 / KD_PI * acos(exp(r->tip[i] * inverse));
        if (r->hub_loss) F = F * (2.0 / KD_PI) * acos(exp(r->hub[i] * inverse));
        F = fmax(F, 1e-12);
    }
    double four_fs = 4.0 * F * s;
    double k = r->solidity[i] * cn / (four_fs * s);
    double kp = r->solidity[i] * ct / (four_fs * c);
    double a = k / (1.0 + k);
    if (k > 2.0 / 3.0) {  /* Buhl's empirical thrust above a = 0.4 */
        double g1 = 2.0 * F * k - (10.0 / 9.0 - F);
        double g2 = fmax(2.0 * F * k - F * (4.0 / 3.0 - F), 0.0);
        double g3 = 2.0 * F * k - (25.0 / 9.0 - 2.0 * F);
        a = fabs(g3) < 1e-6 ? 1.0 - 1.0 / (2.0 * sqrt(fmax(g2, 1e-12)))
                            : (g1 - sqrt(g2)) / g3;
    }
    if (phi > 0) {
        out.residual = s / (1.0 - a) - ratio * c * (1.0 - kp);
    } else {  /* the propeller brake */
        a = k > 1.0 ? k / (k - 1.0) : 0.0;
        out.residual = s * (1.0 - k) - ratio * c * (1.0 - kp);
    }
    out.a = a; out.kp = kp; out.cn = cn; out.ct = ct;
    return out;
}

/* one inflow: the bracket (after the guess's neighbourhood), then the safeguarded
   Newton steps of _safeguarded_newton; 0 where no bracket is found */
static int kd_solve_one(const kd_rotor *r, Py_ssize_t i, double ratio, double theta,
                        int has_guess, double g, double *phi, kd_state *state) {
    double lo = NAN, hi = NAN, flo = NAN, fhi = NAN, newton = NAN;
    if (has_guess) {
        /* stay on the guess's side of 0 and pi/2: the branches differ there */
        double edge = g > KD_PI / 2 ? KD_PI / 2 : (g > 0 ? KD_EPS : -KD_PI / 4);
        double top = g > KD_PI / 2 ? KD_PI - KD_EPS : (g > 0 ? KD_PI / 2 : -KD_EPS);
        double a = fmax(g - 0.05, edge), b = fmin(g + 0.05, top);
        double c = fmin(fmax(g - KD_HALF_GAP, a), b), d = fmin(fmax(g + KD_HALF_GAP, a), b);
        double fa = kd_evaluate(r, i, a, ratio, theta).residual;
        double fb = kd_evaluate(r, i, b, ratio, theta).residual;
        double fc = kd_evaluate(r, i, c, ratio, theta).residual;
        double fd = kd_evaluate(r, i, d, ratio, theta).residual;
        if (fa * fc <= 0) { lo = a; hi = c; flo = fa; fhi = fc; }
        else if (fc * fd <= 0) { lo = c; hi = d; flo = fc; fhi = fd; }
        else if (fd * fb <= 0) { lo = d; hi = b; flo = fd; fhi = fb; }
        if (!isnan(lo)) newton = c - fc * (d - c) / (fd - fc);
    }
    static const double ends[3][2] = {{KD_EPS, KD_PI / 2}, {-KD_PI / 4, -KD_EPS},
                                      {KD_PI / 2, KD_PI - KD_EPS}};
    for (int k = 0; k < 3 && isnan(lo); k++) {
        double fa = kd_evaluate(r, i, ends[k][0], ratio, theta).residual;
        double fb = kd_evaluate(r, i, ends[k][1], ratio, theta).residual;
        if (fa * fb <= 0) { lo = ends[k][0]; hi = ends[k][1]; flo = fa; fhi = fb; }
    }
    if (isnan(lo)) return 0;
    int side = 0;
    double below = lo, above = lo;
    kd_state at_below, at_above;
    for (int it = 0; it < KD_MAX_ITERATIONS; it++) {
        double step = fhi - flo;
        double falsi = step != 0 ? (lo * fhi - hi * flo) / step : (lo + hi) / 2;
        double x = (newton > lo && newton < hi) ? newton : fmin(fmax(falsi, lo), hi);
        below = fmax(x - KD_HALF_GAP, lo);
        above = fmin(x + KD_HALF_GAP, hi);
        at_below = kd_evaluate(r, i, below, ratio, theta);
        at_above = kd_evaluate(r, i, above, ratio, theta);
        double fbelow = at_below.residual, fabove = at_above.residual;
        if (fbelow * fabove <= 0) break;
        int left = flo * fabove > 0;  /* root in (above, hi): above replaces lo */
        if (left) { lo = above; flo = fabove; } else { hi = below; fhi = fbelow; }
        /* Illinois: an end kept twice in a row has its residual halved */
        if (left && side == 1) fhi /= 2;
        if (!left && side == -1) flo /= 2;
        side = left ? 1 : -1;
        newton = below - fbelow * (above - below) / (fabove - fbelow);
    }
    int pick = fabs(at_above.residual) < fabs(at_below.residual);
    *phi = pick ? above : below;
    *state = pick ? at_above : at_below;
    return 1;
}

static int kd_view(PyObject *obj, Py_buffer *view, Py_ssize_t size, Py_ssize_t count,
                   int writable, const char *name) {
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) < 0) return -1;
    if (view->itemsize != size || view->len != size * count) {
        PyErr_Format(PyExc_ValueError, "%s: %zd items of %zd bytes expected", name, count,
                     size);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

#define KD_ARRAYS 17

static PyObject *kd_solve(PyObject *self, PyObject *args) {
    PyObject *obj[KD_ARRAYS];
    int flags;
    if (!PyArg_ParseTuple(args, "OOOOOOOOOOOOOOOOOi", &obj[0], &obj[1], &obj[2], &obj[3],
                          &obj[4], &obj[5], &obj[6], &obj[7], &obj[8], &obj[9], &obj[10],
                          &obj[11], &obj[12], &obj[13], &obj[14], &obj[15], &obj[16],
                          &flags))
        return NULL;
    static const char *names[KD_ARRAYS] = {
        "phi", "a", "kp", "cn", "ct", "ratio", "theta", "guess", "annulus", "solidity",
        "tip_exponent", "hub_exponent", "grid", "lift", "drag", "lift_slope",
        "drag_slope"};
    Py_buffer view[KD_ARRAYS];
    Py_ssize_t M = PyObject_Length(obj[5]), n = PyObject_Length(obj[9]);
    Py_ssize_t G = PyObject_Length(obj[12]);
    if (M < 0 || n < 0 || G < 2) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "grid: 2 angles at least");
        return NULL;
    }
    int got = 0, failed = 0;
    for (; got < KD_ARRAYS; got++) {
        Py_ssize_t count = got <= 8 ? M : (got <= 11 ? n : (got == 12 ? G : n * G));
        Py_ssize_t size = got == 8 ? (Py_ssize_t)sizeof(int32_t) : (Py_ssize_t)sizeof(double);
        if (kd_view(obj[got], &view[got], size, count, got < 5, names[got]) < 0) break;
    }
    Py_ssize_t lost = 0;
    if (got == KD_ARRAYS) {
        double *out[5];
        for (int k = 0; k < 5; k++) out[k] = (double *)view[k].buf;
        const double *ratio = view[5].buf, *theta = view[6].buf, *guess = view[7].buf;
        const int32_t *annulus = view[8].buf;
        kd_rotor rotor = {view[9].buf, view[10].buf, view[11].buf, view[12].buf,
                          view[13].buf, view[14].buf, view[15].buf, view[16].buf, G,
                          flags & 1, (flags & 2) != 0};
        for (Py_ssize_t m = 0; m < M && !failed; m++)
            if (annulus[m] < 0 || annulus[m] >= n) failed = 1;
        if (!failed) {
            Py_BEGIN_ALLOW_THREADS
            for (Py_ssize_t m = 0; m < M; m++) {
                double phi;
                kd_state state;
                if (kd_solve_one(&rotor, annulus[m], ratio[m], theta[m], flags & 4,
                                 guess[m], &phi, &state)) {
                    out[0][m] = phi; out[1][m] = state.a; out[2][m] = state.kp;
                    out[3][m] = state.cn; out[4][m] = state.ct;
                } else {
                    for (int k = 0; k < 5; k++) out[k][m] = NAN;
                    lost++;
                }
            }
            Py_END_ALLOW_THREADS
        }
    }
    for (int k = 0; k < got; k++) PyBuffer_Release(&view[k]);
    if (got < KD_ARRAYS) return NULL;
    if (failed) {
        PyErr_SetString(PyExc_ValueError, "annulus: an index outside 0 .. n - 1");
        return NULL;
    }
    return PyLong_FromSsize_t(lost);
}

static PyMethodDef kd_methods[] = {
    {"solve", kd_solve, METH_VARARGS, "solve each inflow's annulus for its inflow angle"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef kd_module = {PyModuleDef_HEAD_INIT, "@NAME@", NULL, -1,
                                       kd_methods};

PyMODINIT_FUNC PyInit_@NAME@(void) { return PyModule_Create(&kd_module); }
"""


def kernel():
    """The compiled kernel module (built on first use, then from the cache).

    Raises
    ------
    CompilerError
        No C compiler, or the compilation failed.
    """
    return load_fixed_module(_GENERATION, _SOURCE)
