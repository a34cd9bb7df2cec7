"""Independent tasks over the ranks of a communicator: each task on a group of ranks of its own.

Some stages of a run are several independent solves that are each too small to gain from more
than a rank or two: the two gears' thermal models (about 10⁴ unknowns each), the positions of a
meshing cycle. :func:`run_split` deals such tasks out over sub-communicators, runs them at the same
time and returns every task's result on every rank, so that the ranks never wait on one another's
serial work (a rank spinning in a collective while another computes costs CPU time and does
nothing).

Errors are collective: a task that raises on its group is re-raised on every rank after all
groups have finished, so no rank is left waiting in a collective call the others have left.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from typing import Any

from mpi4py import MPI


def run_split[K: Hashable](
    comm: MPI.Comm, keys: Sequence[K], task: Callable[[K, MPI.Comm], Any]
) -> dict[K, Any]:
    """``task(key, sub)`` for every key, the keys dealt out over ``min(len(keys), comm.size)``
    groups of ranks (group g: the ranks r with r mod groups = g, holding keys g, g + groups, ...);
    the results on every rank, by key (collective on ``comm``).

    With one rank or one key, every task runs on ``comm`` itself, one after the other. A task's
    result is taken from the first rank of its group and must be picklable (the group's other
    ranks may return anything).
    """
    keys = list(keys)
    groups = min(len(keys), comm.size)
    if groups < 2:
        return {k: task(k, comm) for k in keys}
    color = comm.rank % groups
    sub = comm.Split(color, comm.rank)
    mine: dict[K, Any] = {}
    error: BaseException | None = None
    try:
        for i, k in enumerate(keys):
            if i % groups == color:
                mine[k] = task(k, sub)
    except Exception as err:  # re-raised on every rank below
        error = err
    finally:
        sub.Free()
    for err in comm.allgather(error):
        if err is not None:
            raise err
    out: dict[K, Any] = {}
    for i, k in enumerate(keys):
        owner = i % groups  # the first rank of group g is rank g
        out[k] = comm.bcast(mine.get(k) if comm.rank == owner else None, root=owner)
    return out
