"""Numerical uncertainty of a run's reported quantities, from stored refinement studies.

A refinement study (:mod:`gearfem.refinement`, ``gearfem converge``) measures, for one case's
resolution and one refinement direction (*kind*: thermal mesh, structural contact-zone mesh,
structural layers across the face width, positions per pitch, tip elements), the numerical
standard uncertainty u_num of every reported quantity at that resolution (the grid convergence
index of :mod:`gearfem.core.gci`, divided by 1.15 as in ASME V&V 20). The studies are filed by
the case's :func:`resolution_key` — a hash of everything that sets the discretisation (geometry,
both meshes, positions, thermal degree and time error, contact discretisation, the flux
reconstruction's widths and algorithm, the camera's footprint, time and aim quadratures) and
nothing that sets only the physics (materials, convection, friction, sources, operating point,
the instruments' optics):

* ``gearfem/data/uncertainty/<key>/<kind>.json``: shipped studies (the built-in case), and
* ``<cache root>/uncertainty/<key>/<kind>.json``: studies written by ``gearfem converge``
  (a study found in both places: the cache's, the newer measurement, is used).

A study also carries the version of what the study of its kind measures
(:data:`STUDY_DESIGN_VERSION`): a study filed in the cache by an older gearfem whose refinement
path has since changed is not used (a warning names it), so that a re-designed study is
measured again instead of read back stale.

A run looks up the studies of its resolution (:func:`run_uncertainty`) and combines the kinds in
quadrature, u_num = sqrt(Σ_kind u_kind²) (independent error sources). Discretisation errors of
the (nearly linear) thermal problem scale with the heating: a study made at another operating
point is applied relative to the quantity's rise, u = u_study · |S − S_ref| / |S_study − S_ref|
with S_ref the ambient temperature for temperatures and 0 otherwise, and the result says so
(``scaled``). Kinds without a stored study are listed as missing: the run then reports u_num
from the kinds it has, and names the command that would measure the rest. A resolution with no
study at all gets no u_num (``None``), never a made-up one.
"""

from __future__ import annotations

import dataclasses
import datetime
import hashlib
import json
import logging
import math
from importlib import resources
from pathlib import Path

from gearfem.config import Case
from gearfem.core.doctables import Provenance
from gearfem.core.io import read_json, write_json
from gearfem.core.params import to_dict
from gearfem.core.provenance import code_hash, git_hash
from gearfem.core.results import JsonRecord
from gearfem.coupling.transfer import RECONSTRUCTION_VERSION
from gearfem.cycle.cache import cache_root

log = logging.getLogger(__name__)

#: Bump when a change of gearfem.refinement changes what a study measures (the levels it runs);
#: part of every stored study. 1: until 6499368 (2026-11-26); 2: the contact-zone study keeps
#: the flux reconstruction's widths (they shrink with the positions and the layers only).
STUDY_DESIGN_VERSION = 2

#: Relative difference within which a run's value is the study's own (not scaled by the rise).
SAME_VALUE_RTOL = 1e-6

KINDS = ("thermal_mesh", "structural_mesh", "structural_layers", "positions", "tip")

#: Where the built-in case sits in each kind's study (the shipped studies,
#: benchmarks/verification/uncertainty_builtin.py): in the middle of the
#: thermal-mesh study (4 / 6 / 9 thermal layers, the case 6), of the positions study (12 / 18 / 27
#: positions per pitch: the middle-grid GCI, from one coarser and one finer cycle) and, second of
#: four, of the layers study (3 / 4 / 6 / 9 graded layers, the case 4: a 13-layer level would need
#: some 24 GB); the coarsest of the others (a contact zone 1.5x coarser than the case's is outside
#: the range where the pitch-point pressure has converged, docs/cycle.md).
BUILTIN_CASE_LEVEL = {
    "thermal_mesh": "middle",
    "structural_mesh": "coarsest",
    "structural_layers": "middle",
    "positions": "middle",
    "tip": "coarsest",
}
#: How many levels each kind's study has: four across the face width, where three levels (2/3/5
#: equal layers, on 2026-11-26) moved the camera reading by 0.2 and 0.1 K, too little above the
#: readings' scatter for three solutions to tell a slow trend (their order 0.38: Fs = 3, 2.2 K)
#: from settling; a fourth level and the least-squares fit through all four do.
BUILTIN_LEVELS = {
    "thermal_mesh": 3,
    "structural_mesh": 3,
    "structural_layers": 4,
    "positions": 3,
    "tip": 3,
}

# the [thermal] and [contact] keys that set the discretisation (the rest is physics)
_THERMAL_RESOLUTION = (
    "degree",
    "time_stepping",
    "dt_initial_s",
    "dt_min_s",
    "dt_max_s",
    "time_error_K",
    "newton_rtol",
    "newton_atol_W",
)
_CONTACT_RESOLUTION = (
    "method",
    "penalty_factor",
    "penalty_Pa_m",
    "penetration_tolerance_rel",
    "penetration_tolerance_m",
    "pressure_smoothing_Pa",
    "slip_tolerance",
    "slip_regularization_m_s",
    "two_pass",
    "quadrature_degree",
    "search_distance_rel",
    "projection_tolerance",
    "newton_rtol",
    "uzawa_newton_rtol",
)


def resolution_key(case: Case) -> str:
    """Hash of what sets the case's discretisation (see the module docstring)."""
    thermal, contact = to_dict(case.thermal), to_dict(case.contact)
    data = {
        "geometry": to_dict(case.geometry),
        "mesh": to_dict(case.mesh),
        "thermal_mesh": to_dict(case.thermal_mesh_options),
        "cycle": {
            k: v
            for k, v in to_dict(case.cycle).items()
            if k in ("positions_per_pitch", "pitches", "start_angle_deg", "contact_kinds")
        },
        "thermal": {k: thermal[k] for k in _THERMAL_RESOLUTION if k in thermal},
        "contact": {k: contact[k] for k in _CONTACT_RESOLUTION if k in contact},
        "flux_smoothing_mm": [
            case.sources.flux_smoothing_profile_mm,
            case.sources.flux_smoothing_axial_mm,
        ],
        # the reconstruction's algorithm (2: mirrored at the side faces) and where it is evaluated
        # (the default's key kept as it was before the option existed)
        "flux_reconstruction": RECONSTRUCTION_VERSION
        if case.sources.flux_evaluation == "reference_facets"
        else f"{RECONSTRUCTION_VERSION}-{case.sources.flux_evaluation}",
        # the camera reading's quadratures (footprint rays, rotation phases, sub-pixel aims)
        "camera_quadrature": [
            case.instruments.camera.subsamples,
            case.instruments.camera.phases,
            case.instruments.camera.aim_offsets,
        ],
    }
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:16]


#: The modules whose code a quoted result of a run depends on (and what they import).
RUN_CODE = ("gearfem.pipeline",)
#: ... of a diagnosis (the forward model, the selection, the report).
DIAGNOSIS_CODE = ("gearfem.diagnose.report",)


def provenance(case: Case | None, roots: tuple[str, ...] = RUN_CODE) -> Provenance:
    """The provenance of a result computed now with the current code of ``roots`` on ``case``
    (None: a result without a case resolution behind it): its resolution key, the code hash of
    the modules (:func:`gearfem.core.provenance.code_hash`), the commit and the date. A figure
    quoted from the result carries it (:mod:`gearfem.claims` checks it)."""
    return Provenance(
        resolution=resolution_key(case) if case is not None else None,
        code={m: code_hash(m) for m in roots},
        commit=git_hash(),
        date=datetime.date.today().isoformat(),
    )


@dataclasses.dataclass(frozen=True)
class StudyUncertainty(JsonRecord):
    """What the store keeps of one refinement study: per quantity the value at the case's
    resolution, its unit, u_num and whether the three levels were in the asymptotic range."""

    kind: str
    resolution_key: str
    case: str
    speed_rpm: float
    torque_Nm: float
    ambient_C: float
    factor: float
    values: dict[str, float]
    units: dict[str, str]
    u_num: dict[str, float]
    asymptotic: dict[str, bool]
    design: int = 1  # STUDY_DESIGN_VERSION of the code that ran it (1: files without the field)


@dataclasses.dataclass(frozen=True)
class QuantityUncertainty(JsonRecord):
    """u_num of one quantity of a run: combined, and per refinement kind."""

    u_num: float
    parts: dict[str, float]
    asymptotic: bool  # every part from a study in the asymptotic range
    scaled: bool  # some part measured at another operating point, scaled by the rise


@dataclasses.dataclass(frozen=True)
class RunUncertainty(JsonRecord):
    """The numerical uncertainty of a run's quantities (``summary.json`` "numerical_uncertainty").

    ``sources`` names the stored study of each kind found; ``missing`` the kinds without one."""

    resolution_key: str
    sources: dict[str, str]
    missing: tuple[str, ...]
    quantities: dict[str, QuantityUncertainty]

    def u_num(self, quantity: str) -> float | None:
        q = self.quantities.get(quantity)
        return q.u_num if q is not None else None


def _shipped_dir(key: str):
    return resources.files("gearfem").joinpath("data", "uncertainty", key)


def store_directory(key: str) -> Path:
    """Where ``gearfem converge`` files the studies of resolution ``key``."""
    return cache_root() / "uncertainty" / key


def store_study(study: StudyUncertainty) -> Path:
    """File a study under its resolution key and kind (one rank)."""
    path = store_directory(study.resolution_key) / f"{study.kind}.json"
    write_json(path, study)
    return path


def stored_studies(key: str) -> dict[str, tuple[StudyUncertainty, str]]:
    """The stored study of every kind for resolution ``key``: kind -> (study, where). Studies of
    another :data:`STUDY_DESIGN_VERSION` are left out (with a warning)."""
    found: dict[str, tuple[StudyUncertainty, str]] = {}
    shipped = _shipped_dir(key)
    for kind in KINDS:
        candidates = []
        item = shipped.joinpath(f"{kind}.json")
        if item.is_file():
            data = json.loads(item.read_text(encoding="utf-8"))
            candidates.append((data, f"gearfem/data/uncertainty/{key}/{kind}.json"))
        path = store_directory(key) / f"{kind}.json"
        if path.is_file():  # the cache's, the newer measurement, wins
            candidates.append((read_json(path), str(path)))
        for data, where in candidates:
            study = StudyUncertainty.from_json(data)
            if study.design != STUDY_DESIGN_VERSION:
                log.warning(
                    "%s: a %s study of design %d, not the current %d (gearfem converge "
                    "--kind %s measures it again); not used",
                    where,
                    kind,
                    study.design,
                    STUDY_DESIGN_VERSION,
                    kind,
                )
                continue
            found[kind] = (study, where)
    return found


def _scaled(
    study: StudyUncertainty, quantity: str, value: float, ambient_C: float
) -> tuple[float, bool]:
    """u of ``quantity`` at ``value`` from ``study`` (scaled by the rise when the operating point
    or ambient differs)."""
    u = study.u_num[quantity]
    ref_run, ref_study = (
        (ambient_C, study.ambient_C) if study.units.get(quantity) == "C" else (0.0, 0.0)
    )
    # the study's own value, reproduced to the solvers' tolerances (a cycle solved on other
    # condensed surfaces moves the headline by about 4e-8), is not a change of the heating
    same = abs(value - study.values[quantity]) <= SAME_VALUE_RTOL * max(1.0, abs(value))
    if same and ref_run == ref_study:
        return u, False
    rise_study = study.values[quantity] - ref_study
    if rise_study == 0.0:
        return u, True
    return u * abs(value - ref_run) / abs(rise_study), True


def run_uncertainty(case: Case, values: dict[str, float]) -> RunUncertainty | None:
    """u_num of each of a run's ``values`` (quantity name -> value, in the studies' units) from
    the studies stored for the case's resolution; None when there is none. A quantity that some
    of the stored studies do not follow (added after they ran) gets none."""
    key = resolution_key(case)
    found = stored_studies(key)
    if not found:
        return None
    quantities = {}
    for q, v in values.items():
        if v is None or not math.isfinite(v):
            continue
        if any(q not in study.u_num for study, _ in found.values()):
            continue  # a sum over some of the directions would understate u_num
        parts, asym, scaled = {}, True, False
        for kind, (study, _) in found.items():
            u, s = _scaled(study, q, v, case.thermal.ambient_C)
            parts[kind] = u
            asym = asym and study.asymptotic[q]
            scaled = scaled or s
        total = math.sqrt(sum(u * u for u in parts.values()))  # found is not empty
        quantities[q] = QuantityUncertainty(total, parts, asym, scaled)
    return RunUncertainty(
        resolution_key=key,
        sources={k: where for k, (_, where) in found.items()},
        missing=tuple(k for k in KINDS if k not in found),
        quantities=quantities,
    )
