"""Objects kept within a process (gearfem.core.kept): found again only under equal values and
the very same objects, the oldest forgotten first."""

from __future__ import annotations

import pytest
from mpi4py import MPI

from gearfem.core.errors import ParameterError
from gearfem.core.kept import Kept, forget_all, members


def test_an_entry_is_found_again_only_with_equal_values_and_the_same_objects():
    kept = Kept(2)
    a, b = object(), object()
    built = []

    def build(tag):
        built.append(tag)
        return tag

    assert kept.get(("x", 1.0), (a,), lambda: build("first")) == "first"
    assert kept.get(("x", 1.0), (a,), lambda: build("again")) == "first"  # equal values, a
    assert kept.get(("x", 1.0), (b,), lambda: build("other object")) == "other object"
    assert kept.get(("x", 2.0), (b,), lambda: build("other value")) == "other value"
    assert built == ["first", "other object", "other value"]
    assert (kept.hits, kept.builds) == (1, 3)


def test_the_least_recently_used_entry_is_forgotten_first():
    kept = Kept(2)
    kept.get(1, (), lambda: "one")
    kept.get(2, (), lambda: "two")
    kept.get(1, (), lambda: "one again")  # 1 used last: 2 is the oldest
    kept.get(3, (), lambda: "three")
    assert kept.get(1, (), lambda: "one rebuilt") == "one"
    assert kept.get(2, (), lambda: "two rebuilt") == "two rebuilt"
    forget_all()
    assert kept.get(1, (), lambda: "after forget_all") == "after forget_all"


def test_an_unhashable_key_is_built_every_time():
    kept = Kept(2)
    assert kept.get(([1.0],), (), lambda: "built") == "built"
    assert kept.get(([1.0],), (), lambda: "built again") == "built again"
    assert (kept.hits, kept.builds) == (0, 2)


def test_a_size_below_one_is_refused():
    with pytest.raises(ParameterError, match="Kept.size"):
        Kept(0)


def test_members_are_the_world_ranks_of_a_communicator():
    world = MPI.COMM_WORLD
    assert members(MPI.COMM_SELF) == (world.rank,)
    assert members(world) == tuple(range(world.size))
