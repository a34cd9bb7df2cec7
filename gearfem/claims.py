"""Quoted results and the model they belong to: stale claims.

The README and the pages in ``docs/`` quote results of the built-in case (and of a demo's case,
named in :data:`REGENERATIONS`): the main job's headline, the bench readings, the bench verdict
with its intervals and the confirmation table, the steel/POM demo. Each is
written between ``<!-- gearfem:begin NAME -->`` markers by the script that computes it
(:mod:`gearfem.core.doctables`), headed by a provenance line
(:func:`gearfem.uncertainty.provenance`): the resolution key of the case it was computed on and
the code hash of the modules that computed it. A change of the model (a new
resolution of the built-in case, an edit of the code) then leaves the quoted figure marked as
stale instead of standing beside a model that no longer gives it:

* :func:`stale_claims` lists every block whose provenance no longer matches: a resolution key that
  is not the built-in case's, a code hash that is not the current code's (docstrings and comments
  do not count, :func:`gearfem.core.provenance.code_hash`), and every block of
  :data:`QUOTED_BLOCKS` that carries no provenance at all;
* the test suite runs it (``tests/test_claims.py``), so a change of the model cannot leave the
  headline behind; ``gearfem claims`` prints the list with the command that regenerates each;
* a block that has not been written again yet says so where it stands: :func:`mark_stale`
  (``gearfem claims --mark``) puts a visible note under its provenance line, naming the commit and
  date it was computed at, the code that changed since and the command that writes it again. The
  test suite accepts a stale block only with that note (and a note only on a stale block), so a
  change of the model either regenerates a quoted figure or tells its reader it is outdated, never
  leaves it standing; regenerating the block removes the note;
* :data:`REGENERATIONS` holds those commands in the order to run them, each once for all the blocks
  it writes (:func:`regenerations` picks the ones a list of stale blocks needs);
  ``benchmarks/regenerate.py`` runs them and times each.

This module only checks: no run or diagnosis imports it, so adding a quoted block is not a change
of the code the quoted figures hash.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from gearfem.config import Case, load_case
from gearfem.core.doctables import Provenance, blocks, read_block, replace_block
from gearfem.core.provenance import code_hash
from gearfem.uncertainty import resolution_key

_BENCH_POINTS = "mpirun -n 2 python demos/bench_camera.py"
_FRICTION = "mpirun -n 2 python benchmarks/verification/"


@dataclasses.dataclass(frozen=True)
class Regeneration:
    """One command, run from the repository's root, and the quoted blocks it writes: ``(page,
    block)`` pairs, the page relative to the root. ``case``: the case file (relative to the root)
    the blocks quote, when it is not the built-in case; their resolution key is that case's."""

    command: str
    blocks: tuple[tuple[str, str], ...]
    case: str | None = None


#: The commands that write the quoted blocks, in the order to run them: the headline reads the
#: bench points' runs that the first leaves in ``results/``, and each command is run once for
#: all the blocks it writes (the bench diagnosis, about 40 min, writes four).
REGENERATIONS: tuple[Regeneration, ...] = (
    Regeneration(_BENCH_POINTS, (("docs/reproduction.md", "bench_camera"),)),
    Regeneration(
        "./dev.sh run && python benchmarks/headline.py results/thesis "
        "--other results/bench_2000rpm_4Nm",
        (("README.md", "readme_headline"),),
    ),
    Regeneration(
        f"{_BENCH_POINTS} --verdict --reproduce --confirm 1000/4,1000/6,1500/6,2000/8 --skip-runs",
        (
            ("docs/diagnosis.md", "bench_verdict"),
            ("README.md", "readme_verdict"),
            ("docs/diagnosis.md", "bench_verdict_confirm"),
        ),
    ),
    Regeneration(
        f"{_BENCH_POINTS} --verdict --skip-runs --pass-balance tooth --flash-half-width-um 100 "
        "--out results/balanced",
        (("docs/diagnosis.md", "bench_verdict_balanced"),),
    ),
    Regeneration(
        f"{_BENCH_POINTS} --diagnose tests/cases/coarse.toml --skip-runs",
        (("docs/diagnosis.md", "bench_camera_diagnosis"),),
        case="tests/cases/coarse.toml",
    ),
    Regeneration(
        "mpirun -n 2 python benchmarks/studies/vdi2736_gearfem.py --docs",
        (("docs/materials.md", "vdi2736_gearfem"),),
    ),
    Regeneration(
        f"{_FRICTION}friction_tractions.py --mu 0.13 --docs docs/friction.md",
        (("docs/friction.md", "friction_tractions"),),
    ),
    Regeneration(
        f"{_FRICTION}branch_switching.py --mu-glassy 0.13 --variants entry tip_radius "
        "flash_width --docs docs/friction.md",
        (("docs/friction.md", "branch_switching"),),
    ),
    Regeneration(
        f"{_FRICTION}branch_switching.py --mu-glassy 0.13 --variants entry --flash-width profile "
        "--docs docs/friction.md --block branch_switching_profile_flash",
        (("docs/friction.md", "branch_switching_profile_flash"),),
    ),
    Regeneration(
        "python benchmarks/verification/flash_convergence.py --docs docs/friction.md",
        (("docs/friction.md", "flash_convergence"),),
    ),
    Regeneration(
        f"{_FRICTION}branch_switching.py --mu-glassy 0.13 --variants entry tip_radius "
        "--flash-width stated --flash-half-width-um 100 --pass-balance tooth "
        "--docs docs/friction.md --block branch_switching_balanced",
        (("docs/friction.md", "branch_switching_balanced"),),
    ),
    Regeneration(
        f"{_FRICTION}friction_fixed_point.py --mu-glassy 0.13 --docs docs/friction.md",
        (("docs/friction.md", "friction_fixed_point"),),
    ),
    Regeneration(
        f"{_FRICTION}friction_fixed_point.py --mu-glassy 0.13 --cycle-mu effective "
        "--docs docs/friction.md --block friction_fixed_point_effective",
        (("docs/friction.md", "friction_fixed_point_effective"),),
    ),
    Regeneration(
        f"{_FRICTION}friction_fixed_point.py --mu-glassy 0.13 0.17 --start glassy "
        "--docs docs/friction.md --block friction_fixed_point_scan",
        (("docs/friction.md", "friction_fixed_point_scan"),),
    ),
    Regeneration(
        f"{_FRICTION}modulus_temperature.py --docs docs/materials.md",
        (("docs/materials.md", "modulus_temperature"),),
    ),
    Regeneration(
        f"{_FRICTION}modulus_temperature.py --case demos/steel_pom.toml --points 2000/8 3000/10 "
        "--block modulus_temperature_steel_pom --docs docs/materials.md",
        (("docs/materials.md", "modulus_temperature_steel_pom"),),
        case="demos/steel_pom.toml",
    ),
    Regeneration(
        f"{_FRICTION}modulus_temperature.py --case benchmarks/studies/cases/steel_pa66.toml "
        "--points 2000/8 3000/8 --block modulus_temperature_steel_pa66 --docs docs/materials.md",
        (("docs/materials.md", "modulus_temperature_steel_pa66"),),
        case="benchmarks/studies/cases/steel_pa66.toml",
    ),
    Regeneration(
        "mpirun -n 2 python demos/steel_pom.py --docs docs/materials.md",
        (("docs/materials.md", "steel_pom_demo"),),
        case="demos/steel_pom.toml",
    ),
    Regeneration(
        "mpirun -n 2 python benchmarks/studies/vdi2736_gearfem.py --case demos/steel_pom.toml "
        "--points 1000/2,1000/4,2000/2 --block vdi2736_gearfem_steel_pom --docs",
        (("docs/materials.md", "vdi2736_gearfem_steel_pom"),),
        case="demos/steel_pom.toml",
    ),
    Regeneration(
        "mpirun -n 2 python benchmarks/studies/vdi2736_gearfem.py "
        "--case benchmarks/studies/cases/pom_pom.toml --block vdi2736_gearfem_pom_pom --docs",
        (("docs/materials.md", "vdi2736_gearfem_pom_pom"),),
        case="benchmarks/studies/cases/pom_pom.toml",
    ),
    Regeneration(
        "mpirun -n 2 python benchmarks/studies/vdi2736_gearfem.py "
        "--case benchmarks/studies/cases/steel_pa66.toml --block vdi2736_gearfem_steel_pa66 --docs",
        (("docs/materials.md", "vdi2736_gearfem_steel_pa66"),),
        case="benchmarks/studies/cases/steel_pa66.toml",
    ),
)


def _by_page(steps: tuple[Regeneration, ...]) -> dict[str, dict[str, str]]:
    out: dict[str, dict[str, str]] = {}
    for step in steps:
        for page, block in step.blocks:
            out.setdefault(page, {})[block] = step.command
    return out


#: Blocks that quote results of the built-in case (or of a demo's case) and must carry a
#: provenance line, by page (relative to the repository root), with the command that writes them.
QUOTED_BLOCKS: dict[str, dict[str, str]] = _by_page(REGENERATIONS)


#: The line :func:`mark_stale` puts under a stale block's provenance line, above its visible note.
STALE_MARK = "<!-- gearfem:stale -->"


@dataclasses.dataclass(frozen=True)
class StaleClaim:
    """A quoted block that no longer belongs to the shipped model, and why. ``marked``: the block
    says so to its reader (:func:`mark_stale`). What changed, where it is one of the two things a
    block hashes: ``resolution`` (the block's case has another resolution) or ``module`` (the code
    of that module, with what it imports); ``reason`` says it in words."""

    page: str
    block: str
    reason: str
    marked: bool = False
    resolution: bool = False
    module: str | None = None

    def __str__(self) -> str:
        return f"{self.page}: block {self.block!r}: {self.reason}" + " (marked)" * self.marked


def check_block(page: str, name: str, text: str, case_key: str, required: bool) -> list[StaleClaim]:
    """The reasons why block ``name`` of ``page`` is stale (empty: it is current), each marked
    when the block carries the stale note; a note on a current block is a reason of its own."""
    out = _stale_reasons(page, name, text, case_key, required)
    if STALE_MARK not in text:
        return out
    if not out:
        return [
            StaleClaim(page, name, "marked stale, but current: `gearfem claims --mark` clears it")
        ]
    return [dataclasses.replace(c, marked=True) for c in out]


def _stale_reasons(
    page: str, name: str, text: str, case_key: str, required: bool
) -> list[StaleClaim]:
    prov = Provenance.parse(text)
    if prov is None:
        return [StaleClaim(page, name, "no provenance line")] if required else []
    out = []
    if prov.resolution is not None and prov.resolution != case_key:
        out.append(
            StaleClaim(
                page,
                name,
                f"computed at resolution {prov.resolution}, its case's is {case_key}",
                resolution=True,
            )
        )
    for module, digest in prov.code.items():
        try:
            now = code_hash(module)
        except (OSError, SyntaxError):
            now = None
        if now != digest:
            out.append(
                StaleClaim(
                    page,
                    name,
                    f"computed with code {module}@{digest}, the current code is {module}@{now}",
                    module=module,
                )
            )
    return out


def stale_claims(root: str | Path, builtin: Case | None = None) -> list[StaleClaim]:
    """Every stale quoted block of the README and the docs pages under ``root`` (the repository),
    against the built-in case (or ``builtin``)."""
    root = Path(root)
    key = resolution_key(builtin if builtin is not None else load_case(None))
    own_case = {
        block: resolution_key(load_case(root / step.case))
        for step in REGENERATIONS
        if step.case is not None and (root / step.case).is_file()
        for block in step.blocks
    }
    pages = [root / "README.md", *sorted((root / "docs").rglob("*.md"))]
    out: list[StaleClaim] = []
    for path in pages:
        if not path.is_file():
            continue
        page = path.relative_to(root).as_posix()
        required = QUOTED_BLOCKS.get(page, {})
        found = blocks(path)
        for name in required:
            if name not in found:
                out.append(StaleClaim(page, name, "block missing from the page"))
        for name, text in found.items():
            block_key = own_case.get((page, name), key)
            out.extend(check_block(page, name, text, block_key, name in required))
    return out


def unmarked(found: list[StaleClaim]) -> list[StaleClaim]:
    """The claims of ``found`` whose block does not tell its reader (what the test suite fails
    on)."""
    return [c for c in found if not c.marked]


def mark_stale(root: str | Path, builtin: Case | None = None) -> list[StaleClaim]:
    """Put the stale note into every stale, unmarked block under ``root`` that has a provenance
    line, and take it out of every marked block that is current again; the claims still unmarked
    afterwards (blocks without a provenance line or missing from their page, which only their
    command can write)."""
    root = Path(root)
    found = stale_claims(root, builtin)
    by_block: dict[tuple[str, str], list[StaleClaim]] = {}
    for c in found:
        by_block.setdefault((c.page, c.block), []).append(c)
    for (page, name), items in by_block.items():
        path = root / page
        if not path.is_file() or name not in blocks(path):
            continue
        text = read_block(path, name)
        prov = Provenance.parse(text)
        if prov is None:
            continue
        if STALE_MARK in text:
            if any(c.marked for c in items):
                continue  # marked and stale: as it should be
            replace_block(path, name, _without_note(text))  # marked and current
        else:
            replace_block(path, name, _with_note(text, prov, items))
    return unmarked(stale_claims(root, builtin))


def _with_note(text: str, prov: Provenance, items: list[StaleClaim]) -> str:
    line, _, body = text.partition("\n")
    changed = []
    if any(c.resolution for c in items):
        changed.append("the case's resolution")
    modules = sorted({c.module for c in items if c.module is not None})
    if modules:
        changed.append(
            "the code of " + ", ".join(f"`{m}`" for m in modules) + " and what it imports"
        )
    at = (" at " + prov.commit if prov.commit else "") + (" on " + prov.date if prov.date else "")
    command = regenerate_command(items[0])
    note = (
        f"> **Not re-run on the current model.** Computed{at}; since then "
        f"{' and '.join(changed) or 'the model'} changed."
        + (f" `{command}` writes it again." if command else "")
    )
    return f"{line}\n{STALE_MARK}\n{note}\n\n{body.strip()}"


def _without_note(text: str) -> str:
    line, _, rest = text.partition("\n")
    body = rest.split(STALE_MARK, 1)[1].lstrip("\n").partition("\n\n")[2]
    return f"{line}\n{body.strip()}"


def regenerate_command(claim: StaleClaim) -> str | None:
    """The command that writes the block of ``claim`` (None: not one of :data:`QUOTED_BLOCKS`)."""
    return QUOTED_BLOCKS.get(claim.page, {}).get(claim.block)


def regenerations(found: list[StaleClaim]) -> list[Regeneration]:
    """The commands of :data:`REGENERATIONS` that write the blocks of ``found``, each once, in
    the order to run them (a stale block that no command writes is not among them)."""
    wanted = {(c.page, c.block) for c in found}
    return [r for r in REGENERATIONS if wanted.intersection(r.blocks)]


__all__ = [
    "QUOTED_BLOCKS",
    "REGENERATIONS",
    "STALE_MARK",
    "Regeneration",
    "StaleClaim",
    "check_block",
    "mark_stale",
    "regenerate_command",
    "regenerations",
    "stale_claims",
    "unmarked",
]
