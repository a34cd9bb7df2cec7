"""The documentation site builds without a warning: a broken reference fails here, not on a reader.

``./dev.sh docs`` builds docs/_build/html (Sphinx, MyST pages, the demos rendered, the API reference
from the docstrings). This test reads and resolves the same site with warnings as errors and
nitpicky references (``-W -n``), with Sphinx's ``dummy`` builder: every page, demo and API module
is parsed and every reference resolved as for HTML, without writing HTML (about half the time;
about 30 s of one core). It belongs to the full tier (``slow``).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

pytestmark = pytest.mark.slow


def test_docs_site_builds_with_warnings_as_errors(tmp_path):
    if os.environ.get("CI") != "true":
        pytest.importorskip("sphinx", reason="the docs extra: ./dev.sh docs installs it")
        pytest.importorskip("myst_parser", reason="the docs extra: ./dev.sh docs installs it")
    cmd = [
        sys.executable,
        "-m",
        "sphinx",
        "-b",
        "dummy",
        "-W",
        "--keep-going",
        "-n",
        "-E",
        "-q",
        "-d",
        str(tmp_path / "doctrees"),
        str(ROOT / "docs"),
        str(tmp_path / "out"),
    ]
    env = dict(os.environ, OMP_NUM_THREADS="1", PYVISTA_OFF_SCREEN="true", MPLBACKEND="Agg")
    r = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, f"sphinx -W -n failed:\n{r.stderr[-6000:]}"
    demos = sorted(p.stem for p in (ROOT / "docs" / "_generated" / "demos").glob("*.md"))
    assert demos == sorted(p.stem for p in (ROOT / "demos").glob("*.py"))  # every demo rendered
