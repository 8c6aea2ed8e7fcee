"""C source of the FMI interface around the standalone C export: ``fmi2.c`` (FMI 2.0)
or ``fmi3.c`` (FMI 3.0), each the shared core (:mod:`._c_core`) between the
standard's types (before it) and its functions (after it).

The model's functions are those of the standalone export (``model.c``:
``kanedyn_rhs``, ``kanedyn_constraints``, ``kanedyn_energy``, ``kanedyn_project``,
``kanedyn_advance``), linked into the same library.

Model exchange: the importer integrates ``der(y)``; after an integrator step
whose largest constraint residual exceeds ``kanedyn.projection_tol``,
``fmi2CompletedIntegratorStep`` (``fmi3…``) asks for an event, and
``fmi2NewDiscreteStates`` (``fmi3UpdateDiscreteStates``) projects the state onto
the constraints (as ``kd.simulate``'s drift event).  Co-simulation: ``fmi2DoStep``
(``fmi3DoStep``) integrates with ``kanedyn_advance`` (Dormand-Prince 5(4), the
inputs held or, when their derivatives are set through FMI 2.0's
``fmi2SetRealInputDerivatives``, linear in time; the state projected after any
internal step whose residual exceeds the tolerance).  Both make the initial state
consistent at the end of initialization, as ``kd.simulate`` does.
"""

from __future__ import annotations

from . import _c_fmi2, _c_fmi3
from ._c_core import CORE

__all__ = ["wrapper_source", "WRAPPER_FILES"]

#: the interface's source file name, per FMI major version
WRAPPER_FILES = {2: "fmi2.c", 3: "fmi3.c"}
_INTERFACES = {2: _c_fmi2, 3: _c_fmi3}


def _c_string(text):
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _numbers(values):
    return ", ".join(repr(float(v)) for v in values) or "0.0"


def wrapper_source(layout, identifier, guid, title, n_constraints, settings, fmi_version=2,
                   n_contacts=0):
    """C99 source of ``fmi2.c`` or ``fmi3.c``.

    Parameters
    ----------
    layout : FmuVariables
    identifier, guid, title : str
        ``guid`` is FMI 3.0's ``instantiationToken``.
    n_constraints : int
        Configuration plus velocity constraints (``kanedyn_constraints``'s residuals).
    settings : sequence of float
        Start values of ``kanedyn.rtol``, ``kanedyn.atol``, ``kanedyn.projection_tol``.
    fmi_version : {2, 3}
    n_contacts : int
        The model's contacts (``model.c`` then has the contact loop,
        ``kanedyn_contact_*``: the co-simulation step, the model-exchange
        derivatives, event indicators and event update).

    Returns
    -------
    str
    """
    interface = _INTERFACES[fmi_version]
    variables = layout.variables
    nx, np_, nr = layout.n_states, layout.n_parameters, layout.n_inputs
    inputs = variables[2 * nx + np_:2 * nx + np_ + nr]
    return (interface.HEAD + CORE + interface.API) % {
        "title": title.replace("*/", "* /"), "identifier": identifier, "guid": guid,
        "nx": nx, "nc": n_contacts, "niv": layout.n_indicators, "np": np_, "nr": nr, "ne": layout.n_energies, "ncon": n_constraints,
        "y_start": _numbers(v.start for v in variables[:nx]),
        "y_nominal": _numbers(1.0 if v.nominal is None else v.nominal
                              for v in variables[:nx]),
        "r_start": _numbers(v.start for v in inputs), "settings": _numbers(settings),
        "names": ", ".join(_c_string(v.name) for v in variables)}
