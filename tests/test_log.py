"""Logging and the progress bar: log lines are printed above a live bar, never into it, and no bar
is drawn into a file or pipe (issue: the bar of ``gearfem run`` was broken by INFO lines)."""

from __future__ import annotations

import io
import logging

import pytest
from mpi4py import MPI

from gearfem.core.errors import ParameterError
from gearfem.core.log import ProgressBar, resolve_level, setup_logging


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.fixture
def restore_logging():
    logger = logging.getLogger("gearfem")
    level, handlers = logger.level, list(logger.handlers)
    yield
    logger.handlers[:] = handlers
    logger.setLevel(level)


def test_log_lines_scroll_above_a_live_bar(restore_logging):
    term = _Terminal()
    setup_logging("INFO", stream=term)
    log = logging.getLogger("gearfem.test")
    with ProgressBar(MPI.COMM_SELF, title="cycle", stream=term) as bar:
        bar.update(1, 4, "phi 1")
        log.info("position 1 converged")
        bar.update(2, 4, "phi 2")
    out = term.getvalue()
    if MPI.COMM_WORLD.rank != 0:  # the log handler prints on rank 0 only
        assert "position 1 converged" not in out
        return
    # the record has a cleared line of its own, and the bar is redrawn below it
    i = out.index("position 1 converged")
    start = out.rfind("\r\033[K", 0, i) + len("\r\033[K")
    end = out.index("\n", i)
    assert "cycle [" not in out[start:end], "log line and bar share a line"
    assert "cycle [" in out[end:], "bar not redrawn below the log line"
    assert out.endswith("\n")


def test_no_bar_into_a_file_or_pipe():
    stream = io.StringIO()  # isatty() is False
    with ProgressBar(MPI.COMM_SELF, stream=stream) as bar:
        bar.update(1, 2)
        bar.update(2, 2)
    assert stream.getvalue() == ""


def test_bar_only_on_rank_zero():
    term = _Terminal()
    with ProgressBar(MPI.COMM_WORLD, stream=term) as bar:
        bar.update(1, 1)
    assert (term.getvalue() != "") == (MPI.COMM_WORLD.rank == 0)


def test_bad_log_level_names_the_option():
    with pytest.raises(ParameterError, match="--log-level"):
        resolve_level("LOUD")
