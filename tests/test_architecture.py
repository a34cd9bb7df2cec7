"""The package layers (docs/architecture.md) and lint, checked as tests.

* ``lint-imports`` (import-linter, contracts in pyproject.toml) passes on the package: imports
  point down the layers only, contact and thermal know nothing of gears, option modules are
  DOLFINx-free.
* The check is not vacuous: a copy of the package with one deliberate upward import, one
  DOLFINx import in an option module and one gear import in the contact package fails it, naming
  each broken contract.
* ruff (lint and format) is clean on the repository.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def _tool(name: str) -> str:
    path = BIN / name
    if not path.exists():
        found = shutil.which(name)
        if found is None:
            pytest.fail(f"{name} is not installed: install gearfem[test] (pyproject.toml)")
        return found
    return str(path)


def _lint_imports(root: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(root))
    return subprocess.run(
        [_tool("lint-imports"), "--config", str(ROOT / "pyproject.toml"), "--no-cache"],
        cwd=root,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_layers_are_kept():
    res = _lint_imports(ROOT)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "3 kept, 0 broken" in res.stdout


def test_upward_imports_break_the_layers(tmp_path):
    shutil.copytree(
        ROOT / "gearfem", tmp_path / "gearfem", ignore=shutil.ignore_patterns("__pycache__")
    )
    violations = {
        "core/params.py": "from gearfem import pipeline  # deliberate upward import\n",
        "cycle/options.py": "import dolfinx  # deliberate DOLFINx import in an option module\n",
        "contact/rigid.py": "from gearfem.geometry import involute  # deliberate gear import\n",
    }
    for rel, line in violations.items():
        path = tmp_path / "gearfem" / rel
        path.write_text(path.read_text() + "\n" + line)
    res = _lint_imports(tmp_path)
    assert res.returncode != 0
    out = res.stdout
    assert "0 kept, 3 broken" in out, out
    assert "gearfem.core.params -> gearfem.pipeline" in out
    assert "gearfem.cycle.options -> dolfinx" in out
    assert "gearfem.contact.rigid -> gearfem.geometry.involute" in out


@pytest.mark.parametrize("args", [["check"], ["format", "--check"]], ids=["lint", "format"])
def test_ruff_clean(args):
    res = subprocess.run(
        [_tool("ruff"), *args, "--no-cache", "."],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stdout[-5000:] + res.stderr[-2000:]
