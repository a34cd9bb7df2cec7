"""Parametric studies: a grid (or list) of speeds × torques, one structural cycle per torque.

A study file is a case file (:mod:`gearfem.config`, the same tables and defaults) with one extra
table ``[study]``::

    name = "thesis gears, speed x torque"
    [study]
    speeds_rpm = [500.0, 1000.0, 2000.0]   # with torques_Nm: the full grid
    torques_Nm = [4.0, 8.0]
    # points = [[1000.0, 8.0], [2000.0, 4.0]]   # or (also) an explicit list of (speed_rpm,
    torque_Nm)
    parallel = "auto"                      # "cases", "mpi" or "auto" (see below)
    [thermal]
    duration_s = 900.0

How it runs (``gearfem study STUDY.toml --out DIR``, under ``mpirun -n N`` or serial):

1. the meshes are built once on all ranks;
2. the structural cycle of every torque is computed (or found in the cycle cache): the cycle is
   speed-independent (its friction flux is stored per unit speed), so every speed reuses it;
3. every operating point runs the thermal stage and baselines (:func:`gearfem.pipeline.run`, all
   cycles are cache hits now) into ``DIR/cases/<label>/``;
4. ``results.csv``/``results.json``, ``temperature_histories.png`` and ``steady_temperature.png``
   are collected; ``study.json`` is written last (a study without it is incomplete).

Parallelism: with ``parallel = "cases"`` every rank runs whole tasks on its own (COMM_SELF, tasks
dealt round-robin); with ``"mpi"`` every task runs on all ranks. ``"auto"`` takes ``"cases"`` for a
stage when it has at least as many tasks as ranks, else ``"mpi"``. Measured on 2 cores (thermal,
24.7k DOFs, 8000 s): 25.9 s on 1 rank, 15.1 s on 2 ranks, i.e. 1.7× from MPI against 2× from
running two cases side by side; see ``docs/study.md`` for the cycle.

Resuming: a case whose ``summary.json`` exists and whose stored ``case.toml`` equals the resolved
case is not recomputed. On a cluster, ``--index I`` runs only task I (e.g. one Slurm array task per
operating point) and ``--collect`` only gathers the table (``docs/study.md``).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import logging
import os
import time
import tomllib
from pathlib import Path
from typing import Any

from mpi4py import MPI

from gearfem import pipeline
from gearfem.config import Case, case_from_dict, case_to_dict, read_toml
from gearfem.core.errors import ParameterError
from gearfem.core.io import write_json
from gearfem.core.params import (
    from_dict,
    require_choice,
    require_nonnegative,
    require_positive,
    to_dict,
)
from gearfem.core.provenance import code_hash
from gearfem.core.results import JsonRecord
from gearfem.geometry.mesh import build_gear_mesh
from gearfem.pipeline import RunSummary
from gearfem.uncertainty import RUN_CODE

log = logging.getLogger(__name__)

PARALLEL = ("auto", "cases", "mpi")


@dataclasses.dataclass(frozen=True)
class StudyOptions:
    """``[study]``: the operating points and how to run them.

    Attributes:
        speeds_rpm: Pinion speeds (rpm); with ``torques_Nm`` they span the full grid.
        torques_Nm: Resisting torques on the wheel (N m).
        points: Extra explicit (speed_rpm, torque_Nm) pairs.
        parallel: ``"cases"`` (independent tasks side by side, one rank each), ``"mpi"`` (each task
        on
            all ranks) or ``"auto"`` (cases when a stage has at least as many tasks as ranks).
        write_fields: Write the VTX temperature fields of every case (large; off by default).
    """

    speeds_rpm: tuple[float, ...] = ()
    torques_Nm: tuple[float, ...] = ()
    points: tuple[tuple[float, float], ...] = ()
    parallel: str = "auto"
    write_fields: bool = False

    def __post_init__(self) -> None:
        for i, s in enumerate(self.speeds_rpm):
            require_nonnegative(f"study.speeds_rpm[{i}]", s)
        for i, t in enumerate(self.torques_Nm):
            require_positive(f"study.torques_Nm[{i}]", t)
        if bool(self.speeds_rpm) != bool(self.torques_Nm):
            raise ParameterError(
                "study.speeds_rpm / study.torques_Nm",
                (list(self.speeds_rpm), list(self.torques_Nm)),
                "both given (a grid) or neither",
            )
        for i, p in enumerate(self.points):
            if len(p) != 2:
                raise ParameterError(f"study.points[{i}]", list(p), "a pair [speed_rpm, torque_Nm]")
            require_nonnegative(f"study.points[{i}][0] (speed_rpm)", p[0])
            require_positive(f"study.points[{i}][1] (torque_Nm)", p[1])
        require_choice("study.parallel", self.parallel, PARALLEL)
        if not self.operating_points():
            raise ParameterError(
                "study", "no operating points", "speeds_rpm and torques_Nm, or points"
            )

    def operating_points(self) -> list[tuple[float, float]]:
        """(speed_rpm, torque_Nm) in a stable order: grid (torque-major), then the explicit points;
        duplicates removed."""
        pts = [(float(s), float(t)) for t in self.torques_Nm for s in self.speeds_rpm]
        pts += [(float(s), float(t)) for s, t in self.points]
        return list(dict.fromkeys(pts))


@dataclasses.dataclass(frozen=True)
class Study:
    name: str
    case: Case
    options: StudyOptions

    def cases(self) -> list[tuple[str, Case]]:
        """(label, case) per operating point."""
        return [
            (case_label(s, t), self.case.with_operating(speed_rpm=s, torque_Nm=t))
            for s, t in self.options.operating_points()
        ]

    def torques(self) -> list[float]:
        return sorted({t for _, t in self.options.operating_points()})


def case_label(speed_rpm: float, torque_Nm: float) -> str:
    return f"n{speed_rpm:g}rpm_T{torque_Nm:g}Nm"


#: The command-line form of a list of operating points.
POINTS_FORM = "'rpm/Nm,rpm/Nm,...' with positive numbers (e.g. '1000/8,2000/4')"


def parse_points(text: str, parameter: str) -> tuple[tuple[float, float], ...]:
    """Operating points (speed_rpm, torque_Nm) from their command-line form ``'1000/8,2000/4'``;
    a malformed list or a point that is not positive is a :class:`ParameterError` naming
    ``parameter`` (the option it came from)."""
    points = []
    for item in text.split(","):
        parts = item.split("/")
        try:
            speed, torque = (float(x) for x in parts)
        except ValueError as e:
            raise ParameterError(parameter, text, POINTS_FORM) from e
        if not (speed > 0 and torque > 0):
            raise ParameterError(parameter, text, POINTS_FORM, f"point {item.strip()!r}")
        points.append((speed, torque))
    return tuple(points)


def study_from_dict(data: dict[str, Any]) -> Study:
    data = dict(data)
    raw = data.pop("study", None)
    if raw is None:
        raise ParameterError("study", None, "a [study] table with speeds_rpm/torques_Nm or points")
    raw = dict(raw)
    if "points" in raw:
        raw["points"] = tuple(
            tuple(p) if isinstance(p, (list, tuple)) else (p,) for p in raw["points"]
        )
    opts = from_dict(StudyOptions, raw, "study")
    case = case_from_dict(data)
    return Study(name=case.name, case=case, options=opts)


def load_study(path: str | Path) -> Study:
    return study_from_dict(read_toml(path, "study file"))


# ------------------------------------------------------------------------------------------------
def parallel_mode(option: str, n_tasks: int, size: int) -> str:
    """How to spread ``n_tasks`` over ``size`` ranks: ``"cases"`` (one task per rank, each on
    COMM_SELF) or ``"mpi"`` (each task on all ranks); ``"auto"`` picks cases when there are at
    least as many tasks as ranks."""
    if option != "auto":
        return option
    return "cases" if size > 1 and n_tasks >= size else "mpi"


def is_done(case: Case, directory: Path, code: dict[str, str] | None = None) -> bool:
    """A finished case: summary.json present, the stored case equal to this one and, with
    ``code`` (module -> code hash, :data:`gearfem.uncertainty.RUN_CODE`), computed by that code
    (its summary's provenance): a case finished by other code is not finished for this one."""
    summ, stored = directory / "summary.json", directory / "case.toml"
    if not (summ.exists() and stored.exists()):
        return False
    try:
        if tomllib.loads(stored.read_text()) != json.loads(json.dumps(case_to_dict(case))):
            return False
        if code is None:
            return True
        prov = json.loads(summ.read_text()).get("provenance") or {}
        return prov.get("code") == code
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, OSError):
        return False


def run_study(
    study: Study,
    out_dir: str | Path,
    comm: MPI.Comm | None = None,
    index: int | None = None,
    collect_only: bool = False,
) -> dict[str, Any]:
    """Run (or resume) a study; returns the collected results (collective).

    Args:
        index: Run only this task (0-based into :meth:`Study.cases`) and do not collect (cluster
            array jobs).
        collect_only: Only gather the table and plots from the finished cases.
    """

    comm = comm or MPI.COMM_WORLD
    out = Path(out_dir)
    cases = study.cases()
    if index is not None and not 0 <= index < len(cases):
        raise ParameterError(
            "--index", index, f"0 .. {len(cases) - 1} (the study has {len(cases)} operating points)"
        )
    if comm.rank == 0:
        (out / "cases").mkdir(parents=True, exist_ok=True)
        stale = out / "study.json"
        if stale.exists() and not collect_only:
            stale.unlink()
    comm.barrier()
    t0 = time.perf_counter()
    timing: dict[str, float] = {}
    ran: list[str] = []
    if not collect_only:
        # which points are finished is decided on rank 0 from its files and broadcast: ranks
        # reading the files each on their own could disagree (a file being written) and then
        # wait in different collectives
        code = {m: code_hash(m) for m in RUN_CODE}  # a case of other code is run again
        done = comm.bcast(
            [is_done(c, out / "cases" / lab, code) for lab, c in cases] if comm.rank == 0 else None,
            root=0,
        )
        todo = [
            (lab, c)
            for i, (lab, c) in enumerate(cases)
            if (index is None or i == index) and not done[i]
        ]
        skipped = len([1 for i, _ in enumerate(cases) if index is None or i == index]) - len(todo)
        if comm.rank == 0:
            log.info(
                "study %s: %d operating points, %d to run, %d finished before",
                study.name,
                len(cases),
                len(todo),
                skipped,
            )
        if todo:
            # 1. meshes on all ranks (the pair for the cycle, one body for the thermal model)
            c0 = todo[0][1]
            if c0.sources.mode == "cycle":
                pipeline.pair_mesh(c0, comm)

            build_gear_mesh(c0.geometry, c0.thermal_mesh_options, comm, bodies=(c0.thermal.body,))
            # 2. one cycle per torque
            if c0.sources.mode == "cycle":
                torques = sorted({c.operating.torque_Nm for _, c in todo})
                reps = {t: next(c for _, c in todo if c.operating.torque_Nm == t) for t in torques}
                mode = parallel_mode(study.options.parallel, len(torques), comm.size)
                t1 = time.perf_counter()
                dispatch(comm, mode, list(reps.values()), lambda c, sub: pipeline.cycle(c, sub))
                timing["cycles_s"] = time.perf_counter() - t1
                timing["cycles_parallel"] = mode  # type: ignore[assignment]
            # 3. thermal + baselines per operating point
            mode = parallel_mode(study.options.parallel, len(todo), comm.size)
            t2 = time.perf_counter()

            def one(item, sub):
                lab, c = item
                pipeline.run(
                    c,
                    out / "cases" / lab,
                    sub,
                    progress=False,
                    write_fields=study.options.write_fields,
                )

            dispatch(comm, mode, todo, one)
            timing["cases_s"] = time.perf_counter() - t2
            timing["cases_parallel"] = mode  # type: ignore[assignment]
            ran = [lab for lab, _ in todo]
    if index is not None:
        comm.barrier()
        return StudyResult(study.name, to_dict(study.options), (), (), False, ran=tuple(ran))
    results = dataclasses.replace(
        collect(study, out, comm),
        ran=tuple(ran),
        wall_time_s=time.perf_counter() - t0,
        timing=timing,
        mpi_size=comm.size,
    )
    if comm.rank == 0:
        write_json(out / "study.json", results)  # last: marks a complete study
    comm.barrier()
    return results


def dispatch(comm: MPI.Comm, mode: str, tasks: list, fn) -> None:
    """Run ``fn(task, comm)`` for every task: all on ``comm`` ("mpi") or dealt round-robin to the
    ranks, each on COMM_SELF ("cases"). Errors on any rank are raised on every rank."""
    if mode == "mpi" or comm.size == 1:
        for t in tasks:
            fn(t, comm)
        return
    error = None
    for i, t in enumerate(tasks):
        if i % comm.size != comm.rank:
            continue
        try:
            fn(t, MPI.COMM_SELF)
        except Exception as err:
            error = err
            break
    errors = comm.allgather(None if error is None else f"{type(error).__name__}: {error}")
    if error is not None:
        raise error
    bad = [e for e in errors if e]
    if bad:
        raise RuntimeError(f"a study task failed on another rank: {bad[0]}")


# ------------------------------------------------------------------------------------------------
COLUMNS = (
    "label",
    "speed_rpm",
    "torque_Nm",
    "status",
    "power_W",
    "friction_W",
    "hysteresis_W",
    "t_end_s",
    "max_surface_end_C",
    "max_surface_steady_C",
    "mean_bulk_end_C",
    "flank_max_end_C",
    "effective_contact_ratio",
    "max_contact_pressure_MPa",
    "vdi2736_flank_C",
    "vdi2736_root_C",
    "mao_bulk_C",
    "wall_time_s",
)


@dataclasses.dataclass(frozen=True)
class StudyRow(JsonRecord):
    """One operating point of a study (a row of ``results.csv``); None where not computed."""

    label: str
    speed_rpm: float
    torque_Nm: float
    status: str  # "done" or "missing"
    power_W: float | None = None
    friction_W: float | None = None  # friction heat into the whole gear
    hysteresis_W: float | None = None
    t_end_s: float | None = None
    max_surface_end_C: float | None = None
    max_surface_steady_C: float | None = None
    mean_bulk_end_C: float | None = None
    flank_max_end_C: float | None = None
    effective_contact_ratio: float | None = None
    max_contact_pressure_MPa: float | None = None
    vdi2736_flank_C: float | None = None
    vdi2736_root_C: float | None = None
    mao_bulk_C: float | None = None
    wall_time_s: float | None = None

    @classmethod
    def of(cls, label: str, speed: float, torque: float, directory: Path) -> StudyRow:
        """The row of the run in ``directory`` (status "missing" without its summary.json)."""
        f = directory / "summary.json"
        if not f.exists():
            return cls(label, speed, torque, "missing")
        s = RunSummary.read(f)
        th, b = s.thermal, s.baselines
        bal = th.get("final_balance_W", {})
        frac = th.get("model_fraction") or 1.0
        final = th.get("final_temperatures_C", {})
        return cls(
            label,
            speed,
            torque,
            "done",
            power_W=b.get("power_W"),
            friction_W=(bal.get("friction_W") or 0.0) / frac,
            hysteresis_W=(bal.get("hysteresis_W") or 0.0) / frac,
            t_end_s=th.get("time_s"),
            max_surface_end_C=final.get("max_surface"),
            max_surface_steady_C=th.get("steady_state_C", {}).get("max_surface"),
            mean_bulk_end_C=final.get("mean_bulk"),
            flank_max_end_C=final.get("flank_max"),
            effective_contact_ratio=s.cycle.effective_contact_ratio if s.cycle else None,
            max_contact_pressure_MPa=s.cycle.max_contact_pressure_MPa if s.cycle else None,
            vdi2736_flank_C=s.headline.vdi2736_flank_C,
            vdi2736_root_C=s.headline.vdi2736_root_C,
            mao_bulk_C=s.headline.mao_bulk_C,
            wall_time_s=s.wall_time_s.get("total_s"),
        )


@dataclasses.dataclass(frozen=True)
class StudyResult(JsonRecord):
    """A collected study (``study.json``, written last)."""

    name: str
    study: dict[str, Any]
    results: tuple[StudyRow, ...]
    missing: tuple[str, ...]
    complete: bool
    ran: tuple[str, ...] = ()
    wall_time_s: float | None = None
    timing: dict[str, Any] | None = None
    mpi_size: int | None = None


def collect(study: Study, out: Path, comm: MPI.Comm) -> dict[str, Any]:
    """Gather the results table and plots (rank 0 writes; returned on every rank)."""
    rows = None
    if comm.rank == 0:
        rows = [
            StudyRow.of(lab, c.operating.speed_rpm, c.operating.torque_Nm, out / "cases" / lab)
            for lab, c in study.cases()
        ]
        tmp = out / f".results.csv.tmp{os.getpid()}"
        with tmp.open("w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=COLUMNS)
            w.writeheader()
            for r in rows:
                row = r.to_json()
                w.writerow({k: "" if row[k] is None else row[k] for k in COLUMNS})
        os.replace(tmp, out / "results.csv")
        try:
            plot_study(rows, out)
        except Exception as err:
            log.warning("study plots failed: %s", err)
    rows = comm.bcast(rows, root=0)
    missing = tuple(r.label for r in rows if r.status != "done")
    return StudyResult(
        name=study.name,
        study=to_dict(study.options),
        results=tuple(rows),
        missing=missing,
        complete=not missing,
    )


def plot_study(rows: list[StudyRow], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    done = [r for r in rows if r.status == "done"]
    if not done:
        return
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for r in done:
        hist = out / "cases" / r.label / "thermal" / "thermal_history.csv"
        if not hist.exists():
            continue
        data = np.genfromtxt(hist, delimiter=",", names=True)
        ax.plot(
            data["time_s"] / 60.0,
            data["T_max_surface_C"],
            label=f"{r.speed_rpm:g} rpm, {r.torque_Nm:g} N m",
        )
    ax.set_xlabel("time (min)")
    ax.set_ylabel("maximum surface temperature (°C)")
    ax.set_title("Maximum surface temperature per operating point")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "temperature_histories.png", dpi=130)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    key = (
        "max_surface_steady_C"
        if all(r.max_surface_steady_C is not None for r in done)
        else "max_surface_end_C"
    )
    for t in sorted({r.torque_Nm for r in done}):
        sel = sorted((r for r in done if r.torque_Nm == t), key=lambda r: r.speed_rpm)
        ax.plot(
            [r.speed_rpm for r in sel],
            [getattr(r, key) for r in sel],
            "o-",
            label=f"{t:g} N m (FE)",
        )
        vdi = [r.vdi2736_flank_C for r in sel]
        if all(v is not None for v in vdi):
            ax.plot(
                [r.speed_rpm for r in sel],
                vdi,
                "x--",
                color=ax.lines[-1].get_color(),
                alpha=0.6,
                label=f"{t:g} N m (VDI 2736 flank)",
            )
    ax.set_xlabel("pinion speed (rpm)")
    ax.set_ylabel(
        "steady maximum surface temperature (°C)"
        if key.endswith("steady_C")
        else "maximum surface temperature at the end (°C)"
    )
    ax.set_title("Operating temperature over speed and torque")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "steady_temperature.png", dpi=130)
    plt.close(fig)
