"""Saving, loading and caching cycle results.

A :class:`~gearfem.cycle.solve.CycleResult` is stored as ``cycle.npz`` (arrays) plus
``cycle.json`` (scalars and metadata), written to a temporary name and renamed, so an interrupted
run never leaves a result that looks complete. Results are cached under
``<cache>/cycles/<key>/`` with ``key`` a hash of everything that changes the structural answer:
geometry, mesh options, materials, contact and cycle options (the solver among them), torque, the
source of the contact/cycle code, and the digests of a friction field or a modulus field the
cycle is solved with (speed does not enter: one cycle solve per torque serves every speed). The
condensed solver's gear compliances are stored under ``<cache>/compliance/`` (one per mesh,
material, modulus field and contact surface set, whatever the torque: :func:`compliance_store`).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from gearfem.contact.compliance import ComplianceStore
from gearfem.core.io import jsonable
from gearfem.core.params import to_dict
from gearfem.core.provenance import code_hash
from gearfem.cycle.friction_field import FrictionField
from gearfem.cycle.history import ContactHistory
from gearfem.cycle.modulus_field import ModulusField
from gearfem.cycle.options import MODULUS_LOOP_KEYS
from gearfem.cycle.result import BodyFields, CycleResult, PeriodicityCheck
from gearfem.cycle.solve import solve_cycle
from gearfem.geometry.mesh import cache_key as mesh_cache_key
from gearfem.geometry.options import BODIES

log = logging.getLogger(__name__)

ENV_CACHE = "GEARFEM_CACHE"
_SCALARS = (
    "torque_Nm",
    "friction_coefficient",
    "pitch_angle_rad",
    "theoretical_contact_ratio",
    "base_pitch_m",
)
_ARRAYS = (
    "phi_rad",
    "te_m",
    "pinion_torque_Nm",
    "wheel_torque_Nm",
    "friction_power_W_per_rad_s",
    "p_max_Pa",
    "p_max_mid_Pa",
    "newton_iterations",
    "uzawa_iterations",
    "wall_time_s",
)


def cache_root() -> Path:
    """``$GEARFEM_CACHE`` if set, else ``cache`` under the working directory."""
    return Path(os.environ.get(ENV_CACHE, "cache"))


def _code_hash() -> str:
    """Hash of the code of every gearfem module the cycle solve imports, transitively (the mesh,
    contact, materials, facet geometry, Newton driver, ...; docstrings and comments aside,
    :func:`gearfem.core.provenance.code_hash`): an edit of the code there invalidates stored
    cycles, an edit elsewhere (the thermal model, the diagnosis) or of the explanations does
    not."""
    return code_hash("gearfem.cycle.solve", "gearfem.cycle.model", "gearfem.cycle.cache")


def cycle_key(
    geometry,
    mesh_options,
    materials: dict,
    contact,
    cycle_options,
    torque_Nm: float,
    friction_field: FrictionField | None = None,
    moduli: ModulusField | None = None,
) -> str:
    """The cache key of a cycle (see the module docstring); ``friction_field``: the mu at each
    contact the cycle is solved with, by its digest (None: the contact options' one mu);
    ``moduli``: the modulus per cell, by its digest (None: each material's constant one)."""
    data = {
        "geometry": to_dict(geometry),
        "mesh": to_dict(mesh_options),
        # the mesh's own key: its code, the gmsh version and the meshed bodies (both)
        "mesh_key": mesh_cache_key(geometry, mesh_options),
        "materials": {b: to_dict(m) for b, m in materials.items()},
        "contact": to_dict(contact),
        # how the ranks share the work changes the result only within the solver's tolerance,
        # like the number of ranks: not part of the key; nor the modulus fixed point's options
        # (which cycles are solved; the field's digest below says what one holds)
        "cycle": {
            k: v
            for k, v in to_dict(cycle_options).items()
            if k != "parallel" and k not in MODULUS_LOOP_KEYS
        },
        "torque_Nm": float(torque_Nm),
        "code": _code_hash(),
    }
    if friction_field is not None:
        data["friction_field"] = friction_field.digest()
    if moduli is not None:
        data["moduli"] = moduli.digest()
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:16]


def compliance_context(
    geometry, mesh_options, materials: dict, moduli: ModulusField | None = None
) -> str:
    """What a stored gear compliance depends on besides its body's DOFs and supports (which
    :class:`~gearfem.contact.compliance.ComplianceStore` adds): the pair mesh (its key), each
    gear's elastic constants and the modulus field scaling them (its digest), and the code that
    computes it (the compliance module and the stiffness form, with what they import, and the
    field's sampling). Torque, friction, contact and cycle options do not enter: one compliance
    serves every operating point."""
    data = {
        "mesh_key": mesh_cache_key(geometry, mesh_options),
        "elastic": {
            b: [float(m.youngs_modulus_Pa), float(m.poissons_ratio)]
            for b, m in sorted(materials.items())
        },
        "code": code_hash("gearfem.contact.compliance", "gearfem.contact.elasticity"),
    }
    if moduli is not None:
        data["moduli"] = moduli.digest()
        data["moduli_code"] = code_hash("gearfem.cycle.modulus_field")
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:16]


def compliance_store(
    geometry,
    mesh_options,
    materials: dict,
    cache_dir: Path | None = None,
    moduli: ModulusField | None = None,
) -> ComplianceStore:
    """The store of the gear compliances under ``<cache>/compliance/`` (of the gears scaled by
    ``moduli`` when given)."""
    return ComplianceStore(
        (cache_dir or cache_root()) / "compliance",
        compliance_context(geometry, mesh_options, materials, moduli),
    )


def save(result: CycleResult, directory: str | Path, replace: bool = True) -> Path:
    """Write ``cycle.npz`` and ``cycle.json`` into ``directory`` atomically (call on one rank).

    An existing entry is replaced, unless ``replace`` is false and it is complete: then it is kept
    and this result discarded (a cache entry that another process, e.g. a second test worker or a
    concurrent study, stored under the same key meanwhile holds the same result, and a reader of
    it never sees it removed)."""
    directory = Path(directory)
    directory.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".tmp-cycle-", dir=directory.parent))
    arrays: dict[str, np.ndarray] = {k: np.asarray(getattr(result, k)) for k in _ARRAYS}
    for b, v in result.root_stress_Pa.items():
        arrays[f"root_stress_Pa__{b}"] = v
    for k, v in result.tooth_load_N.items():
        arrays[f"tooth_load_N__{k}"] = v
        arrays[f"tooth_S_m__{k}"] = result.tooth_S_m[k]
    for b, f in result.fields.items():
        for name in BodyFields.__dataclass_fields__:
            val = getattr(f, name)
            if isinstance(val, np.ndarray):
                arrays[f"fields__{b}__{name}"] = val
    if result.history is not None:
        for k, v in result.history.arrays().items():
            arrays[f"history__{k}"] = v
    field = result.friction_field
    if field is not None:
        for k, v in field.arrays().items():
            arrays[f"friction_field__{k}"] = v
    np.savez_compressed(tmp / "cycle.npz", **arrays)
    meta: dict[str, Any] = {k: getattr(result, k) for k in _SCALARS}
    meta.update(
        reference_tooth=result.reference_tooth,
        info=result.info,
        periodicity=None if result.periodicity is None else result.periodicity.to_json(),
        history_z_bin_m=None if result.history is None else result.history.z_bin_m,
        friction_field=None if field is None else {"z_bin_m": field.z_bin_m, "step": field.step},
        fields={
            b: {"tooth_angle_rad": f.tooth_angle_rad, "pitch_angle_rad": f.pitch_angle_rad}
            for b, f in result.fields.items()
        },
    )
    (tmp / "cycle.json").write_text(json.dumps(meta, indent=2, default=jsonable))
    if not replace and _complete(directory):
        shutil.rmtree(tmp, ignore_errors=True)
        return directory
    if directory.exists():
        shutil.rmtree(directory)
    try:
        os.replace(tmp, directory)  # atomic: the entry appears complete or not at all
    except OSError:
        shutil.rmtree(tmp, ignore_errors=True)
        if replace or not _complete(directory):
            raise
    return directory


def _complete(directory: Path) -> bool:
    return (directory / "cycle.json").is_file() and (directory / "cycle.npz").is_file()


def load(directory: str | Path) -> CycleResult:
    directory = Path(directory)
    meta = json.loads((directory / "cycle.json").read_text())
    with np.load(directory / "cycle.npz") as z:
        arr = {k: z[k] for k in z.files}
    fields = {}
    for b, fm in meta["fields"].items():
        kw = {
            name: arr[f"fields__{b}__{name}"]
            for name in BodyFields.__dataclass_fields__
            if f"fields__{b}__{name}" in arr
        }
        fields[b] = BodyFields(
            tooth_angle_rad=fm["tooth_angle_rad"], pitch_angle_rad=fm["pitch_angle_rad"], **kw
        )
    teeth = sorted(int(k.split("__")[1]) for k in arr if k.startswith("tooth_load_N__"))
    hist = {k.split("__", 1)[1]: v for k, v in arr.items() if k.startswith("history__")}
    ff = {k.split("__", 1)[1]: v for k, v in arr.items() if k.startswith("friction_field__")}
    ff_meta = meta.get("friction_field")
    return CycleResult(
        **{k: meta[k] for k in _SCALARS},
        **{k: arr[k] for k in _ARRAYS},
        root_stress_Pa={
            k.split("__")[1]: v for k, v in arr.items() if k.startswith("root_stress_Pa__")
        },
        tooth_load_N={k: arr[f"tooth_load_N__{k}"] for k in teeth},
        tooth_S_m={k: arr[f"tooth_S_m__{k}"] for k in teeth},
        fields=fields,
        reference_tooth=meta["reference_tooth"],
        periodicity=_periodicity(meta.get("periodicity")),
        info=meta.get("info", {}),
        history=ContactHistory.from_arrays(hist, meta["history_z_bin_m"]) if hist else None,
        friction_field=(
            FrictionField.from_arrays(ff, ff_meta["z_bin_m"], ff_meta["step"]) if ff_meta else None
        ),
    )


def _periodicity(data: dict | None) -> PeriodicityCheck | None:
    """The stored periodicity check; one stored before it was a record (its sector energies under
    ``"<body>_sector_energy_J"`` as ``{"sector", "shifted", "mapped"}``) read as the record."""
    if data is None:
        return None
    if "sector_energy_J" not in data:
        data = dict(data)
        data["sector_energy_J"] = {
            b: [
                {"sector": e["sector"], "shifted_J": e["shifted"], "mapped_J": e["mapped"]}
                for e in data.pop(f"{b}_sector_energy_J", [])
            ]
            for b in BODIES
        }
    return PeriodicityCheck.from_json(data)


def cached_cycle(
    model_factory,
    key: str,
    comm,
    cache_dir: Path | None = None,
    rebuild: bool = False,
    **run_kwargs,
) -> tuple[CycleResult, Path, bool]:
    """The cycle result for ``key`` from the cache, or computed (``model_factory()`` then
    :func:`~gearfem.cycle.solve.run_cycle`) and stored. Collective. Returns (result, dir,
    from_cache)."""

    directory = (cache_dir or cache_root()) / "cycles" / key
    done = comm.bcast(_complete(directory), root=0)
    if done and not rebuild:
        log.info("cycle %s from the cache (%s)", key, directory)
        return load(directory), directory, True
    result = solve_cycle(model_factory(), **run_kwargs)  # collective on comm
    if comm.rank == 0:
        save(result, directory, replace=rebuild)
    comm.barrier()
    return result, directory, False
