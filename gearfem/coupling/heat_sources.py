"""Heat sources from the contact cycle, placed on the thermal mesh of one gear.

The cycle (:mod:`gearfem.cycle`) gives, for the reference tooth of each gear, the maximum strain
energy density U_max of every cell of the tooth's sector and the revolution-averaged friction flux
of every contact facet, per unit pinion speed. With rotation-averaged sources every tooth sees
the same heating (thesis 5.2), so each thermal cell and flank facet takes the value of its
congruent place in the reference sector: its centroid is rotated by whole pitches into that
sector and the nearest reference entity is taken (identical meshes of the teeth make this exact;
otherwise it is nearest-neighbour sampling). The flank heat of every tooth is then rescaled to
exactly the reference tooth's heat, so the heat put into the thermal model equals the gear's share
of the friction loss to round-off.

* hysteresis: q_h = H(T) U_max f with f the rotational frequency of the gear (thesis eq. 2.15) or
  the tooth-pass frequency (``loading_frequency``);
* friction: q = flux per unit ω₁ × ω₁, into the drive flanks, tips and roots that touched.
"""

from __future__ import annotations

import math

import numpy as np
import ufl
from mpi4py import MPI
from scipy.spatial import cKDTree

from gearfem.contact.kinematics import evaluate
from gearfem.core.errors import ParameterError
from gearfem.core.facets import FacetReference
from gearfem.core.materials import ZERO_CELSIUS_K, Material
from gearfem.coupling.options import SourceOptions
from gearfem.geometry.mesh import parse_group_name
from gearfem.thermal.source_terms import (
    HeatSources,
    loading_frequency_Hz,
)

# ------------------------------------------------------------------------------------------------


def _tooth_local(
    points: np.ndarray, center: np.ndarray, tooth_angles: np.ndarray, pitch: float, ref_angle: float
) -> tuple[np.ndarray, np.ndarray]:
    """Rotate points into the reference tooth's sector: (rotated points, index of their tooth)."""
    p = np.asarray(points) - center
    theta = np.arctan2(p[:, 1], p[:, 0])
    d = np.angle(np.exp(1j * (theta[:, None] - np.asarray(tooth_angles)[None, :])))
    k = np.argmin(np.abs(d), axis=1)
    rot = ref_angle - np.asarray(tooth_angles)[k]
    c, s = np.cos(rot), np.sin(rot)
    out = np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1], p[:, 2]])
    return out, k


def _cell_centroids(mesh, n: int) -> np.ndarray:
    return mesh.geometry.x[mesh.geometry.dofmaps[0][:n]].mean(axis=1)


def u_max_function(domain, gear_mesh, body: str, fields):
    """DG0 U_max (J/m³) on the thermal mesh from the cycle's reference sector (collective-free)."""
    from dolfinx import fem

    mesh = domain.mesh
    Q = fem.functionspace(mesh, ("DG", 0))
    f = fem.Function(Q, name="U_max")
    n = mesh.topology.index_map(3).size_local + mesh.topology.index_map(3).num_ghosts
    x = _cell_centroids(mesh, n)
    angles = gear_mesh.tooth_angles(body)
    center = np.asarray(gear_mesh.center(body))
    xl, _ = _tooth_local(x, center, angles, fields.pitch_angle_rad, fields.tooth_angle_rad)
    ref = fields.cell_points_m - fields.center_m
    _, j = cKDTree(ref).query(xl)
    f.x.array[Q.dofmap.list[:n, 0]] = fields.u_max_J_m3[j]
    f.x.scatter_forward()
    return f


# Facet areas for the per-tooth normalisation: exact enough on curved P2 facets (tip rounds) that
# the heat assembled with this rule equals the target to round-off (degree 2 left 2e-6).
AREA_QUADRATURE_DEGREE = 6


def friction_flux_function(
    domain,
    gear_mesh,
    body: str,
    fields,
    omega1_rad_s: float,
    heat_fraction: float,
    kinds: tuple[str, ...] = ("drive_flank", "tip", "root"),
):
    """DG0 flank flux (W/m²) into this gear on the cells next to the contact surfaces, and those
    surfaces' names: ``heat_fraction`` of the generated flux at pinion speed ``omega1_rad_s``.

    Each facet of the drive flanks, tips and roots takes the reference facet nearest to its
    congruent place; every tooth's total is then scaled to the reference tooth's heat. (A cell
    touching two such facets carries their area-weighted mean.) Collective (totals are reduced).
    """
    from dolfinx import fem

    mesh = domain.mesh
    tdim = mesh.topology.dim
    names = tuple(
        n
        for n in domain.groups
        if parse_group_name(n)[0] == body
        and parse_group_name(n)[2] in kinds
        and parse_group_name(n)[1] is not None
    )
    if not names:
        raise ParameterError(
            "sources.friction surfaces", kinds, f"facet groups of {body!r} in the thermal mesh"
        )
    facets = domain.facets(names)
    n_owned_f = mesh.topology.index_map(tdim - 1).size_local
    facets = facets[facets < n_owned_f]
    mesh.topology.create_connectivity(tdim - 1, tdim)
    cf = np.asarray(
        fem.compute_integration_domains(fem.IntegralType.exterior_facet, mesh.topology, facets)
    ).reshape(-1, 2)
    import basix

    cell_type = {
        "tetrahedron": basix.CellType.tetrahedron,
        "hexahedron": basix.CellType.hexahedron,
    }[mesh.topology.cell_name()]
    ref = FacetReference.create(cell_type, mesh.geometry.cmaps[0].degree)
    X = mesh.geometry.x[
        np.take_along_axis(mesh.geometry.dofmaps[0][cf[:, 0]], ref.facet_nodes[cf[:, 1]], axis=1)
    ]
    xc = X[:, : ref.num_vertices].mean(axis=1)
    qp, qw = ref.quadrature(AREA_QUADRATURE_DEGREE)
    area = np.zeros(len(facets))
    for p_, w_ in zip(qp, qw):
        _, a1, a2, _ = evaluate(ref, X, np.tile(p_, (len(facets), 1)))
        area += w_ * np.linalg.norm(np.cross(a1, a2), axis=1)
    angles = gear_mesh.tooth_angles(body)
    center = np.asarray(gear_mesh.center(body))
    xl, tooth = _tooth_local(xc, center, angles, fields.pitch_angle_rad, fields.tooth_angle_rad)
    _, j = cKDTree(fields.facet_points_m - fields.center_m).query(xl)
    q = heat_fraction * fields.generated_flux_W_m2_per_rad_s[j] * omega1_rad_s
    # per-tooth conservation: each tooth carries exactly the reference tooth's heat
    ntooth = len(angles)
    tooth_heat = mesh.comm.allreduce(
        np.bincount(tooth, weights=q * area, minlength=ntooth), op=MPI.SUM
    )
    generated = float(np.sum(fields.generated_flux_W_m2_per_rad_s * fields.facet_area_m2))
    target = heat_fraction * generated * omega1_rad_s
    scale = np.where(tooth_heat > 0, target / np.where(tooth_heat > 0, tooth_heat, 1.0), 0.0)
    q = q * scale[tooth]
    Q = fem.functionspace(mesh, ("DG", 0))
    fn = fem.Function(Q, name="flank_flux")
    n_cells = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
    num = np.bincount(cf[:, 0], weights=q * area, minlength=n_cells)
    den = np.bincount(cf[:, 0], weights=area, minlength=n_cells)
    vals = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
    fn.x.array[Q.dofmap.list[:n_cells, 0]] = vals
    fn.x.scatter_forward()
    return fn, names


def cycle_heat_sources(
    domain,
    gear_mesh,
    body: str,
    cycle,
    options: SourceOptions,
    materials: dict[str, Material],
    speed_rpm: float,
) -> HeatSources:
    """:class:`HeatSources` of one gear from a cycle result at pinion speed ``speed_rpm``.

    ``materials`` holds both gears' materials: the friction heat generated in the mesh is split
    between the gears here (:meth:`SourceOptions.heat_fractions`), so the cached cycle does not
    depend on the split."""
    fields = cycle.fields[body]
    material = materials[body]
    fraction = options.heat_fractions(materials)[body]
    z = gear_mesh.geometry.teeth(body)
    speed_body = gear_mesh.geometry.speed_rpm(body, speed_rpm)
    omega1 = 2.0 * math.pi * speed_rpm / 60.0
    kw = {}
    if options.hysteresis:
        kw.update(
            u_max=u_max_function(domain, gear_mesh, body, fields),
            loading_frequency_Hz=loading_frequency_Hz(options.loading_frequency, speed_body, z),
            hysteresis=material.hysteresis_table(),
            hysteresis_scale=options.hysteresis_scale,
        )
    if options.friction and cycle.friction_coefficient > 0.0:
        flux, names = friction_flux_function(domain, gear_mesh, body, fields, omega1, fraction)
        kw.update(
            flank_flux_W_m2=flux,
            flux_surfaces=names,
            flux_scale=options.flux_scale,
            flux_temperature_factor=friction_temperature_factor(options),
        )
    return HeatSources(**kw)


def friction_temperature_factor(options: SourceOptions):
    """T (kelvin, UFL) -> mu(T)/mu_ref, or None when mu does not depend on temperature."""
    beta = options.friction_temperature_coefficient_per_K
    if beta == 0.0:
        return None
    t_ref = options.friction_reference_C + ZERO_CELSIUS_K

    def factor(T):
        return ufl.exp(-beta * (T - t_ref))

    return factor
