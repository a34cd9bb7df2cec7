"""Transient thermal model of one gear body: sources, convection, radiation, heat balance.

Public API::

    ThermalDomain            mesh + facet groups + roles (teeth, sides, bore, cuts), monitors
    HeatSources              hysteresis (U_max, H(T), f) and flank flux (the cycle stage's product)
    PrescribedSources        [sources] table: uniform flank heat and U_max until the cycle exists
    ThermalOptions           [thermal] table
    ThermalBoundary          resolved surface exchanges (from_options: thesis eq. 5.1-5.6)
    ThermalProblem           transient (BDF2, adaptive) and steady solver
    HeatBalance, StepRecord  per-step results
"""

from gearfem.thermal.balance import HeatBalance
from gearfem.thermal.boundary import SurfaceExchange, ThermalBoundary
from gearfem.thermal.convection import (
    AirProperties,
    ConvectionCoefficients,
    GearRadii,
    thesis_convection,
)
from gearfem.thermal.domain import ThermalDomain
from gearfem.thermal.options import PrescribedSources, ThermalOptions, loading_frequency_Hz
from gearfem.thermal.problem import StepRecord, ThermalProblem
from gearfem.thermal.source_terms import HeatSources, prescribed_heat_sources

__all__ = [
    "AirProperties",
    "ConvectionCoefficients",
    "GearRadii",
    "HeatBalance",
    "HeatSources",
    "PrescribedSources",
    "StepRecord",
    "SurfaceExchange",
    "ThermalBoundary",
    "ThermalDomain",
    "ThermalOptions",
    "ThermalProblem",
    "loading_frequency_Hz",
    "prescribed_heat_sources",
    "thesis_convection",
]
