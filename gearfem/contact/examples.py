"""Verification geometries for contact: two blocks (patch test, sliding) and two cylinders (Hertz).

Each function builds a gmsh model on rank 0 of ``comm`` and returns DOLFINx ``MeshData`` whose
physical groups are looked up by name. Bodies are separate gmsh volumes (no shared nodes), so
their interface meshes do not match.
"""

from __future__ import annotations

import contextlib
import math

import gmsh
import numpy as np
from mpi4py import MPI

from gearfem.params import require_int, require_positive


INITIAL_GAP = 1e-6  # relative to the radius, see hertz_cylinders


@contextlib.contextmanager
def _gmsh_model(name: str):
    """An initialised gmsh with a fresh model (rank-local)."""
    started = not gmsh.isInitialized()
    if started:
        gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(name)
    try:
        yield gmsh.model
    finally:
        gmsh.model.remove()
        if started:
            gmsh.finalize()


def _to_dolfinx(comm: MPI.Comm, build) -> object:
    from dolfinx.io import gmsh as gmshio

    with _gmsh_model("gearfem_example"):
        if comm.rank == 0:
            build()
        return gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=3)


def _box_surfaces(vol: int) -> dict[str, int]:
    """Bounding-box named faces of an axis-aligned box volume: xmin, xmax, ymin, ... -> surface tag."""
    out = {}
    for dim, tag in gmsh.model.getBoundary([(3, vol)], oriented=False):
        xmin, ymin, zmin, xmax, ymax, zmax = gmsh.model.getBoundingBox(dim, tag)
        c = np.array([xmin + xmax, ymin + ymax, zmin + zmax]) / 2
        ext = np.array([xmax - xmin, ymax - ymin, zmax - zmin])
        k = int(np.argmin(ext))
        lo, hi = gmsh.model.getBoundingBox(3, vol)[k], gmsh.model.getBoundingBox(3, vol)[k + 3]
        out[("xyz"[k]) + ("min" if abs(c[k] - lo) < abs(c[k] - hi) else "max")] = tag
    return out


def two_blocks(
    comm: MPI.Comm,
    size_lower: float = 0.25,
    size_upper: float = 0.17,
    order: int = 2,
    hexahedra: bool = False,
    width: float = 1.0,
    height: float = 0.5,
):
    """Two blocks [0, w]² × [−h, 0] ("lower") and [0, w]² × [0, h] ("upper"), non-matching meshes.

    Physical groups: volumes ``lower``, ``upper``; faces ``{body}_{x,y,z}{min,max}``.
    """
    require_positive("size_lower", size_lower)
    require_positive("size_upper", size_upper)
    require_int("order", order, 1, 2)

    def build():
        occ = gmsh.model.occ
        lo = occ.addBox(0, 0, -height, width, width, height)
        up = occ.addBox(0, 0, 0, width, width, height)
        occ.synchronize()
        for name, vol, h in (("lower", lo, size_lower), ("upper", up, size_upper)):
            gmsh.model.addPhysicalGroup(3, [vol], name=name)
            for face, tag in _box_surfaces(vol).items():
                gmsh.model.addPhysicalGroup(2, [tag], name=f"{name}_{face}")
            pts = gmsh.model.getBoundary([(3, vol)], recursive=True)
            gmsh.model.mesh.setSize(pts, h)
            if hexahedra:
                for dim, tag in gmsh.model.getBoundary([(3, vol)], recursive=False):
                    for _, c in gmsh.model.getBoundary([(dim, tag)], recursive=False):
                        gmsh.model.mesh.setTransfiniteCurve(abs(c), max(2, int(round(width / h)) + 1))
                    gmsh.model.mesh.setTransfiniteSurface(tag)
                    gmsh.model.mesh.setRecombine(2, tag)
                gmsh.model.mesh.setTransfiniteVolume(vol)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(order)

    return _to_dolfinx(comm, build)


def hertz_cylinders(
    comm: MPI.Comm,
    radius: float = 1.0,
    thickness: float = 0.05,
    contact_size: float = 0.02,
    far_size: float = 0.25,
    refine_half_width: float = 0.15,
    layers: int = 1,
    order: int = 2,
):
    """Two equal half-cylinders (axis z) touching along the z axis: plane-strain Hertz line contact.

    The upper body is the lower half of a disc of ``radius`` centred at (0, R), the lower body the
    upper half of a disc centred at (0, −R(1 + INITIAL_GAP)) (a 1e-6 R initial gap keeps the mesher
    from joining the bodies; it is negligible next to the displacements); both extruded over ``thickness`` in z with ``layers``
    element layers (tetrahedra). The mesh is graded from ``contact_size`` within
    ``refine_half_width`` of the contact line to ``far_size``.

    Physical groups: ``upper``, ``lower`` (volumes); ``upper_flat``, ``lower_flat`` (the cut
    planes y = ±R), ``upper_curved``, ``lower_curved`` (cylindrical faces), ``{body}_front`` (z = 0),
    ``{body}_back`` (z = t).
    """
    for name, val in (("radius", radius), ("thickness", thickness), ("contact_size", contact_size),
                      ("far_size", far_size), ("refine_half_width", refine_half_width)):
        require_positive(name, val)
    require_int("layers", layers, 1, 1000)
    require_int("order", order, 1, 2)
    R = radius

    def build():
        occ = gmsh.model.occ
        out, contact_points = {}, []
        # gmsh's structured extrusion identifies mesh vertices by position, which would join the
        # two bodies at coincident contact-line nodes: the lower body starts INITIAL_GAP below.
        for name, cy, sgn in (("upper", R, -1.0), ("lower", -R - INITIAL_GAP * R, 1.0)):
            # half disc: centre (0, cy), the half towards the contact point (origin)
            p0 = occ.addPoint(0, cy, 0)
            p1 = occ.addPoint(R, cy, 0)
            p2 = occ.addPoint(0, cy + sgn * R, 0)  # contact point
            p3 = occ.addPoint(-R, cy, 0)
            a1 = occ.addCircleArc(p1, p0, p2)
            a2 = occ.addCircleArc(p2, p0, p3)
            ln = occ.addLine(p3, p1)
            surf = occ.addPlaneSurface([occ.addCurveLoop([a1, a2, ln])])
            ext = occ.extrude([(2, surf)], 0, 0, thickness, numElements=[layers], recombine=False)
            out[name] = (surf, a1, a2, ln, ext)
            contact_points.append(p2)
        occ.synchronize()
        # grading toward the contact point
        f_dist = gmsh.model.mesh.field.add("Distance")
        gmsh.model.mesh.field.setNumbers(f_dist, "PointsList", contact_points)
        f_th = gmsh.model.mesh.field.add("Threshold")
        gmsh.model.mesh.field.setNumber(f_th, "InField", f_dist)
        gmsh.model.mesh.field.setNumber(f_th, "SizeMin", contact_size)
        gmsh.model.mesh.field.setNumber(f_th, "SizeMax", far_size)
        gmsh.model.mesh.field.setNumber(f_th, "DistMin", refine_half_width)
        gmsh.model.mesh.field.setNumber(f_th, "DistMax", refine_half_width + 4 * (far_size - contact_size) + R / 4)
        gmsh.model.mesh.field.setAsBackgroundMesh(f_th)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        for name, (surf, a1, a2, ln, ext) in out.items():
            vol = [t for d, t in ext if d == 3][0]
            gmsh.model.addPhysicalGroup(3, [vol], name=name)
            faces = {"front": [surf], "back": [ext[0][1]], "curved": [], "flat": []}
            for d, t in ext[2:]:
                if d != 2:
                    continue
                com = occ.getCenterOfMass(2, t)
                cy = R if name == "upper" else -R - INITIAL_GAP * R
                (faces["flat"] if abs(com[1] - cy) < 1e-9 * R else faces["curved"]).append(t)
            for face, tags in faces.items():
                gmsh.model.addPhysicalGroup(2, tags, name=f"{name}_{face}")
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(order)

    return _to_dolfinx(comm, build)


def hertz_line_contact(force_per_length_N_m: float, radius1_m: float, radius2_m: float, E1_Pa: float,
                       nu1: float, E2_Pa: float, nu2: float) -> tuple[float, float]:
    """Hertz line contact of two parallel cylinders: (half-width a in m, peak pressure p0 in Pa).

    a = sqrt(4 P' R / (π E*)), p0 = 2 P' / (π a), 1/R = 1/R1 + 1/R2 (R2 = inf for a plane),
    1/E* = (1 − ν1²)/E1 + (1 − ν2²)/E2 (Johnson, Contact Mechanics, §4.2).
    """
    inv_R = 1.0 / radius1_m + (0.0 if math.isinf(radius2_m) else 1.0 / radius2_m)
    E_star = 1.0 / ((1 - nu1**2) / E1_Pa + (1 - nu2**2) / E2_Pa)
    a = math.sqrt(4.0 * force_per_length_N_m / (math.pi * E_star * inv_R))
    return a, 2.0 * force_per_length_N_m / (math.pi * a)
