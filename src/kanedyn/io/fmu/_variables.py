"""The FMI variables of an exported model: states, derivatives, parameters, inputs,
outputs and the co-simulation solver's settings, with their value references.

Value references are consecutive, in blocks (the C wrapper's ``VR_*`` macros):
the states ``y`` (coordinates then speeds, as ``model.state_names``), their
derivatives, the parameters ``p`` (the model's constants, in the order of
``model.constants``), the specified inputs ``r``, the energy outputs (kinetic;
potential where the model declares one), the solver settings, then, with contacts,
their modes (outputs) and, in FMI 3.0, their event indicators.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["FmuVariable", "FmuVariables", "SETTINGS", "fmu_variables"]

#: the co-simulation solver's settings (FMI parameters): name -> description
SETTINGS = {
    "kanedyn.rtol": "relative tolerance of the co-simulation step's Dormand-Prince 5(4) "
                    "integration (the tolerance of fmi2SetupExperiment replaces it when "
                    "given)",
    "kanedyn.atol": "absolute tolerance of the co-simulation step's integration",
    "kanedyn.projection_tol": "largest constraint residual before the state is projected "
                              "onto the constraints (co-simulation: after an internal step; "
                              "model exchange: a step event)"}


@dataclass(frozen=True)
class FmuVariable:
    """One FMI ``ScalarVariable`` (all are Real).

    Attributes
    ----------
    name : str
    value_reference : int
    causality : str
        ``"output"``, ``"local"``, ``"parameter"`` or ``"input"``.
    variability : str
        ``"continuous"`` or ``"fixed"``.
    initial : str or None
        ``"exact"``, ``"calculated"`` or ``None`` (inputs: not given).
    start : float or None
    unit : str or None
    description : str
    derivative : int or None
        For a state derivative: the 1-based index of its state among the
        model variables.
    nominal : float or None
        For a state: its typical magnitude, where declared (importers scale their
        absolute tolerance by it; FMI's default is 1).
    """

    name: str
    value_reference: int
    causality: str
    variability: str
    initial: str | None
    start: float | None
    unit: str | None
    description: str
    derivative: int | None = None
    nominal: float | None = None


@dataclass(frozen=True)
class FmuVariables:
    """The variables of an FMU and the sizes of their blocks.

    Attributes
    ----------
    variables : tuple of FmuVariable
        In value-reference order (which is also their order in
        ``modelDescription.xml``: index = value reference + 1).
    n_states, n_parameters, n_inputs, n_energies : int
        Sizes of the blocks (``n_energies``: 1, or 2 with a potential energy).
    n_indicators : int
        The event indicators' variables, the last block (FMI 3.0 declares the
        event indicators of a model with contacts as variables).
    """

    variables: tuple
    n_states: int
    n_parameters: int
    n_inputs: int
    n_energies: int
    n_indicators: int = 0

    def block(self, causality, variability="continuous"):
        """1-based indices of the variables of ``causality`` and ``variability``."""
        return [k + 1 for k, v in enumerate(self.variables)
                if v.causality == causality and v.variability == variability]

    @property
    def derivatives(self):
        """1-based indices of the state derivatives."""
        return [k + 1 for k, v in enumerate(self.variables) if v.derivative is not None]


def derivative_unit(unit):
    """The unit of the time derivative of a quantity in ``unit`` (None: unknown)."""
    if unit is None:
        return None
    if unit.endswith("/s"):
        return unit + "^2" if "/" not in unit[:-2] else f"({unit})/s"
    return f"{unit}/s"


def fmu_variables(model, y0, r0, settings, constant_units, nominals=None, indicators=False):
    """The variables of ``model`` exported as an FMU.

    Parameters
    ----------
    model : NumericModel
    y0 : ndarray, shape (n_states,)
        Start values of the states (SI units).
    r0 : sequence of float, length n_r
        Start values of the specified inputs.
    settings : dict
        ``{setting name: value}`` for every name of :data:`SETTINGS`.
    constant_units : dict
        ``{constant name: unit}`` of the constants whose unit is declared.
    nominals : dict, optional
        ``{state name: typical magnitude}`` of the states whose nominal value is
        declared.
    indicators : bool
        Declare the event indicators (two per contact) as variables (FMI 3.0).

    Returns
    -------
    FmuVariables
    """
    out = []
    nominals = nominals or {}

    def add(name, causality, variability, initial, start, unit, description, derivative=None,
            nominal=None):
        out.append(FmuVariable(name, len(out), causality, variability, initial,
                               None if start is None else float(start), unit, description,
                               derivative, nominal))

    units = model.state_units
    n = model.n_q
    for k, name in enumerate(model.state_names):
        dependent = (n - model.n_q_dep <= k < n) or k >= n + model.n_u - model.n_u_dep
        kind = "coordinate" if k < n else "speed"
        note = " (dependent: completed from the constraints at initialization)" \
            if dependent else ""
        add(name, "output", "continuous", "exact", y0[k], units.get(name), kind + note,
            nominal=nominals.get(name))
    for k, name in enumerate(model.state_names):
        add(f"der({name})", "local", "continuous", None, None,
            derivative_unit(units.get(name)), f"time derivative of {name}", derivative=k + 1)
    for name, value in model.constants.items():
        add(name, "parameter", "fixed", "exact", value, constant_units.get(name),
            "constant of the model")
    for name, value in zip(model.input_names, r0):
        add(name.removesuffix("(t)"), "input", "continuous", None, value, None,
            "specified input (linearly interpolated within a co-simulation step when its "
            "derivative is set)")
    add("kinetic_energy", "output", "continuous", "calculated", None, "J", "kinetic energy")
    if model.has_potential:
        add("potential_energy", "output", "continuous", "calculated", None, "J",
            "potential energy (as the model declares it)")
    for name, description in SETTINGS.items():
        add(name, "parameter", "fixed", "exact", settings[name], None, description)
    for contact in model.contacts:
        add(f"{contact['name']}.mode", "output", "continuous", "calculated", None, None,
            f"mode of contact {contact['name']}: 0 separated, 1 sliding, 2 sticking "
            "(piecewise constant)")
    n_indicators = 2 * len(model.contacts) if indicators else 0
    for contact in model.contacts if indicators else ():
        for k in (1, 2):
            add(f"{contact['name']}.event_indicator_{k}", "local", "continuous", None, None,
                None, f"event indicator {k} of contact {contact['name']}: the value of an "
                "event function of its current mode (an event where it falls to zero)")
    return FmuVariables(tuple(out), model.n_states, len(model.constants),
                        len(model.input_names), 2 if model.has_potential else 1,
                        n_indicators)
