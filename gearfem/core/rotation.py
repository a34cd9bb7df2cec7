"""Rotations about an axis parallel to z, and the rotational periodicity of a sector model.

A gear sector of n of z teeth is rotationally periodic when its field is: the values on its
``cut_end`` face are those on its ``cut_start`` face turned about the gear's axis by the
sector's angle 2 pi n / z. :class:`RotationalPeriodicity` carries that map (the axis and the
angle); the thermal model ties the two faces' unknowns with it (:mod:`gearfem.thermal.periodic`),
the instruments turn a sector's copies with :func:`rotate_xy`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from gearfem.core.errors import ParameterError


def rotate_xy(points: np.ndarray, center: np.ndarray, angle: float) -> np.ndarray:
    """Points turned by ``angle`` (rad, counter-clockwise about +z) about the axis through
    ``center``."""
    if angle == 0.0:
        return points
    c, s = math.cos(angle), math.sin(angle)
    p = points - center
    out = np.empty_like(p)
    out[..., 0] = c * p[..., 0] - s * p[..., 1]
    out[..., 1] = s * p[..., 0] + c * p[..., 1]
    out[..., 2] = p[..., 2]
    return out + center


@dataclasses.dataclass(frozen=True)
class RotationalPeriodicity:
    """The map of a sector's start cut face onto its end cut face.

    center_m: A point of the axis (x, y, z) in metres (the axis is parallel to z).
    angle_rad: The sector's angle: the end face is the start face turned by it
        (counter-clockwise about +z), in (0, 2 pi).
    """

    center_m: tuple[float, float, float]
    angle_rad: float

    def __post_init__(self) -> None:
        if len(self.center_m) != 3 or not all(math.isfinite(c) for c in self.center_m):
            raise ParameterError("periodicity.center_m", self.center_m, "three finite numbers")
        if not (0.0 < self.angle_rad < 2.0 * math.pi):
            raise ParameterError("periodicity.angle_rad", self.angle_rad, "(0, 2 pi)")

    def image(self, points: np.ndarray) -> np.ndarray:
        """Points of the start face turned onto the end face, (n, 3) -> (n, 3)."""
        return rotate_xy(points, np.asarray(self.center_m, dtype=float), self.angle_rad)

    def preimage(self, points: np.ndarray) -> np.ndarray:
        """Points of the end face turned back onto the start face (the inverse of :meth:`image`)."""
        return rotate_xy(points, np.asarray(self.center_m, dtype=float), -self.angle_rad)
