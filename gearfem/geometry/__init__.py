"""Gear geometry: involute tooth mathematics (numpy), the gmsh model of the pair, DOLFINx meshes.

* :mod:`gearfem.geometry.involute` — :class:`GearPairGeometry` (the ``[geometry]`` table),
  :class:`GearPair` (kinematics, contact ratio, backlash, tooth outlines), pure numpy.
* :mod:`gearfem.geometry.gmsh_pair` — :class:`MeshOptions` (the ``[mesh]`` table) and the gmsh
  model with named physical groups.
* :mod:`gearfem.geometry.mesh` — :func:`build_gear_mesh` (cached, MPI-safe) returning a
  :class:`GearMesh` the solvers use.
"""

from __future__ import annotations

from gearfem.geometry.involute import (
    GearPair,
    GearPairGeometry,
    PathOfContact,
    ToothProfile,
    inv,
    inv_inverse,
)
from gearfem.geometry.mesh import GearMesh, build_gear_mesh
from gearfem.geometry.options import MeshOptions

__all__ = [
    "GearMesh",
    "GearPair",
    "GearPairGeometry",
    "MeshOptions",
    "PathOfContact",
    "ToothProfile",
    "build_gear_mesh",
    "inv",
    "inv_inverse",
]
