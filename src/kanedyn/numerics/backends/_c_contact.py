r"""C source of the compiled contact segments (part of modules with contacts).

``contact_segment(t0, t1, z0, p, spec, rtol, atol[, stop, timeout])`` integrates one segment
of a contact simulation (:func:`kanedyn.simulation._hybrid.simulate_contacts`)
with the contact modes fixed: the state ``z = (q, u, dissipated work, contact
work)``, SciPy's ``RK45`` (same coefficients, error norm, step control and
initial step as :mod:`._c_integrator`), and the mode's terminal event
functions evaluated in C after every accepted step, their zeros located by
Brent's method on the quartic continuous extension (SciPy's ``solve_ivp``
event handling: the earliest root of a sign change in the event's
direction ends the segment).

The per-mode contact solve is the Schur complement of
:func:`kanedyn.numerics._contact_dynamics._one_contact`: no active contact,
or one active unilateral contact sliding (one unknown normal force, Coulomb
friction along the slip direction of
:func:`kanedyn.numerics._contact_dynamics.slip_direction`) or sticking (a
3-vector force), with Baumgarte stabilization of the normal distance.  Several
active contacts only when all are frictionless and sliding with independent
normal rows (their normal forces by the Schur complement).  The exported FMU
(where ``KD_GENERAL_CONTACTS`` is defined and the segment sets ``general``) solves
every other case by the general solve of :mod:`._c_contact_general`;
``kd.simulate`` gives such segments to the Python path.  Any
other case (several active contacts, dependent speeds, specified inputs, an
ill-conditioned contact-space matrix) and any failure (singular or not
finite) returns status 2 at once: the caller integrates that segment with
the Python reference path instead.

``spec`` is a tuple of arrays, one entry per contact unless stated:
``modes`` (int: 0 separated, 1 slip, 2 stick), ``has_ref`` (int), ``ref``
(k x 3 reference slip directions), ``slow``, ``still``, ``offset`` (of the
gap events), ``mu_k``, ``mu_s``, ``viscous``, ``stabilization`` (float),
``ev_contact`` and ``ev_kind`` (int, one per event: 0 gap closes, 1 normal
force vanishes, 2 slip stops, 3 friction reaches its limit).

Returns ``(status, t, z, event, nfev)``: status 0 (reached ``t1``), 1 (the
event with index ``event`` ended the segment at ``t[-1]``), 2 (not handled
here) or 3 (stopped between two steps by the stop flag ``stop`` of the run's
guard, by a ``KeyboardInterrupt`` at the signal check, or by its time limit,
``timeout`` s of computing, 0: none, checked every 16 steps: what it has); ``t``
(N,) and ``z`` (N, n + 2) the accepted steps from ``t0`` (and the event point).
Like the integration loop it lets Python's other threads work between its steps.

:data:`SEGMENT` is the Python-free part (the solve, the event functions located
by :data:`._c_integrator.BRENT`, which must precede it, and the loop
``kd_seg_run``), shared with the standalone export's contact
loop (:mod:`._c_hybrid`); :data:`CONTACT` adds the module's entry point.
"""

SEGMENT = r"""
/* ------------------------------------------------------------------------
   Compiled contact segments
   ------------------------------------------------------------------------ */
#define KD_NZ (KD_NX + 2)
#define KD_MAXEV (2 * KD_NC)
#define KD_STALL_TURN 0.06030737921409157  /* 1 - cos(20 deg) */
#define KD_SLOW_STILL 10.0  /* _SLOW_STILL of kanedyn.simulation._hybrid */

typedef struct {
    const double *p;
    double *w;
    int modes[KD_NC], has_ref[KD_NC];
    int general;  /* several active contacts in the export's general solve */
    double ref[3 * KD_NC], slow[KD_NC], still[KD_NC], offset[KD_NC];
    double mu_k[KD_NC], mu_s[KD_NC], visc[KD_NC], stab;
    int n_ev, ev_c[KD_MAXEV], ev_kind[KD_MAXEV];
    long nfev;
    double t_old, h, z_old[KD_NZ], Q[KD_NZ * 4];
} KdSeg;

typedef struct {
    double N[KD_NC], total[3 * KD_NC], vt[3 * KD_NC];
    double gap[KD_NC], grad[KD_NC], normal[3 * KD_NC], vel[3 * KD_NC];
} KdSegOut;

static inline double kd_dot3(const double *a, const double *b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* eigenvalues ev and eigenvectors (columns of V, row-major) of a symmetric
   3 x 3 matrix, by cyclic Jacobi rotations */
static void kd_jacobi3(const double *S, double *ev, double *V) {
    double A[9];
    memcpy(A, S, sizeof(A));
    for (int i = 0; i < 9; ++i) V[i] = (i % 4 == 0);
    for (int sweep = 0; sweep < 50; ++sweep) {
        double off = A[1] * A[1] + A[2] * A[2] + A[5] * A[5];
        double diag = A[0] * A[0] + A[4] * A[4] + A[8] * A[8];
        if (off <= 1e-40 * diag || off == 0.0) break;
        for (int p = 0; p < 2; ++p)
            for (int q = p + 1; q < 3; ++q) {
                double apq = A[3 * p + q];
                if (apq == 0.0) continue;
                double theta = (A[3 * q + q] - A[3 * p + p]) / (2 * apq);
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1));
                double c = 1 / sqrt(t * t + 1), s = t * c;
                for (int k = 0; k < 3; ++k) {  /* A <- A G (columns p, q) */
                    double akp = A[3 * k + p], akq = A[3 * k + q];
                    A[3 * k + p] = c * akp - s * akq;
                    A[3 * k + q] = s * akp + c * akq;
                }
                for (int k = 0; k < 3; ++k) {  /* A <- G^T A (rows p, q) */
                    double apk = A[3 * p + k], aqk = A[3 * q + k];
                    A[3 * p + k] = c * apk - s * aqk;
                    A[3 * q + k] = s * apk + c * aqk;
                }
                for (int k = 0; k < 3; ++k) {
                    double vkp = V[3 * k + p], vkq = V[3 * k + q];
                    V[3 * k + p] = c * vkp - s * vkq;
                    V[3 * k + q] = s * vkp + c * vkq;
                }
            }
    }
    for (int i = 0; i < 3; ++i) ev[i] = A[4 * i];
}

/* slip_direction: vt the slip velocity to follow; a reference projected onto the
   slips the projector space (3 x 3) allows, or (NULL) onto the tangent plane */
static void kd_seg_slip_dir(const KdSeg *S, int c, const double *n, const double *v,
                            const double *vt, const double *space, double *s) {
    double speed = sqrt(kd_dot3(vt, vt));
    int moving = speed > 1e-12 * fmax(1.0, sqrt(kd_dot3(v, v)));
    const double *r = S->ref + 3 * c;
    if ((!S->has_ref[c] && moving)
            || (S->has_ref[c] && moving && speed > S->still[c]
                && (kd_dot3(vt, r) > 0 || speed > S->slow[c]))) {
        for (int i = 0; i < 3; ++i) s[i] = vt[i] / speed;
        return;
    }
    if (!S->has_ref[c]) { s[0] = s[1] = s[2] = 0.0; return; }
    double rn = kd_dot3(r, n);
    for (int i = 0; i < 3; ++i)
        s[i] = space ? space[3 * i] * r[0] + space[3 * i + 1] * r[1] + space[3 * i + 2] * r[2]
                     : r[i] - rn * n[i];
    double norm = sqrt(kd_dot3(s, s));
    for (int i = 0; i < 3; ++i) s[i] = norm > 0 ? s[i] / norm : 0.0;
}

#if !(KD_NUDEP > 0 || KD_NR > 0)
/* whether the k rows R (k x KD_NU, k <= 3) are independent: the smallest singular
   value above 1e-10 times the largest (eigenvalues of R R^T, padded to 3 x 3) */
static int kd_seg_independent(const double *R, int k) {
    double G[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0}, ev[3], V[9];
    for (int a = 0; a < k; ++a)
        for (int b = 0; b < k; ++b)
            for (int j = 0; j < KD_NU; ++j) G[3 * a + b] += R[a * KD_NU + j] * R[b * KD_NU + j];
    kd_jacobi3(G, ev, V);
    for (int a = 0; a < 2; ++a)  /* descending */
        for (int b = a + 1; b < 3; ++b)
            if (ev[b] > ev[a]) { double x = ev[a]; ev[a] = ev[b]; ev[b] = x; }
    return ev[0] > 0 && ev[k - 1] > 1e-20 * ev[0];
}

/* several active contacts, all frictionless (no Coulomb or viscous friction) and
   sliding, their normal rows independent: the normal forces by the Schur
   complement (solve_modes' general path without friction); 2 otherwise */
static int kd_seg_frictionless(KdSeg *S, const double *z, double *zd, KdSegOut *o,
                               const double *M, const double *f, const double *jac,
                               const double *acc, const double *rate) {
    int act[3], k = 0;
    (void)acc;
    for (int i = 0; i < KD_NC; ++i) {
        if (S->modes[i] == 0) continue;
        if (S->modes[i] != 1 || S->mu_k[i] != 0.0 || S->mu_s[i] != 0.0 || S->visc[i] != 0.0
                || k == 3)
            return 2;
        act[k++] = i;
    }
    double R[3 * KD_NU], X[4 * KD_NU], A[KD_NU * KD_NU], W[9], lam[3];
    for (int a = 0; a < k; ++a) {
        const double *J = jac + 3 * act[a] * KD_NU, *n = o->normal + 3 * act[a];
        for (int j = 0; j < KD_NU; ++j)
            R[a * KD_NU + j] = n[0] * J[j] + n[1] * J[KD_NU + j] + n[2] * J[2 * KD_NU + j];
    }
    if (!kd_seg_independent(R, k)) return 2;
    for (int j = 0; j < KD_NU; ++j) {
        X[(k + 1) * j] = f[j];
        for (int a = 0; a < k; ++a) X[(k + 1) * j + 1 + a] = R[a * KD_NU + j];
    }
    memcpy(A, M, sizeof(A));
    if (kd_lu_solve(KD_NU, A, X, k + 1) != 0) return 1;
    for (int a = 0; a < k; ++a) {
        int c = act[a];
        const double *n = o->normal + 3 * c, *v = o->vel + 3 * c;
        double dist = o->gap[c] / o->grad[c], w = S->stab;
        lam[a] = -(rate[c] + 2 * w * kd_dot3(n, v) + w * w * dist);
        for (int j = 0; j < KD_NU; ++j) {
            lam[a] -= R[a * KD_NU + j] * X[(k + 1) * j];
            for (int b = 0; b < k; ++b)
                W[k * a + b] = (j ? W[k * a + b] : 0.0) + R[a * KD_NU + j] * X[(k + 1) * j + 1 + b];
        }
    }
    if (kd_lu_solve(k, W, lam, 1) != 0) return 2;
    double *ud = zd + KD_NQ, power = 0.0;
    const double *u = z + KD_NQ;
    for (int j = 0; j < KD_NU; ++j) {
        ud[j] = X[(k + 1) * j];
        for (int a = 0; a < k; ++a) ud[j] += X[(k + 1) * j + 1 + a] * lam[a];
    }
    for (int a = 0; a < k; ++a) {
        int c = act[a];
        o->N[c] = lam[a];
        for (int i = 0; i < 3; ++i) o->total[3 * c + i] = lam[a] * o->normal[3 * c + i];
        for (int j = 0; j < KD_NU; ++j) power += lam[a] * R[a * KD_NU + j] * u[j];
    }
    zd[KD_NX] = 0.0;
    zd[KD_NX + 1] = power;
    for (int i = 0; i < KD_NZ; ++i) if (!isfinite(zd[i])) return 1;
    return 0;
}
#endif

#ifdef KD_GENERAL_CONTACTS
static int kd_seg_general(KdSeg *S, const double *z, double *zd, KdSegOut *o,
                          const double *M, const double *f, const double *jac,
                          const double *acc, const double *rate);
/* what the segment solver cannot do alone: the general solve where S asks for it */
#define KD_SEG_OTHERWISE \
    (S->general ? kd_seg_general(S, z, zd, o, M, f, jac, acc, rate) : 2)
#else
#define KD_SEG_OTHERWISE 2
#endif

/* z' and the contact forces for the fixed modes: 0, 1 singular / not finite,
   2 not handled here */
static int kd_seg_solve(KdSeg *S, double t, const double *z, double *zd, KdSegOut *o) {
#if KD_NUDEP > 0 || KD_NR > 0
    (void)S; (void)t; (void)z; (void)zd; (void)o;
    return 2;
#else
    const double r[1] = {0.0};
    double qd[KD_SZ(KD_NQ)], M[KD_NU * KD_NU], f[KD_NU], B[1], Ka[1], fa[1];
    double jac[3 * KD_NC * KD_NU], acc[3 * KD_NC], rate[KD_NC];
    S->nfev++;
    kd_eval_dynamics(t, z, S->p, r, S->w, qd, M, f, B, Ka, fa);
    kd_eval_contacts(t, z, S->p, r, S->w, o->gap, o->grad, o->normal, o->vel, jac, acc, rate);
    const double *u = z + KD_NQ;
    int c = -1;
    for (int i = 0; i < KD_NC; ++i) {
        const double *n = o->normal + 3 * i, *v = o->vel + 3 * i;
        double vn = kd_dot3(n, v);
        for (int a = 0; a < 3; ++a) { o->vt[3 * i + a] = v[a] - vn * n[a]; o->total[3 * i + a] = 0.0; }
        o->N[i] = 0.0;
        if (S->modes[i] != 0) { if (c >= 0) c = -2; else if (c == -1) c = i; }
    }
    memcpy(zd, qd, sizeof(double) * KD_NQ);
    if (c == -2) {
        int st = kd_seg_frictionless(S, z, zd, o, M, f, jac, acc, rate);
        return st == 2 ? KD_SEG_OTHERWISE : st;
    }
    double *ud = zd + KD_NQ;
    double A[KD_NU * KD_NU];
    memcpy(A, M, sizeof(A));
    if (c < 0) {
        memcpy(ud, f, sizeof(double) * KD_NU);
        if (kd_lu_solve(KD_NU, A, ud, 1) != 0) return 1;
        zd[KD_NX] = zd[KD_NX + 1] = 0.0;
    } else {
        const double *J = jac + 3 * c * KD_NU, *n = o->normal + 3 * c, *v = o->vel + 3 * c;
        const double *vt = o->vt + 3 * c;
        const double w = S->stab;
        double dist = o->gap[c] / o->grad[c];
        double corr = 2 * w * kd_dot3(n, v) + w * w * dist;
        double F[KD_NU], tot[3];
        for (int j = 0; j < KD_NU; ++j) {
            F[j] = f[j];
            if (S->visc[c] != 0.0)
                for (int i = 0; i < 3; ++i) F[j] -= S->visc[c] * J[i * KD_NU + j] * vt[i];
        }
        if (S->modes[c] == 1) {
            double s[3], col[KD_NU], row[KD_NU], X[2 * KD_NU], m = S->mu_k[c];
            double nc = 0.0, nr = 0.0, den = 0.0, r0 = 0.0;
            kd_seg_slip_dir(S, c, n, v, vt, NULL, s);
            for (int j = 0; j < KD_NU; ++j) {
                col[j] = row[j] = 0.0;
                for (int i = 0; i < 3; ++i) {
                    col[j] += J[i * KD_NU + j] * (n[i] - m * s[i]);
                    row[j] += n[i] * J[i * KD_NU + j];
                }
                X[2 * j] = F[j]; X[2 * j + 1] = col[j];
                nc += col[j] * col[j]; nr += row[j] * row[j];
            }
            if (kd_lu_solve(KD_NU, A, X, 2) != 0) return 1;
            for (int j = 0; j < KD_NU; ++j) { den += row[j] * X[2 * j + 1]; r0 += row[j] * X[2 * j]; }
            if (!(fabs(den) > 1e-12 * sqrt(nr) * sqrt(nc))) return KD_SEG_OTHERWISE;
            double N = (-(rate[c] + corr) - r0) / den;
            for (int j = 0; j < KD_NU; ++j) ud[j] = X[2 * j] + N * X[2 * j + 1];
            for (int i = 0; i < 3; ++i) tot[i] = N * (n[i] - m * s[i]);
        } else {
            /* the force acts along, and the constraint holds, the directions
               the point can move in: Q, an orthonormal basis of range(J) (the
               eigenvectors of J J^T with nonzero eigenvalues) */
            double JJ[9], V[9], ev[3], Q[9], X[4 * KD_NU], Wc[9], lam[3], big = 0.0;
            int rank = 0;
            for (int a = 0; a < 3; ++a)
                for (int b = 0; b < 3; ++b) {
                    double sum = 0.0;
                    for (int j = 0; j < KD_NU; ++j) sum += J[a * KD_NU + j] * J[b * KD_NU + j];
                    JJ[3 * a + b] = sum;
                }
            kd_jacobi3(JJ, ev, V);
            for (int a = 0; a < 3; ++a) big = fmax(big, ev[a]);
            if (!(big > 0)) return KD_SEG_OTHERWISE;
            for (int a = 0; a < 3; ++a) {
                double rel = ev[a] / big;
                if (rel > 1e-20 && rel < 1e-8) return KD_SEG_OTHERWISE;  /* rank unclear */
                if (rel >= 1e-8) {
                    for (int i = 0; i < 3; ++i) Q[3 * i + rank] = V[3 * i + a];
                    rank++;
                }
            }
            /* X = M^-1 [F, J^T Q] */
            for (int j = 0; j < KD_NU; ++j) {
                X[4 * j] = F[j];
                for (int b = 0; b < 3; ++b) {
                    double sum = 0.0;
                    if (b < rank) for (int i = 0; i < 3; ++i) sum += J[i * KD_NU + j] * Q[3 * i + b];
                    X[4 * j + 1 + b] = sum;
                }
            }
            if (kd_lu_solve(KD_NU, A, X, 4) != 0) return 1;
            /* Wc = Q^T J X[:, 1:], rhs -(Q^T (acc + corr n) + Q^T J X[:, 0]) */
            for (int a = 0; a < rank; ++a) {
                double qa = 0.0;
                for (int i = 0; i < 3; ++i) qa += Q[3 * i + a] * (acc[3 * c + i] + corr * n[i]);
                lam[a] = -qa;
                for (int j = 0; j < KD_NU; ++j) {
                    double qj = 0.0;
                    for (int i = 0; i < 3; ++i) qj += Q[3 * i + a] * J[i * KD_NU + j];
                    lam[a] -= qj * X[4 * j];
                    for (int b = 0; b < rank; ++b)
                        Wc[rank * a + b] = (j ? Wc[rank * a + b] : 0.0) + qj * X[4 * j + 1 + b];
                }
            }
            if (kd_lu_solve(rank, Wc, lam, 1) != 0) return KD_SEG_OTHERWISE;
            for (int j = 0; j < KD_NU; ++j) {
                ud[j] = X[4 * j];
                for (int b = 0; b < rank; ++b) ud[j] += X[4 * j + 1 + b] * lam[b];
            }
            for (int i = 0; i < 3; ++i) {
                tot[i] = 0.0;
                for (int b = 0; b < rank; ++b) tot[i] += Q[3 * i + b] * lam[b];
            }
        }
        double N = kd_dot3(tot, n), fr[3], Ju[3];
        o->N[c] = N;
        for (int i = 0; i < 3; ++i) {
            o->total[3 * c + i] = tot[i];
            fr[i] = tot[i] - N * n[i] - S->visc[c] * vt[i];
            Ju[i] = 0.0;
            for (int j = 0; j < KD_NU; ++j) Ju[i] += J[i * KD_NU + j] * u[j];
        }
        zd[KD_NX] = kd_dot3(fr, v);
        zd[KD_NX + 1] = (N * n[0] + fr[0]) * Ju[0] + (N * n[1] + fr[1]) * Ju[1]
                        + (N * n[2] + fr[2]) * Ju[2];
    }
    for (int i = 0; i < KD_NZ; ++i) if (!isfinite(zd[i])) return 1;
    return 0;
#endif
}

/* the event values at (t, z) */
static int kd_seg_events(KdSeg *S, double t, const double *z, double *g) {
    double zd[KD_NZ];
    KdSegOut o;
    int st = kd_seg_solve(S, t, z, zd, &o);
    if (st) return st;
    for (int k = 0; k < S->n_ev; ++k) {
        int c = S->ev_c[k];
        const double *vt = o.vt + 3 * c, *n = o.normal + 3 * c, *tot = o.total + 3 * c;
        switch (S->ev_kind[k]) {
        case 0: g[k] = o.gap[c] / o.grad[c] + S->offset[c]; break;
        case 1: g[k] = o.N[c]; break;
        case 2: {  /* _slip_stop_value of kanedyn.simulation._hybrid */
            double along = kd_dot3(vt, S->ref + 3 * c), speed = sqrt(kd_dot3(vt, vt));
            g[k] = fmax(along, speed - S->slow[c]);
            if (S->slow[c] <= KD_SLOW_STILL * S->still[c] && speed > 0) {
                double turn = fmin(1.0, (1.0 - along / speed) / KD_STALL_TURN);
                g[k] = fmin(g[k], speed - 0.5 * S->still[c] * turn);
            }
            break;
        }
        default: {
            double ft[3];
            for (int i = 0; i < 3; ++i) ft[i] = tot[i] - o.N[c] * n[i];
            g[k] = S->mu_s[c] * fabs(o.N[c]) - sqrt(kd_dot3(ft, ft));
        }
        }
    }
    return 0;
}

static void kd_seg_dense(const KdSeg *S, double t, double *out) {
    double x = (t - S->t_old) / S->h;
    double p1 = x, p2 = x * x, p3 = p2 * x, p4 = p3 * x;
    for (int i = 0; i < KD_NZ; ++i) {
        const double *q = S->Q + 4 * i;
        out[i] = S->z_old[i] + S->h * (q[0] * p1 + q[1] * p2 + q[2] * p3 + q[3] * p4);
    }
}

/* event k of the segment at time t on the continuous extension, for kd_brent
   (_c_integrator.BRENT, which precedes this code); the events' status is kept */
typedef struct { KdSeg *S; int k; int status; } KdSegEvent;

static int kd_seg_event_at(void *ctx, double t, double *g) {
    KdSegEvent *E = (KdSegEvent *)ctx;
    double z[KD_NZ], all[KD_MAXEV];
    kd_seg_dense(E->S, t, z);
    E->status = kd_seg_events(E->S, t, z, all);
    *g = all[E->k];
    return E->status;
}

/* event k's zero in [a, b] by Brent's method; nonzero: the events' status */
static int kd_seg_root(KdSeg *S, int k, double a, double b, double fa, double fb,
                       double *root) {
    KdSegEvent E = {S, k, 0};
    return kd_brent(kd_seg_event_at, &E, a, b, fa, fb, root) != 0 ? E.status : 0;
}

static int kd_seg_f(KdSeg *S, double t, const double *z, double *zd) {
    KdSegOut o;
    return kd_seg_solve(S, t, z, zd, &o);
}


/* what kd_seg_run reports: phase 0 before each step (return nonzero: stop there,
   status 3), phase 1 a point of the segment (t, z) to keep (return nonzero: a
   failure, status -1) */
typedef int (*KdSegKeep)(void *ctx, int phase, double t, const double *z);

/* Integrates the segment of S from (t0, z) toward t1 with SciPy's RK45 (its
   coefficients, error norm, step control and initial step), the events
   evaluated after every accepted step and located by Brent's method on the
   continuous extension.  Status 0: reached t1; 1: event *event ended the
   segment; 2: not handled here, singular or not finite, or the step became too
   small; 3: stopped by keep; -1: keep failed.  On return z holds the last point
   and *t_end its time.  *h_next: the step to try first (0: SciPy's choice) and,
   on return, the one to try next. */
static int kd_seg_run(KdSeg *S, double t0, double t1, double *z, double rtol, double atol,
                      double *h_next, KdSegKeep keep, void *ctx, double *t_end, int *event) {
    int st;
    double t = t0, f[KD_NZ], z_new[KD_NZ], K[7][KD_NZ], ztmp[KD_NZ];
    double g_old[KD_MAXEV], g_new[KD_MAXEV], scale[KD_NZ];
    *event = -1;
    *t_end = t0;
    if (kd_seg_f(S, t, z, f) != 0) return 2;
    if (S->n_ev && kd_seg_events(S, t, z, g_old) != 0) return 2;
    if (keep(ctx, 1, t, z)) return -1;
    double h_abs, interval = t1 - t0;
    if (interval <= 0.0) return 0;
    if (h_next != NULL && *h_next > 0) h_abs = fmin(*h_next, interval);
    else {  /* initial step: SciPy's select_initial_step (order 4) */
        double y1[KD_NZ], f1[KD_NZ], tmp[KD_NZ];
        for (int i = 0; i < KD_NZ; ++i) scale[i] = atol + fabs(z[i]) * rtol;
        double d0 = kd_rms(z, scale, KD_NZ), d1 = kd_rms(f, scale, KD_NZ), h0;
        h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
        h0 = fmin(h0, interval);
        for (int i = 0; i < KD_NZ; ++i) y1[i] = z[i] + h0 * f[i];
        if (kd_seg_f(S, t + h0, y1, f1) != 0) return 2;
        for (int i = 0; i < KD_NZ; ++i) tmp[i] = f1[i] - f[i];
        double d2 = kd_rms(tmp, scale, KD_NZ) / h0, h1;
        if (d1 <= 1e-15 && d2 <= 1e-15) h1 = fmax(1e-6, h0 * 1e-3);
        else h1 = pow(0.01 / fmax(d1, d2), 1.0 / 5.0);
        h_abs = fmin(fmin(100 * h0, h1), interval);
    }
    while (t < t1) {
        if (keep(ctx, 0, t, z)) return 3;
        double min_step = 10 * fabs(nextafter(t, INFINITY) - t);
        if (h_abs < min_step) h_abs = min_step;
        int accepted = 0, rejected = 0;
        double h = 0.0, t_new = t, err_norm = 0.0, wanted = h_abs;
        while (!accepted) {
            if (h_abs < min_step) return 2;
            wanted = h_abs;
            t_new = t + h_abs;
            if (t_new > t1) t_new = t1;
            h = t_new - t;
            h_abs = fabs(h);
            memcpy(K[0], f, sizeof(f));
            for (int s = 1; s < 7; ++s) {
                for (int i = 0; i < KD_NZ; ++i) {
                    double a = 0.0;
                    for (int j = 0; j < s; ++j) a += kd_A[s][j] * K[j][i];
                    ztmp[i] = z[i] + h * a;
                }
                if (s == 6) memcpy(z_new, ztmp, sizeof(z_new));
                if (kd_seg_f(S, t + kd_C[s] * h, ztmp, K[s]) != 0) return 2;
            }
            double err[KD_NZ];
            for (int i = 0; i < KD_NZ; ++i) {
                double e = 0.0;
                for (int s = 0; s < 7; ++s) e += kd_E[s] * K[s][i];
                err[i] = e * h;
                scale[i] = atol + fmax(fabs(z[i]), fabs(z_new[i])) * rtol;
            }
            err_norm = kd_rms(err, scale, KD_NZ);
            if (err_norm < 1) {
                double factor = err_norm == 0 ? 10.0 : fmin(10.0, 0.9 * pow(err_norm, -0.2));
                if (rejected) factor = fmin(1.0, factor);
                h_abs *= factor;
                accepted = 1;
            } else {
                double factor = 0.9 * pow(err_norm, -0.2);
                if (!(factor > 0.2)) factor = 0.2;
                h_abs *= factor;
                rejected = 1;
            }
        }
        if (h_next != NULL) *h_next = t_new == t1 ? fmax(wanted, h_abs) : h_abs;
        S->t_old = t; S->h = h;
        memcpy(S->z_old, z, sizeof(double) * KD_NZ);
        for (int i = 0; i < KD_NZ; ++i)
            for (int j = 0; j < 4; ++j) {
                double s = 0.0;
                for (int k = 0; k < 7; ++k) s += K[k][i] * kd_P[k][j];
                S->Q[4 * i + j] = s;
            }
        if (S->n_ev) {
            if (kd_seg_events(S, t_new, z_new, g_new) != 0) return 2;
            double first = INFINITY;
            for (int k = 0; k < S->n_ev; ++k) {
                if (!(g_old[k] >= 0 && g_new[k] <= 0)) continue;  /* direction -1 */
                double root;
                if ((st = kd_seg_root(S, k, t, t_new, g_old[k], g_new[k], &root)) != 0)
                    return 2;
                if (root < first) { first = root; *event = k; }
            }
            if (*event >= 0) {
                kd_seg_dense(S, first, z);
                *t_end = first;
                return keep(ctx, 1, first, z) ? -1 : 1;
            }
            memcpy(g_old, g_new, sizeof(double) * S->n_ev);
        }
        t = t_new;
        memcpy(z, z_new, sizeof(double) * KD_NZ);
        memcpy(f, K[6], sizeof(f));
        *t_end = t;
        if (keep(ctx, 1, t, z)) return -1;
    }
    return 0;
}
"""

CONTACT = SEGMENT + r"""
/* the Python entry's keep (kd_seg_run): the points into buffers; before a step,
   Python's signals, the guard's stop flag and its time limit */
typedef struct {
    KdBuf *t, *z;
    const volatile npy_int32 *stop;
    double deadline, next_yield;
    unsigned long steps;
    int interrupted;  /* -1: an exception other than KeyboardInterrupt is set */
} KdSegPy;

static int kd_seg_keep_py(void *ctx, int phase, double t, const double *z) {
    KdSegPy *k = (KdSegPy *)ctx;
    if (phase == 1) return kd_buf_push(k->t, &t, 1) || kd_buf_push(k->z, z, KD_NZ);
    if (PyErr_CheckSignals() != 0) {
        if (!PyErr_ExceptionMatches(PyExc_KeyboardInterrupt)) { k->interrupted = -1; return 1; }
        PyErr_Clear();  /* stopped (Ctrl-C): what it has */
        return 1;
    }
    return *k->stop || kd_pause(&k->steps, k->deadline, &k->next_yield);
}

static int kd_seg_array(PyObject *obj, npy_intp n, int integer, void *out) {
    PyArrayObject *a = (PyArrayObject *)PyArray_FROMANY(obj, integer ? NPY_INT : NPY_DOUBLE,
                                                        0, 2, NPY_ARRAY_IN_ARRAY);
    if (a == NULL) return -1;
    if (PyArray_SIZE(a) != n) {
        PyErr_Format(PyExc_ValueError, "contact_segment: an array of the spec has %zd "
                     "entries, expected %zd", (Py_ssize_t)PyArray_SIZE(a), (Py_ssize_t)n);
        Py_DECREF(a);
        return -1;
    }
    if (n) memcpy(out, PyArray_DATA(a), (integer ? sizeof(int) : sizeof(double)) * n);
    Py_DECREF(a);
    return 0;
}

static PyObject *kd_py_contact_segment(PyObject *self, PyObject *args) {
    double t0, t1, rtol, atol, timeout = 0.0;
    PyObject *z0obj, *pobj, *spec, *stopobj = NULL;
    (void)self;
    if (!PyArg_ParseTuple(args, "ddOOO!dd|Od", &t0, &t1, &z0obj, &pobj, &PyTuple_Type, &spec,
                          &rtol, &atol, &stopobj, &timeout))
        return NULL;
    const volatile npy_int32 *stop = kd_stop_flag(stopobj);
    if (stop == NULL) return NULL;
    double deadline = timeout > 0 ? kd_clock() + timeout : 0.0;
    double next_yield = kd_clock() + KD_YIELD_SECONDS;
    if (PyTuple_GET_SIZE(spec) != 12) {
        PyErr_SetString(PyExc_ValueError, "contact_segment: spec must have 12 entries");
        return NULL;
    }
    KdSeg S;
    memset(&S, 0, sizeof(S));
    PyObject *keep_z = NULL, *keep_p = NULL, *result = NULL;
    static const double empty[1] = {0.0};
    const double *z0 = kd_vector(z0obj, KD_NZ, &keep_z, "z0");
    if (z0 == NULL) return NULL;
    S.p = empty;
    if (KD_NP > 0 && (S.p = kd_vector(pobj, KD_NP, &keep_p, "p")) == NULL) {
        Py_XDECREF(keep_z);
        return NULL;
    }
    S.w = (double *)PyMem_Malloc(sizeof(double) * KD_SZ(KD_NW));
    KdBuf out_t = {0}, out_z = {0};
    if (S.w == NULL) { PyErr_NoMemory(); goto done; }
    PyObject *ec = PyTuple_GET_ITEM(spec, 10);
    S.n_ev = (int)PyObject_Length(ec);
    if (S.n_ev < 0 || S.n_ev > KD_MAXEV) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "contact_segment: too many events");
        goto done;
    }
    if (kd_seg_array(PyTuple_GET_ITEM(spec, 0), KD_NC, 1, S.modes)
        || kd_seg_array(PyTuple_GET_ITEM(spec, 1), KD_NC, 1, S.has_ref)
        || kd_seg_array(PyTuple_GET_ITEM(spec, 2), 3 * KD_NC, 0, S.ref)
        || kd_seg_array(PyTuple_GET_ITEM(spec, 3), KD_NC, 0, S.slow)
        || kd_seg_array(PyTuple_GET_ITEM(spec, 4), KD_NC, 0, S.still)
        || kd_seg_array(PyTuple_GET_ITEM(spec, 5), KD_NC, 0, S.offset)
        || kd_seg_array(PyTuple_GET_ITEM(spec, 6), KD_NC, 0, S.mu_k)
        || kd_seg_array(PyTuple_GET_ITEM(spec, 7), KD_NC, 0, S.mu_s)
        || kd_seg_array(PyTuple_GET_ITEM(spec, 8), KD_NC, 0, S.visc)
        || kd_seg_array(PyTuple_GET_ITEM(spec, 10), S.n_ev, 1, S.ev_c)
        || kd_seg_array(PyTuple_GET_ITEM(spec, 11), S.n_ev, 1, S.ev_kind))
        goto done;
    S.stab = PyFloat_AsDouble(PyTuple_GET_ITEM(spec, 9));
    if (S.stab == -1.0 && PyErr_Occurred()) goto done;

    KdSegPy keep = {&out_t, &out_z, stop, deadline, next_yield, 0, 0};
    double z[KD_NZ], t_end;
    int event = -1;
    memcpy(z, z0, sizeof(z));
    int status = kd_seg_run(&S, t0, t1, z, rtol, atol, NULL, kd_seg_keep_py, &keep, &t_end,
                            &event);
    if (status == -1) goto done;
    if (status == 3 && keep.interrupted < 0) goto done;  /* an exception other than Ctrl-C */
    {
        PyObject *ta = kd_buf_array(&out_t, out_t.n, -1);
        PyObject *za = kd_buf_array(&out_z, out_t.n, KD_NZ);
        if (ta && za) result = Py_BuildValue("(iNNil)", status, ta, za, event, S.nfev);
        else { Py_XDECREF(ta); Py_XDECREF(za); }
    }
done:
    PyMem_Free(out_t.data);
    PyMem_Free(out_z.data);
    PyMem_Free(S.w);
    Py_XDECREF(keep_z);
    Py_XDECREF(keep_p);
    return result;
}
"""
