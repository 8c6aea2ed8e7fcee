r"""Orthogonalized speeds of constrained systems (Lesser 1992).

With velocity constraints :math:`B(q, t)\,u + b(q, t) = 0` (nonholonomic, or
the rates of configuration constraints) the speeds the constraints admit
form the subspace

.. math::

    u = C\,u_i + u_p,\qquad C = \begin{bmatrix} I \\ -B_d^{-1} B_i \end{bmatrix},

with :math:`u_i` the model's independent speeds, :math:`B = [B_i\ B_d]`
split by the model's independent/dependent partition, and :math:`u_p` the
dependent speeds that :math:`b` alone demands.  The columns of :math:`C` are
the partial velocities of the independent speeds; the kinetic-energy metric
restricted to them is :math:`M_r = C^T M C`, and with :math:`M_r = L L^T` the
speeds :math:`v^* = L^T u_i` are orthonormal on the admissible subspace: the
mass matrix in :math:`v^*` is the identity.

The basis is the one Kane's elimination uses, so it is smooth wherever
:math:`B_d` is invertible and the orthogonalized model is singular exactly
where elimination is.  The state is :math:`[q, v^*]` (every coordinate,
dependent ones included, then one new speed per independent speed); the
dependent speeds are not states but follow from the constraints.

The generalized constraint forces :math:`g = M\dot u - f = B^T\lambda` lie in
the orthogonal complement of the admissible subspace: :math:`C^T g = 0`
(they do no work on any admissible motion), and in the kinetic-energy metric
the constraint's share of the acceleration, :math:`M^{-1} g`, is orthogonal
to every admissible velocity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._orthogonal_speeds import (MassMatrices, OrthogonalSpeedsModel, _congruence, _frozen,
                                 _solve, depends_on_time, reference_factor, reference_of,
                                 refuse_speed_dependence)
from .backends._python import compile_python, generate_python
from .._errors import ModelError

__all__ = ["ConstrainedOrthogonalSpeedsModel", "orthogonalize_constrained"]


def _basis(B, p):
    r""":math:`C = [I;\ -B_d^{-1}B_i]` of a constraint matrix ``B`` (m x o), p independent."""
    return np.vstack([np.eye(p), -_solve(B[:, p:], B[:, :p])])


@dataclass(frozen=True)
class _ReducedTerms:
    r"""The terms of the equations in the new speeds at one state.

    ``M`` (o x o) and ``B`` (m x o) the mass and velocity-constraint
    matrices, ``C`` (o x p) the admissible basis, ``M_r = C^T M C`` and its
    factor ``L`` (p x p), ``u_ind`` the independent speeds,
    ``qdot`` (n), ``force`` :math:`f`
    (o), ``particular`` :math:`\dot u_p = [0;\ -B_d^{-1} f_a]` (o), the
    accelerations the acceleration constraints :math:`B\dot u + f_a = 0`
    demand, ``f_r`` :math:`= C^T(f - M\dot u_p)` (p) and ``M_r_dot``
    :math:`\dot M_r` (``None`` for a constant factor).
    """

    M: np.ndarray
    B: np.ndarray
    C: np.ndarray
    M_r: np.ndarray
    L: np.ndarray
    u_ind: np.ndarray
    qdot: np.ndarray
    force: np.ndarray
    particular: np.ndarray
    f_r: np.ndarray
    M_r_dot: np.ndarray | None


class ConstrainedOrthogonalSpeedsModel(OrthogonalSpeedsModel):
    r"""A model in orthonormal speeds on the constraint-satisfying subspace.

    Made by :func:`kanedyn.orthogonalize_speeds` for a model with dependent
    speeds.  With the velocity constraints :math:`B u + b = 0` split by the
    model's partition, :math:`B = [B_i\ B_d]`, the admissible speeds are
    :math:`u = C u_i + u_p`, :math:`C = [I;\ -B_d^{-1}B_i]`; the kinetic-energy
    metric on them is :math:`M_r = C^T M C = L L^T` and the new speeds are
    :math:`v^* = L^T u_i`.  Kane's reduced equations
    :math:`M_r\dot u_i = f_r = C^T(f - M\dot u_p)` become, along the motion,

    .. math::

        \dot v^* = L^{-1} f_r + \dot L^T u_i ,

    and the generalized constraint forces :math:`M\dot u - f = B^T\lambda`
    lie in the orthogonal complement of the admissible subspace.  The basis
    is the one Kane's elimination uses: smooth wherever :math:`B_d` is
    invertible.

    Attributes
    ----------
    state_names : tuple of str
        Every coordinate (dependent ones included), then ``<speed>_star``
        for each independent speed.
    n_q, n_q_dep : int
        Numbers of coordinates and of dependent coordinates;
        :func:`kanedyn.simulate` keeps the latter on the configuration
        constraints by projecting as the original model does (independent
        coordinates and speeds kept).
    n_u : int
        Number of new speeds, as many as independent speeds.
    multiplier_names : tuple of str
        Names of the velocity constraints' multipliers (the original's).
    original, along_motion, reference_factor
        As for :class:`OrthogonalSpeedsModel`.

    Examples
    --------
    >>> import numpy as np, kanedyn as kd
    >>> d = kd.models.build("rolling-disk")
    >>> model = d.numeric()
    >>> ortho = kd.orthogonalize_speeds(model)
    >>> ortho.state_names[5:]
    ('u1_star', 'u2_star', 'u3_star')
    >>> y = ortho.from_original(model.state(d.initial(model)))
    >>> bool(ortho.mass_matrices(0.0, y).identity_error < 1e-12)
    True
    """

    def __init__(self, original, reference_factor, sources, reference=None, time=None,
                 time_dependent=False):
        super().__init__(original, reference_factor, sources, reference=reference,
                         time=time, time_dependent=time_dependent)
        n, p = original.n_q, original.n_u - original.n_u_dep
        names = original.state_names
        self.state_names = tuple(names[:n]) + tuple(f"{s}_star" for s in names[n:n + p])
        self.n_u = p
        self.n_q_dep = original.n_q_dep
        self.multiplier_names = original.multiplier_names

    def __repr__(self):
        kind = "along the motion" if self.along_motion else "constant factor"
        o = self.original
        return (f"<OrthogonalSpeedsModel ({kind}): {self.n_q} coordinates "
                f"({self.n_q_dep} dependent), {self.n_u} speeds on the subspace of "
                f"{o.n_u} speeds that {o.n_u_dep} velocity constraints admit>")

    # ------------------------------------------------------------ basics
    def state(self, values, t=0.0, what="initial value"):
        """A state ``[q, v*]``; dependent coordinates are put on the constraints."""
        y = super().state(values, t, what)
        return self.consistent_state(t, y) if self.n_q_dep else y

    def consistent_state(self, t, y, **options):
        """``y`` with the dependent coordinates solved from the configuration constraints.

        As the original model projects: the independent coordinates and
        speeds are kept (``options`` go to its ``consistent_state``).
        """
        y = self._check_y(y)
        if not self.n_q_dep:
            return y
        yo = self.original.consistent_state(t, self.to_original(y, t), **options)
        return self.from_original(yo, t)

    def constraint_residuals(self, t, y):
        """Configuration-constraint residuals (the velocity constraints hold by construction)."""
        y = self._check_y(y)
        return self.original._constraint_terms(t, self._with_speeds(y[:self.n_q]))[0]

    def _with_speeds(self, q, u=None):
        """An original state ``[q, u]`` (``u`` zero when not given)."""
        out = np.zeros(self.original.n_states)
        out[:self.n_q] = q
        if u is not None:
            out[self.n_q:] = u
        return out

    # ------------------------------------------------ basis, metric, maps
    def _metric(self, t, y):
        """``M, B, C, M_r`` at the configuration of ``y`` (any state layout)."""
        M, B = self._fn["ortho_metric"](t, self._with_speeds(y[:self.n_q]), self._args(),
                                        ())
        C = _basis(B, self.n_u)
        return M, B, C, C.T @ M @ C

    def _factor_of(self, M_r):
        """The factor of ``M_r`` along the motion, else the constant one."""
        return np.linalg.cholesky(M_r) if self.along_motion else self.reference_factor

    def _mass(self, t, y):
        """The reduced metric :math:`M_r = C^T M C` (only ``y[:n_q]`` matters)."""
        return self._metric(t, y)[3]

    def _original_state(self, t, q, u_ind, B):
        """``[q, u]`` with the dependent speeds solved from the velocity constraints.

        The constraints are linear in the speeds (:math:`B` does not depend
        on them): with the dependent speeds at zero their residual is
        :math:`B_i u_i + b`.
        """
        p = self.n_u
        y = self._with_speeds(q, np.concatenate([u_ind, np.zeros(self.original.n_u - p)]))
        c = self.original._constraint_terms(t, y)[3]
        y[self.n_q + p:] = -_solve(B[:, p:], c)
        return y

    def _map_one(self, y, t, inverse):
        n, p = self.n_q, self.n_u
        if inverse:
            _, B, _, M_r = self._metric(t, y)
            L = self._factor_of(M_r)
            return self._original_state(t, y[:n], self._speeds(L, y[n:]), B)
        scale = 1.0 + np.max(np.abs(y[n:]), initial=0.0)
        residual = np.max(np.abs(self.original.constraint_residuals(t, y)), initial=0.0)
        if not residual <= 1e-8 * scale:
            raise ValueError(
                f"the state does not satisfy the constraints (largest residual "
                f"{residual:.3g}): the new speeds hold only the independent speeds, so "
                "make the state consistent first (model.consistent_state(t, y))")
        L = self._factor(t, y)
        return np.concatenate([y[:n], L.T @ y[n:n + p]])

    def admissible_basis(self, t, y):
        r"""The basis :math:`C` of the admissible speeds at ``y* = [q, v*]``.

        Returns
        -------
        ndarray, shape (o, p)
            :math:`[I;\ -B_d^{-1}B_i]`, dimensionless when independent and
            dependent speeds have the same units; :math:`B C = 0`.
        """
        return self._metric(t, self._check_y(y))[2]

    # ---------------------------------------------------------- dynamics
    def _reduced(self, t, y):
        """Every term at ``y*`` (see :class:`_ReducedTerms`)."""
        y = self._check_y(y)
        n, p = self.n_q, self.n_u
        M, B, C, M_r = self._metric(t, y)
        L = self._factor_of(M_r)
        u_ind = self._speeds(L, y[n:])
        yo = self._original_state(t, y[:n], u_ind, B)
        out = self._fn["ortho_dynamics"](t, yo, self._args(), self.original._r(t, yo))
        qd, f, acc_f = out[:3]
        particular = np.zeros(self.original.n_u)
        particular[p:] = -_solve(B[:, p:], acc_f)
        M_r_dot = None
        if self.along_motion:
            M_dot, B_dot = out[3:]
            C_dot = np.zeros_like(C)
            C_dot[p:] = -_solve(B[:, p:], B_dot @ C)
            MC_dot = C_dot.T @ M @ C
            M_r_dot = MC_dot + MC_dot.T + C.T @ M_dot @ C
        return _ReducedTerms(M=M, B=B, C=C, M_r=M_r, L=L, u_ind=u_ind,
                             qdot=qd, force=f, particular=particular,
                             f_r=C.T @ (f - M @ particular), M_r_dot=M_r_dot)

    def cholesky_factor(self, t, y):
        r"""The factor :math:`L` of :math:`M_r = C^T M C` and its rate at ``y*``.

        :math:`\dot M_r = \dot C^T M C + C^T\dot M C + C^T M\dot C` with
        :math:`\dot C = [0;\ -B_d^{-1}\dot B C]`, :math:`\dot M` and
        :math:`\dot B` generated exactly; then
        :math:`\dot L = L\,\Phi(L^{-1}\dot M_r L^{-T})`.

        Returns
        -------
        L, L_dot : ndarray, shape (p, p)
        """
        r = self._reduced(t, y)
        if r.M_r_dot is None:
            return r.L, np.zeros_like(r.L)
        return r.L, self._factor_rate(r.L, r.M_r_dot)

    def _terms(self, t, y):
        """``L, u_i, q', M*, f*`` at ``y*`` (see :meth:`forcing`)."""
        r = self._reduced(t, y)
        L, u_ind = r.L, r.u_ind
        if r.M_r_dot is not None:
            f_star = _solve(L, r.f_r) + self._factor_rate(L, r.M_r_dot).T @ u_ind
            return L, u_ind, r.qdot, None, f_star
        return L, u_ind, r.qdot, _congruence(L, r.M_r), _solve(L, r.f_r)

    def mass_matrices(self, t, y):
        r"""The full, reduced and orthogonalized mass matrices at ``y*``.

        Returns
        -------
        MassMatrices
            ``original`` :math:`M` (o x o), ``reduced`` :math:`C^T M C`,
            ``orthogonalized`` :math:`L^{-1} C^T M C L^{-T}` and ``factor``
            :math:`L` (p x p).
        """
        y = self._check_y(y)
        M, _, _, M_r = self._metric(t, y)
        L = self._factor(t, y)
        return MassMatrices(_frozen(M), _frozen(_congruence(L, M_r)), _frozen(L),
                            _frozen(M_r))

    # ------------------------------------------------- constraint forces
    def generalized_constraint_forces(self, t, y):
        r"""Generalized constraint forces :math:`g = M\dot u - f` at ``y*`` (o).

        :math:`\dot u = C\dot u_i + \dot u_p` with :math:`\dot u_i` from the
        new speeds' equations (:math:`M_r\dot u_i = f_r`, i.e.
        :math:`\dot u_i = L^{-T}L^{-1} f_r` along the motion).  They lie in
        the orthogonal complement of the admissible subspace: :math:`C^T g = 0`
        to round-off.  Units of the generalized forces (N, N m per speed).
        """
        return self._constraint_balance(t, y)[0]

    def _constraint_balance(self, t, y):
        """``(g, B)``: generalized constraint forces and the constraint matrix."""
        r = self._reduced(t, y)
        udot = r.C @ np.linalg.solve(r.M_r, r.f_r) + r.particular
        return r.M @ udot - r.force, r.B

    def multipliers(self, t, y, udot=None):
        r"""Multipliers :math:`\lambda` of the velocity constraints, ``{name: value}``.

        From the dependent rows of :math:`g = B^T\lambda`
        (:meth:`generalized_constraint_forces`): :math:`\lambda = B_d^{-T} g_d`.
        """
        if udot is not None:
            raise ValueError("multipliers of the orthogonalized model use its own "
                             "accelerations: udot cannot be given")
        names = self.multiplier_names
        if not names:
            return {}
        g, B = self._constraint_balance(t, y)
        p = self.n_u
        return dict(zip(names, _solve(B[:, p:].T, g[p:])))

    def constraint_forces(self, t, y):
        """Constraint forces at ``y*``, ``{name: value}``.

        Those of auxiliary speeds (the original model's, at the mapped
        state) and the identified forces' magnitudes from :meth:`multipliers`.
        """
        o = self.original
        out = o.auxiliary(t, self.to_original(y, t)) if o.aux_names else {}
        if o.identified_names:
            lam = self.multipliers(t, y)
            out.update((name, lam[name]) for name in o.identified_names)
        return out


def orthogonalize_constrained(model, at, t):
    """:func:`kanedyn.orthogonalize_speeds` of a model with dependent speeds.

    Generates the metric (mass matrix and velocity-constraint matrix at a
    configuration) and the dynamics (q', forcing, acceleration-constraint
    terms; along the motion also the exact rates of both matrices).
    """
    eom = model._eom
    prog = eom._program
    args, outputs = model._functions["dynamics"]
    qdot_out, mass_out, force_out, vel_B_out, acc_K_out, acc_f_out = outputs
    names = model.state_names
    if [str(a) for a in vel_B_out[1]] != [str(a) for a in acc_K_out[1]]:
        raise ModelError("orthogonalize_speeds: the acceleration constraints are not the "
                         "rates of the velocity constraints (their matrices differ)")
    vel_B = vel_B_out[1]
    refuse_speed_dependence(eom, args, vel_B, "the velocity-constraint matrix (of "
                            + ", ".join(names[model.n_q + model.n_u_ind:]) + ")")
    metric_args = {"y": args["y"], "p": args["p"], "r": []}
    sources = {"ortho_metric": generate_python(prog, "ortho_metric", metric_args,
                                               [mass_out, vel_B_out])}
    dyn = [qdot_out, force_out, acc_f_out]
    if at is None:
        dyn += [(mass_out[0], [prog.dt(e) for e in mass_out[1]]),
                (vel_B_out[0], [prog.dt(e) for e in vel_B])]
    sources["ortho_dynamics"] = generate_python(prog, "ortho_dynamics", args, dyn)
    time_dependent = depends_on_time(eom, list(mass_out[1]) + list(vel_B))
    factor = y_ref = None
    if at is not None:
        y_ref, t = reference_of(model, at, t, time_dependent)
        metric = compile_python(sources["ortho_metric"], "ortho_metric")
        M, B = metric(t, y_ref, model._p, ())
        C = _basis(B, model.n_u_ind)
        factor = reference_factor(C.T @ M @ C, model, y_ref)
    return ConstrainedOrthogonalSpeedsModel(model, factor, sources, reference=y_ref, time=t,
                                            time_dependent=time_dependent)
