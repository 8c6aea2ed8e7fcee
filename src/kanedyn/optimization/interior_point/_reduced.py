r"""The NLP as the interior-point iterations see it: fixed variables taken
out, rows without bounds dropped, objective and rows scaled.

From ``nlp`` (the interface of :mod:`kanedyn.optimization._solvers`) with
bounds :math:`x_L \le x \le x_U`, :math:`g_L \le g(x) \le g_U`:

- a variable with :math:`x_L = x_U` is fixed at that value and leaves the
  problem (IPOPT's ``fixed_variable_treatment = make_parameter``); its bound
  multiplier is computed at the end from the Lagrangian's gradient;
- a row with neither bound finite (beyond :math:`10^{19}`, IPOPT's
  infinity) is dropped, its multiplier zero;
- the kept rows are equalities (:math:`g_L = g_U`) or inequalities, the
  latter given a slack :math:`s` with :math:`g_L \le s \le g_U` and the row
  :math:`g(x) - s = 0`;
- gradient-based scaling (IPOPT's ``nlp_scaling_method``): the objective
  times :math:`s_f = \min(1, g_{\max}/\|\nabla f(x_0)\|_\infty)`, row j
  times :math:`\min(1, g_{\max}/\|\nabla g_j(x_0)\|_\infty)` (at least
  ``nlp_scaling_min_value``), :math:`g_{\max}` = ``nlp_scaling_max_gradient``.

Every array here is of the reduced, scaled problem unless its name says
``full``.
"""

from __future__ import annotations

import numpy as np

from .kkt._dense import check_structure
from .kkt._periodic import PeriodicIndex, kernel_index, periodic

__all__ = ["ReducedNLP", "INFINITE_BOUND", "compact_index_type"]

#: a bound at or beyond this magnitude is no bound (IPOPT's nlp_upper_bound_inf)
INFINITE_BOUND = 1e19

#: the entries moved at a time where the left-out ones are taken out in place
_CHUNK = 1 << 16

#: J^T y of at most this many entries sums an array of their products
#: (``np.bincount``); beyond, SciPy's product, which makes none (or, of
#: patterns held as runs, the KKT kernel's, the same sums in the same order)
PRODUCTS_ARRAY_ENTRIES = 1 << 16


class ReducedNLP:
    """``nlp`` without its fixed variables and unbounded rows, scaled.

    Parameters
    ----------
    nlp : object
        The NLP interface (``n``, ``m``, bounds, callbacks, ``exact_hessian``).
    x0 : ndarray, shape (nlp.n,)
        The starting point (its fixed entries replaced by their values).
    settings : namespace
        The solver's options (:func:`._options.settings`).
    exact_hessian : bool
        Whether the NLP's Hessian is used; if not, the Hessian's pattern is
        empty (the limited-memory approximation, :mod:`._quasi_newton`).

    Attributes
    ----------
    n, m : int
        Free variables and kept rows.
    free : ndarray of bool, shape (n_full,)
        Which variables of the full vector are free (a mask: a byte each,
        where an index took four or eight).
    fixed : ndarray of int
        The fixed variables' indices in the full vector, ``int32``
        (``int64`` beyond its range).
    rows : ndarray of bool, shape (m_full,)
        Which of the full rows are kept (a mask).
    equality : ndarray of bool, shape (m,)
        Which kept rows are equalities; the others have a slack each.
    jacobian_structure : (rows, cols)
        The reduced Jacobian's pattern, ``int32`` (``int64`` beyond its
        range), read-only (a KKT factorization may keep it), or after
        :meth:`hold_periodic` each as a
        :class:`~.kkt._periodic.PeriodicIndex` where that holds less; the
        Hessian's is made when asked (:meth:`hessian_structure`), not held.
    hessian_size : int
        The reduced Hessian's entries.
    row_scale : ndarray, shape (m,), or float
        Each row's scale; ``1.0`` (not an array: the same products and
        quotients) while every row's is 1.
    objective_scale : float

    Notes
    -----
    Of the full patterns only the entries left out are held (in fixed
    variables' columns, or in dropped rows: few, often none), not the
    entries kept; nor a full start vector (:meth:`start_full` makes it from
    the caller's ``x0``).
    """

    def __init__(self, nlp, x0, settings, exact_hessian=True):
        self.nlp = nlp
        n_full, m_full = int(nlp.n), int(nlp.m)
        self.n_full, self.m_full = n_full, m_full
        x_lower = np.asarray(nlp.x_lower, dtype=float).reshape(n_full)
        x_upper = np.asarray(nlp.x_upper, dtype=float).reshape(n_full)
        g_lower = np.asarray(nlp.g_lower, dtype=float).reshape(m_full)
        g_upper = np.asarray(nlp.g_upper, dtype=float).reshape(m_full)
        index = compact_index_type(max(n_full, m_full))
        fixed = x_lower == x_upper
        self.fixed = np.flatnonzero(fixed).astype(index)
        self.free = ~fixed
        self.n = int(np.count_nonzero(self.free))
        kept = ~((g_lower <= -INFINITE_BOUND) & (g_upper >= INFINITE_BOUND))
        self.rows = kept
        self.m = int(np.count_nonzero(kept))
        self.equality = g_lower[kept] == g_upper[kept]
        self.inequality = np.flatnonzero(~self.equality)
        #: the caller's start (read, not copied) and the fixed variables' values
        self._x0 = np.asarray(x0, dtype=float).reshape(n_full)
        self._fixed_values = x_lower[self.fixed]
        column_of = self._column_of()
        row_of = np.full(m_full, -1, dtype=index)
        row_of[self.rows] = np.arange(self.m)
        # the patterns are checked, then held in the compact type (of the full
        # Jacobian's only its entries in the fixed variables' columns)
        jr, jc = (a.astype(index) for a in check_structure(
            "the NLP's jacobian_structure", nlp.jacobian_structure(), m_full, n_full))
        # the entries in the fixed variables' columns: their multipliers at the end
        in_fixed = np.flatnonzero(column_of[jc] < 0)
        fixed_of = np.zeros(n_full, dtype=index)
        fixed_of[self.fixed] = np.arange(self.fixed.size)
        self._fixed_jacobian = (in_fixed, jr[in_fixed], fixed_of[jc[in_fixed]])
        #: the last :meth:`jacobian`'s entries in the fixed columns (``None``
        #: before one, or without fixed variables)
        self.fixed_jacobian = None
        use = (column_of[jc] >= 0) & (row_of[jr] >= 0)
        #: the full patterns' entries left out, ``None`` where none is
        self._jacobian_dropped = _dropped(use)
        self.jacobian_structure = _read_only(row_of[jr[use]], column_of[jc[use]])
        self._exact_hessian = exact_hessian
        #: the NLP's jacobian() and hessian() give a new array at each call,
        #: which the entries left out are then taken out of in place
        self._owned = bool(getattr(nlp, "returns_new_arrays", False))
        hr, hc = self._full_hessian_structure()
        use = (column_of[hr] >= 0) & (column_of[hc] >= 0)
        self._hessian_dropped = _dropped(use)
        self.hessian_size = int(np.count_nonzero(use))
        #: every row kept: the full rows are taken as they are (no index)
        self._all_rows = self.m == m_full
        #: the patterns held and given as runs where they repeat (hold_periodic)
        self._periodic = False
        self.objective_scale = 1.0
        self.row_scale = 1.0
        #: each Jacobian entry's row scale, or ``None`` while every row's is 1
        self._entry_scale = None
        self._settings = settings

    # ----------------------------------------------------------- scaling
    def kept_jacobian(self, jacobian_full):
        """The full Jacobian's values (unscaled) in the order of
        :attr:`jacobian_structure`: ``jacobian_full`` itself where no entry
        is left out, else a new array."""
        return _kept(jacobian_full, self._jacobian_dropped)

    def scale_at(self, x_full, gradient_full, jacobian_full):
        """Gradient-based scaling from the unscaled derivatives at the start."""
        s = self._settings
        factor = s.obj_scaling_factor
        if s.nlp_scaling_method == "gradient-based":
            limit, floor = s.nlp_scaling_max_gradient, s.nlp_scaling_min_value
            largest = np.max(np.abs(gradient_full[self.free]), initial=0.0)
            if largest > limit:
                factor *= max(limit / largest, floor)
            rows = self.jacobian_structure[0]
            values = np.abs(self.kept_jacobian(jacobian_full))
            row_max = np.zeros(self.m)
            np.maximum.at(row_max, rows, values)
            row_scale = np.where(row_max > limit,
                                 np.maximum(limit / np.maximum(row_max, 1e-300), floor), 1.0)
            if np.all(row_scale == 1.0):
                self.row_scale, self._entry_scale = 1.0, None
            else:
                self.row_scale, self._entry_scale = row_scale, row_scale[rows]
        self.objective_scale = float(factor)

    # ------------------------------------------------------------ bounds
    def variable_bounds(self):
        """``(lower, upper)`` of the free variables (infinite beyond 1e19;
        the NLP's bounds read again, not held)."""
        nlp = self.nlp
        return (_infinite(np.asarray(nlp.x_lower, dtype=float).reshape(self.n_full)[self.free]),
                _infinite(np.asarray(nlp.x_upper, dtype=float).reshape(self.n_full)[self.free]))

    def row_bounds(self):
        """``(lower, upper)`` of the kept rows, scaled (infinite beyond 1e19;
        the NLP's bounds read again, not held)."""
        nlp = self.nlp
        return (_infinite(np.asarray(nlp.g_lower, dtype=float).reshape(self.m_full)[self.rows])
                * self.row_scale,
                _infinite(np.asarray(nlp.g_upper, dtype=float).reshape(self.m_full)[self.rows])
                * self.row_scale)

    # --------------------------------------------------------- patterns
    def _column_of(self):
        """Each full variable's column among the free ones, -1 for a fixed
        one (the compact index type)."""
        column_of = np.full(self.n_full, -1,
                            dtype=compact_index_type(max(self.n_full, self.m_full)))
        column_of[self.free] = np.arange(self.n)
        return column_of

    def _full_hessian_structure(self):
        """The NLP's Hessian pattern, checked, in the compact index type
        (empty without the exact Hessian)."""
        n_full = self.n_full
        structure = self.nlp.hessian_structure() if self._exact_hessian else ([], [])
        index = compact_index_type(max(n_full, self.m_full))
        return (a.astype(index) for a in check_structure(
            "the NLP's hessian_structure", structure, n_full, n_full, lower=True))

    def hessian_structure(self):
        """``(rows, cols)`` of the reduced Hessian's lower triangle, made from
        the NLP's pattern when asked (for the KKT system's analysis; not
        held), the compact index type, read-only (the KKT factorization may
        keep them)."""
        hr, hc = self._full_hessian_structure()
        column_of = self._column_of()
        hr, hc = column_of[hr], column_of[hc]
        use = (hr >= 0) & (hc >= 0)
        structure = _read_only(hr[use], hc[use])
        return tuple(periodic(index) for index in structure) if self._periodic else structure

    def hold_periodic(self):
        """Hold the Jacobian's pattern, and give the Hessian's, as
        :class:`~.kkt._periodic.PeriodicIndex` runs where they repeat (large
        collocation patterns: no index arrays held while the solver
        iterates).  Only where the KKT kernel is available: the products
        with the pattern are then the kernel's (:meth:`transpose_times`)."""
        self._periodic = True
        self.jacobian_structure = tuple(periodic(index) for index in self.jacobian_structure)

    # -------------------------------------------------------- evaluation
    def full(self, x):
        """The full decision vector of the free variables ``x``."""
        out = np.empty(self.n_full)
        out[self.fixed] = self._fixed_values
        out[self.free] = x
        return out

    def start_full(self):
        """The full decision vector of the start ``x0``, its fixed variables
        at their values."""
        return self.full(self._x0[self.free])

    # Where every row (entry) is kept and scaled by 1, and the objective by 1,
    # the index and the product by 1.0 are left out: a copy of the NLP's
    # array (it may reuse its own), the same numbers.
    def objective(self, x_full):
        return self.objective_scale * float(self.nlp.objective(x_full))

    def constraints(self, x_full):
        if self._all_rows and self._entry_scale is None:
            return np.array(self.nlp.constraints(x_full), dtype=float)
        return np.asarray(self.nlp.constraints(x_full), dtype=float)[self.rows] \
            * self.row_scale

    def gradient(self, x_full):
        values = np.asarray(self.nlp.gradient(x_full), dtype=float)[self.free]
        return values if self.objective_scale == 1.0 else self.objective_scale * values

    def jacobian(self, x_full):
        """The scaled Jacobian's values in the reduced pattern; the NLP's
        entries in the fixed variables' columns kept in :attr:`fixed_jacobian`
        (the multipliers of :meth:`multipliers_full` at this point, without
        the Jacobian evaluated again)."""
        full = np.asarray(self.nlp.jacobian(x_full), dtype=float)
        self.fixed_jacobian = full[self._fixed_jacobian[0]] if self.fixed.size else None
        values = _kept(full, self._jacobian_dropped, copy=True, owned=self._owned)
        if self._entry_scale is not None:
            values *= self._entry_scale
        return values

    def hessian(self, x_full, multipliers, objective_factor=1.0):
        """The scaled Lagrangian's Hessian (lower triangle, reduced pattern's
        order) at ``x_full`` with the scaled rows' multipliers."""
        if self._all_rows and self._entry_scale is None:
            full = multipliers  # the NLP's callbacks do not write their arguments
        else:
            full = np.zeros(self.m_full)
            full[self.rows] = multipliers * self.row_scale
        values = np.asarray(self.nlp.hessian(x_full, full,
                                              objective_factor * self.objective_scale),
                            dtype=float)
        return _kept(values, self._hessian_dropped, copy=True, owned=self._owned)

    def transpose_times(self, jacobian_values, y):
        """:math:`J^T y`, shape (n,): the entries' products summed by
        ``np.bincount``, or for more than :data:`PRODUCTS_ARRAY_ENTRIES`
        entries by SciPy's product of the entries as they are (no array of
        their products; the same sums in the same order, slower to set up);
        a pattern held as runs (:meth:`hold_periodic`) by the KKT kernel's
        ``transpose_product``, which sums as SciPy does."""
        rows, cols = self.jacobian_structure
        if isinstance(rows, PeriodicIndex) or isinstance(cols, PeriodicIndex):
            from .kkt._kernel import kernel
            out = np.empty(self.n)
            values = np.ascontiguousarray(jacobian_values, dtype=float)
            kernel().transpose_product(out, values, np.ascontiguousarray(y, dtype=float),
                                       kernel_index(rows), kernel_index(cols))
            return out
        if jacobian_values.size <= PRODUCTS_ARRAY_ENTRIES:
            weights = y[rows]
            weights *= jacobian_values
            return np.bincount(cols, weights=weights, minlength=self.n)
        import scipy.sparse as sp
        return sp.coo_matrix((jacobian_values, (cols, rows)), shape=(self.n, self.m)) @ y

    # ---------------------------------------------------------- unscaling
    def multipliers_full(self, x_full, y, z_lower, z_upper, fixed_jacobian=None):
        """IPOPT's unscaled multipliers ``{"g", "x_lower", "x_upper"}`` of the
        full problem from the rows' ``y`` and the free variables' bound
        multipliers ``z_lower``, ``z_upper`` (each ``(index, values)``: the
        free variables that have one, among them, and its values; the others
        0); a fixed variable's from the Lagrangian's gradient, with
        ``fixed_jacobian`` (:attr:`fixed_jacobian` of a Jacobian at
        ``x_full``) or else the NLP's Jacobian evaluated at ``x_full``."""
        sf = self.objective_scale
        g = np.zeros(self.m_full)
        g[self.rows] = y * self.row_scale / sf
        zl, zu = np.zeros(self.n_full), np.zeros(self.n_full)
        for out, (index, values) in ((zl, z_lower), (zu, z_upper)):  # (one at a time)
            free = np.zeros(self.n)
            free[index] = values
            free /= sf
            out[self.free] = free
            del free
        if self.fixed.size:  # the Lagrangian's gradient in their columns
            entries, rows, columns = self._fixed_jacobian
            values = (fixed_jacobian if fixed_jacobian is not None else
                      np.asarray(self.nlp.jacobian(x_full), dtype=float)[entries])
            r = np.asarray(self.nlp.gradient(x_full), dtype=float)[self.fixed] + np.bincount(
                columns, weights=values * g[rows], minlength=self.fixed.size)
            zl[self.fixed], zu[self.fixed] = np.maximum(r, 0.0), np.maximum(-r, 0.0)
        return {"g": g, "x_lower": zl, "x_upper": zu}

    def scaled_multipliers(self, warm):
        """A warm start's ``(y, z_lower, z_upper)`` (IPOPT's unscaled
        multipliers of the full problem) for the reduced, scaled one."""
        sf = self.objective_scale
        g = np.asarray(warm["g"], dtype=float).reshape(self.m_full)
        zl = np.asarray(warm["x_lower"], dtype=float).reshape(self.n_full)
        zu = np.asarray(warm["x_upper"], dtype=float).reshape(self.n_full)
        return g[self.rows] * sf / self.row_scale, zl[self.free] * sf, zu[self.free] * sf


def compact_index_type(count):
    """The integer type of indices below ``count``: ``int32`` when they fit
    (half the bytes of NumPy's default), else ``int64``."""
    return np.int32 if count <= np.iinfo(np.int32).max else np.int64


def _read_only(*arrays):
    """``arrays``, each made read-only (a pattern that others may keep)."""
    for a in arrays:
        a.flags.writeable = False
    return arrays


def _dropped(use):
    """The entries that ``use`` (a mask) leaves out, in the compact index
    type, or ``None`` when it keeps every entry."""
    dropped = np.flatnonzero(~use)
    return dropped.astype(compact_index_type(use.size)) if dropped.size else None


def _kept(values, dropped, copy=False, owned=False):
    """``values`` without the entries ``dropped`` (:func:`_dropped`), a new
    array; when none is, ``values`` itself, or its copy with ``copy``.  With
    ``owned`` (``values`` the caller's to overwrite) in its own storage
    instead: the kept entries moved forward over the dropped ones (a chunk
    at a time), their leading part returned (a view)."""
    if owned:
        if dropped is not None:
            for i, start in enumerate(dropped):  # the entries after it, i + 1 places back
                stop = dropped[i + 1] if i + 1 < dropped.size else values.size
                for k0 in range(int(start) + 1, int(stop), _CHUNK):
                    k1 = min(int(stop), k0 + _CHUNK)
                    values[k0 - i - 1:k1 - i - 1] = values[k0:k1]
            values = values[:values.size - dropped.size]
        return values
    if dropped is None:
        return values.copy() if copy else values
    return np.delete(values, dropped)


def _infinite(bound):
    return np.where(bound <= -INFINITE_BOUND, -np.inf,
                    np.where(bound >= INFINITE_BOUND, np.inf, bound))
