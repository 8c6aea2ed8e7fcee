"""Simulation: integration in time, events, modes and impacts, results.

``_simulate``    ``simulate``: checks, dispatch to solve_ivp, the compiled loop, a
                 scheme's own integrator or the contact loop; drift projection
``_run_guard``   what ends a run early (non-finite derivative, Ctrl-C, the time
                 limit) without losing what was computed
``_energy_check`` whether a run's energy balance holds (the stored energy against
                 the work done on the model); ``TrustWarning``
``_hybrid``      contact modes, events and impacts, segment by segment
``_impact``      the impulse-momentum form of impacts with friction
``_index3``      the fixed-step integrator of the index-3 augmented Lagrangian
``_results``     ``SimulationResult``
``_sweep``       ``sweep``: many runs over a parameter grid or samples, on Dask
``_ensemble``    ``simulate_many``: many runs of a compiled model at once, in C threads
``_events``      ``Event``: events given as SymPy expressions, for ``simulate`` (as
                 Python functions) and ``simulate_many`` (compiled to C)
``_sensitivity`` ``sensitivity``: a run with the derivatives of its states with
                 respect to the initial state and the constants
"""

from .._lazy import lazy_attributes as _lazy_attributes

#: public name -> the module (in this package) that defines it; imported on first use
#: (a run on the compiled loop imports neither SciPy nor SymPy)
_LAZY = {
    "simulate": "._simulate",
    "SimulationResult": "._results",
    "ModeChange": "._hybrid",
    "Impact": "._impact",
    "TrustWarning": "._energy_check",
    "COMPILED_METHODS": "._simulate",
    "METHODS": "._simulate",
    "OWN_INTEGRATORS": "._simulate",
    "sweep": "._sweep",
    "simulate_many": "._ensemble",
    "EnsembleResult": "._ensemble",
    "Event": "._events",
    "SweepInterrupted": "._sweep",
    "SWEEP_OUTPUTS": "._sweep",
    "check_scheduler": "._sweep",
    "sensitivity": "._sensitivity",
    "Sensitivity": "._sensitivity",
}

__all__ = list(_LAZY)

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__)
