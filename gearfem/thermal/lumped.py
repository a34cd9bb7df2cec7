"""Lumped (one-node) view of a thermal model: the correlation radii of a gear and the steady
rise and time constant of the modelled body from its exchange coefficients."""

from __future__ import annotations

import logging
import math

from gearfem.core.materials import STEFAN_BOLTZMANN_W_m2K4
from gearfem.thermal.convection import GearRadii
from gearfem.thermal.problem import ThermalProblem

log = logging.getLogger(__name__)


def gear_radii(profile) -> GearRadii:
    """Correlation lengths of a gear (:class:`gearfem.geometry.involute.ToothProfile`)."""
    return GearRadii(
        2.0 * profile.operating_pitch_radius_m, profile.base_radius_m, profile.bore_radius_m
    )


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
        return {
            "theta_ss_K": 0.0,
            "tau_s": math.nan,
            "hA_W_K": hA,
            "eps_A_m2": epsA,
            **{f"area_{k}_m2": v for k, v in areas.items()},
        }

    def balance(theta: float) -> float:
        return (
            hA * theta
            + epsA * STEFAN_BOLTZMANN_W_m2K4 * ((amb + theta) ** 4 - amb**4)
            - generated_W
        )

    theta = brentq(balance, 0.0, 1.0e4)
    C = problem.material.density_kg_m3 * problem.material.specific_heat_J_kgK * problem.volume_m3
    return {
        "theta_ss_K": theta,
        "tau_s": C * theta / generated_W,
        "hA_W_K": hA,
        "eps_A_m2": epsA,
        "heat_capacity_J_K": C,
        **{f"area_{k}_m2": v for k, v in areas.items()},
    }
