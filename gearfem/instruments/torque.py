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

    ``cycle_friction_power_W`` is the cycle's own friction power at the operating speed, for
    comparison with ``torque_loss_Nm`` × ω₁ (= ``friction_power_W``).
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


def read_torque(
    options: TorqueMeterOptions, torques: CycleTorques, pinion_speed_rpm: float
) -> TorqueReading:
    """The torque meters' reading of a cycle at the operating speed."""
    t1 = float(np.mean(torques.pinion_torque_Nm))
    t2 = torques.resisting_torque_Nm
    i = torques.speed_ratio
    omega = 2.0 * math.pi * pinion_speed_rpm / 60.0
    loss = t1 - t2 * i
    eta = t2 * i / t1
    u = options.uncertainty_Nm
    return TorqueReading(
        input_torque_Nm=t1,
        output_torque_Nm=t2,
        torque_loss_Nm=loss,
        efficiency=eta,
        friction_power_W=loss * omega,
        cycle_friction_power_W=float(np.mean(torques.friction_power_W_per_rad_s)) * omega,
        u_torque_loss_Nm=u * math.sqrt(1.0 + i * i),
        u_efficiency=eta * u * math.sqrt(1.0 / t1**2 + 1.0 / t2**2),
        meter_uncertainty_Nm=u,
    )
