"""The repository's scripts as modules: demos/ and benchmarks/ are no packages, so a test imports
a demo (its ``main(argv)``) or a benchmark script by its path."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def load_script(relative: str) -> ModuleType:
    """The script ``relative`` to the repository's root (``demos/steel_pom.py``,
    ``benchmarks/regenerate.py``) imported as a module named after its folder and stem, its
    folder on the path as when python runs it (a script imports its folder's modules by name)."""
    path = ROOT / relative
    if str(path.parent) not in sys.path:
        sys.path.append(str(path.parent))
    spec = importlib.util.spec_from_file_location(f"{path.parent.name}_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module
