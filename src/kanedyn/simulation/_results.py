"""Simulation results: states, constraint residuals, energy, constraint forces."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from .._output_files import replacing

__all__ = ["SimulationResult"]

#: numeric codes of the contact modes in CSV output
_MODE_CODES = {"separated": 0, "slip": 1, "stick": 2}


class _SegmentedSolution:
    """Continuous solution made of consecutive ``OdeSolution`` pieces."""

    def __init__(self, pieces):
        self.pieces = pieces
        self.breaks = np.array([p.t_min for p in pieces[1:]])

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        scalar = t.ndim == 0
        t = np.atleast_1d(t)
        idx = np.searchsorted(self.breaks, t, side="right")
        out = np.empty((self.pieces[0](t[0]).shape[0], t.size))
        for k in np.unique(idx):
            sel = idx == k
            out[:, sel] = self.pieces[k](t[sel])
        return out[:, 0] if scalar else out


class SimulationResult:
    """What a simulation computed; immutable.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Output times, s.
    y : ndarray, shape (n_states, N)
        States at the output times (``solve_ivp`` layout).
    state_names : tuple of str
    success : bool
    status : int
        0: reached the end; 1: a terminal event; -1: failure.
    message : str
    t_events, y_events : list of ndarray
        Per user event, as in ``solve_ivp``.
    sol : callable or None
        Continuous solution when ``dense_output=True``.
    constraint_residuals : ndarray, shape (n_constraints, N)
        Configuration then velocity constraint residuals.
    kinetic_energy : ndarray, shape (N,)
    energy : ndarray or None
        Total energy (kinetic + potential) where the model defines it, or the
        kinetic energy of a model without loads; else ``None``.
    constraint_forces : dict
        ``{name: ndarray (N,)}`` when requested.

    The histories (residuals, energies, constraint forces) are computed from
    the states on first access.
    projections : int
        Number of constraint-drift projections.
    initial_state : ndarray
        The (consistent) initial state actually used.
    nfev, njev, nlu : int
        Counts summed over integration segments.
    """

    @classmethod
    def build(cls, model, t, y, status, message, t_events, y_events, dense_segments,
              counters, projections, initial_state, constraint_forces, method,
              contacts=None, balance=None):
        """``balance``: the energy balance the integrator sampled for the energy
        check (:class:`kanedyn.simulation._energy_check.Balance`), where it did."""
        self = object.__new__(cls)
        d = self.__dict__
        d.update(model=model, t=t, y=y, status=status, message=message,
                 success=status >= 0, t_events=t_events, y_events=y_events,
                 projections=projections, initial_state=initial_state, method=method,
                 state_names=model.state_names, **counters)
        if dense_segments is None or callable(dense_segments):
            d["sol"] = dense_segments
        else:
            d["sol"] = _SegmentedSolution(dense_segments) if dense_segments else None
        d["_want_forces"] = constraint_forces
        d["_contacts"] = contacts
        d["_balance"] = balance
        return self

    # ------------------------------------------- histories, computed on demand
    def _lazy(self, name, compute):
        if name not in self.__dict__:
            self.__dict__[name] = compute()
        return self.__dict__[name]

    def _finite_columns(self):
        return np.flatnonzero(np.all(np.isfinite(self.y), axis=0))

    def _energies(self):
        """(kinetic, potential) histories, one evaluation per output time."""
        model = self.model
        ke = np.full(self.t.size, np.nan)
        pe = np.full(self.t.size, np.nan)
        for k in self._finite_columns():
            ke[k], pe[k] = model.energies(self.t[k], self.y[:, k])
        return ke, pe

    @property
    def constraint_residuals(self):
        """Configuration then velocity constraint residuals, shape (n_c, N)."""
        def compute():
            model = self.model
            out = np.zeros((model.n_q_dep + model.n_u_dep, self.t.size))
            if out.shape[0]:
                for k in self._finite_columns():
                    out[:, k] = model.constraint_residuals(self.t[k], self.y[:, k])
            return out
        return self._lazy("_constraint_residuals", compute)

    @property
    def kinetic_energy(self):
        """Kinetic energy history, shape (N,)."""
        return self._lazy("_energy_pair", self._energies)[0]

    @property
    def potential_energy(self):
        """Potential energy history, or ``None`` when the model declares none."""
        if not self.model.has_potential:
            return None
        return self._lazy("_energy_pair", self._energies)[1]

    @property
    def energy(self):
        """Total energy where the model defines it (see the class docstring)."""
        if self.model.has_potential:
            return self.kinetic_energy + self.potential_energy
        return None if self.model.has_loads else self.kinetic_energy.copy()

    @property
    def constraint_forces(self):
        """``{name: history}`` of the constraint forces, when requested."""
        def compute():
            if not self._want_forces:
                return {}
            model = self.model
            names = model.constraint_force_names
            values = np.full((len(names), self.t.size), np.nan)
            for k in self._finite_columns():
                out = model.constraint_forces(self.t[k], self.y[:, k])
                values[:, k] = [out[nm] for nm in names]
            return dict(zip(names, values))
        return self._lazy("_constraint_forces", compute)

    def __setattr__(self, name, value):
        raise AttributeError("SimulationResult is immutable")

    def __getstate__(self):
        return self.__dict__

    def __setstate__(self, state):
        self.__dict__.update(state)

    def __repr__(self):
        return (f"<SimulationResult: {self.t.size} points, t={self.t[0] if self.t.size else 0:g}"
                f"..{self.t[-1] if self.t.size else 0:g}, success={self.success}, "
                f"message={self.message!r}>")

    def _repr_html_(self):
        """Notebook display: headline numbers and a small plot of the states."""
        from .._html import box, names, number, png, table
        info = self.summary()
        rows = [("success", info["success"]), ("message", self.message)]
        if self.t.size:
            rows.append(("t", f"{number(self.t[0])} .. {number(self.t[-1])} s"))
        rows += [("points", info["points"]), ("rhs evaluations", info["rhs_evaluations"])]
        if "energy_balance" in info:
            rows.append(("energy balance error", "n/a" if info["energy_balance"] is None
                         else f"{number(info['energy_balance'], 3)} J"))
            rows.append(("impacts", info["impacts"]))
        else:
            rows.append(("energy drift (relative)", number(info["energy_drift"], 3)))
        if self.constraint_residuals.shape[0]:
            rows.append(("max constraint residual",
                         number(info["max_constraint_residual"], 3)))
            rows.append(("projections", info["projections"]))
        final = []
        if self.t.size:
            limit = 16
            final = [(name, number(self.y[i, -1])) for i, name
                     in enumerate(self.state_names[:limit])]
            if len(self.state_names) > limit:
                final.append(("...", f"{len(self.state_names) - limit} more"))
        figure = ""
        if self.t.size > 1:
            try:
                fig = self.plot(extras=False)
            except Exception as exc:  # noqa: BLE001  (a display must not fail)
                figure = table([("plot not drawn", str(exc).splitlines()[0])])
            else:
                import matplotlib.pyplot as plt
                figure = png(fig, alt=f"states of the simulation: {names(self.state_names)}")
                plt.close(fig)
        model = self.model
        return box(table(rows, caption="simulation"),
                   table(final, caption="final state") if final else "", figure,
                   title=f"SimulationResult ({getattr(self, 'method', 'simulate')}): "
                         f"{model.n_q} coordinates, {model.n_u} speeds")

    # ------------------------------------------------------------ contacts
    @property
    def mode_history(self):
        """Contact mode changes: ``ModeChange(t, contact, old, new, reason)``."""
        return list(self._contacts["mode_history"]) if self._contacts else []

    @property
    def impacts(self):
        """The impacts, in time order (:class:`kanedyn.Impact` records)."""
        return list(self._contacts["impacts"]) if self._contacts else []

    @property
    def dissipated_work(self):
        """Work of the friction forces on the relative motion (<= 0), J, shape (N,)."""
        return self._contacts["dissipated_work"] if self._contacts else None

    @property
    def contact_forces(self):
        """``{contact: {"normal": (N,), "friction": (N, 3), "mode": list}}``.

        Normal force magnitude and friction force vector on each contact point
        at the output times, in the contact mode in force there.
        """
        if not self._contacts:
            return {}

        def compute():
            from ..numerics import solve_modes
            names = [c["name"] for c in self.model.contacts]
            normal = np.full((len(names), self.t.size), np.nan)
            friction = np.full((len(names), self.t.size, 3), np.nan)
            modes = self._contacts["point_modes"]
            dirs = self._contacts["point_directions"]
            for k in self._finite_columns():
                sol = solve_modes(self.model, self.t[k], self.y[:, k], modes[k], dirs[k],
                                  self._contacts["stabilization"])
                normal[:, k] = sol.normal_force
                friction[:, k] = sol.friction
            return {name: {"normal": normal[i], "friction": friction[i],
                           "mode": [m[i] for m in modes]} for i, name in enumerate(names)}
        return self._lazy("_contact_forces", compute)

    @property
    def contact_work(self):
        """Work of all contact forces on the system, J, shape (N,).

        The friction work (:attr:`dissipated_work`) plus the work moving
        surfaces do through the contact forces.
        """
        return self._contacts["contact_work"] if self._contacts else None

    def energy_balance(self):
        """Energy error of a simulation with contacts, J, shape (N,).

        Change of total energy minus the work of the contact forces and the
        kinetic energy jumps at impacts, from the first output time on: zero
        to the integration tolerance when the model's other loads are
        conservative and its kinematics do not depend explicitly on time (the
        surfaces may move).  Empty for a run that has no output point.
        """
        if self.energy is None:
            raise ValueError("the model defines no total energy (give potential_energy)")
        if not self._contacts:
            raise ValueError("this simulation has no contacts; see energy_drift()")
        if self.t.size == 0:
            return np.zeros(0)
        jumps = np.zeros(self.t.size)
        for impact in self.impacts:  # a point at an impact's time is the state before it
            if impact.t >= self.t[0]:
                jumps[self.t > impact.t] += impact.kinetic_energy_jump
        work = self.contact_work - self.contact_work[0]  # from the first output time
        return self.energy - self.energy[0] - work - jumps

    # ------------------------------------------------------------- access
    def __getitem__(self, key):
        """A state history by name or dynamic symbol, or a named output."""
        if isinstance(key, str):
            name = key
        else:  # a dynamic symbol: SymPy is loaded already
            from ..engine import name_of
            name = name_of(key)
        if name in self.state_names:
            return self.y[self.state_names.index(name)]
        if name in self.constraint_forces:
            return self.constraint_forces[name]
        if name in ("energy", "kinetic_energy", "potential_energy"):
            value = getattr(self, name)
            if value is None:
                raise KeyError(f"{name} is not defined for this model")
            return value
        raise KeyError(f"{key} is neither a state ({', '.join(self.state_names)}) nor "
                       "a computed output of this result")

    def keys(self):
        return list(self.state_names) + list(self.constraint_forces)

    @property
    def constraint_residual(self):
        """Largest absolute constraint residual at each output time."""
        if self.constraint_residuals.shape[0] == 0:
            return np.zeros(self.t.size)
        return np.max(np.abs(self.constraint_residuals), axis=0)

    def energy_drift(self):
        """Largest relative change of :attr:`energy` from its initial value."""
        if self.energy is None or self.t.size == 0:
            return None
        e = self.energy[np.isfinite(self.energy)]
        scale = max(abs(e[0]), np.max(np.abs(self.kinetic_energy[np.isfinite(
            self.kinetic_energy)])), 1e-300)
        return float(np.max(np.abs(e - e[0])) / scale)

    def summary(self):
        """Dictionary of headline numbers (for reports and the CLI)."""
        out = {"success": self.success, "status": self.status, "message": self.message,
               "points": int(self.t.size), "t_end": float(self.t[-1]) if self.t.size else None,
               "rhs_evaluations": int(self.nfev), "projections": int(self.projections),
               "max_constraint_residual": float(np.max(self.constraint_residual))
               if self.t.size else None,
               "energy_drift": self.energy_drift()}
        if self._contacts:
            balance = self.energy_balance() if self.energy is not None else None
            out.update(
                energy_drift=None,  # not conserved: friction, impacts, moving surfaces
                energy_balance=float(np.max(np.abs(balance[np.isfinite(balance)])))
                if balance is not None and self.t.size else None,
                impacts=len(self.impacts),
                impact_energy_loss=float(sum(i.energy_loss for i in self.impacts)),
                friction_work=float(self.dissipated_work[-1]) if self.t.size else 0.0,
                mode_changes=[f"t={c.t:.6g} s: {c.contact} {c.old} -> {c.new} ({c.reason})"
                              for c in self.mode_history])
        return out

    # ------------------------------------------------------------- output
    def _columns(self):
        cols = {"t": self.t}
        for i, name in enumerate(self.state_names):
            cols[name] = self.y[i]
        for name, values in self.constraint_forces.items():
            cols[name] = values
        cols["kinetic_energy"] = self.kinetic_energy
        if self.energy is not None:
            cols["energy"] = self.energy
        if self.constraint_residuals.shape[0]:
            cols["constraint_residual"] = self.constraint_residual
        for name, forces in self.contact_forces.items():
            cols[f"mode_{name}"] = np.array([_MODE_CODES[m] for m in forces["mode"]],
                                            dtype=float)
            cols[f"normal_force_{name}"] = forces["normal"]
            for i, axis in enumerate("xyz"):
                cols[f"friction_{name}_{axis}"] = forces["friction"][:, i]
        if self._contacts:
            cols["friction_work"] = self.dissipated_work
            cols["contact_work"] = self.contact_work
            if self.energy is not None:
                cols["energy_balance"] = self.energy_balance()
        return cols

    def to_csv(self, path):
        """Write time, states and computed outputs as CSV; returns the path.

        With contacts: per contact its mode (0 separated, 1 slip, 2 stick),
        normal force and friction force components (inertial), and the work
        and energy-balance histories.
        """
        path = Path(path)
        cols = self._columns()
        with replacing(path, newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(list(cols))
            for row in zip(*cols.values()):
                writer.writerow([repr(float(v)) for v in row])
        return path

    def to_npz(self, path):
        """Write all arrays to a compressed ``.npz`` file; returns the path."""
        path = Path(path)
        if path.suffix != ".npz":  # as numpy.savez_compressed names it
            path = path.with_name(path.name + ".npz")
        arrays = self._columns()
        arrays["y"] = self.y
        arrays["state_names"] = np.array(self.state_names)
        arrays["constraint_residuals"] = self.constraint_residuals
        with replacing(path, "wb") as handle:
            np.savez_compressed(handle, **arrays)
        return path

    def plot(self, states=None, path=None, extras=True, labels=None, title=None):
        """Plot state histories (and residual/energy panels); returns the Figure.

        One panel per kind and unit of state (angles [rad], positions [m],
        angular rates [rad/s], speeds [m/s], ``[?]`` where the model does not
        tell; a flexible body's modal coordinates apart), curves of very
        different ranges in separate panels, legends beside the axes; the
        title names the model.  States that never exceed 1e-12 (numerical
        noise, or at rest) are left out and named in the title unless asked
        for by ``states``.  At most 1600 x 1000 pixels as saved: beyond four
        panels, coordinates in a left column and speeds in a right one.

        Parameters
        ----------
        states : sequence of str, optional
            Which states to plot (default: all).
        path : str or Path, optional
            Save the figure there.
        extras : bool
            Add panels for constraint residuals, energy and forces when
            available.
        labels : dict, optional
            ``{state name: legend text}`` (e.g. ``{"q4": "lean q4"}``).
        title : str, optional
            Instead of the model's title.
        """
        from ..analysis import plot_result
        return plot_result(self, states=states, path=path, extras=extras, labels=labels,
                           title=title)

    def animate(self, path, visuals=(), trace=(), up="auto", max_frames=2000, title=None,
                inputs=None):
        """Write the motion as a 3D animation: one HTML file that needs no network.

        Parameters
        ----------
        path : str or Path
            The page to write (``.html``).
        visuals : sequence of kanedyn.visuals shapes, optional
            ``kd.visuals.Box``, ``Cylinder``, ``Sphere``, ``Mesh`` attached to
            bodies; a body without one is drawn with the default shape (the
            ellipsoid of equal inertia; a particle: a small sphere).
        trace : sequence of sympy Point, optional
            Points whose paths are drawn.
        up : "auto", "x", "y", "z", "-x", "-y", "-z" or 3 numbers
            The inertial direction drawn upwards; ``"auto"``: against the
            model's declared gravity, else its bodies' weights, else +z.
        max_frames : int
            At most this many output times become frames.
        title : str, optional
        inputs : dict, optional
            ``{specified symbol: function of t, or number}`` for inputs that
            the bodies' positions need but the equations of motion do not
            (a vehicle's displacement, when only its accelerations drive the
            model; ``ModelDefinition.animation_inputs`` of a built-in model).

        Returns
        -------
        Path
            The page written.

        See :func:`kanedyn.io.animate` and ``docs/viewer.md``.
        """
        from ..io import animate
        return animate(self, path, visuals=visuals, trace=trace, up=up,
                       max_frames=max_frames, title=title, inputs=inputs)

    def widget(self, visuals=(), trace=(), up="auto", max_frames=2000, title=None,
               inputs=None, height=480):
        """The 3D animation as a live notebook widget (anywidget; the ``notebook``
        extra): the page of :meth:`animate`, inside Jupyter, without a network.

        Parameters are those of :meth:`animate` (no path) and ``height``
        (pixels); see :func:`kanedyn.io.widget` and ``docs/viewer.md``.
        """
        from ..io import widget
        return widget(self, visuals=visuals, trace=trace, up=up, max_frames=max_frames,
                      title=title, inputs=inputs, height=height)

    def plot_deflection(self, body, times, scale="auto", path=None):
        """Draw a flexible body's deformed member at chosen times; returns the Figure.

        The member in its body frame, at true proportions with the deflection
        magnified by ``scale`` (stated on the figure when not 1), one line per
        time, the tip deflection of each in the legend.

        Parameters
        ----------
        body : kanedyn.FlexibleBody
            A flexible body of the simulated model.
        times : float or sequence of float
            Times inside the run, s.
        scale : float or "auto"
            Deflection magnification; ``"auto"``: 1, 2 or 5 times a power of
            ten so that the drawn deflection is at most about 25 % of the
            member's length.
        path : str or Path, optional
            Save the figure there as PNG.

        Returns
        -------
        matplotlib.figure.Figure

        See Also
        --------
        kanedyn.analysis.plot_deflection : the same drawing, with the details.
        """
        from ..analysis import plot_deflection
        return plot_deflection(self, body, times, scale=scale, path=path)
