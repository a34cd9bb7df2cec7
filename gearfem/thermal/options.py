"""``[thermal]`` options of the case file: boundary model choices, time stepping, discretisation."""

from __future__ import annotations

import dataclasses
import math

from gearfem.core.errors import ParameterError
from gearfem.core.params import (
    require_choice,
    require_int,
    require_nonnegative,
    require_positive,
    require_range,
)
from gearfem.thermal.convection import AIR_MODELS, AirProperties

LOADING_FREQUENCIES = ("rotation", "tooth_pass")


def loading_frequency_Hz(choice: str, speed_rpm: float, teeth: int) -> float:
    """f of q_h = H U_max f: ``"rotation"`` n/60 (thesis eq. 2.15) or ``"tooth_pass"`` z n/60."""
    require_choice("sources.loading_frequency", choice, LOADING_FREQUENCIES)
    require_nonnegative("operating.speed_rpm", speed_rpm)
    return speed_rpm / 60.0 * (teeth if choice == "tooth_pass" else 1)


@dataclasses.dataclass(frozen=True)
class PrescribedSources:
    """``[sources]`` table: prescribed sources until the contact cycle provides them.

    Args:
        flank_heat_per_gear_W: Friction heat into this gear, W, over the whole gear; spread
        uniformly
            over the chosen flanks (scaled to the modelled sector by its fraction of the gear).
        flanks: ``"drive"``, ``"coast"`` or ``"both"``: flanks receiving it.
        u_max_J_m3: Uniform maximum strain energy density, J/m^3 (0: no hysteresis).
        loading_frequency: ``"rotation"`` (n/60, thesis) or ``"tooth_pass"`` (z n/60).
        hysteresis_scale, flux_scale: Multipliers on the two sources.
    """

    flank_heat_per_gear_W: float = 0.0
    flanks: str = "drive"
    u_max_J_m3: float = 0.0
    loading_frequency: str = "rotation"
    hysteresis_scale: float = 1.0
    flux_scale: float = 1.0

    def __post_init__(self) -> None:
        require_nonnegative("sources.flank_heat_per_gear_W", self.flank_heat_per_gear_W)
        require_choice("sources.flanks", self.flanks, ("drive", "coast", "both"))
        require_nonnegative("sources.u_max_J_m3", self.u_max_J_m3)
        require_choice("sources.loading_frequency", self.loading_frequency, LOADING_FREQUENCIES)
        require_nonnegative("sources.hysteresis_scale", self.hysteresis_scale)
        require_nonnegative("sources.flux_scale", self.flux_scale)


CONVECTION_MODELS = ("thesis", "none")


@dataclasses.dataclass(frozen=True)
class ThermalOptions:
    """Options of the thermal model (the ``[thermal]`` table). SI units, temperatures in C.

    Boundary model:
        body: The gear whose temperature is computed, ``"pinion"`` or ``"wheel"``.
        ambient_C: Air and surroundings temperature (thesis: 23 C).
        initial_C: Initial temperature of the gear (None: ambient).
        emissivity: Radiation emissivity of teeth and sides (None: the material's, 0.9).
        convection: ``"thesis"`` (eq. 5.1-5.6 at the operating speed) or ``"none"`` (h = 0).
        air_properties: ``"thesis"`` (constants at 25 C), ``"ambient"`` or ``"film"`` (Sutherland's
            law at ambient / local film temperature); see :mod:`gearfem.thermal.convection`.
        air_kinematic_viscosity_m2_s, air_conductivity_W_mK: Replace the ``"thesis"`` air constants.
        h_teeth_W_m2K, h_sides_W_m2K: Replace the correlations' coefficients.
        h_teeth_factor, h_sides_factor: Multiply the coefficients (after any replacement).
        bore_h_W_m2K: Robin heat path on the bore to ``bore_C`` (0: adiabatic, the thesis).
        bore_C: Temperature the bore path leads to (None: ambient).

    Time stepping (:mod:`gearfem.thermal.timestepping`):
        mode: ``"transient"`` or ``"steady"``.
        duration_s: Simulated time (thesis: 8000 s).
        time_stepping: ``"adaptive"`` (BDF2 with local error control) or ``"fixed"`` (dt_initial_s
            throughout).
        dt_initial_s, dt_min_s, dt_max_s: Step sizes. The first two steps (backward Euler, then
            BDF2) use ``dt_initial_s`` without an error estimate (it needs three solutions): keep
            it small against the flank heating time (default 0.25 s).
        time_error_K: Accepted local error per step (max norm over the nodes), kelvin.
        output_times_s: Times at which fields are written (and steps land exactly); the end is
            always written.

    Discretisation and solver:
        degree: Lagrange degree of the temperature, 1 or 2. Default 2: on the default gear mesh
            (3 element layers across the face width, like the thesis's quadratic model) P2 is within
            0.35 K of a P2 solution on a mesh with 10 layers and finer web/tooth sizes, while P1 is
            off by up to 3 K (tip, coast flank) at 40 W a gear (benchmarks/performance/thermal.py).
        newton_rtol, newton_atol_W: Newton tolerances on ||F||_2 (residual in W per test function).
        newton_max_it: Newton iterations per step.
        linear_solver: ``"direct"`` (CG, GMRES with k(T), preconditioned by a MUMPS Cholesky/LU
            factorisation that is reused while dt changes little; fastest measured on the gear
            meshes), ``"iterative"`` (block Jacobi with incomplete Cholesky/LU blocks, no
            factorisation) or ``"multigrid"`` (hypre BoomerAMG or PETSc GAMG, for large meshes).
    """

    body: str = "pinion"
    ambient_C: float = 23.0
    initial_C: float | None = None
    emissivity: float | None = None
    convection: str = "thesis"
    air_properties: str = "thesis"
    air_kinematic_viscosity_m2_s: float | None = None
    air_conductivity_W_mK: float | None = None
    h_teeth_W_m2K: float | None = None
    h_sides_W_m2K: float | None = None
    h_teeth_factor: float = 1.0
    h_sides_factor: float = 1.0
    bore_h_W_m2K: float = 0.0
    bore_C: float | None = None

    mode: str = "transient"
    duration_s: float = 8000.0
    time_stepping: str = "adaptive"
    dt_initial_s: float = 0.25
    dt_min_s: float = 1.0e-3
    dt_max_s: float = 500.0
    time_error_K: float = 0.05
    output_times_s: tuple[float, ...] = ()

    degree: int = 2
    newton_rtol: float = 1.0e-10
    newton_atol_W: float = 1.0e-10
    newton_max_it: int = 25
    linear_solver: str = "direct"

    def __post_init__(self) -> None:
        require_choice("thermal.body", self.body, ("pinion", "wheel"))
        require_range("thermal.ambient_C", self.ambient_C, -273.15, 1000.0, lo_open=True, unit="C")
        if self.initial_C is not None:
            require_range(
                "thermal.initial_C", self.initial_C, -273.15, 1000.0, lo_open=True, unit="C"
            )
        if self.emissivity is not None:
            require_range("thermal.emissivity", self.emissivity, 0.0, 1.0)
        require_choice("thermal.convection", self.convection, CONVECTION_MODELS)
        require_choice("thermal.air_properties", self.air_properties, AIR_MODELS)
        self.air()  # validates the overrides against the model
        for name in ("h_teeth_W_m2K", "h_sides_W_m2K"):
            if getattr(self, name) is not None:
                require_nonnegative(f"thermal.{name}", getattr(self, name))
        require_nonnegative("thermal.h_teeth_factor", self.h_teeth_factor)
        require_nonnegative("thermal.h_sides_factor", self.h_sides_factor)
        require_nonnegative("thermal.bore_h_W_m2K", self.bore_h_W_m2K)
        if self.bore_C is not None:
            require_range("thermal.bore_C", self.bore_C, -273.15, 1000.0, lo_open=True, unit="C")
            if self.bore_h_W_m2K == 0.0:
                raise ParameterError(
                    "thermal.bore_C",
                    self.bore_C,
                    "unset while thermal.bore_h_W_m2K = 0",
                    "an adiabatic bore has no temperature to lead to",
                )

        require_choice("thermal.mode", self.mode, ("transient", "steady"))
        require_positive("thermal.duration_s", self.duration_s)
        require_choice("thermal.time_stepping", self.time_stepping, ("adaptive", "fixed"))
        require_positive("thermal.dt_min_s", self.dt_min_s)
        require_range(
            "thermal.dt_max_s",
            self.dt_max_s,
            self.dt_min_s,
            math.inf,
            unit="s",
            reason="at least dt_min_s",
        )
        require_range(
            "thermal.dt_initial_s",
            self.dt_initial_s,
            self.dt_min_s,
            min(self.dt_max_s, self.duration_s),
            unit="s",
            reason="between dt_min_s and min(dt_max_s, duration_s)",
        )
        require_positive("thermal.time_error_K", self.time_error_K)
        prev = 0.0
        for i, t in enumerate(self.output_times_s):
            require_range(
                f"thermal.output_times_s[{i}]",
                t,
                prev,
                self.duration_s,
                lo_open=True,
                unit="s",
                reason="increasing, within (0, duration_s]",
            )
            prev = t

        require_int("thermal.degree", self.degree, 1, 2)
        require_range("thermal.newton_rtol", self.newton_rtol, 0.0, 1.0, lo_open=True, hi_open=True)
        require_positive("thermal.newton_atol_W", self.newton_atol_W)
        require_int("thermal.newton_max_it", self.newton_max_it, 1, 1000)
        require_choice(
            "thermal.linear_solver", self.linear_solver, ("iterative", "direct", "multigrid")
        )

    def air(self) -> AirProperties:
        return AirProperties(
            self.air_properties, self.air_kinematic_viscosity_m2_s, self.air_conductivity_W_mK
        )
