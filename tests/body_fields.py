"""Hand-built fields of one gear for the instruments' and the benchmarks' tests: a
:class:`~gearfem.instruments.snapshot.BodyField` of given nodes, cells and temperatures, the rest
that of the built-in pinion at rest in the frame (centre at the origin, one tooth at angle 0)."""

from __future__ import annotations

import numpy as np

from gearfem.instruments.snapshot import BodyField


def body_field(
    nodes_m: np.ndarray,
    cells: np.ndarray,
    temperature_K: np.ndarray,
    faces: np.ndarray | None = None,
    face_kind: np.ndarray | None = None,
) -> BodyField:
    """The pinion's field of ``nodes_m`` (n, 3), ``cells`` (c, 4 or 10) and one label's nodal
    ``temperature_K`` (n,); ``faces`` (f, 3 or 6) of kind ``face_kind`` (f,), none by default."""
    return BodyField(
        body="pinion",
        nodes_m=nodes_m,
        cells=cells,
        faces=np.zeros((0, 3), dtype=int) if faces is None else faces,
        face_kind=np.zeros(0, dtype=np.int8) if face_kind is None else face_kind,
        temperature_K=np.asarray(temperature_K, dtype=float)[None, :],
        center_m=np.zeros(3),
        tooth_angles_rad=np.zeros(1),
        teeth=30,
        rotation_sense=1,
        speed_rpm=1000.0,
        emissivity=0.9,
        temperatures_C={},
    )
