"""Results are typed, frozen dataclasses with an exact JSON round trip (gearfem.core.results):
RunSummary (summary.json), StudyRow/StudyResult (study.json), Diagnosis and DiagnosisReport
(diagnosis.json), a cycle's PeriodicityCheck (cycle.json, cycle_summary.json). Callers read
attributes; the files keep the field names as keys."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np

from gearfem.cli import with_u_num
from gearfem.cycle.cache import _periodicity
from gearfem.cycle.result import PeriodicityCheck, SectorEnergy
from gearfem.diagnose.candidates import LIBRARY
from gearfem.diagnose.data import Dataset, Measurement
from gearfem.diagnose.report import DiagnosisReport
from gearfem.diagnose.select import Diagnosis, Verdict, diagnose
from gearfem.diagnose.vv20 import Comparison, ComparisonTable
from gearfem.pipeline import CycleAtSpeed, CycleCache, Headline, RunSummary
from gearfem.study import StudyResult, StudyRow


def _through_json(record):
    """to_json, through a JSON text as a file would hold it, and back."""
    return type(record).from_json(json.loads(json.dumps(record.to_json())))


def test_run_summary_round_trip_and_attribute_access(tmp_path):
    cyc = CycleAtSpeed(
        effective_contact_ratio=1.71,
        theoretical_contact_ratio=1.45,
        max_contact_pressure_MPa=93.2,
        pitch_point_pressure_MPa=61.0,
        max_root_stress_MPa={"pinion": 30.1, "wheel": 29.7},
        transmission_error_um={"mean": 120.0, "peak_to_peak": 9.0},
        friction_power_W=np.float64(14.2),  # numpy scalars are written as numbers
        pinion_torque_mean_Nm=8.3,
        positions=12,
        newton_iterations=190,
        cycle_wall_time_s=412.0,
        info={"dofs": 92850, "pinion_flank_heat_raw_over_total": 1.01},
        cache=CycleCache("/tmp/cycles/abc", True),
    )
    head = Headline(900.0, 250.1, 93.1, None, {"900": 250.1}, 14.2, 1.71, 110.0, 80.0, 60.0, 150.0)
    s = RunSummary(
        "thesis", 1000.0, 8.0, {"time_s": 900.0}, {"power_W": 837.8}, {"total_s": 1.0}, 2, cyc, head
    )
    back = _through_json(s)
    assert back == s
    assert back.cycle.cache.from_cache and back.headline.steady_max_surface_temperature_C is None
    # the file holds the field names as keys, nested records as objects
    path = tmp_path / "summary.json"
    path.write_text(json.dumps(s.to_json()))
    data = json.loads(path.read_text())
    assert data["headline"]["max_surface_temperature_C"] == 250.1
    assert data["cycle"]["cache"] == {"directory": "/tmp/cycles/abc", "from_cache": True}
    assert RunSummary.read(path) == s
    # a run without a cycle (prescribed sources)
    assert _through_json(dataclasses.replace(s, cycle=None)).cycle is None


def test_the_run_prints_each_headline_number_with_its_u_num():
    """gearfem run's console lines quote u_num beside a number that has one, and nothing
    beside one that has none."""
    head = Headline(
        900.0, 284.884, 98.19, None, {}, 63.41, 1.7217, u_num={"friction_power_W": 0.336}
    )
    assert with_u_num(head, "max_surface_temperature_C", "C") == "284.9 C"
    assert with_u_num(head, "friction_power_W", "W", 2) == "63.41 ± 0.34 W"
    assert with_u_num(head, "effective_contact_ratio", "", 3) == "1.722"
    studied = dataclasses.replace(head, u_num={"max_surface_temperature_C": 16.29})
    assert with_u_num(studied, "max_surface_temperature_C", "C") == "284.9 ± 16.3 C"


def test_study_result_round_trip():
    rows = (
        StudyRow("1000rpm_8Nm", 1000.0, 8.0, "done", friction_W=14.2, max_surface_end_C=250.0),
        StudyRow("2000rpm_8Nm", 2000.0, 8.0, "missing"),
    )
    r = StudyResult(
        "demo",
        {"speeds_rpm": [1000, 2000]},
        rows,
        ("2000rpm_8Nm",),
        False,
        ran=("1000rpm_8Nm",),
        wall_time_s=3.0,
        timing={"cases_s": 2.0},
        mpi_size=2,
    )
    back = _through_json(r)
    assert back == r and isinstance(back.results[0], StudyRow) and back.ran == ("1000rpm_8Nm",)


def _synthetic():
    """Data with a planted friction_scale effect and a linear surrogate of the library: the
    diagnosis is fast and exact enough to exercise every field of the result."""
    by = {c.name: c.parameter for c in LIBRARY}
    slope = {n: 10.0 / (p.hi - p.lo) for n, p in by.items()}
    ms = tuple(
        Measurement(s, 8.0, t, q, 0.0 + 1.0, 2.0, 21.0)
        for s in (1000.0, 1500.0, 2000.0)
        for t in (300.0, 900.0, None)
        for q in ("max_surface", "mean_bulk")
    )

    def predict(d: Dataset, m: dict) -> np.ndarray:
        out = []
        for i, x in enumerate(d.measurements):
            v = 40.0 + 0.02 * x.speed_rpm + (5.0 if x.quantity == "max_surface" else 0.0) + 0.01 * i
            for n, val in m.items():
                v += slope[n] * (val - by[n].null) * (1.0 + 0.3 * (n == "friction_scale") * i)
            out.append(v)
        return np.array(out)

    truth = {
        "friction_scale": by["friction_scale"].null
        + 0.3 * (by["friction_scale"].hi - by["friction_scale"].null)
    }
    values = predict(Dataset(ms, "synthetic"), truth)
    data = Dataset(
        tuple(dataclasses.replace(m, value=float(v)) for m, v in zip(ms, values)), "synthetic"
    )
    return predict, data


def test_diagnosis_round_trip_and_attributes():
    predict, data = _synthetic()
    d = diagnose(predict, data, max_size=1)
    assert isinstance(d, Diagnosis) and isinstance(d.verdict, Verdict)
    assert d.chosen_fit.candidates == d.chosen and d.baseline_fit.candidates == ()
    assert d.models[0].delta == 0.0 and all(m.delta >= 0.0 for m in d.models)
    back = _through_json(d)
    assert back.verdict == d.verdict and back.gain == d.gain and back.chosen == d.chosen
    for a, b in zip(back.models, d.models):
        assert a.candidates == b.candidates and a.params == b.params
        assert a.chi2 == b.chi2 or (math.isnan(a.chi2) and math.isnan(b.chi2))
    comparison = Comparison(
        S=np.array([112.0, 0.05]),
        D=np.array([110.0, 0.04]),
        u_num=np.array([0.5, 0.0]),
        u_input=np.array([2.0, 0.001]),
        u_D=np.array([3.0, 0.01]),
    )
    table = ComparisonTable(
        comparison.rows(["camera", "torque loss"], ["C", "N m"]),
        comparison.k,
        "studies",
        {"k": (0.5, 0.0)},
    )
    report = DiagnosisReport(d, {"source": "synthetic"}, "coarse", table, {}, {})
    flat = json.loads(json.dumps(report.to_json()))
    assert flat["verdict"]["kind"] == d.verdict.kind and flat["case"] == "coarse"
    again = DiagnosisReport.from_json(flat)
    assert again.case == "coarse" and again.diagnosis.verdict == d.verdict
    assert again.vv20 == table and again.vv20.rows[1].unit == "N m"


def _periodicity_check() -> PeriodicityCheck:
    return PeriodicityCheck(
        te_first_m=-1.25e-5,
        te_shifted_m=-1.2501e-5,
        p_max_first_Pa=3.1e7,
        p_max_shifted_Pa=3.09e7,
        tooth_load_first_N={1: 0.0, 2: 373.25, 3: 0.0},
        tooth_load_shifted_N={1: 372.5, 2: 0.0, 3: 0.0},
        sector_energy_J={
            "pinion": (SectorEnergy(1, 0.0125, 0.0124), SectorEnergy(2, 1e-6, 2e-6)),
            "wheel": (SectorEnergy(2, 0.011, 0.0112),),
        },
    )


def test_periodicity_check_round_trip_keeps_the_tooth_numbers():
    """The tooth numbers come back as ints (JSON holds them as strings) and the sector energies as
    records: a cycle read from the cache equals the one computed."""
    check = _periodicity_check()
    flat = json.loads(json.dumps(check.to_json()))
    assert flat["tooth_load_first_N"] == {"1": 0.0, "2": 373.25, "3": 0.0}
    assert flat["sector_energy_J"]["wheel"] == [
        {"sector": 2, "shifted_J": 0.011, "mapped_J": 0.0112}
    ]
    back = PeriodicityCheck.from_json(flat)
    assert back == check
    assert list(back.tooth_load_shifted_N) == [1, 2, 3]
    assert back.sector_energy_J["pinion"][1].mapped_J == 2e-6
    # a cycle stored before the record: its sector energies under "<body>_sector_energy_J"
    old = {k: v for k, v in flat.items() if k != "sector_energy_J"}
    for body, sectors in check.sector_energy_J.items():
        old[f"{body}_sector_energy_J"] = [
            {"sector": e.sector, "shifted": e.shifted_J, "mapped": e.mapped_J} for e in sectors
        ]
    assert _periodicity(old) == check
    assert _periodicity(None) is None
