"""The case file's reference (gearfem.case_keys, docs/case_file.md): every key of every table has a
meaning, the page is the one the options give today, and the parser reads what the docstrings and
the ``require_*`` checks say."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from gearfem import case_keys
from gearfem.cli import main
from gearfem.core.doctables import read_block
from gearfem.core.errors import ParameterError
from gearfem.core.params import require_choice, require_int, require_range
from gearfem.core.provenance import source_files
from gearfem.uncertainty import DIAGNOSIS_CODE, RUN_CODE

ROOT = Path(__file__).resolve().parent.parent
SHAPES = ("round", "square")


@dataclasses.dataclass(frozen=True)
class _Toy:
    """A toy table.

    Args:
        width_mm, height_mm: Sides of the box (mm), the second
            continued on an indented line.
        count: How many.
        shape: ``"round"`` or ``"square"``; see :func:`gearfem.case_keys.markdown`.

    Notes:
        count: not an entry (another section, but a field's name: the entry above ended).
    """

    width_mm: float = 1.0
    height_mm: float = 2.0
    count: int = 3
    shape: str = "round"

    def __post_init__(self) -> None:
        p = "toy."
        require_range("toy.width_mm", self.width_mm, 0.0, 5.0, lo_open=True, unit="mm")
        require_range("toy.height_mm", self.height_mm, 0.0, self.width_mm * 10)  # not literal
        require_int(p + "count", self.count, 1, 8)
        require_choice("toy.shape", self.shape, SHAPES)


def test_every_key_of_the_case_file_has_a_meaning():
    """A key added to an options dataclass without its docstring entry fails here."""
    assert case_keys.undocumented() == []


def test_the_case_file_page_is_the_reference_of_today():
    """docs/case_file.md quotes ``gearfem keys``: regenerate it with
    ``gearfem keys --docs docs/case_file.md`` when an option, default or docstring changes."""
    page = ROOT / "docs" / "case_file.md"
    assert read_block(page, "case_keys") == case_keys.markdown()


def test_docstring_entries_and_checks_are_read():
    doc = case_keys.docstring_entries(_Toy)
    assert (
        doc["width_mm"]
        == doc["height_mm"]
        == ("Sides of the box (mm), the second continued on an indented line.")
    )
    assert doc["count"] == "How many."  # the Notes section's "count:" is no entry
    assert doc["shape"] == '`"round"` or `"square"`; see `gearfem.case_keys.markdown`.'
    checks = case_keys.accepted_values(_Toy)
    assert checks == {
        "width_mm": "(0, 5] mm",
        "count": "integer in [1, 8]",
        "shape": '"round", "square"',
    }  # height_mm's bound depends on another key: not listed


def test_every_table_of_the_case_is_listed_with_the_builtin_values():
    tables = {t.name: t for t in case_keys.case_tables()}
    expected = {"", "geometry", "mesh", "thermal_mesh", "material", "material_wheel", "contact",
                "friction", "cycle", "operating", "sources", "thermal", "baselines",
                "instruments.camera", case_keys.PROBE_TABLE, "instruments.torque"}  # fmt: skip
    assert expected <= set(tables)
    layers = next(k for k in tables["mesh"].keys if k.name == "layers")
    assert (layers.default, layers.builtin) == ("3", "4")  # thesis_case.toml grades 4 layers
    mu = next(k for k in tables["contact"].keys if k.name == "friction_coefficient")
    assert mu.default == "0.5" and mu.builtin == ""  # the thesis's mu in both
    assert tables["thermal_mesh"].absent and tables["material_wheel"].absent
    assert not tables["operating"].absent


def test_an_unknown_table_is_an_error_naming_the_tables():
    with pytest.raises(ParameterError, match="thermal, baselines"):
        case_keys.text("thermals")
    assert case_keys.text("operating").startswith("[operating]")


def test_the_reference_is_not_code_a_quoted_result_hashes():
    for roots in (RUN_CODE, DIAGNOSIS_CODE):
        assert "gearfem.case_keys" not in source_files(*roots)


def test_gearfem_keys_prints_a_table_writes_the_page_and_refuses_an_unknown_table(tmp_path, capsys):
    """A serial test (not mpi-marked): one rank prints and writes."""
    assert main(["keys", "operating"]) == 0
    out = capsys.readouterr().out
    assert "speed_rpm = 1000.0" in out and "Resisting torque on the wheel (N m)." in out
    page = tmp_path / "page.md"
    page.write_text("# x\n\n<!-- gearfem:begin case_keys -->\n<!-- gearfem:end case_keys -->\n")
    assert main(["keys", "--docs", str(page)]) == 0
    assert read_block(page, "case_keys") == case_keys.markdown()
    assert main(["keys", "thermals"]) != 0
    case = tmp_path / "case.toml"
    case.write_text("[operating]\ntorque_Nm = 4.0\n")
    assert main(["keys", "operating", "--case", str(case)]) == 0
    assert "torque_Nm = 8.0    this case: 4.0" in capsys.readouterr().out
