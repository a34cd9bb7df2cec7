"""The thesis bench points as the bench measured them: the IR camera's reading.

Runs the built-in case (or ``--case``) at the two bench points of
``gearfem/data/testbench/thesis_testbench.csv`` (shipped with gearfem; 1000 rpm / 8 N m and
2000 rpm / 4 N m) with
``gearfem run`` (both gears' thermal models, the FLIR E40 of ``[instruments.camera]``, the torque
meters), or reuses a finished run of the same case in ``OUT/<label>``, and reports the predicted
``camera_max`` at 900 s (when the bench was read) and at the steady state next to the bench's
reading and the model's hottest nodes. Writes the table into docs/reproduction.md (block
``bench_camera``) and the thermograms at 900 s into docs/images/.

With ``--diagnose DIAG_CASE.toml`` it also runs ``gearfem diagnose`` on the bench file against
that case (the bench read as ``camera_max``) into ``OUT/bench_diagnosis`` and writes its V&V 20
table and verdict into docs/diagnosis.md (block ``bench_camera_diagnosis``).

With ``--verdict`` (issue 16, second round) it runs ``gearfem diagnose --suggest`` on the bench
file against ``--case`` (default: the built-in case, whose refinement studies give u_num) into
``OUT/bench_verdict``, compares the baseline's hottest nodes with its camera reading (how much of
the gap the instrument model closes), and writes the verdict, ranking, gain and the suggested
measurements into docs/diagnosis.md (block ``bench_verdict``) with its plots in
docs/images/diagnosis/bench_verdict_*.png. With ``--pass-balance tooth --flash-half-width-um
W`` the verdict is taken on the model whose switching temperature converges (each gear's pass of
the contact history balanced to its tooth pair's load, every flash on a stated half-width W;
docs/friction.md, "The switching temperature, width by width") and written into the block
``bench_verdict_balanced`` (plots ``bench_verdict_balanced_*.png``) instead.

Run (each point's structural cycle is cached after its first run):
    mpirun -n 2 python demos/bench_camera.py [--case CASE.toml] [--out results]
        [--diagnose DIAG_CASE.toml] [--verdict --skip-runs]
        [--pass-balance tooth --flash-half-width-um 100]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shutil
from importlib import resources
from pathlib import Path

import numpy as np
from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import case_to_dict, load_case
from gearfem.core.doctables import Provenance, markdown_table, replace_block
from gearfem.core.errors import ParameterError
from gearfem.core.io import read_json
from gearfem.core.log import setup_logging
from gearfem.diagnose.data import Dataset, camera_uncertainty_K, read_csv
from gearfem.diagnose.design import Grid, bench_grid, check_grid
from gearfem.diagnose.forward import FullModel
from gearfem.diagnose.margins import markdown as margins_markdown
from gearfem.diagnose.report import (
    DiagnosisReport,
    design_case,
    run_diagnosis,
    suggestion_markdown,
    winner_params,
)
from gearfem.diagnose.vv20 import TABLE_HEAD
from gearfem.pipeline import RunSummary
from gearfem.study import parse_points
from gearfem.uncertainty import DIAGNOSIS_CODE, provenance

ROOT = Path(__file__).resolve().parent.parent
#: The bench measurements gearfem ships (package data; no file outside the clone is read).
BENCH = Path(str(resources.files("gearfem") / "data" / "testbench" / "thesis_testbench.csv"))


@dataclasses.dataclass(frozen=True)
class VerdictModel:
    """The model a verdict is taken on: the case's own (``pass_balance`` None) or the case with
    ``[friction] pass_balance`` and a stated flash half-width (um), and the docs block it goes
    to."""

    pass_balance: str | None = None
    flash_half_width_um: float | None = None

    def __post_init__(self) -> None:
        if (self.pass_balance is None) != (self.flash_half_width_um is None):
            raise ParameterError(
                "--flash-half-width-um",
                self.flash_half_width_um,
                "given exactly when --pass-balance is (the balanced model): --pass-balance = "
                f"{self.pass_balance!r}",
            )

    @property
    def block(self) -> str:
        return "bench_verdict" if self.pass_balance is None else "bench_verdict_balanced"

    @property
    def flags(self) -> str:
        if self.pass_balance is None:
            return ""
        return (
            f" --pass-balance {self.pass_balance} "
            f"--flash-half-width-um {self.flash_half_width_um:g}"
        )

    @property
    def describe(self) -> str:
        if self.pass_balance is None:
            return ""
        return (
            f"; friction heat with pass_balance {self.pass_balance!r} and every flash on a stated "
            f"half-width of {self.flash_half_width_um:g} um"
        )

    def demote(self, lines: list[str]) -> list[str]:
        """``lines`` with their ``##`` headings two levels down in the balanced model's block
        (a subsection of the page's bench section)."""
        if self.pass_balance is None:
            return lines
        return ["##" + ln if ln.startswith("## ") else ln for ln in lines]

    def apply(self, case):
        if self.pass_balance is None:
            return case
        fr = dataclasses.replace(
            case.friction,
            pass_balance=self.pass_balance,
            flash_width="stated",
            flash_half_width_um=self.flash_half_width_um,
        )
        return dataclasses.replace(case, friction=fr)


def _run(case, out: Path, comm) -> RunSummary:
    """The run of ``case`` in ``out``: reused when finished with the same case by the current
    code (its recorded provenance: resolution key and code hash), else computed."""
    done = False
    if comm.rank == 0 and (out / "summary.json").is_file() and (out / "case.toml").is_file():
        try:
            same_case = case_to_dict(load_case(out / "case.toml")) == case_to_dict(case)
        except ParameterError:  # a case file of another gearfem version: run again
            same_case = False
        recorded = _provenance(RunSummary.read(out / "summary.json").provenance)
        now = provenance(case)
        done = (
            same_case
            and recorded is not None
            and (recorded.resolution, recorded.code) == (now.resolution, now.code)
        )
    if comm.bcast(done, root=0):
        return RunSummary.read(out / "summary.json")
    return pipeline.run(case, out, comm, progress=False)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--case", default=None, help="case TOML (default: the built-in thesis case)")
    p.add_argument("--out", default=str(ROOT / "results"), help="where the runs go")
    p.add_argument("--no-doc", action="store_true", help="do not write into docs/")
    p.add_argument("--diagnose", default=None, help="also diagnose the bench against this case")
    p.add_argument(
        "--verdict",
        action="store_true",
        help="second-round verdict with --suggest against --case (default: built-in case)",
    )
    p.add_argument(
        "--suggest-points",
        default=None,
        help="with --verdict: the design grid's speeds and torques, 'rpm,rpm/Nm,Nm' "
        "(default: the bench grid of gearfem.diagnose.design)",
    )
    p.add_argument(
        "--confirm",
        default=None,
        help="after --verdict: the winner (at its value and interval edges) and the runner-up "
        "on the full model at these operating points, 'rpm/Nm,rpm/Nm,...'",
    )
    p.add_argument(
        "--reproduce",
        action="store_true",
        help="after --verdict: gearfem run on the winner's case files at the bench points, "
        "into README.md (block readme_verdict)",
    )
    p.add_argument(
        "--pass-balance",
        choices=("tooth",),  # the balanced model; "cycle" is the default model's own
        default=None,
        help="with --verdict: the model's [friction] pass_balance (with --flash-half-width-um; "
        "block bench_verdict_balanced)",
    )
    p.add_argument(
        "--flash-half-width-um",
        type=float,
        default=None,
        help="with --verdict: every flash on this stated half-width ([friction] flash_width = "
        '"stated")',
    )
    p.add_argument("--skip-runs", action="store_true", help="only the diagnosis")
    a = p.parse_args()
    model = VerdictModel(a.pass_balance, a.flash_half_width_um)
    setup_logging()  # $GEARFEM_LOG_LEVEL or INFO, rank 0
    comm = MPI.COMM_WORLD
    if a.diagnose:
        diagnosis(a.diagnose, Path(a.out) / "bench_diagnosis", comm, doc=not a.no_doc)
    if a.verdict:
        verdict(a.case, Path(a.out) / "bench_verdict", comm, not a.no_doc, a.suggest_points, model)
    if a.confirm:
        confirm(a.case, Path(a.out) / "bench_verdict", comm, not a.no_doc, a.confirm)
    if a.reproduce:
        reproduce(Path(a.out) / "bench_verdict", comm, not a.no_doc)
    if a.skip_runs:
        return
    base = load_case(a.case)
    bench = read_csv(BENCH)
    rows, provs = [], []
    for m in bench.measurements:
        label = f"bench_{m.speed_rpm:g}rpm_{m.torque_Nm:g}Nm"
        case = base.with_operating(speed_rpm=m.speed_rpm, torque_Nm=m.torque_Nm)
        s = _run(case, Path(a.out) / label, comm)
        provs.append(_provenance(s.provenance))
        ins = s.instruments
        at = "900" if "900" in ins.camera else "end"
        cam = ins.camera[at]
        steady = ins.camera.get("steady")
        th_at = s.thermal["at_times_C"].get(at, s.thermal["final_temperatures_C"])
        other = s.thermal_other or {}
        oth_at = other.get("at_times_C", {}).get(at, other.get("final_temperatures_C", {}))
        top = ", ".join(f"{k} {v:.0%}" for k, v in list(cam.surface_fractions.items())[:3])
        rows.append(
            (
                f"{m.speed_rpm:g} rpm, {m.torque_Nm:g} N m",
                f"{m.value:.0f} ± {m.uncertainty:.1f}",
                f"**{cam.max_C:.1f}**",
                f"{cam.frame_max_range_C[0]:.1f}-{cam.frame_max_range_C[1]:.1f}",
                f"{steady.max_C:.1f}" if steady else "",
                top,
                f"{th_at['max_surface']:.1f}",
                f"{oth_at.get('max_surface', float('nan')):.1f}",
                f"{th_at['mean_bulk']:.1f}",
                f"{ins.torque.torque_loss_Nm:.3f} ± {ins.torque.u_torque_loss_Nm:.3f}"
                if ins.torque
                else "",
                f"{ins.torque.efficiency:.4f}" if ins.torque else "",
            )
        )
        if comm.rank == 0 and not a.no_doc:
            src = Path(a.out) / label / "instruments" / f"thermogram_{at}.png"
            shutil.copyfile(src, ROOT / "docs" / "images" / f"thermogram_{label}.png")
    table = markdown_table(
        (
            "bench point",
            "bench camera (C)",
            "camera_max 900 s (C)",
            "frames (C)",
            "camera_max steady (C)",
            "hottest pixel sees",
            "max node pinion (C)",
            "max node wheel (C)",
            "bulk pinion (C)",
            "torque loss (N m)",
            "efficiency",
        ),
        rows,
    )
    note = (
        f"\n\nCase {base.name!r}; camera: {base.instruments.camera.view} view, "
        f"{base.instruments.camera.distance_m:g} m, emissivity setting "
        f"{base.instruments.camera.emissivity_setting:g}, reflected "
        f"{base.instruments.camera.reflected_C:g} C; bench uncertainty as in docs/diagnosis.md. "
        f"Measured by `mpirun -n {comm.size} python demos/bench_camera.py` "
        f"(1-minute load average {os.getloadavg()[0]:.1f} at the end)."
    )
    if comm.rank == 0:
        print(table + note)
        if not a.no_doc:
            prov = provs[0]
            if prov is not None and all(p is not None for p in provs):
                code = {k: v for p in provs for k, v in p.code.items()}
                prov = Provenance(prov.resolution, code, prov.commit, prov.date)
            replace_block(ROOT / "docs" / "reproduction.md", "bench_camera", table + note, prov)


def _relative(path: Path) -> str:
    try:
        return str(Path(path).resolve().relative_to(ROOT))
    except ValueError:
        return str(path)


def diagnosis(case_path: str, out: Path, comm, doc: bool) -> None:
    """``gearfem diagnose`` of the bench file (as camera_max) against a case; its V&V 20 table
    and verdict into docs/diagnosis.md."""
    case = load_case(case_path)
    data = read_csv(BENCH)
    r = run_diagnosis(data, case, out, comm, max_size=1)
    table = markdown_table(TABLE_HEAD, [row.cells() for row in r.vv20.rows])
    parts = "; ".join(
        f"{k}: {', '.join(f'{v:.2f}' for v in vals)} K" for k, vals in r.vv20.u_input_parts.items()
    )
    g = r.diagnosis.gain
    fit = r.diagnosis.chosen_fit
    # the value the verdict quotes: the full-model refined one where the chosen model was refined
    params = r.diagnosis.refined.params if r.diagnosis.refined is not None else fit.params
    ps = ", ".join(f"{n} = {params[n]:.4g}" for n in fit.candidates) or "none"
    fmt = lambda x: "n/a" if x is None else f"{x:.1f} K"
    text = (
        f"{table}\n\nCase {case.name!r} ({case_path}), thermal degree {case.thermal.degree}; "
        f"u_num: {r.vv20.u_num_method}; u_input parts: {parts}.\n\n"
        f"**Verdict: {r.diagnosis.verdict.text}** Chosen: {fit.label} ({ps}); held-out RMS "
        f"error {fmt(g.loo_rmse_before_K)} before, {fmt(g.loo_rmse_after_K)} after"
        f"{g.other_units_text()}. Measured by "
        f"`mpirun -n {comm.size} python demos/bench_camera.py --diagnose {case_path} --skip-runs`"
        f" (report: {_relative(out)}/report.md)."
    )
    if comm.rank == 0:
        print(text)
        if doc:
            replace_block(
                ROOT / "docs" / "diagnosis.md",
                "bench_camera_diagnosis",
                text,
                _provenance(r.provenance),
            )


def _grid(case, points: str | None) -> Grid | None:
    """The design grid of ``--suggest-points`` ('rpm,rpm/Nm,Nm'), None for the default."""
    if points is None:
        return None
    try:
        speeds, torques = (tuple(float(x) for x in part.split(",")) for part in points.split("/"))
    except ValueError as e:
        raise ParameterError("--suggest-points", points, "'rpm,rpm,.../Nm,Nm,...'") from e
    quantities = tuple(q for q in design_case(case).instruments.quantities if q != "efficiency")
    base = bench_grid(quantities)
    return check_grid(
        dataclasses.replace(
            base, speeds_rpm=speeds, torques_Nm=torques, source="given on the command line"
        )
    )


def verdict(
    case_path: str | None,
    out: Path,
    comm,
    doc: bool,
    points: str | None = None,
    model: VerdictModel = VerdictModel(),
) -> None:
    """Issue 16's second round: ``gearfem diagnose --suggest`` of the bench (as camera_max)
    against ``case_path`` (None: the built-in case) as ``model`` sets it; its verdict, the
    instrument model's share of the gap, the ranking and the suggested measurements into
    docs/diagnosis.md (block ``model.block``), its plots into docs/images/diagnosis/."""
    case = model.apply(load_case(case_path))
    data = read_csv(BENCH)
    grid = _grid(case, points)
    r = run_diagnosis(data, case, out, comm, max_size=2, suggest_next=True, grid=grid)
    d = r.diagnosis
    # the baseline's hottest node (pinion): what gearfem compared before the instrument models
    rows = tuple(dataclasses.replace(m, quantity="max_surface") for m in data.measurements)
    hot = FullModel(case, comm).predict(Dataset(rows, "hottest node"), {})
    vv = r.vv20.rows
    fit = d.chosen_fit
    ref = d.refined
    after = ref.full_C if ref is not None and ref.full_C is not None else fit.predictions_C
    head = (
        "bench point",
        "bench camera (C)",
        "hottest node, pinion (C)",
        "camera_max baseline (C)",
        "u_val (K)",
        f"camera_max, {fit.label} (C)",
    )
    rows = []
    for i, m in enumerate(data.measurements):
        row = [
            f"{m.speed_rpm:g} rpm, {m.torque_Nm:g} N m",
            f"{m.value:.0f} ± {m.uncertainty:.1f}",
            f"{hot[i]:.1f}",
            f"{vv[i].S:.1f}",
            f"{vv[i].u_val:.1f}",
            f"{after[i]:.1f}",
        ]
        rows.append(tuple(row))
    table = markdown_table(head, rows)
    gap_hot = [float(hot[i] - m.value) for i, m in enumerate(data.measurements)]
    gap_cam = [row.E for row in vv]
    ranking = markdown_table(
        ("model", "parameter (95 % profile interval, surrogate)", "chi2", f"Δ{d.criterion}"),
        [
            (
                m.label,
                ", ".join(
                    f"{n} = {m.params[n]:.3g}"
                    + (
                        f" [{m.intervals[n][0]:.3g}, {m.intervals[n][1]:.3g}]"
                        if n in m.intervals
                        else ""
                    )
                    + (
                        f" (range, threshold scaled x{m.interval_scale:.3g}: fails chi2)"
                        if m.interval_scale > 1 and n in m.intervals
                        else ""
                    )
                    for n in m.candidates
                )
                or "-",
                f"{m.chi2:.1f}",
                f"{m.delta:.1f}",
            )
            for m in d.models
            if len(m.candidates) <= 1
        ][:11],
    )
    g = d.gain
    fmt = lambda x: "n/a" if x is None else f"{x:.1f} K"
    closes = "; ".join(
        f"{m.speed_rpm:g} rpm / {m.torque_Nm:g} N m: hottest node {gh:+.1f} K, camera {gc:+.1f} K"
        for m, gh, gc in zip(data.measurements, gap_hot, gap_cam, strict=True)
    )
    images = ("prediction_vs_data", "ranking", "suggestion")
    text = "\n".join(
        [
            table,
            "",
            f"Case {case.name!r} ({case_path or 'built-in'}{model.describe}), thermal degree "
            f"{case.thermal.degree}; u_num: {r.vv20.u_num_method}. Model minus bench, "
            f"{closes}.",
            "",
            f"**Verdict: {d.verdict.text}** Held-out RMS error {fmt(g.loo_rmse_before_K)} "
            f"before, {fmt(g.loo_rmse_after_K)} after; in-sample {fmt(g.rmse_before_K)} before, "
            f"{fmt(g.rmse_after_K)} after on the surrogate"
            + (
                f", {fmt(d.refined.full_rmse_K)} on the full model at the refined value"
                if d.refined is not None and d.refined.full_rmse_K is not None
                else ""
            )
            + g.other_units_text()
            + ".",
            "",
            "Single candidates, ranked (pairs have as many parameters as the bench has data and "
            "are not ranked):",
            "",
            ranking,
            *(
                [
                    "",
                    "**Fold margins** (the branch each bench point lands on: the distance to "
                    "the fold where its gear's cool branch ends, gearfem.diagnose.margins):",
                    "",
                    margins_markdown(r.fold_margins),
                ]
                if r.fold_margins
                else []
            ),
            *(model.demote(suggestion_markdown(r.suggestion)) if r.suggestion is not None else []),
            "",
            *(
                f"![{n}](images/diagnosis/{model.block}_{n}.png)\n"
                for n in images
                if (out / f"{n}.png").is_file()
            ),
            f"Measured by `mpirun -n {comm.size} python demos/bench_camera.py --verdict "
            f"--skip-runs{' --case ' + case_path if case_path else ''}{model.flags}"
            f"{' --suggest-points ' + points if points else ''}` (report: "
            f"{_relative(out)}/report.md; {r.surrogate['full_model_solves']} full-model solves "
            f"for the diagnosis' surrogate; 1-minute load average {os.getloadavg()[0]:.1f} at "
            "the end).",
        ]
    )
    if comm.rank == 0:
        print(text)
        if doc:
            for n in images:
                page_image = ROOT / "docs" / "images" / "diagnosis" / f"{model.block}_{n}.png"
                if (out / f"{n}.png").is_file():
                    shutil.copyfile(out / f"{n}.png", page_image)
                else:  # this diagnosis drew none (a suggestion with nothing to separate)
                    page_image.unlink(missing_ok=True)
            replace_block(
                ROOT / "docs" / "diagnosis.md", model.block, text, _provenance(r.provenance)
            )


def _provenance(data: dict | None) -> Provenance | None:
    """The provenance a diagnosis or run recorded (gearfem.uncertainty.provenance), for its
    quoted blocks."""
    return None if data is None else Provenance(**data)


def reproduce(out: Path, comm, doc: bool) -> None:
    """The verdict reproduced the way a user would: ``gearfem run`` on each case file the
    diagnosis wrote for its winner (``OUT/bench_verdict/winner_<rpm>rpm_<Nm>Nm.toml``), the
    camera's steady reading next to the diagnosis's and the bench's. README.md block
    ``readme_verdict``."""
    rep = DiagnosisReport.from_json(read_json(out / "diagnosis.json"))
    d = rep.diagnosis
    data = read_csv(BENCH)
    fmt = lambda x: "n/a" if x is None else f"{x:.1f} K"
    g = d.gain
    if not d.chosen:
        text = (
            f"**The bench diagnosis on the shipped model**: {d.verdict.text} Held-out error "
            f"{fmt(g.loo_rmse_before_K)} before, {fmt(g.loo_rmse_after_K)} after"
            f"{g.other_units_text()}. Details: [docs/diagnosis.md](docs/diagnosis.md)."
        )
        prov = _provenance(rep.provenance)
    else:
        params = winner_params(d)
        after = (
            d.refined.full_C
            if d.refined is not None and d.refined.full_C
            else (d.chosen_fit.predictions_C)
        )
        rows, provs = [], []
        for i, m in enumerate(data.measurements):
            name = f"winner_{m.speed_rpm:g}rpm_{m.torque_Nm:g}Nm.toml"
            run_out = out / name.removesuffix(".toml")
            s = _run(load_case(out / name), run_out, comm)
            provs.append(s.provenance)
            cam = s.instruments.camera
            steady = cam.get("steady")
            reading = steady.max_C if steady is not None else float("nan")
            vv = rep.vv20.rows[i]
            rows.append(
                (
                    f"{m.speed_rpm:g} rpm, {m.torque_Nm:g} N m",
                    f"{m.value:.0f} ± {m.uncertainty:.1f}",
                    f"{after[i]:.1f}",
                    f"`gearfem run {_relative(out)}/{name}`",
                    f"{reading:.1f}",
                    f"{vv.u_val:.1f}",
                )
            )
        table = markdown_table(
            (
                "bench point",
                "bench camera (C)",
                "diagnosis (C)",
                "reproduce",
                "gearfem run: camera_max, steady (C)",
                "u_val (K)",
            ),
            rows,
        )
        label = ", ".join(f"{k} = {v:.3g}" for k, v in params.items())
        iv = d.refined.intervals if d.refined is not None else d.chosen_fit.intervals
        ivs = ", ".join(f"[{iv[k][0]:.3g}, {iv[k][1]:.3g}]" for k in params if k in iv)
        fragile = [m for m in rep.fold_margins if m.fragile]
        robust = (
            "**fragile**: "
            + "; ".join(
                f"{m.speed_rpm:g} rpm / {m.torque_Nm:g} N m, {m.gear}, within "
                f"{abs(m.margin):.3g} {m.unit} of its fold in {m.parameter} "
                f"(uncertainty ± {m.uncertainty:.3g})"
                for m in fragile
            )
            if fragile
            else (
                "robust: every fold lies beyond its parameter's uncertainty"
                if rep.fold_margins
                else "one steady state at each point (no folds)"
            )
        )
        text = (
            f"**The bench diagnosis on the shipped model**: {d.verdict.text}\n\n"
            + (
                f"Winner {label} (95 % interval {ivs}); held-out error "
                if d.verdict.kind == "identified"
                else f"The best candidate on the surrogate, {label}, is no explanation (the "
                "verdict above); held-out error "
            )
            + f"{fmt(g.loo_rmse_before_K)} before, {fmt(g.loo_rmse_after_K)} after"
            f"{g.other_units_text()}; fold margins "
            f"{robust}. Each bench point reproduced with `gearfem run` on the case file the "
            f"diagnosis writes for that value:\n\n{table}\n\n"
            "Details, the ranking, the margins and what to measure next: "
            "[docs/diagnosis.md](docs/diagnosis.md)."
        )
        prov = _provenance(provs[0]) if provs and provs[0] else _provenance(rep.provenance)
        if prov is not None and rep.provenance:
            prov = Provenance(
                prov.resolution,
                {**prov.code, **Provenance(**rep.provenance).code},
                prov.commit,
                prov.date,
            )
    if comm.rank == 0:
        print(text)
        if doc:
            replace_block(ROOT / "README.md", "readme_verdict", text, prov)


def confirm(case_path: str | None, out: Path, comm, doc: bool, points: str) -> None:
    """The finished verdict's winner (refined value and its interval edges) and the runner-up
    (the best other single candidate) run on the full model at ``points`` ('rpm/Nm,...'), read
    by the camera, a web thermocouple and the torque meters: where the two explanations'
    readings differ by several of the camera's uncertainties, a measurement decides between
    them (needed when only one explanation stands and ``--suggest``'s information gain, which
    weighs the runner-up by its Akaike weight, has nothing left to gain). Block
    ``bench_verdict_confirm`` of docs/diagnosis.md."""
    pts = parse_points(points, "--confirm")
    case = design_case(load_case(case_path))
    rep = DiagnosisReport.from_json(read_json(out / "diagnosis.json"))
    d = rep.diagnosis
    if d.refined is None:
        raise ParameterError(
            "diagnosis.json", str(out), "a diagnosis whose chosen model was refined"
        )
    (name,) = d.chosen
    lo, hi = d.refined.intervals[name]
    best = d.refined.params[name]
    rival = next(m for m in d.models if len(m.candidates) == 1 and m.candidates != d.chosen)
    amb = read_csv(BENCH).measurements[0].ambient_C
    qs = ("camera_max", "probe:web", "torque_loss_Nm")
    full = FullModel(case, comm, quantities=qs)
    models = {
        f"{name} = {lo:.3g}": {name: lo},
        f"{name} = {best:.3g}": {name: best},
        f"{name} = {hi:.3g}": {name: hi},
        f"{rival.label} = {rival.params[rival.label]:.3g}": dict(rival.params),
    }
    rows = []
    for sp, tq in pts:
        got = {k: full.evaluate(sp, tq, amb, m) for k, m in models.items()}
        cams = [got[k][("camera_max", None)] for k in models]
        winner = cams[:3]
        u = camera_uncertainty_K(float(np.mean(cams)))
        gap = min(abs(cams[3] - w) for w in winner) / u
        rows.append(
            (
                f"{sp:g} rpm, {tq:g} N m",
                *(
                    f"{got[k][('camera_max', None)]:.1f} / {got[k][('probe:web', None)]:.1f} / "
                    f"{got[k][('torque_loss_Nm', None)]:.3f}"
                    for k in models
                ),
                f"{gap:.1f}",
            )
        )
    table = markdown_table(
        ("operating point", *models, "camera: rival vs winner's nearest (u)"), rows
    )
    text = (
        f"{table}\n\nEach cell: camera_max (C) / web thermocouple probe:web (C) / torque loss "
        f"(N m), end values (steady state; for the glass step the one the transient from ambient "
        f"reaches), ambient {amb:g} C, on the full model (case {case.name!r}). Last column: "
        "the smallest difference between the runner-up's camera reading and the winner's over "
        "its 95 % interval, in units of the camera's stated uncertainty (FLIR E40 with 2 K for "
        "the read-off, as the bench data). Measured by `mpirun -n "
        f"{comm.size} python demos/bench_camera.py --confirm {points}`."
    )
    if comm.rank == 0:
        print(text)
        if doc:
            replace_block(
                ROOT / "docs" / "diagnosis.md",
                "bench_verdict_confirm",
                text,
                provenance(load_case(case_path), DIAGNOSIS_CODE),
            )


if __name__ == "__main__":
    main()
