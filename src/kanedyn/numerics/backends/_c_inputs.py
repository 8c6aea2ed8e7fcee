"""C source: specified inputs held as piecewise polynomials, evaluated in the module.

A model whose specified inputs are all
:class:`~kanedyn.modeling.PiecewisePolynomial` (or numbers) hands the compiled
module their coefficients as data (``Model(p, None, table, names)``): one float64
array, for each input in turn ``n, k, lo, hi``, the ``n + 1`` breaks and the
``n k`` coefficients (:meth:`PiecewisePolynomial.packed`).  The module then
evaluates the inputs itself at every right-hand side (a binary search for the
piece, Horner's rule in the time since its start), in the compiled integration
loop too, and calls no Python for them.  A time outside ``[lo, hi]`` raises
``ValueError`` naming the input (as the Python function does).
"""

from __future__ import annotations

__all__ = ["TABLE_INPUTS"]

TABLE_INPUTS = r"""
/* ------------------------------------------------ inputs as polynomial pieces */
typedef struct {
    npy_intp n;          /* pieces */
    int k;               /* coefficients per piece, highest power first */
    double lo, hi;       /* times accepted (infinite: extrapolated) */
    const double *x;     /* n + 1 breaks */
    const double *c;     /* n k coefficients */
} KdPiece;

/* the pieces of `count` inputs from the packed table (length `size`), pointing into
   it; -1 with ValueError when the table is not made of `count` whole entries */
static int kd_pieces_parse(const double *table, npy_intp size, int count, KdPiece *out) {
    npy_intp at = 0;
    for (int i = 0; i < count; ++i) {
        if (at + 4 > size) goto bad;
        double n = table[at], k = table[at + 1];
        if (!(n >= 1 && k >= 1 && n == floor(n) && k == floor(k) && k <= 64)) goto bad;
        out[i].n = (npy_intp)n;
        out[i].k = (int)k;
        out[i].lo = table[at + 2];
        out[i].hi = table[at + 3];
        out[i].x = table + at + 4;
        out[i].c = out[i].x + out[i].n + 1;
        at += 4 + out[i].n + 1 + out[i].n * out[i].k;
        if (at > size) goto bad;
    }
    if (at == size) return 0;
bad:
    PyErr_SetString(PyExc_ValueError, "the table of inputs is not a whole set of "
                    "piecewise polynomials (n, k, lo, hi, breaks, coefficients)");
    return -1;
}

/* values of the inputs at t into r; -1 with ValueError (naming the input from
   `names`, a tuple of str) for a time outside an input's range */
static int kd_pieces_eval(const KdPiece *pieces, int count, PyObject *names, double t,
                          double *r) {
    for (int i = 0; i < count; ++i) {
        const KdPiece *p = pieces + i;
        if (!(t >= p->lo && t <= p->hi)) {
            char text[160];
            snprintf(text, sizeof(text), "defined for %g s <= t <= %g s only (asked at "
                     "t = %g s)", p->x[0], p->x[p->n], t);
            PyErr_Format(PyExc_ValueError, "%S: %s", PyTuple_GET_ITEM(names, i), text);
            return -1;
        }
        const double *x = p->x;
        npy_intp a = 0, b = p->n;  /* the piece: x[a] <= t < x[a + 1], ends clamped */
        if (t >= x[b]) a = b - 1;
        else if (t > x[0])
            while (b - a > 1) {
                npy_intp m = a + (b - a) / 2;
                if (x[m] <= t) a = m; else b = m;
            }
        const double *c = p->c + a * p->k;
        double s = t - x[a], v = c[0];
        for (int j = 1; j < p->k; ++j) v = v * s + c[j];
        r[i] = v;
    }
    return 0;
}
"""
