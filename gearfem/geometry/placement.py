"""Where each body's teeth are in the pair frame (centre, tooth-centre angles, modelled sector)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gearfem.geometry.involute import GearPair
from gearfem.geometry.options import MeshOptions, reference_tooth


@dataclass(frozen=True)
class BodyPlacement:
    """Where a body's teeth are: centre (m) and tooth-centre angles in the body's own polar frame.

    ``tooth_angles_rad[k]`` is the polar angle (about the body's axis, from +x, counter-clockwise)
    of the centre line of tooth k in the mesh as built, including ``pinion_angle_deg``.
    """

    body: str
    center_m: np.ndarray
    tooth_angles_rad: np.ndarray
    pitch_angle_rad: float
    reference_tooth: int
    full: bool

    @property
    def sector_rad(self) -> tuple[float, float]:
        """Start and end polar angles of the modelled sector (the cut planes) [rad]."""
        h = 0.5 * self.pitch_angle_rad
        return float(self.tooth_angles_rad[0] - h), float(self.tooth_angles_rad[-1] + h)


def placement(pair: GearPair, options: MeshOptions, body: str) -> BodyPlacement:
    """Placement of ``body`` in the pair frame for these options (see the module docstring)."""
    prof = pair.profile(body)
    n = options.teeth_in_model
    k_ref = reference_tooth(body, n)
    psi_w = prof.operating_thickness_m / (2.0 * prof.operating_pitch_radius_m)
    rot_pinion = math.radians(options.pinion_angle_deg)
    if body == "pinion":
        center = np.array([0.0, 0.0, 0.0])
        ref_angle = -psi_w + rot_pinion  # drive flank (ccw side) through the pitch point
    else:
        center = np.array([pair.center_distance_m, 0.0, 0.0])
        ref_angle = math.pi - psi_w + pair.wheel_angle(rot_pinion)
    angles = ref_angle + (np.arange(n) - k_ref) * prof.pitch_angle_rad
    return BodyPlacement(body, center, angles, prof.pitch_angle_rad, k_ref, n == prof.teeth)


def tooth_local(
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
