"""The conservative reconstruction of the cycle's facet flux (gearfem.coupling.transfer), on a
synthetic flank: a regular grid of facets in the flank's plane (x, y) and along the face width z."""

from __future__ import annotations

import basix
import numpy as np
import pytest

from gearfem.core.errors import ConvergenceError, ParameterError
from gearfem.coupling import transfer
from gearfem.coupling.options import FluxReconstruction, SourceOptions
from gearfem.coupling.transfer import (
    SMOOTHING_CUTOFF,
    continuous_operator,
    smoothing_operator,
    subdivision_points,
)


def _flank(n_p=60, n_z=12, h_p=0.2e-3, h_z=1.0e-3, seed=0):
    """Facet centroids on a plane 45 deg in (x, y), jittered, with unequal areas."""
    rng = np.random.default_rng(seed)
    s, z = np.meshgrid(np.arange(n_p) * h_p, np.arange(n_z) * h_z, indexing="ij")
    s = s.ravel() + rng.uniform(-0.1, 0.1, s.size) * h_p
    z = z.ravel() + rng.uniform(-0.1, 0.1, z.size) * h_z
    pts = np.column_stack([s / np.sqrt(2), s / np.sqrt(2), z])
    area = h_p * h_z * rng.uniform(0.5, 1.5, s.size)
    return pts, area, s, z


def test_reconstruction_keeps_every_facets_heat_and_a_uniform_flux():
    """Balanced: on a jittered flank with unequal areas, edges included, a uniform flux comes out
    uniform and every facet's heat is kept, both to round-off (column normalisation alone, as
    before ad5929c, kept the heat but let a uniform flux vary by up to 15 % inside and more at
    edges)."""
    pts, area, _, _ = _flank()
    S = smoothing_operator(pts, area, (0.1e-3, 1.0e-3), None)
    rng = np.random.default_rng(1)
    q = rng.uniform(0.0, 1e5, len(area))
    # conservative: Σ A q̃ = Σ A q, to round-off, for any flux (columns: A_i S_ij sum to A_j)
    assert np.sum(area * (S @ q)) == pytest.approx(np.sum(area * q), rel=1e-13)
    np.testing.assert_allclose(area @ S, area, rtol=1e-13)
    # uniform in, uniform out, on every facet
    np.testing.assert_allclose(S @ np.ones(len(area)), 1.0, rtol=0, atol=1e-13)
    assert S.min() >= 0.0  # a positive flux stays positive
    # no reconstruction: the identity
    S0 = smoothing_operator(pts, area, None, None)
    np.testing.assert_array_equal((S0 @ q), q)


def test_balancing_that_does_not_converge_raises(monkeypatch):
    pts, area, _, _ = _flank()
    monkeypatch.setattr(transfer, "BALANCE_MAX_ITERATIONS", 1)
    with pytest.raises(ConvergenceError, match="flux reconstruction balancing"):
        smoothing_operator(pts, area, (0.1e-3, 1.0e-3), None)


def test_reconstruction_spreads_a_facet_with_the_stated_standard_deviations():
    """One facet's heat spread on a fine regular grid: its second moments in the flank's plane and
    along z are the kernel's σ² (to the grid's and the cut-off's accuracy)."""
    h = 0.05e-3
    s, z = np.meshgrid(np.arange(121) * h, np.arange(121) * 10 * h, indexing="ij")
    s, z = s.ravel(), z.ravel()
    pts = np.column_stack([s / np.sqrt(2), s / np.sqrt(2), z])
    area = np.full(len(s), h * 10 * h)
    sig = (0.2e-3, 2.0e-3)
    S = smoothing_operator(pts, area, sig, None)
    j = np.argmin((s - s.mean()) ** 2 + (z - z.mean()) ** 2)
    w = S[:, [j]].toarray().ravel() * area  # the heat it puts on each facet
    assert np.sum(w) == pytest.approx(area[j], rel=1e-12)
    var_s = np.sum(w * (s - s[j]) ** 2) / np.sum(w)
    var_z = np.sum(w * (z - z[j]) ** 2) / np.sum(w)
    # a Gaussian truncated at 3σ in 2D (radially): variance per axis σ² (1 - c), c small
    trunc = 1.0 - SMOOTHING_CUTOFF**2 * np.exp(-0.5 * SMOOTHING_CUTOFF**2) / (
        2 * (1 - np.exp(-0.5 * SMOOTHING_CUTOFF**2))
    )
    assert np.sqrt(var_s) == pytest.approx(sig[0] * np.sqrt(trunc), rel=0.02)
    assert np.sqrt(var_z) == pytest.approx(sig[1] * np.sqrt(trunc), rel=0.02)


def _rows(z_in_layer, layers, b, n_p=40, h_p=0.1e-3):
    """Facet centroids of a flank in ``layers`` equal layers across the face width ``b``, each
    layer holding rows at the fractions ``z_in_layer`` of its thickness; equal areas."""
    h = b / layers
    zr = np.concatenate([(k + np.asarray(z_in_layer)) * h for k in range(layers)])
    s, z = np.meshgrid(np.arange(n_p) * h_p, zr, indexing="ij")
    s, z = s.ravel(), z.ravel()
    pts = np.column_stack([s / np.sqrt(2), s / np.sqrt(2), z])
    return pts, np.full(len(s), h_p * h / len(z_in_layer)), s, z


@pytest.mark.parametrize(
    "z_in_layer, layers, sigma_z_rows",
    [
        ((0.5,), 14, 1.63),  # 7 layers x 2 rows with 1.5 mm: where the old bias was largest
        ((1 / 3, 2 / 3), 2, 1.0),  # two rows of centroids per layer, symmetric in the layer
        ((0.5,), 4, 0.46),  # the built-in case's rows and width
    ],
)
def test_images_mirror_the_kernel_in_the_side_faces(z_in_layer, layers, sigma_z_rows):
    """Next to a side face, a facet's heat spreads as the Gaussian plus its image in the side
    plane (a reflecting face), normalised: the heat each row receives from a facet of the first
    row is Σ_row A_i [G(x_i - x_j) + G(x_i - M_0 x_j)] / Σ_all, to round-off."""
    b = 12.934e-3
    pts, area, s, z = _rows(z_in_layer, layers, b)
    spacing = b / (layers * len(z_in_layer))
    # σ_p not a multiple of the grid's 0.1 mm: neighbours at exactly the cut-off would fall in or
    # out by round-off
    sig = np.array([0.107e-3, 0.107e-3, sigma_z_rows * spacing])
    S = smoothing_operator(pts, area, tuple(sig[1:]), (0.0, b))
    j = int(np.argmin(np.abs(s - s.mean()) + z))  # mid-profile, first row
    got = S[:, [j]].toarray().ravel() * area  # the heat facet j puts on each facet
    image = pts[j] * [1.0, 1.0, -1.0]
    kernel = sum(
        np.where(d < SMOOTHING_CUTOFF, np.exp(-0.5 * d**2), 0.0)
        for d in (np.linalg.norm((pts - x) / sig, axis=1) for x in (pts[j], image))
    )
    want = area[j] * area * kernel / np.sum(area * kernel)
    rows = np.round(z * 1e7).astype(int)
    per_row = [(got[rows == r].sum(), want[rows == r].sum()) for r in np.unique(rows)]
    np.testing.assert_allclose(*zip(*per_row), rtol=1e-12, atol=1e-15 * area[j])
    if sigma_z_rows > 0.9:  # the kernel reaches the image: without it, another spread
        plain = smoothing_operator(pts, area, tuple(sig[1:]), None)[:, [j]].toarray().ravel()
        plain_rows = np.array([(plain * area)[rows == r].sum() for r in np.unique(rows)])
        want_rows = np.array([w for _, w in per_row])
        assert np.max(np.abs(plain_rows - want_rows)) > 0.01 * area[j]


def test_side_planes_must_bracket_the_facets():
    pts, area, _, _ = _rows((0.5,), 4, 12.934e-3)
    with pytest.raises(ParameterError, match="side_planes_z_m"):
        smoothing_operator(pts, area, (0.1e-3, 1e-3), (2e-3, 12.934e-3))  # first row at 1.6 mm


def test_bad_smoothing_options_are_refused_by_name():
    with pytest.raises(ParameterError, match="flux_smoothing_profile_mm"):
        SourceOptions(flux_smoothing_profile_mm=0.0, flux_smoothing_axial_mm=1.0)
    with pytest.raises(ParameterError, match="flux_smoothing_axial_mm"):
        SourceOptions(flux_smoothing_axial_mm=-1.0)
    none = SourceOptions(flux_smoothing_profile_mm=0.0, flux_smoothing_axial_mm=0.0)
    assert none.flux_reconstruction is None
    with pytest.raises(ParameterError, match="flux_evaluation"):
        SourceOptions(flux_evaluation="nodal")
    with pytest.raises(ParameterError, match="flux_evaluation"):  # needs the kernel
        SourceOptions(
            flux_smoothing_profile_mm=0.0, flux_smoothing_axial_mm=0.0, flux_evaluation="continuous"
        )
    with pytest.raises(ParameterError, match="sigma_m"):
        FluxReconstruction(sigma_m=(0.0, 1e-3))
    assert SourceOptions(flux_evaluation="continuous").flux_reconstruction == FluxReconstruction(
        sigma_m=(1e-4, 1.5e-3), evaluation="continuous"
    )


def test_continuous_evaluation_interpolates_the_reconstruction():
    """The kernel evaluated anywhere: at the facets' own points it is S (c(x_i) = c_i), a uniform
    flux is uniform at any point (edges and side faces included), and a positive flux stays
    positive; a point beyond the kernel's reach takes its nearest facet's row of S."""
    b = 12.934e-3
    pts, area, _, _ = _rows((0.5,), 4, b)
    sig, planes = (0.107e-3, 1.5e-3), (0.0, b)
    S = smoothing_operator(pts, area, sig, planes, tapered=True)
    at_facets = continuous_operator(pts, pts, area, sig, planes)
    np.testing.assert_allclose(at_facets.toarray(), S.toarray(), rtol=0, atol=1e-13 * S.max())
    rng = np.random.default_rng(3)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    t = rng.uniform(0.0, 1.0, (500, 1))
    targets = lo + t * (hi - lo)  # on the flank's plane, over its whole extent
    targets[:, 2] = rng.uniform(0.0, b, 500)  # side faces included
    C = continuous_operator(targets, pts, area, sig, planes)
    np.testing.assert_allclose(C @ np.ones(len(area)), 1.0, rtol=0, atol=1e-13)
    assert C.min() >= 0.0
    far = (hi + np.array([1e-3, 1e-3, 0.0]))[None, :]  # 1 mm beyond the last facet: out of reach
    nearest = int(np.argmin(np.linalg.norm(pts - far, axis=1)))
    got = continuous_operator(far, pts, area, sig, planes).toarray().ravel()
    np.testing.assert_allclose(got, S[nearest].toarray().ravel(), rtol=0, atol=1e-15)


def test_continuous_evaluation_has_no_steps_across_the_rows():
    """Across the face width a flux that differs between two halves of the rows (4 rows of
    3.2 mm, the built-in case's): evaluated per reference facet it jumps where the rows meet
    (the largest change between neighbouring points along z stays the jump however close the
    points), continuously it does not (the largest change halves with the points' spacing)."""
    b = 12.934e-3
    pts, area, s, z = _rows((0.5,), 4, b)
    sig, planes = (0.107e-3, 1.5e-3), (0.0, b)
    q = np.where(z > b / 2, 2.0, 1.0)
    S = smoothing_operator(pts, area, sig, planes)
    mid = pts[np.argmin(np.abs(s - s.mean()))]
    largest = {}
    for n in (451, 901):
        line = np.column_stack(
            [np.full(n, mid[0]), np.full(n, mid[1]), np.linspace(0.05 * b, 0.95 * b, n)]
        )
        smooth = continuous_operator(line, pts, area, sig, planes) @ q
        nearest = np.argmin(np.linalg.norm(line[:, None, :] - pts[None, :, :], axis=2), axis=1)
        stepped = (S @ q)[nearest]
        largest[n] = (np.max(np.abs(np.diff(smooth))), np.max(np.abs(np.diff(stepped))))
    assert largest[451][0] / largest[901][0] == pytest.approx(2.0, rel=0.02)
    assert largest[451][1] == pytest.approx(largest[901][1], rel=1e-12)
    assert largest[901][1] > 0.2 > 20 * largest[901][0]


@pytest.mark.parametrize("kind", ["triangle", "quadrilateral"])
@pytest.mark.parametrize("n", [1, 3, 8])
def test_facet_subdivision_integrates_linear_fields_exactly(kind, n):
    """The sample points of the transfer's facet mean (TRANSFER_SUBDIVISIONS per side): their
    weights add up to the reference facet's area and they integrate every linear field exactly
    (the facet mean of a linear flux is its value at the facet's centroid), and the points are
    the midpoints of n² equal parts (no two coincide)."""
    facet = getattr(basix.CellType, kind)
    pts, w = subdivision_points(facet, n)
    area = 0.5 if kind == "triangle" else 1.0
    centroid = np.array([1 / 3, 1 / 3]) if kind == "triangle" else np.array([0.5, 0.5])
    assert len(w) == n * n and np.sum(w) == pytest.approx(area, rel=1e-14)
    np.testing.assert_allclose(w @ pts / area, centroid, rtol=1e-14)
    assert len(np.unique(np.round(pts, 12), axis=0)) == n * n


@pytest.mark.parametrize("evaluation", ["reference_facets", "continuous"])
def test_facet_sampler_is_built_once_per_inputs(evaluation):
    """The thermal facets' sampler is kept for its inputs: the same inputs (a diagnosis's next
    run) give the kept operator, equal to a fresh build; other sample points or another
    reconstruction build their own."""
    b = 12.934e-3
    pts, area, _, _ = _rows((0.5,), 4, b)
    rng = np.random.default_rng(5)
    local = pts[rng.integers(0, len(pts), (30, 4))] + rng.normal(0.0, 2e-5, (30, 4, 3))
    weight = np.full(30 * 4, 0.25)
    rec = FluxReconstruction((0.107e-3, 1.5e-3), evaluation)
    transfer._SAMPLERS.clear()
    first = transfer.facet_sampler(local, weight, pts, area, rec, (0.0, b))
    again = transfer.facet_sampler(local.copy(), weight.copy(), pts, area, rec, (0.0, b))
    assert again is first and len(transfer._SAMPLERS) == 1
    transfer._SAMPLERS.clear()
    fresh = transfer.facet_sampler(local, weight, pts, area, rec, (0.0, b))
    assert fresh is not first and (fresh != first).nnz == 0
    np.testing.assert_allclose(first @ np.ones(len(area)), 1.0, rtol=0, atol=1e-13)
    transfer.facet_sampler(local + 1e-6, weight, pts, area, rec, (0.0, b))
    other = FluxReconstruction((0.2e-3, 1.5e-3), evaluation)
    transfer.facet_sampler(local, weight, pts, area, other, (0.0, b))
    assert len(transfer._SAMPLERS) == 3
