"""Outputs of a thermal run: CSV time series, VTX fields, a plot of T versus time, a JSON summary.

Files in the output directory (rank 0 writes; fields are written collectively):

* ``thermal_history.csv`` — one row per accepted step: time, step size, Newton iterations,
  error estimate, temperatures in C (max surface, mean bulk, monitored surfaces mean/max) and
  the heat balance in W (generated = hysteresis + friction + volumetric; stored, convected,
  radiated, bore, imbalance). Written as ``.partial`` during the run and renamed at the end.
* ``temperature.bp`` — VTX (ADIOS2) temperature field in C at the output times.
* ``thermal_history.png`` — temperatures versus time.
* ``thermal_summary.json`` — written last; its presence marks a complete run.
"""

from __future__ import annotations

import csv
import json
import logging
import math
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from gearfem.core.materials import ZERO_CELSIUS_K
from gearfem.thermal.branches import lowest_steady_state
from gearfem.thermal.problem import StepRecord, ThermalProblem

CSV_NAME = "thermal_history.csv"
SUMMARY_NAME = "thermal_summary.json"
PLOT_NAME = "thermal_history.png"
FIELD_NAME = "temperature.bp"

log = logging.getLogger(__name__)


class ThermalWriter:
    """Observer for :meth:`ThermalProblem.run` writing the files above into ``out_dir``.

    Use as a context manager; :meth:`finish` writes the plot and the summary (the completion
    marker).
    """

    def __init__(
        self, out_dir: str | Path, problem, write_fields: bool = True, write_plot: bool = True
    ) -> None:
        self.write_plot = write_plot
        from dolfinx import fem

        self.out = Path(out_dir)
        self.comm = problem.comm
        self.rank = self.comm.rank
        if self.rank == 0:
            self.out.mkdir(parents=True, exist_ok=True)
            for name in (SUMMARY_NAME, CSV_NAME):  # a stale marker must not survive a new run
                (self.out / name).unlink(missing_ok=True)
        self.comm.barrier()
        self._rows: list[dict[str, Any]] = []
        self._csv_file = None
        self._csv_writer = None
        self._vtx = None
        if write_fields:
            from dolfinx.io import VTXWriter

            self._T_C = fem.Function(problem.V, name="temperature_C")
            self._vtx = VTXWriter(self.comm, str(self.out / FIELD_NAME), [self._T_C], engine="BP4")

    def __enter__(self) -> ThermalWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def on_step(self, problem, record, write_field: bool) -> None:
        row = record.row()
        self._rows.append(row)
        if self.rank == 0:
            if self._csv_writer is None:
                self._csv_file = open(self.out / (CSV_NAME + ".partial"), "w", newline="")  # noqa: SIM115
                self._csv_writer = csv.DictWriter(self._csv_file, fieldnames=list(row))
                self._csv_writer.writeheader()
            self._csv_writer.writerow({k: _fmt(v) for k, v in row.items()})
            self._csv_file.flush()
        if write_field and self._vtx is not None:
            self._T_C.x.array[:] = problem.T.x.array - ZERO_CELSIUS_K
            self._vtx.write(record.time_s)

    def close(self) -> None:
        if self._vtx is not None:
            self._vtx.close()
            self._vtx = None
        if self._csv_file is not None:
            self._csv_file.close()
            self._csv_file = None

    def finish(self, summary: dict[str, Any]) -> None:
        """Close files, rename the CSV, plot, write the summary last."""
        self.close()
        if self.rank == 0:
            partial = self.out / (CSV_NAME + ".partial")
            if partial.exists():
                os.replace(partial, self.out / CSV_NAME)
            if self.write_plot:
                plot_history(self._rows, self.out / PLOT_NAME, title=summary.get("title", ""))
            tmp = self.out / (SUMMARY_NAME + ".partial")
            tmp.write_text(json.dumps(_jsonable(summary), indent=2))
            os.replace(tmp, self.out / SUMMARY_NAME)
        self.comm.barrier()


def _fmt(v: Any) -> Any:
    return f"{v:.10g}" if isinstance(v, float) else v


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def plot_history(rows: list[dict[str, Any]], path: Path, title: str = "") -> None:
    """Temperatures (C) of every ``T_*_C`` column versus time: linear and logarithmic time axes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not rows:
        return
    t = [r["time_s"] for r in rows]
    fig, axes = plt.subplots(1, 2, figsize=(12, 5), sharey=True)
    for ax, log in zip(axes, (False, True)):
        for key in rows[0]:
            if key.startswith("T_") and key.endswith("_C"):
                style = "-" if key in ("T_max_surface_C", "T_mean_bulk_C") else "--"
                pts = [(ti, r[key]) for ti, r in zip(t, rows) if ti > 0 or not log]
                if pts:
                    ax.plot(
                        *zip(*pts),
                        style,
                        marker="o" if len(pts) == 1 else None,
                        label=key[2:-2].replace("_", " "),
                    )
        ax.set_xlabel("time (s)" + (", log scale" if log else ""))
        if log and any(ti > 0 for ti in t):
            ax.set_xscale("log")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("temperature (C)")
    axes[0].legend(fontsize=8, ncol=2)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def summary(problem, records, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """JSON-able summary: final temperatures, step statistics, balance closure, model set-up."""
    last = records[-1]
    steps = [r for r in records if r.step > 0]
    rel = [r.balance.relative_imbalance for r in steps]
    out: dict[str, Any] = {
        "complete": True,
        "time_s": last.time_s,
        "steps": len(steps),
        "newton_iterations": sum(r.newton_iterations for r in steps),
        "dofs": problem.num_dofs,
        # the size of the solved systems: the DOFs less a periodic sector's tied end face
        "unknowns": problem.num_unknowns,
        "periodic_cuts": problem.domain.periodic is not None,
        "degree": problem.options.degree,
        "ranks": problem.comm.size,
        "final_temperatures_C": {k: v - ZERO_CELSIUS_K for k, v in last.temperatures_K.items()},
        "final_balance_W": last.balance.as_dict(),
        "max_relative_imbalance": max(rel) if rel else 0.0,
        "model_fraction": problem.domain.model_fraction,
        "boundary": {
            role: {
                "h_W_m2K": (None if callable(ex.h_W_m2K) else ex.h_W_m2K),
                "h_depends_on_T": callable(ex.h_W_m2K),
                "fluid_C": ex.fluid_K - ZERO_CELSIUS_K,
                "emissivity": ex.emissivity,
            }
            for role, ex in problem.boundary.exchanges().items()
        },
        "convection_correlations": (
            problem.boundary.convection.as_dict() if problem.boundary.convection else None
        ),
    }
    stats = problem.transient_statistics
    if stats is not None:
        # the transient Newton solver's counts and this rank's seconds (where the run's time went)
        out["transient_solver"] = stats.as_dict()
    if extra:
        out.update(extra)
    return out


class _Observers:
    """Several observers of :meth:`ThermalProblem.integrate` as one (called in order)."""

    def __init__(self, *observers) -> None:
        self.observers = observers

    def on_step(self, problem, record, write_field: bool) -> None:
        for ob in self.observers:
            ob.on_step(problem, record, write_field)


def solve_and_write(
    problem: ThermalProblem,
    out_dir: str | Path,
    extra: dict[str, Any] | None = None,
    write_fields: bool = True,
    more: Callable[[list[StepRecord]], dict[str, Any]] | None = None,
    write_plot: bool = True,
    observers: tuple = (),
) -> tuple[list[StepRecord], dict[str, Any]]:
    """Solve (transient or steady, as ``problem.options.mode`` says) and write CSV, VTX, plot,
    summary.

    ``extra`` and ``more(records)`` (computed after the run, collectively) are added to the
    summary. ``observers`` are told every step after the writer (``on_step(problem, record,
    write_field)``; ``write_field`` is true at the output times and the end). The summary
    (``thermal_summary.json``) is written last: a run that fails leaves none.
    """
    t0 = time.perf_counter()
    with ThermalWriter(
        out_dir, problem, write_fields=write_fields, write_plot=write_plot
    ) as writer:
        observer = _Observers(writer, *observers)
        lowest = None
        if problem.options.mode == "steady":
            if problem.sources.flank_flux_may_rise:
                # several steady states may exist: the one a run from ambient reaches
                rec, lowest = lowest_steady_state(problem)
            else:
                rec = problem.solve_steady()
            observer.on_step(problem, rec, write_field=True)
            records = [rec]
        else:
            records = problem.integrate(observer=observer)
        info = {"wall_time_s": time.perf_counter() - t0, "mode": problem.options.mode}
        if lowest is not None:
            info["steady_state_search"] = lowest.to_json()
        info.update(extra or {})
        if more is not None:
            info.update(more(records))
        summ = summary(problem, records, info)
        writer.finish(summ)
    last = records[-1]
    log.info(
        "thermal %s: t = %g s, %d steps, T_max surface %.2f C, mean bulk %.2f C, max |imbalance| "
        "%.2e, "
        "%.1f s wall",
        problem.options.mode,
        last.time_s,
        summ["steps"],
        last.temperatures_K["max_surface"] - ZERO_CELSIUS_K,
        last.temperatures_K["mean_bulk"] - ZERO_CELSIUS_K,
        summ["max_relative_imbalance"],
        summ["wall_time_s"],
    )
    return records, summ
