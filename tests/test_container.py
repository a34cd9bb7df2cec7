"""The container recipe, exercised as far as possible without a Docker engine.

No Docker engine runs in CI, so these tests check what can be checked: the base image is the pinned
DOLFINx release that pyproject's `fenics` extra pins; the image installs through `./dev.sh` only
(one dependency list: pyproject.toml); and `./dev.sh setup` takes the image's route — a Python that
already has DOLFINx on its path gets a `--system-site-packages` venv without the PyPI wheel — which
is run for real here against this environment's DOLFINx, the way the image provides it (PYTHONPATH).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCKERFILE = ROOT / "container" / "Dockerfile"


def _instructions() -> list[tuple[str, str]]:
    text = DOCKERFILE.read_text().replace("\\\n", " ")
    out = []
    for line in text.splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            word, _, rest = line.partition(" ")
            out.append((word.upper(), rest.strip()))
    return out


def test_base_image_is_pinned_to_the_dolfinx_the_pip_route_uses():
    froms = [rest for word, rest in _instructions() if word == "FROM"]
    assert froms == ["ghcr.io/fenics/dolfinx/dolfinx:v0.11.0"]
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"
    ]
    (pin,) = [d for d in extras["fenics"] if d.startswith("dolfinx-solver-real")]
    assert re.search(r"==\s*0\.11(\.\*)?$", pin), pin


def test_image_installs_and_tests_through_dev_sh_only():
    runs = " ".join(rest for word, rest in _instructions() if word == "RUN")
    assert "./dev.sh setup" in runs and "./dev.sh test" in runs
    # no second hand-kept dependency list: pip is never called with package names in the recipe
    assert "pip install" not in runs and "requirements" not in runs
    ignored = (ROOT / ".dockerignore").read_text().split()
    assert ".venv" in ignored  # the host venv must not leak into the image


@pytest.mark.slow
def test_dev_sh_setup_takes_the_image_route(tmp_path):
    """An interpreter that sees DOLFINx through PYTHONPATH (as in the image) gets a venv without the
    wheel."""
    bash = shutil.which("bash")
    assert bash is not None
    site = sysconfig.get_paths()["purelib"]  # this environment's DOLFINx stands in for the image's
    base = getattr(sys, "_base_executable", sys.executable)
    # the image also puts its MPI library on LD_LIBRARY_PATH; here it lives in this venv's lib/
    libdir = str(Path(sys.prefix) / "lib")
    env = dict(
        os.environ,
        GEARFEM_PYTHON=base,
        GEARFEM_VENV=str(tmp_path / "venv"),
        PYTHONPATH=site,
        LD_LIBRARY_PATH=os.pathsep.join(filter(None, [libdir, os.environ.get("LD_LIBRARY_PATH")])),
    )
    r = subprocess.run(
        [bash, str(ROOT / "dev.sh"), "setup"],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    assert "DOLFINx found" in r.stderr and "gearfem[test]" in r.stderr
    py = tmp_path / "venv" / "bin" / "python"
    freeze = subprocess.run(
        [str(py), "-m", "pip", "list", "--local", "--format=freeze"],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    ).stdout
    assert (
        "dolfinx-solver-real" not in freeze and "mpich" not in freeze
    )  # the image's DOLFINx is used
    info = subprocess.run(
        [str(tmp_path / "venv" / "bin" / "gearfem"), "info"],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert info.returncode == 0 and "dolfinx" in info.stdout, info.stderr[-2000:]
