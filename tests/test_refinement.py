"""``gearfem converge``: the thermal refinement study of a case (gearfem.refinement)."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import pytest
from camera_options import QUICK_CAMERA

from gearfem.config import load_case
from gearfem.core.errors import ParameterError
from gearfem.core.gci import branch_convergence, grid_convergence, least_squares_convergence
from gearfem.geometry.options import MeshOptions
from gearfem.refinement import (
    RefinementLevel,
    RefinementStudy,
    branch_labels,
    layer_similarity,
    level_branch,
    markdown,
    refined_mesh,
    refinement_study,
)

ROOT = Path(__file__).resolve().parent.parent


def _small_case():
    c = load_case(ROOT / "tests" / "cases" / "coarse.toml")
    mesh = MeshOptions(
        teeth_in_model=2,
        refined_teeth=2,
        layers=1,
        size_flank_mm=0.8,
        size_tip_mm=0.8,
        size_root_mm=0.8,
        size_tooth_mm=1.6,
        size_body_mm=4.0,
    )
    return dataclasses.replace(
        c,
        thermal_mesh=mesh,
        sources=dataclasses.replace(c.sources, mode="prescribed", flank_heat_per_gear_W=40.0),
        thermal=dataclasses.replace(c.thermal, duration_s=120.0, degree=1, output_times_s=()),
        instruments=dataclasses.replace(
            c.instruments, camera=dataclasses.replace(c.instruments.camera, **QUICK_CAMERA)
        ),
    )


def test_refined_mesh_scales_sizes_and_layers():
    m = refined_mesh(MeshOptions(layers=2, size_flank_mm=0.3, size_growth=0.6), 1.5)
    assert m.size_flank_mm == pytest.approx(0.2) and m.layers == 3
    assert m.size_growth == pytest.approx(0.4)  # geometrically similar refinement
    # coarsening (the level below a case in the middle of a study) and refining back: the same
    # options, exactly (the same mesh and cache key)
    c = refined_mesh(MeshOptions(layers=4, size_flank_mm=0.14), 1.0 / 1.5)
    assert c.size_flank_mm == 0.21 and c.layers == 3
    assert refined_mesh(refined_mesh(m, 1.0 / 1.5), 1.5) == m
    with pytest.raises(ParameterError, match="refinement factor"):
        refined_mesh(MeshOptions(), 0.0)
    # the entry size refines with the contact zone when set, and stays off when not
    assert refined_mesh(MeshOptions(size_entry_mm=0.06), 1.5).size_entry_mm == pytest.approx(0.04)
    assert refined_mesh(MeshOptions(), 1.5).size_entry_mm is None


def _study_with_layers(kind: str, layers: tuple[int, ...]) -> RefinementStudy:
    levels = tuple(
        RefinementLevel(i, 0.02 / 1.5**i, 1000 * (i + 1), {"layers": n})
        for i, n in enumerate(layers)
    )
    return RefinementStudy("case", kind, 1.5, 1, "key", levels, ())


def test_a_thermal_study_says_when_its_layers_are_not_similar():
    """The layers refine with the element sizes but are rounded up to whole layers: a case at 4
    thermal layers gives 3 / 4 / 6 at factor 1.5 (refined by 1.33, then 1.5), which the
    representative size from the DOFs does not show. The table's caption says so; 4 / 6 / 9 (by
    1.5 exactly) and the structural layers' own study (h = 1 / layers) say nothing."""
    rounded = _study_with_layers("thermal_mesh", (3, 4, 6))
    sentence = layer_similarity(rounded)
    assert "3 / 4 / 6" in sentence and "1.33, 1.5" in sentence and "not by 1.5" in sentence
    assert sentence in markdown(rounded).splitlines()[0]
    assert layer_similarity(_study_with_layers("thermal_mesh", (4, 6, 9))) == ""
    assert layer_similarity(_study_with_layers("structural_layers", (3, 4, 6))) == ""
    # the levels the tool makes from a case at 4 layers are the rounded ones
    coarse = refined_mesh(MeshOptions(layers=4), 1.0 / 1.5)
    assert (coarse.layers, refined_mesh(MeshOptions(layers=4), 1.5).layers) == (3, 6)


def test_levels_that_round_to_the_same_discretisation_are_refused(tmp_path, comm):
    """Counts are rounded: 2 layers coarsened by 1.5 round back up to 2, and a study whose levels
    are not three different discretisations has no order to observe. Refused before anything
    runs or is written."""
    case = load_case(None)
    case = dataclasses.replace(
        case, mesh=dataclasses.replace(case.mesh, layers=2, layer_grading=None)
    )
    out = tmp_path / "degenerate"
    with pytest.raises(ParameterError, match="refinement factor.*structural_layers"):
        refinement_study(case, out, comm, "structural_layers", 1.5, case_level="middle")
    assert not out.exists()


@pytest.mark.mpi
@pytest.mark.slow
@pytest.mark.parametrize("case_level", ["coarsest", "middle", "finest"])
def test_thermal_refinement_study(tmp_out, comm, case_level):
    out = tmp_out / f"converge_{case_level}"
    case = _small_case()
    study = refinement_study(case, out, comm, "thermal_mesh", factor=1.5, case_level=case_level)
    assert study.dofs[0] < study.dofs[1] < study.dofs[2]
    # the case's own resolution is the level named, and its u_num is that level's
    at = {"coarsest": 0, "middle": 1, "finest": 2}[case_level]
    assert study.case_level == at
    assert study.levels[at].setting == dataclasses.asdict(case.thermal_mesh_options)
    for r in study.rows:
        conv = grid_convergence(list(r.values), list(r.sizes), formal_order=2.0)
        assert r.u_num_case == pytest.approx(conv.u_num_at(2 - at), rel=1e-12, abs=1e-12)
    assert {r.quantity for r in study.rows} >= {"max_surface", "mean_bulk", "flank_max"}
    for r in study.rows:
        assert math.isfinite(r.gci) and r.gci >= 0.0 and r.u_num == pytest.approx(r.gci / 1.15)
        if r.asymptotic:  # the fine value lies within its GCI of the extrapolation
            assert abs(r.values[0] - r.extrapolated) <= r.gci * (1 + 1e-9)
    if case_level == "coarsest":  # (coarsened, this test mesh has a single layer)
        assert study.row("mean_bulk").u_num < 2.0  # the bulk is smooth: well resolved
    comm.barrier()
    data = json.loads((out / "refinement.json").read_text())
    assert RefinementStudy.from_json(data) == study
    for name in ("refinement.csv", "refinement.md", "refinement.png"):
        assert (out / name).stat().st_size > 0


@pytest.mark.mpi
@pytest.mark.slow
def test_a_four_level_study_fits_all_levels(tmp_out, comm):
    """``--levels 4``: four thermal meshes, each row's u_num of the case from the least-squares
    fit through all four (gearfem.core.gci.least_squares_convergence), the tables with a column
    per level; a fifth of the allowed range is refused before anything runs."""
    out = tmp_out / "converge_four"
    case = _small_case()
    study = refinement_study(case, out, comm, "thermal_mesh", 1.5, "coarsest", levels=4)
    assert len(study.levels) == 4 and all(len(r.values) == 4 for r in study.rows)
    assert list(study.dofs) == sorted(study.dofs) and len(set(study.dofs)) == 4
    assert study.case_value_index == 3 and study.case_level_name == "coarsest"
    for r in study.rows:
        conv = least_squares_convergence(list(r.values), list(r.sizes), formal_order=2.0)
        assert r.u_num_case == pytest.approx(conv.u_num_at(3), rel=1e-9, abs=1e-12)
        assert r.observed_order == pytest.approx(conv.observed_order, rel=1e-9, nan_ok=True)
    table = markdown(study).splitlines()
    assert "| fine | level 2 | level 1 | coarse (case) |" in table[2]
    assert all(row.count("|") == table[2].count("|") for row in table[2:-2])
    header = (out / "refinement.csv").read_text().splitlines()[0]
    assert header.startswith("quantity,unit,fine,level_2,level_1,coarse,order")
    with pytest.raises(ParameterError, match="refinement levels"):
        refinement_study(case, tmp_out / "converge_six", comm, "thermal_mesh", levels=6)


def _thermal_with_branches(states, picked):
    """A thermal summary's friction part as gearfem.pipeline.friction_branches writes it."""
    return {
        "friction": {
            "branches": [
                {
                    "start": name,
                    "converged": True,
                    "temperatures_C": {"max_surface": t, "mean_bulk": t / 3.0},
                    "friction_W": q,
                    "stable": True,
                    "same_as": None,
                }
                for name, (q, t) in states.items()
            ],
            "transient_branch": picked,
        }
    }


def test_levels_are_labelled_by_the_steady_state_they_reached():
    """Three levels of a bistable gear: the coarse one found both branches (cool 2 W / 60 C, hot
    6.5 W / 240 C) and reached the cool one, the medium one found only the hot one, the fine one
    reached the cool one: labels 0, 1, 0 by friction heat, and the gap of each quantity is the
    distance between the branches where both were found; a law with one steady state gives no
    labels."""
    coarse = level_branch(
        _thermal_with_branches({"cold": (2.0, 60.0), "hot": (6.5, 240.0)}, "cold")
    )
    medium = level_branch(_thermal_with_branches({"transient": (6.2, 236.0)}, "transient"))
    fine = level_branch(_thermal_with_branches({"transient": (2.1, 61.0)}, "transient"))
    labels, gaps = branch_labels([coarse, medium, fine])
    assert labels == [0, 1, 0]
    assert gaps == {"max_surface": pytest.approx(180.0), "mean_bulk": pytest.approx(60.0)}
    # on one branch the levels share a label (heats within BRANCH_HEAT_RATIO)
    assert branch_labels([coarse, fine, fine])[0] == [0, 0, 0]
    assert level_branch({"friction": {"branch_search": "not needed"}}) is None
    assert branch_labels([None, None, None]) == ([None, None, None], {})
    # a study whose levels differ by branch: the table says so and u_num is the gap
    values, sizes = (61.0, 236.0, 60.0), (0.1, 0.15, 0.225)  # fine to coarse
    conv = branch_convergence(values, sizes, labels[::-1], gaps["max_surface"])
    assert conv.branches_differ and conv.u_num == pytest.approx(180.0)
