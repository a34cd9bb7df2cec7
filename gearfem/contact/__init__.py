"""Two-body frictional contact for DOLFINx on curved P2 (and P1) meshes.

``surface`` (facets of a body), ``kinematics`` (curved-facet evaluation, projection, segmentation),
``interface`` (gaps, tractions, linearisation of one surface pair), ``problem`` (elasticity +
contact,
Newton / augmented Lagrangian), ``rigid`` (rigid motions of bodies), ``verification`` (verification
geometries and the Hertz formulas).
"""

from gearfem.contact.interface import ContactInterface, ContactPoints
from gearfem.contact.options import ContactOptions
from gearfem.contact.problem import ContactProblem, SolveReport, fixed_mask
from gearfem.contact.rigid import RigidMotion
from gearfem.contact.surface import ContactSurface

__all__ = [
    "ContactInterface",
    "ContactOptions",
    "ContactPoints",
    "ContactProblem",
    "ContactSurface",
    "RigidMotion",
    "SolveReport",
    "fixed_mask",
]
