"""Grid convergence index (gearfem.core.gci) against exact power laws."""

from __future__ import annotations

import math

import pytest

from gearfem.core.errors import ParameterError
from gearfem.core.gci import (
    branch_convergence,
    convergence,
    grid_convergence,
    least_squares_convergence,
    representative_size,
)


@pytest.mark.parametrize("order", [1.0, 2.0, 3.0])
def test_exact_power_law_with_unequal_ratios(order):
    """φ_h = 3 + 2 h^p on h = 0.1, 0.13, 0.2 (r21 ≠ r32): p, φ_ext exact; GCI = 1.25 |φ1 − φ|."""
    sizes = (0.2, 0.1, 0.13)  # any order
    values = [3.0 + 2.0 * h**order for h in sizes]
    c = grid_convergence(values, sizes, formal_order=3.0)
    assert c.observed_order == pytest.approx(order, rel=1e-9)
    assert c.extrapolated == pytest.approx(3.0, abs=1e-10)
    err = abs(c.values[0] - 3.0)
    assert c.gci == pytest.approx(1.25 * err, rel=1e-8) and c.asymptotic
    assert c.u_num == pytest.approx(c.gci / 1.15)


def test_order_above_the_formal_one_is_not_trusted():
    sizes = (0.1, 0.2, 0.4)
    values = [1.0 + h**4 for h in sizes]
    c = grid_convergence(values, sizes, formal_order=2.0)
    assert c.observed_order == pytest.approx(4.0) and not c.asymptotic
    assert c.order_used == 2.0 and c.gci > 1.25 * abs(values[0] - 1.0)


def test_oscillatory_convergence_is_flagged_and_bounded_by_the_spread():
    c = grid_convergence([1.0, 1.1, 0.95], [0.1, 0.2, 0.4])
    assert not c.asymptotic
    assert c.gci >= 3.0 * (1.1 - 0.95)


def test_converged_and_bad_input():
    c = grid_convergence([2.0, 2.0, 2.0], [0.1, 0.2, 0.4])
    assert c.gci == 0.0 and c.extrapolated == 2.0 and math.isnan(c.observed_order)
    with pytest.raises(ParameterError) as err:
        grid_convergence([1.0, 2.0], [0.1, 0.2])
    assert err.value.name == "refinement levels"
    with pytest.raises(ParameterError) as err:
        grid_convergence([1.0, 2.0, 3.0], [0.1, 0.1, 0.2])
    assert err.value.name == "mesh sizes"
    assert representative_size(1000, 1.0) == pytest.approx(0.1)


def test_differences_growing_under_refinement_are_not_convergence():
    """The built-in case's maximum surface temperature (C) on three thermal meshes of 15405, 36477
    and 106425 DOFs: the change grows from 3.5 K to 7.6 K as the mesh refines — the formula still
    returns an order, but the sequence is not converging in the asymptotic sense."""
    dofs = (15405, 36477, 106425)
    values = (250.29, 253.78, 261.35)
    c = grid_convergence(values, [representative_size(n) for n in dofs], formal_order=3.0)
    assert not c.asymptotic
    assert c.gci >= 3.0 * (261.35 - 253.78) / (c.sizes[1] / c.sizes[0]) ** c.order_used


@pytest.mark.parametrize("level", [0, 1, 2])
def test_uncertainty_of_every_level_on_an_exact_power_law(level):
    """The GCI of the medium and coarsest solutions is Fs |φ_level − φ| (Roache's coarse-grid
    GCI): a run made at the coarsest of three resolutions gets its own, larger, u_num."""
    sizes = (0.1, 0.15, 0.225)
    values = [3.0 + 2.0 * h**2 for h in sizes]
    c = grid_convergence(values, sizes, formal_order=3.0)
    exact_error = abs(values[level] - 3.0)
    assert c.gci_at(level) == pytest.approx(1.25 * exact_error, rel=1e-8)
    assert c.u_num_at(level) == pytest.approx(c.gci_at(level) / 1.15)
    assert c.gci_at(0) == c.gci
    with pytest.raises(ParameterError):
        c.gci_at(3)


@pytest.mark.parametrize("order", [0.8, 1.5, 2.6])
@pytest.mark.parametrize("sizes", [(0.5, 1 / 3, 0.2, 1 / 7), (0.1, 0.13, 0.2, 0.26, 0.4)])
def test_least_squares_on_an_exact_power_law(order, sizes):
    """Four or five solutions φ_h = 3 + 2 h^p (unequal ratios, e.g. the layers 2 / 3 / 5 / 7): the
    fit is exact (σ = 0), p and φ0 are recovered, and the uncertainty of every level is Fs
    |φ_i − φ| with Fs = 1.25, as Roache's GCI of that level."""
    values = [3.0 + 2.0 * h**order for h in sizes]
    c = least_squares_convergence(values, sizes, formal_order=3.0)
    assert c.observed_order == pytest.approx(order, rel=1e-6)
    assert c.extrapolated == pytest.approx(3.0, abs=1e-8)
    assert c.asymptotic and c.safety_factor == 1.25 and c.scatter == pytest.approx(0, abs=1e-8)
    for level, v in enumerate(c.values):
        assert c.gci_at(level) == pytest.approx(1.25 * abs(v - 3.0), rel=1e-6, abs=1e-8)
    assert c.gci == c.gci_at(0) and c.u_num == pytest.approx(c.gci / 1.15)
    with pytest.raises(ParameterError, match="refinement level"):
        c.gci_at(len(sizes))


def test_least_squares_with_scatter_brackets_the_error():
    """A power law of order 1.2 with a scatter of about a tenth of its successive differences:
    the fit recovers the order roughly, and the expanded uncertainty U of every level brackets its
    true error (exact value 10)."""
    sizes = (1 / 2, 1 / 3, 1 / 5, 1 / 7, 1 / 10)
    noise = (0.004, -0.006, 0.005, -0.003, 0.002)
    values = [10.0 + 0.5 * h**1.2 + e for h, e in zip(sizes, noise)]
    c = least_squares_convergence(values, sizes)
    assert c.asymptotic and 0.9 < c.observed_order < 1.5 and c.scatter > 0.0
    for level, v in enumerate(c.values):
        assert c.gci_at(level) >= abs(v - 10.0)  # U, the expanded uncertainty


def test_least_squares_outside_the_asymptotic_range():
    """A slow trend (order 0.3) is not trusted: the fit is repeated at the clipped order 0.5 with
    Fs = 3, which bounds the coarse level's true error; oscillating solutions are flagged too."""
    sizes = (1 / 2, 1 / 3, 1 / 5, 1 / 7)
    values = [5.0 + h**0.3 for h in sizes]
    c = least_squares_convergence(values, sizes)
    assert c.observed_order == pytest.approx(0.3, rel=1e-5) and not c.asymptotic
    assert c.order_used == 0.5 and c.safety_factor == 3.0
    assert c.gci_at(3) >= abs(values[0] - 5.0)
    osc = least_squares_convergence([1.0, 1.2, 0.9, 1.1], [0.1, 0.2, 0.3, 0.4])
    assert not osc.asymptotic and osc.safety_factor == 3.0


def test_convergence_takes_the_procedure_of_the_number_of_solutions():
    sizes3, values3 = (0.1, 0.15, 0.225), (3.02, 3.045, 3.101)
    assert convergence(values3, sizes3) == grid_convergence(values3, sizes3)
    four = convergence([*values3, 3.2], [*sizes3, 0.3])
    assert len(four.fitted) == 4
    with pytest.raises(ParameterError, match="refinement levels"):
        least_squares_convergence(values3, sizes3)
    with pytest.raises(ParameterError, match="mesh sizes"):
        least_squares_convergence([1.0, 2.0, 3.0, 4.0], [0.1, 0.2, 0.2, 0.4])
    flat = least_squares_convergence([2.0] * 4, [0.1, 0.2, 0.3, 0.4])
    assert flat.gci == 0.0 and flat.gci_at(3) == 0.0


def test_levels_on_different_branches_get_the_branch_gap():
    """Three solutions of a bistable model: on one branch the usual GCI; when the middle level
    landed on the other branch (a jump of 60 K), u_num is the gap between the branches, at every
    level, and the estimate says the branches differ."""
    h = (0.1, 0.15, 0.225)
    same = (100.0, 100.4, 101.3)
    usual = grid_convergence(same, h)
    on_one = branch_convergence(same, h, [0, 0, 0], gap=60.0)
    assert on_one == usual and not on_one.branches_differ
    assert branch_convergence(same, h, [None, None, None]) == usual
    jumped = (100.0, 160.4, 101.3)
    c = branch_convergence(jumped, h, [0, 1, 0], gap=61.0)
    assert c.branches_differ and not c.asymptotic and math.isnan(c.observed_order)
    assert c.u_num == pytest.approx(61.0)
    assert c.u_num_at(0) == c.u_num_at(2) == pytest.approx(61.0)
    # without a measured gap the spread of the values, which holds the jump
    assert branch_convergence(jumped, h, [0, 1, 0]).u_num == pytest.approx(60.4)
    with pytest.raises(ParameterError, match="branches"):
        branch_convergence(jumped, h, [0, 1])
