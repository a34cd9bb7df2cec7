"""``gearfem thermal CASE.toml --out DIR``: the thermal model of one gear from a case file.

Tables read (others are left to the stages that own them):

* ``[geometry]`` (:class:`gearfem.geometry.GearPairGeometry`) and ``[mesh]``
  (:class:`gearfem.geometry.MeshOptions`): the gear; the thermal model meshes only its body
  (``[thermal] body``), which balances the mesh over the ranks;
* ``[material]`` (:class:`gearfem.materials.Material`);
* ``[operating]`` (:class:`OperatingPoint`): the speed sets convection and loading frequency;
* ``[thermal]`` (:class:`~gearfem.thermal.options.ThermalOptions`);
* ``[sources]`` (:class:`~gearfem.thermal.sources.PrescribedSources`): prescribed sources until
  the contact-cycle stage stores its own.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import tomllib
from pathlib import Path
from typing import Any

from gearfem.errors import ParameterError
from gearfem.materials import STEFAN_BOLTZMANN_W_m2K4, Material
from gearfem.params import from_dict, require_nonnegative, require_positive, to_dict
from gearfem.thermal.boundary import ThermalBoundary
from gearfem.thermal.convection import GearRadii
from gearfem.thermal.domain import ThermalDomain
from gearfem.thermal.options import ThermalOptions
from gearfem.thermal.problem import ThermalProblem
from gearfem.thermal.run import run_and_write
from gearfem.thermal.sources import PrescribedSources

log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class OperatingPoint:
    """``[operating]``: the pinion speed (rpm) and torque (N m; used by the contact stage)."""

    speed_rpm: float = 1000.0
    torque_Nm: float = 8.0

    def __post_init__(self) -> None:
        require_nonnegative("operating.speed_rpm", self.speed_rpm)
        require_positive("operating.torque_Nm", self.torque_Nm)


def read_case(path: str | Path) -> dict[str, Any]:
    try:
        return tomllib.loads(Path(path).read_text())
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise ParameterError("CASE", str(path), "a readable TOML file", str(err)) from None


def gear_radii(profile) -> GearRadii:
    """Correlation lengths of a gear (:class:`gearfem.geometry.involute.ToothProfile`)."""
    return GearRadii(2.0 * profile.operating_pitch_radius_m, profile.base_radius_m, profile.bore_radius_m)


def lumped_estimate(problem: ThermalProblem, generated_W: float) -> dict[str, float]:
    """One-node estimate of the steady rise and time constant of the modelled body.

    Solves P = sum_roles h A theta + eps sigma A ((T_a + theta)^4 - T_a^4) for theta (h at the
    ambient film temperature when h depends on T) and gives tau = rho c_p V / (P / theta).
    """
    from scipy.optimize import brentq

    areas = problem.role_areas_m2()
    amb = problem.boundary.teeth.fluid_K
    hA, epsA = 0.0, 0.0
    for role, ex in problem.boundary.exchanges().items():
        a = areas.get(role, 0.0)
        hA += float(ex.h(amb)) * a
        epsA += ex.emissivity * a
    if generated_W <= 0.0:
        return {"theta_ss_K": 0.0, "tau_s": math.nan, "hA_W_K": hA, "eps_A_m2": epsA, **{f"area_{k}_m2": v for k, v in areas.items()}}

    def balance(theta: float) -> float:
        return hA * theta + epsA * STEFAN_BOLTZMANN_W_m2K4 * ((amb + theta) ** 4 - amb**4) - generated_W

    theta = brentq(balance, 0.0, 1.0e4)
    C = problem.material.density_kg_m3 * problem.material.specific_heat_J_kgK * problem.volume_m3
    return {"theta_ss_K": theta, "tau_s": C * theta / generated_W, "hA_W_K": hA, "eps_A_m2": epsA,
            "heat_capacity_J_K": C, **{f"area_{k}_m2": v for k, v in areas.items()}}


def run_thermal_case(case: dict[str, Any], out_dir: str | Path, cache_dir: str | Path | None = None,
                     comm=None) -> dict[str, Any]:
    """Build the gear mesh, the sources and the problem of ``case``; run; write outputs; return the summary."""
    from mpi4py import MPI

    from gearfem.geometry import GearPairGeometry, MeshOptions, build_gear_mesh

    comm = comm or MPI.COMM_WORLD
    geometry = from_dict(GearPairGeometry, case.get("geometry", {}), "geometry")
    mesh_opts = from_dict(MeshOptions, case.get("mesh", {}), "mesh")
    material = from_dict(Material, case.get("material", {}), "material")
    operating = from_dict(OperatingPoint, case.get("operating", {}), "operating")
    options = from_dict(ThermalOptions, case.get("thermal", {}), "thermal")
    prescribed = from_dict(PrescribedSources, case.get("sources", {}), "sources")
    body = options.body
    if body not in mesh_opts.bodies:
        raise ParameterError("thermal.body", body, f"one of the meshed bodies {list(mesh_opts.bodies)}")
    gm = build_gear_mesh(geometry, dataclasses.replace(mesh_opts, bodies=(body,)), comm, cache_dir=cache_dir)
    domain = ThermalDomain.from_gear_mesh(gm, body, flux_flanks=prescribed.flanks)
    profile = gm.pair.profile(body)
    teeth = profile.teeth
    speed = operating.speed_rpm if body == "pinion" else operating.speed_rpm * geometry.teeth_pinion / teeth
    boundary = ThermalBoundary.from_options(options, material, speed, gear_radii(profile))
    sources = prescribed.build(domain, material, speed, teeth)
    problem = ThermalProblem(domain, material, sources, boundary, options)
    extra = {
        "title": f"{body}, {speed:g} rpm, {prescribed.flank_heat_per_gear_W:g} W flank heat per gear",
        "body": body, "speed_rpm": speed, "teeth": teeth, "teeth_modelled": domain.teeth_modelled,
        "mesh_cache_key": gm.cache_key,
        "case": {"geometry": to_dict(geometry), "mesh": to_dict(mesh_opts), "material": to_dict(material),
                 "operating": to_dict(operating), "thermal": to_dict(options), "sources": to_dict(prescribed)},
    }

    def more(records) -> dict[str, Any]:
        gen = records[-1].balance.generated_W
        return {"generated_per_gear_W": gen / domain.model_fraction if math.isfinite(gen) else None,
                "lumped_estimate": lumped_estimate(problem, gen if math.isfinite(gen) else 0.0)}

    with problem:  # frees the solvers collectively, also on failure
        _, summary = run_and_write(problem, out_dir, extra=extra, more=more)
    return summary

