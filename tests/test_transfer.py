"""The conservative reconstruction of the cycle's facet flux (gearfem.coupling.transfer), on a
synthetic flank: a regular grid of facets in the flank's plane (x, y) and along the face width z."""

from __future__ import annotations

import basix
import numpy as np
import pytest

from gearfem.core.errors import ParameterError
from gearfem.coupling.options import SourceOptions
from gearfem.coupling.transfer import (
    SMOOTHING_CUTOFF,
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
    pts, area, s, z = _flank()
    S = smoothing_operator(pts, area, (0.1e-3, 1.0e-3))
    rng = np.random.default_rng(1)
    q = rng.uniform(0.0, 1e5, len(area))
    # conservative: Σ A q̃ = Σ A q, to round-off, for any flux (columns: A_i S_ij sum to A_j)
    assert np.sum(area * (S @ q)) == pytest.approx(np.sum(area * q), rel=1e-13)
    np.testing.assert_allclose(area @ S, area, rtol=1e-13)
    # a uniform flux stays uniform away from the edges (within the area jitter's weight noise)
    inner = (s > 1e-3) & (s < s.max() - 1e-3) & (z > 3e-3) & (z < z.max() - 3e-3)
    u = S @ np.ones(len(area))
    assert np.max(np.abs(u[inner] - 1.0)) < 0.15
    # no reconstruction: the identity
    S0 = smoothing_operator(pts, area, None)
    np.testing.assert_array_equal((S0 @ q), q)


def test_reconstruction_spreads_a_facet_with_the_stated_standard_deviations():
    """One facet's heat spread on a fine regular grid: its second moments in the flank's plane and
    along z are the kernel's σ² (to the grid's and the cut-off's accuracy)."""
    h = 0.05e-3
    s, z = np.meshgrid(np.arange(121) * h, np.arange(121) * 10 * h, indexing="ij")
    s, z = s.ravel(), z.ravel()
    pts = np.column_stack([s / np.sqrt(2), s / np.sqrt(2), z])
    area = np.full(len(s), h * 10 * h)
    sig = (0.2e-3, 2.0e-3)
    S = smoothing_operator(pts, area, sig)
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


def test_bad_smoothing_options_are_refused_by_name():
    with pytest.raises(ParameterError, match="flux_smoothing_profile_mm"):
        SourceOptions(flux_smoothing_profile_mm=0.0, flux_smoothing_axial_mm=1.0)
    with pytest.raises(ParameterError, match="flux_smoothing_axial_mm"):
        SourceOptions(flux_smoothing_axial_mm=-1.0)
    assert (
        SourceOptions(flux_smoothing_profile_mm=0.0, flux_smoothing_axial_mm=0.0).flux_smoothing_m
        is None
    )


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
