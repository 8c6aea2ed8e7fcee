"""C source of the compiled integration loop (part of every generated module).

Two methods, both with SciPy's ``solve_ivp`` conventions for tolerances,
output times and events:

``RK45``
    Explicit Dormand-Prince 5(4) with the step-size control, initial step
    selection and quartic dense output of SciPy's ``RK45`` (safety factor 0.9,
    step factors within [0.2, 10], RMS error norm of
    ``err / (atol + max(|y|, |y_new|) rtol)``).
``Rosenbrock23``
    A linearly implicit (Rosenbrock) 2(3) pair for stiff problems, the
    modified Rosenbrock formula of Shampine & Reichelt (1997), with a
    finite-difference Jacobian and its own continuous extension.

Event functions are Python callables ``event(t, y)`` with optional
``terminal`` and ``direction`` attributes; zeros are located with Brent's
method on the continuous extension.  Constraint drift is projected away after
any accepted step whose largest constraint residual exceeds ``project_tol``.

Singular configurations (:class:`kanedyn.numerics.SingularityMonitor`) are
looked for as the run goes, with a ``singular_threshold``: each step is
screened with bounds on the singular values of the velocity-constraint matrix
at its ends (the matrix of the drift check), and only a step that may dip below
the threshold is examined and its minimum refined, so that a run keeps the
minima it found and nothing of the steps it took.

The loop also samples the energy balance (``kanedyn.simulation._energy_check``):
where a panel of ``KD_WORK_PANEL`` accepted steps ends (a piece of the solution
starts with a panel of one step; a projection, a terminal event and the end of
the run end a piece), the power :math:`dE/dt` along the right-hand side, a
central difference (half width ``KD_POWER_STEP`` times the step), whose two
energies give the stored and the potential energy there (their mean), and the
work of what the stored energy does not hold, the power integrated along the
parabola through the ends of the panel and of the one before.  It returns at
most ``KD_KEPT_SAMPLES`` samples (every second one dropped when full, the last
kept; ``"balance"``: rows of time, power, stored and potential energy, work),
the work's error estimate, the largest drift of the trapezoidal rule's sum
from it (``"work_error"``), and the work of the power's magnitude, the energy
that flowed in and out (``"work_flow"``).  Sampling every step instead cost
8-19 % of the loop's time (``docs/benchmarks.md``).

The loop ends early, keeping what was computed, when the run's stop flag is
raised (a stop signal, read at every step: ``"interrupted"``) or its time limit
has passed (``timeout`` s of computing, 0: none; checked every 16 steps, next to
the stop flag: ``"timed_out"``).
"""

#: Python-free C shared by the compiled loop and the standalone export: the
#: constraint residual and the projection onto the constraints (needs
#: ``kd_eval_constraints`` with its four outputs h, dh/dq, B = dc/du, c, and
#: ``kd_lu_solve``)
PROJECTION = r"""
/* largest constraint residual at (t, y) (inputs r, work w); the
   velocity-constraint matrix B = dc/du there into B (m x o, row-major) */
static double kd_residual_at(double t, const double *y, const double *p, const double *r,
                             double *w, double *B) {
#if KD_HAS_DEP
    double h[KD_SZ(KD_NQDEP)], J[KD_SZ(KD_NQDEP * KD_NQ)], b[KD_SZ(KD_NUDEP)];
    kd_eval_constraints(t, y, p, r, w, h, J, B, b);
    double worst = 0.0;
    for (int i = 0; i < KD_NQDEP; ++i) worst = fmax(worst, fabs(h[i]));
    for (int i = 0; i < KD_NUDEP; ++i) worst = fmax(worst, fabs(b[i]));
    return worst;
#else
    (void)t; (void)y; (void)p; (void)r; (void)w; (void)B;
    return 0.0;
#endif
}

/* dependent coordinates, then dependent speeds, by Newton's method with the
   independent ones fixed (as NumericModel.consistent_state): 0, or 1 if singular */
static int kd_project_at(double t, double *y, const double *p, const double *r, double *w) {
#if KD_HAS_DEP
    double h[KD_SZ(KD_NQDEP)], J[KD_SZ(KD_NQDEP * KD_NQ)];
    double B[KD_SZ(KD_NUDEP * KD_NU)], b[KD_SZ(KD_NUDEP)];
    for (int it = 0; it < 50 && KD_NQDEP > 0; ++it) {
        kd_eval_constraints(t, y, p, r, w, h, J, B, b);
        double worst = 0.0;
        for (int i = 0; i < KD_NQDEP; ++i) worst = fmax(worst, fabs(h[i]));
        if (worst <= 1e-12) break;
        double Jd[KD_SZ(KD_NQDEP * KD_NQDEP)];
        for (int i = 0; i < KD_NQDEP; ++i)
            for (int j = 0; j < KD_NQDEP; ++j) Jd[i * KD_NQDEP + j] = J[i * KD_NQ + KD_NQ - KD_NQDEP + j];
        if (kd_lu_solve(KD_NQDEP, Jd, h, 1) != 0) return 1;
        for (int i = 0; i < KD_NQDEP; ++i) y[KD_NQ - KD_NQDEP + i] -= h[i];
    }
    /* dependent speeds by Newton's method on the velocity residuals b (one
       step when they are linear in the speeds) */
    for (int it = 0; it < 50 && KD_NUDEP > 0; ++it) {
        kd_eval_constraints(t, y, p, r, w, h, J, B, b);
        double worst = 0.0;
        for (int i = 0; i < KD_NUDEP; ++i) worst = fmax(worst, fabs(b[i]));
        if (worst <= 1e-13 || (it > 0 && worst <= 1e-10)) break;
        double Bd[KD_SZ(KD_NUDEP * KD_NUDEP)];
        for (int i = 0; i < KD_NUDEP; ++i)
            for (int j = 0; j < KD_NUDEP; ++j) Bd[i * KD_NUDEP + j] = B[i * KD_NU + KD_NUI + j];
        if (kd_lu_solve(KD_NUDEP, Bd, b, 1) != 0) return 1;
        for (int i = 0; i < KD_NUDEP; ++i) y[KD_NQ + KD_NUI + i] -= b[i];
    }
#else
    (void)t; (void)y; (void)p; (void)r; (void)w;
#endif
    return 0;
}
"""

#: Python-free C shared by the compiled loop and the standalone export: the RMS
#: norm of the step-size control and the Dormand-Prince 5(4) tableau
DORMAND_PRINCE = r"""
/* y = x, n doubles: a loop (with a run-time n, memcpy is a call; a state is short) */
static inline void kd_copy(double *y, const double *x, int n) {
    for (int i = 0; i < n; ++i) y[i] = x[i];
}

static double kd_rms(const double *x, const double *scale, int n) {
    double s = 0.0;
    for (int i = 0; i < n; ++i) { double v = x[i] / scale[i]; s += v * v; }
    return sqrt(s / n);
}

/* Dormand-Prince 5(4) coefficients (the values SciPy's RK45 uses) */
static const double kd_C[7] = {0.0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1.0, 1.0};
static const double kd_A[7][6] = {
    {0, 0, 0, 0, 0, 0},
    {1.0 / 5, 0, 0, 0, 0, 0},
    {3.0 / 40, 9.0 / 40, 0, 0, 0, 0},
    {44.0 / 45, -56.0 / 15, 32.0 / 9, 0, 0, 0},
    {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729, 0, 0},
    {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656, 0},
    {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84}};
static const double kd_E[7] = {-71.0 / 57600, 0, 71.0 / 16695, -71.0 / 1920,
                               17253.0 / 339200, -22.0 / 525, 1.0 / 40};

/* the continuous extension of a Dormand-Prince step (t_old, y_old, h, Q: see
   kd_dopri_extension): y_old + h Q [x, x^2, x^3, x^4] at x = (t - t_old) / h */
static inline void kd_dopri_dense(const double *y_old, double t_old, double h, const double *Q,
                                  double t, double *out) {
    double x = (t - t_old) / h;
    double p1 = x, p2 = x * x, p3 = p2 * x, p4 = p3 * x;
    for (int i = 0; i < KD_NX; ++i) {
        const double *q = Q + 4 * i;
        out[i] = y_old[i] + h * (q[0] * p1 + q[1] * p2 + q[2] * p3 + q[3] * p4);
    }
}

/* a right-hand side for the steppers: out = f(t, y); nonzero ends the integration */
typedef int (*KdRhsFn)(void *ctx, double t, const double *y, double *out);

/* one Dormand-Prince 5(4) attempt of step h from (t, y), f = f(t, y): the stages K
   (K[6] = f at the new state), y_new, and the RMS norm of the error estimate
   err / (atol + max(|y|, |y_new|) rtol) */
static inline int kd_dopri_attempt(KdRhsFn fn, void *ctx, double t, const double *y,
                                   const double *f, double h, double rtol,
                                   const double *atol, double *K, double *y_new,
                                   double *err_norm) {
    double ytmp[KD_NX], err[KD_NX], scale[KD_NX];
    kd_copy(K, f, KD_NX);
    for (int s = 1; s < 7; ++s) {
        for (int i = 0; i < KD_NX; ++i) {
            double acc = 0.0;
            for (int j = 0; j < s; ++j) acc += kd_A[s][j] * K[j * KD_NX + i];
            ytmp[i] = y[i] + h * acc;
        }
        if (s == 6) kd_copy(y_new, ytmp, KD_NX);
        int status = fn(ctx, t + kd_C[s] * h, ytmp, K + s * KD_NX);
        if (status != 0) return status;
    }
    for (int i = 0; i < KD_NX; ++i) {
        double e = 0.0;
        for (int s = 0; s < 7; ++s) e += kd_E[s] * K[s * KD_NX + i];
        err[i] = e * h;
        scale[i] = atol[i] + fmax(fabs(y[i]), fabs(y_new[i])) * rtol;
    }
    *err_norm = kd_rms(err, scale, KD_NX);
    return 0;
}

/* the initial step of a method of error order err_order from (t, y), f = f(t, y),
   towards a span of length interval > 0 in direction dir (Hairer, Norsett & Wanner;
   SciPy's select_initial_step), at most max_step */
static inline int kd_first_step(KdRhsFn fn, void *ctx, double t, const double *y,
                                const double *f, double dir, double interval, double rtol,
                                const double *atol, double max_step, int err_order,
                                double *h_abs) {
    double scale[KD_NX], tmp[KD_NX], y1[KD_NX], f1[KD_NX];
    for (int i = 0; i < KD_NX; ++i) scale[i] = atol[i] + fabs(y[i]) * rtol;
    double d0 = kd_rms(y, scale, KD_NX), d1 = kd_rms(f, scale, KD_NX), h0;
    h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    h0 = fmin(h0, interval);
    for (int i = 0; i < KD_NX; ++i) y1[i] = y[i] + h0 * dir * f[i];
    int status = fn(ctx, t + h0 * dir, y1, f1);
    if (status != 0) return status;
    for (int i = 0; i < KD_NX; ++i) tmp[i] = f1[i] - f[i];
    double d2 = kd_rms(tmp, scale, KD_NX) / h0, h1;
    if (d1 <= 1e-15 && d2 <= 1e-15) h1 = fmax(1e-6, h0 * 1e-3);
    else h1 = pow(0.01 / fmax(d1, d2), 1.0 / (err_order + 1));
    *h_abs = fmin(fmin(100 * h0, h1), fmin(interval, max_step));
    return 0;
}
"""

#: the coefficients of RK45's continuous extension (the compiled loop's and the
#: contact segments')
DENSE_OUTPUT = r"""
/* Dormand-Prince 5(4) dense output (SciPy's RK45's) */
static const double kd_P[7][4] = {
    {1, -8048581381.0 / 2820520608, 8663915743.0 / 2820520608, -12715105075.0 / 11282082432},
    {0, 0, 0, 0},
    {0, 131558114200.0 / 32700410799, -68118460800.0 / 10900136933, 87487479700.0 / 32700410799},
    {0, -1754552775.0 / 470086768, 14199869525.0 / 1410260304, -10690763975.0 / 1880347072},
    {0, 127303824393.0 / 49829197408, -318862633887.0 / 49829197408, 701980252875.0 / 199316789632},
    {0, -282668133.0 / 205662961, 2019193451.0 / 616988883, -1453857185.0 / 822651844},
    {0, 40617522.0 / 29380423, -110615467.0 / 29380423, 69997945.0 / 29380423}};
"""

BRENT = r"""
/* a function of time: g(t) into *g; nonzero: an error (in the loop: a Python error) */
typedef int (*KdRootFn)(void *ctx, double t, double *g);

/* Brent's method for a zero of fn in [a, b] (fa, fb: its values there), the loop's,
   the ensemble's and the FMU's impacts (SciPy's brentq with xtol = rtol = 4 eps) */
static int kd_brent(KdRootFn fn, void *ctx, double a, double b, double fa, double fb,
                    double *root) {
    const double eps = 2.220446049250313e-16, xtol = 4 * eps, rtol = 4 * eps;
    double c = a, fc = fa, d = b - a, e = d;
    for (int iter = 0; iter < 200; ++iter) {
        if ((fb > 0 && fc > 0) || (fb < 0 && fc < 0)) { c = a; fc = fa; d = e = b - a; }
        if (fabs(fc) < fabs(fb)) { a = b; b = c; c = a; fa = fb; fb = fc; fc = fa; }
        double tol = 2 * eps * fabs(b) + 0.5 * (xtol + rtol * fabs(b));
        double m = 0.5 * (c - b);
        if (fabs(m) <= tol || fb == 0.0) { *root = b; return 0; }
        if (fabs(e) >= tol && fabs(fa) > fabs(fb)) {
            double s = fb / fa, p, q;
            if (a == c) { p = 2 * m * s; q = 1 - s; }
            else {
                double qq = fa / fc, rr = fb / fc;
                p = s * (2 * m * qq * (qq - rr) - (b - a) * (rr - 1));
                q = (qq - 1) * (rr - 1) * (s - 1);
            }
            if (p > 0) q = -q; else p = -p;
            if (2 * p < fmin(3 * m * q - fabs(tol * q), fabs(e * q))) { e = d; d = p / q; }
            else { d = m; e = m; }
        } else { d = m; e = m; }
        a = b; fa = fb;
        b += fabs(d) > tol ? d : (m > 0 ? tol : -tol);
        if (fn(ctx, b, &fb) != 0) return -1;
    }
    *root = b;
    return 0;
}
"""

_LOOP = r"""
/* ------------------------------------------------------------------------
   Compiled integration loop
   ------------------------------------------------------------------------ */
typedef struct { double *data; npy_intp n, cap; } KdBuf;

#include <time.h>
/* A long run lets Python's other threads work (the optimized build of this model,
   which then points KD_RHS_CORE at its code) every KD_YIELD_SECONDS: longer than
   the interpreter's switch interval (5 ms), so that a waiting thread has asked for
   the interpreter by then and the release hands it over (released more often, the
   waiting thread never gets to ask and the loop takes the interpreter back). */
#define KD_YIELD_SECONDS 0.02
static double kd_clock(void) {
#if defined(CLOCK_MONOTONIC)
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
#else
    return (double)clock() / CLOCKS_PER_SEC;
#endif
}

/* what a loop does between its steps besides reading the stop flag, every 16th call
   (count: the loop's): 1 once the deadline (kd_clock's time, 0: none) has passed;
   otherwise a moment for Python's other threads every KD_YIELD_SECONDS */
static int kd_pause(unsigned long *count, double deadline, double *next_yield) {
    if ((++*count & 15) != 0) return 0;
    double now = kd_clock();
    if (deadline > 0 && now >= deadline) return 1;
    if (now >= *next_yield) {
        Py_BEGIN_ALLOW_THREADS
        Py_END_ALLOW_THREADS
        *next_yield = kd_clock() + KD_YIELD_SECONDS;
    }
    return 0;
}

static int kd_buf_push(KdBuf *b, const double *x, npy_intp k) {
    if (b->n + k > b->cap) {
        npy_intp cap = b->cap ? 2 * b->cap : 1024;
        while (cap < b->n + k) cap *= 2;
        double *d = (double *)PyMem_Realloc(b->data, sizeof(double) * cap);
        if (d == NULL) { PyErr_NoMemory(); return -1; }
        b->data = d; b->cap = cap;
    }
    memcpy(b->data + b->n, x, sizeof(double) * k);
    b->n += k;
    return 0;
}

static PyObject *kd_buf_array(KdBuf *b, npy_intp rows, npy_intp cols) {
    npy_intp dims[2] = {rows, cols};
    PyObject *a = PyArray_SimpleNew(cols < 0 ? 1 : 2, dims, NPY_DOUBLE);
    if (a != NULL && b->n) memcpy(PyArray_DATA((PyArrayObject *)a), b->data, sizeof(double) * b->n);
    return a;
}

typedef struct {
    KdModel *model;
    PyObject *events;        /* sequence of callables or NULL */
    int n_events;
    long nfev, njev, nlu;
    int method;              /* 0 RK45, 1 Rosenbrock23 */
    int singular;            /* the derivative failed (singular, not finite) at t_singular */
    double t_singular;
    double *y_singular;      /* KD_NX (the caller's) */
    double *W, *LU;          /* Rosenbrock iteration matrices (heap) */
    double *exact;           /* the module's exact derivatives: their work (heap), or NULL */
    const KdJacobianInfo *jacobians;  /* and those derivatives (one for the whole run) */
    /* continuous extension of the last step */
    double t_old, h;
    double *y_old;           /* KD_NX (the caller's) */
    double *Q;               /* KD_NX * 4 (the caller's): RK45: y = y_old + h Q [x, x^2, x^3, x^4]; R23: Q[:,0]=k1, Q[:,1]=k2 */
} KdIntegrator;

static const double kd_r23_d = 0.29289321881345248; /* 1 / (2 + sqrt(2)) */
static const double kd_r23_e32 = 7.4142135623730950; /* 6 + sqrt(2) */

static void kd_dense(const KdIntegrator *ig, double t, double *out) {
    if (ig->method == 0) {
        kd_dopri_dense(ig->y_old, ig->t_old, ig->h, ig->Q, t, out);
    } else {
        double x = (t - ig->t_old) / ig->h, d = kd_r23_d;
        double a = x * (1.0 - x) / (1.0 - 2.0 * d), b = x * (x - 2.0 * d) / (1.0 - 2.0 * d);
        for (int i = 0; i < KD_NX; ++i)
            out[i] = ig->y_old[i] + ig->h * (a * ig->Q[4 * i] + b * ig->Q[4 * i + 1]);
    }
}

/* values of the specified inputs at (t, y) for a raw state vector */
static int kd_inputs_at(KdModel *model, double t, const double *y, double *r) {
    if (KD_NR == 0) return 0;
    if (model->table != NULL)  /* in C, no state array needed */
        return kd_pieces_eval(model->pieces, KD_NR, model->input_names, t, r);
    npy_intp dims[1] = {KD_NX};
    PyObject *ya = PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    if (ya == NULL) return -1;
    memcpy(PyArray_DATA((PyArrayObject *)ya), y, sizeof(double) * KD_NX);
    int bad = kd_inputs(model, t, ya, r);
    Py_DECREF(ya);
    return bad;
}

/* the half width of the power's central difference: this fraction of the step */
#define KD_POWER_STEP 1e-4

/* the stored energy, kinetic plus declared potential, and the potential (0 where none
   is declared: the function's NAN) */
static int kd_stored_energy(KdModel *model, double t, const double *y, double *e,
                            double *potential) {
    double r[KD_SZ_R], kinetic;
    if (kd_inputs_at(model, t, y, r) != 0) return -1;
    kd_eval_energy(t, y, model->p, r, model->work, &kinetic, potential);
    if (isnan(*potential)) *potential = 0.0;
    *e = kinetic + *potential;
    return 0;
}

/* a sample of the energy balance at a state of the run */
typedef struct { double t, power, energy, potential, work; } KdSample;

/* the sample at (t, y), derivative f there (its work left as it is): dE/dt along f,
   the central difference over (t - delta, t + delta), the times kept within
   [t_lo, t_hi] (inputs may be defined on the time span only; at its ends the quotient
   then holds half of dE/dt's explicit time part, for one step); the energies there,
   the means of the two (to delta^2) */
static int kd_sample(KdModel *model, double t, const double *y, const double *f, double delta,
                     double t_lo, double t_hi, KdSample *out) {
    double ahead[KD_NX], behind[KD_NX], e1, e0, v1, v0;
    delta = fabs(delta);
    for (int i = 0; i < KD_NX; ++i) { ahead[i] = y[i] + delta * f[i]; behind[i] = y[i] - delta * f[i]; }
    if (kd_stored_energy(model, fmin(t + delta, t_hi), ahead, &e1, &v1) != 0
        || kd_stored_energy(model, fmax(t - delta, t_lo), behind, &e0, &v0) != 0) return -1;
    out->t = t;
    out->power = (e1 - e0) / (2 * delta);
    out->energy = 0.5 * (e1 + e0);
    out->potential = 0.5 * (v1 + v0);
    return 0;
}

/* accepted steps in a panel (a piece's first panel: one), and the most samples kept
   (_PANEL_STEPS and _KEPT_SAMPLES of kanedyn.simulation._energy_check) */
#define KD_WORK_PANEL 4
#define KD_KEPT_SAMPLES 2048

/* the energy balance summed by the loop, panel by panel */
typedef struct {
    double t_lo, t_hi;      /* the time span (kd_sample) */
    int known;              /* the open panel's start sampled (0: a piece starts) */
    int has_prev;           /* a panel before it in the piece */
    int steps;              /* accepted steps in the open panel */
    KdSample a;             /* the open panel's start */
    double t_prev, p_prev;  /* the start of the panel before it */
    double drift;           /* the trapezoidal sum minus the parabolic one */
    double error, flow;     /* the largest |drift| (work_error); the work of |power| */
    KdBuf kept;             /* samples kept: every stride-th, a KdSample's 5 doubles each */
    long seen, stride;
    KdSample last;          /* the sample taken last */
} KdWork;

/* keep a sample: every stride-th of them, the stride doubled (every other one dropped)
   when KD_KEPT_SAMPLES are kept */
static int kd_keep(KdWork *w, const KdSample *s) {
    w->last = *s;
    if (w->seen++ % w->stride != 0) return 0;
    if (w->kept.n == 5 * KD_KEPT_SAMPLES) {
        for (npy_intp k = 1; k < KD_KEPT_SAMPLES / 2; ++k)
            memcpy(w->kept.data + 5 * k, w->kept.data + 10 * k, 5 * sizeof(double));
        w->kept.n = 5 * (KD_KEPT_SAMPLES / 2);
        w->stride *= 2;
        if ((w->seen - 1) % w->stride != 0) return 0;
    }
    return kd_buf_push(&w->kept, (const double *)s, 5);
}

/* a piece of the solution starts at (t, y), derivative f */
static int kd_work_start(KdModel *model, KdWork *w, double t, const double *y, const double *f,
                         double delta) {
    if (kd_sample(model, t, y, f, delta, w->t_lo, w->t_hi, &w->a) != 0) return -1;
    w->known = 1; w->has_prev = 0;
    return kd_keep(w, &w->a);
}

/* the open panel ends at (t, y), derivative f, where the next one starts: the power
   over it is the parabola through its ends and the start of the panel before (the
   line on a piece's first panel), p_a + beta s + gamma s^2 (s from its start), the
   work integrated along it */
static int kd_work_end(KdModel *model, KdWork *w, double t, const double *y, const double *f,
                       double delta) {
    KdSample b;
    double h = t - w->a.t, gamma = 0.0;
    if (kd_sample(model, t, y, f, delta, w->t_lo, w->t_hi, &b) != 0) return -1;
    if (w->has_prev) {
        double a = w->t_prev - w->a.t;
        gamma = ((b.power - w->a.power) / h - (w->p_prev - w->a.power) / a) / (h - a);
        w->drift += gamma * h * h * h / 6.0;
        w->error = fmax(w->error, fabs(w->drift));
    }
    double beta = (b.power - w->a.power) / h - gamma * h;
    w->flow += 0.5 * fabs(h) * (fabs(w->a.power) + fabs(b.power));
    b.work = w->a.work + h * (w->a.power + h * (beta / 2.0 + h * gamma / 3.0));
    w->t_prev = w->a.t; w->p_prev = w->a.power; w->has_prev = 1;
    w->a = b;
    w->steps = 0;
    return kd_keep(w, &b);
}

static int kd_f(KdIntegrator *ig, double t, const double *y, double *out) {
    ig->nfev++;
    double r[KD_SZ_R];
    if (kd_inputs_at(ig->model, t, y, r) != 0) return -1;
    int bad = KD_RHS_CORE(t, y, ig->model->p, r, ig->model->work, out) != 0;
    for (int i = 0; i < KD_NX && !bad; ++i) bad = !isfinite(out[i]);
    if (bad) {
        for (int i = 0; i < KD_NX; ++i) out[i] = NAN;  /* the step is rejected */
        if (!ig->singular) {
            ig->singular = 1; ig->t_singular = t;
            memcpy(ig->y_singular, y, sizeof(double) * KD_NX);
        }
    }
    return 0;
}

/* event value g(t, y); -1 on a Python error */
static int kd_event(KdIntegrator *ig, int k, double t, const double *y, double *g) {
    npy_intp dims[1] = {KD_NX};
    PyObject *ya = PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    if (ya == NULL) return -1;
    memcpy(PyArray_DATA((PyArrayObject *)ya), y, sizeof(double) * KD_NX);
    PyObject *args[2];
    args[0] = PyFloat_FromDouble(t);
    args[1] = ya;
    PyObject *fn = PySequence_Fast_GET_ITEM(ig->events, k);
    PyObject *res = args[0] ? PyObject_Vectorcall(fn, args, 2, NULL) : NULL;
    Py_XDECREF(args[0]);
    Py_DECREF(ya);
    if (res == NULL) return -1;
    *g = PyFloat_AsDouble(res);
    Py_DECREF(res);
    if (*g == -1.0 && PyErr_Occurred()) return -1;
    return 0;
}

/* whether an event whose values went from g_old to g_new over a step has a zero there
   in its direction (> 0: upward, < 0: downward, 0: either) */
static inline int kd_event_active(double g_old, double g_new, double direction) {
    int up = g_old <= 0 && g_new >= 0, down = g_old >= 0 && g_new <= 0;
    return (up && direction > 0) || (down && direction < 0) || ((up || down) && direction == 0);
}

/* the n roots (and the events they belong to) sorted by time along dir */
static void kd_sort_roots(double *roots, int *which, int n, double dir) {
    for (int a = 1; a < n; ++a)
        for (int b = a; b > 0 && dir * (roots[b] - roots[b - 1]) < 0; --b) {
            double tr = roots[b]; roots[b] = roots[b - 1]; roots[b - 1] = tr;
            int tw = which[b]; which[b] = which[b - 1]; which[b - 1] = tw;
        }
}

/* a function of the state along the loop's continuous extension: g(t, y) into *g, -1
   on a Python error; as a KdRootFn of t with its KdAlong */
typedef int (*KdAlongFn)(KdIntegrator *ig, void *ctx, double t, const double *y, double *g);
typedef struct { KdIntegrator *ig; KdAlongFn fn; void *ctx; } KdAlong;
static int kd_along(void *along, double t, double *g) {
    const KdAlong *a = (const KdAlong *)along;
    double y[KD_NX];
    kd_dense(a->ig, t, y);
    return a->fn(a->ig, a->ctx, t, y, g);
}

static int kd_event_at(KdIntegrator *ig, void *ctx, double t, const double *y, double *g) {
    return kd_event(ig, *(const int *)ctx, t, y, g);
}

/* largest constraint residual (-1 on a Python error in the inputs); the
   velocity-constraint matrix B = dc/du there into B (m x o, row-major) */
static double kd_residual(KdModel *model, double t, const double *y, double *B) {
    double r[KD_SZ_R];
    if (KD_NQDEP + KD_NUDEP > 0 && kd_inputs_at(model, t, y, r) != 0) return -1.0;
    return kd_residual_at(t, y, model->p, r, model->work, B);
}

/* kd_project_at with the inputs at (t, y): 0, 1 if singular, -1 on a Python error */
static int kd_project(KdModel *model, double t, double *y) {
    double r[KD_SZ_R];
    if (KD_NQDEP + KD_NUDEP > 0 && kd_inputs_at(model, t, y, r) != 0) return -1;
    return kd_project_at(t, y, model->p, r, model->work);
}

/* ------------------------------------------------------------------------
   Singular configurations, found as the run goes (the compiled form of
   kanedyn.numerics.SingularityMonitor): local minima along the motion of
   rho = sigma_min / sigma_max of the velocity-constraint matrix B = dc/du below
   a threshold.  Each accepted step is screened with what the drift check
   computed anyway: by Weyl's inequality no singular value moves by more than
   |B(t) - B(t_end)| within the step, taken to be at most 2 d, d = |B_b - B_a|_F
   (B is smooth along an accepted step); with sigma_min >= lo and sigma_max <=
   |B|_F at an end, the ratio stays above (lo - 2d) / (|B|_F + 2d).  Only a
   step whose bound is below the threshold is examined: the rate of rho along
   the motion at its ends (a central difference along q', as
   SingularityMonitor._rate), a change of sign from falling to rising whose dip
   may reach below the threshold, and Brent's method on the continuous
   extension for the minimum.  Memory: the minima found.
   ------------------------------------------------------------------------ */
#define KD_NOISE 1e-12  /* a change of rho below this is round-off (as _NOISE) */
#define KD_SCREEN 2.0   /* the factor on |B_b - B_a|_F of the screen */
typedef struct {
    double threshold, displacement;  /* threshold 0: off */
    double dir;                      /* direction of integration */
    KdBuf t, y;                      /* minima found: times and states */
    long examined;                   /* steps the screen did not clear */
    double t_at, *y_at;              /* the start of the current step (KD_NX, the caller's) */
#if KD_HAS_UDEP
    double *B;                       /* B there (KD_NUDEP * KD_NU, the caller's) */
    double lo, fro;                  /* sigma_min >= lo, sigma_max <= fro there */
    int known;                       /* the rate there computed */
    double rate, ratio;              /* the rate there; the ratio (nan: not yet) */
#endif
} KdMonitor;

#if KD_HAS_UDEP
/* sigma_min / sigma_max of B (m x o, m <= o) by one-sided Jacobi rotations of its
   rows (singular values to high relative accuracy); 0 for B = 0, nan if not finite */
static double kd_sv_ratio(const double *B) {
    const int m = KD_NUDEP, o = KD_NU;
    double A[KD_NUDEP * KD_NU], norm2[KD_NUDEP];
    for (int i = 0; i < m * o; ++i) { if (!isfinite(B[i])) return NAN; A[i] = B[i]; }
    for (int sweep = 0; sweep < 60; ++sweep) {
        int rotated = 0;
        for (int i = 0; i < m; ++i) {  /* the rows' squared norms, updated by the rotations */
            double s = 0.0;
            for (int k = 0; k < o; ++k) s += A[i * o + k] * A[i * o + k];
            norm2[i] = s;
        }
        for (int i = 0; i < m - 1; ++i)
            for (int j = i + 1; j < m; ++j) {
                double *a = A + i * o, *b = A + j * o, gamma = 0.0;
                for (int k = 0; k < o; ++k) gamma += a[k] * b[k];
                if (gamma == 0.0 || fabs(gamma) <= 1e-15 * sqrt(norm2[i] * norm2[j])) continue;
                double zeta = (norm2[j] - norm2[i]) / (2.0 * gamma);
                double tn = (zeta >= 0 ? 1.0 : -1.0) / (fabs(zeta) + sqrt(1.0 + zeta * zeta));
                double c = 1.0 / sqrt(1.0 + tn * tn), s = c * tn;
                for (int k = 0; k < o; ++k) {
                    double x = a[k], z = b[k];
                    a[k] = c * x - s * z; b[k] = s * x + c * z;
                }
                norm2[i] -= tn * gamma; norm2[j] += tn * gamma;
                rotated = 1;
            }
        if (!rotated) break;
    }
    double smin = INFINITY, smax = 0.0;
    for (int i = 0; i < m; ++i) {
        double s = 0.0;
        for (int k = 0; k < o; ++k) s += A[i * o + k] * A[i * o + k];
        s = sqrt(s);
        smin = fmin(smin, s); smax = fmax(smax, s);
    }
    return smax > 0.0 ? smin / smax : 0.0;
}

/* cheap bounds sigma_min(B) >= *lo and sigma_max(B) <= *fro = |B|_F: with G = B B^T
   = L L^T (Cholesky), lambda_min(G) >= 1 / trace(G^-1) = 1 / |L^-1|_F^2, less the
   round-off of forming and factoring G; *lo = 0 where G is not positive definite */
static void kd_sv_bounds(const double *B, double *lo, double *fro) {
    const int m = KD_NUDEP, o = KD_NU;
    double G[KD_NUDEP * KD_NUDEP], norm2 = 0.0;
    for (int k = 0; k < m * o; ++k) norm2 += B[k] * B[k];
    *fro = sqrt(norm2);
    *lo = 0.0;
    if (!(norm2 > 0.0) || !isfinite(norm2)) return;
    for (int i = 0; i < m; ++i)
        for (int j = 0; j <= i; ++j) {
            double s = 0.0;
            for (int k = 0; k < o; ++k) s += B[i * o + k] * B[j * o + k];
            G[i * m + j] = s;
        }
    for (int j = 0; j < m; ++j) {  /* L in the lower triangle of G */
        double d = G[j * m + j];
        for (int k = 0; k < j; ++k) d -= G[j * m + k] * G[j * m + k];
        if (!(d > 0.0)) return;
        d = sqrt(d);
        G[j * m + j] = d;
        for (int i = j + 1; i < m; ++i) {
            double s = G[i * m + j];
            for (int k = 0; k < j; ++k) s -= G[i * m + k] * G[j * m + k];
            G[i * m + j] = s / d;
        }
    }
    double trace = 0.0, x[KD_NUDEP];
    for (int c = 0; c < m; ++c) {  /* column c of L^-1 by forward substitution */
        for (int i = 0; i < m; ++i) {
            double s = i == c ? 1.0 : 0.0;
            for (int k = c; k < i; ++k) s -= G[i * m + k] * x[k];
            x[i] = i < c ? 0.0 : s / G[i * m + i];
            if (i >= c) trace += x[i] * x[i];
        }
    }
    double lambda = 1.0 / trace - 2.0 * (KD_NU + KD_NUDEP + 2) * 2.220446049250313e-16 * norm2;
    *lo = lambda > 0.0 ? sqrt(lambda) : 0.0;
}

/* B = dc/du at (t, y); -1 on a Python error (inputs) */
static int kd_constraint_matrix(KdModel *model, double t, const double *y, double *B) {
    double h[KD_SZ(KD_NQDEP)], J[KD_SZ(KD_NQDEP * KD_NQ)], b[KD_NUDEP], r[KD_SZ_R];
    if (kd_inputs_at(model, t, y, r) != 0) return -1;
    kd_eval_constraints(t, y, model->p, r, model->work, h, J, B, b);
    return 0;
}

/* the rate of rho along the motion at (t, y), times the direction of integration
   (a minimum: from negative to positive in the order of the steps); 1/s, never
   exactly zero: d rho/dt taken as 1 at rest or where rho does not change.  f:
   the derivative there, or NULL (then the kinematic rates are evaluated; the
   right-hand side writes q' before its solve, which may fail this close to a
   singular position). */
static int kd_monitor_rate(KdIntegrator *ig, KdMonitor *mon, double t, const double *y,
                           const double *f, double *rate) {
    double qd[KD_NQ];
    if (f != NULL) memcpy(qd, f, sizeof(qd));
    else {
        double r[KD_SZ_R], out[KD_NX];
        if (kd_inputs_at(ig->model, t, y, r) != 0) return -1;
        (void)KD_RHS_CORE(t, y, ig->model->p, r, ig->model->work, out);
        memcpy(qd, out, sizeof(qd));
    }
    double speed = 0.0;
    for (int i = 0; i < KD_NQ; ++i) speed = fmax(speed, fabs(qd[i]));
    *rate = mon->dir;
    if (!(speed > 0.0) || !isfinite(speed)) return 0;
    double dt = mon->displacement / speed, ahead[KD_NX], behind[KD_NX];
    double Ba[KD_NUDEP * KD_NU], Bb[KD_NUDEP * KD_NU];
    memcpy(ahead, y, sizeof(ahead)); memcpy(behind, y, sizeof(behind));
    for (int i = 0; i < KD_NQ; ++i) { ahead[i] += dt * qd[i]; behind[i] -= dt * qd[i]; }
    if (kd_constraint_matrix(ig->model, t + dt, ahead, Ba) != 0
            || kd_constraint_matrix(ig->model, t - dt, behind, Bb) != 0) return -1;
    double ra = kd_sv_ratio(Ba), rb = kd_sv_ratio(Bb);
    if (!isfinite(ra) || !isfinite(rb) || fabs(ra - rb) <= KD_NOISE) return 0;
    double g = (ra - rb) / (2.0 * dt);
    if (isfinite(g)) *rate = mon->dir * g;
    return 0;
}

static int kd_monitor_rate_at(KdIntegrator *ig, void *ctx, double t, const double *y, double *g) {
    return kd_monitor_rate(ig, (KdMonitor *)ctx, t, y, NULL, g);
}

/* the start of a step at (t, y): the first state, or one projected */
static int kd_monitor_start(KdIntegrator *ig, KdMonitor *mon, double t, const double *y) {
    if (kd_constraint_matrix(ig->model, t, y, mon->B) != 0) return -1;
    kd_sv_bounds(mon->B, &mon->lo, &mon->fro);
    mon->t_at = t;
    memcpy(mon->y_at, y, sizeof(double) * KD_NX);
    mon->known = 0;
    mon->ratio = NAN;
    return 0;
}

/* the start of the current step counts as a minimum when its ratio is below the
   threshold: called for the first state and the last (a run that starts at, or
   stops near, a singular position) */
static int kd_monitor_here(KdMonitor *mon) {
    if (mon->lo >= mon->threshold * mon->fro) return 0;  /* ratio >= lo / fro */
    if (kd_sv_ratio(mon->B) < mon->threshold
            && (kd_buf_push(&mon->t, &mon->t_at, 1) || kd_buf_push(&mon->y, mon->y_at, KD_NX)))
        return -1;
    return 0;
}

/* the step of ig's continuous extension, accepted up to (t, y) (derivative f
   there, or NULL; B there, or NULL to evaluate it): screen it, find a minimum in
   it, and make its end the start of the next step.  -1 on a Python error. */
static int kd_monitor_step(KdIntegrator *ig, KdMonitor *mon, double t, const double *y,
                           const double *f, const double *B_end) {
    double B[KD_NUDEP * KD_NU], lo, fro, d = 0.0;
    if (B_end != NULL) memcpy(B, B_end, sizeof(B));
    else if (kd_constraint_matrix(ig->model, t, y, B) != 0) return -1;
    kd_sv_bounds(B, &lo, &fro);
    for (int k = 0; k < KD_NUDEP * KD_NU; ++k) d += (B[k] - mon->B[k]) * (B[k] - mon->B[k]);
    d = KD_SCREEN * sqrt(d);
    double bound = fmax((mon->lo - d) / (mon->fro + d), (lo - d) / (fro + d));
    int known = 0;
    double rate = 1.0, ratio = NAN;
    if (!(bound >= mon->threshold)) {  /* also for nan */
        mon->examined++;
        if (!mon->known) {
            if (kd_monitor_rate(ig, mon, ig->t_old, ig->y_old, NULL, &mon->rate) != 0) return -1;
            mon->known = 1;
        }
        if (kd_monitor_rate(ig, mon, t, y, f, &rate) != 0) return -1;
        known = 1;
        /* a minimum inside the step lies no deeper than the ends' ratios minus
           their rates over half the step: refine only those that may be below */
        int turns = mon->rate < 0.0 && rate >= 0.0;
        if (turns && isnan(mon->ratio)) mon->ratio = kd_sv_ratio(mon->B);
        if (turns) ratio = kd_sv_ratio(B);
        double lowest = fmin(mon->ratio, ratio)
                        - 0.5 * fabs(t - ig->t_old) * fmax(fabs(mon->rate), fabs(rate));
        if (turns && lowest < mon->threshold) {
            double root, yr[KD_NX], Br[KD_NUDEP * KD_NU];
            KdAlong along = {ig, kd_monitor_rate_at, mon};
            if (kd_brent(kd_along, &along, ig->t_old, t, mon->rate, rate, &root) != 0)
                return -1;
            kd_dense(ig, root, yr);
            if (kd_constraint_matrix(ig->model, root, yr, Br) != 0) return -1;
            if (kd_sv_ratio(Br) < mon->threshold
                    && (kd_buf_push(&mon->t, &root, 1) || kd_buf_push(&mon->y, yr, KD_NX)))
                return -1;
        }
    }
    memcpy(mon->B, B, sizeof(B));
    mon->t_at = t;
    memcpy(mon->y_at, y, sizeof(double) * KD_NX);
    mon->lo = lo; mon->fro = fro;
    mon->known = known; mon->rate = rate; mon->ratio = ratio;
    return 0;
}
#else
static int kd_monitor_start(KdIntegrator *ig, KdMonitor *mon, double t, const double *y) {
    (void)ig; (void)mon; (void)t; (void)y;
    return 0;
}
static int kd_monitor_here(KdMonitor *mon) {
    (void)mon;
    return 0;
}
static int kd_monitor_step(KdIntegrator *ig, KdMonitor *mon, double t, const double *y,
                           const double *f, const double *B_end) {
    (void)ig; (void)mon; (void)t; (void)y; (void)f; (void)B_end;
    return 0;
}
#endif

""" + DENSE_OUTPUT + r"""
/* one attempted RK45 step of size h from (t, y, f): y_new, f_new (= K[6]), error norm */
/* kd_f as a KdRhsFn (ctx: the KdIntegrator) */
static int kd_f_stepper(void *ctx, double t, const double *y, double *out) {
    return kd_f((KdIntegrator *)ctx, t, y, out);
}

/* the continuous extension of an accepted Dormand-Prince step from its stages:
   y = y_old + h Q [x, x^2, x^3, x^4] (Q row-major, 4 per component) */
static void kd_dopri_extension(const double *K, double *Q) {
    for (int i = 0; i < KD_NX; ++i)
        for (int j = 0; j < 4; ++j) {
            double s = 0.0;
            for (int k = 0; k < 7; ++k) s += K[k * KD_NX + i] * kd_P[k][j];
            Q[4 * i + j] = s;
        }
}

/* Jacobian df/dy (row-major): the module's exact derivatives where it has them
   (kd_jacobians; the inputs do not follow the state then: the caller's choice),
   else forward differences; df/dt by a forward difference */
static int kd_jacobian(KdIntegrator *ig, double t, const double *y, const double *f,
                       double *J, double *T) {
    const double sqrt_eps = 1.4901161193847656e-08;
    double yp[KD_NX], fp[KD_NX];
    memcpy(yp, y, sizeof(double) * KD_NX);
    const KdJacobianInfo *info = ig->jacobians;
    int exact = ig->exact != NULL;
    if (exact) {
        double r[KD_SZ_R];
        if (kd_inputs_at(ig->model, t, y, r) != 0) return -1;
        double *D = ig->exact + info->scratch, *C = D + (KD_NX + KD_NUDEP) * info->columns;
        /* a singular system: the differences (their non-finite values reject the step) */
        exact = info->core(t, y, ig->model->p, r, ig->model->work, ig->exact, fp, D, C) == 0;
        for (int i = 0; i < KD_NX && exact; ++i)
            for (int j = 0; j < KD_NX; ++j) J[i * KD_NX + j] = D[i * info->columns + j];
    }
    for (int j = 0; j < KD_NX && !exact; ++j) {
        double dj = sqrt_eps * fmax(fabs(y[j]), 1e-5);
        yp[j] = y[j] + dj;
        dj = yp[j] - y[j];
        if (kd_f(ig, t, yp, fp) != 0) return -1;
        for (int i = 0; i < KD_NX; ++i) J[i * KD_NX + j] = (fp[i] - f[i]) / dj;
        yp[j] = y[j];
    }
    double dt = sqrt_eps * fmax(fabs(t), 1e-5);
    if (kd_f(ig, t + dt, y, fp) != 0) return -1;
    for (int i = 0; i < KD_NX; ++i) T[i] = (fp[i] - f[i]) / dt;
    ig->njev++;
    return 0;
}

/* one attempted Rosenbrock 2(3) step; k1, k2 kept for the continuous extension */
static int kd_r23_try(KdIntegrator *ig, double t, const double *y, const double *f, double h,
                      const double *J, const double *T, double rtol, const double *atol,
                      double *y_new, double *f_new, double *k1, double *k2, double *err_norm,
                      int *singular) {
    const double d = kd_r23_d, e32 = kd_r23_e32;
    double *W = ig->W, *LU = ig->LU;
    const size_t bytes = sizeof(double) * KD_NX * KD_NX;
    double k3[KD_NX], f1[KD_NX], ytmp[KD_NX], b[KD_NX];
    for (int i = 0; i < KD_NX; ++i)
        for (int j = 0; j < KD_NX; ++j) W[i * KD_NX + j] = (i == j) - h * d * J[i * KD_NX + j];
    *singular = 0;
    ig->nlu++;
    memcpy(LU, W, bytes);
    for (int i = 0; i < KD_NX; ++i) k1[i] = f[i] + h * d * T[i];
    if (kd_lu_solve(KD_NX, LU, k1, 1) != 0) { *singular = 1; return 0; }
    for (int i = 0; i < KD_NX; ++i) ytmp[i] = y[i] + 0.5 * h * k1[i];
    if (kd_f(ig, t + 0.5 * h, ytmp, f1) != 0) return -1;
    memcpy(LU, W, bytes);
    for (int i = 0; i < KD_NX; ++i) k2[i] = f1[i] - k1[i];
    if (kd_lu_solve(KD_NX, LU, k2, 1) != 0) { *singular = 1; return 0; }
    for (int i = 0; i < KD_NX; ++i) { k2[i] += k1[i]; y_new[i] = y[i] + h * k2[i]; }
    if (kd_f(ig, t + h, y_new, f_new) != 0) return -1;
    memcpy(LU, W, bytes);
    for (int i = 0; i < KD_NX; ++i)
        b[i] = f_new[i] - e32 * (k2[i] - f1[i]) - 2.0 * (k1[i] - f[i]) + h * d * T[i];
    if (kd_lu_solve(KD_NX, LU, b, 1) != 0) { *singular = 1; return 0; }
    memcpy(k3, b, sizeof(b));
    double err[KD_NX], scale[KD_NX];
    for (int i = 0; i < KD_NX; ++i) {
        err[i] = h / 6.0 * (k1[i] - 2.0 * k2[i] + k3[i]);
        scale[i] = atol[i] + fmax(fabs(y[i]), fabs(y_new[i])) * rtol;
    }
    *err_norm = kd_rms(err, scale, KD_NX);
    return 0;
}

/* a Python callback's ValueError (an input's or event's failure, named by
   kanedyn): its text into text[size], the error cleared; 0 for any other error */
static int kd_callback_failure(char *text, size_t size) {
    if (!PyErr_ExceptionMatches(PyExc_ValueError)) return 0;
    PyObject *type, *value, *traceback;
    PyErr_Fetch(&type, &value, &traceback);
    PyObject *str = value ? PyObject_Str(value) : NULL;
    const char *utf8 = str ? PyUnicode_AsUTF8(str) : NULL;
    snprintf(text, size, "%s", utf8 ? utf8 : "a Python callback raised ValueError");
    Py_XDECREF(str); Py_XDECREF(type); Py_XDECREF(value); Py_XDECREF(traceback);
    PyErr_Clear();
    return 1;
}

/* the stop flag of a run (RunGuard.stop_flag of kanedyn.simulation._run_guard): a
   1-entry int32 array that the run's signal handler sets to 1, read where a loop
   checks for signals, between its steps; None: a flag that stays 0 */
static const volatile npy_int32 *kd_stop_flag(PyObject *obj) {
    static const npy_int32 never = 0;
    if (obj == NULL || obj == Py_None) return &never;
    if (!PyArray_Check(obj) || PyArray_TYPE((PyArrayObject *)obj) != NPY_INT32
            || PyArray_SIZE((PyArrayObject *)obj) != 1) {
        PyErr_SetString(PyExc_TypeError, "stop must be a 1-entry int32 array or None");
        return NULL;
    }
    return (const volatile npy_int32 *)PyArray_DATA((PyArrayObject *)obj);
}

/* an error inside the loop: Ctrl-C (a KeyboardInterrupt raised in a Python callback
   or by the signal check) keeps what was computed, and so does a callback's
   ValueError, whose text becomes the message; any other error propagates */
#define KD_FAIL do { \
        if (PyErr_ExceptionMatches(PyExc_KeyboardInterrupt)) { \
            PyErr_Clear(); status = -1; failed = 1; interrupted = 1; \
            message = "interrupted"; goto finish; } \
        if (kd_callback_failure(error_text, sizeof(error_text))) { \
            status = -1; failed = 1; message = error_text; goto finish; } \
        goto done; } while (0)

/* integrate(t0, t1, y0, t_eval, rtol, atol, max_step, first_step, method, events,
             project_tol, dense[, singular_threshold, displacement, stop, timeout, energy])
             -> dict
   (singular_threshold 0, the default: no search for singular configurations;
   stop: see kd_stop_flag; timeout: seconds of computing, 0, the default: none;
   energy false: no work summed, "work" all zero: what the energy check costs) */
static PyObject *KdModel_integrate(KdModel *self, PyObject *args) {
    double t0, t1, rtol, max_step, first_step, project_tol, timeout = 0.0;
    PyObject *y0obj, *tevalobj, *atolobj, *events, *method_obj, *stopobj = NULL;
    int dense, energy = 1;
    KdMonitor mon;
    memset(&mon, 0, sizeof(mon));
    /* the state-sized storage (before any jump past it: variable sizes) */
    double mon_y_at[KD_NX], ig_y_singular[KD_NX], ig_y_old[KD_NX], ig_Q[KD_NX * 4];
    double y[KD_NX], f[KD_NX], y_new[KD_NX], f_new[KD_NX], K[7 * KD_NX];
    double T[KD_NX], k1[KD_NX], k2[KD_NX], atol[KD_NX];
    mon.y_at = mon_y_at;
#if KD_HAS_UDEP
    double mon_B[KD_NUDEP * KD_NU];
    mon.B = mon_B;
#endif
    mon.displacement = 1e-7;
    if (!PyArg_ParseTuple(args, "ddOOdOddOOdp|ddOdp", &t0, &t1, &y0obj, &tevalobj, &rtol,
                          &atolobj, &max_step, &first_step, &method_obj, &events, &project_tol,
                          &dense, &mon.threshold, &mon.displacement, &stopobj, &timeout,
                          &energy))
        return NULL;
    const volatile npy_int32 *stop = kd_stop_flag(stopobj);
    if (stop == NULL) return NULL;
    double deadline = timeout > 0 ? kd_clock() + timeout : 0.0;
    const int monitoring = KD_NUDEP > 0 && mon.threshold > 0.0;
    const char *method_name = PyUnicode_AsUTF8(method_obj);
    if (method_name == NULL) return NULL;
    KdIntegrator ig;
    memset(&ig, 0, sizeof(ig));
    ig.model = self;
    ig.y_singular = ig_y_singular;
    ig.y_old = ig_y_old;
    ig.Q = ig_Q;
    if (strcmp(method_name, "RK45") == 0) ig.method = 0;
    else if (strcmp(method_name, "Rosenbrock23") == 0) ig.method = 1;
    else { PyErr_Format(PyExc_ValueError, "unknown compiled method %s", method_name); return NULL; }

    PyObject *keep_y = NULL, *keep_a = NULL;
    const double *y0 = kd_vector(y0obj, KD_NX, &keep_y, "y0");
    if (y0 == NULL) return NULL;
    const double *av = kd_vector(atolobj, KD_NX, &keep_a, "atol");
    if (av == NULL) { Py_XDECREF(keep_y); return NULL; }
    memcpy(atol, av, sizeof(atol));
    Py_XDECREF(keep_a);

    PyArrayObject *teval = NULL;
    if (tevalobj != Py_None) {
        teval = (PyArrayObject *)PyArray_FROMANY(tevalobj, NPY_DOUBLE, 1, 1, NPY_ARRAY_IN_ARRAY);
        if (teval == NULL) { Py_XDECREF(keep_y); return NULL; }
    }
    const double *te = teval ? (const double *)PyArray_DATA(teval) : NULL;
    npy_intp n_teval = teval ? PyArray_SIZE(teval) : 0, next_eval = 0;

    /* events */
    PyObject *evseq = NULL;
    if (events != Py_None) {
        evseq = PySequence_Fast(events, "events must be a sequence");
        if (evseq == NULL) { Py_XDECREF(keep_y); Py_XDECREF(teval); return NULL; }
        ig.n_events = (int)PySequence_Fast_GET_SIZE(evseq);
    }
    ig.events = evseq;
    double *ev_dir = (double *)PyMem_Calloc(KD_SZ(ig.n_events), sizeof(double));
    int *ev_term = (int *)PyMem_Calloc(KD_SZ(ig.n_events), sizeof(int));
    double *g_old = (double *)PyMem_Calloc(KD_SZ(ig.n_events), sizeof(double));
    double *g_new = (double *)PyMem_Calloc(KD_SZ(ig.n_events), sizeof(double));
    KdBuf *ev_t = (KdBuf *)PyMem_Calloc(KD_SZ(ig.n_events), sizeof(KdBuf));
    KdBuf *ev_y = (KdBuf *)PyMem_Calloc(KD_SZ(ig.n_events), sizeof(KdBuf));
    KdBuf out_t = {0}, out_y = {0}, dn_t = {0}, dn_y = {0}, dn_q = {0};
    PyObject *result = NULL;
    double *J = NULL;
    int status = 0, failed = 0, interrupted = 0, timed_out = 0, keep_last = 1;
    KdWork work;
    memset(&work, 0, sizeof(work));
    work.stride = 1;
    long projections = 0;
    const char *message = "the integration reached the end of the interval";
    char error_text[512];  /* the message of a callback's ValueError (KD_FAIL) */
    if (!ev_dir || !ev_term || !g_old || !g_new || !ev_t || !ev_y) { PyErr_NoMemory(); goto done; }
    for (int k = 0; k < ig.n_events; ++k) {
        PyObject *fn = PySequence_Fast_GET_ITEM(evseq, k);
        PyObject *a = PyObject_GetAttrString(fn, "direction");
        if (a) { ev_dir[k] = PyFloat_AsDouble(a); Py_DECREF(a); if (PyErr_Occurred()) goto done; }
        else PyErr_Clear();
        a = PyObject_GetAttrString(fn, "terminal");
        if (a) { ev_term[k] = PyObject_IsTrue(a); Py_DECREF(a); if (ev_term[k] < 0) goto done; }
        else PyErr_Clear();
    }

    double dir = t1 >= t0 ? 1.0 : -1.0;
    mon.dir = dir;
    work.t_lo = fmin(t0, t1); work.t_hi = fmax(t0, t1);
    double t = t0;
    J = (double *)PyMem_Malloc(sizeof(double) * KD_NX * KD_NX * 3);
    if (J == NULL) { PyErr_NoMemory(); goto done; }
    ig.W = J + KD_NX * KD_NX;
    ig.LU = ig.W + KD_NX * KD_NX;
    if (ig.method == 1 && KD_JACOBIANS != NULL) {
        const KdJacobianInfo *info = ig.jacobians = KD_JACOBIANS;
        ig.exact = (double *)PyMem_Malloc(sizeof(double) * (info->scratch
            + (KD_NX + KD_NUDEP) * info->columns + info->constraint_rows * KD_NX));
        if (ig.exact == NULL) { PyErr_NoMemory(); goto done; }
    }
    memcpy(y, y0, sizeof(y));
    if (kd_f(&ig, t, y, f) != 0) KD_FAIL;
    if (monitoring && (kd_monitor_start(&ig, &mon, t, y) != 0 || kd_monitor_here(&mon) != 0))
        KD_FAIL;
    for (int k = 0; k < ig.n_events; ++k)
        if (kd_event(&ig, k, t, y, &g_old[k]) != 0) KD_FAIL;
    if (te == NULL) {
        if (kd_buf_push(&out_t, &t, 1) || kd_buf_push(&out_y, y, KD_NX)) KD_FAIL;
    } else {
        while (next_eval < n_teval && te[next_eval] == t) {
            if (kd_buf_push(&out_t, &t, 1) || kd_buf_push(&out_y, y, KD_NX)) KD_FAIL;
            next_eval++;
        }
    }

    /* initial step (Hairer, Norsett & Wanner; SciPy's select_initial_step) */
    double h_abs;
    double interval = fabs(t1 - t0);
    int err_order = ig.method == 0 ? 4 : 2;
    if (first_step > 0) h_abs = first_step;
    else if (interval == 0.0) h_abs = 0.0;
    else if (kd_first_step(kd_f_stepper, &ig, t, y, f, dir, interval, rtol, atol, max_step,
                           err_order, &h_abs) != 0) KD_FAIL;
    double exponent = -1.0 / (err_order + 1);
    double max_factor = ig.method == 0 ? 10.0 : 5.0;

    unsigned long steps_taken = 0;
    double next_yield = kd_clock() + KD_YIELD_SECONDS;
    while (dir * (t1 - t) > 0) {
        if (PyErr_CheckSignals() != 0) KD_FAIL;  /* Ctrl-C: keep what was computed */
        if (*stop) {  /* the run's guard took the signal */
            status = -1; failed = 1; interrupted = 1; message = "interrupted";
            break;
        }
        if (kd_pause(&steps_taken, deadline, &next_yield)) {  /* the time limit */
            status = -1; failed = 1; timed_out = 1;
            message = "the time limit was reached";
            break;
        }
        double min_step = 10 * fabs(nextafter(t, dir * INFINITY) - t);
        if (h_abs > max_step) h_abs = max_step;
        else if (h_abs < min_step) h_abs = min_step;
        int accepted = 0, rejected = 0;
        double h = 0.0, t_new = t, err_norm = 0.0;
        if (ig.method == 1 && kd_jacobian(&ig, t, y, f, J, T) != 0) KD_FAIL;
        while (!accepted) {
            if (h_abs < min_step) {
                failed = 1;
                status = -1;
                message = "Required step size is less than spacing between numbers.";
                break;
            }
            h = h_abs * dir;
            t_new = t + h;
            if (dir * (t_new - t1) > 0) t_new = t1;
            h = t_new - t;
            h_abs = fabs(h);
            if (ig.method == 0) {
                if (kd_dopri_attempt(kd_f_stepper, &ig, t, y, f, h, rtol, atol, K, y_new,
                                     &err_norm) != 0) KD_FAIL;
                kd_copy(f_new, K + 6 * KD_NX, KD_NX);
            } else {
                int singular;
                if (kd_r23_try(&ig, t, y, f, h, J, T, rtol, atol, y_new, f_new, k1, k2,
                               &err_norm, &singular) != 0) KD_FAIL;
                if (singular) err_norm = INFINITY;
            }
            if (err_norm < 1) {
                double factor = err_norm == 0 ? max_factor
                                              : fmin(max_factor, 0.9 * pow(err_norm, exponent));
                if (rejected) factor = fmin(1.0, factor);
                h_abs *= factor;
                accepted = 1;
            } else {
                double factor = 0.9 * pow(err_norm, exponent);
                if (!(factor > 0.2)) factor = 0.2;   /* also for nan */
                h_abs *= factor;
                rejected = 1;
            }
        }
        if (failed) break;
        /* continuous extension of this step */
        ig.t_old = t; ig.h = h;
        kd_copy(ig.y_old, y, KD_NX);
        if (ig.method == 0) {
            kd_dopri_extension(K, ig.Q);
        } else {
            for (int i = 0; i < KD_NX; ++i) { ig.Q[4 * i] = k1[i]; ig.Q[4 * i + 1] = k2[i]; }
        }
        /* events */
        double t_stop = t_new;
        int terminate = 0;
        for (int k = 0; k < ig.n_events; ++k)
            if (kd_event(&ig, k, t_new, y_new, &g_new[k]) != 0) KD_FAIL;
        if (ig.n_events) {
            /* roots of the active events in time order, up to the first terminal one */
            double roots[64];
            int which[64], n_roots = 0;
            for (int k = 0; k < ig.n_events && n_roots < 64; ++k) {
                if (!kd_event_active(g_old[k], g_new[k], ev_dir[k])) continue;
                double root;
                KdAlong along = {&ig, kd_event_at, &k};
                if (kd_brent(kd_along, &along, t, t_new, g_old[k], g_new[k], &root) != 0)
                    KD_FAIL;
                roots[n_roots] = root; which[n_roots] = k; n_roots++;
            }
            kd_sort_roots(roots, which, n_roots, dir);
            for (int a = 0; a < n_roots; ++a) {
                double ye[KD_NX];
                kd_dense(&ig, roots[a], ye);
                int k = which[a];
                if (kd_buf_push(&ev_t[k], &roots[a], 1) || kd_buf_push(&ev_y[k], ye, KD_NX)) KD_FAIL;
                if (ev_term[k]) { terminate = 1; t_stop = roots[a]; break; }
            }
        }
        /* outputs */
        if (te != NULL) {
            while (next_eval < n_teval && dir * (te[next_eval] - t_stop) <= 0) {
                if (dir * (te[next_eval] - t) > 0) {
                    double ye[KD_NX];
                    kd_dense(&ig, te[next_eval], ye);
                    if (kd_buf_push(&out_t, &te[next_eval], 1) || kd_buf_push(&out_y, ye, KD_NX)) KD_FAIL;
                }
                next_eval++;
            }
        }
        if (terminate) {
            kd_dense(&ig, t_stop, y_new);
            t_new = t_stop;
        }
        /* the energy balance, sampled where a piece starts and where a panel ends (a
           terminal event ends the last one: the derivative there evaluated) */
        if (energy) {
            if (!work.known && kd_work_start(self, &work, t, y, f, KD_POWER_STEP * h) != 0)
                KD_FAIL;
            if (++work.steps >= (work.has_prev ? KD_WORK_PANEL : 1) || terminate
                    || dir * (t1 - t_new) <= 0) {
                if (terminate && kd_f(&ig, t_new, y_new, f_new) != 0) KD_FAIL;
                if (kd_work_end(self, &work, t_new, y_new, f_new, KD_POWER_STEP * h) != 0)
                    KD_FAIL;
            }
        }
        if (dense) {
            double head[2] = {t, h};
            if (kd_buf_push(&dn_t, head, 2) || kd_buf_push(&dn_y, y, KD_NX)
                || kd_buf_push(&dn_q, ig.Q, KD_NX * 4)) KD_FAIL;
        }
        int finite = 1;
        for (int i = 0; i < KD_NX; ++i) if (!isfinite(y_new[i])) finite = 0;
        t = t_new;
        kd_copy(y, y_new, KD_NX);
        kd_copy(f, f_new, KD_NX);
        memcpy(g_old, g_new, sizeof(double) * KD_SZ(ig.n_events));
        /* constraint drift, then singular configurations in the step (the
           matrix B of the drift check: no evaluation of its own) */
        double B_end[KD_SZ(KD_NUDEP * KD_NU)];
        int checked = finite && project_tol > 0;
        double residual = checked ? kd_residual(self, t, y, B_end) : 0.0;
        if (residual < 0) KD_FAIL;
        if (monitoring && finite
                && kd_monitor_step(&ig, &mon, t, y, terminate ? NULL : f,
                                   checked ? B_end : NULL) != 0) KD_FAIL;
        if (residual > project_tol) {
            /* the piece ends: its open panel with it, at the state before the projection */
            if (work.steps > 0 && kd_work_end(self, &work, t, y, f, KD_POWER_STEP * h) != 0)
                KD_FAIL;
            int proj = kd_project(self, t, y);
            if (proj < 0) { keep_last = 0; KD_FAIL; }
            if (proj != 0) {
                status = -1; failed = 1; keep_last = 0;  /* y half projected */
                message = "the constraints could not be satisfied by projection (singular "
                          "constraint Jacobian)";
            } else {
                projections++;
                work.known = 0;  /* a new piece: its power at the next step */
                if (kd_f(&ig, t, y, f) != 0) KD_FAIL;
                if (monitoring && kd_monitor_start(&ig, &mon, t, y) != 0) KD_FAIL;
                for (int k = 0; k < ig.n_events; ++k)
                    if (kd_event(&ig, k, t, y, &g_old[k]) != 0) KD_FAIL;
            }
        }
        if (te == NULL) {
            if (kd_buf_push(&out_t, &t, 1) || kd_buf_push(&out_y, y, KD_NX)) KD_FAIL;
        }
        if (failed) break;
        if (terminate) { status = 1; message = "A termination event occurred."; break; }
    }

finish:
    /* the sample taken last, if the stride left it out */
    if (work.seen > 0 && (work.seen - 1) % work.stride != 0
            && kd_buf_push(&work.kept, (const double *)&work.last, 5) != 0) goto done;
    /* the last state the search reached (that of a projection that failed: the
       state before it) */
    if (monitoring && mon.t_at != t0 && kd_monitor_here(&mon) != 0) goto done;
    if (failed && keep_last && te != NULL && t != t0) {
        /* ended early with output times: keep the state accepted last when it lies
           beyond the last output (sparse outputs would lose everything after it) */
        int keep = out_t.n == 0 || dir * (t - out_t.data[out_t.n - 1]) > 0;
        for (int i = 0; i < KD_NX && keep; ++i) if (!isfinite(y[i])) keep = 0;
        if (keep && (kd_buf_push(&out_t, &t, 1) || kd_buf_push(&out_y, y, KD_NX))) goto done;
    }
    if (failed && ig.singular && !interrupted) {
        static char text[160];
        snprintf(text, sizeof(text), "singular equations of motion at t=%.6g (the "
                 "integrator could not step past it)", ig.t_singular);
        message = text;
    }
    result = PyDict_New();
    if (result == NULL) goto done;
    npy_intp n_out = out_t.n;
    PyObject *item;
#define KD_SET(key, value) do { item = (value); \
        if (item == NULL || PyDict_SetItemString(result, key, item) < 0) { Py_XDECREF(item); \
            Py_CLEAR(result); goto done; } Py_DECREF(item); } while (0)
    KD_SET("t", kd_buf_array(&out_t, n_out, -1));
    KD_SET("y", kd_buf_array(&out_y, n_out, KD_NX));
    KD_SET("status", PyLong_FromLong(status));
    KD_SET("message", PyUnicode_FromString(message));
    KD_SET("nfev", PyLong_FromLong(ig.nfev));
    KD_SET("njev", PyLong_FromLong(ig.njev));
    KD_SET("nlu", PyLong_FromLong(ig.nlu));
    KD_SET("projections", PyLong_FromLong(projections));
    KD_SET("interrupted", PyBool_FromLong(interrupted));
    KD_SET("timed_out", PyBool_FromLong(timed_out));
    KD_SET("balance", kd_buf_array(&work.kept, work.kept.n / 5, 5));
    KD_SET("work_error", PyFloat_FromDouble(work.error));
    KD_SET("work_flow", PyFloat_FromDouble(work.flow));
    if (ig.singular) {
        KD_SET("t_bad", PyFloat_FromDouble(ig.t_singular));
        npy_intp nx = KD_NX;
        KdBuf bad = {ig.y_singular, KD_NX, KD_NX};
        KD_SET("y_bad", kd_buf_array(&bad, nx, -1));
    }
    PyObject *tl = PyList_New(ig.n_events), *yl = PyList_New(ig.n_events);
    if (tl == NULL || yl == NULL) { Py_XDECREF(tl); Py_XDECREF(yl); Py_CLEAR(result); goto done; }
    for (int k = 0; k < ig.n_events; ++k) {
        PyList_SET_ITEM(tl, k, kd_buf_array(&ev_t[k], ev_t[k].n, -1));
        PyList_SET_ITEM(yl, k, kd_buf_array(&ev_y[k], ev_t[k].n, KD_NX));
    }
    KD_SET("t_events", tl);
    KD_SET("y_events", yl);
    KD_SET("singular_t", kd_buf_array(&mon.t, mon.t.n, -1));
    KD_SET("singular_y", kd_buf_array(&mon.y, mon.t.n, KD_NX));
    KD_SET("singular_examined", PyLong_FromLong(mon.examined));
    if (dense) {
        npy_intp steps = dn_t.n / 2;
        KD_SET("dense_th", kd_buf_array(&dn_t, steps, 2));
        KD_SET("dense_y", kd_buf_array(&dn_y, steps, KD_NX));
        KD_SET("dense_q", kd_buf_array(&dn_q, steps, KD_NX * 4));
    }
#undef KD_SET
done:
    for (int k = 0; ev_t && ev_y && k < ig.n_events; ++k) {
        PyMem_Free(ev_t[k].data); PyMem_Free(ev_y[k].data);
    }
    PyMem_Free(ev_t); PyMem_Free(ev_y); PyMem_Free(ev_dir); PyMem_Free(ev_term);
    PyMem_Free(g_old); PyMem_Free(g_new);
    PyMem_Free(out_t.data); PyMem_Free(out_y.data); PyMem_Free(work.kept.data);
    PyMem_Free(dn_t.data); PyMem_Free(dn_y.data); PyMem_Free(dn_q.data);
    PyMem_Free(mon.t.data); PyMem_Free(mon.y.data);
    PyMem_Free(J); PyMem_Free(ig.exact);
    Py_XDECREF(evseq); Py_XDECREF(teval); Py_XDECREF(keep_y);
    return result;
}
"""

INTEGRATOR = DORMAND_PRINCE + PROJECTION + BRENT + _LOOP
