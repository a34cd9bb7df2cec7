"""Carrying a flux of the cycle's reference tooth onto the flank facets of the thermal mesh.

The cycle gives a flux per facet of one reference tooth sector (body frame, as built), summed
over discrete positions. It is first reconstructed as a smoother field on the reference facets
(optional, ``[sources] flux_smoothing_*_mm``): every reference facet j spreads its heat q_j A_j
over its neighbours i with Gaussian weights, balanced so that

    q̃_i = Σ_j S_ij q_j,   S = D_c K D_A D_c,   c_i Σ_j K_ij A_j c_j = 1 for every i,

K the symmetric kernel below, A the facet areas, D diagonal. The scaling c (symmetric
Sinkhorn-Knopp balancing, to 1e-14) makes both the rows of S sum to one (a uniform flux stays
uniform on every facet) and, K being symmetric, the area-weighted columns Σ_i A_i S_ij = A_j
(every facet's heat is kept: Σ_i A_i q̃_i = Σ_j A_j q_j). The kernel is anisotropic (standard
deviations σ_p in the flank's plane, σ_z along the face width, cut at 3σ) and mirrored in the
two side planes z = 0 and z = b (method of images, a reflecting side face):

    K_ij = G(x_i - x_j) + G(x_i - M_0 x_j) + G(x_i - M_b x_j),

M_0, M_b the reflections. Until stop 30 the kernel was only normalised per column
(S_ij = A_j G_ij / Σ_k A_k G_kj): the heat was kept, but a facet near a side face or the tip or
root end of the surface, having neighbours on one side only, sent its heat inwards, and a
uniform flux came out 0.86 / 0.97 / 1.08 on the first rows of 14 with σ_z = 1.5 mm
(benchmarks/reconstruction_side_faces.py). The images keep the spread next to a side face the
reflected Gaussian; the balancing removes what is left (discrete rows, edges in the profile).

Each flank facet f of the thermal mesh (drive flanks, tips, roots) then takes the mean of the
reconstructed flux over its area,

    q_f = Σ_p w_p q̃(ref(x_p)) / Σ_p w_p,

over the midpoints x_p of a uniform subdivision of the facet (``TRANSFER_SUBDIVISIONS`` per
side, weights w_p the area Jacobian), each taking the reference facet nearest to its congruent
place (rotated by whole pitches into the reference sector). Taking one reference facet at the
centroid instead aliased: the flank's heat band (a few 0.1 mm wide at its foot) is narrower than
the thermal facets (0.21 mm across the profile on the built-in case), and the heat each facet
got depended on where its centroid fell in the band, not on the band. Every tooth's total is
scaled to the reference tooth's heat (a purely geometric correction for meshes that are not
rotated copies of each other), so the heat put in is conserved to round-off for any pair of
meshes. Cells next to the facets carry their facets' area-weighted mean
(DG0). The links (thermal facet, reference facet, weight) of :attr:`FlankTransfer.links` are the
rows S[ref(f), :], shared by the static and the temperature-dependent friction fluxes.
"""

from __future__ import annotations

import math

import basix
import numpy as np
import scipy.sparse as sps
from mpi4py import MPI
from scipy.spatial import cKDTree

from gearfem.contact.kinematics import evaluate
from gearfem.core.errors import ConvergenceError, ParameterError
from gearfem.core.facets import FacetReference
from gearfem.geometry.mesh import parse_group_name

# Facet areas for the per-tooth normalisation: exact enough on curved P2 facets (tip rounds) that
# the heat assembled with this rule equals the target to round-off (degree 2 left 2e-6).
AREA_QUADRATURE_DEGREE = 6
#: Sample points per side of a thermal facet for its mean of the reference flux (a subdivision
#: into TRANSFER_SUBDIVISIONS² sub-facets; 0.21 mm facets are sampled every 26 um).
TRANSFER_SUBDIVISIONS = 8
FLANK_KINDS = ("drive_flank", "tip", "root")
#: Kernel cut-off of the reconstruction, in standard deviations.
SMOOTHING_CUTOFF = 3.0
#: Tolerance and iteration budget of the reconstruction's balancing (:func:`_balance`): the rows of
#: S sum to 1 and its area-weighted columns to the facets' areas within BALANCE_RTOL.
BALANCE_RTOL = 1e-14
BALANCE_MAX_ITERATIONS = 500
#: What the reconstruction computes, for the keys of stored results made with it (the numerical
#: uncertainty studies): 1 until stop 30 (normalised per column); 2: balanced, mirrored kernels.
RECONSTRUCTION_VERSION = 2


def smoothing_operator(
    points_m: np.ndarray,
    area_m2: np.ndarray,
    sigma_m: tuple[float, float] | None,
    side_planes_z_m: tuple[float, float] | None,
) -> sps.csr_matrix:
    """The conservative reconstruction S (module docstring) on facets at ``points_m`` (tooth-local,
    z along the axis) with areas ``area_m2``; the identity for ``sigma_m`` None. The kernel is
    mirrored in the planes z = ``side_planes_z_m`` (the side faces; None: a face without ends)."""
    n = len(area_m2)
    if sigma_m is None:
        return sps.identity(n, format="csr")
    points = np.asarray(points_m, dtype=float)
    sp_, sz = sigma_m
    scale = np.array([sp_, sp_, sz])
    y = points / scale
    tree = cKDTree(y)
    pairs = tree.query_pairs(SMOOTHING_CUTOFF, output_type="ndarray")
    i = [pairs[:, 0], pairs[:, 1], np.arange(n)]
    j = [pairs[:, 1], pairs[:, 0], np.arange(n)]
    k = [np.exp(-0.5 * np.sum((y[a] - y[b]) ** 2, axis=1)) for a, b in zip(i[:2], j[:2])]
    k.append(np.ones(n))
    if side_planes_z_m is not None:
        z0, z1 = side_planes_z_m
        inside = (points[:, 2] >= z0) & (points[:, 2] <= z1)
        if not z0 < z1 or not np.all(inside):
            raise ParameterError(
                "side_planes_z_m",
                (z0, z1),
                f"z0 < z1 bracketing the facets' z, [{points[:, 2].min()}, {points[:, 2].max()}] m",
            )
        for plane in (z0, z1):
            image = points * [1.0, 1.0, -1.0] + [0.0, 0.0, 2.0 * plane]
            d = tree.sparse_distance_matrix(
                cKDTree(image / scale), SMOOTHING_CUTOFF, output_type="ndarray"
            )  # (facet i, image of facet j, distance)
            i.append(d["i"])
            j.append(d["j"])
            k.append(np.exp(-0.5 * d["v"] ** 2))
    i, j, k = np.concatenate(i), np.concatenate(j), np.concatenate(k)
    K = sps.csr_matrix((k, (i, j)), shape=(n, n))  # duplicates (a pair and its image) summed
    c = _balance(K, np.asarray(area_m2, dtype=float))
    return (sps.diags(c) @ K @ sps.diags(area_m2 * c)).tocsr()


def _balance(K: sps.csr_matrix, area: np.ndarray) -> np.ndarray:
    """The scaling c > 0 with c_i Σ_j K_ij A_j c_j = 1 for every i (symmetric Sinkhorn-Knopp
    balancing of the symmetric kernel ``K``: c <- sqrt(c / (K A c)), converging geometrically);
    :class:`ConvergenceError` when it has not reached :data:`BALANCE_RTOL` in
    :data:`BALANCE_MAX_ITERATIONS`."""
    c = 1.0 / np.sqrt(K @ area)  # exact for a kernel whose A-weighted sums are all equal
    err = math.inf
    for _ in range(BALANCE_MAX_ITERATIONS):
        r = c * (K @ (area * c))
        err = float(np.max(np.abs(r - 1.0))) if len(r) else 0.0
        if err <= BALANCE_RTOL:
            return c
        c = c / np.sqrt(r)
    raise ConvergenceError(
        "flux reconstruction balancing",
        f"rows of S sum to 1 within {err:.3e}, not {BALANCE_RTOL:g}",
        iteration=BALANCE_MAX_ITERATIONS,
        residual=err,
    )


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


def subdivision_points(facet_type, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Midpoints and reference areas of a uniform subdivision of the reference facet into n²
    parts (triangles: n² sub-triangles of the unit triangle; quadrilaterals: n x n squares of the
    unit square); the areas sum to the reference facet's."""
    if facet_type == basix.CellType.triangle:
        up = [((i + 1 / 3) / n, (j + 1 / 3) / n) for i in range(n) for j in range(n - i)]
        down = [((i + 2 / 3) / n, (j + 2 / 3) / n) for i in range(n) for j in range(n - 1 - i)]
        pts = np.array(up + down)
        return pts, np.full(len(pts), 0.5 / n**2)
    g = (np.arange(n) + 0.5) / n
    pts = np.array([(a, b) for a in g for b in g])
    return pts, np.full(len(pts), 1.0 / n**2)


class FlankTransfer:
    """The owned flank facets of one gear's thermal mesh and their reference facets (see the
    module docstring). Collective-free to build.

    Attributes: ``names`` (facet groups), ``cells``/``local_facet`` (cell and local facet of every
    owned flank facet), ``area`` (m²), ``centroid`` (m), ``tooth`` (thermal tooth index),
    ``num_teeth``, ``Q`` (the DG0 space), ``num_cells`` (local, owned and ghost), ``cell_area``
    (flank area of each facet's cell), ``smoother`` (S on the reference facets), ``sampler`` (the
    facet means of S q: thermal facets x reference facets), ``links`` (facet, reference facet,
    weight: the non-zeros of ``sampler``).
    """

    def __init__(
        self,
        domain,
        gear_mesh,
        body: str,
        fields,
        kinds=FLANK_KINDS,
        smoothing_m: tuple[float, float] | None = None,
    ) -> None:
        from dolfinx import fem

        mesh = domain.mesh
        tdim = mesh.topology.dim
        self.comm = mesh.comm
        self.fields = fields
        names = tuple(
            n
            for n in domain.groups
            if parse_group_name(n)[0] == body
            and parse_group_name(n)[2] in kinds
            and parse_group_name(n)[1] is not None
        )
        if not names:
            raise ParameterError(
                "sources.friction surfaces", kinds, f"facet groups of {body!r} in the thermal mesh"
            )
        self.names = names
        facets = domain.facets(names)
        n_owned_f = mesh.topology.index_map(tdim - 1).size_local
        facets = facets[facets < n_owned_f]
        mesh.topology.create_connectivity(tdim - 1, tdim)
        cf = np.asarray(
            fem.compute_integration_domains(fem.IntegralType.exterior_facet, mesh.topology, facets)
        ).reshape(-1, 2)
        cell_type = {
            "tetrahedron": basix.CellType.tetrahedron,
            "hexahedron": basix.CellType.hexahedron,
        }[mesh.topology.cell_name()]
        ref = FacetReference.create(cell_type, mesh.geometry.cmaps[0].degree)
        X = mesh.geometry.x[
            np.take_along_axis(
                mesh.geometry.dofmaps[0][cf[:, 0]], ref.facet_nodes[cf[:, 1]], axis=1
            )
        ]
        xc = X[:, : ref.num_vertices].mean(axis=1)
        qp, qw = ref.quadrature(AREA_QUADRATURE_DEGREE)
        area = np.zeros(len(facets))
        for p_, w_ in zip(qp, qw):
            _, a1, a2, _ = evaluate(ref, X, np.tile(p_, (len(facets), 1)))
            area += w_ * np.linalg.norm(np.cross(a1, a2), axis=1)
        angles = gear_mesh.tooth_angles(body)
        center = np.asarray(gear_mesh.center(body))
        _, tooth = tooth_local(xc, center, angles, fields.pitch_angle_rad, fields.tooth_angle_rad)
        # the subdivision's midpoints, rotated with their facet into the reference sector
        sub, sub_w = subdivision_points(ref.facet_type, TRANSFER_SUBDIVISIONS)
        nf, m = len(facets), len(sub_w)
        pts, jac = np.empty((nf, m, 3)), np.empty((nf, m))
        for i, (p_, w_) in enumerate(zip(sub, sub_w)):
            x, a1, a2, _ = evaluate(ref, X, np.tile(p_, (nf, 1)))
            pts[:, i], jac[:, i] = x, w_ * np.linalg.norm(np.cross(a1, a2), axis=1)
        rot = fields.tooth_angle_rad - np.asarray(angles)[tooth]
        c, s_ = np.cos(rot)[:, None], np.sin(rot)[:, None]
        rel = pts - center
        local = np.stack(
            [c * rel[..., 0] - s_ * rel[..., 1], s_ * rel[..., 0] + c * rel[..., 1], rel[..., 2]],
            axis=-1,
        )
        _, j = cKDTree(fields.facet_points_m - fields.center_m).query(local.reshape(-1, 3))
        n_ref = len(fields.facet_area_m2)
        mean = sps.csr_matrix(
            ((jac / jac.sum(axis=1, keepdims=True)).ravel(), (np.repeat(np.arange(nf), m), j)),
            shape=(nf, n_ref),
        )  # duplicates summed: q_f = Σ_p w_p q(ref(x_p)) / Σ_p w_p
        self.cells, self.local_facet = cf[:, 0], cf[:, 1]
        self.area, self.centroid, self.tooth = area, xc, tooth
        # the side faces z = 0 and z = b, in the tooth-local frame (the axis point at z = 0)
        b = gear_mesh.geometry.face_width_mm * 1e-3
        self.smoother = smoothing_operator(
            fields.facet_points_m - fields.center_m,
            fields.facet_area_m2,
            smoothing_m,
            (0.0 - fields.center_m[2], b - fields.center_m[2]),
        )
        #: (thermal facets x reference facets): the facet means of the reconstructed flux
        self.sampler = (mean @ self.smoother).tocsr()
        rows = self.sampler.tocoo()
        self.links = (rows.row.astype(np.int64), rows.col.astype(np.int64), rows.data)
        self.num_teeth = len(angles)
        self.Q = fem.functionspace(mesh, ("DG", 0))
        imap = mesh.topology.index_map(tdim)
        self.num_cells = imap.size_local + imap.num_ghosts
        den = np.bincount(self.cells, weights=area, minlength=self.num_cells)
        self.cell_area = den[self.cells]
        self.dofs = self.Q.dofmap.list[: self.num_cells, 0]

    def tooth_scale(self, q_ref: np.ndarray) -> np.ndarray:
        """Per thermal tooth: the factor that makes its heat, with the facet flux ``q_ref[ref]``,
        equal the reference tooth's Σ q_ref A_ref (collective)."""
        q = self.sample(q_ref)
        tooth_heat = self.comm.allreduce(
            np.bincount(self.tooth, weights=q * self.area, minlength=self.num_teeth), op=MPI.SUM
        )
        target = float(np.sum(q_ref * self.fields.facet_area_m2))
        return np.where(tooth_heat > 0, target / np.where(tooth_heat > 0, tooth_heat, 1.0), 0.0)

    def sample(self, q_ref: np.ndarray) -> np.ndarray:
        """The reconstructed reference flux averaged over every owned flank facet (before the
        tooth scale)."""
        return self.sampler @ np.asarray(q_ref, dtype=float)

    def cell_values(self, q_facet: np.ndarray) -> np.ndarray:
        """Area-weighted mean of a facet quantity per local cell (0 off the flanks)."""
        num = np.bincount(self.cells, weights=q_facet * self.area, minlength=self.num_cells)
        den = np.bincount(self.cells, weights=self.area, minlength=self.num_cells)
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)

    def function(self, q_facet: np.ndarray, name: str):
        """DG0 Function of :meth:`cell_values`."""
        from dolfinx import fem

        fn = fem.Function(self.Q, name=name)
        fn.x.array[self.dofs] = self.cell_values(q_facet)
        fn.x.scatter_forward()
        return fn


__all__ = [
    "AREA_QUADRATURE_DEGREE",
    "FLANK_KINDS",
    "RECONSTRUCTION_VERSION",
    "SMOOTHING_CUTOFF",
    "TRANSFER_SUBDIVISIONS",
    "FlankTransfer",
    "smoothing_operator",
    "subdivision_points",
    "tooth_local",
]
