"""The visible surface of a gear as flat triangles carrying nodal temperatures (numpy only).

A :class:`Surface` is a triangle soup: per triangle its three vertices (pair frame, m), the
temperatures at its vertices at every snapshot label (linear in between), the kind of surface it
lies on and, for closed surfaces, an outward orientation (counter-clockwise seen from outside).

:func:`gear_surface` builds the whole gear from a :class:`~gearfem.instruments.snapshot.BodyField`:

* each quadratic boundary face (6 nodes) is split into its four linear sub-triangles (the curved
  P2 face is approximated by the chords through its mid-edge nodes, and the quadratic temperature
  by the linear interpolant of its six nodal values);
* a sector model is completed by rotation: the pitch sector of the central tooth (the one furthest
  from the adiabatic cut faces), bounded by the two axial half-planes at ±half a pitch from its
  centre line, is cut out exactly (triangles crossing a half-plane are clipped there, their
  temperatures interpolated linearly along the cut edges) and copied to every tooth of the gear.
  The copies meet on the half-planes, so the ring is closed; the cut faces of the sector are not
  part of it. This is exact for the rotation-averaged heat sources, which are the same on every
  tooth (the sector's edge teeth differ from the periodic field by the adiabatic-cut error).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from gearfem.core.rotation import rotate_xy
from gearfem.instruments.snapshot import KINDS, BodyField

# linear sub-triangles of a 6-node triangle (v0, v1, v2, e(1,2), e(0,2), e(0,1)), same orientation
_SUB = np.array([[0, 5, 4], [5, 1, 3], [4, 3, 2], [5, 3, 4]])


@dataclasses.dataclass(frozen=True, eq=False)
class Surface:
    """A triangle soup with vertex temperatures (see the module docstring).

    Attributes:
        points_m: (t, 3, 3) vertices of each triangle.
        temperature_K: (labels, t, 3) vertex temperatures.
        kind: (t,) index into :data:`gearfem.instruments.snapshot.KINDS`.
        closed: True when the triangles bound a solid and are oriented outwards (back faces can
            be culled).
        emissivity: Normal emissivity of the surface.
        center_m, rotation_sense, pitch_rad: The rotation the surface turns with (about the axis
            through ``center_m`` along z).
    """

    points_m: np.ndarray
    temperature_K: np.ndarray
    kind: np.ndarray
    closed: bool
    emissivity: float
    center_m: np.ndarray
    rotation_sense: int
    pitch_rad: float

    @property
    def count(self) -> int:
        return len(self.points_m)

    def area_m2(self) -> float:
        p = self.points_m
        return float(
            0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
        )


def linear_triangles(faces: np.ndarray) -> np.ndarray:
    """Node indices of the linear triangles of boundary faces: 6-node faces give four each."""
    faces = np.asarray(faces)
    if faces.shape[1] == 3:
        return faces
    if faces.shape[1] != 6:
        raise ValueError("faces of 3 or 6 nodes expected")
    return faces[:, _SUB].reshape(-1, 3)


def clip_half_space(
    points: np.ndarray, values: np.ndarray, kind: np.ndarray, normal: np.ndarray, origin: np.ndarray
):
    """Keep the part of each triangle where (x - origin)·normal >= 0.

    ``points`` (t, 3, 3), ``values`` (labels, t, 3) interpolated linearly onto cut edges, ``kind``
    (t,). A triangle with one vertex inside becomes one triangle, with two a quadrilateral split
    into two; the vertex order (orientation) is kept. Returns the clipped (points, values, kind).
    """
    d = (points - origin) @ normal  # (t, 3)
    inside = d >= 0.0
    n_in = inside.sum(axis=1)
    out_p = [points[n_in == 3]]
    out_v = [values[:, n_in == 3]]
    out_k = [kind[n_in == 3]]

    def rolled(mask, first):
        # roll each triangle's vertices so that vertex `first` (per triangle) comes first
        idx = (first[:, None] + np.arange(3)[None, :]) % 3
        p = np.take_along_axis(points[mask], idx[:, :, None], axis=1)
        v = np.take_along_axis(values[:, mask], idx[None, :, :], axis=2)
        dd = np.take_along_axis(d[mask], idx, axis=1)
        return p, v, dd

    def cut(pa, pb, va, vb, da, db):
        t = da / (da - db)
        return pa + t[:, None] * (pb - pa), va + t[None, :] * (vb - va)

    one = n_in == 1
    if np.any(one):
        first = np.argmax(inside[one], axis=1)
        p, v, dd = rolled(one, first)
        pab, vab = cut(p[:, 0], p[:, 1], v[..., 0], v[..., 1], dd[:, 0], dd[:, 1])
        pca, vca = cut(p[:, 0], p[:, 2], v[..., 0], v[..., 2], dd[:, 0], dd[:, 2])
        out_p.append(np.stack([p[:, 0], pab, pca], axis=1))
        out_v.append(np.stack([v[..., 0], vab, vca], axis=2))
        out_k.append(kind[one])
    two = n_in == 2
    if np.any(two):
        first = np.argmin(inside[two], axis=1)  # the outside vertex first: (o, a, b)
        p, v, dd = rolled(two, first)
        poa, voa = cut(p[:, 1], p[:, 0], v[..., 1], v[..., 0], dd[:, 1], dd[:, 0])
        pbo, vbo = cut(p[:, 2], p[:, 0], v[..., 2], v[..., 0], dd[:, 2], dd[:, 0])
        out_p.append(np.stack([poa, p[:, 1], p[:, 2]], axis=1))
        out_v.append(np.stack([voa, v[..., 1], v[..., 2]], axis=2))
        out_p.append(np.stack([poa, p[:, 2], pbo], axis=1))
        out_v.append(np.stack([voa, v[..., 2], vbo], axis=2))
        out_k += [kind[two], kind[two]]
    return np.concatenate(out_p), np.concatenate(out_v, axis=1), np.concatenate(out_k)


def gear_surface(field: BodyField, emissivity: float | None = None) -> Surface:
    """The whole gear's boundary (module docstring); ``emissivity`` overrides the field's."""
    cuts = np.isin(field.face_kind, [KINDS.index("cut_start"), KINDS.index("cut_end")])
    faces = field.faces[~cuts]
    kind = field.face_kind[~cuts]
    per = 4 if faces.shape[1] == 6 else 1
    tris = linear_triangles(faces)
    kind = np.repeat(kind, per)
    points = field.nodes_m[tris]  # (t, 3, 3)
    values = field.temperature_K[:, tris]  # (labels, t, 3)
    center = np.asarray(field.center_m, dtype=float)
    if not field.full:
        pitch = field.pitch_rad
        theta = float(field.tooth_angles_rad[field.central_tooth])
        lo, hi = theta - 0.5 * pitch, theta + 0.5 * pitch
        # keep angle > lo: normal (-sin lo, cos lo); keep angle < hi: normal (sin hi, -cos hi)
        for n in (
            np.array([-math.sin(lo), math.cos(lo), 0.0]),
            np.array([math.sin(hi), -math.cos(hi), 0.0]),
        ):
            points, values, kind = clip_half_space(points, values, kind, n, center)
        copies = [
            rotate_xy(points, center, k * pitch) for k in range(field.teeth)
        ]  # tooth k of the gear
        points = np.concatenate(copies)
        values = np.tile(values, (1, field.teeth, 1))
        kind = np.tile(kind, field.teeth)
    return Surface(
        points_m=np.ascontiguousarray(points),
        temperature_K=np.ascontiguousarray(values),
        kind=kind.astype(np.int8),
        closed=True,
        emissivity=field.emissivity if emissivity is None else float(emissivity),
        center_m=center,
        rotation_sense=int(field.rotation_sense),
        pitch_rad=field.pitch_rad,
    )
