"""Vehicle (base) motion: crash pulses, measured records and their filters (``kd.vehicle``).

What drives a :class:`kanedyn.VehicleMotion` (the moving frame itself stays at
``kd.VehicleMotion``); ``docs/vehicle_motion.md`` describes each::

    CrashPulse          a pulse a(t) made of pieces, with exact velocity change
    HalfSinePulse       a = A sin(pi t/T) on [0, T]
    HaversinePulse      a = A (1 - cos(2 pi t/T))/2 on [0, T]
    TrapezoidPulse      a linear rise, a hold, a linear fall
    pulse_from_delta_v  a half-sine or haversine pulse from a velocity change
    read_pulse_csv      a CSV record of accelerations and angular rates, checked
    read_iso_mme        a crash-test record in the ISO 13499 (ISO-MME) format
    read_nhtsa_csv      a record in the CSV of the NHTSA test database's export
    write_iso_mme       an ISO-MME test folder (from samples of your own)
    write_nhtsa_csv     an NHTSA-style CSV (from samples of your own)
    cfc_filter          an SAE J211/1 channel-frequency-class filter (CFC 60, 180, ...)
    example_pulse       the path of a pulse record shipped with kanedyn (CSV)

These names were at ``kd.`` before: that spelling still gives the same object,
with a DeprecationWarning naming the new one.
"""

from ._lazy import NAMESPACES as _NAMESPACES
from ._lazy import lazy_attributes as _lazy_attributes

#: public name -> the module that defines it (relative to ``kanedyn``); imported on first use
_LAZY = {
    "CrashPulse": ".modeling.vehicle",
    "HalfSinePulse": ".modeling.vehicle",
    "HaversinePulse": ".modeling.vehicle",
    "TrapezoidPulse": ".modeling.vehicle",
    "pulse_from_delta_v": ".modeling.vehicle",
    "read_pulse_csv": ".modeling.vehicle",
    "read_iso_mme": ".modeling.vehicle",
    "read_nhtsa_csv": ".modeling.vehicle",
    "write_iso_mme": ".modeling.vehicle",
    "write_nhtsa_csv": ".modeling.vehicle",
    "cfc_filter": ".modeling.vehicle",
    "example_pulse": ".modeling.vehicle",
}

__all__ = list(_LAZY)

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__,
                                        neighbours=_NAMESPACES)
