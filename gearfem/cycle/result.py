"""What one meshing-cycle solve produces: per-position histories and per-entity fields of each
gear's reference tooth sector (:class:`CycleResult`, :class:`BodyFields`), and the check of its
periodicity one pitch on (:class:`PeriodicityCheck`)."""

from __future__ import annotations

import dataclasses

import numpy as np

from gearfem.core.errors import GearfemError
from gearfem.core.results import JsonRecord
from gearfem.cycle.friction_field import FrictionField
from gearfem.cycle.history import ContactHistory


@dataclasses.dataclass
class BodyFields:
    """Per-entity results of one gear's reference tooth sector (replicated on all ranks).

    Points are body-frame coordinates (m) of the mesh as built; ``tooth_angle_rad`` is the
    reference tooth's centre-line angle about ``center_m``.
    """

    center_m: np.ndarray
    tooth_angle_rad: float
    pitch_angle_rad: float
    cell_points_m: np.ndarray  # (n, 3) cell centroids in the sector
    cell_volume_m3: np.ndarray
    u_max_J_m3: np.ndarray  # max strain energy density over the whole engagement
    facet_points_m: np.ndarray  # (m, 3) contact-surface facet centroids in the sector
    facet_area_m2: np.ndarray
    facet_kind: np.ndarray  # group kind of each facet (drive_flank, tip, root)
    # revolution-averaged friction heat flux generated at this gear's flank facets per unit ω₁
    # (both gears' share: the coupling splits it)
    generated_flux_W_m2_per_rad_s: np.ndarray
    pressure_max_Pa: np.ndarray  # envelope of the facet-mean contact pressure over the engagement
    u_history_J_m3: (
        np.ndarray
    )  # (n_images * n_positions, n) strain energy of each sector cell over the engagement
    history_angle_rad: np.ndarray  # pinion angle of each history sample, relative to the start
    # the contact-surface facet (gathered order, -1: outside the model) at each tooth image
    # (rows: images -1, 0, +1 pitch) of every sector facet, and its area: the revolution average
    # of a facet sums what its images carry over one pitch of positions
    facet_image_index: np.ndarray
    facet_image_area_m2: np.ndarray


@dataclasses.dataclass(frozen=True)
class SectorEnergy(JsonRecord):
    """Strain energy (J) of one interior tooth sector ``sector`` of a gear at start + pitch
    (``shifted_J``) and of the sector that periodicity maps onto it at the start (``mapped_J``:
    the pinion's sector + 1, the wheel's sector − 1)."""

    sector: int
    shifted_J: float
    mapped_J: float


@dataclasses.dataclass(frozen=True)
class PeriodicityCheck(JsonRecord):
    """The cycle's first position against the position one pitch after the start.

    One pitch on the state repeats with the tooth numbers shifted by one: the pinion's tooth k
    then carries what tooth k + 1 carried at the start. Transmission errors (m), largest contact
    pressures (Pa), normal load on each pinion tooth by tooth number (N) at both positions, and
    the strain energies of each gear's interior tooth sectors (J) by gear (``"pinion"``,
    ``"wheel"``). ``to_json``/``from_json`` round trip exactly (the tooth numbers back to ints).
    """

    te_first_m: float
    te_shifted_m: float
    p_max_first_Pa: float
    p_max_shifted_Pa: float
    tooth_load_first_N: dict[int, float]
    tooth_load_shifted_N: dict[int, float]
    sector_energy_J: dict[str, tuple[SectorEnergy, ...]]


@dataclasses.dataclass
class CycleResult:
    """Everything the thermal stage and the reports need from one structural cycle solve."""

    torque_Nm: float
    friction_coefficient: float
    pitch_angle_rad: float
    phi_rad: np.ndarray  # pinion angles solved
    te_m: np.ndarray  # transmission error (wheel lag along the line of action)
    pinion_torque_Nm: np.ndarray
    wheel_torque_Nm: np.ndarray  # contact moment balance on the wheel (equals the resisting torque)
    friction_power_W_per_rad_s: np.ndarray  # ∫ μ p v_s dA per unit ω₁
    p_max_Pa: np.ndarray
    p_max_mid_Pa: np.ndarray  # largest pressure in the middle half of the face width
    root_stress_Pa: dict[str, np.ndarray]  # largest principal stress on each gear's roots
    tooth_load_N: dict[int, np.ndarray]  # normal load on each pinion tooth (pair k)
    tooth_S_m: dict[
        int, np.ndarray
    ]  # load-weighted contact position along the line of action (NaN: none)
    newton_iterations: np.ndarray
    uzawa_iterations: np.ndarray
    wall_time_s: np.ndarray
    fields: dict[str, BodyFields]
    reference_tooth: dict[str, int]
    theoretical_contact_ratio: float
    base_pitch_m: float
    periodicity: PeriodicityCheck | None = None
    info: dict = dataclasses.field(default_factory=dict)
    history: ContactHistory | None = None  # the contact points of every position
    # the mu the cycle was solved with at each contact (None: friction_coefficient everywhere)
    friction_field: FrictionField | None = None

    # derived ----------------------------------------------------------------------------------
    @property
    def step_rad(self) -> float:
        return (
            float(self.phi_rad[1] - self.phi_rad[0])
            if len(self.phi_rad) > 1
            else self.pitch_angle_rad
        )

    def engagement_curve(self, load_fraction: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
        """Load on the reference pinion tooth over its whole engagement: (φ relative to the pitch
        point position, load N), assembled from the tooth's images over one pitch of positions."""
        k = self.reference_tooth["pinion"]
        phis, loads = [], []
        p = self.pitch_angle_rad
        # tooth k at φ - m·pitch  <->  tooth k - m (pinion) at φ ... the pinion's next tooth is k -
        # 1
        for m in (-2, -1, 0, 1, 2):
            kk = k + m
            if kk in self.tooth_load_N:
                phis.append(self.phi_rad - self.phi_rad[0] + m * p)
                loads.append(self.tooth_load_N[kk])
        phi = np.concatenate(phis)
        order = np.argsort(phi)
        return phi[order], np.concatenate(loads)[order]

    def effective_contact_ratio(self, load_fraction: float = 2e-3) -> float:
        """Loaded part of one tooth's engagement over the pitch: Δφ × (number of positions at which
        the tooth carries more than ``load_fraction`` of the total normal load) / pitch.

        A sample count (midpoint rule) is unbiased whether the load sets in with a jump (stiff
        teeth,
        low torque) or a ramp (soft teeth); its resolution is ±½ position step at each end.
        """
        _phi, load = self.engagement_curve()
        total = float(np.median(np.sum(np.stack(list(self.tooth_load_N.values())), axis=0)))
        return float(
            np.count_nonzero(load > load_fraction * total) * self.step_rad / self.pitch_angle_rad
        )

    @property
    def contact_ratio_resolution(self) -> float:
        """± uncertainty of :meth:`effective_contact_ratio` from the position step."""
        return float(self.step_rad / self.pitch_angle_rad)

    def mean_friction_power_W_per_rad_s(self) -> float:
        return float(np.mean(self.friction_power_W_per_rad_s))

    def mean_friction_coefficient(self) -> float:
        """The constant mu that dissipates the cycle's friction power on its contact pressures
        and slips: ``friction_coefficient`` with one mu everywhere; with a friction field, the
        heat-weighted mean ∫ μ p ŝ·v_T dA / ∫ p ŝ·v_T dA over the positions (from the history)."""
        if self.friction_field is None:
            return float(self.friction_coefficient)
        if self.history is None:
            raise GearfemError(
                "a cycle solved with a friction field has no contact history: its mean mu "
                "cannot be computed"
            )
        per_mu = float(np.mean(self.history.friction_power_W_per_rad_s(1.0, len(self.phi_rad))))
        if per_mu <= 0.0:
            return float(self.friction_coefficient)
        return self.mean_friction_power_W_per_rad_s() / per_mu

    def tooth_heat_W_per_rad_s(self, body: str) -> float:
        """Friction heat generated at one tooth's flanks of ``body`` per unit ω₁ (before the split
        between the gears); times the tooth count it is the mean friction power."""
        f = self.fields[body]
        return float(np.sum(f.generated_flux_W_m2_per_rad_s * f.facet_area_m2))


# ------------------------------------------------------------------------------------------------
