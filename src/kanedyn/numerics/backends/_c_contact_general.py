r"""C source of the general contact solve of the standalone export (no Python).

:data:`GENERAL` is :func:`kanedyn.numerics._contact_dynamics.solve_modes`'
general path, for models without dependent speeds, specified inputs or
bilateral contacts (the export refuses those): any number of active contacts,
sliding with Coulomb friction along the slip direction of
:func:`kanedyn.numerics._contact_dynamics.slip_direction` (the slip
velocities free of the other active contacts' drift and the reference
directions projected on the slips they allow,
:func:`kanedyn.numerics._contact_dynamics.slip_velocities`) or sticking (the
force along the directions the point can move in), one linear system in the
accelerations and the contact forces; where the contact constraints are
redundant (a ladder sticking at both ends of one floor, a bead in the corner
of a tube) the accelerations by least squares and the forces that need the
least friction (:func:`kanedyn.numerics._contact_dynamics._least_friction`).

The segment solver of :data:`._c_contact.SEGMENT` calls
``kd_seg_general`` where the export defines ``KD_GENERAL_CONTACTS`` and the
segment asks for it (``KdSeg.general``): several active contacts, and one
whose Schur complement is ill-conditioned (a point that cannot move in some
direction).  The compiled module of ``kd.simulate`` leaves those segments to
its Python path, as before.

The small dense linear algebra it needs (``kd_svd``: one-sided Jacobi SVD;
``kd_lstsq``: least-norm least squares with a relative cut-off of the singular
values, as NumPy's ``lstsq`` and ``pinv``) is shared with the impacts of
several contacts (:mod:`._c_impacts`).
"""

from __future__ import annotations

__all__ = ["GENERAL"]

GENERAL = r"""
/* ------------------------------------------------------------------------
   Small dense linear algebra: SVD, least squares (row-major)
   ------------------------------------------------------------------------ */
#define KD_NA (KD_NU + 3 * KD_NC)
#define KD_NA2 (KD_NA * KD_NA)

/* one-sided Jacobi SVD of A (m x n, m * n <= KD_NA2, n <= KD_NA): U (m x n) = A V
   with orthogonal columns, s[j] their norms (the singular values), V (n x n)
   orthogonal: A = sum_j U[:, j] V[:, j]^T */
static void kd_svd(int m, int n, const double *A, double *U, double *s, double *V) {
    memcpy(U, A, sizeof(double) * m * n);
    for (int i = 0; i < n * n; ++i) V[i] = (i % (n + 1) == 0);
    for (int sweep = 0; sweep < 80; ++sweep) {
        int rotated = 0;
        for (int p = 0; p < n - 1; ++p)
            for (int q = p + 1; q < n; ++q) {
                double a = 0.0, b = 0.0, g = 0.0;
                for (int i = 0; i < m; ++i) {
                    double up = U[i * n + p], uq = U[i * n + q];
                    a += up * up; b += uq * uq; g += up * uq;
                }
                if (g == 0.0 || fabs(g) <= 1e-15 * sqrt(a) * sqrt(b)) continue;
                rotated = 1;
                double zeta = (b - a) / (2 * g);
                double t = (zeta >= 0 ? 1.0 : -1.0) / (fabs(zeta) + hypot(1.0, zeta));
                double c = 1 / sqrt(1 + t * t), sn = c * t;
                for (int i = 0; i < m; ++i) {
                    double up = U[i * n + p], uq = U[i * n + q];
                    U[i * n + p] = c * up - sn * uq;
                    U[i * n + q] = sn * up + c * uq;
                }
                for (int i = 0; i < n; ++i) {
                    double vp = V[i * n + p], vq = V[i * n + q];
                    V[i * n + p] = c * vp - sn * vq;
                    V[i * n + q] = sn * vp + c * vq;
                }
            }
        if (!rotated) break;
    }
    for (int j = 0; j < n; ++j) {
        double sum = 0.0;
        for (int i = 0; i < m; ++i) sum += U[i * n + j] * U[i * n + j];
        s[j] = sqrt(sum);
    }
}

static double kd_max_of(const double *s, int n) {
    double big = 0.0;
    for (int j = 0; j < n; ++j) big = fmax(big, s[j]);
    return big;
}

/* x (n) = the least-norm least-squares solution of A x = b (A m x n), singular
   values at or below rcond times the largest dropped (NumPy's lstsq and pinv) */
static void kd_lstsq(int m, int n, const double *A, const double *b, double rcond, double *x) {
    double U[KD_NA2], s[KD_NA], V[KD_NA2];
    kd_svd(m, n, A, U, s, V);
    double cut = rcond * kd_max_of(s, n);
    for (int i = 0; i < n; ++i) x[i] = 0.0;
    for (int j = 0; j < n; ++j) {
        if (!(s[j] > cut) || s[j] == 0.0) continue;
        double c = 0.0;
        for (int i = 0; i < m; ++i) c += U[i * n + j] * b[i];
        c /= s[j] * s[j];
        for (int i = 0; i < n; ++i) x[i] += c * V[i * n + j];
    }
}

/* the columns of V (n x n) whose singular values are at or below rcond times the
   largest: an orthonormal basis of the null space of A (m x n), into N (n x *k) */
static void kd_null_space(int m, int n, const double *A, double rcond, double *N, int *k) {
    double U[KD_NA2], s[KD_NA], V[KD_NA2];
    kd_svd(m, n, A, U, s, V);
    double cut = rcond * kd_max_of(s, n);
    int cols = 0;
    for (int j = 0; j < n; ++j) if (!(s[j] > cut)) cols++;
    *k = 0;
    for (int j = 0; j < n; ++j) {
        if (s[j] > cut) continue;
        for (int i = 0; i < n; ++i) N[i * cols + *k] = V[i * n + j];
        (*k)++;
    }
}

#ifdef KD_GENERAL_CONTACTS
/* ------------------------------------------------------------------------
   Several active contacts with friction (solve_modes' general path)
   ------------------------------------------------------------------------ */

/* slip_velocities: the slip velocity of each sliding contact with the other active
   contacts' drift removed (slips, 3 per contact) and the projector onto the slips
   they allow (space, 9 per contact; has_space 0: the tangent plane) */
static void kd_gen_slips(const KdSeg *S, const double *M, const double *jac,
                         const KdSegOut *o, double *slips, double *space, int *has_space) {
    int act = 0, slides = 0, nr = 0, owner[3 * KD_NC];
    double C[3 * KD_NC * KD_NU], r[3 * KD_NC];
    memcpy(slips, o->vt, sizeof(double) * 3 * KD_NC);
    for (int c = 0; c < KD_NC; ++c) {
        has_space[c] = 0;
        if (S->modes[c] == 0) continue;
        act++;
        slides += S->modes[c] == 1;
        const double *J = jac + 3 * c * KD_NU, *n = o->normal + 3 * c, *v = o->vel + 3 * c;
        if (S->modes[c] == 1) {
            for (int j = 0; j < KD_NU; ++j)
                C[nr * KD_NU + j] = n[0] * J[j] + n[1] * J[KD_NU + j] + n[2] * J[2 * KD_NU + j];
            r[nr] = kd_dot3(n, v);
            owner[nr++] = c;
        } else for (int a = 0; a < 3; ++a) {
            memcpy(C + nr * KD_NU, J + a * KD_NU, sizeof(double) * KD_NU);
            r[nr] = v[a];
            owner[nr++] = c;
        }
    }
    if (act < 2 || !slides) return;
    double WC[KD_NU * 3 * KD_NC], Mc[KD_NU * KD_NU], G[9 * KD_NC * KD_NC];
    for (int j = 0; j < KD_NU; ++j)
        for (int a = 0; a < nr; ++a) WC[j * nr + a] = C[a * KD_NU + j];
    memcpy(Mc, M, sizeof Mc);
    if (kd_lu_solve(KD_NU, Mc, WC, nr) != 0)  /* a singular metric: the identity */
        for (int j = 0; j < KD_NU; ++j)
            for (int a = 0; a < nr; ++a) WC[j * nr + a] = C[a * KD_NU + j];
    for (int a = 0; a < nr; ++a)
        for (int b = 0; b < nr; ++b) {
            double sum = 0.0;
            for (int j = 0; j < KD_NU; ++j) sum += C[a * KD_NU + j] * WC[j * nr + b];
            G[a * nr + b] = sum;
        }
    for (int c = 0; c < KD_NC; ++c) {
        if (S->modes[c] != 1) continue;
        int keep[3 * KD_NC], nk = 0, nn = 0;
        double Gk[9 * KD_NC * KD_NC], rk[3 * KD_NC], y[3 * KD_NC], du[KD_NU];
        double Ck[3 * KD_NC * KD_NU], Nb[KD_NA2], w[3], allowed[3 * KD_NU];
        const double *J = jac + 3 * c * KD_NU, *n = o->normal + 3 * c, *v = o->vel + 3 * c;
        for (int a = 0; a < nr; ++a) if (owner[a] != c) keep[nk++] = a;
        for (int a = 0; a < nk; ++a) {
            rk[a] = r[keep[a]];
            memcpy(Ck + a * KD_NU, C + keep[a] * KD_NU, sizeof(double) * KD_NU);
            for (int b = 0; b < nk; ++b) Gk[a * nk + b] = G[keep[a] * nr + keep[b]];
        }
        kd_lstsq(nk, nk, Gk, rk, 1e-10, y);
        for (int j = 0; j < KD_NU; ++j) {
            du[j] = 0.0;
            for (int a = 0; a < nk; ++a) du[j] -= WC[j * nr + keep[a]] * y[a];
        }
        for (int i = 0; i < 3; ++i) {
            w[i] = v[i];
            for (int j = 0; j < KD_NU; ++j) w[i] += J[i * KD_NU + j] * du[j];
        }
        double wn = kd_dot3(n, w);
        for (int i = 0; i < 3; ++i) slips[3 * c + i] = w[i] - wn * n[i];
        /* the slips the others allow: the range of T J N(C_keep) */
        kd_null_space(nk, KD_NU, Ck, 1e-10, Nb, &nn);
        for (int i = 0; i < 3; ++i)
            for (int b = 0; b < nn; ++b) {
                double sum = 0.0;
                for (int j = 0; j < KD_NU; ++j) sum += J[i * KD_NU + j] * Nb[j * nn + b];
                allowed[i * nn + b] = sum;
            }
        for (int b = 0; b < nn; ++b) {
            double an = n[0] * allowed[b] + n[1] * allowed[nn + b] + n[2] * allowed[2 * nn + b];
            for (int i = 0; i < 3; ++i) allowed[i * nn + b] -= an * n[i];
        }
        double *P = space + 9 * c;
        for (int i = 0; i < 9; ++i) P[i] = 0.0;
        has_space[c] = 1;
        if (nn) {
            double U[3 * KD_NU], s[KD_NU], V[KD_NU * KD_NU];
            kd_svd(3, nn, allowed, U, s, V);
            double cut = 1e-10 * fmax(kd_max_of(s, nn), 1e-300);
            for (int b = 0; b < nn; ++b) {
                if (!(s[b] > cut)) continue;
                for (int i = 0; i < 3; ++i)
                    for (int k = 0; k < 3; ++k) P[3 * i + k] += U[i * nn + b] * U[k * nn + b] / (s[b] * s[b]);
            }
        }
    }
}

/* _least_friction: among the solutions of the singular system A x = b (N x N), the
   one whose sticking contacts need the least friction; st: (offset of its
   multipliers, how many), TQ (3 x 3 per sticking contact, its multipliers to the
   tangential force), nQ (3 per contact: to the normal force), mu_s */
static void kd_gen_least_friction(int N, const double *A, const double *b, int ns,
                                  const int *off, const int *size, const double *TQ,
                                  const double *nQ, const double *mu_s, double *x) {
    double x0[KD_NA], Z[KD_NA2];
    int nz = 0;
    kd_lstsq(N, N, A, b, 2.220446049250313e-16 * N, x0);
    memcpy(x, x0, sizeof(double) * N);
    kd_null_space(N, N, A, 1e-10, Z, &nz);
    if (!nz || !ns) return;
    double weights[KD_NC];
    for (int j = 0; j < ns; ++j) weights[j] = 1.0;
    for (int pass = 0; pass < 2; ++pass) {
        double F[3 * KD_NC * KD_NA], FZ[3 * KD_NC * KD_NA], Fx0[3 * KD_NC], y[KD_NA];
        double Y[KD_NA2], V2[KD_NA2];
        int nf = 3 * ns, ny = 0;
        memset(F, 0, sizeof F);
        for (int j = 0; j < ns; ++j)
            for (int a = 0; a < 3; ++a)
                for (int c = 0; c < size[j]; ++c)
                    F[(3 * j + a) * N + KD_NU + off[j] + c] = sqrt(weights[j]) * TQ[9 * j + 3 * a + c];
        for (int a = 0; a < nf; ++a) {
            Fx0[a] = 0.0;
            for (int i = 0; i < N; ++i) Fx0[a] += F[a * N + i] * x0[i];
            for (int b2 = 0; b2 < nz; ++b2) {
                double sum = 0.0;
                for (int i = 0; i < N; ++i) sum += F[a * N + i] * Z[i * nz + b2];
                FZ[a * nz + b2] = sum;
            }
        }
        kd_lstsq(nf, nz, FZ, Fx0, 1e-10, y);
        for (int i = 0; i < N; ++i) {
            x[i] = x0[i];
            for (int b2 = 0; b2 < nz; ++b2) x[i] -= Z[i * nz + b2] * y[b2];
        }
        /* what the friction leaves free: least norm */
        kd_null_space(nf, nz, FZ, 1e-10, V2, &ny);
        for (int i = 0; i < N; ++i)
            for (int c = 0; c < ny; ++c) {
                double sum = 0.0;
                for (int b2 = 0; b2 < nz; ++b2) sum += Z[i * nz + b2] * V2[b2 * ny + c];
                Y[i * ny + c] = sum;
            }
        for (int c = 0; c < ny; ++c) {
            double yx = 0.0;
            for (int i = 0; i < N; ++i) yx += Y[i * ny + c] * x[i];
            for (int i = 0; i < N; ++i) x[i] -= Y[i * ny + c] * yx;
        }
        double limits[KD_NC], top = -INFINITY;
        for (int j = 0; j < ns; ++j) {
            double sum = 0.0;
            for (int c = 0; c < size[j]; ++c) sum += nQ[3 * j + c] * x[KD_NU + off[j] + c];
            limits[j] = mu_s[j] * sum;
            top = fmax(top, limits[j]);
        }
        if (!(top > 0)) break;
        for (int j = 0; j < ns; ++j) weights[j] = 1.0 / fmax(limits[j], 1e-9 * top);
    }
}

/* whether the k rows R (k x KD_NU) are redundant (_redundant, rtol 1e-10) */
static int kd_gen_redundant(const double *R, int k) {
    if (k > KD_NU) return 1;
    if (k == 1) {
        for (int j = 0; j < KD_NU; ++j) if (R[j] != 0.0) return 0;
        return 1;
    }
    double Rt[KD_NA2], U[KD_NA2], s[KD_NA], V[KD_NA2], low = INFINITY;
    for (int a = 0; a < k; ++a)
        for (int j = 0; j < KD_NU; ++j) Rt[j * k + a] = R[a * KD_NU + j];
    kd_svd(KD_NU, k, Rt, U, s, V);
    for (int a = 0; a < k; ++a) low = fmin(low, s[a]);
    return low <= 1e-10 * kd_max_of(s, k);
}

/* z' and the contact forces of the modes of S, any number of active contacts:
   0, 1 singular or not finite */
static int kd_seg_general(KdSeg *S, const double *z, double *zd, KdSegOut *o,
                          const double *M, const double *f, const double *jac,
                          const double *acc, const double *rate) {
    double slips[3 * KD_NC], space[9 * KD_NC], raw[3 * KD_NC], F[KD_NU];
    double A[KD_NA2], b[KD_NA], x[KD_NA], G[KD_NU * 3 * KD_NC], R[3 * KD_NC * KD_NU];
    double dirs[3 * KD_NC], Qs[9 * KD_NC], TQ[9 * KD_NC], nQ[3 * KD_NC], mu_s[KD_NC];
    int has_space[KD_NC], k = 0, ns = 0, first[KD_NC], size[KD_NC], soff[KD_NC], ssize[KD_NC];
    const double w = S->stab, *u = z + KD_NQ;
    memcpy(raw, o->vt, sizeof raw);
    kd_gen_slips(S, M, jac, o, slips, space, has_space);
    memcpy(F, f, sizeof F);
    for (int c = 0; c < KD_NC; ++c) {
        first[c] = k;
        size[c] = 0;
        if (S->modes[c] == 0) continue;
        const double *J = jac + 3 * c * KD_NU, *n = o->normal + 3 * c, *v = o->vel + 3 * c;
        double corr = 2 * w * kd_dot3(n, v) + w * w * o->gap[c] / o->grad[c];
        if (S->visc[c] != 0.0)
            for (int j = 0; j < KD_NU; ++j)
                for (int i = 0; i < 3; ++i) F[j] -= S->visc[c] * J[i * KD_NU + j] * raw[3 * c + i];
        if (S->modes[c] == 1) {
            double *s = dirs + 3 * c;
            kd_seg_slip_dir(S, c, n, v, slips + 3 * c, has_space[c] ? space + 9 * c : NULL, s);
            for (int j = 0; j < KD_NU; ++j) {
                double col = 0.0, row = 0.0;
                for (int i = 0; i < 3; ++i) {
                    col += J[i * KD_NU + j] * (n[i] - S->mu_k[c] * s[i]);
                    row += n[i] * J[i * KD_NU + j];
                }
                G[j * 3 * KD_NC + k] = col;
                R[k * KD_NU + j] = row;
            }
            b[KD_NU + k] = -(rate[c] + corr);
            size[c] = 1;
            k++;
        } else {
            /* the directions the point can move in: the left singular vectors of J */
            double Jt[3 * KD_NU], U[3 * KD_NU], sv[3], V[9], *Q = Qs + 9 * c;
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < KD_NU; ++j) Jt[j * 3 + i] = J[i * KD_NU + j];
            kd_svd(KD_NU, 3, Jt, U, sv, V);
            double cut = 1e-12 * fmax(kd_max_of(sv, 3), 1e-300);
            int rank = 0;
            for (int a = 0; a < 3; ++a) {
                if (!(sv[a] > cut)) continue;
                for (int i = 0; i < 3; ++i) Q[3 * i + rank] = V[3 * i + a];
                rank++;
            }
            soff[ns] = k;
            ssize[ns] = rank;
            mu_s[ns] = S->mu_s[c];
            for (int a = 0; a < rank; ++a) {
                double nq = n[0] * Q[a] + n[1] * Q[3 + a] + n[2] * Q[6 + a];
                nQ[3 * ns + a] = nq;
                for (int i = 0; i < 3; ++i) TQ[9 * ns + 3 * i + a] = Q[3 * i + a] - n[i] * nq;
                for (int j = 0; j < KD_NU; ++j) {
                    double col = 0.0;
                    for (int i = 0; i < 3; ++i) col += J[i * KD_NU + j] * Q[3 * i + a];
                    G[j * 3 * KD_NC + k] = col;
                    R[k * KD_NU + j] = col;
                }
                double qa = 0.0;
                for (int i = 0; i < 3; ++i) qa += Q[3 * i + a] * (acc[3 * c + i] + corr * n[i]);
                b[KD_NU + k] = -qa;
                k++;
            }
            ns++;
            size[c] = rank;
        }
    }
    int N = KD_NU + k;
    memset(A, 0, sizeof(double) * N * N);
    for (int j = 0; j < KD_NU; ++j) {
        b[j] = F[j];
        for (int i = 0; i < KD_NU; ++i) A[j * N + i] = M[j * KD_NU + i];
        for (int a = 0; a < k; ++a) {
            A[j * N + KD_NU + a] = -G[j * 3 * KD_NC + a];
            A[(KD_NU + a) * N + j] = R[a * KD_NU + j];
        }
    }
    if (k && kd_gen_redundant(R, k))
        kd_gen_least_friction(N, A, b, ns, soff, ssize, TQ, nQ, mu_s, x);
    else {
        memcpy(x, b, sizeof(double) * N);
        if (kd_lu_solve(N, A, x, 1) != 0) return 1;
    }
    double *ud = zd + KD_NQ, dissipation = 0.0, power = 0.0;
    memcpy(ud, x, sizeof(double) * KD_NU);
    for (int c = 0; c < KD_NC; ++c) {
        const double *J = jac + 3 * c * KD_NU, *n = o->normal + 3 * c, *v = o->vel + 3 * c;
        const double *lam = x + KD_NU + first[c];
        double tot[3] = {0.0, 0.0, 0.0}, Nc, fr[3], Ju[3];
        if (S->modes[c] == 1) {
            for (int i = 0; i < 3; ++i) tot[i] = lam[0] * (n[i] - S->mu_k[c] * dirs[3 * c + i]);
        } else if (S->modes[c] == 2) {
            for (int i = 0; i < 3; ++i)
                for (int a = 0; a < size[c]; ++a) tot[i] += Qs[9 * c + 3 * i + a] * lam[a];
        }
        Nc = S->modes[c] == 1 ? lam[0] : kd_dot3(tot, n);
        o->N[c] = Nc;
        for (int i = 0; i < 3; ++i) {
            o->total[3 * c + i] = tot[i];
            o->vt[3 * c + i] = slips[3 * c + i];
            fr[i] = S->modes[c] ? tot[i] - Nc * n[i] - S->visc[c] * raw[3 * c + i] : 0.0;
            Ju[i] = 0.0;
            for (int j = 0; j < KD_NU; ++j) Ju[i] += J[i * KD_NU + j] * u[j];
        }
        dissipation += kd_dot3(fr, v);
        power += (Nc * n[0] + fr[0]) * Ju[0] + (Nc * n[1] + fr[1]) * Ju[1]
                 + (Nc * n[2] + fr[2]) * Ju[2];
    }
    zd[KD_NX] = dissipation;
    zd[KD_NX + 1] = power;
    for (int i = 0; i < KD_NZ; ++i) if (!isfinite(zd[i])) return 1;
    return 0;
}
#endif
"""
