"""The model definition shared by all built-in models."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import sympy as sm

from .._errors import ModelError
from ..engine import name_of

__all__ = ["ModelDefinition"]


@dataclass(frozen=True)
class ModelDefinition:
    """A ready-to-derive model: SymPy objects, parameter values, initial state.

    Every call of a model builder creates fresh SymPy objects, so two
    definitions never share cached velocities.

    Attributes
    ----------
    name : str
        Registry name (``kanedyn list``).
    title : str
        One-line description.
    kane_args : dict
        Keyword arguments of :func:`kanedyn.kane`.
    constants : dict
        ``{Symbol: value}`` default parameters (SI units).
    initial_state : dict
        ``{dynamic symbol: value}`` for the independent coordinates and
        speeds (dependent ones are completed from the constraints), plus
        starting guesses for dependent coordinates.
    t_end : float
        Default simulation length, s.
    specified : dict
        Values for specified inputs (numbers, SymPy expressions in t, callables).
    symbols : dict
        Named handles to symbols and objects (for tests and examples).
    description : str
        Longer text: what the model is and what it validates.
    units : dict
        ``{Symbol: unit text}`` of constants whose unit is declared (shown by
        ``kanedyn list MODEL``); the others are in SI units too.
    """

    name: str
    title: str
    kane_args: dict
    constants: dict
    initial_state: dict
    t_end: float
    specified: dict = field(default_factory=dict)
    symbols: dict = field(default_factory=dict)
    description: str = ""
    units: dict = field(default_factory=dict)

    def derive(self, progress=False, method="kane"):
        """Equations of motion (:func:`kanedyn.formulate`)."""
        from ..formulations import formulate
        return formulate(method=method, progress=progress, **self.kane_args)

    def numeric(self, eom=None, constants=None, specified=None, **options):
        """Numerical model with the default constants, updated by ``constants``."""
        eom = eom if eom is not None else self.derive()
        values = dict(self.constants)
        values.update(self._constant_overrides(constants or {}))
        inputs = dict(self.specified)
        inputs.update(specified or {})
        return eom.numeric(constants=values, specified=inputs, **options)

    def _constant_overrides(self, overrides):
        out = {}
        by_name = {str(s): s for s in self.constants}
        for key, value in overrides.items():
            sym = by_name.get(key) if isinstance(key, str) else key
            if sym not in self.constants:
                raise ModelError(f"{key} is not a parameter of model {self.name}; "
                                 f"parameters: {', '.join(sorted(by_name))}")
            out[sym] = value
        return out

    def initial(self, model, overrides=None):
        """Initial state array for ``model`` (independent values as given)."""
        y = np.zeros(model.n_states)
        values = dict(self.initial_state)
        for key, value in (overrides or {}).items():
            values[key] = value
        for key, value in values.items():
            y[model.index(key if isinstance(key, str) else name_of(key))] = float(value)
        return y

    def parameter_table(self):
        """``[(name, value)]`` of the default constants, sorted by name."""
        return sorted(((str(k), v) for k, v in self.constants.items()), key=lambda x: x[0])


def gravity_potential(masses_heights):
    """Sum of ``m * g * h`` terms (helper for model potentials)."""
    return sm.Add(*[m * g * h for m, g, h in masses_heights])
