"""Studies (``gearfem study``): validation of the study file, the operating-point grid, running the
cases side by side or on all ranks, resuming (a finished case is not recomputed, a changed one or
one finished by other code is), and the collected table.

The cases use prescribed flank heat on a small mesh (no structural cycle), so a study of two
operating points costs seconds; the cycle cache is covered by tests/test_cycle.py.
"""

from __future__ import annotations

import csv
import json
import shutil

import pytest
from camera_options import QUICK_CAMERA
from mpi4py import MPI

from gearfem.core.errors import ParameterError
from gearfem.study import StudyOptions, load_study, parse_points, run_study, study_from_dict

SMALL_MESH = {
    "teeth_in_model": 2,
    "refined_teeth": 2,
    "layers": 1,
    "size_flank_mm": 0.8,
    "size_tip_mm": 0.8,
    "size_root_mm": 0.8,
    "size_tooth_mm": 2.0,
    "size_body_mm": 6.0,
}


def _study(points=((1000.0, 8.0), (2000.0, 4.0)), parallel="auto", duration=120.0, heat=2.0):
    return {
        "name": "two points",
        "mesh": dict(SMALL_MESH),
        "sources": {"mode": "prescribed", "flank_heat_per_gear_W": heat},
        "thermal": {"duration_s": duration, "degree": 1, "dt_initial_s": 1.0},
        "instruments": {"camera": dict(QUICK_CAMERA)},
        "study": {"points": [list(p) for p in points], "parallel": parallel},
    }


@pytest.mark.parametrize(
    "change, name",
    [
        ({"study": None}, "study"),
        ({"study": {"speeds_rpm": [1000.0]}}, r"study\.speeds_rpm"),
        ({"study": {"speeds_rpm": [-5.0], "torques_Nm": [8.0]}}, r"study\.speeds_rpm\[0\]"),
        ({"study": {"speeds_rpm": [1000.0], "torques_Nm": [0.0]}}, r"study\.torques_Nm\[0\]"),
        ({"study": {"points": [[1000.0]]}}, r"study\.points\[0\]"),
        ({"study": {"points": [[1000.0, 8.0]], "parallel": "threads"}}, r"study\.parallel"),
        ({"study": {"points": [[1000.0, 8.0]], "speed": 3}}, r"study\.speed"),
        ({"study": {}}, "study"),
        ({"thermal": {"duration_s": -1.0}}, r"thermal\.duration_s"),
    ],
)
def test_bad_study_files_name_the_parameter(change, name):
    data = _study()
    for k, v in change.items():
        if v is None:
            data.pop(k)
        else:
            data[k] = v
    with pytest.raises(ParameterError, match=name):
        study_from_dict(data)


def test_grid_and_points_give_each_operating_point_once(tmp_path):
    opts = StudyOptions(
        speeds_rpm=(1000.0, 2000.0), torques_Nm=(4.0, 8.0), points=((1000.0, 8.0), (500.0, 2.0))
    )
    assert opts.operating_points() == [
        (1000.0, 4.0),
        (2000.0, 4.0),
        (1000.0, 8.0),
        (2000.0, 8.0),
        (500.0, 2.0),
    ]
    f = tmp_path / "s.toml"
    f.write_text(
        "[study]\nspeeds_rpm = [1000.0]\ntorques_Nm = [8.0, 4.0]\n[operating]\nspeed_rpm = 1.0\n"
    )
    study = load_study(f)
    # the operating point of every case is the study's (in the file's order), the rest the case
    # file's
    assert [(c.operating.speed_rpm, c.operating.torque_Nm) for _, c in study.cases()] == [
        (1000.0, 8.0),
        (1000.0, 4.0),
    ]
    assert study.torques() == [4.0, 8.0]
    with pytest.raises(ParameterError, match="study file"):
        load_study(tmp_path / "missing.toml")


def test_command_line_points_parse_or_name_the_option():
    assert parse_points("1000/8, 2000/4.5", "--points") == ((1000.0, 8.0), (2000.0, 4.5))
    for bad in ("1000/8,2000", "1000-8", "1000/8/2", "", "1000/0", "-5/8", "nan/8"):
        with pytest.raises(ParameterError, match=r"--points = .*allowed: 'rpm/Nm,rpm/Nm"):
            parse_points(bad, "--points")


@pytest.mark.mpi
@pytest.mark.slow
@pytest.mark.parametrize("parallel", ["cases", "mpi"])
def test_study_runs_collects_and_resumes(parallel, tmp_out, comm):
    if parallel == "mpi" and comm.size == 1:
        pytest.skip('on 1 rank "mpi" (every task on all ranks) is "cases" (each on one rank)')
    out = tmp_out / f"study_{parallel}"
    if comm.rank == 0 and out.exists():
        shutil.rmtree(out)
    comm.barrier()
    study = study_from_dict(_study(parallel=parallel))
    res = run_study(study, out, comm)
    labels = [lab for lab, _ in study.cases()]
    assert res.complete and sorted(res.ran) == sorted(labels)
    rows = {r.label: r for r in res.results}
    for lab, c in study.cases():
        r = rows[lab]
        assert r.status == "done"
        # the prescribed heat reaches the model: per gear, the flank heat given in the file
        assert r.friction_W == pytest.approx(2.0, rel=1e-6)
        assert r.max_surface_end_C > c.thermal.ambient_C
        assert r.power_W == pytest.approx(
            c.operating.torque_Nm * c.operating.speed_rpm * 3.141592653589793 / 30
        )
    assert (out / "study.json").exists() and (out / "temperature_histories.png").exists()
    with (out / "results.csv").open() as fh:
        assert [r["label"] for r in csv.DictReader(fh)] == labels
    # faster at 2000 rpm: more convection, same heat -> cooler
    assert rows[labels[1]].max_surface_end_C < rows[labels[0]].max_surface_end_C
    # every rank has read the files before the resume below rewrites study.json (rank 0 removes
    # it first: without this, a slower rank can look for it in between)
    comm.barrier()

    # resume: nothing to do
    again = run_study(study, out, comm)
    assert again.ran == () and again.complete
    # a case whose output was lost is recomputed, and only that one
    if comm.rank == 0:
        (out / "cases" / labels[1] / "summary.json").unlink()
    comm.barrier()
    third = run_study(study, out, comm)
    assert third.ran == (labels[1],)
    # a case finished by other code (its summary's provenance) is recomputed, and only that one
    if comm.rank == 0:
        path = out / "cases" / labels[0] / "summary.json"
        summ = json.loads(path.read_text())
        summ["provenance"]["code"] = {"gearfem.pipeline": "0" * 12}
        path.write_text(json.dumps(summ))
    comm.barrier()
    assert run_study(study, out, comm).ran == (labels[0],)
    # a changed case (more heat) is recomputed in full, and its result changes accordingly
    hotter = study_from_dict(_study(parallel=parallel, heat=4.0))
    fourth = run_study(hotter, out, comm)
    assert sorted(fourth.ran) == sorted(labels)
    new = {r.label: r for r in fourth.results}
    for lab in labels:
        assert new[lab].friction_W == pytest.approx(4.0, rel=1e-6)
        assert new[lab].max_surface_end_C > rows[lab].max_surface_end_C
    summary = json.loads((out / "study.json").read_text())
    assert summary["complete"] and summary["mpi_size"] == comm.size


@pytest.mark.mpi
@pytest.mark.slow
def test_single_task_and_collect(tmp_out, comm):
    """Cluster route: ``--index`` runs one task and writes no study.json; ``--collect`` gathers."""
    out = tmp_out / "study_index"
    if comm.rank == 0 and out.exists():
        shutil.rmtree(out)
    comm.barrier()
    study = study_from_dict(_study())
    with pytest.raises(ParameterError, match="--index"):
        run_study(study, out, comm, index=2)
    assert run_study(study, out, comm, index=1).ran == (study.cases()[1][0],)
    assert not (out / "study.json").exists()
    partial = run_study(study, out, comm, collect_only=True)
    assert not partial.complete and partial.missing == (study.cases()[0][0],)
    assert run_study(study, out, comm, index=0).ran == (study.cases()[0][0],)
    assert run_study(study, out, comm, collect_only=True).complete
    comm.barrier()
    assert MPI.COMM_WORLD.allreduce(1) == comm.size
