"""Heat sources of the thermal model: the interface between the contact cycle and the thermal
solver.

Two physical sources (thesis 5.2.2, 5.2.3):

* hysteresis, volumetric: ``q_h = s_h H(T) U_max f`` (W/m^3) with U_max the maximum strain energy
  density of a cell over a load cycle (J/m^3, DG0), H(T) the loss fraction evaluated at the local
  temperature at every step and iteration, f the loading frequency (the thesis: rotational
  frequency n/60; tooth-pass frequency z n/60 is the alternative);
* friction, on the flank surfaces: the rotation-averaged flux into this body (W/m^2), already
  scaled by speed and split between the two gears, optionally multiplied by a temperature factor
  (e.g. mu(T)/mu_ref) and a scale;
* a surface flux that depends on the local surface temperature through any (numpy) function, a
  :class:`SurfaceFluxModel` (the friction heat of a friction law evaluated at the contact
  temperature of every contact point, :mod:`gearfem.coupling.friction_heat`). Per cell next to
  its surfaces the solver hands it the cell's surface-mean temperature T̄ (the mean of T over the
  cell's facets on those surfaces) and applies q(T̄) on those facets (DG0, like the cycle's flux);
  the Newton Jacobian gets the exact term −∫φ_i q'(T̄) ∂T̄/∂T_j ds as a matrix. It is updated before
  every residual evaluation (every step, Newton iteration and line-search trial): the source
  follows the temperature it produces.

``volumetric_W_m3`` is an extra prescribed volumetric source (verification, user loads).
Fields are a float, a ``dolfinx.fem.Function`` on the thermal mesh, or a callable
``(x, t) -> UFL expression`` of the spatial coordinate (m) and the time constant (s).

:func:`prescribed_heat_sources` builds them from the ``[sources]`` prescribed fields
(:class:`~gearfem.thermal.options.PrescribedSources`) until the cycle stage provides them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from gearfem.core.errors import ParameterError
from gearfem.core.forms import kept_form
from gearfem.core.materials import Material, TemperatureTable
from gearfem.core.params import require_nonnegative, require_positive
from gearfem.thermal.options import PrescribedSources, loading_frequency_Hz

SourceField = Any  # float | fem.Function | Callable[[x, t], ufl.core.expr.Expr]
TemperatureFactor = Callable[[Any], Any]  # T (kelvin, UFL) -> dimensionless UFL expression


@runtime_checkable
class SurfaceFluxModel(Protocol):
    """A heat flux into the body on ``surfaces`` that depends on the local surface temperature (see
    the module docstring). ``value`` and ``slope`` are DG0 Functions on the thermal mesh (W/m²,
    dq/dT̄ in W/(m² K)) that :meth:`update` fills from the surface-mean temperature of every local
    cell (an array over the local cells, owned and ghost, kelvin; 0 where a cell has no facet on
    ``surfaces``). ``update`` is collective. ``may_rise_with_temperature`` says whether the flux can
    grow with T anywhere (then the Jacobian may be indefinite)."""

    surfaces: tuple[str, ...]
    value: Any
    slope: Any
    may_rise_with_temperature: bool

    def update(self, surface_mean_K: np.ndarray) -> None: ...


@dataclasses.dataclass(frozen=True, eq=False)
class HeatSources:
    """Heat sources on the thermal mesh (see the module docstring).

    Args:
        u_max: DG0 Function, maximum strain energy density over a load cycle, J/m^3 (None: no
        hysteresis).
        loading_frequency_Hz: f in q_h = H(T) U_max f.
        hysteresis: H(T) (kelvin -> loss fraction), e.g. ``Material.hysteresis_table()``.
        flank_flux_W_m2: Rotation-averaged friction flux into this body on ``flux_surfaces``.
        flux_surfaces: Facet group names receiving the flux.
        hysteresis_scale: Multiplies q_h (model-discrepancy hook).
        flux_scale: Multiplies the flank flux (model-discrepancy hook).
        flux_temperature_factor: Optional T -> UFL factor on the flank flux (e.g. mu(T)/mu_ref).
        flank_flux_model: A :class:`SurfaceFluxModel` (temperature-dependent surface flux, e.g.
            the friction heat of a friction law at the contact temperature); ``flux_scale``
            multiplies it too.
        volumetric_W_m3: Extra prescribed volumetric source.
    """

    u_max: Any = None
    loading_frequency_Hz: float = 0.0
    hysteresis: TemperatureTable | None = None
    flank_flux_W_m2: SourceField | None = None
    flux_surfaces: tuple[str, ...] = ()
    hysteresis_scale: float = 1.0
    flux_scale: float = 1.0
    flux_temperature_factor: TemperatureFactor | None = None
    flank_flux_model: SurfaceFluxModel | None = None
    volumetric_W_m3: SourceField | None = None

    def __post_init__(self) -> None:
        require_nonnegative("sources.loading_frequency_Hz", self.loading_frequency_Hz)
        require_nonnegative("sources.hysteresis_scale", self.hysteresis_scale)
        require_nonnegative("sources.flux_scale", self.flux_scale)
        if self.u_max is not None:
            if self.hysteresis is None:
                raise ParameterError(
                    "sources.hysteresis", None, "an H(T) table when u_max is given"
                )
            if self.loading_frequency_Hz <= 0.0:
                raise ParameterError(
                    "sources.loading_frequency_Hz",
                    self.loading_frequency_Hz,
                    "> 0 when u_max is given",
                )
        if self.flank_flux_W_m2 is not None and not self.flux_surfaces:
            raise ParameterError(
                "sources.flux_surfaces", self.flux_surfaces, "facet groups for the flank flux"
            )
        if self.flank_flux_model is not None:
            if not isinstance(self.flank_flux_model, SurfaceFluxModel):
                raise ParameterError(
                    "sources.flank_flux_model",
                    type(self.flank_flux_model).__name__,
                    "a SurfaceFluxModel (surfaces, value, slope, update)",
                )
            if not self.flank_flux_model.surfaces:
                raise ParameterError(
                    "sources.flank_flux_model.surfaces", (), "facet groups for the flux"
                )
        if self.flux_temperature_factor is not None and not callable(self.flux_temperature_factor):
            raise ParameterError(
                "sources.flux_temperature_factor",
                self.flux_temperature_factor,
                "a callable T -> factor",
            )

    @property
    def flank_flux_may_rise(self) -> bool:
        """Whether the surface flux model can grow with temperature somewhere (a friction law
        rising with T): then the Jacobian need not be positive definite."""
        model = self.flank_flux_model
        return model is not None and bool(model.may_rise_with_temperature)


def field_ufl(field: SourceField, x: Any, t: Any) -> Any:
    """UFL expression of a source field (float, Function or callable (x, t))."""
    if callable(field) and not hasattr(field, "function_space"):
        return field(x, t)
    if isinstance(field, (int, float)):
        return ufl.as_ufl(float(field))
    return field


def _flank_groups(domain, flanks: str) -> tuple[str, ...]:
    kinds = {
        "drive": ("drive_flank",),
        "coast": ("coast_flank",),
        "both": ("drive_flank", "coast_flank"),
    }[flanks]
    out = tuple(n for n in domain.teeth if any(n.endswith("_" + k) for k in kinds))
    if not out:
        raise ParameterError(
            "sources.flanks", flanks, "a mesh with *_drive_flank / *_coast_flank facet groups"
        )
    return out


def prescribed_heat_sources(
    prescribed: PrescribedSources, domain, material: Material, speed_rpm: float, teeth: int
) -> HeatSources:
    """The :class:`HeatSources` of the ``[sources]`` prescribed fields on ``domain`` (a
    :class:`~gearfem.thermal.domain.ThermalDomain`)."""
    require_positive("geometry.teeth", teeth)
    surfaces = _flank_groups(domain, prescribed.flanks)
    flux = None
    if prescribed.flank_heat_per_gear_W > 0.0:
        ds = domain.surface_measure({1: surfaces}, {})  # the same form on every mesh
        area = domain.comm.allreduce(fem.assemble_scalar(kept_form(1.0 * ds(1))), op=MPI.SUM)
        if area <= 0.0:
            raise ParameterError(
                "sources.flanks", prescribed.flanks, "flanks with positive area in the mesh"
            )
        flux = prescribed.flank_heat_per_gear_W * domain.model_fraction / area
    u_max = None
    if prescribed.u_max_J_m3 > 0.0:
        Q = fem.functionspace(domain.mesh, ("DG", 0))
        u_max = fem.Function(Q, name="U_max_J_m3")
        u_max.x.array[:] = prescribed.u_max_J_m3
    return HeatSources(
        u_max=u_max,
        loading_frequency_Hz=loading_frequency_Hz(prescribed.loading_frequency, speed_rpm, teeth)
        if u_max
        else 0.0,
        hysteresis=material.hysteresis_table() if u_max else None,
        flank_flux_W_m2=flux,
        flux_surfaces=surfaces if flux is not None else (),
        hysteresis_scale=prescribed.hysteresis_scale,
        flux_scale=prescribed.flux_scale,
    )
