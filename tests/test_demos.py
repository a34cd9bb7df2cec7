"""The demos run from their command line and write complete, mutually consistent outputs."""

from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scripts import load_script

from gearfem.contact.verification import peak_pressure_bound
from gearfem.core.material_library import effusivity_partition

ROOT = Path(__file__).resolve().parent.parent


def _run_demo(name: str, args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = dict(
        os.environ,
        PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
        MPLBACKEND="Agg",
    )
    return subprocess.run(
        [sys.executable, str(ROOT / "demos" / name), *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )


@pytest.mark.slow
def test_hertz_contact_demo(tmp_path):
    """Serial run on a coarse mesh (h = 0.014 m ≈ a/2.2): files complete, CSV and summary agree
    with each other and with Hertz's formulas, p0 within the discretisation's bound (h/a)²/12
    (1.7 %, :func:`~gearfem.contact.verification.peak_pressure_bound`) and a within 3 %."""
    out = tmp_path / "hertz"
    proc = _run_demo("hertz_contact.py", ["--contact-size", "0.014", "--out", str(out)], tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert str(out / "summary.json") in proc.stdout  # says where the files went
    names = sorted(p.name for p in out.iterdir())
    assert names == ["hertz_contact.bp", "hertz_pressure.csv", "hertz_pressure.png", "summary.json"]
    assert (out / "hertz_pressure.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (out / "hertz_contact.bp" / "md.idx").is_file()

    s = json.loads((out / "summary.json").read_text())
    assert s["ranks"] == 1 and s["solver"]["uzawa_iterations"] >= 1
    # the augmented Lagrangian meets its tolerance where its multipliers live (facet Gauss points);
    # the contact integration points in between penetrate slightly more, still a fraction of h
    assert 0.0 < s["solver"]["constraint_penetration_m"] <= s["solver"]["penetration_tolerance_m"]
    assert 0.0 < s["solver"]["max_penetration_m"] < 0.05 * 0.014
    assert s["solver"]["penetration_tolerance_m"] < 0.01 * 0.014  # 1 % of the smallest facet size
    # Hertz (Johnson §4.2) for equal cylinders R = 1 m, E = 1 Pa, nu = 0.3, recomputed here
    P = s["force_per_length_N_m"]
    E_star = 1.0 / (2.0 * (1.0 - 0.3**2))
    a = math.sqrt(4.0 * P * 0.5 / (math.pi * E_star))
    assert s["hertz"]["a_m"] == pytest.approx(a, rel=1e-12)
    assert s["hertz"]["p0_Pa"] == pytest.approx(2.0 * P / (math.pi * a), rel=1e-12)
    assert abs(s["errors"]["p0"]) < peak_pressure_bound(0.014, a)
    assert abs(s["errors"]["a_moments"]) < 0.03

    with open(out / "hertz_pressure.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    col = lambda k: np.array([float(r[k]) for r in rows])
    k, w, ty, p = col("pass"), col("weight_m2"), col("traction_y_Pa"), col("pressure_Pa")
    # force on the lower body: its slave traction in pass 0 plus the reaction of pass 1's slave
    force = np.sum(w[k == 0] * ty[k == 0]) - np.sum(w[k == 1] * ty[k == 1])
    assert -force / s["case"]["thickness_m"] == pytest.approx(P, rel=1e-8)
    assert p.max() == pytest.approx(s["fe"]["p0_Pa"], rel=1e-9)
    xa = col("x_ref_m") / s["hertz"]["a_m"]
    expected = s["hertz"]["p0_Pa"] * np.sqrt(np.clip(1.0 - xa**2, 0.0, None))
    np.testing.assert_allclose(
        col("p_hertz_Pa"), expected, rtol=1e-8, atol=1e-12 * s["hertz"]["p0_Pa"]
    )


@pytest.mark.slow
def test_thermal_gear_demo(tmp_path):
    """Serial run: files complete, heat balance closed, the gear heats above ambient."""
    out = tmp_path / "thermal"
    proc = _run_demo("thermal_gear.py", ["--duration-s", "300", "--out", str(out)], tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    names = sorted(p.name for p in out.iterdir())
    assert names == [
        "temperature.bp",
        "thermal_history.csv",
        "thermal_history.png",
        "thermal_summary.json",
    ]
    s = json.loads((out / "thermal_summary.json").read_text())
    assert s["time_s"] == pytest.approx(300.0)
    assert s["max_relative_imbalance"] < 1e-9
    assert s["final_temperatures_C"]["max_surface"] > s["final_temperatures_C"]["mean_bulk"] > 23.0


@pytest.mark.slow
def test_steel_pom_demo(tmp_path):
    """Serial run of the steel/POM demo (its case at fewer positions): the two gears' friction heat
    adds up to the cycle's friction power (to the solver's tolerance) under both splits: by
    effusivity (Blok, 0.943 into the steel) and by contact temperature (the steel's share lower,
    the gears' contact temperatures within the tolerance); the steel makes no hysteresis heat,
    the POM some; VDI 2736 rates the POM wheel with the plastic/steel k_theta and not the steel;
    the table is printed."""
    out = tmp_path / "steel_pom"
    # the demo's case at 3 positions per pitch (it has 8): the balances and splits checked here
    # hold position by position
    text = (ROOT / "demos" / "steel_pom.toml").read_text()
    assert "\npositions_per_pitch = 8\n" in text
    case = tmp_path / "steel_pom.toml"
    case.write_text(text.replace("\npositions_per_pitch = 8\n", "\npositions_per_pitch = 3\n"))
    proc = _run_demo("steel_pom.py", ["--case", str(case), "--out", str(out)], tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "| effusivities | pinion | steel | 0.943 |" in proc.stdout
    effusivity = effusivity_partition("steel", "POM")
    for run, split in ((out, "contact temperatures"), (out / "effusivity_split", "effusivities")):
        s = json.loads((run / "summary.json").read_text())
        assert s["thermal"]["body"] == "wheel" and s["thermal_other"]["body"] == "pinion"
        heat = {
            t["body"]: {k: v / t["model_fraction"] for k, v in t["final_balance_W"].items()}
            for t in (s["thermal"], s["thermal_other"])
        }
        total = heat["pinion"]["friction_W"] + heat["wheel"]["friction_W"]
        assert total == pytest.approx(s["cycle"]["friction_power_W"], rel=1e-6), split
        share = heat["pinion"]["friction_W"] / total
        assert heat["pinion"]["hysteresis_W"] == 0.0 < heat["wheel"]["hysteresis_W"]
        if split == "effusivities":
            assert s["heat_split"] is None
            assert share == pytest.approx(effusivity, rel=1e-6)
        else:
            last = s["heat_split"]["passes"][-1]
            assert abs(last["contact_pinion_C"] - last["contact_wheel_C"]) < 0.5
            assert share == pytest.approx(last["fraction_pinion"], rel=1e-6)
            assert 0.5 < share < effusivity - 0.1  # the hotter steel takes less
    b = s["baselines"]
    assert (b["vdi2736_k_theta_flank"], b["vdi2736_k_theta_root"]) == (6300.0, 895.0)
    assert b["vdi2736_flank1_C"] is None and b["vdi2736_flank2_C"] > 23.0
    assert s["headline"]["vdi2736_flank_C"] == b["vdi2736_flank2_C"]


@pytest.mark.mpi
@pytest.mark.slow
def test_demos_on_all_ranks(tmp_out):
    """The literate demos run in-process on every rank of the communicator (under
    ``mpirun -n 2`` in CI) and give the serial results' physics: Hertz p0 within (h/a)²/12 and a
    within 3 %, the thermal balance closed."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    out = Path(comm.bcast(str(tmp_out / "demos_all_ranks"), root=0))
    hertz, thermal = load_script("demos/hertz_contact.py"), load_script("demos/thermal_gear.py")
    assert hertz.main(["--contact-size", "0.014", "--out", str(out / "h")]) == 0
    assert thermal.main(["--duration-s", "300", "--out", str(out / "t")]) == 0
    comm.barrier()
    s = json.loads((out / "h" / "summary.json").read_text())
    assert s["ranks"] == comm.size
    assert abs(s["errors"]["p0"]) < peak_pressure_bound(0.014, s["hertz"]["a_m"])
    assert abs(s["errors"]["a_moments"]) < 0.03
    t = json.loads((out / "t" / "thermal_summary.json").read_text())
    assert t["max_relative_imbalance"] < 1e-9
