"""Rigid-body motions of whole bodies, applied on top of their elastic displacement.

Each body keeps its mesh and its displacement u in its own (body) frame. A :class:`RigidMotion`
places the body: current position x = c + R (X + u − c) + t, with R a rotation by ``angle_rad``
about ``axis`` through ``center``. Gears are put at any mesh position this way without re-meshing.
The motion also carries a kinematic velocity (angular speed about the axis plus a translation
velocity) used for the direction of friction.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gearfem.core.errors import ParameterError
from gearfem.core.params import require_finite


def rotation_matrix(axis: np.ndarray, angle_rad: float) -> np.ndarray:
    """Rotation by ``angle_rad`` (right-handed) about the unit vector ``axis``."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


@dataclasses.dataclass(frozen=True)
class RigidMotion:
    """Rigid placement and kinematic velocity of one body.

    Args:
        center: A point on the rotation axis, m.
        axis: Rotation axis direction.
        angle_rad: Rotation angle about ``axis`` (right-handed), rad.
        translation_m: Translation applied after the rotation, m.
        angular_velocity_rad_s: Angular speed about ``axis`` (for sliding directions), rad/s.
        velocity_m_s: Translational velocity (for sliding directions), m/s.
    """

    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    angle_rad: float = 0.0
    translation_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity_rad_s: float = 0.0
    velocity_m_s: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        require_finite("rigid motion angle_rad", self.angle_rad)
        if np.linalg.norm(self.axis) == 0.0:
            raise ParameterError("rigid motion axis", self.axis, "a non-zero vector")

    @property
    def R(self) -> np.ndarray:
        return rotation_matrix(np.asarray(self.axis), self.angle_rad)

    def place(self, points: np.ndarray) -> np.ndarray:
        """Current positions of body-frame points (..., 3) (already including u if wanted)."""
        c = np.asarray(self.center)
        return c + (np.asarray(points) - c) @ self.R.T + np.asarray(self.translation_m)

    def velocity(self, x: np.ndarray) -> np.ndarray:
        """Rigid velocity at current positions x (..., 3), m/s."""
        a = np.asarray(self.axis, dtype=np.float64)
        a = a / np.linalg.norm(a)
        c = np.asarray(self.center) + np.asarray(self.translation_m)
        return self.angular_velocity_rad_s * np.cross(a, np.asarray(x) - c) + np.asarray(
            self.velocity_m_s
        )

    def rotated(self, angle_rad: float) -> RigidMotion:
        return dataclasses.replace(self, angle_rad=angle_rad)
