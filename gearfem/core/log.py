"""Logging: Python ``logging`` with a rank-0 filter, and a progress bar that cooperates with it.

Every gearfem module logs through ``logging.getLogger(__name__)``. :func:`setup_logging` installs
one handler on the ``gearfem`` logger that prints only on MPI rank 0 (other ranks' records are
dropped unless ``all_ranks=True``, then each line carries its rank). The level comes from the
argument, else the ``GEARFEM_LOG_LEVEL`` environment variable, else ``INFO``.

:class:`ProgressBar` draws a one-line bar on rank 0 when its stream is a terminal (never into a
file or pipe, where it would only add carriage returns). While a bar is live, the gearfem log
handler erases it, prints the record on its own line and redraws the bar below: log lines scroll
above a bar that stays at the bottom.
"""

from __future__ import annotations

import logging
import os
import sys
import time
from typing import TextIO

from mpi4py import MPI

from gearfem.core.errors import ParameterError

ENV_VAR = "GEARFEM_LOG_LEVEL"
LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR", "CRITICAL")


def _rank() -> int:
    return MPI.COMM_WORLD.rank


class RankFilter(logging.Filter):
    """Pass records on rank 0 only (or on every rank, tagged, when ``all_ranks``)."""

    def __init__(self, all_ranks: bool = False) -> None:
        super().__init__()
        self.rank = _rank()
        self.all_ranks = all_ranks

    def filter(self, record: logging.LogRecord) -> bool:
        record.rank = self.rank
        return self.all_ranks or self.rank == 0


def resolve_level(level: str | int | None = None) -> int:
    """Level from the argument, else ``$GEARFEM_LOG_LEVEL``, else INFO. Bad names raise."""
    source = "--log-level"
    if level is None:
        level, source = os.environ.get(ENV_VAR, "INFO"), ENV_VAR
    if isinstance(level, int):
        return level
    name = str(level).strip().upper()
    if name not in LEVELS:
        raise ParameterError(source, level, ", ".join(LEVELS))
    return getattr(logging, name)


class ProgressBar:
    """A one-line progress bar, drawn by rank 0 on a terminal only (no collective calls).

    ``update(i, n, label)`` redraws it; ``close()`` ends the line. On other ranks, or when
    ``stream`` is not a terminal (a log file, CI), nothing is drawn. Use as a context manager or
    call :meth:`close`; log records emitted meanwhile are printed above the bar.
    """

    _live: ProgressBar | None = None  # the bar the log handler redraws

    def __init__(
        self, comm: MPI.Comm, title: str = "cycle", stream: TextIO | None = None, width: int = 30
    ) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.active = comm.rank == 0 and bool(getattr(self.stream, "isatty", lambda: False)())
        self.title, self.width = title, width
        self.t0 = time.perf_counter()
        self.line = ""

    def update(self, i: int, n: int, label: str = "") -> None:
        if not self.active:
            return
        done = int(self.width * i / max(n, 1))
        el = time.perf_counter() - self.t0
        eta = el / max(i, 1) * (n - i)
        self.line = (
            f"  {self.title} [{'#' * done}{'.' * (self.width - done)}] {i}/{n} {label:>10}  "
            f"{el:6.0f} s, ~{eta:4.0f} s left"
        )
        ProgressBar._live = self
        self.draw()

    def draw(self) -> None:
        self.stream.write("\r\033[K" + self.line)
        self.stream.flush()

    def erase(self) -> None:
        self.stream.write("\r\033[K")
        self.stream.flush()

    def close(self) -> None:
        if self.active and self.line:
            self.stream.write("\n")
            self.stream.flush()
        if ProgressBar._live is self:
            ProgressBar._live = None
        self.line = ""

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class _BarAwareHandler(logging.StreamHandler):
    """Stream handler that prints records above a live :class:`ProgressBar` on the same stream."""

    def emit(self, record: logging.LogRecord) -> None:
        bar = ProgressBar._live
        if bar is None or bar.stream is not self.stream:
            super().emit(record)
            return
        bar.erase()
        super().emit(record)
        bar.draw()


def setup_logging(
    level: str | int | None = None, all_ranks: bool = False, stream: TextIO | None = None
) -> logging.Logger:
    """Configure the ``gearfem`` logger (idempotent) and return it (``stream``: default stderr)."""
    logger = logging.getLogger("gearfem")
    logger.setLevel(resolve_level(level))
    for h in list(logger.handlers):
        if getattr(h, "_gearfem", False):
            logger.removeHandler(h)
    handler = _BarAwareHandler(stream if stream is not None else sys.stderr)
    handler._gearfem = True  # type: ignore[attr-defined]
    fmt = (
        "%(asctime)s [rank %(rank)d] %(levelname)s %(name)s: %(message)s"
        if all_ranks
        else "%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    handler.setFormatter(logging.Formatter(fmt, datefmt="%H:%M:%S"))
    handler.addFilter(RankFilter(all_ranks))
    logger.addHandler(handler)
    logger.propagate = False
    return logger
