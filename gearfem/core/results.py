"""Results as typed, frozen dataclasses that serialise to and from JSON.

A result class derives from :class:`JsonRecord`; ``to_json()`` gives plain JSON data (nested
records as objects, tuples and numpy arrays as lists, numpy scalars as numbers, dict keys as
strings) and ``from_json()`` rebuilds the record from it (the keys of a ``dict[int, ...]`` as
ints again), so ``R.from_json(r.to_json()) == r`` for records of plain values. Callers read
attributes (``summary.headline.max_surface_temperature_C``), never string keys by convention; the
JSON files keep the field names as keys.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from typing import Any, Self

from gearfem.core.io import jsonable


def _build(hint: Any, value: Any) -> Any:
    """``value`` (JSON data) as the type ``hint`` says: records, tuples and optional records."""
    if value is None:
        return None
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        return _build(args[0], value) if len(args) == 1 else value
    if isinstance(hint, type) and issubclass(hint, JsonRecord):
        return hint.from_json(value)
    if origin is tuple:
        args = typing.get_args(hint)
        inner = args[0] if args else Any
        return tuple(_build(inner, v) for v in value)
    if origin is list:
        (inner,) = typing.get_args(hint) or (Any,)
        return [_build(inner, v) for v in value]
    if origin is dict:
        args = typing.get_args(hint)
        key, inner = args if len(args) == 2 else (Any, Any)
        # JSON keys are strings: integer keys (tooth numbers) back to ints
        return {(int(k) if key is int else k): _build(inner, v) for k, v in value.items()}
    return value


class JsonRecord:
    """Mixin for frozen result dataclasses: ``to_json`` and ``from_json``."""

    def to_json(self) -> dict[str, Any]:
        return {f.name: jsonable(getattr(self, f.name)) for f in dataclasses.fields(self)}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Self:
        hints = typing.get_type_hints(cls)
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: _build(hints[k], v) for k, v in data.items() if k in names})
