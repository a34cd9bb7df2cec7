"""Objects kept within a process for the next run that asks for the same one.

A diagnosis evaluates the thermal model of one case hundreds of times with other parameter
values: the thermal mesh and its facet groups, the map of the cycle's contact surfaces onto the
mesh and the contact bands of the friction heat are the same in every run at one torque and
cost as much as the solve of a cheap run. :class:`Kept` holds the last few of such objects,
each under every input that changes it: values (hashable: frozen options, numbers, strings)
compared by equality, and objects (a cycle result, a mesh) compared by identity and held by
the entry, so that an entry can only be found again with the very objects it was built from.
"""

from __future__ import annotations

import weakref
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any

from mpi4py import MPI

from gearfem.core.errors import ParameterError


class Kept[T]:
    """The ``size`` most recently used objects, each under its inputs (see the module
    docstring)."""

    def __init__(self, size: int) -> None:
        if size < 1:
            raise ParameterError("Kept.size", size, ">= 1")
        self.size = size
        self._entries: OrderedDict[Hashable, tuple[tuple[Any, ...], T]] = OrderedDict()
        self.builds = 0
        self.hits = 0
        _ALL.add(self)

    def get(self, key: Hashable, objects: tuple[Any, ...], build: Callable[[], T]) -> T:
        """The object built from ``key`` (values) and ``objects`` (by identity), built by
        ``build()`` when not held. A collective ``build`` stays collective: the entries depend
        only on the inputs, which every rank of a run passes alike."""
        try:
            entry = self._entries.get(key)
        except TypeError:  # a key that cannot be hashed is never kept
            self.builds += 1
            return build()
        if entry is not None and _same(entry[0], objects):
            self._entries.move_to_end(key)
            self.hits += 1
            return entry[1]
        value = build()
        self.builds += 1
        self._entries[key] = (tuple(objects), value)
        self._entries.move_to_end(key)
        while len(self._entries) > self.size:
            self._entries.popitem(last=False)
        return value

    def clear(self) -> None:
        """Forget every entry."""
        self._entries.clear()


_ALL: weakref.WeakSet[Kept] = weakref.WeakSet()


def forget_all() -> None:
    """Forget the entries of every :class:`Kept` of the process (the next runs build anew)."""
    for kept in list(_ALL):
        kept.clear()


def _same(held: tuple[Any, ...], objects: tuple[Any, ...]) -> bool:
    return len(held) == len(objects) and all(a is b for a, b in zip(held, objects))


def members(comm: MPI.Comm) -> tuple[int, ...]:
    """The ranks of ``comm`` in ``MPI.COMM_WORLD``: what an object distributed over ``comm``
    may be reused on (a communicator split again for every run has the same members)."""
    group, world = comm.Get_group(), MPI.COMM_WORLD.Get_group()
    try:
        return tuple(int(r) for r in group.Translate_ranks(list(range(comm.size)), world))
    finally:
        group.Free()
        world.Free()


__all__ = ["Kept", "forget_all", "members"]
