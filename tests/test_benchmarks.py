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

import pytest
from scripts import load_script

from gearfem import claims

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
