"""Prescribed vehicle (base) motion: crash pulses, motion records, CFC filters.

``_pulses``  analytic pulses (half-sine, haversine, trapezoid, from a velocity change)
``_series``  reading and checking CSV records of accelerations and angular rates
``_filters`` SAE J211/1 channel-frequency-class filters
``_motion``  ``VehicleMotion``: the moving frame and its specified inputs
``_examples`` the example pulses shipped in ``pulses/`` and how they are made
"""

from ._examples import example_pulse
from ._filters import CFC_CLASSES, cfc_filter, cfc_response
from ._iso_mme import read_iso_mme, write_iso_mme
from ._motion import MotionCheck, VehicleMotion
from ._nhtsa import read_nhtsa_csv, write_nhtsa_csv
from ._pulses import (G0, CrashPulse, HalfSinePulse, HaversinePulse, TrapezoidPulse,
                      pulse_from_delta_v)
from ._series import PulseSeries, read_pulse_csv, write_pulse_csv

__all__ = ["VehicleMotion", "MotionCheck", "CrashPulse", "HalfSinePulse", "HaversinePulse",
           "TrapezoidPulse", "pulse_from_delta_v", "G0", "PulseSeries", "read_pulse_csv",
           "write_pulse_csv", "cfc_filter", "cfc_response", "CFC_CLASSES", "example_pulse",
           "read_iso_mme", "write_iso_mme", "read_nhtsa_csv", "write_nhtsa_csv"]
