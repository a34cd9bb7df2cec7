"""Logging: Python ``logging`` with a rank-0 filter.

Every gearfem module logs through ``logging.getLogger(__name__)``. :func:`setup_logging` installs
one handler on the ``gearfem`` logger that prints only on MPI rank 0 (other ranks' records are
dropped unless ``all_ranks=True``, then each line carries its rank). The level comes from the
argument, else the ``GEARFEM_LOG_LEVEL`` environment variable, else ``INFO``.
"""

from __future__ import annotations

import logging
import os
import sys

ENV_VAR = "GEARFEM_LOG_LEVEL"
LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR", "CRITICAL")


def _rank() -> int:
    from mpi4py import MPI

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
    from gearfem.errors import ParameterError

    source = "--log-level"
    if level is None:
        level, source = os.environ.get(ENV_VAR, "INFO"), ENV_VAR
    if isinstance(level, int):
        return level
    name = str(level).strip().upper()
    if name not in LEVELS:
        raise ParameterError(source, level, ", ".join(LEVELS))
    return getattr(logging, name)


def setup_logging(level: str | int | None = None, all_ranks: bool = False) -> logging.Logger:
    """Configure the ``gearfem`` logger (idempotent) and return it."""
    logger = logging.getLogger("gearfem")
    logger.setLevel(resolve_level(level))
    for h in list(logger.handlers):
        if getattr(h, "_gearfem", False):
            logger.removeHandler(h)
    handler = logging.StreamHandler(sys.stderr)
    handler._gearfem = True  # type: ignore[attr-defined]
    fmt = "%(asctime)s [rank %(rank)d] %(levelname)s %(name)s: %(message)s" if all_ranks else "%(asctime)s %(levelname)s %(name)s: %(message)s"
    handler.setFormatter(logging.Formatter(fmt, datefmt="%H:%M:%S"))
    handler.addFilter(RankFilter(all_ranks))
    logger.addHandler(handler)
    logger.propagate = False
    return logger
