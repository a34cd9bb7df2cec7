"""Run a thermal problem and write its outputs (the work behind ``gearfem thermal``)."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from gearfem.materials import ZERO_CELSIUS_K
from gearfem.thermal.outputs import ThermalWriter, summary
from gearfem.thermal.problem import StepRecord, ThermalProblem

log = logging.getLogger(__name__)


def run_and_write(problem: ThermalProblem, out_dir: str | Path, extra: dict[str, Any] | None = None,
                  write_fields: bool = True,
                  more: Callable[[list[StepRecord]], dict[str, Any]] | None = None,
                  write_plot: bool = True) -> tuple[list[StepRecord], dict[str, Any]]:
    """Solve (transient or steady, as ``problem.options.mode`` says) and write CSV, VTX, plot, summary.

    ``extra`` and ``more(records)`` (computed after the run, collectively) are added to the
    summary. The summary (``thermal_summary.json``) is written last: a run that fails leaves none.
    """
    t0 = time.perf_counter()
    with ThermalWriter(out_dir, problem, write_fields=write_fields, write_plot=write_plot) as writer:
        if problem.options.mode == "steady":
            rec = problem.solve_steady()
            writer.on_step(problem, rec, write_field=True)
            records = [rec]
        else:
            records = problem.run(observer=writer)
        info = {"wall_time_s": time.perf_counter() - t0, "mode": problem.options.mode}
        info.update(extra or {})
        if more is not None:
            info.update(more(records))
        summ = summary(problem, records, info)
        writer.finish(summ)
    last = records[-1]
    log.info("thermal %s: t = %g s, %d steps, T_max surface %.2f C, mean bulk %.2f C, max |imbalance| %.2e, "
             "%.1f s wall", problem.options.mode, last.time_s, summ["steps"],
             last.temperatures_K["max_surface"] - ZERO_CELSIUS_K, last.temperatures_K["mean_bulk"] - ZERO_CELSIUS_K,
             summ["max_relative_imbalance"], summ["wall_time_s"])
    return records, summ
