"""Quoted results belong to the shipped model (gearfem.claims): the README's headline, the bench
readings and the verdict carry the resolution key and code hash they were computed with, and a
change of either leaves them marked stale."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from gearfem import claims
from gearfem.config import load_case
from gearfem.core.doctables import Provenance, blocks, replace_block
from gearfem.core.provenance import _code_of, code_hash, source_files
from gearfem.uncertainty import DIAGNOSIS_CODE, RUN_CODE, provenance, resolution_key

ROOT = Path(__file__).resolve().parent.parent


def test_quoted_results_belong_to_the_shipped_model():
    """Every block of the README and docs that quotes a result of the built-in case was computed
    at the built-in case's resolution with today's code (``gearfem claims`` lists the others and
    the command that regenerates each)."""
    stale = claims.unmarked(claims.stale_claims(ROOT))
    assert not stale, "stale quoted results without a stale note:\n" + "\n".join(
        f"{c}  [{claims.regenerate_command(c)}]" for c in stale
    )


def _page(tmp_path: Path, prov: Provenance | None) -> Path:
    (tmp_path / "docs").mkdir(exist_ok=True)
    readme = tmp_path / "README.md"
    readme.write_text(
        "# x\n\n<!-- gearfem:begin readme_headline -->\n<!-- gearfem:end readme_headline -->\n"
        "<!-- gearfem:begin readme_verdict -->\n<!-- gearfem:end readme_verdict -->\n"
    )
    for name in ("readme_headline", "readme_verdict"):
        replace_block(readme, name, "| a |\n|---|\n| 1 |", provenance=prov)
    return readme


def test_a_changed_resolution_or_code_makes_a_quoted_block_stale(tmp_path):
    builtin = load_case(None)
    now = provenance(builtin)
    assert now.resolution == resolution_key(builtin)
    readme = _page(tmp_path, now)
    assert Provenance.parse(blocks(readme)["readme_headline"]) == now
    # the other pages of QUOTED_BLOCKS are absent here: only the README is checked
    assert claims.stale_claims(tmp_path) == []
    # a deliberately edited resolution key
    _page(tmp_path, dataclasses.replace(now, resolution="0123456789abcdef"))
    stale = claims.stale_claims(tmp_path)
    assert {c.block for c in stale} == {"readme_headline", "readme_verdict"}
    assert all("resolution 0123456789abcdef" in c.reason for c in stale)
    assert all(c.resolution and c.module is None for c in stale)
    # the built-in case's resolution changed under the quoted block
    _page(tmp_path, now)
    finer = dataclasses.replace(
        builtin, mesh=dataclasses.replace(builtin.mesh, layers=builtin.mesh.layers + 1)
    )
    assert len(claims.stale_claims(tmp_path, builtin=finer)) == 2
    # code older than the modules
    module = next(iter(now.code))
    _page(tmp_path, dataclasses.replace(now, code={module: "000000000000"}))
    stale = claims.stale_claims(tmp_path)
    assert len(stale) == 2 and all(f"{module}@000000000000" in c.reason for c in stale)
    assert all(c.module == module and not c.resolution for c in stale)
    # no provenance at all on a block that quotes the built-in case
    _page(tmp_path, None)
    assert {c.reason for c in claims.stale_claims(tmp_path)} == {"no provenance line"}
    assert claims.regenerate_command(claims.stale_claims(tmp_path)[0])


def test_a_stale_block_says_so_until_it_is_written_again(tmp_path):
    """``gearfem claims --mark`` (:func:`claims.mark_stale`) puts a visible note into a stale
    block, which the check then accepts; regenerating the block removes the note; a note on a
    current block is itself reported."""
    now = provenance(load_case(None))
    module = next(iter(now.code))
    old = dataclasses.replace(
        now, code={module: "000000000000"}, commit="abc1234", date="2026-01-02"
    )
    readme = _page(tmp_path, old)
    assert len(claims.unmarked(claims.stale_claims(tmp_path))) == 2
    assert claims.mark_stale(tmp_path) == []
    stale = claims.stale_claims(tmp_path)
    assert len(stale) == 2 and all(c.marked for c in stale) and not claims.unmarked(stale)
    text = blocks(readme)["readme_headline"]
    assert Provenance.parse(text) == old  # the provenance line stays first
    assert claims.STALE_MARK in text and "Computed at abc1234 on 2026-01-02" in text
    assert f"`{module}`" in text and "| a |" in text
    assert claims.mark_stale(tmp_path) == [] and blocks(readme)["readme_headline"] == text  # once
    # the block written again: the note is gone, the block current
    replace_block(readme, "readme_headline", "| a |\n|---|\n| 2 |", provenance=now)
    assert claims.STALE_MARK not in blocks(readme)["readme_headline"]
    assert [c.block for c in claims.stale_claims(tmp_path)] == ["readme_verdict"]
    # a note left on a current block (code put back as it was) is reported, and --mark clears it
    _page(tmp_path, old)
    claims.mark_stale(tmp_path)
    src = readme.read_text()
    readme.write_text(src.replace(f"{module}@000000000000", f"{module}@{now.code[module]}"))
    left = claims.unmarked(claims.stale_claims(tmp_path))
    assert len(left) == 2 and all("marked stale, but current" in c.reason for c in left)
    assert claims.mark_stale(tmp_path) == [] and claims.stale_claims(tmp_path) == []
    assert blocks(readme)["readme_headline"].endswith("| 1 |")


def test_the_list_of_quoted_blocks_is_not_code_they_quote():
    """gearfem.claims (the quoted blocks and their check) is outside the code a run or a diagnosis
    hashes: adding a block, or a command, leaves the quoted figures current."""
    for roots in (RUN_CODE, DIAGNOSIS_CODE):
        closure = source_files(*roots)
        assert roots[0] in closure and "gearfem.uncertainty" in closure
        assert "gearfem.claims" not in closure


def test_code_hash_follows_the_code_not_its_docstrings(tmp_path):
    a, b, c = (tmp_path / f"{n}.py" for n in "abc")
    a.write_text('"""Doc."""\n\ndef f(x):\n    """Twice."""\n    return 2 * x  # comment\n')
    b.write_text('"""Other doc."""\n\ndef f(x):\n    """Two times x."""\n    return 2 * x\n')
    c.write_text('"""Doc."""\n\ndef f(x):\n    """Twice."""\n    return 3 * x\n')
    assert _code_of(a) == _code_of(b)
    assert _code_of(a) != _code_of(c)
    assert code_hash("gearfem.pipeline") == code_hash("gearfem.pipeline")
    assert code_hash("gearfem.pipeline") != code_hash("gearfem.core.doctables")


@pytest.mark.parametrize("text", ["| a |", "<!-- gearfem:provenance -->\n| a |"])
def test_a_block_without_fields_is_not_a_provenance(text):
    prov = Provenance.parse(text)
    assert prov is None or (prov.resolution is None and prov.code == {})


def test_each_quoted_block_has_one_command_and_the_commands_run_once_in_order():
    written = [b for r in claims.REGENERATIONS for b in r.blocks]
    assert len(written) == len(set(written))
    assert {(p, b) for p, names in claims.QUOTED_BLOCKS.items() for b in names} == set(written)
    # the verdict's three blocks stale: its one command (the diagnosis of about 40 min), once;
    # with the headline as well: the bench points' runs first, which the headline reads
    verdict = [
        claims.StaleClaim(p, b, "x") for p, b in written if "verdict" in b and "balanced" not in b
    ]
    steps = claims.regenerations(verdict)
    assert len(steps) == 1 and "--verdict" in steps[0].command
    # the verdict on the balanced model: a diagnosis of its own, into its own block
    balanced = claims.regenerations(
        [claims.StaleClaim("docs/diagnosis.md", "bench_verdict_balanced", "x")]
    )
    assert len(balanced) == 1 and "--pass-balance tooth" in balanced[0].command
    assert balanced[0].command != steps[0].command
    headline = claims.StaleClaim("README.md", "readme_headline", "x")
    steps = claims.regenerations([headline, *verdict])
    assert "benchmarks/headline.py" in steps[0].command and "--verdict" in steps[1].command
    order = [r.command for r in claims.REGENERATIONS]
    first = next(
        r for r in claims.REGENERATIONS if ("docs/reproduction.md", "bench_camera") in r.blocks
    )
    assert order.index(first.command) < order.index(steps[0].command)


def test_a_demo_block_is_checked_against_its_own_case(tmp_path):
    """A block that quotes a demo's case (steel_pom_demo: demos/steel_pom.toml) is current at that
    case's resolution and stale at the built-in case's, the other way round from the README's."""
    step = next(
        r for r in claims.REGENERATIONS if ("docs/materials.md", "steel_pom_demo") in r.blocks
    )
    (page, name), case_file = step.blocks[0], step.case
    (tmp_path / "demos").mkdir()
    (tmp_path / case_file).write_text((ROOT / case_file).read_text())
    (tmp_path / "docs").mkdir()
    doc = tmp_path / page
    doc.write_text(f"<!-- gearfem:begin {name} -->\n<!-- gearfem:end {name} -->\n")
    own = provenance(load_case(ROOT / case_file))
    assert own.resolution != resolution_key(load_case(None))
    replace_block(doc, name, "| a |\n|---|\n| 1 |", provenance=own)
    assert [c for c in claims.stale_claims(tmp_path) if c.block == name] == []
    replace_block(doc, name, "| a |\n|---|\n| 1 |", provenance=provenance(load_case(None)))
    (stale,) = [c for c in claims.stale_claims(tmp_path) if c.block == name]
    assert f"its case's is {own.resolution}" in stale.reason
