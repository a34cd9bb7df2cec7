"""Gear meshing cycle: torque-controlled contact sweep, load sharing, U_max and friction flux."""

from gearfem.cycle.model import CycleOptions, GearContactModel
from gearfem.cycle.sweep import CycleResult, run_cycle

__all__ = ["CycleOptions", "CycleResult", "GearContactModel", "run_cycle"]
