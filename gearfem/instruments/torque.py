"""Torque meters on the input (pinion) and output (wheel) shafts: the mesh's torque loss and
efficiency as the bench measures them (numpy only; options:
:class:`gearfem.instruments.options.TorqueMeterOptions`).

The structural cycle gives the torque T₁(φ) that turns the pinion against the constant resisting
torque T₂ on the wheel at each pinion angle φ over one mesh period. A torque transducer averages
over many mesh periods (its bandwidth is far below the tooth-pass frequency), so it reads the
cycle means. Referred to the input shaft (ω₂ = ω₁ z₁/z₂):

    torque loss  T_loss = T̄₁ − T₂ z₁/z₂          [N m]
    efficiency   η = T₂ ω₂ / (T̄₁ ω₁) = T₂ z₁ / (T̄₁ z₂)

Over a periodic cycle the elastic energy returns to its value, so the power balance gives
T_loss ω₁ = the mean friction power ∫ μ p v_s dA (the cycle's energy-balance check): the torque
loss is a direct measurement of the mesh's friction. Standard uncertainties from the meters'
(independent) uncertainty u: u(T_loss) = u sqrt(1 + (z₁/z₂)²), u(η) = η u sqrt(1/T̄₁² + 1/T₂²).

**The reading of the active friction law.** The structural cycle is solved with one constant μ,
while the friction heat follows the case's friction law (``[friction]``: μ at each contact point's
contact temperature, pressure and sliding speed). What the meters read is the power the pair
dissipates at its thermal state: the friction heat of the law (both gears' shares, each gear's
from its own thermal model) plus the hysteresis heat of both gears, referred to the input shaft,

    T_loss = (P_friction + P_hysteresis) / ω₁,    T̄₁ = T₂ z₁/z₂ + T_loss,

at every reported time of the run (:func:`read_torque` with ``heat``). With the cycle's constant μ
the law's friction heat is the cycle's friction power, so this reading is the cycle's own plus the
hysteresis; the cycle's constant-μ reading is kept beside it (``cycle_torque_loss_Nm``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from gearfem.core.results import JsonRecord
from gearfem.instruments.options import TorqueMeterOptions
from gearfem.instruments.snapshot import CycleTorques


@dataclasses.dataclass(frozen=True)
class TorqueReading(JsonRecord):
    """What the two torque meters give (see the module docstring).

    ``source``: ``"law"`` when the reading is the power of the active friction law and the
    hysteresis at the run's thermal state (``friction_power_W`` and ``hysteresis_power_W`` then
    sum to ``torque_loss_Nm`` × ω₁), ``"cycle"`` when it is the structural cycle's torques at its
    constant μ. ``cycle_friction_power_W`` and ``cycle_torque_loss_Nm`` are the cycle's own, for
    comparison.
    """

    input_torque_Nm: float
    output_torque_Nm: float
    torque_loss_Nm: float
    efficiency: float
    friction_power_W: float
    cycle_friction_power_W: float
    u_torque_loss_Nm: float
    u_efficiency: float
    meter_uncertainty_Nm: float
    source: str = "cycle"
    hysteresis_power_W: float = 0.0
    cycle_torque_loss_Nm: float | None = None

    def effective_mu(self, mu_cycle: float) -> float:
        """The constant mu at which the structural cycle, solved at ``mu_cycle``, would dissipate
        the friction power this reading gives: ``mu_cycle`` P_f / P_cycle (``mu_cycle`` itself
        for a reading of the cycle's torques)."""
        return mu_cycle * self.friction_power_W / self.cycle_friction_power_W


def read_torque(
    options: TorqueMeterOptions,
    torques: CycleTorques,
    pinion_speed_rpm: float,
    heat: tuple[float, float] | None = None,
) -> TorqueReading:
    """The torque meters' reading at the operating speed: with ``heat`` = (friction, hysteresis)
    power of the pair (W) at the run's thermal state, the reading of that dissipation (the
    active friction law's, see the module docstring); without, the structural cycle's torques."""
    t1_cycle = float(np.mean(torques.pinion_torque_Nm))
    t2 = torques.resisting_torque_Nm
    i = torques.speed_ratio
    omega = 2.0 * math.pi * pinion_speed_rpm / 60.0
    cycle_loss = t1_cycle - t2 * i
    if heat is None:
        t1, loss = t1_cycle, cycle_loss
        p_f, p_h, source = loss * omega, 0.0, "cycle"
    else:
        p_f, p_h = (float(v) for v in heat)
        loss = (p_f + p_h) / omega
        t1, source = t2 * i + loss, "law"
    eta = t2 * i / t1
    u = options.uncertainty_Nm
    return TorqueReading(
        input_torque_Nm=t1,
        output_torque_Nm=t2,
        torque_loss_Nm=loss,
        efficiency=eta,
        friction_power_W=p_f,
        cycle_friction_power_W=float(np.mean(torques.friction_power_W_per_rad_s)) * omega,
        u_torque_loss_Nm=u * math.sqrt(1.0 + i * i),
        u_efficiency=eta * u * math.sqrt(1.0 / t1**2 + 1.0 / t2**2),
        meter_uncertainty_Nm=u,
        source=source,
        hysteresis_power_W=p_h,
        cycle_torque_loss_Nm=cycle_loss,
    )
