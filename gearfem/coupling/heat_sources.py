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
* friction: q = flux per unit ω₁ × ω₁, into the drive flanks, tips and roots that touched; with a
  friction law other than the cycle's constant mu, recomputed from the contact history
  (:mod:`gearfem.coupling.friction_heat`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from gearfem.contact.friction import FrictionOptions
from gearfem.core.kept import Kept
from gearfem.core.materials import ZERO_CELSIUS_K, Material
from gearfem.coupling.friction_heat import ThermalFrictionFlux, reference_flux
from gearfem.coupling.options import FluxReconstruction, SourceOptions
from gearfem.coupling.transfer import (
    AREA_QUADRATURE_DEGREE,
    FLANK_KINDS,
    FlankTransfer,
    tooth_local,
)
from gearfem.thermal.source_terms import (
    HeatSources,
    loading_frequency_Hz,
)

# ------------------------------------------------------------------------------------------------


def _cell_centroids(mesh, n: int) -> np.ndarray:
    return mesh.geometry.x[mesh.geometry.dofmaps[0][:n]].mean(axis=1)


#: U_max functions and flank transfers of the last runs, kept by their thermal domain, gear mesh
#: and cycle fields (the same objects; a diagnosis's runs at one torque share them).
KEPT_U_MAX: Kept = Kept(4)
KEPT_TRANSFERS: Kept[FlankTransfer] = Kept(4)


def u_max_function(domain, gear_mesh, body: str, fields):
    """DG0 U_max (J/m³) on the thermal mesh from the cycle's reference sector (collective-free;
    kept for the same domain, gear mesh and fields: read, never written, by the sources)."""
    return KEPT_U_MAX.get(
        body, (domain, gear_mesh, fields), lambda: _u_max_function(domain, gear_mesh, body, fields)
    )


def flank_transfer(
    domain, gear_mesh, body: str, fields, kinds=FLANK_KINDS, reconstruction=None
) -> FlankTransfer:
    """:class:`FlankTransfer` of the cycle's ``fields`` onto ``domain``, kept for the same domain,
    gear mesh and fields (the same objects) and the same kinds and reconstruction
    (collective-free)."""
    return KEPT_TRANSFERS.get(
        (body, tuple(kinds), reconstruction),
        (domain, gear_mesh, fields),
        lambda: FlankTransfer(domain, gear_mesh, body, fields, kinds, reconstruction),
    )


def _u_max_function(domain, gear_mesh, body: str, fields):
    from dolfinx import fem

    mesh = domain.mesh
    Q = fem.functionspace(mesh, ("DG", 0))
    f = fem.Function(Q, name="U_max")
    n = mesh.topology.index_map(3).size_local + mesh.topology.index_map(3).num_ghosts
    x = _cell_centroids(mesh, n)
    angles = gear_mesh.tooth_angles(body)
    center = np.asarray(gear_mesh.center(body))
    xl, _ = tooth_local(x, center, angles, fields.pitch_angle_rad, fields.tooth_angle_rad)
    ref = fields.cell_points_m - fields.center_m
    _, j = cKDTree(ref).query(xl)
    f.x.array[Q.dofmap.list[:n, 0]] = fields.u_max_J_m3[j]
    f.x.scatter_forward()
    return f


def friction_flux_function(
    domain,
    gear_mesh,
    body: str,
    fields,
    omega1_rad_s: float,
    heat_fraction: float,
    kinds: tuple[str, ...] = FLANK_KINDS,
    reference_flux_W_m2: np.ndarray | None = None,
    reconstruction: FluxReconstruction | None = None,
):
    """DG0 flank flux (W/m²) into this gear on the cells next to the contact surfaces, and those
    surfaces' names: ``heat_fraction`` of the generated flux at pinion speed ``omega1_rad_s``
    (or, if given, ``reference_flux_W_m2`` per reference facet, already at the speed and split).

    The reference flux is reconstructed as ``reconstruction`` says (None: as the cycle gives it);
    each facet of the drive flanks, tips and roots takes its mean at its congruent place; every
    tooth's total is then scaled to the reference tooth's heat
    (:mod:`gearfem.coupling.transfer`). Collective (totals are reduced).
    """
    tr = flank_transfer(domain, gear_mesh, body, fields, kinds, reconstruction)
    if reference_flux_W_m2 is None:
        q_ref = heat_fraction * fields.generated_flux_W_m2_per_rad_s * omega1_rad_s
    else:
        q_ref = np.asarray(reference_flux_W_m2, dtype=float)
    scale = tr.tooth_scale(q_ref)
    q = tr.sample(q_ref) * scale[tr.tooth]
    return tr.function(q, "flank_flux"), tr.names


def cycle_heat_sources(
    domain,
    gear_mesh,
    body: str,
    cycle,
    options: SourceOptions,
    materials: dict[str, Material],
    speed_rpm: float,
    friction: FrictionOptions | None = None,
) -> HeatSources:
    """:class:`HeatSources` of one gear from a cycle result at pinion speed ``speed_rpm``.

    ``materials`` holds both gears' materials: the friction heat generated in the mesh is split
    between the gears here (:meth:`SourceOptions.heat_fractions`, or Blok's partition with
    ``heat_partition = "blok"``), so the cached cycle does not depend on the split.

    ``friction`` (the ``[friction]`` law, None: the cycle's constant mu): the cycle's own constant
    mu with the fixed split and the cycle's scale of the passes is today's flux, as the cycle
    computed it; a law that does not depend on
    temperature (another constant, pressure and sliding-speed factors, Blok's partition) is
    recomputed once from the contact history
    (:func:`gearfem.coupling.friction_heat.reference_flux`); a law that depends on temperature
    becomes a surface flux model that the thermal solver updates at every residual evaluation
    (:class:`ThermalFrictionFlux`)."""
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
    friction = friction or FrictionOptions()
    reconstruction = options.flux_reconstruction
    if options.friction and cycle.friction_coefficient > 0.0:
        law = friction.law_for(cycle.friction_coefficient)
        kw["flux_scale"] = options.flux_scale
        if (
            law.is_constant
            and law.mu0 == cycle.friction_coefficient
            and (options.heat_partition == "fixed")
            and friction.pass_balance == "cycle"  # the cycle's flux is scaled as the cycle's
        ):
            flux, names = friction_flux_function(
                domain, gear_mesh, body, fields, omega1, fraction, reconstruction=reconstruction
            )
            kw.update(flank_flux_W_m2=flux, flux_surfaces=names)
        elif not law.depends_on_temperature:
            q_ref, _, _ = reference_flux(
                cycle,
                body,
                law,
                materials,
                speed_rpm,
                ZERO_CELSIUS_K,  # any: the law does not depend on temperature
                options.heat_partition,
                fraction,
                "flank",
                friction.band_model,  # the bands' widths set Blok's partition
            )
            flux, names = friction_flux_function(
                domain,
                gear_mesh,
                body,
                fields,
                omega1,
                1.0,
                reference_flux_W_m2=q_ref,
                reconstruction=reconstruction,
            )
            kw.update(flank_flux_W_m2=flux, flux_surfaces=names)
        else:
            kw["flank_flux_model"] = ThermalFrictionFlux(
                flank_transfer(domain, gear_mesh, body, fields, reconstruction=reconstruction),
                cycle,
                body,
                law,
                materials,
                speed_rpm,
                options.heat_partition,
                fraction,
                friction.contact_temperature,
                friction.band_model,
            )
    return HeatSources(**kw)


__all__ = [
    "AREA_QUADRATURE_DEGREE",
    "cycle_heat_sources",
    "flank_transfer",
    "friction_flux_function",
    "u_max_function",
]
