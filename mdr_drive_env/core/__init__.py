"""Physics core of mdr-drive: parameters, materials, waveforms and the MDR drive simulator.

Knows nothing of Gymnasium or RL.
"""

from .analysis import CriticalLoad, SteadyVelocity, critical_load, steady_velocity
from .materials import (
    contact_radius,
    h_normal,
    h_tangential,
    mdr_profile,
    mindlin_tangential_force,
    normal_force_analytic,
)
from .params import NUMERICS_PRESETS, Contact, Drive, DriveParams, Material, Numerics, numerics_preset
from .simulator import DriveSimulator, PeriodResult, concat_traces
from .waveform import PAPER_X, PAPER_Z, AxisWaveform, Waveform, period_knots

__all__ = [
    "CriticalLoad",
    "SteadyVelocity",
    "critical_load",
    "steady_velocity",
    "AxisWaveform",
    "Contact",
    "Drive",
    "DriveParams",
    "DriveSimulator",
    "Material",
    "NUMERICS_PRESETS",
    "Numerics",
    "PAPER_X",
    "PAPER_Z",
    "PeriodResult",
    "Waveform",
    "concat_traces",
    "contact_radius",
    "h_normal",
    "h_tangential",
    "mdr_profile",
    "mindlin_tangential_force",
    "normal_force_analytic",
    "numerics_preset",
    "period_knots",
]
