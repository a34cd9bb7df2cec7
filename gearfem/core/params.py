"""Typed, validated parameters: checks and (de)serialisation of frozen dataclasses.

gearfem's configuration is a tree of frozen dataclasses, one per physics concept, composed into a
:class:`gearfem.config.Case`. Each dataclass validates itself in ``__post_init__`` with the
``require_*`` helpers below, so that a bad value raises a
:class:`~gearfem.core.errors.ParameterError`
naming the parameter, its value and the allowed range, whether it came from a TOML file, the
command line or Python. Nothing is clamped.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Mapping
from typing import Any, TypeVar

from gearfem.core.errors import ParameterError

T = TypeVar("T")


def require_finite(name: str, value: float) -> float:
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise ParameterError(name, value, "a finite real number")
    return float(value)


def require_positive(name: str, value: float) -> float:
    require_finite(name, value)
    if value <= 0:
        raise ParameterError(name, value, "> 0")
    return float(value)


def require_nonnegative(name: str, value: float) -> float:
    require_finite(name, value)
    if value < 0:
        raise ParameterError(name, value, ">= 0")
    return float(value)


def require_range(
    name: str,
    value: float,
    lo: float,
    hi: float,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    unit: str = "",
    reason: str = "",
) -> float:
    """Check ``lo <= value <= hi`` (open ends as requested) and return ``float(value)``."""
    require_finite(name, value)
    below = value <= lo if lo_open else value < lo
    above = value >= hi if hi_open else value > hi
    if below or above:
        raise ParameterError(name, value, interval(lo, hi, lo_open, hi_open, unit), reason)
    return float(value)


def interval(
    lo: float, hi: float, lo_open: bool = False, hi_open: bool = False, unit: str = ""
) -> str:
    """The allowed range of :func:`require_range` as its errors and the case-file reference
    write it: "[0, 2]", "(0, 0.1] K"."""
    lb = "(" if lo_open else "["
    rb = ")" if hi_open else "]"
    return f"{lb}{lo:g}, {hi:g}{rb}" + (f" {unit}" if unit else "")


def require_int(name: str, value: int, lo: int | None = None, hi: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        else:
            raise ParameterError(name, value, "an integer")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        lo_s = "-inf" if lo is None else str(lo)
        hi_s = "inf" if hi is None else str(hi)
        raise ParameterError(name, value, f"integer in [{lo_s}, {hi_s}]")
    return value


def require_choice(name: str, value: str, choices: typing.Iterable[str]) -> str:
    choices = tuple(choices)
    if value not in choices:
        raise ParameterError(name, value, "one of " + ", ".join(repr(c) for c in choices))
    return value


# --------------------------------------------------------------------------------------------
# dict <-> dataclass
# --------------------------------------------------------------------------------------------


def _strip_optional(tp: Any) -> tuple[Any, bool]:
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(args) == 1:
            return args[0], True
    return tp, False


def _convert(tp: Any, value: Any, name: str) -> Any:
    tp, optional = _strip_optional(tp)
    if value is None:
        if optional:
            return None
        raise ParameterError(name, value, f"a value of type {getattr(tp, '__name__', tp)}")
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, Mapping):
            raise ParameterError(name, value, f"a table of {tp.__name__} fields")
        return from_dict(tp, value, prefix=name)
    origin = typing.get_origin(tp)
    if origin in (tuple, list):
        args = typing.get_args(tp)
        if not isinstance(value, (list, tuple)):
            raise ParameterError(name, value, "a list")
        if origin is tuple and len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(args[0], v, f"{name}[{i}]") for i, v in enumerate(value))
        if origin is tuple and args:
            if len(args) != len(value):
                raise ParameterError(name, value, f"a list of {len(args)} values")
            return tuple(
                _convert(a, v, f"{name}[{i}]") for i, (a, v) in enumerate(zip(args, value))
            )
        return list(value)
    if origin is dict:  # a table of named entries (e.g. [instruments.probes.NAME])
        _, value_t = typing.get_args(tp) or (str, Any)
        if not isinstance(value, Mapping):
            raise ParameterError(name, value, "a table of named entries")
        return {str(k): _convert(value_t, v, f"{name}.{k}") for k, v in value.items()}
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParameterError(name, value, "a number")
        return float(value)
    if tp is int:
        return require_int(name, value)
    if tp is bool:
        if not isinstance(value, bool):
            raise ParameterError(name, value, "true or false")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise ParameterError(name, value, "a string")
        return value
    return value


def from_dict[T](cls: type[T], data: Mapping[str, Any], prefix: str = "") -> T:
    """Build the frozen dataclass ``cls`` from a (TOML) mapping.

    Unknown keys are an error (a misspelt key must not be silently ignored); missing keys take
    the dataclass defaults. Nested dataclasses are built recursively; ``prefix`` gives the dotted
    path used in error messages.
    """
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        where = prefix or cls.__name__
        raise ParameterError(
            f"{where}.{unknown[0]}" if prefix else unknown[0],
            data[unknown[0]],
            f"a known key of [{where}]: " + ", ".join(sorted(fields)),
            "unknown key",
        )
    kwargs = {}
    for key, value in data.items():
        dotted = f"{prefix}.{key}" if prefix else key
        kwargs[key] = _convert(hints[key], value, dotted)
    try:
        return cls(**kwargs)
    except ParameterError as err:
        # a table reused under another name ([thermal_mesh] is a MeshOptions, which names its
        # keys "mesh.*") or nested ([instruments.camera] names its keys "camera.*"): name the key
        # as the user wrote it, with its whole dotted path
        _, _, key = err.name.partition(".")
        if prefix and key and not err.name.startswith(prefix + "."):
            raise ParameterError(f"{prefix}.{key}", err.value, err.allowed, err.reason) from err
        raise


def to_dict(obj: Any) -> Any:
    """Serialise a dataclass tree to plain TOML/JSON-compatible data (None values dropped)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out = {}
        for f in dataclasses.fields(obj):
            v = to_dict(getattr(obj, f.name))
            if v is not None:
                out[f.name] = v
        return out
    if isinstance(obj, (list, tuple)):
        return [to_dict(v) for v in obj]
    if isinstance(obj, Mapping):
        return {k: to_dict(v) for k, v in obj.items()}
    return obj
