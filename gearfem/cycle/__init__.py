"""Gear meshing cycle: torque-controlled contact solve over the mesh cycle, load sharing, U_max and
friction flux."""

from gearfem.cycle.model import GearContactModel
from gearfem.cycle.options import CycleOptions
from gearfem.cycle.result import CycleResult
from gearfem.cycle.solve import solve_cycle

__all__ = ["CycleOptions", "CycleResult", "GearContactModel", "solve_cycle"]
