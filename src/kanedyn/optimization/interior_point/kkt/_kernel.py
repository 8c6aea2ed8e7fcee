"""The C kernel of :class:`~._sparse.SparseKKT`: its source and its module.

One fixed source (no generated part), compiled once and cached like the
models' modules (``load_fixed_module`` of :mod:`kanedyn.numerics`), loaded on the
first :class:`~._sparse.SparseKKT`.  Its functions take their arrays
through the buffer protocol (C-contiguous, ``float64`` values, ``int32``
indices and column pointers, so at most 2^31 - 2 entries in ``K`` and in
``L``; the caller makes them so) and release the GIL while they compute:

``symbolic(parent, column_counts, Ap, Ai, pair)``
    the elimination tree and the number of entries of each column of ``L``
    (``int32``; their sum is the caller's to check) from the pattern of the
    permuted upper triangle ``Ap, Ai`` (CSC), the two columns of a 2 x 2 pivot
    given the same rows.
``factor(Ax, Lp, Li, Lx, D, E, Ap, Ai, parent, pair, hessian_map, hessian_values,
jacobian_map, jacobian_values, diagonal_map, diagonal_x, diagonal_x_index,
diagonal_c, zero, tolerance, n, x_constant, x_added, c_constant)``
    scatters the values into ``Ax`` through the maps, factors ``A = L D Lᵀ``
    up-looking (row ``k`` of ``L`` by a sparse triangular solve on the
    elimination tree; ``D`` block diagonal, ``E`` the off-diagonal entries of
    its 2 x 2 blocks, ``pair`` the kind of each pivot), returns
    ``(n_positive, n_negative, n_zero)`` and sets ``zero[k]`` (``int8``, N) to
    1 where the pivot ``k`` was zero (both rows of a 2 x 2 block), else 0.
    K's diagonal beside H's entries: ``diagonal_x`` (n entries, or none for
    ``x_constant`` on each, or those of the increasing entries
    ``diagonal_x_index`` (int32; none: no index), ``x_constant`` on the
    others) plus ``x_added`` where that is not 0 (the sums as NumPy's
    ``diagonal_x + x_added``); below it ``-diagonal_c`` (N - n entries, or
    none for ``c_constant`` on each).  So a constant diagonal, the interior
    point's regularization, or its barrier's (on the bounded variables)
    needs no array of every variable's.
``solve(x, Lp, Li, Lx, D, E, pair, permutation, k)``
    overwrites the ``k`` right-hand sides in ``x`` (``k`` rows of length N,
    in the original order) with the solutions.

``factor`` and ``solve`` allocate their scratch (5 N and N doubles) for the
call, so that it is not held between factorizations (40 and 8 bytes a row of K);
``zero`` is the caller's, allocated once with the factor.  Every function's
scratch and result of 4 MiB or more is an anonymous mapping of its own,
handed back to the system when freed (``mmap``; ``malloc`` below that, and
everywhere off POSIX): glibc serves a freed block of a few MB again from its
heap once its mmap threshold has risen past that size, and a heap shrinks
only from its top, so such blocks stayed resident under later arrays
(``optimization/interior_point/_mapped.py`` does the same for NumPy's
arrays).  Results are buffers that ``numpy.frombuffer`` reads.

The envelope storage of :class:`~._envelope.EnvelopeKKT` (L by rows,
every column from a row's first entry, values only):

An index argument (the patterns' rows and columns below) is an int32 array
or the ``(runs, table)`` of a :class:`~._periodic.PeriodicIndex`
(:func:`~._periodic.kernel_index`), whose entries are walked in the array's
order without it being made.

``envelope(rowptr, inverse, pair, hessian_rows, hessian_cols, jacobian_rows,
jacobian_cols, n)``
    the envelope's row pointers (int32) of K's lower triangle in the order
    (``inverse``: the place of each row of K); returns the envelope's size
    and K's distinct entries off the diagonal.
``envelope_factor(Lx, rowptr, D, pair, permutation, hessian_values,
jacobian_values, diagonal_x, diagonal_x_index, diagonal_c, zero, hessian_rows,
hessian_cols, jacobian_rows, jacobian_cols, tolerance, n, x_constant, x_added,
c_constant)``
    the values summed into the envelope (as ``factor`` sums them) and
    factored in place, the pivots judged as ``factor`` judges them; returns
    ``(n_positive, n_negative, n_zero, largest)``.  Scratch: a double (each
    column's largest magnitude below the diagonal) and the order's inverse
    (an int32) a row.
``envelope_solve(x, rowptr, Lx, D, pair, permutation, k)``
    ``solve`` with those factors, in ``x``'s storage through the order (no
    scratch).
``structured_matvec(y, x, hessian_values, jacobian_values, diagonal_x,
diagonal_x_index, diagonal_c, hessian_rows, hessian_cols, jacobian_rows,
jacobian_cols, n, x_constant, x_added, c_constant)``
    ``y = K x`` from the structures and values (K's own order; the diagonals
    as ``factor`` takes them).
``transpose_product(out, values, y, rows, cols)``
    ``out = Jᵀ y`` of the entries ``(rows, cols, values)`` (checked to lie
    in the matrix), summed
    entry by entry in their order, as SciPy's product of a COO matrix sums
    them.
``matvec(y, x, Ap, Ai, Ax, permutation)``
    ``y = K x`` from the stored (permuted, upper) values.
``invalid(a_0, ..., a_k, nonnegative)``
    the first entry of the ``float64`` arrays ``a_0, ..., a_k`` that is not
    finite (the arrays in turn), else the first that is negative in
    ``a_nonnegative, ..., a_k``: ``(array, entry)``, or ``None`` when there is
    none (the checks of ``factor``'s and ``solve``'s arguments in one call,
    in place of NumPy's ``isfinite``, ``all`` and ``min`` on each).
``error_reductions(dual, c, y, z_lower, z_upper, gap_lower, gap_upper, mu)``
    the sums and maxima of the interior point's optimality error, the numbers
    of :func:`~.._optimality.numpy_error_reductions` to the last bit (the sums
    by NumPy's pairwise summation, the maxima from 0.0, a NaN kept): 20 NumPy
    calls in one.

Three more make the analysis's patterns in int32 (the NumPy and SciPy
construction they replace, through ``int64`` copies and COO conversions,
held 2.9 KiB a node of temporaries on the 100,000-node swing-up); ``csr``
and ``compressed`` hold nothing beyond their result, whose indices' storage
holds the entries before their repeats are merged:

``csr(n_rows, n_cols, symmetric, part[, part])``
    the CSR pattern of the entries ``(rows + row_offset, cols)`` of one or two
    parts, each a tuple ``(rows, cols, row_offset[, mask])`` (index
    arguments; the entries where the boolean ``mask`` is true, all where it is
    ``None`` or absent), with ``symmetric`` their mirror images too, repeats
    merged, each row's columns increasing (SciPy's canonical form), as two
    buffers of int32 ``(indptr, indices)`` (``numpy.frombuffer`` reads them).
``compressed(node, n_nodes, part[, part])``
    the same (symmetric) of the graph that joins ``node[i]`` and ``node[j]``
    for each entry ``(i, j)`` of the parts where both are ``>= 0`` and
    differ (the pairs' graph of :func:`~._ordering.elimination_order`, made
    from K's entries without K's own pattern).
``permuted(Ap, hessian_map, jacobian_map, diagonal_map, inverse, hessian_rows,
hessian_cols, jacobian_rows, jacobian_cols, n)``
    K's upper triangle in the elimination order as CSC: fills ``Ap`` and the
    maps of every entry to its place, returns the row indices as a buffer
    of int32.

And one orders that graph:

``cuthill_mckee(order, indptr, indices, start)``
    fills ``order`` (int32) with Cuthill-McKee's order of a symmetric
    pattern, each component from a pseudo-peripheral node (George and Liu's
    search), or from ``start`` for its own; new neighbours by increasing
    degree (:func:`~._ordering.reverse_cuthill_mckee`).  Scratch: 12 bytes a
    node.
"""

from __future__ import annotations

from ....numerics import load_fixed_module
from .._mapped import MAPPED_BYTES

__all__ = ["kernel", "SOURCE"]

#: changes whenever the source's meaning changes (part of the cache key)
_GENERATION = "kanedyn sparse LDL 36"

SOURCE = r"""
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#if defined(__unix__) || defined(__APPLE__)
#include <sys/mman.h>
#include <unistd.h>
#define KD_MMAP 1
#endif

/* scratch and results of KD_MAPPED bytes or more each in an anonymous mapping of
   its own, handed back to the system when freed (glibc serves a freed block of
   a few MB again from its heap once its mmap threshold has risen past that
   size, and holds it resident while anything above it in the heap lives);
   smaller ones from malloc.  kd_unscratch takes the size kd_scratch was given. */
#define KD_MAPPED ((size_t)@MAPPED@)

static void *kd_scratch(size_t size, int zero) {
    if (size == 0) size = 1;
#ifdef KD_MMAP
    if (size >= KD_MAPPED) {
        void *p = mmap(NULL, size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (p == MAP_FAILED) return NULL;
#ifdef MADV_HUGEPAGE
        madvise(p, size, MADV_HUGEPAGE);
#endif
        return p;  /* zero */
    }
#endif
    return zero ? calloc(size, 1) : malloc(size);
}

static void kd_unscratch(void *p, size_t size) {
    if (p == NULL) return;
    if (size == 0) size = 1;
#ifdef KD_MMAP
    if (size >= KD_MAPPED) {
        munmap(p, size);
        return;
    }
#endif
    free(p);
}

/* a result's storage (kd_scratch's), read by NumPy through the buffer
   protocol (numpy.frombuffer); `length` bytes of `held` */
typedef struct {
    PyObject_HEAD
    char *data;
    Py_ssize_t length;
    size_t held;
} kd_buffer;

static int kd_buffer_view(PyObject *self, Py_buffer *view, int flags) {
    kd_buffer *b = (kd_buffer *)self;
    return PyBuffer_FillInfo(view, self, b->data, b->length, 0, flags);
}

static void kd_buffer_dealloc(PyObject *self) {
    kd_buffer *b = (kd_buffer *)self;
    kd_unscratch(b->data, b->held);
    Py_TYPE(self)->tp_free(self);
}

static PyBufferProcs kd_buffer_procs = {kd_buffer_view, NULL};

static PyTypeObject kd_buffer_type = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "kanedyn_kkt_buffer",
    .tp_basicsize = sizeof(kd_buffer),
    .tp_dealloc = kd_buffer_dealloc,
    .tp_as_buffer = &kd_buffer_procs,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "a kernel result's storage (a buffer of bytes)",
};

/* a new buffer of `length` bytes (NULL with the error set) */
static PyObject *kd_buffer_new(Py_ssize_t length) {
    kd_buffer *b = PyObject_New(kd_buffer, &kd_buffer_type);
    if (b == NULL) return NULL;
    b->held = (size_t)(length > 0 ? length : 1);
    b->length = length;
    b->data = kd_scratch(b->held, 0);
    if (b->data == NULL) {
        b->held = 0;
        Py_DECREF(b);
        return PyErr_NoMemory();
    }
    return (PyObject *)b;
}

/* a buffer's first `length` bytes kept, the rest handed back where it is its
   own (a mapping's whole pages past them, or a copy made smaller): before
   anything reads it */
static void kd_buffer_shrink(PyObject *self, Py_ssize_t length) {
    kd_buffer *b = (kd_buffer *)self;
    size_t want = (size_t)(length > 0 ? length : 1);
    b->length = length;
    if (b->held >= KD_MAPPED) {
#ifdef KD_MMAP
        size_t page = (size_t)sysconf(_SC_PAGESIZE), keep = (want + page - 1) / page * page;
        if (keep < KD_MAPPED) keep = KD_MAPPED;  /* freed as a mapping: one still */
        if (keep < b->held) {
            munmap(b->data + keep, b->held - keep);
            b->held = keep;
        }
#endif
    } else if (want < b->held) {
        char *smaller = realloc(b->data, want);
        if (smaller != NULL) {
            b->data = smaller;
            b->held = want;
        }
    }
}

/* a buffer of `count` items of `size` bytes, C-contiguous */
static int kd_view(PyObject *obj, Py_buffer *view, Py_ssize_t size, int writable,
                   const char *name) {
    int flags = PyBUF_C_CONTIGUOUS | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) < 0) return -1;
    if (view->itemsize != size) {
        PyErr_Format(PyExc_ValueError, "%s: items of %zd bytes expected, not %zd", name,
                     size, view->itemsize);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

#define KD_COUNT(view) ((view).len / (view).itemsize)

static void kd_release(Py_buffer *views, int count) {
    for (int i = 0; i < count; i++)
        if (views[i].obj != NULL) PyBuffer_Release(&views[i]);
}

/* the buffers of the first `count` arguments (item sizes, writability and names
   given), all or none: -1 with the error set */
static int kd_views(PyObject *args, int count, Py_buffer *views, const Py_ssize_t *size,
                    const int *writable, const char *const *names) {
    if (!PyTuple_Check(args) || PyTuple_GET_SIZE(args) < count) {
        PyErr_Format(PyExc_TypeError, "%d arrays expected", count);
        return -1;
    }
    memset(views, 0, sizeof(Py_buffer) * (size_t)count);
    for (int i = 0; i < count; i++)
        if (kd_view(PyTuple_GET_ITEM(args, i), &views[i], size[i], writable[i],
                    names[i]) < 0) {
            kd_release(views, i);
            return -1;
        }
    return 0;
}

/* an index array held as runs (PeriodicIndex of kkt/_periodic.py), walked
   in entry order: runs of (period, repeats, first) over an int32 table; a
   run of one repeat holds its entries at table[first:], one of more its bases
   there and their steps after them, its entry s * period + j at
   base[j] + s * step[j].  An int32 array is one run of one repeat. */
typedef struct {
    const int64_t *runs;
    const int32_t *table;
    Py_ssize_t run;
    int64_t j, s;
} kd_index;

/* the index of the buffers `runs` (int64) and `table` (int32), checked to
   hold `count` entries whose runs lie in the table: -1 with the error set
   (the entries' values are the caller's to have checked) */
static int kd_index_of(const Py_buffer *runs, const Py_buffer *table, Py_ssize_t count,
                       const char *name, kd_index *x) {
    const int64_t *r = runs->buf;
    Py_ssize_t n_runs = KD_COUNT(*runs) / 3, size = KD_COUNT(*table);
    int64_t total = 0;
    int ok = KD_COUNT(*runs) % 3 == 0;
    for (Py_ssize_t i = 0; ok && i < n_runs; i++) {
        int64_t period = r[3 * i], repeats = r[3 * i + 1], first = r[3 * i + 2];
        int64_t held = repeats > 1 ? 2 * period : period;
        ok = period > 0 && repeats > 0 && first >= 0 && first <= size - held;
        total += period * repeats;
    }
    if (!ok || total != count) {
        PyErr_Format(PyExc_ValueError, "%s: runs that do not make %zd entries of their table",
                     name, count);
        return -1;
    }
    x->runs = r;
    x->table = table->buf;
    x->run = 0;
    x->j = x->s = 0;
    return 0;
}

/* the entries taken at a time by kd_take */
#define KD_BLOCK 1024

/* the index's next `count` entries (count <= KD_BLOCK): a pointer into the
   table where they are stored as they are (a run of one repeat: an array's
   entries), else made in `buf` from their runs' bases and steps */
static const int32_t *kd_take(kd_index *x, int32_t *buf, Py_ssize_t count) {
    if (count == 0) return buf;
    const int64_t *r = x->runs + 3 * x->run;
    if (r[1] == 1 && r[0] - x->j >= count) {  /* within a run of one repeat */
        const int32_t *at = x->table + r[2] + x->j;
        x->j += count;
        if (x->j == r[0]) {
            x->j = 0;
            x->run++;
        }
        return at;
    }
    Py_ssize_t k = 0;
    while (k < count) {
        r = x->runs + 3 * x->run;
        int64_t period = r[0], j = x->j, s = x->s;
        const int32_t *base = x->table + r[2], *step = base + period;
        if (j == 0 && r[1] > 1 && period <= count - k) {  /* whole repeats at once */
            int64_t repeats = (count - k) / period;
            if (repeats > r[1] - s) repeats = r[1] - s;
            for (int64_t t = 0; t < period; t++) {  /* each place of the period in turn */
                int64_t value = base[t] + s * (int64_t)step[t], d = step[t];
                int32_t *out = buf + k + t;
                for (int64_t q = 0; q < repeats; q++, value += d) out[q * period] = (int32_t)value;
            }
            s += repeats;
            k += repeats * period;
            x->s = s;
            if (s == r[1]) {
                x->s = 0;
                x->run++;
            }
            continue;
        }
        int64_t n = period - j < count - k ? period - j : count - k;
        if (s == 0)
            for (int64_t t = 0; t < n; t++) buf[k + t] = base[j + t];
        else
            for (int64_t t = 0; t < n; t++)
                buf[k + t] = (int32_t)(base[j + t] + s * (int64_t)step[j + t]);
        k += n;
        x->j += n;
        if (x->j == period) {
            x->j = 0;
            if (++x->s == r[1]) {
                x->s = 0;
                x->run++;
            }
        }
    }
    return buf;
}

/* the walk from i up the elimination tree to the first node marked for row k:
   the nodes passed (the first row of a pair with its second) appended to `out`
   and marked; with `build`, a node without a parent gets k (the tree made as
   the rows come, symbolic); returns how many were appended */
static Py_ssize_t kd_walk(int32_t i, Py_ssize_t k, int32_t *flag, int32_t *parent,
                          const int8_t *pair, int32_t *out, int build) {
    Py_ssize_t length = 0;
    for (; flag[i] != k; i = parent[i]) {
        if (pair[i] == 2 && flag[i - 1] != k) {  /* a pair's rows: both */
            out[length++] = i - 1;
            flag[i - 1] = (int32_t)k;
        }
        if (build && parent[i] == -1) parent[i] = (int32_t)k;
        out[length++] = i;
        flag[i] = (int32_t)k;
    }
    return length;
}

/* ---------------------------------------------------------------- symbolic */
static PyObject *kd_symbolic(PyObject *self, PyObject *args) {
    static const Py_ssize_t size[5] = {4, 4, 4, 4, 1};
    static const int writable[5] = {1, 1, 0, 0, 0};
    static const char *const names[5] = {"parent", "column_counts", "Ap", "Ai", "pair"};
    Py_buffer v[5];
    if (kd_views(args, 5, v, size, writable, names) < 0) return NULL;
    Py_ssize_t N = KD_COUNT(v[0]);
    int32_t *parent = v[0].buf, *counts = v[1].buf, *Ap = v[2].buf, *Ai = v[3].buf;
    const int8_t *pair = v[4].buf;
    size_t flag_bytes = sizeof(int32_t) * 2 * (size_t)(N > 0 ? N : 1);
    int32_t *flag = kd_scratch(flag_bytes, 0);
    if (flag == NULL) {
        kd_release(v, 5);
        return PyErr_NoMemory();
    }
    int32_t *passed = flag + N;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t k = 0; k < N; k++) {
        parent[k] = -1;
        flag[k] = (int32_t)k;
        counts[k] = 0;
        for (int64_t p = Ap[k]; p < Ap[k + 1]; p++) {
            /* each node passed has an entry in row k of L */
            Py_ssize_t length = kd_walk(Ai[p], k, flag, parent, pair, passed, 1);
            for (Py_ssize_t j = 0; j < length; j++) counts[passed[j]]++;
        }
    }
    Py_END_ALLOW_THREADS
    kd_unscratch(flag, flag_bytes);
    kd_release(v, 5);
    Py_RETURN_NONE;
}

/* ------------------------------------------------------------------ factor */
/* pair[k]: 0 a 1 x 1 pivot of a variable, 3 one of a constraint; 1 the first row
   of a 2 x 2 pivot (a variable), 2 its second (the variable's constraint); E[k]
   the off-diagonal entry of the 2 x 2 block starting at k */
enum {F_AX, F_LP, F_LI, F_LX, F_D, F_E, F_AP, F_AI, F_PARENT, F_PAIR, F_HMAP, F_HV,
      F_JMAP, F_JV, F_DMAP, F_DX, F_DXI, F_DC, F_ZERO, F_COUNT};

/* K's diagonals beside H's and the Jacobian's entries: the variables' diagonal_x
   (an array of n, or NULL for one constant, or x_count values at the entries
   x_index, the constant elsewhere) plus added_x (where not 0), the rows'
   diagonal_c (an array of N - n, or NULL for one constant) */
typedef struct {
    Py_ssize_t n, x_count;
    const double *x, *c;
    const int32_t *x_index;
    double x_constant, x_added, c_constant;
} kd_diagonals;

/* the diagonals from the buffers `dx`, `dx_index`, `dc` (dx: n or 0 entries, or
   as many as dx_index, the increasing entries below n that dx holds, the others
   x_constant; dc: N - n or 0) and the arguments args[at:at + 4] = (n,
   x_constant, x_added, c_constant): -1 with the error set when they do not fit
   K's order N */
static int kd_diagonals_of(PyObject *args, Py_ssize_t at, const Py_buffer *dx,
                           const Py_buffer *dx_index, const Py_buffer *dc, Py_ssize_t N,
                           kd_diagonals *d) {
    if (PyTuple_GET_SIZE(args) != at + 4) {
        PyErr_Format(PyExc_TypeError, "%zd arguments expected", at + 4);
        return -1;
    }
    d->n = PyLong_AsSsize_t(PyTuple_GET_ITEM(args, at));
    if (d->n == -1 && PyErr_Occurred()) return -1;
    d->x_constant = PyFloat_AsDouble(PyTuple_GET_ITEM(args, at + 1));
    d->x_added = PyFloat_AsDouble(PyTuple_GET_ITEM(args, at + 2));
    d->c_constant = PyFloat_AsDouble(PyTuple_GET_ITEM(args, at + 3));
    if (PyErr_Occurred()) return -1;
    Py_ssize_t nx = KD_COUNT(*dx), ni = KD_COUNT(*dx_index), nc = KD_COUNT(*dc);
    if (d->n < 0 || d->n > N || (ni == 0 && nx != 0 && nx != d->n) || (ni != 0 && nx != ni)
        || (nc != 0 && nc != N - d->n)) {
        PyErr_SetString(PyExc_ValueError, "diagonals of inconsistent sizes");
        return -1;
    }
    d->x = nx ? dx->buf : NULL;
    d->x_index = ni ? dx_index->buf : NULL;
    d->x_count = ni;
    for (Py_ssize_t k = 0; k < ni; k++) {
        int32_t j = d->x_index[k];
        if (j < 0 || j >= d->n || (k > 0 && j <= d->x_index[k - 1])) {
            PyErr_Format(PyExc_ValueError, "diagonal_x's index: entry %zd (%d) is not "
                         "increasing within 0..n - 1", k, (int)j);
            return -1;
        }
    }
    d->c = nc ? dc->buf : NULL;
    return 0;
}

/* the variable j's diagonal entry beside H's (the sum as NumPy's array +
   added_x), the variables taken in turn (j = 0, 1, ...) with `at` (0 at the
   first) the place in an index */
static inline double kd_dx(const kd_diagonals *d, Py_ssize_t j, Py_ssize_t *at) {
    double value;
    if (d->x_index == NULL) value = d->x != NULL ? d->x[j] : d->x_constant;
    else if (*at < d->x_count && d->x_index[*at] == j) value = d->x[(*at)++];
    else value = d->x_constant;
    return d->x_added != 0.0 ? value + d->x_added : value;
}

/* the row i's diagonal_c */
static inline double kd_dc(const kd_diagonals *d, Py_ssize_t i) {
    return d->c != NULL ? d->c[i] : d->c_constant;
}

/* a zero pivot is replaced by this (its sign chosen by the caller): 1 / sqrt(eps)
   times the larger of its scale and K's largest entry, so that the rows below
   change about as little as if its row and column were left out (at most
   1e300) */
static double kd_replacement(double scale, double largest) {
    double base = scale > largest && isfinite(scale) ? scale : largest;
    double r = base / sqrt(DBL_EPSILON);
    return r < 1e300 ? r : 1e300;
}

/* the 2 x 2 pivot [[a, e], [e, d]] (a variable, then its constraint): its
   eigenvalues counted, a zero one replaced so that the block has one positive
   and one negative eigenvalue, magnitude `scale`; the block rewritten with the
   replacement.  The larger eigenvalue is zero when |big| <= tolerance * scale;
   the smaller, det / big, when the determinant cancels, |a d - e^2| <=
   tolerance (|a d| + e^2), or when |small| <= tolerance * growth (growth: the
   square of the largest entry of the two rows off the block over the largest
   of K, the rows below growing by that over |small|); either when not
   finite.  So [[S, 1], [1, 0]] with a barrier term S = 1e12, the largest
   entry of K, is sound: its small eigenvalue -1/S has no cancellation, and
   the rows below grow to S at most.  Returns how many eigenvalues were zero */
static int kd_block(double *a, double *e, double *d, double tolerance, double scale,
                     double growth, double largest, Py_ssize_t *n_positive,
                     Py_ssize_t *n_negative, Py_ssize_t *n_zero) {
    double mean = 0.5 * (*a + *d), half = 0.5 * (*a - *d);
    double radius = hypot(half, *e);
    double big = mean >= 0.0 ? mean + radius : mean - radius;  /* the larger magnitude */
    double small = big != 0.0 ? (*a * *d - *e * *e) / big : 0.0;
    double product = *a * *d, square = *e * *e;
    int big_zero = !(fabs(big) > tolerance * scale);
    int small_zero = big_zero || !(fabs(product - square) > tolerance * (fabs(product) + square))
                     || !(fabs(small) > tolerance * growth) || !isfinite(small);
    if (!big_zero && !small_zero) {
        if (big > 0.0) (*n_positive)++; else (*n_negative)++;
        if (small > 0.0) (*n_positive)++; else (*n_negative)++;
        return 0;
    }
    double r = kd_replacement(scale, largest);
    /* the unit eigenvector of `big` (from the better conditioned of the two rows
       of B - big I), the other one orthogonal to it */
    double vx, vy;
    if (fabs(big - *d) >= fabs(big - *a)) {
        vx = big - *d;
        vy = *e;
    } else {
        vx = *e;
        vy = big - *a;
    }
    double norm = hypot(vx, vy);
    if (!(norm > 0.0) || !isfinite(norm)) {
        vx = 1.0;
        vy = 0.0;
    } else {
        vx /= norm;
        vy /= norm;
    }
    if (big_zero) {
        *n_zero += 2;
        big = r;
        small = -r;
    } else {
        *n_zero += 1;
        if (big > 0.0) (*n_positive)++; else (*n_negative)++;
        small = big > 0.0 ? -r : r;
    }
    *a = big * vx * vx + small * vy * vy;
    *d = big * vy * vy + small * vx * vx;
    *e = (big - small) * vx * vy;
    return big_zero ? 2 : 1;
}

/* Envelope (profile) storage of L in the elimination order: row k holds its
   columns first_k .. k - 1 at Lx[rowptr[k] ...] (column j at rowptr[k + 1] -
   (k - j)), first_k = k - (rowptr[k + 1] - rowptr[k]); no row indices.  No
   pivoting keeps L's entries in K's envelope (the columns left of row k's
   first entry of K stay zero); a 2 x 2 pivot's rows are one column of the
   envelope's rows, so a row whose first entry is a pair's second column
   starts at the pair's first.  L of a pair's second row k has no entry in
   column k - 1 (its own block): that place holds the block's off-diagonal
   entry (KD_SLOT of k - 1), and the row's entries of L are its first
   KD_WIDTH. */
#define KD_FIRST(rowptr, k) ((int64_t)(k) - ((int64_t)(rowptr)[(k) + 1] - (rowptr)[k]))

/* the place in Lx of the entry (i, j) of the permuted K, i != j */
#define KD_PLACE(rowptr, i, j) ((i) > (j) ? (int64_t)(rowptr)[(i) + 1] - ((i) - (j)) \
                                          : (int64_t)(rowptr)[(j) + 1] - ((j) - (i)))

/* the place of the off-diagonal entry of the 2 x 2 block of rows j, j + 1 */
#define KD_SLOT(rowptr, j) ((int64_t)(rowptr)[(j) + 2] - 1)

/* how many of row k's places, from its first, hold entries of L */
#define KD_WIDTH(rowptr, pair, k) ((int64_t)(rowptr)[(k) + 1] - (rowptr)[k] - ((pair)[k] == 2))

/* the pivots of a factorization so far: their counts by sign, the scale of the
   first row of the current 2 x 2 pivot, and the threshold and K's largest
   magnitude (1 for an empty K) that judge them */
typedef struct {
    double tolerance, largest, first_scale;
    Py_ssize_t n_positive, n_negative, n_zero;
} kd_pivots;

/* pivot k, d = K(k, k) - l . w summed from terms of total magnitude `terms`:
   D[k] set (a zero one replaced; for a pair's second row, with D[k - 1] and
   the block's off-diagonal entry *e), zero[k] (both rows of a 2 x 2 block)
   set to 1 or 0, counted.  A zero pivot: small beside the terms it was summed from
   (cancelled), or beside the square of the largest entry of its row of K off
   the diagonal over the largest of K (the rows below would grow by that over
   |d|; by more than 1 / tolerance, or 1 / sqrt(tolerance) for a variable's),
   or not finite.  row_max: the largest magnitude in row k of K; off_max: off
   the diagonal and off a pair's block; off_before: off_max of row k - 1 */
static void kd_judge(kd_pivots *p, Py_ssize_t k, double d, double terms,
                     const int8_t *pair, double *D, double *e, double row_max,
                     double off_max, double off_before, int8_t *zero) {
    double scale = terms > row_max ? terms : row_max, largest = p->largest;
    D[k] = d;
    zero[k] = 0;
    if (pair[k] == 1) {
        p->first_scale = scale;
    } else if (pair[k] == 2) {
        double off = off_max > off_before ? off_max : off_before;
        if (kd_block(&D[k - 1], e, &D[k], p->tolerance,
                     scale > p->first_scale ? scale : p->first_scale, off * off / largest,
                     largest, &p->n_positive, &p->n_negative, &p->n_zero))
            zero[k - 1] = zero[k] = 1;
    } else if (!(fabs(d) > p->tolerance * terms)
               || !(fabs(d) > (pair[k] == 0 ? sqrt(p->tolerance) : p->tolerance) * off_max
                                * off_max / largest)) {
        p->n_zero++;
        zero[k] = 1;
        double r = kd_replacement(scale, largest);
        D[k] = pair[k] == 3 ? -r : r;
    } else if (d > 0.0) {
        p->n_positive++;
    } else {
        p->n_negative++;
    }
}

/* D y = z in place, blockwise: the 2 x 2 blocks' off-diagonal entries in E */
static void kd_divide(double *w, const double *D, const double *E, const int8_t *pair,
                      Py_ssize_t N) {
    for (Py_ssize_t j = 0; j < N; j++) {
        if (pair[j] == 1) {
            double e = E[j], a = D[j], b = D[j + 1], det = a * b - e * e;
            double w0 = w[j], w1 = w[j + 1];
            w[j] = (b * w0 - e * w1) / det;
            w[j + 1] = (a * w1 - e * w0) / det;
            j++;
        } else {
            w[j] /= D[j];
        }
    }
}

static PyObject *kd_factor(PyObject *self, PyObject *args) {
    if (!PyTuple_Check(args) || PyTuple_GET_SIZE(args) != F_COUNT + 5) {
        PyErr_Format(PyExc_TypeError, "%d arguments expected", F_COUNT + 5);
        return NULL;
    }
    double tolerance = PyFloat_AsDouble(PyTuple_GET_ITEM(args, F_COUNT));
    if (tolerance == -1.0 && PyErr_Occurred()) return NULL;
    static const Py_ssize_t size[F_COUNT] = {8, 4, 4, 8, 8, 8, 4, 4, 4, 1, 4, 8, 4, 8, 4,
                                             8, 4, 8, 1};
    static const int writable[F_COUNT] = {1, 0, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                                          0, 0, 1};
    static const char *const names[F_COUNT] = {"Ax", "Lp", "Li", "Lx", "D", "E", "Ap", "Ai",
                                         "parent", "pair", "hessian map", "hessian_values",
                                         "jacobian map", "jacobian_values", "diagonal map",
                                         "diagonal_x", "diagonal_x index", "diagonal_c",
                                         "zero"};
    Py_buffer v[F_COUNT];
    if (kd_views(args, F_COUNT, v, size, writable, names) < 0) return NULL;
    double *Ax = v[F_AX].buf, *Lx = v[F_LX].buf, *D = v[F_D].buf, *E = v[F_E].buf;
    const int32_t *Lp = v[F_LP].buf, *Ap = v[F_AP].buf;
    int32_t *Li = v[F_LI].buf;
    const int32_t *Ai = v[F_AI].buf, *parent = v[F_PARENT].buf;
    const int8_t *pair = v[F_PAIR].buf;
    const int32_t *hmap = v[F_HMAP].buf, *jmap = v[F_JMAP].buf, *dmap = v[F_DMAP].buf;
    const double *hv = v[F_HV].buf, *jv = v[F_JV].buf;
    Py_ssize_t N = KD_COUNT(v[F_D]), nnz = KD_COUNT(v[F_AX]);
    Py_ssize_t nh = KD_COUNT(v[F_HV]), nj = KD_COUNT(v[F_JV]);
    kd_diagonals diagonals;
    if (kd_diagonals_of(args, F_COUNT + 1, &v[F_DX], &v[F_DXI], &v[F_DC], N,
                        &diagonals) < 0) {
        kd_release(v, F_COUNT);
        return NULL;
    }
    Py_ssize_t nx = diagonals.n, nc = N - nx;
    if (KD_COUNT(v[F_ZERO]) < N) {
        kd_release(v, F_COUNT);
        PyErr_SetString(PyExc_ValueError, "zero: fewer than N entries");
        return NULL;
    }
    /* the workspace, 5 N doubles: held only while this call runs */
    size_t work_bytes = sizeof(double) * 5 * (size_t)(N > 0 ? N : 1);
    double *work = kd_scratch(work_bytes, 0);
    if (work == NULL) {
        kd_release(v, F_COUNT);
        return PyErr_NoMemory();
    }
    double *Y = work, *rowmax = work + N, *offmax = work + 2 * N;
    int64_t *filled = (int64_t *)(work + 3 * N);
    int32_t *pattern = (int32_t *)(work + 4 * N), *flag = pattern + N;
    int8_t *zero = v[F_ZERO].buf;
    kd_pivots pivots = {tolerance, 1.0, 0.0, 0, 0, 0};
    Py_BEGIN_ALLOW_THREADS
    /* the values of K, summed into the permuted upper triangle */
    memset(Ax, 0, sizeof(double) * (size_t)nnz);
    for (Py_ssize_t e = 0; e < nh; e++) Ax[hmap[e]] += hv[e];
    for (Py_ssize_t e = 0; e < nj; e++) Ax[jmap[e]] += jv[e];
    for (Py_ssize_t j = 0, at = 0; j < nx; j++) Ax[dmap[j]] += kd_dx(&diagonals, j, &at);
    for (Py_ssize_t i = 0; i < nc; i++) Ax[dmap[nx + i]] -= kd_dc(&diagonals, i);
    /* the largest magnitude in each row of K (both triangles), and off the
       diagonal (and off a pair's block) */
    for (Py_ssize_t k = 0; k < N; k++) {
        rowmax[k] = 0.0;
        offmax[k] = 0.0;
        Y[k] = 0.0;
        E[k] = 0.0;
    }
    for (Py_ssize_t k = 0; k < N; k++)
        for (int64_t p = Ap[k]; p < Ap[k + 1]; p++) {
            double a = fabs(Ax[p]);
            int32_t i = Ai[p];
            if (a > rowmax[k]) rowmax[k] = a;
            if (a > rowmax[i]) rowmax[i] = a;
            /* off the diagonal and off the 2 x 2 block of a pair */
            if (i != k && !(pair[k] == 2 && i == k - 1)) {
                if (a > offmax[k]) offmax[k] = a;
                if (a > offmax[i]) offmax[i] = a;
            }
        }
    double largest = 0.0;
    for (Py_ssize_t k = 0; k < N; k++) if (rowmax[k] > largest) largest = rowmax[k];
    pivots.largest = largest == 0.0 ? 1.0 : largest;
    /* up-looking block L D L^T: w = L(0:k,0:k)^-1 A(0:k, k), then row k of L is
       D^-1 w (blockwise) and d_k = A(k, k) - (row k of L) w */
    for (Py_ssize_t k = 0; k < N; k++) {
        Py_ssize_t top = N;
        flag[k] = (int32_t)k;
        filled[k] = 0;
        for (int64_t p = Ap[k]; p < Ap[k + 1]; p++) {
            Y[Ai[p]] += Ax[p];
            Py_ssize_t length = kd_walk(Ai[p], k, flag, (int32_t *)parent, pair, pattern, 0);
            while (length > 0) pattern[--top] = pattern[--length];
        }
        double d = Y[k], terms = fabs(Y[k]);
        Y[k] = 0.0;
        for (; top < N; top++) {
            int32_t i = pattern[top];
            double wi = Y[i];
            int64_t end = Lp[i] + filled[i];
            for (int64_t p = Lp[i]; p < end; p++) Y[Li[p]] -= Lx[p] * wi;
            if (pair[i] == 1) {  /* kept in Y until its partner i + 1 comes */
                if (i == k - 1) {  /* k's own partner: the block's off-diagonal entry */
                    E[i] = wi;
                    Y[i] = 0.0;
                    Li[end] = (int32_t)k;
                    Lx[end] = 0.0;
                    filled[i]++;
                }
                continue;
            }
            Y[i] = 0.0;
            if (pair[i] == 2) {  /* [l_{i-1}, l_i] = B^-1 [w_{i-1}, w_i] */
                double w0 = Y[i - 1], a = D[i - 1], e = E[i - 1], b = D[i];
                double det = a * b - e * e;
                double l0 = (b * w0 - e * wi) / det, l1 = (a * wi - e * w0) / det;
                Y[i - 1] = 0.0;
                d -= l0 * w0 + l1 * wi;
                terms += fabs(l0 * w0) + fabs(l1 * wi);
                int64_t end0 = Lp[i - 1] + filled[i - 1];
                Li[end0] = (int32_t)k;
                Lx[end0] = l0;
                filled[i - 1]++;
                Li[end] = (int32_t)k;
                Lx[end] = l1;
                filled[i]++;
            } else {
                double l = wi / D[i];
                d -= l * wi;
                terms += fabs(l * wi);
                Li[end] = (int32_t)k;
                Lx[end] = l;
                filled[i]++;
            }
        }
        kd_judge(&pivots, k, d, terms, pair, D, pair[k] == 2 ? E + k - 1 : NULL, rowmax[k],
                 offmax[k], k > 0 ? offmax[k - 1] : 0.0, zero);
    }
    Py_END_ALLOW_THREADS
    kd_unscratch(work, work_bytes);
    kd_release(v, F_COUNT);
    return Py_BuildValue("nnn", pivots.n_positive, pivots.n_negative, pivots.n_zero);
}

/* ------------------------------------------------------------------- solve */
static PyObject *kd_solve(PyObject *self, PyObject *args) {
    if (!PyTuple_Check(args) || PyTuple_GET_SIZE(args) != 9) {
        PyErr_SetString(PyExc_TypeError, "9 arguments expected");
        return NULL;
    }
    Py_ssize_t columns = PyLong_AsSsize_t(PyTuple_GET_ITEM(args, 8));
    if (columns == -1 && PyErr_Occurred()) return NULL;
    static const Py_ssize_t size[8] = {8, 4, 4, 8, 8, 8, 1, 4};
    static const int writable[8] = {1, 0, 0, 0, 0, 0, 0, 0};
    static const char *const names[8] = {"rhs", "Lp", "Li", "Lx", "D", "E", "pair",
                                         "permutation"};
    Py_buffer v[8];
    if (kd_views(args, 8, v, size, writable, names) < 0) return NULL;
    double *X = v[0].buf;
    const int32_t *Lp = v[1].buf, *Li = v[2].buf, *perm = v[7].buf;
    const double *Lx = v[3].buf, *D = v[4].buf, *E = v[5].buf;
    const int8_t *pair = v[6].buf;
    Py_ssize_t N = KD_COUNT(v[4]);
    if (columns < 0 || KD_COUNT(v[0]) != columns * N) {
        kd_release(v, 8);
        PyErr_SetString(PyExc_ValueError, "rhs: not of the factored size");
        return NULL;
    }
    size_t w_bytes = sizeof(double) * (size_t)(N > 0 ? N : 1);
    double *w = kd_scratch(w_bytes, 0);  /* for this call */
    if (w == NULL) {
        kd_release(v, 8);
        return PyErr_NoMemory();
    }
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t c = 0; c < columns; c++) {
        double *x = X + c * N;
        for (Py_ssize_t k = 0; k < N; k++) w[k] = x[perm[k]];
        for (Py_ssize_t j = 0; j < N; j++) {  /* L z = b */
            double wj = w[j];
            for (int64_t p = Lp[j]; p < Lp[j + 1]; p++) w[Li[p]] -= Lx[p] * wj;
        }
        kd_divide(w, D, E, pair, N);  /* D y = z */
        for (Py_ssize_t j = N - 1; j >= 0; j--) {  /* L^T x = y */
            double wj = w[j];
            for (int64_t p = Lp[j]; p < Lp[j + 1]; p++) wj -= Lx[p] * w[Li[p]];
            w[j] = wj;
        }
        for (Py_ssize_t k = 0; k < N; k++) x[perm[k]] = w[k];
    }
    Py_END_ALLOW_THREADS
    kd_unscratch(w, w_bytes);
    kd_release(v, 8);
    Py_RETURN_NONE;
}

/* ------------------------------------------------------------------ matvec */
static PyObject *kd_matvec(PyObject *self, PyObject *args) {
    static const Py_ssize_t size[6] = {8, 8, 4, 4, 8, 4};
    static const int writable[6] = {1, 0, 0, 0, 0, 0};
    static const char *const names[6] = {"y", "x", "Ap", "Ai", "Ax", "permutation"};
    Py_buffer v[6];
    if (kd_views(args, 6, v, size, writable, names) < 0) return NULL;
    double *y = v[0].buf;
    const double *x = v[1].buf, *Ax = v[4].buf;
    const int32_t *Ap = v[2].buf, *Ai = v[3].buf, *perm = v[5].buf;
    Py_ssize_t N = KD_COUNT(v[0]);
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t k = 0; k < N; k++) y[k] = 0.0;
    for (Py_ssize_t k = 0; k < N; k++) {
        int32_t ok = perm[k];
        double xk = x[ok], yk = 0.0;
        for (int64_t p = Ap[k]; p < Ap[k + 1]; p++) {
            int32_t oi = perm[Ai[p]];
            yk += Ax[p] * x[oi];
            if (oi != ok) y[oi] += Ax[p] * xk;
        }
        y[ok] += yk;
    }
    Py_END_ALLOW_THREADS
    kd_release(v, 6);
    Py_RETURN_NONE;
}

/* ----------------------------------------------------------------- invalid */
static PyObject *kd_invalid(PyObject *self, PyObject *args) {
    if (!PyTuple_Check(args) || PyTuple_GET_SIZE(args) < 1 || PyTuple_GET_SIZE(args) > 9) {
        PyErr_SetString(PyExc_TypeError, "1 to 8 arrays and a count expected");
        return NULL;
    }
    int count = (int)PyTuple_GET_SIZE(args) - 1;
    Py_ssize_t nonnegative = PyLong_AsSsize_t(PyTuple_GET_ITEM(args, count));
    if (nonnegative == -1 && PyErr_Occurred()) return NULL;
    static const Py_ssize_t size[8] = {8, 8, 8, 8, 8, 8, 8, 8};
    static const int writable[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    static const char *const names[8] = {"array", "array", "array", "array", "array",
                                         "array", "array", "array"};
    Py_buffer v[8];
    if (kd_views(args, count, v, size, writable, names) < 0) return NULL;
    Py_ssize_t which = -1, entry = -1;
    Py_BEGIN_ALLOW_THREADS
    for (int a = 0; a < count && which < 0; a++) {
        const double *x = v[a].buf;
        Py_ssize_t n = KD_COUNT(v[a]);
        for (Py_ssize_t i = 0; i < n; i++)
            if (!isfinite(x[i])) { which = a; entry = i; break; }
    }
    for (int a = (int)(nonnegative < 0 ? count : nonnegative); a < count && which < 0; a++) {
        const double *x = v[a].buf;
        Py_ssize_t n = KD_COUNT(v[a]);
        for (Py_ssize_t i = 0; i < n; i++)
            if (x[i] < 0.0) { which = a; entry = i; break; }
    }
    Py_END_ALLOW_THREADS
    kd_release(v, count);
    if (which < 0) Py_RETURN_NONE;
    return Py_BuildValue("nn", which, entry);
}

/* ------------------------------------------------------ error_reductions */
/* sum |a_i| as np.abs(a).sum() makes it: 0.0 plus NumPy's pairwise sum
   (eight accumulators in blocks of up to 128, halves beyond; its
   pairwise_sum of numpy/_core/src/umath/loops_utils.h.src) */
static double kd_pairwise_abs(const double *a, Py_ssize_t n) {
    if (n < 8) {
        double res = 0.;
        for (Py_ssize_t i = 0; i < n; i++) res += fabs(a[i]);
        return res;
    }
    if (n <= 128) {
        double r[8], res;
        Py_ssize_t i;
        for (int j = 0; j < 8; j++) r[j] = fabs(a[j]);
        for (i = 8; i < n - (n % 8); i += 8)
            for (int j = 0; j < 8; j++) r[j] += fabs(a[i + j]);
        res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; i++) res += fabs(a[i]);
        return res;
    }
    Py_ssize_t n2 = n / 2;
    n2 -= n2 % 8;
    return kd_pairwise_abs(a, n2) + kd_pairwise_abs(a + n2, n - n2);
}

/* the larger of m and v as np.maximum's reduction keeps it: a NaN stays */
#define KD_MAX(m, v) do { double kd_v = (v); if (kd_v > (m) || isnan(kd_v)) (m) = kd_v; } while (0)

static PyObject *kd_error_reductions(PyObject *self, PyObject *args) {
    if (!PyTuple_Check(args) || PyTuple_GET_SIZE(args) != 8) {
        PyErr_SetString(PyExc_TypeError, "7 arrays and mu expected");
        return NULL;
    }
    double mu = PyFloat_AsDouble(PyTuple_GET_ITEM(args, 7));
    if (mu == -1.0 && PyErr_Occurred()) return NULL;
    static const Py_ssize_t size[7] = {8, 8, 8, 8, 8, 8, 8};
    static const int writable[7] = {0, 0, 0, 0, 0, 0, 0};
    static const char *const names[7] = {"dual", "c", "y", "z_lower", "z_upper",
                                         "gap_lower", "gap_upper"};
    Py_buffer v[7];
    if (kd_views(args, 7, v, size, writable, names) < 0) return NULL;
    const double *dual = v[0].buf, *c = v[1].buf, *y = v[2].buf, *zl = v[3].buf,
                 *zu = v[4].buf, *gl = v[5].buf, *gu = v[6].buf;
    Py_ssize_t n_lower = KD_COUNT(v[3]), n_upper = KD_COUNT(v[4]);
    if (KD_COUNT(v[5]) != n_lower || KD_COUNT(v[6]) != n_upper) {
        kd_release(v, 7);
        PyErr_SetString(PyExc_ValueError, "the gaps and the multipliers differ in length");
        return NULL;
    }
    double y_sum, zl_sum, zu_sum, dual_max = 0.0, c_max = 0.0, cl_max = 0.0, cu_max = 0.0,
           cl_mu = 0.0, cu_mu = 0.0;
    Py_BEGIN_ALLOW_THREADS
    y_sum = 0.0 + kd_pairwise_abs(y, KD_COUNT(v[2]));
    zl_sum = 0.0 + kd_pairwise_abs(zl, n_lower);
    zu_sum = 0.0 + kd_pairwise_abs(zu, n_upper);
    for (Py_ssize_t i = 0; i < KD_COUNT(v[0]); i++) KD_MAX(dual_max, fabs(dual[i]));
    for (Py_ssize_t i = 0; i < KD_COUNT(v[1]); i++) KD_MAX(c_max, fabs(c[i]));
    for (Py_ssize_t i = 0; i < n_lower; i++) {
        double product = zl[i] * gl[i];
        KD_MAX(cl_max, product);
        KD_MAX(cl_mu, fabs(product - mu));
    }
    for (Py_ssize_t i = 0; i < n_upper; i++) {
        double product = zu[i] * gu[i];
        KD_MAX(cu_max, product);
        KD_MAX(cu_mu, fabs(product - mu));
    }
    Py_END_ALLOW_THREADS
    kd_release(v, 7);
    return Py_BuildValue("ddddddddd", y_sum, zl_sum, zu_sum, dual_max, c_max, cl_max,
                         cu_max, cl_mu, cu_mu);
}

/* ---------------------------------------------------------------- patterns */
/* an index argument of the pattern functions, `obj`: an int32 array, or a
   (runs, table) pair of a PeriodicIndex; its index in *x, its entries in
   *count, its buffers in views[0] and views[1] (released by the caller; an
   array's in views[1]), an array's one run in `run` (the caller's, kept
   while x is walked): -1 with the error set */
static int kd_arg_of(PyObject *obj, const char *name, Py_buffer *views, int64_t *run,
                     kd_index *x, Py_ssize_t *count) {
    if (PyTuple_Check(obj)) {
        if (PyTuple_GET_SIZE(obj) != 2) {
            PyErr_Format(PyExc_TypeError, "%s: an int32 array or (runs, table) expected",
                         name);
            return -1;
        }
        if (kd_view(PyTuple_GET_ITEM(obj, 0), &views[0], 8, 0, name) < 0
            || kd_view(PyTuple_GET_ITEM(obj, 1), &views[1], 4, 0, name) < 0) return -1;
        const int64_t *r = views[0].buf;
        int64_t total = 0;
        for (Py_ssize_t i = 0; i + 2 < KD_COUNT(views[0]); i += 3) total += r[i] * r[i + 1];
        *count = (Py_ssize_t)total;
        return kd_index_of(&views[0], &views[1], *count, name, x);
    }
    if (kd_view(obj, &views[1], 4, 0, name) < 0) return -1;
    *count = KD_COUNT(views[1]);
    run[0] = *count;
    run[1] = 1;
    run[2] = 0;
    x->runs = run;
    x->table = views[1].buf;
    x->run = 0;
    x->j = x->s = 0;
    return 0;
}

/* the `count` index arguments (kd_arg_of) of args from item `at`, named
   `names`: their indexes in x, their entries in counts, their buffers in
   views (two each, released by the caller), arrays' runs in runs (three
   each): -1 with the error set */
static int kd_index_args(PyObject *args, Py_ssize_t at, int count, const char *const *names,
                         Py_buffer *views, int64_t *runs, kd_index *x, Py_ssize_t *counts) {
    for (int a = 0; a < count; a++)
        if (kd_arg_of(PyTuple_GET_ITEM(args, at + a), names[a], views + 2 * a, runs + 3 * a,
                      &x[a], &counts[a]) < 0) return -1;
    return 0;
}

/* pairs (r[e] + offset, c[e]), e < count, where mask[e] (all where mask is
   NULL): a part of a pattern's entries, r and c walked from their start a
   block at a time (kd_take; a copy of a part not yet walked walks it again
   in its own buffers; `runs` holds an array's one run); with `node`, each
   pair (node[i], node[j]) instead, where both are >= 0 and differ (the
   caller has checked that i and j index node) */
typedef struct {
    kd_index r, c;
    Py_ssize_t count;
    int64_t offset;
    const uint8_t *mask;
    const int32_t *node;
    int64_t runs[6];
    const int32_t *R, *C;  /* the block's entries, `left` of them from `at` */
    Py_ssize_t at, left;
    int32_t rbuf[KD_BLOCK], cbuf[KD_BLOCK];
} kd_part;

/* a part of the entries of indices r and c (count of them, rows moved by
   offset), walked from their start */
static kd_part kd_part_of(kd_index r, kd_index c, Py_ssize_t count, int64_t offset) {
    kd_part part;
    part.r = r;
    part.c = c;
    part.count = count;
    part.offset = offset;
    part.mask = NULL;
    part.node = NULL;
    part.at = part.left = 0;
    return part;
}

/* the part's entry e (each in turn, from 0), in *i and *j: 0 where the mask
   (or the node map) leaves it out */
static inline int kd_part_next(kd_part *p, Py_ssize_t e, int64_t *i, int64_t *j) {
    if (p->left == 0) {
        Py_ssize_t n = p->count - e < KD_BLOCK ? p->count - e : KD_BLOCK;
        p->R = kd_take(&p->r, p->rbuf, n);
        p->C = kd_take(&p->c, p->cbuf, n);
        p->at = 0;
        p->left = n;
    }
    *i = p->R[p->at] + p->offset;
    *j = p->C[p->at++];
    p->left--;
    if (p->mask != NULL && !p->mask[e]) return 0;
    if (p->node == NULL) return 1;
    *i = p->node[*i];
    *j = p->node[*j];
    return *i >= 0 && *j >= 0 && *i != *j;
}

/* a new buffer holding `count` int32 items of `data` (NULL with the error set) */
static PyObject *kd_int32_bytes(const int32_t *data, Py_ssize_t count) {
    PyObject *out = kd_buffer_new((Py_ssize_t)sizeof(int32_t) * count);
    if (out != NULL && count > 0)
        memcpy(((kd_buffer *)out)->data, data, sizeof(int32_t) * (size_t)count);
    return out;
}

/* pointers advanced by a bucket fill (ptr[i] the end of bucket i) back to the starts */
static void kd_unshift(int32_t *ptr, Py_ssize_t n) {
    for (Py_ssize_t i = n; i > 0; i--) ptr[i] = ptr[i - 1];
    ptr[0] = 0;
}

static int kd_int32_order(const void *a, const void *b) {
    int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
    return (x > y) - (x < y);
}

/* a[0:n] sorted increasing: by insertion where short (a pattern's rows
   mostly are), else by qsort */
static void kd_sort_int32(int32_t *a, int64_t n) {
    if (n > 32) {
        qsort(a, (size_t)n, sizeof(int32_t), kd_int32_order);
        return;
    }
    for (int64_t q = 1; q < n; q++) {
        int32_t value = a[q];
        int64_t t = q;
        for (; t > 0 && a[t - 1] > value; t--) a[t] = a[t - 1];
        a[t] = value;
    }
}

/* the CSR pattern of an n_rows x n_cols matrix with the entries of `parts` (with
   `symmetric` their mirror images too), repeats merged and each row's columns
   increasing: the entries bucketed by row in the result's own storage, each row
   then sorted and its repeats merged, the rows compacted.  Two buffers of int32,
   (indptr, indices), or NULL with the error set.  Scratch: none beyond the
   result (the indices' buffer holds the entries before their repeats are
   merged, then gives back the rest). */
static PyObject *kd_csr_of(Py_ssize_t n_rows, Py_ssize_t n_cols, const kd_part *parts,
                           int n_parts, int symmetric) {
    Py_ssize_t total = 0;
    for (int p = 0; p < n_parts; p++) {
        kd_part part = parts[p];
        for (Py_ssize_t e = 0; e < part.count; e++) {
            int64_t i, j;
            if (!kd_part_next(&part, e, &i, &j)) continue;
            if (i < 0 || i >= n_rows || j < 0 || j >= n_cols ||
                    (symmetric && (j >= n_rows || i >= n_cols))) {
                PyErr_Format(PyExc_ValueError, "entry (%lld, %lld) outside a %zd x %zd "
                             "pattern", (long long)i, (long long)j, n_rows, n_cols);
                return NULL;
            }
            total += symmetric ? 2 : 1;
        }
    }
    if (total >= INT32_MAX || n_rows >= INT32_MAX || n_cols >= INT32_MAX) {
        PyErr_SetString(PyExc_ValueError, "a pattern too large for 32-bit indices");
        return NULL;
    }
    PyObject *pointers = kd_buffer_new((Py_ssize_t)sizeof(int32_t) * (n_rows + 1));
    PyObject *indices = pointers == NULL ? NULL
                        : kd_buffer_new((Py_ssize_t)sizeof(int32_t) * total);
    if (indices == NULL) {
        Py_XDECREF(pointers);
        return NULL;
    }
    int32_t *indptr = (int32_t *)((kd_buffer *)pointers)->data;
    int32_t *by_row = (int32_t *)((kd_buffer *)indices)->data;
    int64_t kept = 0;
    Py_BEGIN_ALLOW_THREADS
    memset(indptr, 0, sizeof(int32_t) * (size_t)(n_rows + 1));
    for (int p = 0; p < n_parts; p++) {  /* each row's entries counted */
        kd_part part = parts[p];
        for (Py_ssize_t e = 0; e < part.count; e++) {
            int64_t i, j;
            if (!kd_part_next(&part, e, &i, &j)) continue;
            indptr[i + 1]++;
            if (symmetric) indptr[j + 1]++;
        }
    }
    for (Py_ssize_t i = 0; i < n_rows; i++) indptr[i + 1] += indptr[i];
    for (int p = 0; p < n_parts; p++) {  /* and bucketed (indptr[i]: row i's end so far) */
        kd_part part = parts[p];
        for (Py_ssize_t e = 0; e < part.count; e++) {
            int64_t i, j;
            if (!kd_part_next(&part, e, &i, &j)) continue;
            by_row[indptr[i]++] = (int32_t)j;
            if (symmetric) by_row[indptr[j]++] = (int32_t)i;
        }
    }
    kd_unshift(indptr, n_rows);
    /* each row sorted, its repeats merged, the rows compacted (kept <= begin) */
    int64_t begin = 0;
    for (Py_ssize_t i = 0; i < n_rows; i++) {
        int64_t end = indptr[i + 1], first = kept;
        kd_sort_int32(by_row + begin, end - begin);
        for (int64_t q = begin; q < end; q++)
            if (kept == first || by_row[kept - 1] != by_row[q]) by_row[kept++] = by_row[q];
        indptr[i] = (int32_t)first;
        begin = end;
    }
    indptr[n_rows] = (int32_t)kept;
    Py_END_ALLOW_THREADS
    kd_buffer_shrink(indices, (Py_ssize_t)sizeof(int32_t) * kept);
    return Py_BuildValue("(NN)", pointers, indices);
}

/* the `n_parts` parts of args from item `first`, each a tuple (rows, cols,
   row_offset[, mask]): rows and cols kd_arg arguments of one length, mask
   None or a bool array of that length; their buffers in views (five a part;
   released by the caller) and `parts`; -1 with the error set */
static int kd_parts(PyObject *args, Py_ssize_t first, int n_parts, Py_buffer *views,
                    kd_part *parts) {
    for (int p = 0; p < n_parts; p++) {
        PyObject *part = PyTuple_GET_ITEM(args, first + p);
        Py_ssize_t size = PyTuple_Check(part) ? PyTuple_GET_SIZE(part) : 0;
        if (size != 3 && size != 4) {
            PyErr_SetString(PyExc_TypeError, "a part (rows, cols, row_offset[, mask]) "
                            "expected");
            return -1;
        }
        Py_buffer *v = views + 5 * p;
        Py_ssize_t count_r, count_c;
        if (kd_arg_of(PyTuple_GET_ITEM(part, 0), "rows", v, parts[p].runs, &parts[p].r,
                      &count_r) < 0
            || kd_arg_of(PyTuple_GET_ITEM(part, 1), "cols", v + 2, parts[p].runs + 3,
                         &parts[p].c, &count_c) < 0) return -1;
        if (count_r != count_c) {
            PyErr_SetString(PyExc_ValueError, "rows and cols differ in length");
            return -1;
        }
        parts[p].count = count_r;
        parts[p].at = parts[p].left = 0;
        parts[p].offset = PyLong_AsLongLong(PyTuple_GET_ITEM(part, 2));
        if (PyErr_Occurred()) return -1;
        parts[p].mask = NULL;
        parts[p].node = NULL;
        if (size == 4 && PyTuple_GET_ITEM(part, 3) != Py_None) {
            if (kd_view(PyTuple_GET_ITEM(part, 3), v + 4, 1, 0, "mask") < 0) return -1;
            if (KD_COUNT(v[4]) != count_r) {
                PyErr_SetString(PyExc_ValueError, "a mask not of the entries' length");
                return -1;
            }
            parts[p].mask = v[4].buf;
        }
    }
    return 0;
}

/* csr(n_rows, n_cols, symmetric, part[, part]): the pattern of kd_csr_of with the
   entries (rows + row_offset, cols) of one or two parts (kd_parts) */
static PyObject *kd_csr(PyObject *self, PyObject *args) {
    Py_ssize_t count = PyTuple_Check(args) ? PyTuple_GET_SIZE(args) : 0;
    if (count != 4 && count != 5) {
        PyErr_SetString(PyExc_TypeError, "n_rows, n_cols, symmetric and one or two "
                        "(rows, cols, row_offset[, mask]) expected");
        return NULL;
    }
    Py_ssize_t n_rows = PyLong_AsSsize_t(PyTuple_GET_ITEM(args, 0));
    Py_ssize_t n_cols = PyLong_AsSsize_t(PyTuple_GET_ITEM(args, 1));
    int symmetric = PyObject_IsTrue(PyTuple_GET_ITEM(args, 2));
    if (PyErr_Occurred()) return NULL;
    int n_parts = (int)count - 3;
    kd_part parts[2];
    Py_buffer v[10];
    memset(v, 0, sizeof(v));
    PyObject *result = NULL;
    if (kd_parts(args, 3, n_parts, v, parts) == 0)
        result = kd_csr_of(n_rows, n_cols, parts, n_parts, symmetric);
    kd_release(v, 10);
    return result;
}

/* compressed(node, n_nodes, part[, part]): the pattern of kd_csr_of of the graph
   on n_nodes nodes that joins node[i] and node[j] (and node[j] and node[i]) for
   each entry (i, j) = (rows + row_offset, cols) of the parts (kd_parts) where both
   are >= 0 and they differ: the graph of a symmetric matrix given by its entries,
   its rows grouped, without the matrix's own pattern */
static PyObject *kd_compressed(PyObject *self, PyObject *args) {
    Py_ssize_t count = PyTuple_Check(args) ? PyTuple_GET_SIZE(args) : 0;
    if (count != 3 && count != 4) {
        PyErr_SetString(PyExc_TypeError, "node, n_nodes and one or two (rows, cols, "
                        "row_offset[, mask]) expected");
        return NULL;
    }
    Py_ssize_t n_nodes = PyLong_AsSsize_t(PyTuple_GET_ITEM(args, 1));
    if (n_nodes == -1 && PyErr_Occurred()) return NULL;
    int n_parts = (int)count - 2;
    kd_part parts[2];
    Py_buffer v[11];
    memset(v, 0, sizeof(v));
    PyObject *result = NULL;
    if (kd_view(PyTuple_GET_ITEM(args, 0), &v[10], 4, 0, "node") < 0) return NULL;
    const int32_t *node = v[10].buf;
    Py_ssize_t N = KD_COUNT(v[10]);
    if (kd_parts(args, 2, n_parts, v, parts) < 0) goto done;
    for (int p = 0; p < n_parts; p++) {
        kd_part part = parts[p];
        for (Py_ssize_t e = 0; e < part.count; e++) {
            int64_t i, j;
            if (!kd_part_next(&part, e, &i, &j)) continue;
            if (i < 0 || i >= N || j < 0 || j >= N) {
                PyErr_SetString(PyExc_ValueError, "an entry outside the node array");
                goto done;
            }
            if (node[i] >= n_nodes || node[j] >= n_nodes) {
                PyErr_SetString(PyExc_ValueError, "a node number beyond n_nodes");
                goto done;
            }
        }
    }
    for (int p = 0; p < n_parts; p++) parts[p].node = node;
    result = kd_csr_of(n_nodes, n_nodes, parts, n_parts, 1);
done:
    kd_release(v, 11);
    return result;
}

/* permuted(Ap, hessian_map, jacobian_map, diagonal_map, inverse, hessian_rows,
   hessian_cols, jacobian_rows, jacobian_cols, n): the pattern of K's upper
   triangle in the elimination order (`inverse[i]`: the place of row i of K in
   it), CSC: the Hessian's entries, the Jacobian's (rows n + i) and every
   diagonal entry, repeats merged and each column's rows increasing.  Fills the
   column pointers Ap (int32, N + 1) and the maps (the place of each entry,
   int32), returns the row indices as a buffer of int32. */
enum {P_AP, P_HMAP, P_JMAP, P_DMAP, P_INVERSE, P_HR, P_HC, P_JR, P_JC, P_COUNT};

static PyObject *kd_permuted(PyObject *self, PyObject *args) {
    static const Py_ssize_t size[P_COUNT] = {4, 4, 4, 4, 4, 4, 4, 4, 4};
    static const int writable[P_COUNT] = {1, 1, 1, 1, 0, 0, 0, 0, 0};
    static const char *const names[P_COUNT] = {"Ap", "hessian_map", "jacobian_map",
                                               "diagonal_map", "inverse", "hessian rows",
                                               "hessian cols", "jacobian rows",
                                               "jacobian cols"};
    if (!PyTuple_Check(args) || PyTuple_GET_SIZE(args) != P_COUNT + 1) {
        PyErr_Format(PyExc_TypeError, "%d arguments expected", P_COUNT + 1);
        return NULL;
    }
    Py_ssize_t n = PyLong_AsSsize_t(PyTuple_GET_ITEM(args, P_COUNT));
    if (n == -1 && PyErr_Occurred()) return NULL;
    Py_buffer v[P_COUNT];
    if (kd_views(args, P_COUNT, v, size, writable, names) < 0) return NULL;
    int32_t *Ap = v[P_AP].buf, *hmap = v[P_HMAP].buf, *jmap = v[P_JMAP].buf, *dmap = v[P_DMAP].buf;
    const int32_t *inverse = v[P_INVERSE].buf, *hr = v[P_HR].buf, *hc = v[P_HC].buf;
    const int32_t *jr = v[P_JR].buf, *jc = v[P_JC].buf;
    Py_ssize_t N = KD_COUNT(v[P_INVERSE]), nh = KD_COUNT(v[P_HR]), nj = KD_COUNT(v[P_JR]);
    int fits = KD_COUNT(v[P_AP]) == N + 1 && KD_COUNT(v[P_DMAP]) == N && n >= 0 && n <= N
        && KD_COUNT(v[P_HC]) == nh && KD_COUNT(v[P_HMAP]) == nh
        && KD_COUNT(v[P_JC]) == nj && KD_COUNT(v[P_JMAP]) == nj;
    for (Py_ssize_t i = 0; fits && i < N; i++) fits = inverse[i] >= 0 && inverse[i] < N;
    for (Py_ssize_t e = 0; fits && e < nh; e++)
        fits = hr[e] >= 0 && hr[e] < n && hc[e] >= 0 && hc[e] < n;
    for (Py_ssize_t e = 0; fits && e < nj; e++)
        fits = jr[e] >= 0 && jr[e] < N - n && jc[e] >= 0 && jc[e] < n;
    if (!fits) {
        kd_release(v, P_COUNT);
        PyErr_SetString(PyExc_ValueError, "permuted: sizes or indices that do not fit");
        return NULL;
    }
    Py_ssize_t total = nh + nj + N;
    if (total >= INT32_MAX) {
        kd_release(v, P_COUNT);
        PyErr_SetString(PyExc_ValueError, "K has too many entries for 32-bit indices");
        return NULL;
    }
    size_t room = (size_t)(total > 0 ? total : 1);
    size_t rowptr_bytes = sizeof(int64_t) * ((size_t)N + 1), room_bytes = sizeof(int32_t) * room;
    int64_t *rowptr = kd_scratch(rowptr_bytes, 1);
    int32_t *by_row = kd_scratch(room_bytes, 0), *by_col = kd_scratch(room_bytes, 0);
    if (rowptr == NULL || by_row == NULL || by_col == NULL) {
        kd_unscratch(rowptr, rowptr_bytes);
        kd_unscratch(by_row, room_bytes);
        kd_unscratch(by_col, room_bytes);
        kd_release(v, P_COUNT);
        return PyErr_NoMemory();
    }
    int64_t kept = 0;
    Py_BEGIN_ALLOW_THREADS
/* entry e's two places in the order: the Hessian's, the Jacobian's, the diagonal's */
#define KD_ENDS(e, a, b) do {                                                      \
        if ((e) < nh) { a = inverse[hr[e]]; b = inverse[hc[e]]; }                  \
        else if ((e) < nh + nj) { a = inverse[n + jr[(e) - nh]];                   \
                                  b = inverse[jc[(e) - nh]]; }                     \
        else { a = b = inverse[(e) - nh - nj]; }                                   \
        if (a > b) { int32_t t_ = a; a = b; b = t_; }                              \
    } while (0)
    for (Py_ssize_t k = 0; k <= N; k++) Ap[k] = 0;
    for (Py_ssize_t e = 0; e < total; e++) {
        int32_t low, high;
        KD_ENDS(e, low, high);
        rowptr[low + 1]++;
        Ap[high + 1]++;
    }
    for (Py_ssize_t k = 0; k < N; k++) {
        rowptr[k + 1] += rowptr[k];
        Ap[k + 1] += Ap[k];
    }
    for (Py_ssize_t e = 0; e < total; e++) {  /* by row (the lower end) */
        int32_t low, high;
        KD_ENDS(e, low, high);
        by_row[rowptr[low]++] = (int32_t)e;
    }
    for (Py_ssize_t q = 0; q < total; q++) {  /* then by column, rows increasing */
        int32_t low, high, e = by_row[q];
        KD_ENDS(e, low, high);
        by_col[Ap[high]++] = e;
    }
    /* Ap[k], advanced by the fill, is the end of column k's entries in by_col; a
       column's repeats are next to each other: one place each; the rows of the
       places written over by_row (no longer needed) */
    int64_t begin = 0;
    for (Py_ssize_t k = 0; k < N; k++) {
        int64_t end = Ap[k], first = kept;
        for (int64_t q = begin; q < end; q++) {
            int32_t low, high, e = by_col[q];
            KD_ENDS(e, low, high);
            if (kept == first || by_row[kept - 1] != low) by_row[kept++] = low;
            int32_t place = (int32_t)(kept - 1);
            if (e < nh) hmap[e] = place;
            else if (e < nh + nj) jmap[e - nh] = place;
            else dmap[e - nh - nj] = place;
        }
        Ap[k] = (int32_t)first;
        begin = end;
    }
    Ap[N] = (int32_t)kept;
#undef KD_ENDS
    Py_END_ALLOW_THREADS
    kd_unscratch(rowptr, rowptr_bytes);
    kd_unscratch(by_col, room_bytes);
    PyObject *rows = kd_int32_bytes(by_row, (Py_ssize_t)kept);
    kd_unscratch(by_row, room_bytes);
    kd_release(v, P_COUNT);
    return rows;
}

/* a breadth-first search of root's component, queued into q from 0 and marked
   `mark` in `seen`: returns the component's size and sets *last to the place in
   q of the first node of the last level and *depth to the number of levels */
static Py_ssize_t kd_levels(int32_t root, const int32_t *indptr, const int32_t *indices,
                            int32_t *seen, int32_t mark, int32_t *q, Py_ssize_t *last,
                            Py_ssize_t *depth) {
    Py_ssize_t head = 0, tail = 1;
    q[0] = root;
    seen[root] = mark;
    *depth = 0;
    while (head < tail) {
        Py_ssize_t end = tail;
        *last = head;
        (*depth)++;
        for (; head < end; head++)
            for (int32_t p = indptr[q[head]]; p < indptr[q[head] + 1]; p++)
                if (seen[indices[p]] != mark) {
                    seen[indices[p]] = mark;
                    q[tail++] = indices[p];
                }
    }
    return tail;
}

/* cuthill_mckee(order, indptr, indices, start): fills order (int32, N) with the
   Cuthill-McKee order of the symmetric pattern (indptr, indices) (int32, no
   diagonal needed): each component numbered by levels of a breadth-first search,
   every node's new neighbours by increasing degree (then index), from a
   pseudo-peripheral node (George and Liu's: from the component's node of least
   degree, then the least-degree node of the last level while that adds levels),
   or from `start` (>= 0) for its own component, which comes first.  The other
   components follow by their least-degree node. */
static PyObject *kd_cuthill_mckee(PyObject *self, PyObject *args) {
    static const Py_ssize_t size[3] = {4, 4, 4};
    static const int writable[3] = {1, 0, 0};
    static const char *const names[3] = {"order", "indptr", "indices"};
    Py_buffer v[3];
    if (!PyTuple_Check(args) || PyTuple_GET_SIZE(args) != 4) {
        PyErr_SetString(PyExc_TypeError, "order, indptr, indices and start expected");
        return NULL;
    }
    Py_ssize_t start = PyLong_AsSsize_t(PyTuple_GET_ITEM(args, 3));
    if (start == -1 && PyErr_Occurred()) return NULL;
    if (kd_views(args, 3, v, size, writable, names) < 0) return NULL;
    int32_t *order = v[0].buf;
    const int32_t *indptr = v[1].buf, *indices = v[2].buf;
    Py_ssize_t N = KD_COUNT(v[0]), nnz = KD_COUNT(v[2]);
    int bad = KD_COUNT(v[1]) != N + 1 || start >= N || indptr[0] != 0 || indptr[N] != nnz;
    for (Py_ssize_t i = 0; i < N && !bad; i++)  /* (a degree above N: repeats) */
        bad = indptr[i + 1] < indptr[i] || indptr[i + 1] - indptr[i] > N;
    for (Py_ssize_t p = 0; p < nnz && !bad; p++) bad = indices[p] < 0 || indices[p] >= N;
    if (bad) {
        kd_release(v, 3);
        PyErr_SetString(PyExc_ValueError, "cuthill_mckee: a pattern of N nodes (no row "
                        "longer than N) and a start below N expected");
        return NULL;
    }
    /* (int32: N < 2^31 and the marks start again before they would pass it) */
    size_t seen_bytes = sizeof(int32_t) * (size_t)(N > 0 ? N : 1);
    size_t seeds_bytes = sizeof(int32_t) * (size_t)(N + 1);
    size_t count_bytes = sizeof(int32_t) * (size_t)(N + 1);
    int32_t *seen = kd_scratch(seen_bytes, 0);
    int32_t *seeds = kd_scratch(seeds_bytes, 0);
    int32_t *count = kd_scratch(count_bytes, 1);
    if (seen == NULL || seeds == NULL || count == NULL) {
        kd_unscratch(seen, seen_bytes);
        kd_unscratch(seeds, seeds_bytes);
        kd_unscratch(count, count_bytes);
        kd_release(v, 3);
        return PyErr_NoMemory();
    }
    Py_BEGIN_ALLOW_THREADS
#define KD_DEGREE(i) (indptr[(i) + 1] - indptr[i])
    /* the nodes by degree, then index (a counting sort), as the seeds */
    for (Py_ssize_t i = 0; i < N; i++) count[KD_DEGREE(i)]++;
    for (Py_ssize_t d = 0, sum = 0; d <= N; d++) {
        int32_t c = count[d];
        count[d] = (int32_t)sum;
        sum += c;
    }
    for (Py_ssize_t i = 0; i < N; i++) seeds[count[KD_DEGREE(i)]++] = (int32_t)i;
    for (Py_ssize_t i = 0; i < N; i++) seen[i] = -1;
    int32_t mark = 0;  /* each search's; a node placed keeps one >= 0 */
    Py_ssize_t placed = 0;
    for (Py_ssize_t s = -1; s < N; s++) {
        int32_t root = (int32_t)(s < 0 ? start : seeds[s]);
        if (root < 0 || seen[root] >= 0) continue;
        if (mark > INT32_MAX - 64) {  /* (a component takes at most 34 marks) */
            for (Py_ssize_t i = 0; i < N; i++)
                if (seen[i] > 0) seen[i] = 0;  /* placed: still >= 0 */
            mark = 0;
        }
        int32_t *q = order + placed;
        Py_ssize_t last, depth, members;
        members = kd_levels(root, indptr, indices, seen, ++mark, q, &last, &depth);
        for (int tries = 0; s >= 0 && tries < 32; tries++) {  /* George and Liu */
            int32_t best = q[last];
            for (Py_ssize_t p = last + 1; p < members; p++)
                if (KD_DEGREE(q[p]) < KD_DEGREE(best)) best = q[p];
            Py_ssize_t best_last, best_depth;
            kd_levels(best, indptr, indices, seen, ++mark, q, &best_last, &best_depth);
            if (best_depth <= depth) break;
            root = best;
            last = best_last;
            depth = best_depth;
        }
        /* Cuthill-McKee from root: each node's new neighbours by degree */
        int32_t visit = ++mark;
        Py_ssize_t tail = 1;
        q[0] = root;
        seen[root] = visit;
        for (Py_ssize_t head = 0; head < tail; head++) {
            Py_ssize_t first = tail;
            for (int32_t p = indptr[q[head]]; p < indptr[q[head] + 1]; p++)
                if (seen[indices[p]] != visit) {
                    seen[indices[p]] = visit;
                    int32_t j = indices[p];
                    Py_ssize_t t = tail++;
                    for (; t > first && KD_DEGREE(q[t - 1]) > KD_DEGREE(j); t--) q[t] = q[t - 1];
                    q[t] = j;
                }
        }
        placed += tail;
    }
#undef KD_DEGREE
    Py_END_ALLOW_THREADS
    kd_unscratch(seen, seen_bytes);
    kd_unscratch(seeds, seeds_bytes);
    kd_unscratch(count, count_bytes);
    kd_release(v, 3);
    Py_RETURN_NONE;
}

/* ---------------------------------------------------------------- envelope */
/* (the storage of EnvelopeKKT's L: the comment of KD_FIRST, above) */

static const char *const kd_structure_names[4] = {"hessian rows", "hessian cols",
                                                  "jacobian rows", "jacobian cols"};

/* the buffers of the first `n_buffers` arguments (kd_views) and the four
   structure indices after them (kd_index_args) in v (n_buffers + 8 views,
   released here on an error), the indices' arrays' runs in runs (12): -1
   with the error set */
static int kd_structure_views(PyObject *args, int n_buffers, const Py_ssize_t *size,
                              const int *writable, const char *const *names, Py_buffer *v,
                              int64_t *runs, kd_index *index, Py_ssize_t *counts) {
    memset(v, 0, sizeof(Py_buffer) * (size_t)(n_buffers + 8));
    if (kd_views(args, n_buffers, v, size, writable, names) < 0) return -1;
    if (kd_index_args(args, n_buffers, 4, kd_structure_names, v + n_buffers, runs, index,
                      counts) < 0) {
        kd_release(v, n_buffers + 8);
        return -1;
    }
    return 0;
}

/* envelope(rowptr, inverse, pair, hessian_rows, hessian_cols, jacobian_rows,
   jacobian_cols, n): the envelope of the permuted K's lower triangle
   (inverse[r] the place of K's row r; row n + i the constraint i): fills
   rowptr (int32, N + 1) when the total is below 2^31 - 1; returns (total,
   K's distinct entries off the diagonal) */
static PyObject *kd_envelope(PyObject *self, PyObject *args) {
    if (!PyTuple_Check(args) || PyTuple_GET_SIZE(args) != 8) {
        PyErr_SetString(PyExc_TypeError, "8 arguments expected");
        return NULL;
    }
    Py_ssize_t n = PyLong_AsSsize_t(PyTuple_GET_ITEM(args, 7));
    if (n == -1 && PyErr_Occurred()) return NULL;
    static const Py_ssize_t size[3] = {4, 4, 1};
    static const int writable[3] = {1, 0, 0};
    static const char *const names[3] = {"rowptr", "inverse", "pair"};
    Py_buffer v[11];
    kd_index start[4];
    int64_t runs[12];
    Py_ssize_t counts[4];
    if (kd_structure_views(args, 3, size, writable, names, v, runs, start, counts) < 0)
        return NULL;
    int32_t *rowptr = v[0].buf;
    const int32_t *inv = v[1].buf;
    const int8_t *pair = v[2].buf;
    Py_ssize_t N = KD_COUNT(v[1]), nh = counts[0], nj = counts[2];
    if (KD_COUNT(v[0]) != N + 1 || KD_COUNT(v[2]) != N || counts[1] != nh
        || counts[3] != nj || n < 0 || n > N) {
        kd_release(v, 11);
        PyErr_SetString(PyExc_ValueError, "envelope: arrays of inconsistent sizes");
        return NULL;
    }
    int64_t total = 0, distinct = 0;
    int fits = 1;
    /* K's entries: the Hessian's, then the Jacobian's (rows n + i) */
    kd_part entries[2] = {kd_part_of(start[0], start[1], nh, 0),
                          kd_part_of(start[2], start[3], nj, n)};
    Py_BEGIN_ALLOW_THREADS
    /* each row's first column, in rowptr[k + 1] until the widths are summed */
    for (Py_ssize_t k = 0; k < N; k++) rowptr[k + 1] = (int32_t)k;
    for (int q = 0; q < 2; q++) {
        kd_part part = entries[q];
        for (Py_ssize_t e = 0; e < part.count; e++) {
            int64_t i, j;
            kd_part_next(&part, e, &i, &j);
            int32_t a = inv[i], b = inv[j];
            int32_t high = a > b ? a : b, low = a > b ? b : a;
            if (low < rowptr[high + 1]) rowptr[high + 1] = low;
        }
    }
    for (Py_ssize_t k = 0; k < N; k++) {
        int32_t f = rowptr[k + 1];
        if (pair[k] == 2 && f > k - 1) f = (int32_t)(k - 1);  /* the block's own entry */
        if (f < k && pair[f] == 2) f--;  /* not half a pair's columns */
        rowptr[k + 1] = f;
    }
    rowptr[0] = 0;
    for (Py_ssize_t k = 0; k < N; k++) {
        total += (int64_t)k - rowptr[k + 1];
        if (total >= INT32_MAX) fits = 0;
        if (fits) rowptr[k + 1] = (int32_t)total;
    }
    Py_END_ALLOW_THREADS
    if (fits && total > 0) {  /* K's distinct places off the diagonal */
        uint8_t *mark = kd_scratch((size_t)total, 1);
        if (mark == NULL) {
            kd_release(v, 11);
            return PyErr_NoMemory();
        }
        for (int q = 0; q < 2; q++) {
            kd_part part = entries[q];
            for (Py_ssize_t e = 0; e < part.count; e++) {
                int64_t i, j;
                kd_part_next(&part, e, &i, &j);
                int32_t a = inv[i], b = inv[j];
                if (a == b) continue;
                int64_t p = KD_PLACE(rowptr, a, b);
                distinct += !mark[p];
                mark[p] = 1;
            }
        }
        kd_unscratch(mark, (size_t)total);
    }
    kd_release(v, 11);
    return Py_BuildValue("LL", (long long)total, (long long)distinct);
}

/* envelope_factor(Lx, rowptr, D, pair, permutation, hessian_values, jacobian_values,
   diagonal_x, diagonal_x_index, diagonal_c, zero, hessian_rows, hessian_cols, jacobian_rows,
   jacobian_cols, tolerance, n, x_constant, x_added, c_constant), the indices
   each an int32 array or (runs, table) (kd_arg_of): the values
   summed into the envelope (as factor sums them into Ax: the Hessian's, the
   Jacobian's, diagonal_x, minus diagonal_c) and factored in place, row by
   row: w = L(f:k, f:k)^-1 K(f:k, k) by a dot product per column, then row k
   of L is D^-1 w (blockwise) and d_k = K(k, k) - (row k of L) w; the pivots
   judged as factor judges them.  Returns (n_positive, n_negative, n_zero,
   K's largest magnitude) */
enum {V_LX, V_ROWPTR, V_D, V_PAIR, V_PERM, V_HV, V_JV, V_DX, V_DXI, V_DC, V_ZERO, V_COUNT};

static PyObject *kd_envelope_factor(PyObject *self, PyObject *args) {
    if (!PyTuple_Check(args) || PyTuple_GET_SIZE(args) != V_COUNT + 9) {
        PyErr_Format(PyExc_TypeError, "%d arguments expected", V_COUNT + 9);
        return NULL;
    }
    double tolerance = PyFloat_AsDouble(PyTuple_GET_ITEM(args, V_COUNT + 4));
    if (tolerance == -1.0 && PyErr_Occurred()) return NULL;
    static const Py_ssize_t size[V_COUNT] = {8, 4, 8, 1, 4, 8, 8, 8, 4, 8, 1};
    static const int writable[V_COUNT] = {1, 0, 1, 0, 0, 0, 0, 0, 0, 0, 1};
    static const char *const names[V_COUNT] = {
        "Lx", "rowptr", "D", "pair", "permutation", "hessian_values", "jacobian_values",
        "diagonal_x", "diagonal_x index", "diagonal_c", "zero"};
    Py_buffer v[V_COUNT + 8];
    kd_index index[4];
    int64_t runs[12];
    Py_ssize_t counts[4];
    if (kd_structure_views(args, V_COUNT, size, writable, names, v, runs, index, counts) < 0)
        return NULL;
    double *Lx = v[V_LX].buf, *D = v[V_D].buf;
    const int32_t *rowptr = v[V_ROWPTR].buf, *perm = v[V_PERM].buf;
    const int8_t *pair = v[V_PAIR].buf;
    const double *hv = v[V_HV].buf, *jv = v[V_JV].buf;
    int8_t *zero = v[V_ZERO].buf;
    Py_ssize_t N = KD_COUNT(v[V_D]), nh = KD_COUNT(v[V_HV]), nj = KD_COUNT(v[V_JV]);
    kd_diagonals diagonals;
    if (kd_diagonals_of(args, V_COUNT + 5, &v[V_DX], &v[V_DXI], &v[V_DC], N,
                        &diagonals) < 0) {
        kd_release(v, V_COUNT + 8);
        return NULL;
    }
    Py_ssize_t nx = diagonals.n, nc = N - nx;
    kd_index hr = index[0], hc = index[1], jr = index[2], jc = index[3];
    if (KD_COUNT(v[V_PAIR]) != N
        || KD_COUNT(v[V_PERM]) != N || KD_COUNT(v[V_ROWPTR]) != N + 1
        || KD_COUNT(v[V_ZERO]) < N || KD_COUNT(v[V_LX]) != (N ? rowptr[N] : 0)
        || counts[0] != nh || counts[1] != nh || counts[2] != nj || counts[3] != nj) {
        kd_release(v, V_COUNT + 8);
        PyErr_SetString(PyExc_ValueError, "envelope_factor: arrays of inconsistent sizes");
        return NULL;
    }
    /* the workspace, N doubles (each column's largest magnitude below the
       diagonal) and the order's inverse (the place of each row of K in it, N
       int32): held only while this call runs */
    size_t colmax_bytes = sizeof(double) * (size_t)(N > 0 ? N : 1);
    size_t inv_bytes = sizeof(int32_t) * (size_t)(N > 0 ? N : 1);
    double *colmax = kd_scratch(colmax_bytes, 0);
    int32_t *inv = kd_scratch(inv_bytes, 0);
    if (colmax == NULL || inv == NULL) {
        kd_unscratch(colmax, colmax_bytes);
        kd_unscratch(inv, inv_bytes);
        kd_release(v, V_COUNT + 8);
        return PyErr_NoMemory();
    }
    for (Py_ssize_t k = 0; k < N; k++) inv[k] = -1;
    for (Py_ssize_t k = 0; k < N; k++) {
        int32_t row = perm[k];
        if (row < 0 || row >= N || inv[row] >= 0) {
            kd_unscratch(colmax, colmax_bytes);
            kd_unscratch(inv, inv_bytes);
            kd_release(v, V_COUNT + 8);
            PyErr_SetString(PyExc_ValueError, "envelope_factor: permutation is not one");
            return NULL;
        }
        inv[row] = (int32_t)k;
    }
    double largest = 0.0, off_before = 0.0;
    kd_pivots pivots = {tolerance, 1.0, 0.0, 0, 0, 0};
    Py_BEGIN_ALLOW_THREADS
    memset(Lx, 0, sizeof(double) * (size_t)(N ? rowptr[N] : 0));
    for (Py_ssize_t k = 0; k < N; k++) D[k] = 0.0;
    int32_t rbuf[KD_BLOCK], cbuf[KD_BLOCK];
    for (Py_ssize_t e0 = 0; e0 < nh; e0 += KD_BLOCK) {
        Py_ssize_t count = nh - e0 < KD_BLOCK ? nh - e0 : KD_BLOCK;
        const int32_t *R = kd_take(&hr, rbuf, count), *C = kd_take(&hc, cbuf, count);
        const double *values = hv + e0;
        for (Py_ssize_t t = 0; t < count; t++) {
            int32_t a = inv[R[t]], b = inv[C[t]];
            if (a == b) D[a] += values[t];
            else Lx[KD_PLACE(rowptr, a, b)] += values[t];
        }
    }
    for (Py_ssize_t e0 = 0; e0 < nj; e0 += KD_BLOCK) {
        Py_ssize_t count = nj - e0 < KD_BLOCK ? nj - e0 : KD_BLOCK;
        const int32_t *R = kd_take(&jr, rbuf, count), *C = kd_take(&jc, cbuf, count);
        const double *values = jv + e0;
        for (Py_ssize_t t = 0; t < count; t++) {
            int32_t a = inv[nx + R[t]], b = inv[C[t]];
            Lx[KD_PLACE(rowptr, a, b)] += values[t];
        }
    }
    for (Py_ssize_t j = 0, at = 0; j < nx; j++) D[inv[j]] += kd_dx(&diagonals, j, &at);
    for (Py_ssize_t i = 0; i < nc; i++) D[inv[nx + i]] -= kd_dc(&diagonals, i);
    /* K's largest magnitude, and each column's below the diagonal off a pair's
       block (a row's own part is read at its step, before it is overwritten:
       the rows below are still K's) */
    for (Py_ssize_t k = 0; k < N; k++) {
        colmax[k] = 0.0;
        if (fabs(D[k]) > largest) largest = fabs(D[k]);
    }
    for (Py_ssize_t k = 0; k < N; k++) {
        int64_t f = KD_FIRST(rowptr, k);
        const double *R = Lx + rowptr[k];
        for (int64_t j = f; j < k; j++) {
            double a = fabs(R[j - f]);
            if (a > largest) largest = a;
            if (!(pair[k] == 2 && j == k - 1) && a > colmax[j]) colmax[j] = a;
        }
    }
    pivots.largest = largest == 0.0 ? 1.0 : largest;
    for (Py_ssize_t k = 0; k < N; k++) {
        int64_t f = KD_FIRST(rowptr, k), width = k - f;
        double *R = Lx + rowptr[k];
        /* the largest magnitudes in row k of K (both triangles), and off the
           diagonal and off a pair's block: its own part, the column's below,
           and a pair's block entry (in row k + 1) */
        double row_max = fabs(D[k]), off_max = colmax[k];
        for (int64_t t = 0; t < width; t++) {
            double a = fabs(R[t]);
            if (a > row_max) row_max = a;
            if (!(pair[k] == 2 && t == width - 1) && a > off_max) off_max = a;
        }
        if (off_max > row_max) row_max = off_max;
        if (pair[k] == 1 && fabs(Lx[KD_SLOT(rowptr, k)]) > row_max)
            row_max = fabs(Lx[KD_SLOT(rowptr, k)]);
        /* w = L(f:k, f:k)^-1 K(f:k, k), in place of K's row */
        for (int64_t t = 0; t < width; t++) {
            int64_t j = f + t, fj = KD_FIRST(rowptr, j), s = fj > f ? fj : f;
            const double *Rj = Lx + rowptr[j] + (s - fj), *ws = R + (s - f);
            double sum = R[t];
            /* row j's entries of L from column s (not its block's slot) */
            int64_t count = fj + KD_WIDTH(rowptr, pair, j) - s;
            for (int64_t q = 0; q < count; q++) sum -= Rj[q] * ws[q];
            R[t] = sum;
        }
        /* row k of L = D^-1 w, blockwise; the pivot d = K(k, k) - l . w */
        double d = D[k], terms = fabs(D[k]);
        for (int64_t t = 0; t < width; t++) {
            int64_t j = f + t;
            double wj = R[t];
            if (pair[j] == 1) {
                if (j == k - 1) continue;  /* k's own partner: w_j is the block's entry */
                /* [l_j, l_{j+1}] = B^-1 [w_j, w_{j+1}] */
                double w1 = R[t + 1], a = D[j], e = Lx[KD_SLOT(rowptr, j)], b = D[j + 1];
                double det = a * b - e * e;
                double l0 = (b * wj - e * w1) / det, l1 = (a * w1 - e * wj) / det;
                d -= l0 * wj + l1 * w1;
                terms += fabs(l0 * wj) + fabs(l1 * w1);
                R[t] = l0;
                R[++t] = l1;
            } else {
                double l = wj / D[j];
                d -= l * wj;
                terms += fabs(l * wj);
                R[t] = l;
            }
        }
        kd_judge(&pivots, k, d, terms, pair, D, pair[k] == 2 ? R + width - 1 : NULL, row_max,
                 off_max, off_before, zero);
        off_before = off_max;
    }
    Py_END_ALLOW_THREADS
    kd_unscratch(colmax, colmax_bytes);
    kd_unscratch(inv, inv_bytes);
    kd_release(v, V_COUNT + 8);
    return Py_BuildValue("nnnd", pivots.n_positive, pivots.n_negative, pivots.n_zero,
                         largest);
}

/* envelope_solve(x, rowptr, Lx, D, pair, permutation, k): solve's solution
   of the k right-hand sides in x with envelope factors, in x's own storage:
   the sweeps read and write x through the order (row k of the permuted
   system at x[permutation[k]]), no scratch.  (The same sums, in the same
   order, as gathering x into a permuted copy; as fast at 100 to 100,000
   swing-up nodes, measured by hand.  Permuting x in place along the order's
   cycles instead took 1.8-2.3 times as long at 10,000 nodes: a chain of
   dependent loads that jump between K's parts.) */
static PyObject *kd_envelope_solve(PyObject *self, PyObject *args) {
    if (!PyTuple_Check(args) || PyTuple_GET_SIZE(args) != 7) {
        PyErr_SetString(PyExc_TypeError, "7 arguments expected");
        return NULL;
    }
    Py_ssize_t columns = PyLong_AsSsize_t(PyTuple_GET_ITEM(args, 6));
    if (columns == -1 && PyErr_Occurred()) return NULL;
    static const Py_ssize_t size[6] = {8, 4, 8, 8, 1, 4};
    static const int writable[6] = {1, 0, 0, 0, 0, 0};
    static const char *const names[6] = {"rhs", "rowptr", "Lx", "D", "pair", "permutation"};
    Py_buffer v[6];
    if (kd_views(args, 6, v, size, writable, names) < 0) return NULL;
    double *X = v[0].buf;
    const int32_t *rowptr = v[1].buf, *perm = v[5].buf;
    const double *Lx = v[2].buf, *D = v[3].buf;
    const int8_t *pair = v[4].buf;
    Py_ssize_t N = KD_COUNT(v[3]);
    if (columns < 0 || KD_COUNT(v[0]) != columns * N || KD_COUNT(v[1]) != N + 1
        || KD_COUNT(v[2]) != (N ? rowptr[N] : 0) || KD_COUNT(v[4]) != N
        || KD_COUNT(v[5]) != N) {
        kd_release(v, 6);
        PyErr_SetString(PyExc_ValueError, "rhs: not of the factored size");
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t c = 0; c < columns; c++) {
        double *x = X + c * N;
        for (Py_ssize_t k = 0; k < N; k++) {  /* L z = b, row by row */
            int64_t f = KD_FIRST(rowptr, k), width = KD_WIDTH(rowptr, pair, k);
            const double *R = Lx + rowptr[k];
            const int32_t *at = perm + f;
            double sum = x[perm[k]];
            for (int64_t t = 0; t < width; t++) sum -= R[t] * x[at[t]];
            x[perm[k]] = sum;
        }
        for (Py_ssize_t j = 0; j < N; j++) {  /* D y = z, blockwise */
            if (pair[j] == 1) {
                double e = Lx[KD_SLOT(rowptr, j)];
                double a = D[j], b = D[j + 1], det = a * b - e * e;
                double w0 = x[perm[j]], w1 = x[perm[j + 1]];
                x[perm[j]] = (b * w0 - e * w1) / det;
                x[perm[j + 1]] = (a * w1 - e * w0) / det;
                j++;
            } else {
                x[perm[j]] /= D[j];
            }
        }
        for (Py_ssize_t k = N - 1; k >= 0; k--) {  /* L^T x = y, row k's part at once */
            int64_t f = KD_FIRST(rowptr, k), width = KD_WIDTH(rowptr, pair, k);
            const double *R = Lx + rowptr[k];
            const int32_t *at = perm + f;
            double wk = x[perm[k]];
            for (int64_t t = 0; t < width; t++) x[at[t]] -= R[t] * wk;
        }
    }
    Py_END_ALLOW_THREADS
    kd_release(v, 6);
    Py_RETURN_NONE;
}

/* structured_matvec(y, x, hessian_values, jacobian_values, diagonal_x,
   diagonal_x_index, diagonal_c, hessian_rows, hessian_cols, jacobian_rows, jacobian_cols, n,
   x_constant, x_added, c_constant), the indices as envelope_factor takes
   them: y = K x from the values as envelope_factor took them (K's own
   order) */
enum {M_Y, M_X, M_HV, M_JV, M_DX, M_DXI, M_DC, M_COUNT};

static PyObject *kd_structured_matvec(PyObject *self, PyObject *args) {
    if (!PyTuple_Check(args) || PyTuple_GET_SIZE(args) != M_COUNT + 8) {
        PyErr_Format(PyExc_TypeError, "%d arguments expected", M_COUNT + 8);
        return NULL;
    }
    static const Py_ssize_t size[M_COUNT] = {8, 8, 8, 8, 8, 4, 8};
    static const int writable[M_COUNT] = {1, 0, 0, 0, 0, 0, 0};
    static const char *const names[M_COUNT] = {"y", "x", "hessian_values", "jacobian_values",
                                               "diagonal_x", "diagonal_x index",
                                               "diagonal_c"};
    Py_buffer v[M_COUNT + 8];
    kd_index index[4];
    int64_t runs[12];
    Py_ssize_t counts[4];
    if (kd_structure_views(args, M_COUNT, size, writable, names, v, runs, index, counts) < 0)
        return NULL;
    double *y = v[M_Y].buf;
    const double *x = v[M_X].buf, *hv = v[M_HV].buf, *jv = v[M_JV].buf;
    Py_ssize_t N = KD_COUNT(v[M_Y]), nh = KD_COUNT(v[M_HV]), nj = KD_COUNT(v[M_JV]);
    kd_diagonals diagonals;
    if (kd_diagonals_of(args, M_COUNT + 4, &v[M_DX], &v[M_DXI], &v[M_DC], N,
                        &diagonals) < 0) {
        kd_release(v, M_COUNT + 8);
        return NULL;
    }
    Py_ssize_t nx = diagonals.n, nc = N - nx;
    kd_index hr = index[0], hc = index[1], jr = index[2], jc = index[3];
    if (KD_COUNT(v[M_X]) != N || counts[0] != nh || counts[1] != nh || counts[2] != nj
        || counts[3] != nj) {
        kd_release(v, M_COUNT + 8);
        PyErr_SetString(PyExc_ValueError, "structured_matvec: arrays of inconsistent sizes");
        return NULL;
    }

    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t k = 0, at = 0; k < nx; k++) y[k] = kd_dx(&diagonals, k, &at) * x[k];
    for (Py_ssize_t i = 0; i < nc; i++) y[nx + i] = -kd_dc(&diagonals, i) * x[nx + i];
    int32_t rbuf[KD_BLOCK], cbuf[KD_BLOCK];
    for (Py_ssize_t e0 = 0; e0 < nh; e0 += KD_BLOCK) {
        Py_ssize_t count = nh - e0 < KD_BLOCK ? nh - e0 : KD_BLOCK;
        const int32_t *R = kd_take(&hr, rbuf, count), *C = kd_take(&hc, cbuf, count);
        const double *values = hv + e0;
        for (Py_ssize_t t = 0; t < count; t++) {
            int32_t r = R[t], c = C[t];
            y[r] += values[t] * x[c];
            if (r != c) y[c] += values[t] * x[r];
        }
    }
    for (Py_ssize_t e0 = 0; e0 < nj; e0 += KD_BLOCK) {
        Py_ssize_t count = nj - e0 < KD_BLOCK ? nj - e0 : KD_BLOCK;
        const int32_t *R = kd_take(&jr, rbuf, count), *C = kd_take(&jc, cbuf, count);
        const double *values = jv + e0;
        for (Py_ssize_t t = 0; t < count; t++) {
            int32_t r = (int32_t)nx + R[t], c = C[t];
            y[r] += values[t] * x[c];
            y[c] += values[t] * x[r];
        }
    }
    Py_END_ALLOW_THREADS
    kd_release(v, M_COUNT + 8);
    Py_RETURN_NONE;
}

/* transpose_product(out, values, y, rows, cols), the indices as
   envelope_factor takes them: out = J^T y, J's entries (rows, cols, values),
   out set to zero, then out[cols[e]] += values[e] * y[rows[e]] entry by entry
   (SciPy's product of a COO matrix, the same sums in the same order) */
static PyObject *kd_transpose_product(PyObject *self, PyObject *args) {
    static const Py_ssize_t size[3] = {8, 8, 8};
    static const int writable[3] = {1, 0, 0};
    static const char *const names[3] = {"out", "values", "y"};
    static const char *const index_names[2] = {"rows", "cols"};
    if (!PyTuple_Check(args) || PyTuple_GET_SIZE(args) != 5) {
        PyErr_SetString(PyExc_TypeError, "5 arguments expected");
        return NULL;
    }
    Py_buffer v[7];
    memset(v, 0, sizeof(v));
    if (kd_views(args, 3, v, size, writable, names) < 0) return NULL;
    kd_index index[2];
    int64_t runs[6];
    Py_ssize_t counts[2];
    if (kd_index_args(args, 3, 2, index_names, v + 3, runs, index, counts) < 0) {
        kd_release(v, 7);
        return NULL;
    }
    double *out = v[0].buf;
    const double *values = v[1].buf, *y = v[2].buf;
    Py_ssize_t n = KD_COUNT(v[0]), m = KD_COUNT(v[2]), nnz = KD_COUNT(v[1]);
    if (counts[0] != nnz || counts[1] != nnz) {
        kd_release(v, 7);
        PyErr_SetString(PyExc_ValueError, "transpose_product: indices not of the values' "
                        "length");
        return NULL;
    }
    kd_index rows = index[0], cols = index[1];
    int32_t rbuf[KD_BLOCK], cbuf[KD_BLOCK];
    int outside = 0;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t k = 0; k < n; k++) out[k] = 0.0;
    /* the entries checked as they come, a block before its products (this
       product takes no other check) */
    for (Py_ssize_t e0 = 0; e0 < nnz && !outside; e0 += KD_BLOCK) {
        Py_ssize_t count = nnz - e0 < KD_BLOCK ? nnz - e0 : KD_BLOCK;
        const int32_t *R = kd_take(&rows, rbuf, count), *C = kd_take(&cols, cbuf, count);
        for (Py_ssize_t t = 0; t < count; t++)
            outside |= R[t] < 0 || R[t] >= m || C[t] < 0 || C[t] >= n;
        if (outside) break;
        const double *vals = values + e0;
        for (Py_ssize_t t = 0; t < count; t++) out[C[t]] += vals[t] * y[R[t]];
    }
    Py_END_ALLOW_THREADS
    if (outside) {
        kd_release(v, 7);
        PyErr_Format(PyExc_ValueError, "transpose_product: an entry outside the %zd x %zd "
                     "matrix", m, n);
        return NULL;
    }
    kd_release(v, 7);
    Py_RETURN_NONE;
}

static PyMethodDef kd_methods[] = {
    {"symbolic", kd_symbolic, METH_VARARGS, "elimination tree and column counts"},
    {"factor", kd_factor, METH_VARARGS, "scatter the values, factor L D L^T, the inertia"},
    {"solve", kd_solve, METH_VARARGS, "solve with the factors, in place"},
    {"matvec", kd_matvec, METH_VARARGS, "y = K x from the stored values"},
    {"invalid", kd_invalid, METH_VARARGS, "the first entry not finite, or negative"},
    {"error_reductions", kd_error_reductions, METH_VARARGS,
     "the optimality error's sums and maxima"},
    {"csr", kd_csr, METH_VARARGS, "a CSR pattern from entries, repeats merged"},
    {"compressed", kd_compressed, METH_VARARGS, "a graph's pattern on groups of its nodes"},
    {"cuthill_mckee", kd_cuthill_mckee, METH_VARARGS,
     "Cuthill-McKee's order from pseudo-peripheral nodes"},
    {"permuted", kd_permuted, METH_VARARGS, "K's permuted upper triangle and its maps"},
    {"envelope", kd_envelope, METH_VARARGS, "the envelope of K's permuted lower triangle"},
    {"envelope_factor", kd_envelope_factor, METH_VARARGS,
     "scatter the values into the envelope, factor L D L^T in place, the inertia"},
    {"envelope_solve", kd_envelope_solve, METH_VARARGS, "solve with envelope factors"},
    {"structured_matvec", kd_structured_matvec, METH_VARARGS,
     "y = K x from the structures and values"},
    {"transpose_product", kd_transpose_product, METH_VARARGS,
     "J^T y from J's entries, in their order"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef kd_module = {PyModuleDef_HEAD_INIT, "@NAME@", NULL, -1,
                                       kd_methods};

PyMODINIT_FUNC PyInit_@NAME@(void) {
    if (PyType_Ready(&kd_buffer_type) < 0) return NULL;
    return PyModule_Create(&kd_module);
}
""".replace("@MAPPED@", str(MAPPED_BYTES))


def kernel():
    """The compiled kernel module (built on first use, then from the cache).

    Raises
    ------
    CompilerError
        No C compiler, or the compilation failed.
    """
    return load_fixed_module(_GENERATION, SOURCE)
