r"""Campbell diagrams: the modes of a rotating system against its rotor speed.

At each rotor speed :math:`\Omega`:

1. the steady motion: :func:`kanedyn.equilibrium` with the rotor speed held and
   the azimuth moving (every other speed found, normally zero);
2. the exact linearization there (:meth:`NumericModel.linearize`);
3. for three or more blades, the multiblade coordinate transformation of the
   blade coordinates (:mod:`._mbc`): an isotropic rotor in steady motion is
   then time invariant;
4. the azimuth's row and column removed (a cyclic coordinate; ``periodicity``
   says whether the state matrix depends on it), and with
   ``constant_speed`` the rotor speed's too;
5. the eigenvalues; the oscillatory ones (:math:`\mathrm{Im}\,\lambda > 0`) are
   the modes, followed from speed to speed by the modal assurance criterion
   of their coordinate shapes,
   :math:`\mathrm{MAC}(a, b) = |a^H b|^2 / (|a|^2 |b|^2)`, the pairing that
   maximises the sum (so a mode keeps its line through a crossing, and
   through a veering stays on its branch while its shape turns).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import ModelError
from ._mbc import multiblade_names, to_multiblade

__all__ = ["CampbellDiagram", "campbell"]


@dataclass(frozen=True)
class CampbellDiagram:
    r"""Modes of a linearized rotating system against rotor speed (:func:`campbell`).

    Attributes
    ----------
    speeds : ndarray, shape (n_speeds,)
        Rotor speeds, rad/s (the held speed state's values).
    frequencies : ndarray, shape (n_speeds, n_modes)
        Damped natural frequencies :math:`\mathrm{Im}\,\lambda / 2\pi`, **Hz**, of
        the tracked modes (nan where a mode was not found: the steady motion
        did not converge, or the mode is no longer oscillatory).  In the
        non-rotating frame when multiblade coordinates are used, in the
        rotating frame for a single blade.
    damping_ratios : ndarray, shape (n_speeds, n_modes)
        :math:`-\mathrm{Re}\,\lambda / |\lambda|`.
    eigenvalues : ndarray of complex, shape (n_speeds, n_modes)
        1/s.
    shapes : ndarray of complex, shape (n_speeds, n_coordinates, n_modes)
        Coordinate parts of the eigenvectors in the coordinates of
        ``coordinate_names``, each coordinate scaled by the square root of
        the diagonal mass-matrix entry of the speed that moves it (so that
        metres and radians compare: kinetic-energy-like weights), unit
        length.  MAC and labels use these.
    mac : ndarray, shape (n_speeds, n_modes)
        MAC of each mode's shape with its shape at the previous speed where it
        was found (1 at the first speed): low values mark an uncertain pairing
        (speeds too far apart for the shapes' changes).
    labels : tuple of str
        Each mode named by its largest coordinate of ``shapes``, and the next
        one when that exceeds half of it (at the fastest speed where the mode
        was found); a cyclic multiblade coordinate adds the whirl
        (forward: the pattern turns with the rotor, non-rotating frequency
        :math:`\omega_{rot} + \Omega`; backward: against it).
    coordinate_names : tuple of str
        The coordinates of the reduced state (azimuth removed; blade
        coordinates replaced by their multiblade names).
    states : ndarray, shape (n_speeds, n_states)
        The steady motions linearized about.
    converged : ndarray of bool, shape (n_speeds,)
    periodicity : ndarray, shape (n_speeds,)
        Largest change of the (transformed) state matrix when the azimuth
        is advanced by a quarter of the blade spacing, over its largest
        entry: round-off for a time-invariant system; larger values mean the
        linear system is periodic (gravity on the blades, an anisotropic
        rotor, a single blade on a flexible support) and the frequencies are
        those of the azimuth linearized about only (Floquet analysis is then
        the exact answer).
    harmonics : tuple of int
        The multiples of the rotor speed drawn by :meth:`plot` (1P, 3P, 6P).
    """

    speeds: np.ndarray
    frequencies: np.ndarray
    damping_ratios: np.ndarray
    eigenvalues: np.ndarray
    shapes: np.ndarray
    mac: np.ndarray
    labels: tuple
    coordinate_names: tuple
    states: np.ndarray
    converged: np.ndarray
    periodicity: np.ndarray
    harmonics: tuple = (1, 3, 6)

    def mode(self, label):
        """Index of the mode whose label is (or starts with) ``label``."""
        found = [j for j, name in enumerate(self.labels) if name == label]
        found = found or [j for j, name in enumerate(self.labels) if name.startswith(label)]
        if len(found) != 1:
            raise KeyError(f"{'no' if not found else 'more than one'} mode labelled {label!r}; "
                           f"labels: {', '.join(self.labels)}")
        return found[0]

    def plot(self, path=None, speed_unit="rpm", frequency_unit="Hz", title=None,
             max_frequency=None):
        """Frequency against rotor speed, with the rotor harmonics (see ``_campbell_plot``)."""
        from ._campbell_plot import plot_campbell
        return plot_campbell(self, path=path, speed_unit=speed_unit,
                             frequency_unit=frequency_unit, title=title,
                             max_frequency=max_frequency)

    def __repr__(self):
        return (f"<CampbellDiagram: {len(self.labels)} modes at {len(self.speeds)} speeds "
                f"({self.speeds[0]:.4g} to {self.speeds[-1]:.4g} rad/s); "
                f"{int(np.sum(~self.converged))} steady motions not found>")


def campbell(model, speeds, y0, speed, azimuth, rotating=None, hold=(), moving=(),
             constant_speed=False, n_modes=None, harmonics=(1, 3, 6), t=0.0, r=None,
             tol=1e-10):
    r"""The Campbell diagram of a model with a rotor: its modes against rotor speed.

    Parameters
    ----------
    model : NumericModel
        A model with exact derivatives (see :meth:`NumericModel.jacobians`).
    speeds : array_like, shape (n_speeds,)
        Rotor speeds, rad/s, in the order the modes are followed (neighbours
        close enough that shapes change little between them).
    y0 : array_like or dict
        Starting guess of the steady motion at the first speed (SI units;
        a dict as for :meth:`NumericModel.state`); each next speed starts from
        the previous one's.
    speed : str
        The rotor speed state, held at each value of ``speeds``.
    azimuth : str
        The rotor's angle (its rate is the speed): a cyclic coordinate,
        moving and removed from the eigen-analysis.
    rotating : sequence of sequences of str, optional
        The blade coordinates, one list per blade (the same coordinates in
        the same order on each), blades in the direction of rotation: blade
        ``b`` at azimuth ``azimuth + 2 pi (b - 1) / N``.  With three or more
        blades they are replaced by their multiblade coordinates; their rates
        must be speeds of the model (``dq/dt = u``).  None (default): no
        transformation (a single blade: its frequencies are those in the
        rotating frame).
    hold, moving : sequence of str
        Further states held, or coordinates moving, in the steady motion
        (as :func:`kanedyn.equilibrium`).
    constant_speed : bool
        True: the rotor is driven at exactly ``speed`` (its row and column
        leave the state matrix); False (default): it is free to change.
    n_modes : int, optional
        Follow the ``n_modes`` lowest modes of the first speed (default all).
    harmonics : sequence of int
        Multiples of the rotor speed that :meth:`CampbellDiagram.plot` draws.
    t : float
        Time, s.
    r : array_like, optional
        Values of the specified inputs (default: their providers).
    tol : float
        Residual accepted for the steady motions.

    Returns
    -------
    CampbellDiagram

    Raises
    ------
    ModelError
        A name that is not a state of the right kind, blades of different
        coordinate counts, fewer than three blades, a blade rate that is not
        a speed, speeds that are not finite.

    Examples
    --------
    See ``docs/campbell.md`` and ``examples/campbell_rotor.py``.
    """
    from ..numerics import equilibrium
    speeds = np.asarray(speeds, dtype=float)
    if speeds.ndim != 1 or speeds.size == 0 or not np.all(np.isfinite(speeds)):
        raise ModelError("campbell: speeds must be a non-empty 1-D array of finite rotor "
                         "speeds (rad/s)")
    layout = _Layout(model, speed, azimuth, rotating, constant_speed)
    y = np.array(model.state(y0, t), dtype=float)
    rows = []
    for omega in speeds:
        y[layout.speed] = omega
        found = equilibrium(model, y, hold=[speed, *hold], moving=[azimuth, *moving],
                            t=t, r=r, tol=tol)
        if found.converged:
            y = found.y
            rows.append((found.y, *layout.modes(model, found.y, t, r)))
        else:
            rows.append((found.y, None, None, np.nan))
    return _tracked(speeds, rows, layout, n_modes, tuple(int(h) for h in harmonics))


class _Layout:
    """Where the rotor's states are in the linearization's state, and what to remove."""

    def __init__(self, model, speed, azimuth, rotating, constant_speed):
        names = list(model.state_names)
        n_qi, n_ui = model.n_q_ind, model.n_u_ind
        self.names = names[:n_qi] + names[model.n_q:model.n_q + n_ui]
        self.n_qi = n_qi
        self.state_azimuth = self._find(names, azimuth, "azimuth")
        self.speed = self._find(names, speed, "speed")
        self.azimuth = self.names.index(azimuth) if azimuth in self.names else -1
        if not 0 <= self.azimuth < n_qi:
            raise ModelError(f"campbell: azimuth: {azimuth} is not an independent coordinate")
        if speed not in self.names[n_qi:]:
            raise ModelError(f"campbell: speed: {speed} is not an independent speed")
        self.blades = self._blades(rotating, n_qi)
        self.constant_speed = bool(constant_speed)
        if constant_speed and (model.n_q_dep or model.n_u_dep):
            raise ModelError("campbell: constant_speed needs a model without dependent "
                             "coordinates or speeds")
        self.speed_row = self.names.index(speed)
        removed = [self.azimuth] + ([self.speed_row] if constant_speed else [])
        self.kept = [i for i in range(len(self.names)) if i not in removed]
        self.coordinates = [k for k, i in enumerate(self.kept) if i < n_qi]
        coordinate_names = list(self.names[:n_qi])
        if self.blades is not None:
            for q in self.blades.T:
                for i, name in zip(q, multiblade_names(self.names[q[0]], len(q))):
                    coordinate_names[i] = name
        self.coordinate_names = tuple(coordinate_names[i] for i in self.kept if i < n_qi)

    @staticmethod
    def _find(names, name, what):
        if not isinstance(name, str) or name not in names:
            raise ModelError(f"campbell: {what}: {name!r} is not a state of this model; "
                             f"states are {', '.join(names)}")
        return names.index(name)

    def _blades(self, rotating, n_qi):
        if rotating is None:
            return None
        blades = [[c] if isinstance(c, str) else list(c) for c in rotating]
        if len(blades) < 3:
            raise ModelError(f"campbell: rotating: {len(blades)} blade(s) given; the "
                             "multiblade transformation needs three or more (give None "
                             "for a single blade)")
        if len({len(b) for b in blades}) != 1 or not blades[0]:
            raise ModelError("campbell: rotating: every blade needs the same, non-zero "
                             "number of coordinates; got " + ", ".join(
                                 str(len(b)) for b in blades))
        flat = [c for b in blades for c in b]
        wrong = [c for c in flat if c not in self.names[:n_qi] or c == self.names[self.azimuth]]
        if wrong:
            raise ModelError(f"campbell: rotating: {', '.join(map(str, wrong))} are not "
                             "independent coordinates of the blades (the azimuth excluded)")
        if len(set(flat)) != len(flat):
            raise ModelError("campbell: rotating: a coordinate is given twice")
        return np.array([[self.names.index(c) for c in b] for b in blades])

    def _blade_speeds(self, A):
        """The speed whose value is each blade coordinate's rate (a row of A)."""
        n = len(self.names)
        speeds = np.empty_like(self.blades)
        for index, i in np.ndenumerate(self.blades):
            row = A[i]
            k = int(np.argmax(np.abs(row)))
            unit = np.zeros(n)
            unit[k] = 1.0
            if k < self.n_qi or not np.allclose(row, unit, rtol=0, atol=1e-12):
                raise ModelError(f"campbell: rotating: the rate of {self.names[i]} is not a "
                                 "speed of the model (needs dq/dt = u for the multiblade "
                                 "transformation)")
            speeds[index] = k
        return speeds

    def _driven(self, model, A, y, t):
        r"""``A`` with the rotor speed prescribed: its equation dropped, the others solved again.

        At a steady motion (:math:`\dot u^* = 0`) the speeds' rows of ``A`` are
        :math:`M^{-1}\,\delta F`; the speed held by a drive (whose torque is
        what the dropped equation would give) leaves :math:`M` and
        :math:`\delta F` before solving.
        """
        n_qi = self.n_qi
        M = model.mass_matrix(t, y)
        forces = M @ A[n_qi:]
        keep = [k for k in range(len(M)) if k != self.speed_row - n_qi]
        driven = A.copy()
        driven[[n_qi + k for k in keep]] = np.linalg.solve(M[np.ix_(keep, keep)], forces[keep])
        return driven

    def _weights(self, model, A, y, t):
        r"""Per coordinate, :math:`\sqrt{M_{kk}}\,/\,|\partial\dot q_i/\partial u_k|` of the speed
        :math:`u_k` that moves it most: coordinates of different units made comparable
        (a shape so scaled has the units of :math:`\sqrt{kg}\,m`)."""
        n_qi = self.n_qi
        mass = np.abs(np.diag(model.mass_matrix(t, y)))[:len(self.names) - n_qi]
        rates = np.abs(A[:n_qi, n_qi:])
        k = np.argmax(rates, axis=1)
        scale = rates[np.arange(n_qi), k]
        return np.sqrt(mass[k]) / np.where(scale > 0, scale, 1.0)

    def state_matrix(self, model, y, t, r):
        """The linearization about ``y`` (driven, in multiblade coordinates as asked) and
        the weights of the kept coordinates."""
        A = model.linearize(y, t=t, r=r)[0]
        weights = self._weights(model, A, y, t)[self.kept[:len(self.coordinates)]]
        if self.constant_speed:
            A = self._driven(model, A, y, t)
        if self.blades is not None:
            rate = float(model.rhs(t, y)[self.state_azimuth])  # kinematic: no input
            A = to_multiblade(A, self.blades, self._blade_speeds(A), y[self.state_azimuth],
                              rate)
        return A, weights

    def modes(self, model, y, t, r):
        """Eigenvalues, coordinate shapes and periodicity of the steady motion ``y``."""
        A, weights = self.state_matrix(model, y, t, r)
        turned = y.copy()   # a quarter of the blade spacing further on
        turned[self.state_azimuth] += np.pi / (2 * (1 if self.blades is None
                                                    else len(self.blades)))
        change = np.max(np.abs(self.state_matrix(model, turned, t, r)[0] - A))
        periodicity = float(change) / max(float(np.max(np.abs(A))), 1e-300)
        values, vectors = np.linalg.eig(A[np.ix_(self.kept, self.kept)])
        magnitude = max(float(np.max(np.abs(values))), 1e-300) if values.size else 1.0
        oscillatory = values.imag > 1e-9 * magnitude
        shapes = vectors[self.coordinates][:, oscillatory] * weights[:, None]
        shapes = shapes / np.linalg.norm(shapes, axis=0)
        return values[oscillatory], shapes, periodicity


def _mac(a, b):
    """MAC between the columns of ``a`` and those of ``b``, shape (a cols, b cols)."""
    return np.abs(a.conj().T @ b) ** 2 / np.outer(np.sum(np.abs(a) ** 2, 0),
                                                  np.sum(np.abs(b) ** 2, 0))


def _tracked(speeds, rows, layout, n_modes, harmonics):
    """Follow the modes by MAC from speed to speed; the CampbellDiagram."""
    from scipy.optimize import linear_sum_assignment
    first = next((k for k, row in enumerate(rows) if row[1] is not None), None)
    if first is None:
        raise ModelError("campbell: no steady motion found at any speed (see "
                         "kanedyn.equilibrium from y0 with the speed held)")
    order = np.argsort(rows[first][1].imag)
    count = len(order) if n_modes is None else min(int(n_modes), len(order))
    n_s, n_c = len(speeds), len(layout.coordinate_names)
    eigenvalues = np.full((n_s, count), np.nan + 0j)
    shapes = np.full((n_s, n_c, count), np.nan + 0j)
    mac = np.full((n_s, count), np.nan)
    reference = rows[first][2][:, order[:count]]
    for k, (_, values, vectors, _) in enumerate(rows):
        if values is None or k < first:
            continue
        match = _mac(reference, vectors)
        tracks, picks = linear_sum_assignment(-match)
        eigenvalues[k, tracks] = values[picks]
        shapes[k, :, tracks] = vectors[:, picks].T
        mac[k, tracks] = match[tracks, picks]
        reference = reference.copy()
        reference[:, tracks] = vectors[:, picks]
    found = np.isfinite(eigenvalues.real)
    last = [int(np.nonzero(found[:, j])[0][-1]) for j in range(count)]
    labels = tuple(_label(shapes[k, :, j], layout, speeds[k]) for j, k in enumerate(last))
    with np.errstate(invalid="ignore"):
        damping = -eigenvalues.real / np.abs(eigenvalues)
    return CampbellDiagram(
        speeds=speeds, frequencies=eigenvalues.imag / (2 * np.pi), damping_ratios=damping,
        eigenvalues=eigenvalues, shapes=shapes, mac=mac, labels=_unique(labels),
        coordinate_names=layout.coordinate_names,
        states=np.array([row[0] for row in rows]),
        converged=np.array([row[1] is not None for row in rows]),
        periodicity=np.array([row[3] for row in rows]), harmonics=harmonics)


def _label(shape, layout, omega):
    """The largest coordinate's name (and the next if above half of it); a cyclic
    multiblade coordinate says its whirl."""
    names = layout.coordinate_names
    order = np.argsort(-np.abs(shape))
    i = int(order[0])
    name = names[i]
    for suffix, partner in ((" cos", " sin"), (" sin", " cos")):
        if name.endswith(suffix) and name[:-len(suffix)] + partner in names:
            base = name[:-len(suffix)]
            c = shape[names.index(base + " cos")]
            s = shape[names.index(base + " sin")]
            turn = np.imag(np.conj(c) * s) * np.sign(omega)
            if omega == 0 or abs(turn) < 1e-3 * abs(shape[i]) ** 2:
                return f"{base} cyclic"
            return f"{base} {'forward' if turn < 0 else 'backward'} whirl"
    if len(order) > 1 and abs(shape[order[1]]) > 0.5 * abs(shape[i]):
        return f"{name}, {names[int(order[1])]}"
    return name


def _unique(labels):
    """Labels made distinct by a count where several modes share a largest coordinate."""
    seen, out = {}, []
    for name in labels:
        seen[name] = seen.get(name, 0) + 1
        out.append(name if labels.count(name) == 1 else f"{name} ({seen[name]})")
    return tuple(out)
