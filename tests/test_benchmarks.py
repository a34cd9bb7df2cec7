"""Benchmark scripts that read another tool's output read what it writes, and the driver that
regenerates the quoted blocks reports a failure instead of passing over it.

``benchmarks/performance/loops.py --tests`` runs ``./dev.sh test`` in fresh clones (20 min) and
splits its time into the tiers from the lines dev.sh prints; a change of those lines would only
show at the end of such a run. Checked here against dev.sh's own text.
``benchmarks/regenerate.py`` runs commands of hours; its failure paths are checked on commands of
a moment.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest
from body_fields import body_field
from scripts import load_script

from gearfem import claims
from gearfem.core.materials import TemperatureTable

ROOT = Path(__file__).resolve().parent.parent


def test_loops_reads_the_tier_times_dev_sh_reports():
    # dev.sh's say lines with the bash arithmetic and variables as a run prints them
    said = [
        line.split('say "', 1)[1].rsplit('"', 1)[0]
        for line in (ROOT / "dev.sh").read_text().splitlines()
        if 'say "' in line and "passed in" in line
    ]
    printed = "\n".join(
        re.sub(r"\$\(\(SECONDS - t\d\)\)", "123", s).replace("$MPI_NP", "2") for s in said
    )
    for name, pattern in load_script("benchmarks/performance/loops.py")._TIER_LINES.items():
        m = pattern.search(printed)
        assert m is not None and m.group(1) == "123", (name, pattern.pattern, printed)


def test_regenerate_times_a_command_and_stops_on_a_failed_one(tmp_path):
    regenerate = load_script("benchmarks/regenerate.py")
    env = dict(os.environ)
    t = regenerate.run_logged("echo written; sleep 0.2", tmp_path / "1.log", env, cwd=tmp_path)
    assert (tmp_path / "1.log").read_text() == "written\n"
    assert 0.2 <= t.wall_s < 5 and t.user_s >= 0 and t.sys_s >= 0
    with pytest.raises(SystemExit) as failed:
        regenerate.run_logged("echo last words; exit 3", tmp_path / "2.log", env, cwd=tmp_path)
    message = str(failed.value)
    assert "exit code 3" in message and "last words" in message and "2.log" in message


def test_regenerate_names_a_block_its_command_left_stale(tmp_path):
    """A command that ran without writing its block (here: the README has no provenance on it)
    is reported with the block and the reason, not counted as done."""
    regenerate = load_script("benchmarks/regenerate.py")
    (tmp_path / "README.md").write_text(
        "<!-- gearfem:begin readme_headline -->\n| a |\n<!-- gearfem:end readme_headline -->\n"
    )
    step = next(r for r in claims.REGENERATIONS if ("README.md", "readme_headline") in r.blocks)
    left = regenerate.still_stale(step, tmp_path)
    assert [(c.block, c.reason) for c in left] == [("readme_headline", "no provenance line")]


def test_the_modulus_of_a_thermal_state_is_the_teeths_harmonic_volume_mean():
    """benchmarks/verification/modulus_temperature.py: E_eff = V / sum(V_c / E(T_c)) over the cells
    outside the root circle; the cells inside it (the body) do not count; the shares above T_g
    and beyond the table are volume shares of the tooth."""
    script = load_script("benchmarks/verification/modulus_temperature.py")
    unit = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)  # volume 1/6
    # two tooth cells (x about 10 and 12, the second twice as large) and one body cell (x about 1)
    at = lambda x: np.array([x, 0.0, 0.0])
    nodes = np.vstack([unit + at(10), 2 ** (1 / 3) * unit + at(12), unit + at(1)])
    cells = np.arange(12).reshape(3, 4)
    T_C = np.repeat([100.0, 175.0, 300.0], 4)  # the body cell hot: it must not count
    field = body_field(nodes, cells, T_C + 273.15)
    table = TemperatureTable.from_celsius([23.0, 130.0, 170.0], [3.7e9, 3.7e9, 2.3e9])
    got = script.tooth_modulus(field, 0, 5.0, table, glass_transition_C=143.0)
    # cell volumes 1/6 and 2/6 at E 3.7 and 2.3 GPa (175 C is beyond the table: its last value)
    assert got.modulus_Pa == pytest.approx(3.0 / (1 / 3.7e9 + 2 / 2.3e9), rel=1e-12)
    assert got.above_glass_transition == pytest.approx(2 / 3, rel=1e-12)
    assert got.beyond_table == pytest.approx(2 / 3, rel=1e-12)
