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

M_0, M_b the reflections. Before ad5929c (2026-11-26) the kernel was only normalised per column
(S_ij = A_j G_ij / Σ_k A_k G_kj): the heat was kept, but a facet near a side face or the tip or
root end of the surface, having neighbours on one side only, sent its heat inwards, and a
uniform flux came out 0.86 / 0.97 / 1.08 on the first rows of 14 with σ_z = 1.5 mm
(measured with a benchmark script removed after 4a453cc; tests/test_transfer.py checks the
balance). The images keep the spread next to a side face the
reflected Gaussian; the balancing removes what is left (discrete rows, edges in the profile).

Each flank facet f of the thermal mesh (drive flanks, tips, roots) then takes the mean of the
reconstructed flux over its area,

    q_f = Σ_p w_p q̃(x_p) / Σ_p w_p,

over the midpoints x_p of a uniform subdivision of the facet (``TRANSFER_SUBDIVISIONS`` per
side, weights w_p the area Jacobian), each rotated by whole pitches to its congruent place in the
reference sector. ``[sources] flux_evaluation`` says what q̃(x_p) is:

* ``"reference_facets"`` (default): the reconstructed value of the reference facet nearest x_p,
  q̃(x_p) = (S q)_ref(x_p). The field is piecewise constant on the structural facets: a thermal
  mesh finer than them resolves their steps (across the face width the facet rows are a layer's
  half, 3.2 mm on the built-in case).
* ``"continuous"``: the kernel evaluated at x_p itself,

      q̃(x) = c(x) Σ_j K(x, x_j) A_j c_j q_j,   c(x) = 1 / Σ_j K(x, x_j) A_j c_j,

  the balancing extended to any point (at a facet's own point c(x_i) = c_i and q̃ = (S q)_i),
  with the Gaussian tapered to reach zero at its cut-off (a jump there otherwise): a continuous
  field, a uniform flux still uniform everywhere. A point with no facet within the
  cut-off takes its nearest facet's (S q).

Taking one reference facet at the thermal facet's centroid instead of the mean aliased: the
flank's heat band (a few 0.1 mm wide at its foot) is narrower than the thermal facets (0.21 mm
across the profile on the built-in case), and the heat each facet got depended on where its
centroid fell in the band, not on the band. Every tooth's total is scaled to the reference
tooth's heat (a purely geometric correction for meshes that are not rotated copies of each
other), so the heat put in is conserved to round-off for any pair of meshes. Cells next to the
facets carry their facets' area-weighted mean (DG0). The links (thermal facet, reference facet,
weight) of :attr:`FlankTransfer.links` are the non-zeros of the facet means
(q_f = Σ_j weight q_j), shared by the static and the temperature-dependent friction fluxes.
"""

from __future__ import annotations

import hashlib
import math

import basix
import numpy as np
import scipy.sparse as sps
from mpi4py import MPI
from scipy.spatial import cKDTree

from gearfem.contact.kinematics import evaluate
from gearfem.core.errors import ConvergenceError, ParameterError
from gearfem.core.facets import FacetReference
from gearfem.coupling.options import FluxReconstruction
from gearfem.geometry.mesh import parse_group_name
from gearfem.geometry.placement import tooth_local

# Facet areas for the per-tooth normalisation: exact enough on curved P2 facets (tip rounds) that
# the heat assembled with this rule equals the target to round-off (degree 2 left 2e-6).
AREA_QUADRATURE_DEGREE = 6
#: Sample points per side of a thermal facet for its mean of the reference flux (a subdivision
#: into TRANSFER_SUBDIVISIONS² sub-facets; 0.21 mm facets are sampled every 26 um).
TRANSFER_SUBDIVISIONS = 8
FLANK_KINDS = ("drive_flank", "tip", "root")
#: Kernel cut-off of the reconstruction, in standard deviations.
SMOOTHING_CUTOFF = 3.0
#: The Gaussian's value at the cut-off, subtracted by the tapered kernel.
TAPER = math.exp(-0.5 * SMOOTHING_CUTOFF**2)
#: Tolerance and iteration budget of the reconstruction's balancing (:func:`_balance`): the rows of
#: S sum to 1 and its area-weighted columns to the facets' areas within BALANCE_RTOL.
BALANCE_RTOL = 1e-14
BALANCE_MAX_ITERATIONS = 500
#: Thermal facets per block of the continuous evaluation (bounds the memory of the kernel pairs).
CONTINUOUS_BLOCK_FACETS = 4096
#: What the reconstruction computes, for the keys of stored results made with it (the numerical
#: uncertainty studies): 1 before ad5929c (normalised per column); 2: balanced, mirrored kernels.
RECONSTRUCTION_VERSION = 2


def kernel_matrix(
    targets_m: np.ndarray,
    sources_m: np.ndarray,
    sigma_m: tuple[float, float],
    side_planes_z_m: tuple[float, float] | None,
    tapered: bool = False,
) -> sps.csr_matrix:
    """K_ij = G(x_i - y_j) + G(x_i - M_0 y_j) + G(x_i - M_b y_j) between ``targets_m`` x_i and
    ``sources_m`` y_j (tooth-local, z along the axis): the anisotropic Gaussian of standard
    deviations ``sigma_m`` (profile, axial), cut at :data:`SMOOTHING_CUTOFF`, and its images in
    the planes z = ``side_planes_z_m`` (None: no images). ``tapered``: the Gaussian minus its
    value at the cut-off, so that it reaches zero there continuously (no jump of 1.1 % of a
    weight where a facet enters the cut-off). Symmetric when the two point sets are the same."""
    sp_, sz = sigma_m
    scale = np.array([sp_, sp_, sz])
    targets, sources = np.asarray(targets_m, dtype=float), np.asarray(sources_m, dtype=float)
    tree = cKDTree(targets / scale)
    images = [sources]
    if side_planes_z_m is not None:
        images += [sources * [1.0, 1.0, -1.0] + [0.0, 0.0, 2.0 * z] for z in side_planes_z_m]
    i, j, k = [], [], []
    for y in images:
        d = tree.sparse_distance_matrix(cKDTree(y / scale), SMOOTHING_CUTOFF, output_type="ndarray")
        i.append(d["i"])
        j.append(d["j"])
        g = np.exp(-0.5 * d["v"] ** 2)
        k.append(np.maximum(g - TAPER, 0.0) if tapered else g)  # >= 0 at d = cut-off by round-off
    # duplicates (a pair and an image of it) summed
    return sps.csr_matrix(
        (np.concatenate(k), (np.concatenate(i), np.concatenate(j))),
        shape=(len(targets), len(sources)),
    )


def _check_side_planes(points_m: np.ndarray, side_planes_z_m: tuple[float, float] | None) -> None:
    if side_planes_z_m is None:
        return
    z0, z1 = side_planes_z_m
    z = np.asarray(points_m)[:, 2]
    if not z0 < z1 or not np.all((z >= z0) & (z <= z1)):
        raise ParameterError(
            "side_planes_z_m",
            (z0, z1),
            f"z0 < z1 bracketing the facets' z, [{z.min()}, {z.max()}] m",
        )


def balanced_scaling(
    points_m: np.ndarray,
    area_m2: np.ndarray,
    sigma_m: tuple[float, float],
    side_planes_z_m: tuple[float, float] | None,
    tapered: bool = False,
) -> tuple[sps.csr_matrix, np.ndarray]:
    """The kernel K on the facets at ``points_m`` and its balancing c (module docstring;
    ``tapered``: :func:`kernel_matrix`)."""
    _check_side_planes(points_m, side_planes_z_m)
    K = kernel_matrix(points_m, points_m, sigma_m, side_planes_z_m, tapered)
    return K, _balance(K, np.asarray(area_m2, dtype=float))


def smoothing_operator(
    points_m: np.ndarray,
    area_m2: np.ndarray,
    sigma_m: tuple[float, float] | None,
    side_planes_z_m: tuple[float, float] | None,
    tapered: bool = False,
) -> sps.csr_matrix:
    """The conservative reconstruction S (module docstring) on facets at ``points_m`` (tooth-local,
    z along the axis) with areas ``area_m2``; the identity for ``sigma_m`` None. The kernel is
    mirrored in the planes z = ``side_planes_z_m`` (the side faces; None: a face without ends) and
    ``tapered`` as :func:`kernel_matrix` says."""
    if sigma_m is None:
        return sps.identity(len(area_m2), format="csr")
    K, c = balanced_scaling(points_m, area_m2, sigma_m, side_planes_z_m, tapered)
    return (sps.diags(c) @ K @ sps.diags(np.asarray(area_m2, dtype=float) * c)).tocsr()


def continuous_operator(
    targets_m: np.ndarray,
    points_m: np.ndarray,
    area_m2: np.ndarray,
    sigma_m: tuple[float, float],
    side_planes_z_m: tuple[float, float] | None,
    balanced: tuple[sps.csr_matrix, np.ndarray] | None = None,
) -> sps.csr_matrix:
    """The reconstruction evaluated at ``targets_m`` (module docstring): rows
    c(x) K(x, x_j) A_j c_j with c(x) = 1 / Σ_j K(x, x_j) A_j c_j, so that a uniform flux gives
    the same value everywhere and, at a facet's own point, the row of S. The kernel is the
    tapered one (:func:`kernel_matrix`), so the field is continuous: S here is
    ``smoothing_operator(..., tapered=True)``. A target with no facet within the kernel's cut-off
    takes its nearest facet's row of S. ``balanced``: the facets' tapered kernel and balancing,
    :func:`balanced_scaling` (``tapered=True``), when the caller evaluates in blocks."""
    K, c = balanced or balanced_scaling(points_m, area_m2, sigma_m, side_planes_z_m, tapered=True)
    w = np.asarray(area_m2, dtype=float) * c
    Kx = kernel_matrix(targets_m, points_m, sigma_m, side_planes_z_m, tapered=True)
    total = Kx @ w
    far = total <= 0.0
    rows = sps.diags(1.0 / np.where(far, np.inf, total)) @ Kx @ sps.diags(w)
    if np.any(far):
        scale = np.array([sigma_m[0], sigma_m[0], sigma_m[1]])
        _, nearest = cKDTree(np.asarray(points_m) / scale).query(np.asarray(targets_m)[far] / scale)
        pick = sps.csr_matrix(
            (np.ones(len(nearest)), (np.flatnonzero(far), nearest)), shape=Kx.shape
        )
        rows = rows + pick @ (sps.diags(c) @ K @ sps.diags(w))
    return rows.tocsr()


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


#: The samplers built last, by the digest of their inputs (:func:`facet_sampler`; most recent
#: last): a diagnosis builds the same gears' transfers for each of its runs.
_SAMPLERS: dict[str, sps.csr_matrix] = {}
_SAMPLERS_KEPT = 4


def facet_sampler(
    local: np.ndarray,
    weight: np.ndarray,
    ref_points: np.ndarray,
    facet_area: np.ndarray,
    reconstruction: FluxReconstruction | None,
    planes: tuple[float, float],
) -> sps.csr_matrix:
    """The thermal facets' means of the reconstructed reference flux, (thermal facets x
    reference facets): ``local`` (facets, samples, 3) the facets' sample points in the reference
    sector, ``weight`` their normalised area weights (flat), ``ref_points`` and ``facet_area``
    the reference facets' points and areas, ``planes`` the side faces' z. Kept for the last few
    inputs (a digest of all of them): built once per gear for a diagnosis's runs."""
    h = hashlib.sha256(repr((reconstruction, tuple(planes), local.shape)).encode())
    for arr in (local, weight, ref_points, facet_area):
        h.update(np.ascontiguousarray(arr, dtype=float).tobytes())
    key = h.hexdigest()
    sampler = _SAMPLERS.pop(key, None)
    if sampler is None:
        sampler = _facet_sampler(local, weight, ref_points, facet_area, reconstruction, planes)
    _SAMPLERS[key] = sampler
    while len(_SAMPLERS) > _SAMPLERS_KEPT:
        del _SAMPLERS[next(iter(_SAMPLERS))]
    return sampler


def _facet_sampler(local, weight, ref_points, facet_area, reconstruction, planes):
    nf, m = local.shape[:2]
    n_ref = len(facet_area)
    if reconstruction is not None and reconstruction.evaluation == "continuous":
        # the reconstruction evaluated at the sample points (in blocks of facets: memory)
        balanced = balanced_scaling(
            ref_points, facet_area, reconstruction.sigma_m, planes, tapered=True
        )  # once for all blocks
        blocks = []
        for f0 in range(0, nf, CONTINUOUS_BLOCK_FACETS):
            f1 = min(nf, f0 + CONTINUOUS_BLOCK_FACETS)
            at = continuous_operator(
                local[f0:f1].reshape(-1, 3),
                ref_points,
                facet_area,
                reconstruction.sigma_m,
                planes,
                balanced,
            )
            mean = sps.csr_matrix(
                (
                    weight[f0 * m : f1 * m],
                    (np.repeat(np.arange(f1 - f0), m), np.arange((f1 - f0) * m)),
                ),
                shape=(f1 - f0, (f1 - f0) * m),
            )
            blocks.append(mean @ at)
        return sps.vstack(blocks).tocsr() if blocks else sps.csr_matrix((0, n_ref))
    _, j = cKDTree(ref_points).query(local.reshape(-1, 3))
    mean = sps.csr_matrix(
        (weight, (np.repeat(np.arange(nf), m), j)), shape=(nf, n_ref)
    )  # duplicates summed: q_f = Σ_p w_p q(ref(x_p)) / Σ_p w_p
    smoother = smoothing_operator(
        ref_points,
        facet_area,
        None if reconstruction is None else reconstruction.sigma_m,
        planes,
    )
    return (mean @ smoother).tocsr()


class FlankTransfer:
    """The owned flank facets of one gear's thermal mesh and their reference facets (see the
    module docstring). Collective-free to build.

    Attributes: ``names`` (facet groups), ``cells``/``local_facet`` (cell and local facet of every
    owned flank facet), ``area`` (m²), ``centroid`` (m), ``tooth`` (thermal tooth index),
    ``num_teeth``, ``Q`` (the DG0 space), ``num_cells`` (local, owned and ghost), ``cell_area``
    (flank area of each facet's cell), ``sampler`` (thermal facets x reference facets: the facet
    means of the reconstruction, per reference facet or continuous as ``reconstruction`` says),
    ``links`` (facet, reference facet, weight: the non-zeros of ``sampler``).
    """

    def __init__(
        self,
        domain,
        gear_mesh,
        body: str,
        fields,
        kinds=FLANK_KINDS,
        reconstruction: FluxReconstruction | None = None,
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
        ref_points = fields.facet_points_m - fields.center_m
        weight = (jac / jac.sum(axis=1, keepdims=True)).ravel()
        # the side faces z = 0 and z = b, in the tooth-local frame (the axis point at z = 0)
        b = gear_mesh.geometry.face_width_mm * 1e-3
        planes = (0.0 - fields.center_m[2], b - fields.center_m[2])
        self.cells, self.local_facet = cf[:, 0], cf[:, 1]
        self.area, self.centroid, self.tooth = area, xc, tooth
        #: (thermal facets x reference facets): the facet means of the reconstructed flux
        self.sampler = facet_sampler(
            local, weight, ref_points, fields.facet_area_m2, reconstruction, planes
        )
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
    "balanced_scaling",
    "continuous_operator",
    "kernel_matrix",
    "smoothing_operator",
    "subdivision_points",
    "tooth_local",
]
