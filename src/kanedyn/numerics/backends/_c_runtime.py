"""C source shared by every generated extension module.

The generated part defines the ``KD_*`` sizes and the evaluation functions
``kd_eval_dynamics``, ``kd_eval_constraints``, ``kd_eval_energy`` and
``kd_eval_auxiliary``; this runtime adds the linear algebra, the assembly of
the reduced system (dependent speeds eliminated numerically), and the Python
entry points.  Entry points use ``METH_FASTCALL`` and read NumPy buffers
directly: a ``ctypes`` call alone would cost more than the whole evaluation.

A module built from translation units carries the runtime in two: the generic
one (:data:`RUNTIME`, the integrator, the contact loop, :data:`RUNTIME_FOOTER`),
which takes the sizes as run-time constants (``KD_NQ`` is ``kd_nq`` there,
defined by the model's unit; block-scope arrays sized by them are variable
length, the state-sized storage of ``KdModel`` is on the heap, that of the
integrator on its caller's stack; only ``KD_HAS_R``, ``KD_HAS_DEP`` and
``KD_HAS_UDEP`` decide at compile time), so that its text is the same for
every model of a variant, can be compiled before the model is derived and is
compiled once for models of any size (with contacts, the sizes are
compile-time constants in it as everywhere else), and the model's own, in C without Python (:data:`MODEL_SOLVE`,
:data:`LANE_SOLVE`, the table of its functions, which the generic unit turns
into Python functions, and :data:`MODULE_FOOTER`); :data:`SHARED` declares what
each calls of the other.
"""

from ._c_inputs import TABLE_INPUTS

PYTHON_INCLUDES = r"""
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>"""

#: C headers and helpers of the generated expressions (no Python)
PRELUDE = r"""
#include <math.h>
#include <string.h>

/* storage of the generated functions: static in a one-unit source; a module
   built from several units defines KD_GEN empty first (hidden by the flags) */
#ifndef KD_GEN
#define KD_GEN static
#endif

static inline double kd_sign(double x) { return (double)((x > 0) - (x < 0)); }
/* d(b^e) = e b^(e-1) db, 0 where db = 0 (kanedyn.engine.kd_dpow) */
static inline double kd_dpow(double b, double e, double db) {
    return db == 0.0 ? 0.0 : e * pow(b, e - 1.0) * db;
}
static inline double kd_powi(double x, long n) {
    double result = 1.0, base = x;
    unsigned long k = n < 0 ? (unsigned long)(-n) : (unsigned long)n;
    while (k) { if (k & 1UL) result *= base; base *= base; k >>= 1; }
    return n < 0 ? 1.0 / result : result;
}
"""

HEADER = PYTHON_INCLUDES + PRELUDE

RUNTIME_ERRORS = r"""
static PyObject *kd_linalg_error = NULL;
/* the module's exact derivatives (kd_module_create; another module's after
   _adopt), or NULL */
static const KdJacobianInfo *kd_jacobians = NULL;
#if defined(__GNUC__)
#define KD_JACOBIANS (__atomic_load_n(&kd_jacobians, __ATOMIC_ACQUIRE))
#else
#define KD_JACOBIANS kd_jacobians
#endif
"""

#: sizes derived from the ``KD_*`` sizes (every unit of a module), and what
#: the preprocessor decides on them (``KD_HAS_*``: given with the sizes in the
#: generic runtime unit, whose sizes are run-time constants)
SIZE_MACROS = r"""
#define KD_NX (KD_NQ + KD_NU)
#define KD_NUI (KD_NU - KD_NUDEP)
#define KD_SZ(x) ((x) > 0 ? (x) : 1)
#ifndef KD_HAS_R
#define KD_HAS_R (KD_NR > 0)
#define KD_HAS_DEP (KD_NQDEP + KD_NUDEP > 0)
#define KD_HAS_UDEP (KD_NUDEP > 0)
#endif
/* length of an array of the inputs: a constant without (no variable length) */
#if KD_HAS_R
#define KD_SZ_R KD_SZ(KD_NR)
#else
#define KD_SZ_R 1
#endif
"""

#: dense LU with partial pivoting (no Python): part of the generic runtime
LU_SOLVE = r"""
/* Solve A x = B in place (A: n x n row-major, B: n x nrhs row-major) by LU with
   partial pivoting.  Returns 0, or 1 if A is singular. */
KD_GEN int kd_lu_solve(int n, double *A, double *B, int nrhs) {
    for (int k = 0; k < n; ++k) {
        int piv = k;
        double big = fabs(A[k * n + k]);
        for (int i = k + 1; i < n; ++i) {
            double v = fabs(A[i * n + k]);
            if (v > big) { big = v; piv = i; }
        }
        if (!(big > 0.0)) return 1;
        if (piv != k) {
            for (int j = 0; j < n; ++j) {
                double tmp = A[k * n + j]; A[k * n + j] = A[piv * n + j]; A[piv * n + j] = tmp;
            }
            for (int j = 0; j < nrhs; ++j) {
                double tmp = B[k * nrhs + j]; B[k * nrhs + j] = B[piv * nrhs + j];
                B[piv * nrhs + j] = tmp;
            }
        }
        double inv = 1.0 / A[k * n + k];
        for (int i = k + 1; i < n; ++i) {
            double factor = A[i * n + k] * inv;
            if (factor == 0.0) continue;
            for (int j = k + 1; j < n; ++j) A[i * n + j] -= factor * A[k * n + j];
            for (int j = 0; j < nrhs; ++j) B[i * nrhs + j] -= factor * B[k * nrhs + j];
        }
    }
    for (int k = n - 1; k >= 0; --k) {
        double inv = 1.0 / A[k * n + k];
        for (int j = 0; j < nrhs; ++j) {
            double s = B[k * nrhs + j];
            for (int i = k + 1; i < n; ++i) s -= A[k * n + i] * B[i * nrhs + j];
            B[k * nrhs + j] = s * inv;
        }
    }
    return 0;
}
"""

#: the solve of the model's mass matrix (its kind, ``KD_SOLVE``, and the
#: elimination tree come from the model's structure) and the right-hand side
#: ``kd_rhs_core``, without Python: part of the model's own unit
MODEL_SOLVE = r"""
#ifndef KD_HAS_DYNAMICS
#define KD_HAS_DYNAMICS 1  /* kd_eval_dynamics (M) is part of the program */
#endif
/* M = L^T D L factorizations of the mass matrix (Featherstone's order: the
   last coordinate first; L unit lower triangular, overwriting the strict lower
   triangle of A, D on its diagonal), then the solve of A x = b in place.
   Return 0, or 1 if A is not positive definite (a pivot not > 0).

   kd_ltdl_dense: every entry of the lower triangle; the updates run along
   contiguous rows (the compiler vectorizes them).
   kd_ltdl_tree: only the entries (k, i) with i an ancestor of k in the
   elimination tree kd_parent (-1 at a root), computed from the structural
   zeros of the mass matrix when the module is generated; for a kinematic tree
   with its coordinates numbered parents first, no fill-in (O(n d^2) for depth d). */
#ifndef KD_SOLVE
#define KD_SOLVE 1
#endif
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__GLIBC__)
/* vectorized (also for AVX2, chosen at load time) whatever the flags of the rest */
#define KD_VECTORIZED __attribute__((optimize("O3"), target_clones("avx2", "default")))
#elif defined(__GNUC__) && !defined(__clang__)
#define KD_VECTORIZED __attribute__((optimize("O3")))
#else
#define KD_VECTORIZED
#endif

#if KD_NUDEP > 0  /* the reduced system is solved by LU */
#elif KD_SOLVE == 1
KD_VECTORIZED static int kd_ltdl_dense(double *restrict A, double *restrict b) {
    const int n = KD_NU;
    int k = n - 1;
    for (; k >= 1; k -= 2) {  /* rows k and l = k - 1 eliminated together */
        double *restrict rk = A + k * n, *restrict rl = A + (k - 1) * n;
        const double dk = rk[k];
        if (!(dk > 0.0)) return 1;
        const double ik = 1.0 / dk, c = rk[k - 1] * ik;
        for (int j = 0; j < k; ++j) rl[j] -= c * rk[j];
        rk[k - 1] = c;
        const double dl = rl[k - 1];
        if (!(dl > 0.0)) return 1;
        const double il = 1.0 / dl;
        for (int i = k - 2; i >= 0; --i) {
            double *restrict ri = A + i * n;
            const double a = rk[i] * ik, e = rl[i] * il;
            for (int j = 0; j <= i; ++j) ri[j] -= a * rk[j] + e * rl[j];
            rk[i] = a;  /* rk[j], rl[j] for j < i are still unscaled */
            rl[i] = e;
        }
    }
    if (k == 0 && !(A[0] > 0.0)) return 1;
    for (int k = n - 1; k > 0; --k) {  /* L^T z = b */
        const double *restrict rk = A + k * n;
        const double bk = b[k];
        for (int i = 0; i < k; ++i) b[i] -= rk[i] * bk;
    }
    for (int k = 0; k < n; ++k) b[k] /= A[k * n + k];  /* D */
    for (int k = 1; k < n; ++k) {  /* L x = z */
        const double *restrict rk = A + k * n;
        double s = b[k];
        for (int i = 0; i < k; ++i) s -= rk[i] * b[i];
        b[k] = s;
    }
    return 0;
}
#elif KD_SOLVE == 2
static int kd_ltdl_tree(double *restrict A, double *restrict b) {
    const int n = KD_NU;
    for (int k = n - 1; k >= 0; --k) {
        double *restrict rk = A + k * n;
        const double d = rk[k];
        if (!(d > 0.0)) return 1;
        const double inv = 1.0 / d;
        for (int i = kd_parent[k]; i >= 0; i = kd_parent[i]) {
            double *restrict ri = A + i * n;
            const double a = rk[i] * inv;
            for (int j = i; j >= 0; j = kd_parent[j]) ri[j] -= a * rk[j];
            rk[i] = a;
        }
    }
    for (int k = n - 1; k >= 0; --k) {  /* L^T z = b */
        const double *restrict rk = A + k * n;
        const double bk = b[k];
        for (int i = kd_parent[k]; i >= 0; i = kd_parent[i]) b[i] -= rk[i] * bk;
    }
    for (int k = 0; k < n; ++k) b[k] /= A[k * n + k];  /* D */
    for (int k = 0; k < n; ++k) {  /* L x = z */
        const double *restrict rk = A + k * n;
        double s = b[k];
        for (int i = kd_parent[k]; i >= 0; i = kd_parent[i]) s -= rk[i] * b[i];
        b[k] = s;
    }
    return 0;
}
#elif KD_SOLVE == 3
/* The articulated-body factors of M and M x = b in place (see kd_tree_solve):
   for each speed r, UD_r = U_r / D_r with U_r = IA_r S_r (6; IA_r the
   articulated inertia of the bodies at and below r) and 1 / D_r, D_r = S_r . U_r;
   S: 6 per speed, IO: 10 (kd_eval_tree).  1 if a D_r is not > 0. */
KD_VECTORIZED static int kd_tree_factor(const double *restrict S, const double *restrict IO,
                                        double *restrict UD, double *restrict Dinv,
                                        double *restrict b) {
    static const int sym[9] = {0, 1, 2, 1, 3, 4, 2, 4, 5};
    double IA[KD_NU][36], pa[KD_NU][6], A[KD_NU][6];
    for (int r = 0; r < KD_NU; ++r) {
        const double *g = IO + 10 * r;
        double *Ia = IA[r];
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                Ia[i * 6 + j] = g[sym[i * 3 + j]];
                Ia[(i + 3) * 6 + j + 3] = i == j ? g[9] : 0.0;
            }
        }
        const double hx = g[6], hy = g[7], hz = g[8];
        const double H[9] = {0.0, -hz, hy, hz, 0.0, -hx, -hy, hx, 0.0};  /* h x . */
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                Ia[i * 6 + j + 3] = H[i * 3 + j];
                Ia[(j + 3) * 6 + i] = H[i * 3 + j];
            }
        }
        for (int i = 0; i < 6; ++i) pa[r][i] = 0.0;
    }
    for (int k = 0; k < KD_NU; ++k) {  /* leaves to roots */
        const int r = kd_torder[k];
        const double *restrict s = S + 6 * r;
        const double *restrict Ia = IA[r];
        double U[6], d = 0.0, e = b[r];
        for (int i = 0; i < 6; ++i) {
            double v = 0.0;
            for (int j = 0; j < 6; ++j) v += Ia[i * 6 + j] * s[j];
            U[i] = v;
            d += s[i] * v;
            e -= s[i] * pa[r][i];
        }
        if (!(d > 0.0)) return 1;
        const double inv = 1.0 / d;
        Dinv[r] = inv;
        b[r] = e;
        for (int i = 0; i < 6; ++i) UD[6 * r + i] = U[i] * inv;
        const int up = kd_tparent[r];
        if (up < 0) continue;
        double *restrict P = IA[up];
        for (int i = 0; i < 6; ++i) {
            const double ui = U[i] * inv;
            for (int j = 0; j < 6; ++j) P[i * 6 + j] += Ia[i * 6 + j] - ui * U[j];
            pa[up][i] += pa[r][i] + ui * e;
        }
    }
    for (int k = KD_NU - 1; k >= 0; --k) {  /* roots to leaves */
        const int r = kd_torder[k], up = kd_tparent[r];
        const double *restrict s = S + 6 * r;
        double x = b[r] * Dinv[r];
        if (up >= 0)
            for (int i = 0; i < 6; ++i) x -= UD[6 * r + i] * A[up][i];
        for (int i = 0; i < 6; ++i) A[r][i] = (up >= 0 ? A[up][i] : 0.0) + s[i] * x;
        b[r] = x;
    }
    return 0;
}

/* M x = b for M_rs = S_r^T I(B_r & B_s) S_s (a tree of speeds, kd_tparent,
   -1 at a root; kd_torder lists every speed before its parent): an
   articulated-body pass, O(n).  S: 6 per speed (W, V about O); IO: the spatial
   inertia about O of the bodies attached at each speed (J00 J01 J02 J11 J12 J22,
   h, m).  b is overwritten by x.  Returns 1 if a pivot is not > 0. */
static int kd_tree_solve(const double *restrict S, const double *restrict IO,
                         double *restrict b) {
    double UD[6 * KD_NU], Dinv[KD_NU];
    return kd_tree_factor(S, IO, UD, Dinv, b);
}
#endif

/* The state derivative [q', u'] at (t, y).  Returns 0, or 1 if the system is
   singular. */
KD_GEN int kd_rhs_core(double t, const double *y, const double *p, const double *r,
                       double *w, double *out) {
    double qd[KD_SZ(KD_NQ)], M[KD_SZ(KD_NU * KD_NU)], f[KD_SZ(KD_NU)];
    double B[KD_SZ(KD_NUDEP * KD_NU)], Ka[KD_SZ(KD_NUDEP * KD_NU)], fa[KD_SZ(KD_NUDEP)];
    double *ud = out + KD_NQ;
#if KD_SOLVE != 3 || KD_NUDEP > 0
    kd_eval_dynamics(t, y, p, r, w, qd, M, f, B, Ka, fa);
    memcpy(out, qd, KD_NQ * sizeof(double));
#endif
#if KD_NUDEP == 0
#if KD_SOLVE == 3
    (void)qd; (void)f; (void)B; (void)Ka; (void)fa;
    double S[6 * KD_NU], IO[10 * KD_NU];
    kd_eval_tree(t, y, p, r, w, out, ud, S, IO);
    int status = kd_tree_solve(S, IO, ud);
#else
    memcpy(ud, f, sizeof(double) * KD_NU);
#endif
#if KD_SOLVE == 2
    int status = kd_ltdl_tree(M, ud);
#elif KD_SOLVE == 3
#else
    int status = kd_ltdl_dense(M, ud);
#endif
    if (status != 0) {  /* not positive definite: M again, LU with pivoting */
#if KD_HAS_DYNAMICS
        kd_eval_dynamics(t, y, p, r, w, qd, M, f, B, Ka, fa);
        memcpy(ud, f, sizeof(double) * KD_NU);
        if (kd_lu_solve(KD_NU, M, ud, 1) != 0) return 1;
#else  /* a module without M (the tree pass solves): singular */
        return 1;
#endif
    }
#else
    /* Ar = -Bdep^-1 Bind (m x p); the reduced rows M[:p] + Ar^T M[p:] */
    double Bd[KD_NUDEP * KD_NUDEP], X[KD_SZ(KD_NUDEP * KD_NUI)];
    for (int i = 0; i < KD_NUDEP; ++i) {
        for (int j = 0; j < KD_NUDEP; ++j) Bd[i * KD_NUDEP + j] = B[i * KD_NU + KD_NUI + j];
        for (int j = 0; j < KD_NUI; ++j) X[i * KD_NUI + j] = B[i * KD_NU + j];
    }
    if (kd_lu_solve(KD_NUDEP, Bd, X, KD_NUI) != 0) return 1;
    double S[KD_NU * KD_NU];
    for (int i = 0; i < KD_NUI; ++i) {
        for (int j = 0; j < KD_NU; ++j) {
            double s = M[i * KD_NU + j];
            for (int k = 0; k < KD_NUDEP; ++k) s -= X[k * KD_NUI + i] * M[(KD_NUI + k) * KD_NU + j];
            S[i * KD_NU + j] = s;
        }
        double s = f[i];
        for (int k = 0; k < KD_NUDEP; ++k) s -= X[k * KD_NUI + i] * f[KD_NUI + k];
        ud[i] = s;
    }
    for (int i = 0; i < KD_NUDEP; ++i) {
        for (int j = 0; j < KD_NU; ++j) S[(KD_NUI + i) * KD_NU + j] = Ka[i * KD_NU + j];
        ud[KD_NUI + i] = -fa[i];
    }
    if (kd_lu_solve(KD_NU, S, ud, 1) != 0) return 1;
#endif
    return 0;
}
"""

#: the exact derivatives of a module with the generated ``jacobians`` function
#: (``kanedyn.numerics._jacobians``): its outputs, ``g_x, E_x, a_x`` per column
#: group (state, inputs, constants when ``KD_JAC_GROUPS`` is 3), then ``h_y, c_y``, at the
#: accelerations and multipliers of the index-1 system, and the solve of that
#: system for the derivatives; part of the model's unit (no Python)
JACOBIAN_SOLVE = r"""
#define KD_NS (KD_NU + KD_NUDEP)           /* unknowns of the index-1 system */
#define KD_JC (KD_NX + KD_NR + KD_JP)      /* derivative columns */
#define KD_NCON (KD_NQDEP + KD_NUDEP)      /* constraint rows */
/* only the state's columns (no inputs, no constants asked for): the generated
   derivatives write their blocks g_y and [E_y; a_y] where they go, into the
   rows of q' and of u' (and lambda) of D, and the solve runs on them there */
#define KD_JAC_ONE_GROUP (KD_NR == 0 && KD_JP == 0)
#ifndef KD_JAC_SHARED
#define KD_JAC_SHARED 0
#endif
#if KD_JAC_SHARED  /* the derivatives take what kd_eval_dynamics left in w */
#define KD_JAC_EVAL kd_eval_jacobians_shared
#else
#define KD_JAC_EVAL kd_eval_jacobians
#endif
#ifndef KD_TREE_JAC
#define KD_TREE_JAC 0
#endif
#if KD_TREE_JAC
#define KD_TREE_FACTORS (45 * KD_NU)       /* kd_tree_jacobian's vectors */
#define KD_TREE_OUT , TF                   /* the last output of kd_eval_jacobians */
#else
#define KD_TREE_FACTORS 0
#define KD_TREE_OUT
#endif
/* scratch: the dynamics' outputs, the system and its pivots, the extended
   inputs, the derivative blocks of the column groups (none where there is one
   group: they are written in D, where the solve is done in place) and the
   tree's factors; where the articulated-body pass solves, only what that path
   uses (no M, no index-1 system: the pass's vectors instead) */
#ifndef KD_JAC_TREE_SOLVE
#define KD_JAC_TREE_SOLVE 0
#endif
#if KD_JAC_TREE_SOLVE
/* the articulated-body solve (kd_tree_apply): its bias rows, 6 x KD_JC for a
   chain (one block, updated in place), 6 x KD_JC per speed for a tree */
#if KD_TSOLVE_CHAIN
#define KD_TREE_BIAS (6 * KD_JC)
#else
#define KD_TREE_BIAS (6 * KD_JC * KD_NU)
#endif
/* S (6 per speed), IO (10), U / D (6), 1 / D (1) */
#define KD_TREE_SOLVE_SCRATCH (23 * KD_NU + KD_TREE_BIAS)
#else
#define KD_TREE_SOLVE_SCRATCH 0
#endif
/* the blocks of the column groups apart from D (none with one group: in D) */
#define KD_JAC_BLOCKS (KD_JAC_ONE_GROUP ? 0 : (KD_NQ + KD_NS) * KD_JC)
#if KD_JAC_TREE_SOLVE  /* q', the forcing, the extended inputs: no M, no index-1 system */
#define KD_JAC_SCRATCH (KD_NQ + KD_NU + KD_TREE_SOLVE_SCRATCH + KD_NR + KD_NU \
    + KD_JAC_BLOCKS + KD_TREE_FACTORS + 1)
#else
#define KD_JAC_SCRATCH (KD_NQ + KD_NU * KD_NU + KD_NU + 2 * KD_NUDEP * KD_NU + KD_NUDEP \
    + KD_NS * KD_NS + 2 * KD_NS + KD_NR + KD_NS + KD_JAC_BLOCKS + KD_TREE_FACTORS + 1)
#endif

#if KD_TREE_JAC
#if KD_NQ != KD_NU || KD_NUDEP != 0
#error "the tree's derivatives need as many coordinates as speeds and no dependent speeds"
#endif
/* E (KD_NU rows of 2 KD_NU: the coordinates' columns, then the speeds') += the
   derivatives of a tree's inertia forces from the vectors of each speed, F (45
   rows of KD_NU: alpha 6, beta 6, gamma 3, d 6, e 6, S 6, Y 6, Z 6; see
   kanedyn.engine.tree_inertia_derivatives): for j = i or above it,
   dq_ij = alpha_i.e_j + beta_i.d_j + gamma_i.S_j(angular), du_ij = beta_i.S_j +
   2 alpha_i.d_j; for j strictly above i, dq_ji = S_j.Y_i, du_ji = S_j.Z_i.  On a
   chain, rows of contiguous columns (the compiler vectorizes them) */
KD_VECTORIZED static void kd_tree_jacobian(const double *restrict F, double *restrict E) {
    const int n = KD_NU, w = 2 * KD_NU;
    const double *restrict al = F, *restrict be = F + 6 * n, *restrict ga = F + 12 * n;
    const double *restrict d = F + 15 * n, *restrict e = F + 21 * n, *restrict S = F + 27 * n;
    const double *restrict Y = F + 33 * n, *restrict Z = F + 39 * n;
    for (int i = 0; i < n; ++i) {
        double A[6], A2[6], B[6], G[3], Si[6];
        for (int c = 0; c < 6; ++c) {
            A[c] = al[c * n + i];
            A2[c] = 2.0 * A[c];
            B[c] = be[c * n + i];
            Si[c] = S[c * n + i];
        }
        for (int c = 0; c < 3; ++c) G[c] = ga[c * n + i];
        double *restrict q = E + i * w, *restrict u = q + n;
#if KD_TREE_CHAIN
        for (int j = 0; j <= i; ++j) {  /* i and the speeds above it */
            double sq = 0.0, su = 0.0;
            for (int c = 0; c < 6; ++c) {
                sq += A[c] * e[c * n + j] + B[c] * d[c * n + j];
                su += B[c] * S[c * n + j] + A2[c] * d[c * n + j];
            }
            for (int c = 0; c < 3; ++c) sq += G[c] * S[c * n + j];
            q[j] += sq;
            u[j] += su;
        }
        for (int k = i + 1; k < n; ++k) {  /* the speeds below i: S_i.Y_k, S_i.Z_k */
            double sq = 0.0, su = 0.0;
            for (int c = 0; c < 6; ++c) {
                sq += Si[c] * Y[c * n + k];
                su += Si[c] * Z[c * n + k];
            }
            q[k] += sq;
            u[k] += su;
        }
#else
        for (int j = i; j >= 0; j = kd_jparent[j]) {
            double sq = 0.0, su = 0.0;
            for (int c = 0; c < 6; ++c) {
                sq += A[c] * e[c * n + j] + B[c] * d[c * n + j];
                su += B[c] * S[c * n + j] + A2[c] * d[c * n + j];
            }
            for (int c = 0; c < 3; ++c) sq += G[c] * S[c * n + j];
            q[j] += sq;
            u[j] += su;
            if (j == i) continue;
            double tq = 0.0, tu = 0.0;  /* row j, column i: S_j.Y_i, S_j.Z_i */
            for (int c = 0; c < 6; ++c) {
                tq += S[c * n + j] * Y[c * n + i];
                tu += S[c * n + j] * Z[c * n + i];
            }
            E[j * w + i] += tq;
            E[j * w + n + i] += tu;
        }
#endif
    }
}
#endif

/* LU factors of A (n x n, in place) with the row of each pivot; 1 if singular */
static int kd_lu_factor(int n, double *A, double *piv) {
    for (int k = 0; k < n; ++k) {
        int best = k;
        double big = fabs(A[k * n + k]);
        for (int i = k + 1; i < n; ++i) {
            if (fabs(A[i * n + k]) > big) { big = fabs(A[i * n + k]); best = i; }
        }
        if (!(big > 0.0)) return 1;
        piv[k] = best;
        if (best != k) {
            for (int j = 0; j < n; ++j) {
                double tmp = A[k * n + j]; A[k * n + j] = A[best * n + j]; A[best * n + j] = tmp;
            }
        }
        const double inv = 1.0 / A[k * n + k];
        for (int i = k + 1; i < n; ++i) {
            const double factor = A[i * n + k] * inv;
            A[i * n + k] = factor;
            if (factor == 0.0) continue;
            for (int j = k + 1; j < n; ++j) A[i * n + j] -= factor * A[k * n + j];
        }
    }
    return 0;
}

/* X = A^-1 X in place from the factors of kd_lu_factor (X: n x nrhs): the row
   exchanges (whole rows were exchanged in the factors), then L, then U */
KD_VECTORIZED static void kd_lu_apply(int n, const double *A, const double *piv, double *X,
                                      int nrhs) {
    for (int k = 0; k < n; ++k) {
        const int p = (int)piv[k];
        if (p == k) continue;
        for (int j = 0; j < nrhs; ++j) {
            double tmp = X[k * nrhs + j]; X[k * nrhs + j] = X[p * nrhs + j];
            X[p * nrhs + j] = tmp;
        }
    }
    for (int k = 0; k < n; ++k) {
        for (int i = k + 1; i < n; ++i) {
            const double factor = A[i * n + k];
            if (factor == 0.0) continue;
            for (int j = 0; j < nrhs; ++j) X[i * nrhs + j] -= factor * X[k * nrhs + j];
        }
    }
    for (int k = n - 1; k >= 0; --k) {
        const double inv = 1.0 / A[k * n + k];
        for (int i = k + 1; i < n; ++i) {
            const double a = A[k * n + i];
            if (a == 0.0) continue;
            for (int j = 0; j < nrhs; ++j) X[k * nrhs + j] -= a * X[i * nrhs + j];
        }
        for (int j = 0; j < nrhs; ++j) X[k * nrhs + j] *= inv;
    }
}

#if KD_NUDEP == 0 && (KD_SOLVE == 1 || KD_SOLVE == 2)
/* without dependent speeds the system is M, factored as for the right-hand side
   (L^T D L: kd_ltdl_dense or kd_ltdl_tree, the same u'); then X = -M^-1 X (X:
   KD_NU x KD_JC, the sign taken in the diagonal step) from those factors, whole
   rows of X at a time (the compiler vectorizes them).  From rows of 32 columns,
   each row that is updated gathers up to four solved rows per pass, so it is
   loaded and stored once per four of them (the dense factor: both triangular
   solves; a tree's: the solve with L, whose rows gather their ancestors); on
   chain3d, C, per state: 0.83x the time of one row per pass at n = 30, slower at
   n = 7 (14 columns) */
#define KD_JACOBIAN_LTDL 1
#if KD_SOLVE == 1
#define KD_LTDL kd_ltdl_dense
#else
#define KD_LTDL kd_ltdl_tree
#endif
#define KD_GATHER_ROWS (KD_JC >= 32)
/* x -= a0 x0 + a1 x1 + a2 x2 + a3 x3 (rows of KD_JC) */
#define KD_GATHER4(x, a, r) \
    for (int j = 0; j < KD_JC; ++j) \
        x[j] -= (a[0] * r[0][j] + a[1] * r[1][j]) + (a[2] * r[2][j] + a[3] * r[3][j])
KD_VECTORIZED static void kd_ltdl_apply(const double *restrict A, double *restrict X) {
    const int n = KD_NU;
    double a[4];
    const double *r[4];
#if KD_SOLVE == 1
    for (int i = n - 2; i >= 0; --i) {  /* L^T Z = X: row i gathers the rows below it */
        double *restrict xi = X + i * KD_JC;
        int k = i + 1;
        for (; KD_GATHER_ROWS && k + 3 < n; k += 4) {
            for (int c = 0; c < 4; ++c) {
                a[c] = A[(k + c) * n + i];
                r[c] = X + (k + c) * KD_JC;
            }
            KD_GATHER4(xi, a, r);
        }
        for (; k < n; ++k) {
            const double b = A[k * n + i];
            const double *restrict xk = X + k * KD_JC;
            for (int j = 0; j < KD_JC; ++j) xi[j] -= b * xk[j];
        }
    }
#else
    for (int k = n - 1; k > 0; --k) {  /* L^T Z = X: row k scattered to its ancestors */
        const double *restrict xk = X + k * KD_JC;
        for (int i = kd_parent[k]; i >= 0; i = kd_parent[i]) {
            const double b = A[k * n + i];
            double *restrict xi = X + i * KD_JC;
            for (int j = 0; j < KD_JC; ++j) xi[j] -= b * xk[j];
        }
    }
#endif
    for (int k = 0; k < n; ++k) {  /* -D^-1 */
        const double s = -1.0 / A[k * n + k];
        double *restrict xk = X + k * KD_JC;
        for (int j = 0; j < KD_JC; ++j) xk[j] *= s;
    }
    for (int k = 1; k < n; ++k) {  /* L X = Z: row k gathers its ancestors */
        double *restrict xk = X + k * KD_JC;
        const double *restrict rk = A + k * n;
#if KD_SOLVE == 1
        int i = 0;
        for (; KD_GATHER_ROWS && i + 3 < k; i += 4) {
            for (int c = 0; c < 4; ++c) {
                a[c] = rk[i + c];
                r[c] = X + (i + c) * KD_JC;
            }
            KD_GATHER4(xk, a, r);
        }
        for (; i < k; ++i) {
#else
        int i = kd_parent[k], c = 0;
        for (; i >= 0; i = kd_parent[i]) {
            a[c] = rk[i];
            r[c] = X + i * KD_JC;
            if (++c == 4) {
                KD_GATHER4(xk, a, r);
                c = 0;
            }
        }
        for (int e = 0; e < c; ++e) {
            i = (int)((r[e] - X) / KD_JC);
#endif
            const double b = rk[i];
            const double *restrict xi = X + i * KD_JC;
            for (int j = 0; j < KD_JC; ++j) xk[j] -= b * xi[j];
        }
    }
}
#else
#define KD_JACOBIAN_LTDL 0
#endif

/* [[M, -B^T], [K, 0]] [u'; lambda] = [f; -f_a]: the system S, its LU factors
   (pivots piv) and the solution sol; 1 if singular */
static int kd_index1_lu(const double *M, const double *fv, const double *B, const double *Ka,
                        const double *fa, double *S, double *piv, double *sol) {
    for (int i = 0; i < KD_NS; ++i)
        for (int j = 0; j < KD_NS; ++j) S[i * KD_NS + j] = 0.0;
    for (int i = 0; i < KD_NU; ++i) {
        for (int j = 0; j < KD_NU; ++j) S[i * KD_NS + j] = M[i * KD_NU + j];
        sol[i] = fv[i];
    }
    for (int c = 0; c < KD_NUDEP; ++c) {
        for (int j = 0; j < KD_NU; ++j) {
            S[j * KD_NS + KD_NU + c] = -B[c * KD_NU + j];
            S[(KD_NU + c) * KD_NS + j] = Ka[c * KD_NU + j];
        }
        sol[KD_NU + c] = -fa[c];
    }
    if (kd_lu_factor(KD_NS, S, piv) != 0) return 1;
    kd_lu_apply(KD_NS, S, piv, sol, 1);
    return 0;
}

/* one column group of the derivatives: g_x into the rows of q' of D, the
   right-hand sides [E_x; a_x] (negated where `negate`) into X, both at column
   `at` of the KD_JC */
KD_VECTORIZED static void kd_jacobian_group(const double *restrict g, const double *restrict E,
                                            const double *restrict a, int cols, int at,
                                            int negate, double *restrict D,
                                            double *restrict X) {
    for (int i = 0; i < KD_NQ; ++i)
        memcpy(D + i * KD_JC + at, g + i * cols, sizeof(double) * cols);
    for (int i = 0; i < KD_NS; ++i) {
        const double *restrict from = i < KD_NU ? E + i * cols : a + (i - KD_NU) * cols;
        double *restrict to = X + i * KD_JC + at;
        if (negate)
            for (int j = 0; j < cols; ++j) to[j] = -from[j];
        else
            memcpy(to, from, sizeof(double) * cols);
    }
}

/* The derivatives at the solution rx (its inputs, then u' and the multipliers):
   the blocks g_x, E_x, a_x of each column group, each at the start of its own
   rows of G and EA (columns of that group only; in D and X themselves when there
   is one group), h_y and c_y into C, a tree's n^2 part added from TF
   (kd_tree_jacobian); then each group's blocks copied to its columns of D and
   X, negated where `negate`. */
static void kd_jacobian_blocks(double t, const double *y, const double *p, double *rx,
                               double *w, double *G, double *EA, double *TF, int negate,
                               double *D, double *X, double *C) {
    double *g[3], *E[3], *a[3];
    const int cols[3] = {KD_NX, KD_NR, KD_JP};
    for (int k = 0, at = 0; k < 3; at += cols[k], ++k) {
        g[k] = KD_JAC_ONE_GROUP ? D : G + KD_NQ * at;
        E[k] = KD_JAC_ONE_GROUP ? X : EA + KD_NS * at;
        a[k] = E[k] + KD_NU * cols[k];
    }
    /* h_y, then c_y; without configuration constraints h_y has no entries: a
       pointer of its own, not aliasing c_y's (restrict) */
    static double no_rows[1];
    double *h = KD_NQDEP > 0 ? C : no_rows;
#if KD_JAC_GROUPS == 3  /* the constants' outputs, of no columns where there are none */
    KD_JAC_EVAL(t, y, p, rx, w, g[0], E[0], a[0], g[1], E[1], a[1], g[2], E[2], a[2],
                h, C + KD_NQDEP * KD_NX KD_TREE_OUT);
#else
    KD_JAC_EVAL(t, y, p, rx, w, g[0], E[0], a[0], g[1], E[1], a[1],
                h, C + KD_NQDEP * KD_NX KD_TREE_OUT);
#endif
#if KD_TREE_JAC
    kd_tree_jacobian(TF, E[0]);
#else
    (void)TF;
#endif
    for (int k = 0, at = 0; k < 3 && !KD_JAC_ONE_GROUP; at += cols[k], ++k)
        if (cols[k] > 0) kd_jacobian_group(g[k], E[k], a[k], cols[k], at, negate, D, X);
}

#if KD_JAC_TREE_SOLVE
#if KD_SOLVE != 3 || KD_NUDEP > 0
#error "the articulated-body solve of the derivatives needs the tree pass (KD_SOLVE 3)"
#endif
/* X = -M^-1 X in place (X: KD_NU rows of `cols`, a row per speed) from the
   factors of kd_tree_factor, all columns at once along rows (the compiler
   vectorizes them): leaves to roots, c_r = x_r - S_r . P_r and P_parent +=
   P_r + UD_r c_r (P_r: 6 rows, the bias of the bodies below r); roots to
   leaves, x_r = c_r / D_r - UD_r . A_parent and A_r = A_parent + S_r x_r
   (A_r: 6 rows, the acceleration of r's body, in P_r's place), all of them
   negated there (-c_r / D_r: the sign of the result taken in that pass).  About 24
   multiply-adds per speed and column, against n for the factors of M.  The
   number of columns, KD_JC, is known to the compiler, which then vectorizes
   the rows (it did not for a number given at run time) */
KD_VECTORIZED static void kd_tree_apply(const double *restrict S, const double *restrict UD,
                                 const double *restrict Dinv, double *restrict X,
                                 double *restrict P) {
    const int cols = KD_JC;
#if KD_TSOLVE_CHAIN
    for (int c = 0; c < 6 * cols; ++c) P[c] = 0.0;
#define KD_BIAS(r) P  /* one block: P of the speed below, then of r (in place) */
#else
    for (int c = 0; c < 6 * cols * KD_NU; ++c) P[c] = 0.0;
#define KD_BIAS(r) (P + (r) * 6 * cols)
#endif
    for (int k = 0; k < KD_NU; ++k) {  /* leaves to roots */
        const int r = kd_torder[k], up = kd_tparent[r];
        const double s0 = S[6 * r], s1 = S[6 * r + 1], s2 = S[6 * r + 2], s3 = S[6 * r + 3],
                     s4 = S[6 * r + 4], s5 = S[6 * r + 5];
        double *restrict x = X + r * cols;
        double *restrict b0 = KD_BIAS(r), *restrict b1 = b0 + cols, *restrict b2 = b1 + cols,
               *restrict b3 = b2 + cols, *restrict b4 = b3 + cols, *restrict b5 = b4 + cols;
        if (up < 0) {
            for (int j = 0; j < cols; ++j)
                x[j] -= (s0 * b0[j] + s1 * b1[j]) + (s2 * b2[j] + s3 * b3[j])
                        + (s4 * b4[j] + s5 * b5[j]);
            continue;
        }
        const double u0 = UD[6 * r], u1 = UD[6 * r + 1], u2 = UD[6 * r + 2],
                     u3 = UD[6 * r + 3], u4 = UD[6 * r + 4], u5 = UD[6 * r + 5];
#if KD_TSOLVE_CHAIN
        for (int j = 0; j < cols; ++j) {  /* the parent's P in place */
            const double c = x[j] - ((s0 * b0[j] + s1 * b1[j]) + (s2 * b2[j] + s3 * b3[j])
                                     + (s4 * b4[j] + s5 * b5[j]));
            x[j] = c;
            b0[j] += u0 * c; b1[j] += u1 * c; b2[j] += u2 * c;
            b3[j] += u3 * c; b4[j] += u4 * c; b5[j] += u5 * c;
        }
#else
        double *restrict a0 = KD_BIAS(up), *restrict a1 = a0 + cols, *restrict a2 = a1 + cols,
               *restrict a3 = a2 + cols, *restrict a4 = a3 + cols, *restrict a5 = a4 + cols;
        for (int j = 0; j < cols; ++j) {
            const double c = x[j] - ((s0 * b0[j] + s1 * b1[j]) + (s2 * b2[j] + s3 * b3[j])
                                     + (s4 * b4[j] + s5 * b5[j]));
            x[j] = c;
            a0[j] += b0[j] + u0 * c; a1[j] += b1[j] + u1 * c; a2[j] += b2[j] + u2 * c;
            a3[j] += b3[j] + u3 * c; a4[j] += b4[j] + u4 * c; a5[j] += b5[j] + u5 * c;
        }
#endif
    }
    for (int k = KD_NU - 1; k >= 0; --k) {  /* roots to leaves: A in P's place */
        const int r = kd_torder[k], up = kd_tparent[r];
        const double s0 = S[6 * r], s1 = S[6 * r + 1], s2 = S[6 * r + 2], s3 = S[6 * r + 3],
                     s4 = S[6 * r + 4], s5 = S[6 * r + 5];
        const double inv = -Dinv[r];  /* -M^-1 X */
        double *restrict x = X + r * cols;
        double *restrict a0 = KD_BIAS(r), *restrict a1 = a0 + cols, *restrict a2 = a1 + cols,
               *restrict a3 = a2 + cols, *restrict a4 = a3 + cols, *restrict a5 = a4 + cols;
        if (up < 0) {
            for (int j = 0; j < cols; ++j) {
                const double v = x[j] * inv;
                x[j] = v;
                a0[j] = s0 * v; a1[j] = s1 * v; a2[j] = s2 * v;
                a3[j] = s3 * v; a4[j] = s4 * v; a5[j] = s5 * v;
            }
            continue;
        }
        const double u0 = UD[6 * r], u1 = UD[6 * r + 1], u2 = UD[6 * r + 2],
                     u3 = UD[6 * r + 3], u4 = UD[6 * r + 4], u5 = UD[6 * r + 5];
#if KD_TSOLVE_CHAIN
        for (int j = 0; j < cols; ++j) {  /* A of the speed above, then of r (in place) */
            const double v = x[j] * inv - ((u0 * a0[j] + u1 * a1[j]) + (u2 * a2[j] + u3 * a3[j])
                                           + (u4 * a4[j] + u5 * a5[j]));
            x[j] = v;
            a0[j] += s0 * v; a1[j] += s1 * v; a2[j] += s2 * v;
            a3[j] += s3 * v; a4[j] += s4 * v; a5[j] += s5 * v;
        }
#else
        const double *restrict g0 = KD_BIAS(up), *restrict g1 = g0 + cols,
                     *restrict g2 = g1 + cols, *restrict g3 = g2 + cols,
                     *restrict g4 = g3 + cols, *restrict g5 = g4 + cols;
        for (int j = 0; j < cols; ++j) {
            const double v = x[j] * inv - ((u0 * g0[j] + u1 * g1[j]) + (u2 * g2[j] + u3 * g3[j])
                                           + (u4 * g4[j] + u5 * g5[j]));
            x[j] = v;
            a0[j] = g0[j] + s0 * v; a1[j] = g1[j] + s1 * v; a2[j] = g2[j] + s2 * v;
            a3[j] = g3[j] + s3 * v; a4[j] = g4[j] + s4 * v; a5[j] = g5[j] + s5 * v;
        }
#endif
    }
#undef KD_BIAS
}
#endif

#if KD_JAC_TREE_SOLVE
/* kd_jacobian_core of a tree without M: the tree pass (kd_eval_tree: q', the
   forcing, S, IO) and the articulated-body factors give u' and then the
   derivative columns (kd_tree_apply); a factor not > 0: singular (1) */
KD_GEN int kd_jacobian_core(double t, const double *y, const double *p, const double *r,
                            double *w, double *scratch, double *f, double *D, double *C) {
    double *qd = scratch, *fv = qd + KD_NQ, *Sv = fv + KD_NU, *IO = Sv + 6 * KD_NU;
    double *UD = IO + 10 * KD_NU, *Dinv = UD + 6 * KD_NU, *bias = Dinv + KD_NU;
    double *rx = bias + KD_TREE_BIAS, *G = rx + KD_NR + KD_NU;
    double *EA = G + (KD_JAC_ONE_GROUP ? 0 : KD_NQ * KD_JC), *TF = G + KD_JAC_BLOCKS;
    double *X = D + KD_NQ * KD_JC;
    kd_eval_tree(t, y, p, r, w, qd, fv, Sv, IO);
    for (int i = 0; i < KD_NR; ++i) rx[i] = r[i];
    double *ud = rx + KD_NR;
    memcpy(ud, fv, sizeof(double) * KD_NU);
    if (kd_tree_factor(Sv, IO, UD, Dinv, ud) != 0) return 1;
    kd_jacobian_blocks(t, y, p, rx, w, G, EA, TF, 0, D, X, C);
    kd_tree_apply(Sv, UD, Dinv, X, bias);  /* -M^-1 X: the sign in its last pass */
    memcpy(f, qd, sizeof(double) * KD_NQ);
    memcpy(f + KD_NQ, ud, sizeof(double) * KD_NU);
    return 0;
}
#else
KD_GEN int kd_jacobian_core(double t, const double *y, const double *p, const double *r,
                            double *w, double *scratch, double *f, double *D, double *C) {
    double *qd = scratch, *M = qd + KD_NQ, *fv = M + KD_NU * KD_NU, *B = fv + KD_NU;
    double *Ka = B + KD_NUDEP * KD_NU, *fa = Ka + KD_NUDEP * KD_NU, *S = fa + KD_NUDEP;
    double *piv = S + KD_NS * KD_NS, *sol = piv + KD_NS, *rx = sol + KD_NS;
    double *G = rx + KD_NR + KD_NS, *EA = G + (KD_JAC_ONE_GROUP ? 0 : KD_NQ * KD_JC);
    double *TF = G + KD_JAC_BLOCKS;
    double *X = D + KD_NQ * KD_JC;  /* the solve in place: the rows of u', then of lambda */
    kd_eval_dynamics(t, y, p, r, w, qd, M, fv, B, Ka, fa);
    int lu = 1;
#if KD_JACOBIAN_LTDL
    memcpy(sol, fv, sizeof(double) * KD_NU);
    lu = KD_LTDL(M, sol) != 0;  /* M: its factors */
    if (lu) kd_eval_dynamics(t, y, p, r, w, qd, M, fv, B, Ka, fa);  /* not positive
                                                 definite: M again, LU with pivoting */
#endif
    if (lu && kd_index1_lu(M, fv, B, Ka, fa, S, piv, sol) != 0) return 1;
    for (int i = 0; i < KD_NR; ++i) rx[i] = r[i];
    for (int i = 0; i < KD_NS; ++i) rx[KD_NR + i] = sol[i];
    int negate = 1;  /* kd_ltdl_apply negates by itself */
#if KD_JACOBIAN_LTDL
    negate = lu;
#endif
    kd_jacobian_blocks(t, y, p, rx, w, G, EA, TF, negate, D, X, C);
    if (KD_JAC_ONE_GROUP && negate)  /* written in place: the sign here */
        for (int i = 0; i < KD_NS * KD_JC; ++i) X[i] = -X[i];
#if KD_JACOBIAN_LTDL
    if (!lu) kd_ltdl_apply(M, X); else
#endif
    kd_lu_apply(KD_NS, S, piv, X, KD_JC);
    memcpy(f, qd, sizeof(double) * KD_NQ);
    memcpy(f + KD_NQ, sol, sizeof(double) * KD_NU);
    return 0;
}
#endif
"""

#: the exact derivatives of :data:`JACOBIAN_SOLVE` as the Python entry points of
#: the module take them (``KdJacobianInfo``, declared in :data:`SHARED`)
JACOBIAN_INFO = r"""
static const KdJacobianInfo kd_jacobian_info = {kd_jacobian_core, KD_JC, KD_NCON,
                                                KD_JAC_SCRATCH};
#define KD_JACOBIAN_INFO (&kd_jacobian_info)
"""


#: the part of the runtime without Python: linear algebra and the right-hand
#: side ``kd_rhs_core`` (the standalone C export)
LINALG = SIZE_MACROS + LU_SOLVE + MODEL_SOLVE

#: the lane-wise batch path (``KD_LANES`` > 0, generated by ``_c_lanes``): the
#: solve of M u' = f for KD_W states at once and the evaluation of KD_W rows
LANE_RUNTIME = r"""
#ifndef KD_LANES
#define KD_LANES 0
#endif
#if KD_LANES > 0
#define KD_W KD_LANES
#if defined(__clang__)
#define KD_LANE_LOOP _Pragma("clang loop vectorize(enable)")
#elif defined(__GNUC__)
#define KD_LANE_LOOP _Pragma("GCC ivdep")
#else
#define KD_LANE_LOOP
#endif
#if defined(__GNUC__) && defined(__x86_64__)
#define KD_LANES_FN __attribute__((target("avx2")))
static int kd_lanes_usable(void) {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}
#else
#define KD_LANES_FN
static int kd_lanes_usable(void) { return 1; }
#endif
/* doubles of lane work: inputs, outputs, shared values */
#define KD_LANE_WORK ((KD_NX + KD_SZ(KD_NP) + KD_SZ(KD_NR) + 1 + KD_SZ(KD_NQ) \
                       + KD_NU * KD_NU + KD_NU + KD_SZ(KD_NWL)) * KD_W)
#endif
"""

#: defined after the generated lane functions
LANE_SOLVE = r"""
#if KD_LANES > 0
/* M = L^T D L of KD_W mass matrices at once (entry (i, j) of lane l at
   A[(i * KD_NU + j) * KD_W + l]), then M x = b in place: the loops of
   kd_ltdl_dense / kd_ltdl_tree with the lane innermost.  Returns a bit mask of
   the lanes whose matrix is not positive definite (their values are garbage). */
#if KD_SOLVE == 2
#define KD_BELOW(k) kd_parent[k]
#define KD_NEXT(i) kd_parent[i]
#else
#define KD_BELOW(k) ((k) - 1)
#define KD_NEXT(i) ((i) - 1)
#endif
KD_LANES_FN static unsigned kd_lanes_ltdl(double *restrict A, double *restrict b) {
    const int n = KD_NU;
    unsigned bad = 0;
#if KD_SOLVE == 2
    for (int k = n - 1; k >= 0; --k) {
        double *restrict rk = A + (size_t)k * n * KD_W;
        double inv[KD_W];
        for (int l = 0; l < KD_W; ++l) {
            const double d = rk[k * KD_W + l];
            if (!(d > 0.0)) bad |= 1u << l;
            inv[l] = 1.0 / d;
        }
        for (int i = kd_parent[k]; i >= 0; i = kd_parent[i]) {
            double *restrict ri = A + (size_t)i * n * KD_W;
            double a[KD_W];
            KD_LANE_LOOP
            for (int l = 0; l < KD_W; ++l) a[l] = rk[i * KD_W + l] * inv[l];
            for (int j = i; j >= 0; j = kd_parent[j]) {
                KD_LANE_LOOP
                for (int l = 0; l < KD_W; ++l) ri[j * KD_W + l] -= a[l] * rk[j * KD_W + l];
            }
            KD_LANE_LOOP
            for (int l = 0; l < KD_W; ++l) rk[i * KD_W + l] = a[l];
        }
    }
#else  /* rows k and k - 1 together, in the order of kd_ltdl_dense (same roundings) */
    int k = n - 1;
    for (; k >= 1; k -= 2) {
        double *restrict rk = A + (size_t)k * n * KD_W;
        double *restrict rl = A + (size_t)(k - 1) * n * KD_W;
        double ik[KD_W], c[KD_W], il[KD_W];
        for (int l = 0; l < KD_W; ++l) {
            const double d = rk[k * KD_W + l];
            if (!(d > 0.0)) bad |= 1u << l;
            ik[l] = 1.0 / d;
            c[l] = rk[(k - 1) * KD_W + l] * ik[l];
        }
        for (int j = 0; j < k; ++j) {
            KD_LANE_LOOP
            for (int l = 0; l < KD_W; ++l) rl[j * KD_W + l] -= c[l] * rk[j * KD_W + l];
        }
        for (int l = 0; l < KD_W; ++l) {
            rk[(k - 1) * KD_W + l] = c[l];
            const double d = rl[(k - 1) * KD_W + l];
            if (!(d > 0.0)) bad |= 1u << l;
            il[l] = 1.0 / d;
        }
        for (int i = k - 2; i >= 0; --i) {
            double *restrict ri = A + (size_t)i * n * KD_W;
            double a[KD_W], e[KD_W];
            KD_LANE_LOOP
            for (int l = 0; l < KD_W; ++l) {
                a[l] = rk[i * KD_W + l] * ik[l];
                e[l] = rl[i * KD_W + l] * il[l];
            }
            for (int j = 0; j <= i; ++j) {
                KD_LANE_LOOP
                for (int l = 0; l < KD_W; ++l)
                    ri[j * KD_W + l] -= a[l] * rk[j * KD_W + l] + e[l] * rl[j * KD_W + l];
            }
            KD_LANE_LOOP
            for (int l = 0; l < KD_W; ++l) {
                rk[i * KD_W + l] = a[l];
                rl[i * KD_W + l] = e[l];
            }
        }
    }
    if (k == 0)
        for (int l = 0; l < KD_W; ++l)
            if (!(A[l] > 0.0)) bad |= 1u << l;
#endif
    for (int k = n - 1; k > 0; --k) {  /* L^T z = b */
        const double *restrict rk = A + (size_t)k * n * KD_W;
        for (int i = KD_BELOW(k); i >= 0; i = KD_NEXT(i)) {
            KD_LANE_LOOP
            for (int l = 0; l < KD_W; ++l) b[i * KD_W + l] -= rk[i * KD_W + l] * b[k * KD_W + l];
        }
    }
    for (int k = 0; k < n; ++k) {  /* D */
        KD_LANE_LOOP
        for (int l = 0; l < KD_W; ++l) b[k * KD_W + l] /= A[((size_t)k * n + k) * KD_W + l];
    }
    for (int k = 1; k < n; ++k) {  /* L x = z */
        const double *restrict rk = A + (size_t)k * n * KD_W;
#if KD_SOLVE == 2
        for (int i = kd_parent[k]; i >= 0; i = kd_parent[i]) {
#else
        for (int i = 0; i < k; ++i) {  /* the order of kd_ltdl_dense */
#endif
            KD_LANE_LOOP
            for (int l = 0; l < KD_W; ++l) b[k * KD_W + l] -= rk[i * KD_W + l] * b[i * KD_W + l];
        }
    }
    return bad;
}
#undef KD_BELOW
#undef KD_NEXT

/* KD_W rows from `first` (y, out: row-major with KD_NX columns; t: one per row
   unless t_scalar; P: KD_NP per row, or NULL for p; r: KD_NR per row).  A lane
   whose mass matrix is not positive definite is done again by kd_rhs_core
   (LU with pivoting; NaN if singular).  lw: KD_LANE_WORK doubles, w: the scalar
   work array. */
KD_LANES_FN KD_GEN void kd_lanes_rows(const double *t, int t_scalar, const double *y,
                                      const double *P, const double *p, const double *r,
                                      double *out, double *restrict lw, double *w) {
    double *yl = lw, *pl = yl + KD_NX * KD_W, *rl = pl + KD_SZ(KD_NP) * KD_W;
    double *tl = rl + KD_SZ(KD_NR) * KD_W, *qd = tl + KD_W, *M = qd + KD_SZ(KD_NQ) * KD_W;
    double *f = M + KD_NU * KD_NU * KD_W, *shared = f + KD_NU * KD_W;
    for (int l = 0; l < KD_W; ++l) {
        tl[l] = t_scalar ? t[0] : t[l];
        for (int i = 0; i < KD_NX; ++i) yl[i * KD_W + l] = y[l * KD_NX + i];
        for (int i = 0; i < KD_NP; ++i) pl[i * KD_W + l] = P ? P[l * KD_NP + i] : p[i];
        for (int i = 0; i < KD_NR; ++i) rl[i * KD_W + l] = r[l * KD_NR + i];
    }
    kd_lanes_dynamics(tl, yl, pl, rl, shared, qd, M, f);
    unsigned bad = kd_lanes_ltdl(M, f);
    for (int l = 0; l < KD_W; ++l) {
        double *row = out + l * KD_NX;
        if (bad & (1u << l)) {
            static const double no_inputs[1] = {0.0};
            if (kd_rhs_core(tl[l], y + l * KD_NX, P ? P + l * KD_NP : p,
                            KD_NR > 0 ? r + l * KD_NR : no_inputs, w, row) != 0)
                for (int j = 0; j < KD_NX; ++j) row[j] = NAN;
            continue;
        }
        for (int i = 0; i < KD_NQ; ++i) row[i] = qd[i * KD_W + l];
        for (int i = 0; i < KD_NU; ++i) row[KD_NQ + i] = f[i * KD_W + l];
    }
}
#endif
"""

PYTHON_GLUE = r"""
/* ------------------------------------------------------------ the quick module's use */
/* A module from the quick compiler (TinyCC, which defines __TINYC__; see
   kanedyn's _c_quick) adds up the time its Python entry points take, s, read by
   `_quick_use()`: its optimized build starts once that use pays for it.  The
   optimizing compiler's module has none of this. */
#ifdef __TINYC__
#include <time.h>
static double kd_quick_use = 0.0;  /* added to with the GIL held */
static double kd_use_clock(void) {
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}
#define KD_USE_START double kd_use_start = kd_use_clock();
#define KD_USE_END kd_quick_use += kd_use_clock() - kd_use_start;
/* f's Python entry point timed: f_timed, of f's arguments */
#define KD_TIMED(f, PARAMS, ARGS) \
    static PyObject *f##_timed PARAMS { \
        KD_USE_START PyObject *result = f ARGS; KD_USE_END return result; \
    }
#define KD_METHOD(f) f##_timed
static PyObject *kd_py_quick_use(PyObject *self, PyObject *unused) {
    (void)self; (void)unused;
    return PyFloat_FromDouble(kd_quick_use);
}
#else
#define KD_USE_START
#define KD_USE_END
#define KD_TIMED(f, PARAMS, ARGS)
#define KD_METHOD(f) f
#endif
/* the signatures of the entry points: METH_FASTCALL, METH_VARARGS (with keywords) */
#define KD_FAST(T) (T *self, PyObject *const *args, Py_ssize_t nargs)
#define KD_ARGS(T) (T *self, PyObject *args)
#define KD_KEYWORDS(T) (T *self, PyObject *args, PyObject *kwds)

/* ------------------------------------------------------------ the model's code */
/* The model's right-hand side is called through this pointer (and its table of
   functions through kd_table): kd_py_adopt points both at the optimized build of
   the same model, which returns the same numbers, even while an integration
   runs on them. */
typedef int (*KdRhsCore)(double t, const double *y, const double *p, const double *r,
                         double *w, double *out);
static KdRhsCore kd_rhs_now = kd_rhs_core;
#if defined(__GNUC__)
#define KD_RHS_CORE (__atomic_load_n(&kd_rhs_now, __ATOMIC_ACQUIRE))
#else
#define KD_RHS_CORE kd_rhs_now  /* an aligned pointer, stored whole */
#endif

/* ------------------------------------------------------------ arguments */
/* The entries of obj when it is a 1-D float64 array of n entries that can be read
   in place (native byte order, aligned, contiguous), else NULL. */
static const double *kd_in_place(PyObject *obj, npy_intp n) {
    if (!PyArray_CheckExact(obj)) return NULL;
    PyArrayObject *arr = (PyArrayObject *)obj;
    if (PyArray_TYPE(arr) != NPY_DOUBLE || PyArray_NDIM(arr) != 1
            || !PyArray_IS_C_CONTIGUOUS(arr) || !PyArray_ISNOTSWAPPED(arr)
            || !PyArray_ISALIGNED(arr) || PyArray_SIZE(arr) != n) return NULL;
    return (const double *)PyArray_DATA(arr);
}

static const double *kd_vector(PyObject *obj, npy_intp n, PyObject **keep, const char *what) {
    const double *x = kd_in_place(obj, n);
    *keep = NULL;
    if (x != NULL) return x;
    PyArrayObject *arr = (PyArrayObject *)PyArray_FROMANY(obj, NPY_DOUBLE, 1, 1,
                                                          NPY_ARRAY_IN_ARRAY);
    if (arr == NULL) return NULL;
    if (PyArray_SIZE(arr) != n) {
        PyErr_Format(PyExc_ValueError, "%s must have %zd entries, got %zd", what,
                     (Py_ssize_t)n, (Py_ssize_t)PyArray_SIZE(arr));
        Py_DECREF(arr);
        return NULL;
    }
    *keep = (PyObject *)arr;
    return (const double *)PyArray_DATA(arr);
}

static PyObject *kd_new_vector(npy_intp n, double **data) {
    PyObject *out = PyArray_SimpleNew(1, &n, NPY_DOUBLE);
    if (out != NULL) *data = (double *)PyArray_DATA((PyArrayObject *)out);
    return out;
}

static PyObject *kd_new_matrix(npy_intp rows, npy_intp cols, double **data) {
    npy_intp dims[2] = {rows, cols};
    PyObject *out = PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    if (out != NULL) *data = (double *)PyArray_DATA((PyArrayObject *)out);
    return out;
}

/* ---------------------------------------------------------- Model type */
typedef struct {
    PyObject_HEAD
    double *p;         /* KD_NP constants (heap: the sizes are run-time constants) */
    PyObject *inputs;  /* the inputs' Python callable, or None with a table */
    double *work;
    double *table;     /* inputs as polynomial pieces (kd_pieces_parse), or NULL */
    KdPiece *pieces;   /* KD_NR (heap) */
    PyObject *input_names;  /* with a table: tuple of the inputs' names */
} KdModel;

static void KdModel_dealloc(KdModel *self) {
    Py_XDECREF(self->inputs);
    Py_XDECREF(self->input_names);
    PyMem_Free(self->work);
    PyMem_Free(self->table);
    PyMem_Free(self->p);
    PyMem_Free(self->pieces);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyObject *KdModel_new(PyTypeObject *type, PyObject *args, PyObject *kwds) {
    KdModel *self = (KdModel *)PyType_GenericNew(type, args, kwds);
    if (self == NULL) return NULL;
    self->p = (double *)PyMem_Calloc((size_t)KD_SZ(KD_NP), sizeof(double));
    self->pieces = (KdPiece *)PyMem_Calloc((size_t)KD_SZ(KD_NR), sizeof(KdPiece));
    if (self->p == NULL || self->pieces == NULL) {
        Py_DECREF(self);
        return PyErr_NoMemory();
    }
    return (PyObject *)self;
}

/* the specified inputs at (t, y): from the table in C, else from the Python callable
   inputs(t, y) (y a NumPy array); -1 with a Python error */
static int kd_inputs(KdModel *self, double t, PyObject *y, double *r) {
#if KD_HAS_R
    if (self->table != NULL) return kd_pieces_eval(self->pieces, KD_NR, self->input_names, t, r);
    PyObject *inputs = self->inputs;
    PyObject *args[2];
    args[0] = PyFloat_FromDouble(t);
    if (args[0] == NULL) return -1;
    args[1] = y;
    PyObject *res = PyObject_Vectorcall(inputs, args, 2, NULL);
    Py_DECREF(args[0]);
    if (res == NULL) return -1;
    PyObject *seq = PySequence_Fast(res, "specified inputs must be a sequence");
    Py_DECREF(res);
    if (seq == NULL) return -1;
    if (PySequence_Fast_GET_SIZE(seq) != KD_NR) {
        PyErr_SetString(PyExc_ValueError, "wrong number of specified input values");
        Py_DECREF(seq);
        return -1;
    }
    for (int i = 0; i < KD_NR; ++i) {
        r[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, i));
        if (r[i] == -1.0 && PyErr_Occurred()) { Py_DECREF(seq); return -1; }
    }
    Py_DECREF(seq);
#endif
    return 0;
}


static int KdModel_init(KdModel *self, PyObject *args, PyObject *kwds) {
    PyObject *pobj, *inputs = Py_None, *table = Py_None, *names = Py_None, *keep = NULL;
    if (!PyArg_ParseTuple(args, "O|OOO", &pobj, &inputs, &table, &names)) return -1;
    const double *p = kd_vector(pobj, KD_NP, &keep, "p");
    if (p == NULL) return -1;
    for (int i = 0; i < KD_NP; ++i) self->p[i] = p[i];
    Py_XDECREF(keep);
    if (KD_NR > 0 && inputs == Py_None && table == Py_None) {
        PyErr_SetString(PyExc_ValueError, "this model needs a callable or a table for "
                        "its inputs");
        return -1;
    }
    PyMem_Free(self->table);
    self->table = NULL;
    if (KD_NR > 0 && table != Py_None) {  /* inputs(t, y) -> table(t), in C */
        if (!PyTuple_Check(names) || PyTuple_GET_SIZE(names) != KD_NR) {
            PyErr_SetString(PyExc_ValueError, "a table of inputs needs a tuple of their names");
            return -1;
        }
        PyArrayObject *arr = (PyArrayObject *)PyArray_FROMANY(table, NPY_DOUBLE, 1, 1,
                                                              NPY_ARRAY_IN_ARRAY);
        if (arr == NULL) return -1;
        npy_intp size = PyArray_SIZE(arr);
        self->table = (double *)PyMem_Malloc(sizeof(double) * (size_t)(size > 0 ? size : 1));
        if (self->table == NULL) { Py_DECREF(arr); PyErr_NoMemory(); return -1; }
        memcpy(self->table, PyArray_DATA(arr), sizeof(double) * (size_t)size);
        Py_DECREF(arr);
        if (kd_pieces_parse(self->table, size, KD_NR, self->pieces) != 0) {
            PyMem_Free(self->table);
            self->table = NULL;
            return -1;
        }
        Py_INCREF(names);
        Py_XSETREF(self->input_names, names);
    }
    Py_INCREF(inputs);
    Py_XSETREF(self->inputs, inputs);
    if (self->work == NULL) {
        self->work = (double *)PyMem_Malloc(sizeof(double) * KD_SZ(KD_NW));
        if (self->work == NULL) { PyErr_NoMemory(); return -1; }
    }
    return 0;
}

static PyObject *KdModel_rhs(KdModel *self, PyObject *const *args, Py_ssize_t nargs) {
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "rhs(t, y) takes exactly 2 arguments");
        return NULL;
    }
    double t = PyFloat_AsDouble(args[0]);
    if (t == -1.0 && PyErr_Occurred()) return NULL;
    PyObject *keep = NULL;
    const double *y = kd_vector(args[1], KD_NX, &keep, "the state y");
    if (y == NULL) return NULL;
    double r[KD_SZ_R];
    if (kd_inputs(self, t, args[1], r) != 0) { Py_XDECREF(keep); return NULL; }
    double *out;
    PyObject *result = kd_new_vector(KD_NX, &out);
    if (result != NULL && KD_RHS_CORE(t, y, self->p, r, self->work, out) != 0) {
        Py_DECREF(result);
        result = NULL;
        PyErr_SetString(kd_linalg_error, "singular matrix in the equations of motion");
    }
    Py_XDECREF(keep);
    return result;
}

/* ------------------------------------------------------------ batches
   rhs_batch evaluates its rows in C, in blocks of KD_BATCH_BLOCK rows taken in
   turn by `threads` POSIX threads (the GIL released); without POSIX threads, or
   when a thread cannot be started, the calling thread does the remaining blocks. */
#if !defined(KD_NO_THREADS) && (defined(__unix__) || defined(__APPLE__))
#include <pthread.h>
#include <unistd.h>
#ifdef __linux__
#include <sched.h>
#endif
#define KD_HAVE_THREADS 1
#else
#define KD_HAVE_THREADS 0
#endif
#define KD_MAX_THREADS 64
#define KD_MIN_ROWS_PER_THREAD 32  /* fewer rows are not worth a thread */

typedef struct {
    const double *y, *t, *P, *p, *r;
    int t_scalar;
    npy_intp begin, end;
    double *out, *work, *lane_work;  /* lane_work: KD_LANE_WORK doubles when lanes */
    int lanes;  /* rows in blocks of KD_W lanes (kd_lanes_rows) */
    npy_intp *next;  /* shared: first row not yet taken (blocks taken dynamically) */
} KdBatchJob;

#define KD_BATCH_BLOCK 64  /* rows taken at a time: a slow thread holds no one up */

static void kd_batch_block(KdBatchJob *job);

static void kd_batch_rows(KdBatchJob *job) {
    for (;;) {
#if defined(__GNUC__)
        npy_intp first = __atomic_fetch_add(job->next, KD_BATCH_BLOCK, __ATOMIC_RELAXED);
#else
        npy_intp first = *job->next; *job->next += KD_BATCH_BLOCK;  /* one thread only */
#endif
        if (first >= job->end) return;
        job->begin = first;
        KdBatchJob part = *job;
        part.end = first + KD_BATCH_BLOCK < job->end ? first + KD_BATCH_BLOCK : job->end;
        kd_batch_block(&part);
    }
}

static void kd_batch_block(KdBatchJob *job) {
    static const double no_inputs[1] = {0.0};
    npy_intp i = job->begin;
#if KD_LANES > 0
    for (; job->lanes && i + KD_W <= job->end; i += KD_W)
        kd_lanes_rows(job->t_scalar ? job->t : job->t + i, job->t_scalar, job->y + i * KD_NX,
                      job->P ? job->P + i * KD_NP : NULL, job->p,
                      KD_NR > 0 ? job->r + i * KD_NR : NULL, job->out + i * KD_NX,
                      job->lane_work, job->work);
#endif
    for (; i < job->end; ++i) {
        double ti = job->t_scalar ? job->t[0] : job->t[i];
        const double *pi = job->P ? job->P + i * KD_NP : job->p;
        const double *ri = KD_NR > 0 ? job->r + i * KD_NR : no_inputs;
        double *row = job->out + i * KD_NX;
        if (KD_RHS_CORE(ti, job->y + i * KD_NX, pi, ri, job->work, row) != 0) {
            for (int j = 0; j < KD_NX; ++j) row[j] = NAN;
        }
    }
}

#if KD_HAVE_THREADS
static void *kd_batch_thread(void *job) {
    kd_batch_rows((KdBatchJob *)job);
    return NULL;
}
#endif

/* CPUs this process may run on (its affinity mask where known), at least 1. */
static int kd_available_cpus(void) {
#if KD_HAVE_THREADS
#if defined(__linux__) && defined(CPU_COUNT)
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof(set), &set) == 0 && CPU_COUNT(&set) > 0)
        return CPU_COUNT(&set);
#endif
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    if (n > 0) return n > KD_MAX_THREADS ? KD_MAX_THREADS : (int)n;
#endif
    return 1;
}

/* rows [0, k) in `count` blocks; returns 0, or -1 (MemoryError set) */
static int kd_batch_run(KdBatchJob *proto, npy_intp k, int count) {
    KdBatchJob jobs[KD_MAX_THREADS];
#if KD_LANES > 0
    const size_t lane_work = proto->lanes ? KD_LANE_WORK : 0;
#else
    const size_t lane_work = 0;
#endif
    const size_t each = KD_SZ(KD_NW) + lane_work;
    double *work = (double *)PyMem_Malloc(sizeof(double) * each * (size_t)count);
    if (work == NULL) { PyErr_NoMemory(); return -1; }
    npy_intp next = 0;
    for (int j = 0; j < count; ++j) {
        jobs[j] = *proto;
        jobs[j].begin = 0;
        jobs[j].end = k;
        jobs[j].next = &next;
        jobs[j].work = work + (size_t)j * each;
        jobs[j].lane_work = jobs[j].work + KD_SZ(KD_NW);
    }
    Py_BEGIN_ALLOW_THREADS
#if KD_HAVE_THREADS
    pthread_t ids[KD_MAX_THREADS];
    int started[KD_MAX_THREADS] = {0};
    for (int j = 1; j < count; ++j)
        started[j] = pthread_create(&ids[j], NULL, kd_batch_thread, &jobs[j]) == 0;
    kd_batch_rows(&jobs[0]);
    for (int j = 1; j < count; ++j) {
        if (started[j]) pthread_join(ids[j], NULL);
        else kd_batch_rows(&jobs[j]);  /* no thread: done here */
    }
#else
    for (int j = 0; j < count; ++j) kd_batch_rows(&jobs[j]);
#endif
    Py_END_ALLOW_THREADS
    PyMem_Free(work);
    return 0;
}

/* rhs_batch(t, Y, P=None, threads=None, lanes=None): Y (k, nx), t scalar or (k,),
   P (k, np) or None; threads: a positive int, or None for every CPU the
   process may use (never more threads than blocks of KD_MIN_ROWS_PER_THREAD rows);
   lanes: evaluate KD_W rows at once (None: where the module has the lane-wise code
   and the CPU its instructions; True: required; False: one row at a time). */
static PyObject *KdModel_rhs_batch(KdModel *self, PyObject *args, PyObject *kwds) {
    static char *kwlist[] = {"t", "Y", "P", "threads", "lanes", NULL};
    PyObject *tobj, *yobj, *pobj = Py_None, *threads_obj = Py_None, *lanes_obj = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OO|OOO:rhs_batch", kwlist, &tobj, &yobj,
                                     &pobj, &threads_obj, &lanes_obj))
        return NULL;
#if KD_LANES > 0
    int lanes = kd_lanes_usable();
    const char *no_lanes = "this CPU lacks the AVX2 and FMA instructions of the lane-wise code";
#else
    int lanes = 0;
    const char *no_lanes = "this model has no lane-wise code (dependent speeds, or generated "
                           "without it)";
#endif
    if (lanes_obj != Py_None) {
        int want = PyObject_IsTrue(lanes_obj);
        if (want < 0) return NULL;
        if (want && !lanes) {
            PyErr_Format(PyExc_ValueError, "lanes=True: %s", no_lanes);
            return NULL;
        }
        lanes = want;
    }
    long threads;
    if (threads_obj == Py_None) {
        threads = kd_available_cpus();
    } else {
        threads = PyLong_AsLong(threads_obj);
        if (threads == -1 && PyErr_Occurred()) return NULL;
        if (threads < 1) {
            PyErr_Format(PyExc_ValueError, "threads must be a positive integer or None, got %ld",
                         threads);
            return NULL;
        }
    }
    PyArrayObject *Y = (PyArrayObject *)PyArray_FROMANY(yobj, NPY_DOUBLE, 2, 2,
                                                         NPY_ARRAY_IN_ARRAY);
    if (Y == NULL) return NULL;
    npy_intp k = PyArray_DIM(Y, 0);
    if (PyArray_DIM(Y, 1) != KD_NX) {
        PyErr_Format(PyExc_ValueError, "Y must have shape (k, %d)", KD_NX);
        Py_DECREF(Y);
        return NULL;
    }
    PyArrayObject *T = (PyArrayObject *)PyArray_FROMANY(tobj, NPY_DOUBLE, 0, 1,
                                                         NPY_ARRAY_IN_ARRAY);
    if (T == NULL) { Py_DECREF(Y); return NULL; }
    int t_scalar = PyArray_NDIM(T) == 0;
    if (!t_scalar && PyArray_DIM(T, 0) != k) {
        PyErr_SetString(PyExc_ValueError, "t must be a scalar or have one entry per state");
        Py_DECREF(Y); Py_DECREF(T);
        return NULL;
    }
    PyArrayObject *P = NULL;
    if (pobj != Py_None) {
        P = (PyArrayObject *)PyArray_FROMANY(pobj, NPY_DOUBLE, 2, 2, NPY_ARRAY_IN_ARRAY);
        if (P == NULL) { Py_DECREF(Y); Py_DECREF(T); return NULL; }
        if (PyArray_DIM(P, 0) != k || PyArray_DIM(P, 1) != KD_NP) {
            PyErr_Format(PyExc_ValueError, "P must have shape (k, %d)", KD_NP);
            Py_DECREF(Y); Py_DECREF(T); Py_DECREF(P);
            return NULL;
        }
    }
    KdBatchJob proto = {0};
    proto.y = (const double *)PyArray_DATA(Y);
    proto.t = (const double *)PyArray_DATA(T);
    proto.P = P ? (const double *)PyArray_DATA(P) : NULL;
    proto.p = self->p;
    proto.t_scalar = t_scalar;
    proto.lanes = lanes;
    double *inputs = NULL;
    PyObject *result = kd_new_matrix(k, KD_NX, &proto.out);
    if (result != NULL && KD_NR > 0 && k > 0) {  /* the inputs first, with the GIL */
        inputs = (double *)PyMem_Malloc(sizeof(double) * KD_SZ(KD_NR) * (size_t)k);
        if (inputs == NULL) { PyErr_NoMemory(); Py_CLEAR(result); }
        for (npy_intp i = 0; result != NULL && i < k; ++i) {
            npy_intp dims[1] = {KD_NX};
            PyObject *row = PyArray_SimpleNewFromData(1, dims, NPY_DOUBLE,
                                                      (void *)(proto.y + i * KD_NX));
            int bad = row == NULL
                || kd_inputs(self, t_scalar ? proto.t[0] : proto.t[i], row,
                             inputs + i * KD_SZ(KD_NR)) != 0;
            Py_XDECREF(row);
            if (bad) Py_CLEAR(result);
        }
        proto.r = inputs;
    }
    if (result != NULL && k > 0) {
        npy_intp blocks = k / KD_MIN_ROWS_PER_THREAD;
        int count = (int)(threads < blocks ? threads : blocks);
        if (count > KD_MAX_THREADS) count = KD_MAX_THREADS;
        if (count < 1) count = 1;
#if !defined(__GNUC__)
        count = 1;  /* no atomic block counter */
#endif
        if (kd_batch_run(&proto, k, count) != 0) Py_CLEAR(result);
    }
    PyMem_Free(inputs);
    Py_DECREF(Y); Py_DECREF(T); Py_XDECREF(P);
    return result;
}

static PyObject *KdModel_set_parameters(KdModel *self, PyObject *const *args, Py_ssize_t nargs) {
    if (nargs != 1) {
        PyErr_SetString(PyExc_TypeError, "set_parameters(p) takes 1 argument");
        return NULL;
    }
    PyObject *keep = NULL;
    const double *p = kd_vector(args[0], KD_NP, &keep, "p");
    if (p == NULL) return NULL;
    for (int i = 0; i < KD_NP; ++i) self->p[i] = p[i];
    Py_XDECREF(keep);
    Py_RETURN_NONE;
}

/* -------------------------------------------- functions of (t, y, p, r) */
typedef struct { const double *y, *p, *r; PyObject *keep[3]; double t; double *work; } KdArgs;

static int kd_parse(PyObject *const *args, Py_ssize_t nargs, npy_intp nr, KdArgs *a) {
    a->keep[0] = a->keep[1] = a->keep[2] = NULL;
    a->work = NULL;
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError, "takes exactly 4 arguments (t, y, p, r)");
        return -1;
    }
    a->t = PyFloat_AsDouble(args[0]);
    if (a->t == -1.0 && PyErr_Occurred()) return -1;
    static const double empty[1] = {0.0};
    if ((a->y = kd_vector(args[1], KD_NX, &a->keep[0], "y")) == NULL) return -1;
    a->p = empty;
    a->r = empty;
    if (KD_NP > 0 && (a->p = kd_vector(args[2], KD_NP, &a->keep[1], "p")) == NULL) return -1;
    if (nr > 0 && (a->r = kd_vector(args[3], nr, &a->keep[2], "r")) == NULL) return -1;
    a->work = (double *)PyMem_Malloc(sizeof(double) * KD_SZ(KD_NW));
    if (a->work == NULL) { PyErr_NoMemory(); return -1; }
    return 0;
}

static void kd_release(KdArgs *a) {
    for (int i = 0; i < 3; ++i) Py_XDECREF(a->keep[i]);
    PyMem_Free(a->work);
}

/* The model's generated functions as module-level Python functions (the
   entries of its table, kd_module_create).  name(t, y, p, r): a tuple of the
   outputs (floats for shape (), else new arrays). */
static PyObject *kd_function_call(const KdFunction *fn, PyObject *const *args,
                                  Py_ssize_t nargs) {
    KdArgs a;
    if (kd_parse(args, nargs, fn->nr, &a) != 0) { kd_release(&a); return NULL; }
    PyObject *result = PyTuple_New(fn->n_outputs);
    if (result == NULL) { kd_release(&a); return NULL; }
    double *out[KD_MAX_OUTPUTS], scalar[KD_MAX_OUTPUTS];
    for (int k = 0; k < fn->n_outputs; ++k) {
        const long *shape = fn->shapes[k];
        if (shape[0] == 0) { out[k] = &scalar[k]; continue; }
        PyObject *array = shape[0] == 1 ? kd_new_vector(shape[1], &out[k])
                                        : kd_new_matrix(shape[1], shape[2], &out[k]);
        if (array == NULL) { Py_DECREF(result); kd_release(&a); return NULL; }
        PyTuple_SET_ITEM(result, k, array);
    }
    fn->call(a.t, a.y, a.p, a.r, a.work, out);
    kd_release(&a);
    for (int k = 0; k < fn->n_outputs; ++k) {
        if (fn->shapes[k][0] != 0) continue;
        PyObject *value = PyFloat_FromDouble(scalar[k]);
        if (value == NULL) { Py_DECREF(result); return NULL; }
        PyTuple_SET_ITEM(result, k, value);
    }
    return result;
}

/* name_rows(t, Y, p, R): the function at each of N points, t shape (N,), Y
   (N, n_x), R (N, nr); a tuple of arrays with the point axis first, (N, *shape)
   per output. */
static PyObject *kd_function_rows(const KdFunction *fn, PyObject *const *args,
                                  Py_ssize_t nargs) {
    if (nargs != 4) {
        PyErr_Format(PyExc_TypeError, "%s(t, Y, p, R) takes 4 arguments", fn->name);
        return NULL;
    }
    static const double empty[1] = {0.0};
    PyObject *keep = NULL, *result = NULL;
    double *work = NULL;
    PyArrayObject *T = (PyArrayObject *)PyArray_FROMANY(args[0], NPY_DOUBLE, 1, 1,
                                                        NPY_ARRAY_IN_ARRAY);
    PyArrayObject *Y = T == NULL ? NULL : (PyArrayObject *)PyArray_FROMANY(
        args[1], NPY_DOUBLE, 2, 2, NPY_ARRAY_IN_ARRAY);
    PyArrayObject *R = Y == NULL ? NULL : (PyArrayObject *)PyArray_FROMANY(
        args[3], NPY_DOUBLE, 2, 2, NPY_ARRAY_IN_ARRAY);
    if (R == NULL) goto done;
    npy_intp N = PyArray_DIM(T, 0);
    if (PyArray_DIM(Y, 0) != N || PyArray_DIM(Y, 1) != KD_NX || PyArray_DIM(R, 0) != N
            || PyArray_DIM(R, 1) != fn->nr) {
        PyErr_Format(PyExc_ValueError, "%s: t (N,), Y (N, %d) and R (N, %d) expected",
                     fn->name, (int)KD_NX, fn->nr);
        goto done;
    }
    const double *p = KD_NP > 0 ? kd_vector(args[2], KD_NP, &keep, "p") : empty;
    if (p == NULL) goto done;
    work = (double *)PyMem_Malloc(sizeof(double) * KD_SZ(KD_NW));
    if (work == NULL) { PyErr_NoMemory(); goto done; }
    result = PyTuple_New(fn->n_outputs);
    if (result == NULL) goto done;
    double *data[KD_MAX_OUTPUTS], *out[KD_MAX_OUTPUTS];
    npy_intp size[KD_MAX_OUTPUTS];
    for (int k = 0; k < fn->n_outputs; ++k) {
        const long *shape = fn->shapes[k];
        npy_intp dims[3] = {N, shape[1], shape[2]};
        size[k] = shape[0] == 0 ? 1 : shape[0] == 1 ? shape[1] : shape[1] * shape[2];
        PyObject *array = PyArray_SimpleNew(1 + shape[0], dims, NPY_DOUBLE);
        if (array == NULL) { Py_CLEAR(result); goto done; }
        PyTuple_SET_ITEM(result, k, array);
        data[k] = (double *)PyArray_DATA((PyArrayObject *)array);
    }
    const double *t = (const double *)PyArray_DATA(T), *y = (const double *)PyArray_DATA(Y);
    const double *r = (const double *)PyArray_DATA(R);
    for (npy_intp i = 0; i < N; ++i) {
        for (int k = 0; k < fn->n_outputs; ++k) out[k] = data[k] + i * size[k];
        fn->call(t[i], y + i * KD_NX, p, fn->nr > 0 ? r + i * fn->nr : empty, work, out);
    }
done:
    Py_XDECREF(T); Py_XDECREF(Y); Py_XDECREF(R); Py_XDECREF(keep);
    PyMem_Free(work);
    return result;
}

/* the module's exact derivatives, or NULL with a TypeError */
static const KdJacobianInfo *kd_module_jacobians(void) {
    const KdJacobianInfo *info = KD_JACOBIANS;
    if (info == NULL) PyErr_SetString(PyExc_TypeError, "this module has no exact derivatives");
    return info;
}

/* solved_jacobians(t, Y, p, R): the exact derivatives at each of N states (a
   module with the generated `jacobians`, KdJacobianInfo): t (N,), Y (N, n_x), R
   (N, nr); the tuple (F (N, n_x), D (N, n_x + m, columns), C (N, n_con, n_x)) of
   kd_jacobian_core; LinAlgError if the index-1 system is singular at a state */
static PyObject *kd_py_solved_jacobians(PyObject *self, PyObject *const *args,
                                        Py_ssize_t nargs) {
    (void)self;
    const KdJacobianInfo *info = kd_module_jacobians();
    if (info == NULL) return NULL;
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError, "solved_jacobians(t, Y, p, R) takes 4 arguments");
        return NULL;
    }
    static const double empty[1] = {0.0};
    PyObject *keep = NULL, *result = NULL, *F = NULL, *D = NULL, *C = NULL;
    double *work = NULL;
    PyArrayObject *T = (PyArrayObject *)PyArray_FROMANY(args[0], NPY_DOUBLE, 1, 1,
                                                        NPY_ARRAY_IN_ARRAY);
    PyArrayObject *Y = T == NULL ? NULL : (PyArrayObject *)PyArray_FROMANY(
        args[1], NPY_DOUBLE, 2, 2, NPY_ARRAY_IN_ARRAY);
    PyArrayObject *R = Y == NULL ? NULL : (PyArrayObject *)PyArray_FROMANY(
        args[3], NPY_DOUBLE, 2, 2, NPY_ARRAY_IN_ARRAY);
    if (R == NULL) goto done;
    const npy_intp N = PyArray_DIM(T, 0);
    if (PyArray_DIM(Y, 0) != N || PyArray_DIM(Y, 1) != KD_NX || PyArray_DIM(R, 0) != N
            || PyArray_DIM(R, 1) != KD_NR) {
        PyErr_Format(PyExc_ValueError, "solved_jacobians: t (N,), Y (N, %d) and R (N, %d) "
                     "expected", (int)KD_NX, (int)KD_NR);
        goto done;
    }
    const double *p = KD_NP > 0 ? kd_vector(args[2], KD_NP, &keep, "p") : empty;
    if (p == NULL) goto done;
    const npy_intp rows = KD_NX + KD_NUDEP, ncon = info->constraint_rows;
    npy_intp dims_f[2] = {N, KD_NX}, dims_d[3] = {N, rows, info->columns};
    npy_intp dims_c[3] = {N, ncon, KD_NX};
    F = PyArray_SimpleNew(2, dims_f, NPY_DOUBLE);
    D = F == NULL ? NULL : PyArray_SimpleNew(3, dims_d, NPY_DOUBLE);
    C = D == NULL ? NULL : PyArray_SimpleNew(3, dims_c, NPY_DOUBLE);
    work = (double *)PyMem_Malloc(sizeof(double) * (KD_SZ(KD_NW) + info->scratch));
    if (C == NULL || work == NULL) {
        if (C != NULL) PyErr_NoMemory();
        goto done;
    }
    const double *t = (const double *)PyArray_DATA(T), *y = (const double *)PyArray_DATA(Y);
    const double *r = (const double *)PyArray_DATA(R);
    double *f = (double *)PyArray_DATA((PyArrayObject *)F);
    double *d = (double *)PyArray_DATA((PyArrayObject *)D);
    double *c = (double *)PyArray_DATA((PyArrayObject *)C);
    npy_intp bad = -1;
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < N && bad < 0; ++i) {
        if (info->core(t[i], y + i * KD_NX, p, KD_NR > 0 ? r + i * KD_NR : empty, work,
                       work + KD_SZ(KD_NW), f + i * KD_NX, d + i * rows * info->columns,
                       c + i * ncon * KD_NX) != 0)
            bad = i;
    }
    Py_END_ALLOW_THREADS
    if (bad >= 0) {
        PyErr_Format(kd_linalg_error, "singular matrix in the equations of motion (state "
                     "row %zd)", (Py_ssize_t)bad);
        goto done;
    }
    result = PyTuple_Pack(3, F, D, C);
done:
    Py_XDECREF(T); Py_XDECREF(Y); Py_XDECREF(R); Py_XDECREF(keep);
    Py_XDECREF(F); Py_XDECREF(D); Py_XDECREF(C);
    PyMem_Free(work);
    return result;
}

/* solved_jacobian(cls, members, fixed, p, r, t, y): the exact derivatives at one
   state as a new instance of `cls` (NumericModel.jacobians without checks), a
   class with slots: `members` its member descriptors (one per field), the
   first 8 those of f, C, then the blocks of D (the rows of f, then those of
   the multipliers, each in the columns of the state, the inputs and the
   constants), `fixed` a tuple of the values of every field, taken where this
   function does not make one: the fields after the 8, C without constraints
   and the inputs' block without inputs (empty arrays, read-only).  The blocks
   are arrays of their own or None (the constants where none are generated;
   the multipliers without dependent speeds).  p a vector; t a number, r and y
   arrays of n_r and n_x doubles, exactly: None for anything else, which the
   caller then checks and converts.  LinAlgError if singular.

   A call whose work fits in KD_POINT_WORK_MAX doubles keeps the GIL (its work,
   a few microseconds, is shorter than handing the GIL over) and works in a
   buffer the module keeps (kd_point_work, guarded by the GIL) instead of one
   allocated per call; without inputs, constants or multipliers the solve runs
   in place in the state's array (the derivative block is all of D). */
#ifdef Py_GIL_DISABLED  /* no GIL to guard a shared buffer: one per call */
#define KD_POINT_WORK_MAX 0
#else
#define KD_POINT_WORK_MAX 32768
#endif
#define KD_POINT_IN_PLACE 1
static double *kd_point_work = NULL;
static size_t kd_point_capacity = 0;

/* whether `members` are object slots of `cls`, as many as `fixed` holds, at least 8 */
static int kd_slots_of(PyObject *cls, PyObject *members, PyObject *fixed) {
    if (!PyTuple_Check(members) || !PyTuple_Check(fixed)
            || PyTuple_GET_SIZE(members) != PyTuple_GET_SIZE(fixed)
            || PyTuple_GET_SIZE(members) < 8) return 0;
    for (Py_ssize_t k = 0; k < PyTuple_GET_SIZE(members); ++k) {
        PyObject *m = PyTuple_GET_ITEM(members, k);
        if (!Py_IS_TYPE(m, &PyMemberDescr_Type)
                || ((PyDescrObject *)m)->d_type != (PyTypeObject *)cls
                || ((PyMemberDescrObject *)m)->d_member->type != T_OBJECT_EX) return 0;
    }
    return 1;
}

static PyObject *kd_py_solved_jacobian(PyObject *self, PyObject *const *args,
                                       Py_ssize_t nargs) {
    (void)self;
    const KdJacobianInfo *info = kd_module_jacobians();
    if (info == NULL) return NULL;
    if (nargs != 7 || !PyType_Check(args[0]) || !kd_slots_of(args[0], args[1], args[2])) {
        PyErr_SetString(PyExc_TypeError, "solved_jacobian(cls, members, fixed, p, r, t, y): "
                        "a class with slots, its member descriptors and a value for each, "
                        "then the arguments");
        return NULL;
    }
    const double *y = kd_in_place(args[6], KD_NX);
    if (y == NULL || !(PyFloat_Check(args[5]) || PyLong_CheckExact(args[5])))
        Py_RETURN_NONE;
    const double t = PyFloat_AsDouble(args[5]);
    if (t == -1.0 && PyErr_Occurred()) return NULL;
    static const double empty[1] = {0.0};
    const double *r = kd_in_place(args[4], KD_NR);  /* no inputs: an empty array */
    if (r == NULL) Py_RETURN_NONE;
    if (KD_NR == 0) r = empty;
    PyObject *keep[2] = {NULL, NULL}, *values[8] = {NULL}, *result = NULL;
    double *work = NULL, *D = NULL, *f = NULL, *C = NULL, *out[6] = {NULL};
    const double *p = KD_NP > 0 ? kd_vector(args[3], KD_NP, &keep[0], "p") : empty;
    if (p == NULL) goto done;
    const int rows = KD_NX + KD_NUDEP, columns = info->columns;
    const int widths[3] = {KD_NX, KD_NR, columns - KD_NX - KD_NR};
    const int whole = KD_POINT_IN_PLACE && rows == KD_NX && columns == KD_NX;  /* D: the state's block */
    const size_t size = (size_t)KD_SZ(KD_NW) + info->scratch + (whole ? 0 : rows * columns);
    const int keep_gil = size <= KD_POINT_WORK_MAX;
    /* every array first: allocating may run Python code (a collection's
       finalizers), which may call this function and move kd_point_work */
    if ((values[0] = kd_new_vector(KD_NX, &f)) == NULL
            || (info->constraint_rows > 0  /* else the empty array of `fields` */
                && (values[1] = kd_new_matrix(info->constraint_rows, KD_NX, &C)) == NULL))
        goto done;
    for (int b = 0; b < 6; ++b) {
        const int group = b % 3, height = b < 3 ? KD_NX : KD_NUDEP;
        if ((group == 2 && widths[2] == 0) || (b >= 3 && KD_NUDEP == 0)) {
            Py_INCREF(Py_None);
            values[2 + b] = Py_None;
            continue;
        }
        if (b == 1 && widths[1] == 0) continue;  /* no inputs: the empty array of `fields` */
        if ((values[2 + b] = kd_new_matrix(height, widths[group], &out[b])) == NULL)
            goto done;
    }
    if (keep_gil) {
        if (kd_point_capacity < size) {
            double *grown = (double *)PyMem_Realloc(kd_point_work, sizeof(double) * size);
            if (grown == NULL) {
                PyErr_NoMemory();
                goto done;
            }
            kd_point_work = grown;
            kd_point_capacity = size;
        }
        work = kd_point_work;
    } else if ((work = (double *)PyMem_Malloc(sizeof(double) * size)) == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    D = whole ? out[0] : work + KD_SZ(KD_NW) + info->scratch;
    if (C == NULL) C = D;  /* no constraint rows: nothing is written there */
    int bad;
    if (keep_gil) {
        bad = info->core(t, y, p, r, work, work + KD_SZ(KD_NW), f, D, C);
    } else {
        Py_BEGIN_ALLOW_THREADS
        bad = info->core(t, y, p, r, work, work + KD_SZ(KD_NW), f, D, C);
        Py_END_ALLOW_THREADS
    }
    if (bad) {
        PyErr_SetString(kd_linalg_error, "singular matrix in the equations of motion");
        goto done;
    }
    for (int b = whole; b < 6; ++b) {  /* the state's block: D itself where whole */
        if (out[b] == NULL) continue;
        const int group = b % 3, first = b < 3 ? 0 : KD_NX, height = b < 3 ? KD_NX : KD_NUDEP;
        const int at = group == 0 ? 0 : group == 1 ? KD_NX : KD_NX + KD_NR;
        for (int i = 0; i < height; ++i)
            memcpy(out[b] + i * widths[group], D + (first + i) * columns + at,
                   sizeof(double) * widths[group]);
    }
    PyTypeObject *cls = (PyTypeObject *)args[0];
    if ((result = cls->tp_alloc(cls, 0)) == NULL) goto done;  /* object.__new__(cls) */
    for (Py_ssize_t k = 0; k < PyTuple_GET_SIZE(args[1]); ++k) {
        PyObject *value = k < 8 && values[k] != NULL ? values[k] : PyTuple_GET_ITEM(args[2], k);
        PyObject **slot = (PyObject **)((char *)result
            + ((PyMemberDescrObject *)PyTuple_GET_ITEM(args[1], k))->d_member->offset);
        Py_INCREF(value);
        Py_XSETREF(*slot, value);
    }
done:
    for (int k = 0; k < 8; ++k) Py_XDECREF(values[k]);
    Py_XDECREF(keep[0]); Py_XDECREF(keep[1]);
    if (work != kd_point_work) PyMem_Free(work);
    return result;
}

/* entry k of the table: plain module-level functions (their `self` the
   module), one per table entry */
static const KdFunction *kd_table = NULL;
#define KD_ENTRY(k) \
    static PyObject *kd_py_function##k(PyObject *self, PyObject *const *args, \
                                       Py_ssize_t nargs) { \
        (void)self; \
        KD_USE_START \
        PyObject *result = kd_table[k].rows ? kd_function_rows(&kd_table[k], args, nargs) \
                                            : kd_function_call(&kd_table[k], args, nargs); \
        KD_USE_END \
        return result; \
    }
@ENTRIES@
static PyObject *(*const kd_entries[KD_MAX_FUNCTIONS])(PyObject *, PyObject *const *,
                                                       Py_ssize_t) = {@ENTRY_LIST@};
"""


#: ``inverse_point(t, q, u, udot, p)``: inverse dynamics at one point of a model
#: without dependent coordinates or speeds and without specified inputs, for
#: exact float64 1-D arrays of finite entries (None for anything else: the
#: caller then takes the general way, which checks and reports); part of the
#: generic runtime of such a module (``KD_INVERSE_POINT``)
INVERSE_POINT = r"""
static const double *kd_plain_vector(PyObject *obj, npy_intp n) {
    const double *x = kd_in_place(obj, n);  /* with finite entries only */
    for (npy_intp i = 0; x != NULL && i < n; ++i) if (!isfinite(x[i])) return NULL;
    return x;
}

static PyObject *kd_py_inverse_point(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    if (nargs != 5) {
        PyErr_SetString(PyExc_TypeError, "inverse_point(t, q, u, udot, p) takes 5 arguments");
        return NULL;
    }
    PyObject *t_obj = args[0];
    if (PyBool_Check(t_obj) || !(PyFloat_Check(t_obj) || PyLong_Check(t_obj)
                                 || PyArray_IsScalar(t_obj, Floating)
                                 || PyArray_IsScalar(t_obj, Integer))) Py_RETURN_NONE;
    double t = PyFloat_AsDouble(t_obj);
    if (t == -1.0 && PyErr_Occurred()) { PyErr_Clear(); Py_RETURN_NONE; }
    const double *q = kd_plain_vector(args[1], KD_NQ), *u = kd_plain_vector(args[2], KD_NU);
    const double *udot = kd_plain_vector(args[3], KD_NU);
    if (!isfinite(t) || q == NULL || u == NULL || udot == NULL) Py_RETURN_NONE;
    PyObject *keep = NULL;
    static const double empty[1] = {0.0};
    const double *p = KD_NP > 0 ? kd_vector(args[4], KD_NP, &keep, "p") : empty;
    if (p == NULL) return NULL;
    double y[KD_SZ(KD_NX)];
    memcpy(y, q, sizeof(double) * KD_NQ);
    memcpy(y + KD_NQ, u, sizeof(double) * KD_NU);
    double *work = (double *)PyMem_Malloc(sizeof(double) * KD_SZ(KD_NW)), *tau;
    PyObject *result = work == NULL ? PyErr_NoMemory() : kd_new_vector(KD_NU, &tau);
    if (result != NULL) kd_eval_inverse(t, y, p, udot, work, tau);
    PyMem_Free(work);
    Py_XDECREF(keep);
    return result;
}
"""

#: what the two runtime units of a module share (after the sizes and the lane
#: definitions; no Python): the model's table of functions, which the generic
#: unit turns into Python functions, and the calls of each into the other
#: (``KD_GEN``: static in a one-unit source, hidden across the units of one
#: module otherwise)
SHARED = r"""
#define KD_MAX_OUTPUTS @MAX_OUTPUTS@
#define KD_MAX_FUNCTIONS @MAX_FUNCTIONS@
/* a generated function with its outputs given as an array of pointers */
typedef void (*KdCall)(double t, const double *y, const double *p, const double *r,
                       double *w, double *const *out);
typedef struct {
    const char *name;     /* its Python name */
    KdCall call;
    int n_outputs;        /* at most KD_MAX_OUTPUTS */
    int nr;               /* run-time inputs r it takes */
    int rows;             /* 1: evaluated at every point of a trajectory (name_rows) */
    const long (*shapes)[3];  /* per output: dimensions (0, 1 or 2), then the sizes */
} KdFunction;
KD_GEN int kd_lu_solve(int n, double *A, double *B, int nrhs);
KD_GEN int kd_rhs_core(double t, const double *y, const double *p, const double *r,
                       double *w, double *out);
#if KD_LANES > 0
KD_LANES_FN KD_GEN void kd_lanes_rows(const double *t, int t_scalar, const double *y,
                                      const double *P, const double *p, const double *r,
                                      double *out, double *restrict lw, double *w);
#endif
/* the exact derivatives of a module with the generated `jacobians`
   (JACOBIAN_SOLVE): the state derivative f (n_x), the derivatives D ((n_x + m) x
   columns: rows of f, then of the multipliers; columns: state, inputs, and the
   constants when generated) and the constraint rows C (n_con x n_x), with
   `scratch` doubles of work; 0, or 1 if the index-1 system is singular */
typedef int (*KdJacobianCore)(double t, const double *y, const double *p, const double *r,
                              double *w, double *scratch, double *f, double *D, double *C);
typedef struct {
    KdJacobianCore core;
    int columns, constraint_rows;
    long scratch;
} KdJacobianInfo;
/* the module named `name` with the functions of `table` (ended by a NULL name);
   `jacobians`: NULL, or the module's exact derivatives */
KD_GEN void *kd_module_create(const char *name, const KdFunction *table,
                              const KdJacobianInfo *jacobians);
"""

#: outputs of one generated function and functions of one module the runtime
#: takes (``KD_MAX_OUTPUTS``, ``KD_MAX_FUNCTIONS``)
MAX_OUTPUTS = 16
MAX_FUNCTIONS = 16
SHARED = SHARED.replace("@MAX_OUTPUTS@", str(MAX_OUTPUTS)).replace(
    "@MAX_FUNCTIONS@", str(MAX_FUNCTIONS))
PYTHON_GLUE = PYTHON_GLUE.replace(
    "@ENTRIES@", "\n".join(f"KD_ENTRY({k})" for k in range(MAX_FUNCTIONS))).replace(
    "@ENTRY_LIST@", ", ".join(f"kd_py_function{k}" for k in range(MAX_FUNCTIONS)))

#: the generic runtime: what the model's sizes (run-time constants in its own
#: unit) parametrize only (entry points of the Model type, batches, the
#: integrator; the contact loop with contacts)
RUNTIME = RUNTIME_ERRORS + LU_SOLVE + TABLE_INPUTS + PYTHON_GLUE

#: end of the generic runtime: the Model type and the module's creation
RUNTIME_FOOTER = r"""
KD_TIMED(KdModel_rhs, KD_FAST(KdModel), (self, args, nargs))
KD_TIMED(KdModel_rhs_batch, KD_KEYWORDS(KdModel), (self, args, kwds))
KD_TIMED(KdModel_integrate, KD_ARGS(KdModel), (self, args))
KD_TIMED(KdModel_integrate_many, KD_ARGS(KdModel), (self, args))
KD_TIMED(kd_py_solved_jacobians, KD_FAST(PyObject), (self, args, nargs))
KD_TIMED(kd_py_solved_jacobian, KD_FAST(PyObject), (self, args, nargs))
#ifdef KD_NC
KD_TIMED(kd_py_contact_segment, KD_ARGS(PyObject), (self, args))
#endif
#ifdef KD_INVERSE_POINT
KD_TIMED(kd_py_inverse_point, KD_FAST(PyObject), (self, args, nargs))
#endif

static PyMethodDef KdModel_methods[] = {
    {"rhs", (PyCFunction)(void (*)(void))KD_METHOD(KdModel_rhs), METH_FASTCALL,
     "rhs(t, y): the state derivative (a new array)"},
    {"rhs_batch", (PyCFunction)(void (*)(void))KD_METHOD(KdModel_rhs_batch),
     METH_VARARGS | METH_KEYWORDS,
     "rhs_batch(t, Y, P=None, threads=None, lanes=None): state derivatives of many states "
     "(rows of Y), on `threads` threads (None: every CPU the process may use), several "
     "rows at once in SIMD lanes unless lanes=False"},
    {"set_parameters", (PyCFunction)(void (*)(void))KdModel_set_parameters, METH_FASTCALL,
     "set_parameters(p): replace the constants"},
    {"integrate", (PyCFunction)KD_METHOD(KdModel_integrate), METH_VARARGS,
     "integrate(t0, t1, y0, t_eval, rtol, atol, max_step, first_step, method, events, "
     "project_tol, dense): the compiled integration loop"},
    {"integrate_many", (PyCFunction)KD_METHOD(KdModel_integrate_many), METH_VARARGS,
     "integrate_many(t0, t1, Y0, P, r_times, R, t_eval, rtol, atol, max_step, first_step, "
     "project_tol, threads, stop, timeout): many trajectories of RK45 in threads"},
    {NULL, NULL, 0, NULL}
};

static PyTypeObject KdModelType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "kanedyn_generated.Model",
    .tp_basicsize = sizeof(KdModel),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_new = KdModel_new,
    .tp_init = (initproc)KdModel_init,
    .tp_dealloc = (destructor)KdModel_dealloc,
    .tp_methods = KdModel_methods,
};

/* what another module of the same model takes over (kd_py_adopt): its code and
   the sizes that must agree */
typedef struct {
    const char *name;  /* the module's name: the hash of what it computes */
    KdRhsCore rhs;
    const KdFunction *table;
    int nx, np, nr, nw, functions;
    const KdJacobianInfo *jacobians;  /* its exact derivatives, or NULL */
} KdEntry;
static KdEntry kd_entry;

/* _adopt(entry): call the code of another module of the same model (its `_entry`)
   from now on */
static PyObject *kd_py_adopt(PyObject *self, PyObject *capsule) {
    (void)self;
    const KdEntry *other = (const KdEntry *)PyCapsule_GetPointer(capsule, "kanedyn.entry");
    if (other == NULL) return NULL;
    if (strcmp(other->name, kd_entry.name) != 0 || other->nx != kd_entry.nx
            || other->np != kd_entry.np || other->nr != kd_entry.nr
            || other->nw != kd_entry.nw || other->functions != kd_entry.functions) {
        PyErr_SetString(PyExc_ValueError, "_adopt: the entry is another model's");
        return NULL;
    }
#if defined(__GNUC__)
    __atomic_store_n(&kd_rhs_now, other->rhs, __ATOMIC_RELEASE);
    __atomic_store_n(&kd_table, other->table, __ATOMIC_RELEASE);
    __atomic_store_n(&kd_jacobians, other->jacobians, __ATOMIC_RELEASE);
#else
    kd_rhs_now = other->rhs;
    kd_table = other->table;
    kd_jacobians = other->jacobians;
#endif
    Py_RETURN_NONE;
}

static PyMethodDef kd_runtime_functions[] = {
#ifdef KD_NC
    {"contact_segment", (PyCFunction)KD_METHOD(kd_py_contact_segment), METH_VARARGS, NULL},
#endif
    {"_adopt", (PyCFunction)kd_py_adopt, METH_O, NULL},
#ifdef __TINYC__
    {"_quick_use", (PyCFunction)kd_py_quick_use, METH_NOARGS, NULL},
#endif
    {"solved_jacobians", (PyCFunction)(void (*)(void))KD_METHOD(kd_py_solved_jacobians),
     METH_FASTCALL, NULL},
    {"solved_jacobian", (PyCFunction)(void (*)(void))KD_METHOD(kd_py_solved_jacobian),
     METH_FASTCALL, NULL},
#ifdef KD_INVERSE_POINT
    {"inverse_point", (PyCFunction)(void (*)(void))KD_METHOD(kd_py_inverse_point),
     METH_FASTCALL, NULL},
#endif
    {NULL, NULL, 0, NULL}
};

static struct PyModuleDef kd_module = {PyModuleDef_HEAD_INIT, NULL, NULL, -1, NULL};
static PyMethodDef kd_table_methods[KD_MAX_FUNCTIONS + 1];

/* the functions of the model's `table` (at most KD_MAX_FUNCTIONS) added to
   `module` */
static int kd_add_functions(PyObject *module, const KdFunction *table) {
    int count = 0;
    while (table[count].name != NULL) count++;
    if (count > KD_MAX_FUNCTIONS) {
        PyErr_SetString(PyExc_ImportError, "more generated functions than the runtime takes");
        return -1;
    }
    kd_table = table;
    kd_entry = (KdEntry){kd_entry.name, kd_rhs_core, table, KD_NX, KD_NP, KD_NR, KD_NW,
                         count, kd_jacobians};
    for (int k = 0; k < count; ++k) {
        kd_table_methods[k].ml_name = table[k].name;
        kd_table_methods[k].ml_meth = (PyCFunction)(void (*)(void))kd_entries[k];
        kd_table_methods[k].ml_flags = METH_FASTCALL;
    }
    return PyModule_AddFunctions(module, kd_table_methods);
}

/* the module `name` with the Model type, the functions of this runtime and those
   of the model's `table` */
KD_GEN void *kd_module_create(const char *name, const KdFunction *table,
                              const KdJacobianInfo *jacobians) {
    import_array();
    kd_jacobians = jacobians;
    if (PyType_Ready(&KdModelType) < 0) return NULL;
    kd_module.m_name = name;
    kd_entry.name = name;
    kd_module.m_methods = kd_runtime_functions;
    PyObject *module = PyModule_Create(&kd_module);
    if (module == NULL) return NULL;
    if (kd_add_functions(module, table) < 0) {
        Py_DECREF(module);
        return NULL;
    }
    PyObject *entry = PyCapsule_New(&kd_entry, "kanedyn.entry", NULL);
    if (entry == NULL || PyModule_AddObject(module, "_entry", entry) < 0) {
        Py_XDECREF(entry);
        Py_DECREF(module);
        return NULL;
    }
    Py_INCREF(&KdModelType);
    if (PyModule_AddObject(module, "Model", (PyObject *)&KdModelType) < 0) {
        Py_DECREF(&KdModelType);
        Py_DECREF(module);
        return NULL;
    }
    PyObject *linalg = PyImport_ImportModule("numpy.linalg");
    if (linalg == NULL) { Py_DECREF(module); return NULL; }
    kd_linalg_error = PyObject_GetAttrString(linalg, "LinAlgError");
    Py_DECREF(linalg);
    if (kd_linalg_error == NULL) { Py_DECREF(module); return NULL; }
    return module;
}
"""

#: end of the model's unit, after its table of functions ``kd_function_table``:
#: the module's entry point (without Python's headers: a function returning the
#: new module, visible outside the module's file)
MODULE_FOOTER = r"""
#ifndef KD_JACOBIAN_INFO
#define KD_JACOBIAN_INFO NULL
#endif
#if defined(__GNUC__)
__attribute__((visibility("default")))
#endif
void *KD_INIT_FUNCTION(void) {
    return kd_module_create(KD_MODULE_NAME_STR, kd_function_table, KD_JACOBIAN_INFO);
}
"""
