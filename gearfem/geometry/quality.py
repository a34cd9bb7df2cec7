"""Element quality measures of the gear meshes (ANSYS Meshing definitions)."""

from __future__ import annotations

import math

import numpy as np

# ------------------------------------------------------------------------------------------------
# quality
# ------------------------------------------------------------------------------------------------

SKEWNESS_BINS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 1.0)


def tet_skewness(v: np.ndarray) -> np.ndarray:
    """Equilateral-volume skewness of tetrahedra ``v`` (``(n, 4, 3)`` corner coordinates):
    ``1 - V / V_eq``, with ``V_eq`` the volume of the regular tetrahedron that has the same
    circumradius (the ANSYS Meshing definition for tetrahedra; 0 = regular, 1 = degenerate).
    It penalises aspect ratio: swept tetrahedra with layers much thicker than the in-plane size
    score high however good their angles are (see :func:`tet_max_dihedral_deg`)."""
    a = v[:, 1] - v[:, 0]
    b = v[:, 2] - v[:, 0]
    c = v[:, 3] - v[:, 0]
    vol = np.abs(np.einsum("ij,ij->i", a, np.cross(b, c))) / 6.0
    M = np.stack([a, b, c], axis=1)  # circumcentre x (relative to v0): 2 M x = |rows|^2
    rhs = 0.5 * np.einsum("nij,nij->ni", M, M)
    x = np.linalg.solve(M, rhs[..., None])[..., 0]
    R = np.linalg.norm(x, axis=1)
    v_eq = 8.0 * R**3 / (9.0 * math.sqrt(3.0))  # regular tetrahedron with circumradius R
    return np.clip(1.0 - vol / v_eq, 0.0, 1.0)


def tet_max_dihedral_deg(v: np.ndarray) -> np.ndarray:
    """Largest dihedral angle of each tetrahedron [deg] (the maximum-angle condition of FE
    interpolation: anisotropic tetrahedra are fine while this stays away from 180 deg)."""
    faces = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))
    normals = []
    for f in faces:
        n = np.cross(v[:, f[1]] - v[:, f[0]], v[:, f[2]] - v[:, f[0]])
        normals.append(n / np.linalg.norm(n, axis=1)[:, None])
    worst = np.zeros(len(v))
    for i in range(4):
        for j in range(i + 1, 4):
            cosn = np.clip(np.einsum("ij,ij->i", normals[i], normals[j]), -1.0, 1.0)
            worst = np.maximum(worst, 180.0 - np.degrees(np.arccos(cosn)))
    return worst


# gmsh hexahedron corner numbering: 0-3 bottom (counter-clockwise), 4-7 top
_HEX_FACES = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))


def hex_skewness(v: np.ndarray) -> np.ndarray:
    """Normalised equiangular skewness of hexahedra ``v`` (``(n, 8, 3)``, gmsh corner order):
    ``max((t_max - 90) / 90, (90 - t_min) / 90)`` over the 24 corner angles of the six faces (the
    ANSYS Meshing definition for hexahedra; 0 = all right angles, independent of aspect ratio)."""
    tmax = np.zeros(len(v))
    tmin = np.full(len(v), 180.0)
    for face in _HEX_FACES:
        for i in range(4):
            p0, p1, p2 = v[:, face[i - 1]], v[:, face[i]], v[:, face[(i + 1) % 4]]
            e1, e2 = p0 - p1, p2 - p1
            cosang = np.einsum("ij,ij->i", e1, e2) / (
                np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
            )
            ang = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
            tmax = np.maximum(tmax, ang)
            tmin = np.minimum(tmin, ang)
    return np.clip(np.maximum((tmax - 90.0) / 90.0, (90.0 - tmin) / 90.0), 0.0, 1.0)
