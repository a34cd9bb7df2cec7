"""The case file's keys, read from the options dataclasses: every table and key with its default,
the values it accepts and what it means (``gearfem keys``; docs/case_file.md).

* **Meaning**: the key's entry in its dataclass's docstring, ``key: text`` or ``a, b: text`` with
  the text's continuation indented below it (the Google style of the options modules).
* **Default**: the built-in value of :class:`gearfem.config.Case` (a table the built-in case leaves
  out, such as ``[thermal_mesh]``, shows its dataclass's defaults; the probes of
  ``[instruments.probes.NAME]`` have no built-in instance).
* **Accepted**: what the dataclass's ``__post_init__`` checks under the key's name with
  :mod:`gearfem.core.params`' ``require_*`` (a range, a choice, an integer); checks across keys are
  the table's own, and a value they refuse gets an error naming the key, the value and what is
  allowed.

A key without a docstring entry is a documentation defect; :func:`undocumented` lists them and
tests/test_case_keys.py requires none. This module only reads the options: no run imports it, so it
is not code a quoted result hashes.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import re
import sys
import textwrap
import types
import typing
from collections.abc import Iterator

from gearfem.config import Case, load_case
from gearfem.core.doctables import markdown_table
from gearfem.core.errors import ParameterError
from gearfem.core.params import interval

_NAME = "NAME"
#: The name of a probe's table in the listing (each probe is a table of its own).
PROBE_TABLE = f"instruments.probes.{_NAME}"
#: The tables whose options class another table shares, in their own words.
SUMMARY = {
    "thermal_mesh": "The thermal model's own mesh: the keys of `[mesh]`.",
    "material_wheel": "The wheel's material: the keys of `[material]`.",
}
#: The optional tables (None in :class:`Case`) and what a case file that leaves one out gets.
ABSENT = {
    "thermal_mesh": "the `[mesh]` table's mesh",
    "material_wheel": "the `[material]` table's material",
}

_ENTRY = re.compile(r"^(\s*)([A-Za-z_]\w*(?:\s*,\s*[A-Za-z_]\w*)*)\s*:\s+(\S.*)$")
_ROLE = re.compile(r":(?:mod|func|class|meth|data|attr):`~?([^`]+)`")


@dataclasses.dataclass(frozen=True)
class Key:
    """One key of the case file."""

    table: str  # "thermal", "instruments.camera", PROBE_TABLE; "" for the top level
    name: str
    default: str  # as TOML writes it; "(not set)" for None, "(required)" without a default
    builtin: str  # the built-in case's value where it differs from the default, else ""
    accepted: str  # from the require_* checks; "" where only the table's own checks apply
    meaning: str  # the docstring entry, one paragraph; "" where there is none


@dataclasses.dataclass(frozen=True)
class Table:
    """One table of the case file: its options dataclass, summary line and keys."""

    name: str
    options: type
    summary: str
    keys: tuple[Key, ...]
    absent: str = ""  # what a case file that leaves an optional table out gets instead


def docstring_entries(cls: type) -> dict[str, str]:
    """The ``key: text`` entries of ``cls``'s docstring for its fields, by key (an entry naming
    several keys, ``a, b: text``, gives each the text)."""
    fields = {f.name for f in dataclasses.fields(cls)}
    out: dict[str, str] = {}
    names: list[str] = []
    indent = -1
    for line in (inspect.getdoc(cls) or "").splitlines():
        m = _ENTRY.match(line)
        found = [n.strip() for n in m.group(2).split(",")] if m else []
        if m and all(n in fields for n in found):
            # a key's first entry is its meaning (a later ``key:`` line, in another section, is not)
            names, indent = [n for n in found if n not in out], len(m.group(1))
            for n in names:
                out[n] = m.group(3).strip()
        elif names and line.strip() and len(line) - len(line.lstrip()) > indent:
            for n in names:
                out[n] += " " + line.strip()
        else:
            names, indent = [], -1
    return {k: _markdown(v) for k, v in out.items()}


def _markdown(text: str) -> str:
    """reST inline markup of the docstrings as Markdown: roles and double backticks."""
    return _ROLE.sub(r"`\1`", text).replace("``", "`")


def accepted_values(cls: type) -> dict[str, str]:
    """What ``cls.__post_init__`` accepts for each key it checks with a ``require_*`` of
    :mod:`gearfem.core.params` under a literal name (``"table.key"``, or ``p + "key"``)."""
    post = cls.__dict__.get("__post_init__")
    if post is None:
        return {}
    tree = ast.parse(textwrap.dedent(inspect.getsource(post)))
    scope = vars(sys.modules[cls.__module__])
    out: dict[str, str] = {}
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)):
            continue
        check, args = node.func.id, node.args
        if not check.startswith("require_") or not args:
            continue
        key = _literal_key(args[0])
        if key is None or key in out:
            continue
        text = _describe(check, [_value(a, scope) for a in args[2:]], node.keywords, scope)
        if text:
            out[key] = text
    return out


def _literal_key(node: ast.expr) -> str | None:
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value.rsplit(".", 1)[-1]
    if isinstance(node, ast.BinOp) and isinstance(node.right, ast.Constant):
        return str(node.right.value).rsplit(".", 1)[-1]
    return None


_UNKNOWN = object()


def _value(node: ast.expr, scope: dict) -> object:
    """A check's bound: a literal or a module constant (anything else is unknown here)."""
    try:
        return ast.literal_eval(node)
    except ValueError:
        pass
    if isinstance(node, ast.Name) and node.id in scope:
        return scope[node.id]
    if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name):
        try:
            return scope[node.value.id][ast.literal_eval(node.slice)]
        except (KeyError, ValueError, IndexError, TypeError):
            return _UNKNOWN
    return _UNKNOWN


def _describe(check: str, bounds: list, keywords: list[ast.keyword], scope: dict) -> str:
    kw = {k.arg: _value(k.value, scope) for k in keywords if k.arg}
    if check == "require_positive":
        return "> 0"
    if check == "require_nonnegative":
        return ">= 0"
    if check == "require_finite":
        return "finite"
    if check == "require_choice" and bounds and bounds[0] is not _UNKNOWN:
        return ", ".join(f'"{c}"' for c in bounds[0])
    if check == "require_int":
        lo = bounds[0] if len(bounds) > 0 else kw.get("lo")
        hi = bounds[1] if len(bounds) > 1 else kw.get("hi")
        if lo is _UNKNOWN or hi is _UNKNOWN:
            return "integer"
        if lo is not None and hi is not None:
            return f"integer in [{lo}, {hi}]"
        return "integer" + (f" >= {lo}" if lo is not None else "")
    if check == "require_range" and len(bounds) >= 2 and _UNKNOWN not in bounds[:2]:
        unit = kw.get("unit")
        return interval(
            bounds[0],
            bounds[1],
            kw.get("lo_open") is True,
            kw.get("hi_open") is True,
            unit if isinstance(unit, str) else "",
        )
    return ""


def toml_value(value: object) -> str:
    """``value`` as a TOML value (None: not set)."""
    if value is None:
        return "(not set)"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, float):
        return repr(value) if len(repr(value)) <= 10 else f"{value:.6g}"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{}" if not value else "{...}"
    return str(value)


def _options_type(tp: object) -> type | None:
    """The options dataclass a field's annotation names (``X``, ``X | None``), else None."""
    if dataclasses.is_dataclass(tp):
        return tp  # type: ignore[return-value]
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        found = [a for a in typing.get_args(tp) if dataclasses.is_dataclass(a)]
        return found[0] if found else None
    return None


def _tables(cls: type, default: object, builtin: object, prefix: str) -> Iterator[Table]:
    """The table of options class ``cls`` under ``prefix``, then the tables of its fields that are
    options classes: ``default`` is the instance a case file that leaves the table out gets (None:
    a table that is then absent), ``builtin`` the built-in case's."""
    hints = typing.get_type_hints(cls)
    doc = docstring_entries(cls)
    checks = accepted_values(cls)
    keys, subtables = [], []
    for f in dataclasses.fields(cls):
        tp = hints[f.name]
        value = getattr(default, f.name) if default is not None else _default(f)
        ours = getattr(builtin, f.name) if builtin is not None else None
        sub = _options_type(tp)
        name = f"{prefix}.{f.name}" if prefix else f.name
        if sub is not None:
            subtables += _tables(sub, value, ours, name)
            continue
        if typing.get_origin(tp) is dict and dataclasses.is_dataclass(typing.get_args(tp)[1]):
            subtables += _tables(typing.get_args(tp)[1], None, None, f"{name}.{_NAME}")
            continue
        shown = toml_value(value)
        theirs = toml_value(ours) if builtin is not None else shown
        keys.append(
            Key(
                table=prefix,
                name=f.name,
                default=shown,
                builtin=theirs if theirs != shown else "",
                accepted=checks.get(f.name, ""),
                meaning=doc.get(f.name, ""),
            )
        )
    summary = SUMMARY.get(prefix) or _markdown(
        (inspect.getdoc(cls) or "").split("\n\n")[0].replace("\n", " ")
    )
    yield Table(prefix, cls, summary, tuple(keys), absent=ABSENT.get(prefix, ""))
    yield from subtables


def _default(f: dataclasses.Field) -> object:
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return _REQUIRED


class _Required:
    def __repr__(self) -> str:
        return "(required)"


_REQUIRED = _Required()


def case_tables(case: Case | None = None) -> tuple[Table, ...]:
    """Every table of the case file, the top level first, in the order of :class:`Case`'s
    fields, with each key's default and its value in ``case`` (None: the built-in case) where
    that differs (:attr:`Key.builtin`)."""
    return tuple(_tables(Case, Case(), case if case is not None else load_case(None), ""))


def undocumented() -> list[str]:
    """The keys without a docstring entry, as ``table.key``."""
    return [
        f"{t.name}.{k.name}".lstrip(".") for t in case_tables() for k in t.keys if not k.meaning
    ]


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def markdown() -> str:
    """The reference as Markdown: one section per table, a row per key."""
    parts = []
    for t in case_tables():
        if not t.keys:  # a table of tables only ([instruments])
            continue
        title = f"`[{t.name}]`" if t.name else "The top level"
        where = f"`{t.options.__module__}.{t.options.__name__}`"
        absent = f" Left out, the case takes {t.absent}." if t.absent else ""
        parts.append(f"### {title}\n\n{t.summary} ({where}){absent}")
        rows = [
            (
                f"`{k.name}`",
                f"`{_cell(k.default)}`",
                f"`{_cell(k.builtin)}`" if k.builtin else "",
                _cell(k.accepted),
                _cell(k.meaning),
            )
            for k in t.keys
        ]
        parts.append(
            markdown_table(("key", "default", "built-in case", "accepted", "meaning"), rows)
        )
    return "\n\n".join(parts)


def text(table: str | None = None, case: Case | None = None, width: int = 100) -> str:
    """The reference as plain text for a terminal: every table, or ``table`` (``thermal``,
    ``instruments.camera``), with the values of ``case`` (None: the built-in case) where they
    differ from the defaults; an unknown table raises ParameterError naming the known ones."""
    label = "built-in case" if case is None else "this case"
    tables = case_tables(case)
    if table is not None:
        tables = tuple(t for t in tables if t.name == table)
        if not tables:
            known = ", ".join(t.name for t in case_tables() if t.name and t.keys)
            raise ParameterError("table", table, f"a table of the case file: {known}")
    out = []
    for t in tables:
        if not t.keys:
            continue
        out.append(f"[{t.name}]" if t.name else "(top level)")
        about = t.summary + (f" Left out, the case takes {t.absent}." if t.absent else "")
        out += textwrap.wrap(
            about.replace("`", ""), width, initial_indent="  ", subsequent_indent="  "
        )
        for k in t.keys:
            head = f"  {k.name} = {k.default}"
            head += f"    {label}: {k.builtin}" if k.builtin else ""
            head += f"    accepted: {k.accepted}" if k.accepted else ""
            out.append(head)
            out += textwrap.wrap(
                k.meaning.replace("`", ""),
                width,
                initial_indent="      ",
                subsequent_indent="      ",
            )
        out.append("")
    return "\n".join(out)


__all__ = [
    "PROBE_TABLE",
    "Key",
    "Table",
    "accepted_values",
    "case_tables",
    "docstring_entries",
    "markdown",
    "text",
    "toml_value",
    "undocumented",
]
