"""Regenerate the quoted results of the README and docs, and time it.

A change of the code a quoted block hashes (or of the built-in case's resolution) leaves the
block stale (``gearfem claims``, :mod:`gearfem.claims`) until the command that writes it has run
again. This script runs those commands: the ones of :data:`gearfem.claims.REGENERATIONS` that
write a stale block (every one with ``--all``), each once, in that order (the headline reads the
bench points' runs the first command leaves in ``results/``), from the repository's root with the
virtual environment's ``mpirun`` and ``python`` first on the PATH. Each command's output goes to
``LOG_DIR/<n>.log``; after each, the blocks it writes must be current, or the script stops naming
the block and why it is still stale (a command that ran without writing its block, say with a
changed block name). A failed command stops the script with its exit code and the tail of its log:
the blocks already written stay, the later ones stay stale, and ``gearfem claims`` says which.

Prints, per command, its wall time and the CPU time of its processes (user and system; ranks
waiting in MPI show as system time), and the total: what a change of the quoted model costs before
it can land. ``--empty-caches`` runs with ``GEARFEM_CACHE`` and ``GEARFEM_MESH_CACHE`` in a new
temporary directory (the figures from scratch, as on a fresh machine); otherwise the caches are the
environment's. ``--dry-run`` lists the commands without running them. With ``--docs`` the table
goes into block ``claims_regeneration`` of docs/performance.md, with the commit it started at.

    python benchmarks/regenerate.py [--all] [--empty-caches] [--docs] [--dry-run] [--log-dir DIR]
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from gearfem import claims
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.provenance import git_hash

ROOT = Path(__file__).resolve().parent.parent
VENV_BIN = Path(sys.executable).parent


@dataclasses.dataclass(frozen=True)
class Timing:
    """What one command cost: wall time and the CPU time of its processes, in seconds."""

    wall_s: float
    user_s: float
    sys_s: float


def run_logged(command: str, log: Path, env: dict[str, str], cwd: Path = ROOT) -> Timing:
    """Run ``command`` with bash in ``cwd``, its output into ``log``; its :class:`Timing`. A
    non-zero exit raises SystemExit naming the command, the code and the log's last lines."""
    log.parent.mkdir(parents=True, exist_ok=True)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    with log.open("w") as out:
        proc = subprocess.run(
            ["bash", "-c", command], cwd=cwd, env=env, stdout=out, stderr=subprocess.STDOUT
        )
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        tail = "\n".join(log.read_text(errors="replace").splitlines()[-30:])
        raise SystemExit(
            f"{command!r} failed with exit code {proc.returncode} after {wall:.0f} s; "
            f"its log {log} ends:\n{tail}"
        )
    return Timing(wall, after.ru_utime - before.ru_utime, after.ru_stime - before.ru_stime)


def still_stale(step: claims.Regeneration, root: Path = ROOT) -> list[claims.StaleClaim]:
    """The blocks ``step`` writes that are stale after it ran (empty: it did its job)."""
    return [c for c in claims.stale_claims(root) if (c.page, c.block) in step.blocks]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--all", action="store_true", help="every command, not only the stale ones")
    ap.add_argument("--empty-caches", action="store_true", help="run with new, empty caches")
    ap.add_argument("--dry-run", action="store_true", help="list the commands, run nothing")
    ap.add_argument("--docs", action="store_true", help="write the table into docs/performance.md")
    ap.add_argument("--log-dir", default=str(ROOT / "results" / "regeneration"))
    a = ap.parse_args()
    steps = list(claims.REGENERATIONS) if a.all else claims.regenerations(claims.stale_claims(ROOT))
    if not steps:
        print("no stale claims: nothing to regenerate (--all runs every command)")
        return
    for n, step in enumerate(steps, 1):
        print(f"{n}. {step.command}\n   writes {', '.join(b for _, b in step.blocks)}")
    if a.dry_run:
        return
    env = dict(os.environ, PATH=f"{VENV_BIN}{os.pathsep}{os.environ.get('PATH', '')}")
    env.setdefault("PYVISTA_OFF_SCREEN", "true")
    env.setdefault("MPLBACKEND", "Agg")
    if a.empty_caches:
        tmp = Path(tempfile.mkdtemp(prefix="gearfem-regenerate-"))
        env.update(GEARFEM_CACHE=str(tmp / "cache"), GEARFEM_MESH_CACHE=str(tmp / "meshes"))
    commit, started = git_hash(ROOT), datetime.date.today().isoformat()
    rows = []
    total = Timing(0.0, 0.0, 0.0)
    for n, step in enumerate(steps, 1):
        print(f"[{time.strftime('%H:%M:%S')}] {n}/{len(steps)}: {step.command}", flush=True)
        t = run_logged(step.command, Path(a.log_dir) / f"{n}.log", env)
        left = still_stale(step)
        if left:
            raise SystemExit(
                f"{step.command!r} ran ({t.wall_s:.0f} s) but left stale: "
                + "; ".join(str(c) for c in left)
            )
        total = Timing(*(x + y for x, y in zip(dataclasses.astuple(total), dataclasses.astuple(t))))
        rows.append((f"`{step.command}`", ", ".join(b for _, b in step.blocks), *_minutes(t)))
        print(
            f"    {rows[-1][2]} min (user {rows[-1][3]} min, system {rows[-1][4]} min)", flush=True
        )
    rows.append(("all", f"{sum(len(s.blocks) for s in steps)} blocks", *_minutes(total)))
    flags = " --all" * a.all + " --empty-caches" * a.empty_caches
    text = (
        markdown_table(("command", "writes", "wall (min)", "user (min)", "system (min)"), rows)
        + f"\n\nMeasured by `python benchmarks/regenerate.py{flags}` at {commit} on {started} "
        f"({os.cpu_count()} cores, {platform.machine()}; caches "
        f"{'empty at the start' if a.empty_caches else 'as found'}; load average "
        f"{os.getloadavg()[0]:.1f} at the end)."
    )
    print(text)
    if a.docs:
        replace_block(ROOT / "docs" / "performance.md", "claims_regeneration", text)


def _minutes(t: Timing) -> tuple[str, str, str]:
    return f"{t.wall_s / 60:.1f}", f"{t.user_s / 60:.1f}", f"{t.sys_s / 60:.1f}"


if __name__ == "__main__":
    main()
