r"""C source of the impacts of several contacts at once, for the standalone export.

:data:`IMPACTS` is :func:`kanedyn.simulation._impact._simultaneous` in C: the
impulses of the contacts that take part in an impact (those that hit and those
already touching) under Newton's restitution law and the Coulomb cone, in the
contact frames (normal and the tangent basis of
:func:`kanedyn.simulation._impact._tangent_basis`); solved by enumerating the
contacts' states (sticking, sliding, free; :func:`._enumerated`, with its
fixed point of the slip directions, Newton's method on them and the sticking
start brought onto the cones) on at most four contacts, and by projected
Gauss-Seidel (:func:`._gauss_seidel`) where that finds no consistent state.
It uses the least squares of :mod:`._c_contact_general`
(``kd_lstsq``).

Interface (static, for :mod:`._c_hybrid`)::

    void kd_imp_several(int k, const double *W, const double *v0,
                        const double *normals, const double *mu,
                        const double *e, double *P);

``W`` (3k x 3k) the contact-space inverse inertia, ``v0`` (3k) the relative
velocities before, ``normals`` (3k), ``mu`` and ``e`` (k) the kinetic friction
and restitution coefficients; ``P`` (3k) the impulses [N s].
"""

from __future__ import annotations

__all__ = ["IMPACTS"]

IMPACTS = r"""
/* ------------------------------------------------------------------------
   Impacts of several contacts at once (_impact._simultaneous)
   ------------------------------------------------------------------------ */
enum { KD_IMP_STICK = 0, KD_IMP_SLIDE = 1, KD_IMP_FREE = 2 };

/* least-squares solution of the symmetric 2 x 2 system A a = b (cut-off 1e-12) */
static void kd_pinv2(const double *A, const double *b, double *a) {
    double ev[2], V[4];
    double m = 0.5 * (A[0] + A[3]), d = 0.5 * (A[0] - A[3]), r = sqrt(d * d + A[1] * A[1]);
    ev[0] = m + r; ev[1] = m - r;
    if (A[1] == 0.0) { V[0] = 1; V[2] = 0; V[1] = 0; V[3] = 1; ev[0] = A[0]; ev[1] = A[3]; }
    else {
        double x = ev[0] - A[3], y = A[1], nn = sqrt(x * x + y * y);
        V[0] = x / nn; V[2] = y / nn; V[1] = -V[2]; V[3] = V[0];
    }
    double big = fmax(fabs(ev[0]), fabs(ev[1]));
    a[0] = a[1] = 0.0;
    for (int k = 0; k < 2; ++k) {
        if (!(fabs(ev[k]) > 1e-12 * big)) continue;
        double c = (V[k] * b[0] + V[2 + k] * b[1]) / ev[k];
        a[0] += c * V[k]; a[1] += c * V[2 + k];
    }
}


static void kd_imp_basis(const double *n, double *T1, double *T2) {
    double a[3];
    if (fabs(n[0]) < 0.9) { a[0] = 1; a[1] = 0; a[2] = 0; } else { a[0] = 0; a[1] = 1; a[2] = 0; }
    T1[0] = n[1] * a[2] - n[2] * a[1]; T1[1] = n[2] * a[0] - n[0] * a[2]; T1[2] = n[0] * a[1] - n[1] * a[0];
    double norm = sqrt(kd_dot3(T1, T1));
    for (int i = 0; i < 3; ++i) T1[i] /= norm;
    T2[0] = n[1] * T1[2] - n[2] * T1[1]; T2[1] = n[2] * T1[0] - n[0] * T1[2]; T2[2] = n[0] * T1[1] - n[1] * T1[0];
}

static double kd_imp_norm(const double *x, int n) {
    double s = 0.0;
    for (int i = 0; i < n; ++i) s += x[i] * x[i];
    return sqrt(s);
}

/* w = w0 + L x (3k) */
static void kd_imp_after(int k, const double *L, const double *w0, const double *x, double *w) {
    for (int a = 0; a < 3 * k; ++a) {
        w[a] = w0[a];
        for (int b = 0; b < 3 * k; ++b) w[a] += L[a * 3 * k + b] * x[b];
    }
}

/* _state_equations: F (3k) and its Jacobian G (3k x 3k); 0, or 1 where a sliding
   contact's slip vanishes */
static int kd_imp_residual(int k, const double *L, const double *w0, const double *targets,
                           const double *mu, const int *states, const double *x, double eps,
                           double *F, double *G) {
    int n = 3 * k;
    double w[3 * KD_NC];
    kd_imp_after(k, L, w0, x, w);
    memset(G, 0, sizeof(double) * n * n);
    for (int c = 0; c < k; ++c) {
        int r = 3 * c;
        if (states[c] == KD_IMP_FREE) {
            for (int i = 0; i < 3; ++i) { F[r + i] = x[r + i]; G[(r + i) * n + r + i] = 1.0; }
        } else if (states[c] == KD_IMP_STICK) {
            for (int i = 0; i < 3; ++i) {
                F[r + i] = w[r + i] - (i == 0 ? targets[c] : 0.0);
                memcpy(G + (r + i) * n, L + (r + i) * n, sizeof(double) * n);
            }
        } else {
            double vt[2] = {w[r + 1], w[r + 2]}, speed = kd_imp_norm(vt, 2), d[2];
            if (speed <= eps) return 1;
            d[0] = vt[0] / speed; d[1] = vt[1] / speed;
            F[r] = w[r] - targets[c];
            memcpy(G + r * n, L + r * n, sizeof(double) * n);
            for (int a = 0; a < 2; ++a) {
                F[r + 1 + a] = x[r + 1 + a] + mu[c] * x[r] * d[a];
                for (int b = 0; b < n; ++b) {
                    double sum = 0.0;
                    for (int e2 = 0; e2 < 2; ++e2)
                        sum += ((a == e2) - d[a] * d[e2]) / speed * L[(r + 1 + e2) * n + b];
                    G[(r + 1 + a) * n + b] = mu[c] * x[r] * sum;
                }
                G[(r + 1 + a) * n + r + 1 + a] += 1.0;
                G[(r + 1 + a) * n + r] += mu[c] * d[a];
            }
        }
    }
    return 0;
}

/* _newton_states: x refined in place; 0 converged, 1 not */
static int kd_imp_newton(int k, const double *L, const double *w0, const double *targets,
                         const double *mu, const int *states, double *x, double eps) {
    int n = 3 * k;
    double F[3 * KD_NC], G[9 * KD_NC * KD_NC], Fn[3 * KD_NC], Gn[9 * KD_NC * KD_NC];
    double step[3 * KD_NC], minus[3 * KD_NC], trial[3 * KD_NC], scale = 1e-300;
    for (int i = 0; i < n; ++i) scale = fmax(scale, fmax(fabs(x[i]), fabs(w0[i])));
    int bad = kd_imp_residual(k, L, w0, targets, mu, states, x, eps, F, G);
    for (int it = 0; it < 50; ++it) {
        if (bad) return 1;
        double norm = kd_imp_norm(F, n);
        if (norm <= 1e-13 * scale) return 0;
        for (int i = 0; i < n; ++i) minus[i] = -F[i];
        kd_lstsq(n, n, G, minus, 1e-12, step);
        int found = 0;
        for (int h = 0; h < 30; ++h) {
            for (int i = 0; i < n; ++i) trial[i] = x[i] + step[i];
            int b = kd_imp_residual(k, L, w0, targets, mu, states, trial, eps, Fn, Gn);
            if (!b && kd_imp_norm(Fn, n) < norm) { found = 1; break; }
            for (int i = 0; i < n; ++i) step[i] *= 0.5;
        }
        if (!found) return 1;
        memcpy(x, trial, sizeof(double) * n);
        memcpy(F, Fn, sizeof(double) * n);
        memcpy(G, Gn, sizeof(double) * n * n);
        bad = 0;
    }
    return 1;
}

/* _consistent: whether the impulses x satisfy the inequalities of their states */
static int kd_imp_consistent(int k, const double *L, const double *w0, const double *targets,
                             const double *mu, const int *states, const double *x, double eps,
                             double p_scale) {
    double w[3 * KD_NC];
    kd_imp_after(k, L, w0, x, w);
    for (int c = 0; c < k; ++c) {
        double pn = x[3 * c], pt[2] = {x[3 * c + 1], x[3 * c + 2]};
        double vn = w[3 * c], vt[2] = {w[3 * c + 1], w[3 * c + 2]};
        int ok;
        if (states[c] == KD_IMP_FREE) ok = vn >= targets[c] - eps;
        else if (states[c] == KD_IMP_STICK)
            ok = pn >= -1e-12 * p_scale
                 && kd_imp_norm(pt, 2) <= mu[c] * pn * (1 + 1e-12) + 1e-12 * p_scale;
        else {
            double speed = kd_imp_norm(vt, 2), r[2];
            ok = pn >= -1e-12 * p_scale && speed > eps;
            if (ok) {
                r[0] = pt[0] + mu[c] * pn * vt[0] / speed;
                r[1] = pt[1] + mu[c] * pn * vt[1] / speed;
                ok = kd_imp_norm(r, 2) <= 1e-9 * (fabs(pn) + 1e-12 * p_scale);
            }
        }
        if (!ok) return 0;
    }
    return 1;
}

/* the rows of the linear system of states (A x = b) with slip directions dirs
   (has_dir 0: none); frictionless: sliding contacts without tangential impulse,
   stick_start: sliding contacts held as sticking (_stick_start) */
static void kd_imp_system(int k, const double *L, const double *w0, const double *targets,
                          const double *mu, const int *states, const double *dirs,
                          const int *has_dir, int stick_start, int frictionless,
                          double *A, double *b) {
    int n = 3 * k;
    memset(A, 0, sizeof(double) * n * n);
    memset(b, 0, sizeof(double) * n);
    for (int c = 0; c < k; ++c) {
        int r = 3 * c;
        int as_stick = states[c] == KD_IMP_STICK
                       || (stick_start && states[c] == KD_IMP_SLIDE && !frictionless);
        if (states[c] == KD_IMP_FREE) {
            for (int i = 0; i < 3; ++i) A[(r + i) * n + r + i] = 1.0;
        } else if (as_stick) {
            for (int i = 0; i < 3; ++i) {
                memcpy(A + (r + i) * n, L + (r + i) * n, sizeof(double) * n);
                b[r + i] = -w0[r + i];
            }
            b[r] += targets[c];
        } else {
            memcpy(A + r * n, L + r * n, sizeof(double) * n);
            b[r] = targets[c] - w0[r];
            for (int i = 1; i < 3; ++i) {
                A[(r + i) * n + r + i] = 1.0;
                if (!stick_start && has_dir[c]) A[(r + i) * n + r] = mu[c] * dirs[2 * c + i - 1];
            }
        }
    }
}

/* _enumerated: 1 and x where a state assignment is consistent, else 0 */
static int kd_imp_enumerated(int k, const double *L, const double *w0, const double *targets,
                             const double *mu, double *x) {
    int n = 3 * k, total = 1;
    if (k > 4) return 0;
    double scale = 1e-300, dmax = 1e-300;
    for (int i = 0; i < n; ++i) scale = fmax(scale, fabs(w0[i]));
    for (int c = 0; c < k; ++c) scale = fmax(scale, fabs(targets[c]));
    for (int i = 0; i < n; ++i) dmax = fmax(dmax, fabs(L[i * n + i]));
    double eps = 1e-10 * scale, p_scale = scale / dmax;
    for (int c = 0; c < k; ++c) total *= 3;
    for (int index = 0; index < total; ++index) {
        int states[KD_NC], free_all = 1, stick_frictionless = 0, slides = 0;
        for (int c = k - 1, rest = index; c >= 0; --c, rest /= 3) states[c] = rest % 3;
        for (int c = 0; c < k; ++c) {
            free_all &= states[c] == KD_IMP_FREE;
            stick_frictionless |= states[c] == KD_IMP_STICK && mu[c] == 0;
            slides |= states[c] == KD_IMP_SLIDE;
        }
        if (free_all) {
            int ok = 1;
            for (int c = 0; c < k; ++c) ok &= w0[3 * c] >= targets[c] - eps;
            if (ok) { for (int i = 0; i < n; ++i) x[i] = 0.0; return 1; }
            continue;
        }
        if (stick_frictionless) continue;
        double dirs[2 * KD_NC], A[9 * KD_NC * KD_NC], b[3 * KD_NC], guess[3 * KD_NC];
        double w[3 * KD_NC], res[3 * KD_NC];
        int has_dir[KD_NC], have = 0, converged = 0;
        for (int c = 0; c < k; ++c) {
            has_dir[c] = 0;
            if (states[c] != KD_IMP_SLIDE) continue;
            double vt[2] = {w0[3 * c + 1], w0[3 * c + 2]}, norm = kd_imp_norm(vt, 2);
            if (norm > eps) { has_dir[c] = 1; dirs[2 * c] = vt[0] / norm; dirs[2 * c + 1] = vt[1] / norm; }
        }
        for (int it = 0; it < 20; ++it) {  /* fixed point of the slip directions */
            kd_imp_system(k, L, w0, targets, mu, states, dirs, has_dir, 0, 0, A, b);
            kd_lstsq(n, n, A, b, 1e-12, guess);
            for (int a = 0; a < n; ++a) {
                res[a] = -b[a];
                for (int c = 0; c < n; ++c) res[a] += A[a * n + c] * guess[c];
            }
            if (kd_imp_norm(res, n) > 1e-9 * fmax(kd_imp_norm(b, n), scale * 1e-3)) break;
            memcpy(x, guess, sizeof(double) * n);
            have = 1;
            kd_imp_after(k, L, w0, x, w);
            int changed = 0;
            for (int c = 0; c < k; ++c) {
                if (states[c] != KD_IMP_SLIDE) continue;
                double vt[2] = {w[3 * c + 1], w[3 * c + 2]}, norm = kd_imp_norm(vt, 2), d[2];
                if (norm <= eps) continue;
                d[0] = vt[0] / norm; d[1] = vt[1] / norm;
                if (!has_dir[c]) changed = 1;
                else {
                    double diff[2] = {d[0] - dirs[2 * c], d[1] - dirs[2 * c + 1]};
                    if (kd_imp_norm(diff, 2) > 1e-14) changed = 1;
                }
                has_dir[c] = 1; dirs[2 * c] = d[0]; dirs[2 * c + 1] = d[1];
            }
            if (!changed) { converged = 1; break; }
        }
        if (!converged && have && kd_imp_newton(k, L, w0, targets, mu, states, x, eps)) have = 0;
        if (have && kd_imp_consistent(k, L, w0, targets, mu, states, x, eps, p_scale)) return 1;
        if (!slides) continue;
        for (int frictionless = 0; frictionless < 2; ++frictionless) {
            kd_imp_system(k, L, w0, targets, mu, states, dirs, has_dir, 1, frictionless, A, b);
            kd_lstsq(n, n, A, b, 1e-12, x);
            for (int c = 0; c < k; ++c) {
                if (states[c] != KD_IMP_SLIDE) continue;
                double norm = kd_imp_norm(x + 3 * c + 1, 2);
                if (norm > 0)
                    for (int i = 1; i < 3; ++i) x[3 * c + i] *= mu[c] * fabs(x[3 * c]) / norm;
            }
            if (!kd_imp_newton(k, L, w0, targets, mu, states, x, eps)
                    && kd_imp_consistent(k, L, w0, targets, mu, states, x, eps, p_scale))
                return 1;
        }
    }
    return 0;
}

/* _gauss_seidel: projected Gauss-Seidel over the contacts, in the contact frames */
static void kd_imp_gauss_seidel(int k, const double *L, const double *w0,
                                const double *targets, const double *mu, const double *frames,
                                double *X) {
    int n = 3 * k;
    for (int i = 0; i < n; ++i) X[i] = 0.0;
    for (int it = 0; it < 2000; ++it) {
        double change = 0.0, big = 1.0;
        for (int c = 0; c < k; ++c) {
            int r = 3 * c;
            double lv[3], lp[3], nw[3], Ltt[4], rhs[2], pt[2], d[3];
            for (int a = 0; a < 3; ++a) {
                lv[a] = w0[r + a];
                for (int b = 0; b < n; ++b) lv[a] += L[(r + a) * n + b] * X[b];
                lp[a] = X[r + a];
            }
            double pn = fmax(0.0, lp[0] + (targets[c] - lv[0]) / L[r * n + r]);
            for (int a = 0; a < 2; ++a) {
                rhs[a] = lv[1 + a] + L[(r + 1 + a) * n + r] * (pn - lp[0]);
                for (int b = 0; b < 2; ++b) Ltt[2 * a + b] = L[(r + 1 + a) * n + r + 1 + b];
            }
            kd_pinv2(Ltt, rhs, pt);
            pt[0] = lp[1] - pt[0];
            pt[1] = lp[2] - pt[1];
            double limit = mu[c] * pn, norm = kd_imp_norm(pt, 2);
            if (norm > limit) { pt[0] *= limit / norm; pt[1] *= limit / norm; }
            nw[0] = pn; nw[1] = pt[0]; nw[2] = pt[1];
            for (int a = 0; a < 3; ++a) {  /* the change in inertial components */
                d[a] = 0.0;
                for (int b = 0; b < 3; ++b) d[a] += frames[9 * c + 3 * a + b] * (nw[b] - lp[b]);
                change = fmax(change, fabs(d[a]));
            }
            memcpy(X + r, nw, sizeof nw);
        }
        for (int i = 0; i < n; ++i) big = fmax(big, fabs(X[i]));
        if (change <= 1e-13 * big) break;
    }
}

/* the impulses P (3k, inertial) of k contacts hitting or touching at once */
static void kd_imp_several(int k, const double *W, const double *v0, const double *normals,
                           const double *mu, const double *e, double *P) {
    int n = 3 * k;
    double frames[9 * KD_NC], L[9 * KD_NC * KD_NC], w0[3 * KD_NC], targets[KD_NC], x[3 * KD_NC];
    for (int c = 0; c < k; ++c) {  /* columns n, t1, t2 */
        double T1[3], T2[3];
        const double *nc = normals + 3 * c;
        kd_imp_basis(nc, T1, T2);
        for (int i = 0; i < 3; ++i) {
            frames[9 * c + 3 * i] = nc[i];
            frames[9 * c + 3 * i + 1] = T1[i];
            frames[9 * c + 3 * i + 2] = T2[i];
        }
    }
    /* L = F^T W F, w0 = F^T v0 (F block diagonal) */
    for (int a = 0; a < n; ++a) {
        int ca = a / 3, ia = a % 3;
        w0[a] = 0.0;
        for (int i = 0; i < 3; ++i) w0[a] += frames[9 * ca + 3 * i + ia] * v0[3 * ca + i];
        for (int b = 0; b < n; ++b) {
            int cb = b / 3, ib = b % 3;
            double sum = 0.0;
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    sum += frames[9 * ca + 3 * i + ia] * W[(3 * ca + i) * n + 3 * cb + j]
                           * frames[9 * cb + 3 * j + ib];
            L[a * n + b] = sum;
        }
    }
    for (int c = 0; c < k; ++c) targets[c] = w0[3 * c] < 0 ? -e[c] * w0[3 * c] : 0.0;
    if (!kd_imp_enumerated(k, L, w0, targets, mu, x))
        kd_imp_gauss_seidel(k, L, w0, targets, mu, frames, x);
    for (int c = 0; c < k; ++c)
        for (int i = 0; i < 3; ++i)
            P[3 * c + i] = frames[9 * c + 3 * i] * x[3 * c] + frames[9 * c + 3 * i + 1] * x[3 * c + 1]
                           + frames[9 * c + 3 * i + 2] * x[3 * c + 2];
}
"""
