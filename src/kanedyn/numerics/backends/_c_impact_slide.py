r"""C source of an impact's sliding phase whose slip turns (standalone export).

:data:`SLIDE` is :func:`kanedyn.simulation._impact._slide_numerically` in C:
during the impact of one contact with Coulomb friction, the relative velocity
:math:`v` and the tangential impulse :math:`P_t` as functions of the normal
impulse :math:`p`,

.. math::

    \frac{dv}{dp} = W (n - \mu \hat s),\qquad \frac{dP_t}{dp} = -\mu \hat s,

with :math:`\hat s` the current slip direction (the phase's own below the slip
tolerance), integrated from the phase's start until the slip's component along
the phase's direction vanishes, the compression ends (the normal velocity
rises through zero) or Newton's restitution is reached, or ``stop_p``.
``kd.simulate`` integrates it with SciPy's DOP853; this is the Dormand-Prince
5(4) pair with SciPy's RK45 step control (the tableau of
:data:`._c_integrator.DORMAND_PRINCE`, the continuous extension of
:data:`._c_integrator.DENSE_OUTPUT`) at the same tolerances (relative
:math:`10^{-12}`, absolute :math:`10^{-14}` times the speed scale), the
events located by Brent's method (:data:`._c_integrator.BRENT`) on the
continuous extension.

Interface (static, for :mod:`._c_hybrid`)::

    void kd_imp_slide(const double *W, const double *n, double mu,
                      const double *dir, double slip_tol, int compressing,
                      int newton, double target, double stop_p, double scale,
                      double *p, double *v, double *Pt);
"""

from __future__ import annotations

__all__ = ["SLIDE"]

SLIDE = r"""
/* ------------------------------------------------------------------------
   An impact's sliding phase whose slip turns (_impact._slide_numerically)
   ------------------------------------------------------------------------ */
typedef struct {
    const double *W, *n, *dir;
    double mu, slip_tol, target;
    int compressing, newton;
    double q_old, h, y_old[6], Q[24];
} KdSlide;

static void kd_slide_rate(const KdSlide *S, const double *y, double *out) {
    double vn = kd_dot3(S->n, y), wt[3], d[3], x[3], speed;
    for (int i = 0; i < 3; ++i) wt[i] = y[i] - vn * S->n[i];
    speed = sqrt(kd_dot3(wt, wt));
    for (int i = 0; i < 3; ++i) d[i] = speed > S->slip_tol ? wt[i] / speed : S->dir[i];
    for (int i = 0; i < 3; ++i) x[i] = S->n[i] - S->mu * d[i];
    for (int a = 0; a < 3; ++a) {
        out[a] = S->W[3 * a] * x[0] + S->W[3 * a + 1] * x[1] + S->W[3 * a + 2] * x[2];
        out[3 + a] = -S->mu * d[a];
    }
}

/* the event functions: 0 the slip along dir (falling), 1 the normal velocity
   (rising; while compressing) or its distance to Newton's target (rising) */
static void kd_slide_events(const KdSlide *S, const double *y, double *g) {
    double vn = kd_dot3(S->n, y), wt[3];
    for (int i = 0; i < 3; ++i) wt[i] = y[i] - vn * S->n[i];
    g[0] = kd_dot3(wt, S->dir);
    g[1] = S->compressing ? vn : vn - S->target;
}

static void kd_slide_dense(const KdSlide *S, double q, double *y) {
    double x = (q - S->q_old) / S->h, pw[4] = {x, x * x, x * x * x, x * x * x * x};
    for (int i = 0; i < 6; ++i) {
        y[i] = S->y_old[i];
        for (int j = 0; j < 4; ++j) y[i] += S->h * S->Q[4 * i + j] * pw[j];
    }
}

/* event k of the slide on its continuous extension: a KdRootFn of the impulse */
typedef struct { const KdSlide *S; int k; } KdSlideEvent;

static int kd_slide_event_at(void *ctx, double q, double *g) {
    const KdSlideEvent *E = (const KdSlideEvent *)ctx;
    double y[6], gs[2];
    kd_slide_dense(E->S, q, y);
    kd_slide_events(E->S, y, gs);
    *g = gs[E->k];
    return 0;
}

/* event k's zero in [a, b] by Brent's method (_c_integrator.BRENT) */
static double kd_slide_root(const KdSlide *S, int k, double a, double b, double fa, double fb) {
    KdSlideEvent E = {S, k};
    double root = b;
    kd_brent(kd_slide_event_at, &E, a, b, fa, fb, &root);
    return root;
}

/* integrates the phase from *p (v, Pt) to its first event or stop_p; on return
   *p, v and Pt at its end */
static void kd_imp_slide(const double *W, const double *n, double mu, const double *dir,
                         double slip_tol, int compressing, int newton, double target,
                         double stop_p, double scale, double *p, double *v, double *Pt) {
    KdSlide S = {W, n, dir, mu, slip_tol, target, compressing, newton, 0.0, 0.0, {0}, {0}};
    const double rtol = 1e-12, atol = 1e-14 * scale;
    double q = *p, y[6], f[6], K[7][6], y_new[6], ytmp[6], sc[6], g_old[2], g_new[2];
    int n_ev = (compressing || newton) ? 2 : 1;
    memcpy(y, v, sizeof(double) * 3);
    memcpy(y + 3, Pt, sizeof(double) * 3);
    kd_slide_rate(&S, y, f);
    kd_slide_events(&S, y, g_old);
    double interval = stop_p - q, h_abs;
    {   /* SciPy's select_initial_step (order 4) */
        double y1[6], f1[6], tmp[6], d0, d1, d2, h0, h1;
        for (int i = 0; i < 6; ++i) sc[i] = atol + fabs(y[i]) * rtol;
        d0 = kd_rms(y, sc, 6); d1 = kd_rms(f, sc, 6);
        h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
        h0 = fmin(h0, interval);
        for (int i = 0; i < 6; ++i) y1[i] = y[i] + h0 * f[i];
        kd_slide_rate(&S, y1, f1);
        for (int i = 0; i < 6; ++i) tmp[i] = f1[i] - f[i];
        d2 = kd_rms(tmp, sc, 6) / h0;
        h1 = (d1 <= 1e-15 && d2 <= 1e-15) ? fmax(1e-6, h0 * 1e-3)
                                            : pow(0.01 / fmax(d1, d2), 1.0 / 5.0);
        h_abs = fmin(fmin(100 * h0, h1), interval);
    }
    for (int steps = 0; q < stop_p && steps < 100000; ++steps) {
        double min_step = 10 * fabs(nextafter(q, INFINITY) - q), h, q_new, err_norm;
        int rejected = 0, failed = 0;
        if (h_abs < min_step) h_abs = min_step;
        for (;;) {
            q_new = fmin(q + h_abs, stop_p);
            h = q_new - q;
            memcpy(K[0], f, sizeof f);
            for (int s = 1; s < 7; ++s) {
                for (int i = 0; i < 6; ++i) {
                    double a = 0.0;
                    for (int j = 0; j < s; ++j) a += kd_A[s][j] * K[j][i];
                    ytmp[i] = y[i] + h * a;
                }
                if (s == 6) memcpy(y_new, ytmp, sizeof y_new);
                kd_slide_rate(&S, ytmp, K[s]);
            }
            double err[6];
            for (int i = 0; i < 6; ++i) {
                double e = 0.0;
                for (int s = 0; s < 7; ++s) e += kd_E[s] * K[s][i];
                err[i] = e * h;
                sc[i] = atol + fmax(fabs(y[i]), fabs(y_new[i])) * rtol;
            }
            err_norm = kd_rms(err, sc, 6);
            if (err_norm < 1) {
                double factor = err_norm == 0 ? 10.0 : fmin(10.0, 0.9 * pow(err_norm, -0.2));
                h_abs *= rejected ? fmin(1.0, factor) : factor;
                break;
            }
            h_abs *= fmax(0.2, 0.9 * pow(err_norm, -0.2));
            rejected = 1;
            if (h_abs < min_step) { failed = 1; break; }  /* ends where it is (SciPy) */
        }
        if (failed) break;
        S.q_old = q; S.h = h;
        memcpy(S.y_old, y, sizeof y);
        for (int i = 0; i < 6; ++i)
            for (int j = 0; j < 4; ++j) {
                double s = 0.0;
                for (int k = 0; k < 7; ++k) s += K[k][i] * kd_P[k][j];
                S.Q[4 * i + j] = s;
            }
        kd_slide_events(&S, y_new, g_new);
        double first = INFINITY;
        for (int k = 0; k < n_ev; ++k) {
            int hit = k == 0 ? (g_old[0] >= 0 && g_new[0] <= 0)   /* falling */
                             : (g_old[1] <= 0 && g_new[1] >= 0);  /* rising */
            if (hit) first = fmin(first, kd_slide_root(&S, k, q, q_new, g_old[k], g_new[k]));
        }
        if (first < INFINITY) {
            kd_slide_dense(&S, first, y);
            q = first;
            break;
        }
        q = q_new;
        memcpy(y, y_new, sizeof y);
        memcpy(f, K[6], sizeof f);
        memcpy(g_old, g_new, sizeof g_old);
    }
    *p = q;
    memcpy(v, y, sizeof(double) * 3);
    memcpy(Pt, y + 3, sizeof(double) * 3);
}
"""
