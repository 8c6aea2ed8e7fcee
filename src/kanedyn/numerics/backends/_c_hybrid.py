r"""C source of the contact loop of the standalone export (no Python).

What :func:`kanedyn.simulation._hybrid.simulate_contacts` does between and at
events, in C, for an FMU (its co-simulation step; the same event handling for
model exchange, below): the segments between events are
integrated by the compiled contact segment (:data:`._c_contact.SEGMENT`: SciPy's
RK45, the mode's event functions located by Brent's method on the continuous
extension); at an event the modes change as there (the gap closes, the normal
force vanishes, the slip stops, the friction reaches :math:`\mu_s N`), impacts
are resolved by the single-contact law of
:func:`kanedyn.simulation._impact._single` (Poisson or Newton restitution,
Coulomb friction integrated over the normal impulse: in closed form, or where
the slip turns by :mod:`._c_impact_slide`) or, where
several contacts take part (those hitting and those already touching), by
:func:`kanedyn.simulation._impact._simultaneous` (:mod:`._c_impacts`), and the
modes are settled (forces within their limits) before integration resumes.
Several active contacts are solved by the general path of
:func:`kanedyn.numerics._contact_dynamics.solve_modes`
(:mod:`._c_contact_general`).  Tolerances, rest speed, Baumgarte frequency
(10 rad/s) and the choice of slip references (from the slip velocities free of
the other contacts' drift) are those of ``kd.simulate``'s defaults.

What it does not do, a failure with a message naming the contacts (code 5,
``kanedyn_contact_message``): a singular or non-finite contact solve, modes that
do not settle (``kd.simulate`` stops there too).  The export refuses bilateral
contacts, dependent speeds and specified inputs before (``io.fmu``).

Public interface (appended to ``model.c``; ``z`` is the state followed by the
work of the friction forces and of all contact forces [J])::

    size_t kanedyn_contact_state_size(void);
    int kanedyn_contact_start(double t, double *z, const double *p, void *state,
                              double atol);
    int kanedyn_contact_advance(double t0, double t1, double *z, const double *p,
                                void *state, double rtol, double atol, long *steps);
    int kanedyn_contact_mode(const void *state, int contact);
    const char *kanedyn_contact_message(const void *state);

and for model exchange (``y`` the state alone)::

    int kanedyn_contact_derivatives(double t, const double *y, const double *p,
                                    void *state, double *ydot);
    int kanedyn_contact_indicators(double t, const double *y, const double *p,
                                   void *state, double *g);
    int kanedyn_contact_update(double t, double *y, const double *p, void *state,
                               int *changed);

The derivatives are those of the current modes; the two indicators of a contact
are its current mode's event functions (the gap; or the normal force and the
slip's stop or the friction margin; 1 where unused), positive until the event;
the update applies the event whose function has fallen to zero or below, as the
co-simulation step does at the event it locates.
"""

from __future__ import annotations

__all__ = ["HYBRID"]

HYBRID = r"""
#include <stdio.h>
/* ------------------------------------------------------------------------
   The contact loop: modes, events and impacts (kanedyn_contact_*)
   ------------------------------------------------------------------------ */
enum { KD_SEP = 0, KD_SLIP = 1, KD_STICK = 2 };

typedef struct {
    int modes[KD_NC], has_ref[KD_NC], bounced[KD_NC], fresh;
    double ref[3 * KD_NC], slow[KD_NC], still[KD_NC], bounce_t[KD_NC], bounce_v[KD_NC];
    double mu_k[KD_NC], mu_s[KD_NC], visc[KD_NC], e[KD_NC];
    double tol_d, tol_v, tol_slip, tol_f, tol_a, tol_lift, rest, stab, h;
    long events, impacts;
    double *w;
    KdSeg seg;                         /* model exchange: the current segment's events */
    char message[480];
} KdHybrid;

typedef struct {
    double gap[KD_NC], grad[KD_NC], normal[3 * KD_NC], vel[3 * KD_NC];
    double jac[3 * KD_NC * KD_NU], acc[3 * KD_NC], rate[KD_NC];
} KdPoints;

static void kd_hy_points(KdHybrid *H, double t, const double *z, const double *p, KdPoints *P) {
    const double r[1] = {0.0};
    kd_eval_contacts(t, z, p, r, H->w, P->gap, P->grad, P->normal, P->vel, P->jac, P->acc,
                     P->rate);
}

static double kd_hy_dist(const KdPoints *P, int c) { return P->gap[c] / P->grad[c]; }
static double kd_hy_vn(const KdPoints *P, int c) {
    return kd_dot3(P->normal + 3 * c, P->vel + 3 * c);
}
static double kd_hy_slip(const KdPoints *P, int c, double *vt) {
    double vn = kd_hy_vn(P, c);
    for (int i = 0; i < 3; ++i) vt[i] = P->vel[3 * c + i] - vn * P->normal[3 * c + i];
    return sqrt(kd_dot3(vt, vt));
}

static int kd_hy_fail(KdHybrid *H, int c, double t, const char *what) {
    if (c >= 0) snprintf(H->message, sizeof H->message, "contact %s at t = %.17g: %s",
                         kanedyn_contact_names[c], t, what);
    else snprintf(H->message, sizeof H->message, "at t = %.17g: %s", t, what);
    return 5;
}

/* several active contacts: the message naming them */
static int kd_hy_several(KdHybrid *H, double t, const int *modes, const char *what) {
    char names[256] = "";
    for (int c = 0; c < KD_NC; ++c)
        if (modes[c] != KD_SEP && strlen(names) + strlen(kanedyn_contact_names[c]) + 3 < sizeof names) {
            if (names[0]) strcat(names, ", ");
            strcat(names, kanedyn_contact_names[c]);
        }
    snprintf(H->message, sizeof H->message, "contacts %s at t = %.17g: %s", names, t, what);
    return 5;
}

/* the contact equations of modes cannot be solved: the message names the active
   contacts (code 5) */
static int kd_hy_singular(KdHybrid *H, double t, const int *modes) {
    const char *what = "singular or not finite contact equations";
    for (int c = 0; c < KD_NC; ++c)
        if (modes[c] != KD_SEP) return kd_hy_several(H, t, modes, what);
    return kd_hy_fail(H, -1, t, what);
}

/* the segment solver for modes (and the references of H) */
static void kd_hy_seg(const KdHybrid *H, const double *p, const int *modes, KdSeg *S) {
    memset(S, 0, sizeof *S);
    S->p = p;
    S->w = H->w;
    memcpy(S->modes, modes, sizeof S->modes);
    memcpy(S->has_ref, H->has_ref, sizeof S->has_ref);
    memcpy(S->ref, H->ref, sizeof S->ref);
    memcpy(S->slow, H->slow, sizeof S->slow);
    memcpy(S->still, H->still, sizeof S->still);
    memcpy(S->mu_k, H->mu_k, sizeof S->mu_k);
    memcpy(S->mu_s, H->mu_s, sizeof S->mu_s);
    memcpy(S->visc, H->visc, sizeof S->visc);
    S->stab = H->stab;
    S->general = 1;
}

static int kd_hy_solve(KdHybrid *H, double t, const double *z, const double *p,
                       const int *modes, KdSegOut *o) {
    KdSeg S;
    double zd[KD_NZ];
    kd_hy_seg(H, p, modes, &S);
    int st = kd_seg_solve(&S, t, z, zd, o);
    if (st) return kd_hy_singular(H, t, modes);
    return 0;
}

static int kd_hy_touching_mode(const KdHybrid *H, const KdPoints *P, int c) {
    double vt[3];
    return (H->mu_s[c] == 0 || kd_hy_slip(P, c, vt) > H->tol_slip) ? KD_SLIP : KD_STICK;
}

/* how fast contact c would leave its surface if it were free (see _hybrid) */
static int kd_hy_free_normal(KdHybrid *H, double t, const double *z, const double *p,
                             const int *modes, int c, const KdPoints *P, double *out) {
    int free_modes[KD_NC];
    double zd[KD_NZ];
    KdSeg S;
    KdSegOut o;
    memcpy(free_modes, modes, sizeof free_modes);
    free_modes[c] = KD_SEP;
    kd_hy_seg(H, p, free_modes, &S);
    int st = kd_seg_solve(&S, t, z, zd, &o);
    if (st) return kd_hy_solve(H, t, z, p, free_modes, &o);
    const double *n = P->normal + 3 * c, *J = P->jac + 3 * c * KD_NU;
    double acc = P->rate[c], held;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < KD_NU; ++j) acc += n[i] * J[i * KD_NU + j] * zd[KD_NQ + j];
    held = -(2 * H->stab * kd_hy_vn(P, c) + H->stab * H->stab * kd_hy_dist(P, c));
    *out = acc - held;
    return 0;
}

/* modes consistent with the state: forces within limits, gaps open (_hybrid.settle);
   stopped: per contact the slip speed (free of the other contacts' drift) of a slip
   that has just stopped, against which its stick is judged, or < 0 (its own slip
   speed); NULL: none */
static int kd_hy_settle(KdHybrid *H, double t, const double *z, const double *p,
                        const double *stopped) {
    KdPoints P;
    kd_hy_points(H, t, z, p, &P);
    for (int c = 0; c < KD_NC; ++c) {
        int touching = kd_hy_dist(&P, c) <= H->tol_d, leaving = kd_hy_vn(&P, c) > H->tol_v;
        if (H->modes[c] == KD_SEP && touching && !leaving) {
            double a = 0.0;
            int st = kd_hy_free_normal(H, t, z, p, H->modes, c, &P, &a);
            if (st) return st;
            if (a < -H->tol_a) H->modes[c] = kd_hy_touching_mode(H, &P, c);
        } else if (H->modes[c] != KD_SEP) {
            if (leaving) H->modes[c] = KD_SEP;
            else if (H->modes[c] == KD_STICK) {
                double vt[3], speed = stopped && stopped[c] >= 0 ? stopped[c]
                                                                  : kd_hy_slip(&P, c, vt);
                if (speed > H->tol_slip) H->modes[c] = KD_SLIP;
            }
        }
    }
    for (int round = 0; round < 4 * KD_NC + 4; ++round) {
        KdSegOut o;
        int st = kd_hy_solve(H, t, z, p, H->modes, &o), changed = 0;
        if (st) return st;
        for (int c = 0; c < KD_NC && !changed; ++c) {
            if (H->modes[c] == KD_SEP) continue;
            double N = o.N[c];
            if (N < -H->tol_f) { H->modes[c] = KD_SEP; changed = 1; break; }
            if (H->modes[c] == KD_STICK) {
                double ft[3];
                for (int i = 0; i < 3; ++i) ft[i] = o.total[3 * c + i] - N * o.normal[3 * c + i];
                double size = sqrt(kd_dot3(ft, ft));
                if (size > H->mu_s[c] * fabs(N) + H->tol_f) {
                    H->modes[c] = KD_SLIP;
                    H->has_ref[c] = 1;
                    for (int i = 0; i < 3; ++i) H->ref[3 * c + i] = -ft[i] / size;
                    H->slow[c] = INFINITY;
                    H->still[c] = H->tol_slip;
                    changed = 1;
                }
            }
        }
        if (!changed) return 0;
    }
    return kd_hy_fail(H, -1, t, "the contact modes do not settle: no mode assignment keeps "
                      "the normal forces pushing and the friction within its cone");
}

/* ----------------------------------------------- one contact's impact (_impact._single) */
static void kd_hy_matvec(const double *W, const double *x, double *out) {
    for (int a = 0; a < 3; ++a) out[a] = W[3 * a] * x[0] + W[3 * a + 1] * x[1] + W[3 * a + 2] * x[2];
}

/* the impulse on one contact point */
static void kd_hy_single(const double *W, const double *v0, const double *n, double mu_k,
                         double mu_s, double e, int newton, double *P_out) {
    double vn0 = kd_dot3(n, v0), T1[3], T2[3], a[3];
    for (int i = 0; i < 3; ++i) P_out[i] = 0.0;
    if (vn0 >= 0) return;
    if (fabs(n[0]) < 0.9) { a[0] = 1; a[1] = 0; a[2] = 0; } else { a[0] = 0; a[1] = 1; a[2] = 0; }
    T1[0] = n[1] * a[2] - n[2] * a[1]; T1[1] = n[2] * a[0] - n[0] * a[2]; T1[2] = n[0] * a[1] - n[1] * a[0];
    double t1n = sqrt(kd_dot3(T1, T1));
    for (int i = 0; i < 3; ++i) T1[i] /= t1n;
    T2[0] = n[1] * T1[2] - n[2] * T1[1]; T2[1] = n[2] * T1[0] - n[0] * T1[2]; T2[2] = n[0] * T1[1] - n[1] * T1[0];
    double Wn[3], WT1[3], WT2[3], A2[4], b2[2], a2[2], stick_rate[3];
    kd_hy_matvec(W, n, Wn); kd_hy_matvec(W, T1, WT1); kd_hy_matvec(W, T2, WT2);
    A2[0] = kd_dot3(T1, WT1); A2[1] = kd_dot3(T1, WT2); A2[2] = kd_dot3(T2, WT1); A2[3] = kd_dot3(T2, WT2);
    A2[1] = A2[2] = 0.5 * (A2[1] + A2[2]);
    b2[0] = -kd_dot3(T1, Wn); b2[1] = -kd_dot3(T2, Wn);
    kd_pinv2(A2, b2, a2);
    for (int i = 0; i < 3; ++i) stick_rate[i] = T1[i] * a2[0] + T2[i] * a2[1];
    int can_stick = sqrt(a2[0] * a2[0] + a2[1] * a2[1]) <= mu_s * (1 + 1e-12);
    double scale = fmax(sqrt(kd_dot3(v0, v0)), 1e-300), slip_tol = 1e-9 * scale;
    double p_scale = fabs(vn0) / fmax(kd_dot3(n, Wn), 1e-300);
    double p_bound = 1e3 * p_scale * (1 + mu_k) + 1e-300, target = -e * vn0;
    double p = 0.0, v[3], Pt[3] = {0, 0, 0}, pc = -1.0;  /* pc < 0: compression goes on */
    memcpy(v, v0, sizeof v);
    for (int phase = 0; phase < 100; ++phase) {
        double stop_p = (pc >= 0 && !newton) ? (1 + e) * pc : p_bound;
        if (stop_p <= p) break;
        double vt[3], vnv = kd_dot3(n, v), speed, rate[3], x[3], p_next;
        for (int i = 0; i < 3; ++i) vt[i] = v[i] - vnv * n[i];
        speed = sqrt(kd_dot3(vt, vt));
        int sliding = speed > slip_tol;
        if (!sliding && can_stick) {
            for (int i = 0; i < 3; ++i) x[i] = n[i] + stick_rate[i];
            kd_hy_matvec(W, x, rate);
            double rn = kd_dot3(n, rate);
            p_next = stop_p;
            if (pc < 0 && rn > 0) { double x_ = p - vnv / rn; if (x_ >= p) p_next = fmin(p_next, x_); }
            if (pc >= 0 && newton && rn > 0) { double x_ = p + (target - vnv) / rn; if (x_ >= p) p_next = fmin(p_next, x_); }
            for (int i = 0; i < 3; ++i) {
                v[i] += (p_next - p) * rate[i];
                Pt[i] += (p_next - p) * stick_rate[i];
            }
            p = p_next;
        } else {
            double dir[3], cst[3], drift[3];
            if (sliding) for (int i = 0; i < 3; ++i) dir[i] = vt[i] / speed;
            else {  /* the direction slip grows in from rest */
                double sr = fmax(sqrt(kd_dot3(stick_rate, stick_rate)), 1e-300);
                for (int i = 0; i < 3; ++i) dir[i] = -stick_rate[i] / sr;
                for (int it = 0; it < 100; ++it) {
                    double g[3], Wg[3], nd[3], diff = 0.0;
                    for (int i = 0; i < 3; ++i) x[i] = n[i] - mu_k * dir[i];
                    kd_hy_matvec(W, x, Wg);
                    double c1 = kd_dot3(T1, Wg), c2 = kd_dot3(T2, Wg);
                    for (int i = 0; i < 3; ++i) g[i] = T1[i] * c1 + T2[i] * c2;
                    double gn = fmax(sqrt(kd_dot3(g, g)), 1e-300);
                    for (int i = 0; i < 3; ++i) { nd[i] = g[i] / gn; diff += (nd[i] - dir[i]) * (nd[i] - dir[i]); }
                    if (sqrt(diff) < 1e-15) break;
                    memcpy(dir, nd, sizeof dir);
                }
            }
            for (int i = 0; i < 3; ++i) x[i] = n[i] - mu_k * dir[i];
            kd_hy_matvec(W, x, cst);
            double cn = kd_dot3(n, cst), along, off = 0.0;
            for (int i = 0; i < 3; ++i) drift[i] = cst[i] - cn * n[i];
            along = kd_dot3(drift, dir);
            for (int i = 0; i < 3; ++i) off += (drift[i] - along * dir[i]) * (drift[i] - along * dir[i]);
            if (!(sqrt(off) <= 1e-13 * sqrt(kd_dot3(cst, cst)))) {
                /* the slip turns: integrated over the normal impulse */
                kd_imp_slide(W, n, mu_k, dir, slip_tol, pc < 0, newton, target, stop_p, scale,
                             &p, v, Pt);
            } else {  /* the slip keeps its direction: closed form */
                p_next = stop_p;
                if (sliding && along < 0) { double x_ = p - kd_dot3(vt, dir) / along; if (x_ >= p) p_next = fmin(p_next, x_); }
                if (pc < 0 && cn > 0) { double x_ = p - vnv / cn; if (x_ >= p) p_next = fmin(p_next, x_); }
                if (pc >= 0 && newton && cn > 0) { double x_ = p + (target - vnv) / cn; if (x_ >= p) p_next = fmin(p_next, x_); }
                for (int i = 0; i < 3; ++i) {
                    v[i] += (p_next - p) * cst[i];
                    Pt[i] -= (p_next - p) * mu_k * dir[i];
                }
                p = p_next;
                vnv = kd_dot3(n, v);
                for (int i = 0; i < 3; ++i) vt[i] = v[i] - vnv * n[i];
                double along_v = kd_dot3(vt, dir);
                if (sliding && along < 0 && along_v <= slip_tol)
                    for (int i = 0; i < 3; ++i) v[i] -= along_v * dir[i];
            }
        }
        double vn = kd_dot3(n, v);
        if (pc < 0 && vn >= -1e-14 * scale) {
            pc = p;
            if (e == 0) break;
            continue;
        }
        if (pc >= 0 && newton && vn >= target - 1e-14 * scale) break;
        if (pc >= 0 && !newton && p >= (1 + e) * pc * (1 - 1e-15)) break;
    }
    for (int i = 0; i < 3; ++i) P_out[i] = p * n[i] + Pt[i];
}

/* the impact of contact c (restitution e): the speeds of z jump (resolve_impact) */
static int kd_hy_impact(KdHybrid *H, double t, double *z, const double *p, const KdPoints *P,
                        int c, double e) {
    const double r[1] = {0.0};
    double qd[KD_SZ(KD_NQ)], M[KD_NU * KD_NU], f[KD_NU], B[1], Ka[1], fa[1];
    double D[3 * KD_NU], W[9], Pc[3], v1[3];
    const double *J = P->jac + 3 * c * KD_NU, *v0 = P->vel + 3 * c, *n = P->normal + 3 * c;
    kd_eval_dynamics(t, z, p, r, H->w, qd, M, f, B, Ka, fa);
    for (int j = 0; j < KD_NU; ++j)
        for (int i = 0; i < 3; ++i) D[3 * j + i] = J[i * KD_NU + j];
    if (kd_lu_solve(KD_NU, M, D, 3) != 0)
        return kd_hy_fail(H, c, t, "singular mass matrix at the impact");
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            double s = 0.0;
            for (int j = 0; j < KD_NU; ++j) s += J[a * KD_NU + j] * D[3 * j + b];
            W[3 * a + b] = s;
        }
    int newton = kd_contact_law[c];
    for (int attempt = 0; attempt < 2; ++attempt) {
        kd_hy_single(W, v0, n, H->mu_k[c], H->mu_s[c], e, newton, Pc);
        kd_hy_matvec(W, Pc, v1);
        double loss = 0.0;
        for (int i = 0; i < 3; ++i) v1[i] += v0[i];
        loss = -0.5 * (Pc[0] * (v0[0] + v1[0]) + Pc[1] * (v0[1] + v1[1]) + Pc[2] * (v0[2] + v1[2]));
        if (!(newton && loss < -1e-12 * fmax(1.0, fabs(kd_dot3(Pc, v0))))) break;
        newton = 0;  /* Newton's law with friction would gain energy: Poisson's */
    }
    for (int j = 0; j < KD_NU; ++j) z[KD_NQ + j] += D[3 * j] * Pc[0] + D[3 * j + 1] * Pc[1] + D[3 * j + 2] * Pc[2];
    H->impacts++;
    return 0;
}

/* the impact of the k contacts inv (hitting or touching) at once (resolve_impact with
   _simultaneous: Newton's law; without restitution where it would gain energy) */
static int kd_hy_impact_several(KdHybrid *H, double t, double *z, const double *p,
                                const KdPoints *P, const int *inv, int k, const int *plastic) {
    const double r[1] = {0.0};
    double qd[KD_SZ(KD_NQ)], M[KD_NU * KD_NU], f[KD_NU], B[1], Ka[1], fa[1];
    double D[KD_NU * 3 * KD_NC], W[9 * KD_NC * KD_NC], v0[3 * KD_NC], v1[3 * KD_NC];
    double normals[3 * KD_NC], mu[KD_NC], e[KD_NC], Pi[3 * KD_NC];
    int n = 3 * k;
    kd_eval_dynamics(t, z, p, r, H->w, qd, M, f, B, Ka, fa);
    for (int a = 0; a < k; ++a) {
        const double *J = P->jac + 3 * inv[a] * KD_NU;
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < KD_NU; ++j) D[j * n + 3 * a + i] = J[i * KD_NU + j];
            v0[3 * a + i] = P->vel[3 * inv[a] + i];
            normals[3 * a + i] = P->normal[3 * inv[a] + i];
        }
        mu[a] = H->mu_k[inv[a]];
        e[a] = plastic[inv[a]] ? 0.0 : H->e[inv[a]];
    }
    if (kd_lu_solve(KD_NU, M, D, n) != 0) {
        int mask[KD_NC] = {0};
        for (int a = 0; a < k; ++a) mask[inv[a]] = 1;
        return kd_hy_several(H, t, mask, "singular mass matrix at the impact");
    }
    for (int a = 0; a < k; ++a)
        for (int i = 0; i < 3; ++i) {
            const double *J = P->jac + 3 * inv[a] * KD_NU + i * KD_NU;
            for (int col = 0; col < n; ++col) {
                double sum = 0.0;
                for (int j = 0; j < KD_NU; ++j) sum += J[j] * D[j * n + col];
                W[(3 * a + i) * n + col] = sum;
            }
        }
    for (int attempt = 0; attempt < 2; ++attempt) {
        double loss = 0.0, work = 0.0;
        kd_imp_several(k, W, v0, normals, mu, e, Pi);
        for (int a = 0; a < n; ++a) {
            v1[a] = v0[a];
            for (int b = 0; b < n; ++b) v1[a] += W[a * n + b] * Pi[b];
        }
        for (int a = 0; a < n; ++a) { loss -= 0.5 * Pi[a] * (v0[a] + v1[a]); work += Pi[a] * v0[a]; }
        if (!(loss < -1e-12 * fmax(1.0, fabs(work)))) break;
        for (int a = 0; a < k; ++a) e[a] = 0.0;  /* Kane's paradox: no restitution */
    }
    for (int j = 0; j < KD_NU; ++j)
        for (int col = 0; col < n; ++col) z[KD_NQ + j] += D[j * n + col] * Pi[col];
    H->impacts++;
    return 0;
}

/* impacts of approaching contacts (with the contacts already touching), then
   consistent modes (_hybrid._resolve); stopped: as for kd_hy_settle */
static int kd_hy_resolve(KdHybrid *H, double t, double *z, const double *p,
                         const double *stopped) {
    KdPoints P;
    int touching[KD_NC], hitting[KD_NC], plastic[KD_NC], inv[KD_NC], k = 0, any = 0;
    kd_hy_points(H, t, z, p, &P);
    for (int c = 0; c < KD_NC; ++c) {
        touching[c] = kd_hy_dist(&P, c) <= H->tol_d;
        hitting[c] = touching[c] && kd_hy_vn(&P, c) < -H->tol_v;
        any |= hitting[c];
    }
    if (any) {
        int st;
        for (int c = 0; c < KD_NC; ++c) {
            /* too slow to bounce again, or bouncing too little to leave: plastic */
            plastic[c] = hitting[c] && (-kd_hy_vn(&P, c) < H->rest
                                        || (H->bounced[c] && H->bounce_v[c]
                                            * (t - H->bounce_t[c]) <= H->tol_lift));
            if (hitting[c] || (touching[c] && H->modes[c] != KD_SEP)) inv[k++] = c;
        }
        if (k == 1) st = kd_hy_impact(H, t, z, p, &P, inv[0], plastic[inv[0]] ? 0.0 : H->e[inv[0]]);
        else st = kd_hy_impact_several(H, t, z, p, &P, inv, k, plastic);
        if (st) return st;
        kd_hy_points(H, t, z, p, &P);
        for (int a = 0; a < k; ++a) {
            int c = inv[a];
            double vn = kd_hy_vn(&P, c);
            if (vn > H->rest) {
                H->modes[c] = KD_SEP;
                H->bounced[c] = 1;
                H->bounce_t[c] = t;
                H->bounce_v[c] = vn;
            } else {
                H->modes[c] = kd_hy_touching_mode(H, &P, c);
                H->bounced[c] = 0;
            }
        }
    }
    return kd_hy_settle(H, t, z, p, stopped);
}

static int kd_hy_keep(void *ctx, int phase, double t, const double *z) {
    (void)t; (void)z;
    if (phase == 1) ++*(long *)ctx;
    return 0;
}

/* the segment's slip references (at its start, from the slip velocities free of
   the other contacts' drift) and event functions; 0 or 5 */
static int kd_hy_segment(KdHybrid *H, double t, const double *z, const double *p, KdSeg *S) {
    KdPoints P;
    kd_hy_points(H, t, z, p, &P);
    if (H->fresh) {
        KdSegOut o;
        int st = kd_hy_solve(H, t, z, p, H->modes, &o);
        if (st) return st;
        for (int c = 0; c < KD_NC; ++c) {
            const double *vt = o.vt + 3 * c;
            double speed = sqrt(kd_dot3(vt, vt));
            if (H->modes[c] != KD_SLIP) H->has_ref[c] = 0;
            else if (speed > H->tol_slip) {
                H->has_ref[c] = 1;
                for (int i = 0; i < 3; ++i) H->ref[3 * c + i] = vt[i] / speed;
                H->slow[c] = fmax(1e-3 * speed, KD_SLOW_STILL * H->tol_slip);
                H->still[c] = H->tol_slip;
            }
        }
        H->fresh = 0;
    }
    kd_hy_seg(H, p, H->modes, S);
    for (int c = 0; c < KD_NC; ++c) {
        if (H->modes[c] == KD_SEP) {
            S->offset[c] = fmax(0.0, -kd_hy_dist(&P, c)) + 1e-14;
            S->ev_c[S->n_ev] = c; S->ev_kind[S->n_ev++] = 0;
            continue;
        }
        S->ev_c[S->n_ev] = c; S->ev_kind[S->n_ev++] = 1;
        if (H->modes[c] == KD_SLIP && H->has_ref[c] && H->mu_s[c] > 0) {
            S->ev_c[S->n_ev] = c; S->ev_kind[S->n_ev++] = 2;
        } else if (H->modes[c] == KD_STICK) {
            S->ev_c[S->n_ev] = c; S->ev_kind[S->n_ev++] = 3;
        }
    }
    return 0;
}

/* the modes after event `kind` of contact c at (t, z) (simulate_contacts) */
static int kd_hy_event(KdHybrid *H, double t, double *z, const double *p, int c, int kind) {
    double stopped[KD_NC];  /* the slip speeds of the slips that stop here, or -1 */
    for (int i = 0; i < KD_NC; ++i) stopped[i] = -1.0;
    H->events++;
    if (kind == 0) H->modes[c] = KD_STICK;  /* touching; settled below */
    else if (kind == 1) H->modes[c] = KD_SEP;
    else if (kind == 3) {
        KdSegOut o;
        int st = kd_hy_solve(H, t, z, p, H->modes, &o);
        if (st) return st;
        double ft[3], size, vn = kd_dot3(o.normal + 3 * c, o.vel + 3 * c);
        for (int i = 0; i < 3; ++i)  /* the friction, its viscous part on the raw slip */
            ft[i] = o.total[3 * c + i] - o.N[c] * o.normal[3 * c + i]
                    - H->visc[c] * (o.vel[3 * c + i] - vn * o.normal[3 * c + i]);
        size = fmax(sqrt(kd_dot3(ft, ft)), 1e-300);
        H->modes[c] = KD_SLIP;
        H->has_ref[c] = 1;
        for (int i = 0; i < 3; ++i) H->ref[3 * c + i] = -ft[i] / size;
        H->slow[c] = INFINITY;
        H->still[c] = H->tol_slip;
    } else {  /* the slip stops: every sliding contact whose slip (free of the other
                 contacts' drift) has stopped sticks (_stopped) */
        KdSegOut o;
        int st = kd_hy_solve(H, t, z, p, H->modes, &o);
        if (st) return st;
        for (int i = 0; i < KD_NC; ++i) {
            const double *vt = o.vt + 3 * i;
            double speed = sqrt(kd_dot3(vt, vt));
            if (H->modes[i] == KD_SLIP && H->has_ref[i] && (i == c || isfinite(H->slow[i]))
                    && speed <= fmin(H->tol_slip * 1e3, 0.1 * H->slow[i]))
                stopped[i] = speed;
        }
        for (int i = 0; i < KD_NC; ++i) if (stopped[i] >= 0) H->modes[i] = KD_STICK;
    }
    return kd_hy_resolve(H, t, z, p, stopped);
}

size_t kanedyn_contact_state_size(void) { return sizeof(KdHybrid); }

int kanedyn_contact_mode(const void *state, int contact) {
    return ((const KdHybrid *)state)->modes[contact];
}

const char *kanedyn_contact_message(const void *state) {
    return ((const KdHybrid *)state)->message;
}

/* the contacts' modes at the start (t, z): impacts of approaching contacts, then
   forces within their limits; z[KD_NX], z[KD_NX + 1] (the work integrals) set to 0.
   0 or the codes of kanedyn_rhs, 5: see kanedyn_contact_message */
int kanedyn_contact_start(double t, double *z, const double *p, void *state, double atol) {
    KdHybrid *H = (KdHybrid *)state;
    double scale = 1.0;
    memset(H, 0, sizeof *H);
    H->tol_d = H->tol_v = H->tol_slip = fmax(100 * atol, 1e-10);
    H->tol_f = H->tol_a = 1e-9;
    H->tol_lift = 1e-2 * atol;
    H->stab = 10.0;
    for (int i = 0; i < KD_NX; ++i) scale = fmax(scale, fabs(z[i]));
    H->rest = fmax(1e3 * atol, 1e-6) * scale;
    kd_contact_coefficients(p, H->mu_k, H->mu_s, H->visc, H->e);
    z[KD_NX] = z[KD_NX + 1] = 0.0;
    H->w = kd_work();
    if (H->w == NULL) return 2;
    KdPoints P;
    int status = 0;
    kd_hy_points(H, t, z, p, &P);
    for (int c = 0; c < KD_NC && !status; ++c) {
        if (!(P.grad[c] > 0))
            status = kd_hy_fail(H, c, t, "the surface normal vanishes at the contact point");
        else if (kd_hy_dist(&P, c) < -H->tol_d)
            status = kd_hy_fail(H, c, t, "the point starts inside its surface");
    }
    if (!status) status = kd_hy_resolve(H, t, z, p, NULL);
    H->fresh = 1;
    if (!status) status = kd_hy_segment(H, t, z, p, &H->seg);  /* for model exchange */
    kd_free_work(H->w);
    H->w = NULL;
    return status;
}

/* integrates z in place from t0 to t1 through the contact events (kd.simulate's
   contact loop, RK45 with tolerances rtol, atol); *steps counts the steps */
int kanedyn_contact_advance(double t0, double t1, double *z, const double *p, void *state,
                            double rtol, double atol, long *steps) {
    KdHybrid *H = (KdHybrid *)state;
    double t = t0;
    int status = 0, stalled = 0;
    H->w = kd_work();
    if (H->w == NULL) return 2;
    while (t < t1 && !status) {
        KdSeg S;
        double t_end, start = t;
        int event;
        if ((status = kd_hy_segment(H, t, z, p, &S)) != 0) break;
        int st = kd_seg_run(&S, t, t1, z, rtol, atol, &H->h, kd_hy_keep, steps, &t_end, &event);
        if (st == 2) {
            KdSegOut o;
            status = kd_hy_solve(H, t, z, p, H->modes, &o);
            if (!status) status = kd_hy_fail(H, -1, t, "the step size became too small, or "
                                             "the contact equations are singular or not "
                                             "finite");
            break;
        }
        t = t_end;
        if (st == 0) break;
        status = kd_hy_event(H, t, z, p, S.ev_c[event], S.ev_kind[event]);
        H->fresh = 1;
        H->h = 0.0;  /* a new segment: its first step chosen again, as solve_ivp does */
        stalled = t - start <= 1e-12 * fmax(fabs(t1 - t0), 1e-300) ? stalled + 1 : 0;
        if (!status && stalled > 1000)
            status = kd_hy_fail(H, -1, t, "the contact modes change more than 1000 times "
                                "without time advancing (chattering)");
    }
    kd_free_work(H->w);
    H->w = NULL;
    return status;
}

/* ---------------------------------------------------------- model exchange */
/* the derivatives of the state (KD_NX entries) in the current modes */
int kanedyn_contact_derivatives(double t, const double *y, const double *p, void *state,
                                double *ydot) {
    KdHybrid *H = (KdHybrid *)state;
    double z[KD_NZ], zd[KD_NZ];
    KdSegOut o;
    memcpy(z, y, sizeof(double) * KD_NX);
    z[KD_NX] = z[KD_NX + 1] = 0.0;
    H->seg.w = kd_work();
    if (H->seg.w == NULL) return 2;
    H->seg.p = p;
    int st = kd_seg_solve(&H->seg, t, z, zd, &o);
    kd_free_work(H->seg.w);
    H->seg.w = NULL;
    if (st) {
        H->w = NULL;
        return kd_hy_singular(H, t, H->seg.modes);
    }
    memcpy(ydot, zd, sizeof(double) * KD_NX);
    return 0;
}

/* 2 per contact: the values of the current modes' event functions (an event where
   one falls to zero; 1 where a contact has fewer) */
int kanedyn_contact_indicators(double t, const double *y, const double *p, void *state,
                               double *g) {
    KdHybrid *H = (KdHybrid *)state;
    double z[KD_NZ], values[KD_MAXEV];
    int used[KD_NC] = {0};
    memcpy(z, y, sizeof(double) * KD_NX);
    z[KD_NX] = z[KD_NX + 1] = 0.0;
    for (int i = 0; i < 2 * KD_NC; ++i) g[i] = 1.0;
    H->seg.w = kd_work();
    if (H->seg.w == NULL) return 2;
    H->seg.p = p;
    int st = H->seg.n_ev ? kd_seg_events(&H->seg, t, z, values) : 0;
    kd_free_work(H->seg.w);
    H->seg.w = NULL;
    if (st) return kd_hy_fail(H, -1, t, "the contact event functions cannot be evaluated");
    for (int k = 0; k < H->seg.n_ev; ++k) {
        int c = H->seg.ev_c[k];
        g[2 * c + used[c]++] = values[k];
    }
    return 0;
}

/* event mode: the events whose functions have fallen to zero or below change the
   modes (impacts, then modes settled) as kd.simulate's events; *changed: the speeds
   jumped.  The next segment's event functions start positive. */
int kanedyn_contact_update(double t, double *y, const double *p, void *state, int *changed) {
    KdHybrid *H = (KdHybrid *)state;
    double z[KD_NZ], values[KD_MAXEV], before[KD_NX];
    int status = 0, event = -1;
    *changed = 0;
    memcpy(z, y, sizeof(double) * KD_NX);
    memcpy(before, y, sizeof before);
    z[KD_NX] = z[KD_NX + 1] = 0.0;
    H->w = kd_work();
    if (H->w == NULL) return 2;
    H->seg.w = H->w;
    H->seg.p = p;
    if (H->seg.n_ev && kd_seg_events(&H->seg, t, z, values) != 0)
        status = kd_hy_fail(H, -1, t, "the contact event functions cannot be evaluated");
    for (int k = 0; k < H->seg.n_ev && !status; ++k)
        if (values[k] <= 0 && (event < 0 || values[k] < values[event])) event = k;
    if (!status && event >= 0) {
        int c = H->seg.ev_c[event], grazing = 0;
        if (H->seg.ev_kind[event] == 0) {  /* a gap that closes without approaching */
            KdPoints P;
            kd_hy_points(H, t, z, p, &P);
            grazing = kd_hy_vn(&P, c) >= -H->tol_v;
        }
        status = kd_hy_event(H, t, z, p, c, H->seg.ev_kind[event]);
        H->fresh = 1;
        if (!status) status = kd_hy_segment(H, t, z, p, &H->seg);
        if (!status && grazing && H->modes[c] == KD_SEP) {
            /* it stays separated, leaving from the surface at rounding-level speed:
               its next event where it comes back closer than tol_d (the integrator
               of the importer, not this FMU, sets the noise of its gap) */
            KdPoints P;
            kd_hy_points(H, t, z, p, &P);
            H->seg.offset[c] = fmax(0.0, -kd_hy_dist(&P, c)) + H->tol_d;
        }
        memcpy(y, z, sizeof(double) * KD_NX);
        *changed = memcmp(before, y, sizeof before) != 0;
    }
    H->seg.w = NULL;
    kd_free_work(H->w);
    H->w = NULL;
    return status;
}
"""
