"""Rotational periodicity of a gear body: sectors, tooth images, nearest-entity lookups.

The quasi-static state of a gear pair repeats every tooth pitch with the tooth numbers shifted
by one: for the pinion (turning counter-clockwise) the contact zone moves, in its body frame, by
one pitch clockwise per pitch of rotation, so a field w obeys w(x, φ + pitch) = w(R x, φ) with R
the rotation by +2π/z1 about the pinion axis; the wheel turns the other way and R is the rotation by
−2π/z2 about its axis. With this, one pitch of positions gives every tooth's whole engagement.

Entities (cells, facets) are identified across teeth by their centroids: a point rotated by whole
pitches lands in the congruent place of another tooth, and the nearest entity centroid there is
taken (exact where the mesh is periodic, nearest-neighbour sampling where it is not).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial import cKDTree

# sign of the body-frame shift per pitch of forward rotation
SHIFT_SIGN = {"pinion": 1.0, "wheel": -1.0}


def rotate_z(points: np.ndarray, center: np.ndarray, angle: float) -> np.ndarray:
    """Rotate points (n, 3) about the z axis through ``center`` by ``angle`` (rad)."""
    c, s = np.cos(angle), np.sin(angle)
    p = np.asarray(points, dtype=float) - center
    out = np.empty_like(p)
    out[:, 0] = c * p[:, 0] - s * p[:, 1]
    out[:, 1] = s * p[:, 0] + c * p[:, 1]
    out[:, 2] = p[:, 2]
    return out + center


def polar_angle(points: np.ndarray, center: np.ndarray) -> np.ndarray:
    p = np.asarray(points) - center
    return np.arctan2(p[:, 1], p[:, 0])


def in_sector(
    points: np.ndarray, center: np.ndarray, tooth_angle: float, pitch_angle: float
) -> np.ndarray:
    """True for points within half a pitch of the tooth centre line (the tooth's sector)."""
    d = np.angle(np.exp(1j * (polar_angle(points, center) - tooth_angle)))
    return np.abs(d) <= 0.5 * pitch_angle + 1e-12


@dataclasses.dataclass(frozen=True)
class ImageMap:
    """For entities of a reference set: the index of the nearest entity at each tooth image.

    ``index[m][i]`` is the entity (in the searched set) at the image ``m`` (rotation by
    ``m * shift``) of reference entity ``i``, ``valid[m][i]`` whether that image lies in the model
    (its nearest centroid is within ``tolerance`` of the rotated point).
    """

    images: tuple[int, ...]
    index: dict[int, np.ndarray]
    valid: dict[int, np.ndarray]


def image_map(
    ref_points: np.ndarray,
    points: np.ndarray,
    center: np.ndarray,
    shift: float,
    tolerance: np.ndarray | float,
    images=(-1, 0, 1),
) -> ImageMap:
    """Nearest entities of ``points`` to the rotated images of ``ref_points``."""
    tree = cKDTree(points)
    index, valid = {}, {}
    for m in images:
        q = rotate_z(ref_points, center, m * shift)
        d, j = tree.query(q)
        index[m] = j
        valid[m] = d <= tolerance
    return ImageMap(tuple(images), index, valid)


def periodic_max(values: np.ndarray, imap: ImageMap) -> np.ndarray:
    """max over positions and images: values (n_positions, n_entities) -> (n_ref,)."""
    out = np.zeros(len(imap.index[imap.images[0]]))
    for m in imap.images:
        v = values[:, imap.index[m]].max(axis=0)
        out = np.where(imap.valid[m], np.maximum(out, v), out)
    return out


def periodic_sum(values: np.ndarray, imap: ImageMap) -> np.ndarray:
    """sum over positions and images: values (n_positions, n_entities) -> (n_ref,)."""
    out = np.zeros(len(imap.index[imap.images[0]]))
    for m in imap.images:
        out += np.where(imap.valid[m], values[:, imap.index[m]].sum(axis=0), 0.0)
    return out


def history(values: np.ndarray, imap: ImageMap, entity: int) -> tuple[np.ndarray, np.ndarray]:
    """One reference entity's values over the images: (image m per sample, value) ordered by m then
    position."""
    ms, vs = [], []
    for m in sorted(imap.images):
        if imap.valid[m][entity]:
            ms.append(np.full(values.shape[0], m))
            vs.append(values[:, imap.index[m][entity]])
    return (np.concatenate(ms), np.concatenate(vs)) if ms else (np.zeros(0, int), np.zeros(0))
