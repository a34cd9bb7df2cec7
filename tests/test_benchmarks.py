"""Benchmark scripts that read another tool's output read what it writes.

``benchmarks/performance/loops.py --tests`` runs ``./dev.sh test`` in fresh clones (20 min) and
splits its time into the tiers from the lines dev.sh prints; a change of those lines would only
show at the end of such a run. Checked here against dev.sh's own text.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _loops():
    spec = importlib.util.spec_from_file_location(
        "loops", ROOT / "benchmarks" / "performance" / "loops.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


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
    for name, pattern in _loops()._TIER_LINES.items():
        m = pattern.search(printed)
        assert m is not None and m.group(1) == "123", (name, pattern.pattern, printed)
