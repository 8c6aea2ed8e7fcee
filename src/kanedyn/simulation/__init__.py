"""Simulation: integration in time, events, modes and impacts, results.

``_simulate``    ``simulate``: checks, dispatch to solve_ivp, the compiled loop, a
                 scheme's own integrator or the contact loop; drift projection
``_run_guard``   what ends a run early (non-finite derivative, Ctrl-C) without
                 losing what was computed
``_hybrid``      contact modes, events and impacts, segment by segment
``_impact``      the impulse-momentum form of impacts with friction
``_index3``      the fixed-step integrator of the index-3 augmented Lagrangian
``_results``     ``SimulationResult``
``_sweep``       ``sweep``: many runs over a parameter grid or samples, on Dask
"""

from ._hybrid import ModeChange
from ._impact import Impact
from ._results import SimulationResult
from ._simulate import COMPILED_METHODS, METHODS, OWN_INTEGRATORS, TrustWarning, simulate
from ._sweep import OUTPUTS as SWEEP_OUTPUTS
from ._sweep import SweepInterrupted, sweep

__all__ = ["simulate", "SimulationResult", "ModeChange", "Impact", "TrustWarning",
           "COMPILED_METHODS", "METHODS", "OWN_INTEGRATORS", "sweep", "SweepInterrupted",
           "SWEEP_OUTPUTS"]
