"""How long gearfem's loops take on this machine: the main job, a further torque and speed, the
cycle and the thermal run on 1 and 2 ranks, the bench diagnosis (the jobs), and the tests.

Every figure is measured by running the command a user runs, in a subprocess, with empty caches
where the figure is "from scratch" (``GEARFEM_CACHE`` and ``GEARFEM_MESH_CACHE`` in a temporary
directory; the FFCx cache of ``~/.cache/fenics`` is kept, as on any machine after its first run):

* **main job**: ``mpirun -n 2 gearfem run`` of the built-in case with empty caches (mesh,
  compliances, cycle, thermal meshes), its stages from ``summary.json`` (cycle with mesh and
  compliances, thermal, instruments), the cycle's Newton iterations per position, and the CPU
  time of the ranks split into user and system time (system time is what ranks waiting in MPI
  spend, and the sign of a rank idling while the other works);
* **a further torque** (4 N m: a new cycle, the compliances stored) and **a further speed**
  (2000 rpm at 8 N m: the cycle stored, the thermal and camera runs only);
* **1 against 2 ranks** (also alone: ``--ranks``): ``gearfem run`` of the 4 N m case on 1 and on 2
  ranks with the compliances stored and the cycle not; the speed-up of each stage (the cycle, the
  thermal runs of both gears: ``summary.json``'s wall times) and of the whole command (start-up,
  outputs and the instruments, which rank 0 evaluates, included);
* **bench diagnosis**: ``demos/bench_camera.py --verdict --skip-runs --no-doc`` (``gearfem
  diagnose --suggest`` of the bench against the built-in case, the whole library) with a cold
  surrogate cache (the case's cycles at the bench torques stored by the runs before; the cycles
  of the tip-round radius's input-uncertainty variants computed);
* **the tests** (``--suite``: after the jobs; ``--tests``: alone): ``./dev.sh test`` and
  ``./dev.sh test --quick`` in a fresh clone of the repository's HEAD each, with an empty FFCx
  cache (``XDG_CACHE_HOME``) as on a CI machine, set-up and the forms' compilation included;
  each split into set-up (the venv), the 1-rank tier and the ``mpirun`` tier as dev.sh reports
  them.

Prints the tables and, with ``--docs``, writes the jobs' into block ``loops`` of
docs/performance.md and their one-line summary into block ``readme_timings`` of README.md, the
rank comparison into block ``loops_ranks``, the tests' into blocks ``test_tiers`` and
``readme_test_timings``: each block says the commit it was measured at, so the tests (20 min) or
the ranks (15 min) can be measured again without the jobs (an hour).

With ``--log-dir DIR`` each command's output is kept in ``DIR/NAME.log``, the jobs' logs at INFO
level with a time on every line: where each job's time goes.

    python benchmarks/performance/loops.py [--suite | --tests | --ranks] [--docs] [--log-dir DIR]
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.linalg as sla
from threadpoolctl import threadpool_limits

from gearfem.config import load_case, write_case
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.provenance import git_hash

ROOT = Path(__file__).resolve().parents[2]
VENV = Path(sys.executable).parent


def machine_reference_s(repeats: int = 3) -> float:
    """Seconds of a fixed single-core workload, the kind of work a contact position does (an LU
    of a dense 3000 x 3000 matrix and a copy of 320 MB), the least of ``repeats``: how fast the
    machine was when a table was measured. The project's machine runs the same job up to 1.8
    times slower on some hours than on others; two tables compare by their figures over this."""
    rng = np.random.default_rng(0)
    a = rng.standard_normal((3000, 3000))
    big = np.ones(40_000_000)
    best = float("inf")
    with threadpool_limits(1):
        for _ in range(repeats):
            t0 = time.perf_counter()
            sla.lu_factor(a)
            big.copy()
            best = min(best, time.perf_counter() - t0)
    return best


def machine_name() -> str:
    """The machine a table was measured on: its cores and processor."""
    return f"{os.cpu_count()} cores, {platform.processor() or platform.machine()}"


def measured_by(command: str, commit: str, reference_s: tuple[float, float]) -> str:
    """The provenance sentence of a measured table: ``command``, the ``commit`` measured (taken
    before the script writes its first table into the repository, which leaves it dirty), the
    date, the machine, its load now and :func:`machine_reference_s` at the start and the end of
    the measurement (``reference_s``)."""
    start, end = reference_s
    return (
        f"Measured by `python {command}` at {commit} on {datetime.date.today().isoformat()} "
        f"({machine_name()}; load average {os.getloadavg()[0]:.1f} at the end; machine "
        f"reference {start:.2f} s at the start, {end:.2f} s at the end)."
    )


def run_command(
    cmd: list[str],
    env: dict,
    cwd: Path = ROOT,
    name: str | None = None,
    log_dir: Path | None = None,
) -> dict:
    """Run ``cmd``; its wall, user and system time (children) and whether it succeeded. With
    ``name`` and ``log_dir``, its output goes to ``log_dir/name.log`` as well."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, cwd=cwd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if log_dir is not None and name is not None:
        log_dir.mkdir(parents=True, exist_ok=True)
        (log_dir / f"{name}.log").write_text(
            f"$ {' '.join(cmd)}\n{proc.stdout}\n{proc.stderr}wall {wall:.1f} s\n"
        )
    if proc.returncode != 0:
        sys.stderr.write(proc.stdout[-3000:] + proc.stderr[-3000:])
        raise SystemExit(f"failed ({proc.returncode}): {' '.join(cmd)}")
    return {
        "wall_s": wall,
        "user_s": after.ru_utime - before.ru_utime,
        "sys_s": after.ru_stime - before.ru_stime,
        "stdout": proc.stdout,
        "stderr": proc.stderr,
    }


def gearfem_command(np_: int, *args: str) -> list[str]:
    """``mpirun -n np_ gearfem args...`` with the virtual environment's mpirun and gearfem."""
    return [str(VENV / "mpirun"), "-n", str(np_), str(VENV / "gearfem"), *args]


def _case(tmp: Path, name: str, **operating) -> Path:
    """The built-in case at another operating point, as a case file."""
    path = tmp / f"{name}.toml"
    write_case(load_case(None).with_operating(**operating), path)
    return path


def _job_env(tmp: Path, log_dir: Path | None) -> dict:
    """The jobs' environment: caches in ``tmp`` (empty at first), no window; with ``log_dir`` the
    logs at INFO, a time on every line (where each job's time goes)."""
    env = dict(os.environ, PYVISTA_OFF_SCREEN="true", MPLBACKEND="Agg")
    env["GEARFEM_CACHE"] = str(tmp / "cache")
    env["GEARFEM_MESH_CACHE"] = str(tmp / "meshes")
    env["GEARFEM_LOG_LEVEL"] = "INFO" if log_dir is not None else "WARNING"
    return env


def measure_ranks(
    env: dict, tmp: Path, case: Path, log_dir: Path | None
) -> list[tuple[str, str, str, str]]:
    """1 against 2 ranks: ``gearfem run`` of ``case`` with its compliances stored (in
    ``env["GEARFEM_CACHE"]``) and its cycle not, in a copy of that cache without cycles (the
    cache itself keeps the cycles a later job is said to find stored). Rows for each stage of the
    run (``summary.json``'s wall times: the cycle with its mesh and stored compliances, the
    thermal runs of both gears) and for the whole command, which holds the start-up, the
    outputs and the instruments (evaluated on rank 0) as well."""
    cache = Path(env["GEARFEM_CACHE"])
    ranks_cache = tmp / "cache_ranks"
    shutil.copytree(cache, ranks_cache, ignore=shutil.ignore_patterns("cycles"))
    renv = dict(env, GEARFEM_CACHE=str(ranks_cache))
    walls, stages = {}, {}
    for n in (1, 2):
        shutil.rmtree(ranks_cache / "cycles", ignore_errors=True)
        out = tmp / f"ranks{n}"
        cmd = gearfem_command(n, "run", str(case), "--out", str(out))
        walls[n] = run_command(cmd, renv, name=f"ranks{n}", log_dir=log_dir)["wall_s"]
        summary = json.loads((out / "summary.json").read_text())
        stages[n] = summary["wall_time_s"]
    positions = summary["cycle"]["positions"]
    rows = []
    for label, t1, t2, target, note in (
        (
            "cycle stage",
            stages[1]["cycle_s"],
            stages[2]["cycle_s"],
            "speed-up 1.7",
            f"mesh and compliances stored, {positions} positions",
        ),
        (
            "thermal stage",
            stages[1]["thermal_s"],
            stages[2]["thermal_s"],
            "speed-up 1.7",
            "both gears",
        ),
        (
            "the whole gearfem run",
            walls[1],
            walls[2],
            "-",
            f"with start-up, outputs and instruments (rank 0: {stages[2]['instruments_s']:.0f} s)",
        ),
    ):
        rows.append(
            (
                f"{label}, 1 against 2 ranks",
                f"{t1:.0f} s / {t2:.0f} s, speed-up {t1 / t2:.2f}",
                target,
                note,
            )
        )
    return rows


def measure_jobs(log_dir: Path | None) -> tuple[list[tuple[str, str, str, str]], dict]:
    """The jobs' rows and figures (main job, further torque and speed, diagnosis), and the rank
    comparison's rows (:func:`measure_ranks`) in ``facts["ranks"]``."""
    rows: list[tuple[str, str, str, str]] = []
    facts: dict = {}
    tmp = Path(tempfile.mkdtemp(prefix="gearfem-loops-"))
    env = _job_env(tmp, log_dir)
    try:
        # the main job, empty caches
        r = run_command(
            gearfem_command(2, "run", "--out", str(tmp / "main")), env, name="main", log_dir=log_dir
        )
        s = json.loads((tmp / "main" / "summary.json").read_text())
        w, c = s["wall_time_s"], s["cycle"]
        its = c["newton_iterations"] / c["positions"]
        facts["main_s"] = r["wall_s"]
        rows += [
            ("main job, empty caches (2 ranks)", f"{r['wall_s']:.0f} s", "2 min", "gearfem run"),
            (
                "  of which cycle (mesh, compliances, positions)",
                f"{w['cycle_s']:.0f} s",
                "",
                f"{c['positions']} positions, {its:.1f} Newton iterations per position; "
                f"compliances {c['info'].get('condensation_s', 0):.0f} s",
            ),
            ("  thermal (both gears)", f"{w['thermal_s']:.0f} s", "", ""),
            ("  camera", f"{w.get('instruments_s', 0):.0f} s", "", ""),
            (
                "  CPU time of the ranks",
                f"user {r['user_s']:.0f} s, system {r['sys_s']:.0f} s",
                "",
                "system time: ranks waiting in MPI",
            ),
        ]
        t4 = _case(tmp, "torque4", torque_Nm=4.0)
        cmd = gearfem_command(2, "run", str(t4), "--out", str(tmp / "t4"))
        r = run_command(cmd, env, name="torque4", log_dir=log_dir)
        rows.append(
            ("a further torque (4 N m)", f"{r['wall_s']:.0f} s", "30 s", "compliances stored")
        )
        s2 = _case(tmp, "speed2000", speed_rpm=2000.0)
        cmd = gearfem_command(2, "run", str(s2), "--out", str(tmp / "s2"))
        r = run_command(cmd, env, name="speed2000", log_dir=log_dir)
        rows.append(("a further speed (2000 rpm)", f"{r['wall_s']:.0f} s", "15 s", "cycle stored"))
        facts["ranks"] = measure_ranks(env, tmp, t4, log_dir)
        # the bench diagnosis, cold surrogate cache (cycles stored)
        shutil.rmtree(tmp / "cache" / "surrogate", ignore_errors=True)
        r = run_command(
            [
                str(VENV / "mpirun"), "-n", "2", sys.executable,
                str(ROOT / "demos" / "bench_camera.py"), "--verdict", "--skip-runs", "--no-doc",
                "--out", str(tmp / "verdict"),
            ],
            env,
            name="diagnosis",
            log_dir=log_dir,
        )  # fmt: skip
        facts["diagnosis_s"] = r["wall_s"]
        rows.append(
            (
                "bench diagnosis with --suggest (2 ranks)",
                f"{r['wall_s']:.0f} s",
                "10 min",
                "cold surrogate; the case's cycles at 4 and 8 N m stored, the tip-round "
                "variants' (input uncertainty) computed",
            )
        )
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return rows, facts


def measure_ranks_alone(log_dir: Path | None) -> list[tuple[str, str, str, str]]:
    """:func:`measure_ranks` without the other jobs: empty caches, the compliances computed first
    by ``gearfem cycle`` of the 4 N m case on 2 ranks (not timed)."""
    tmp = Path(tempfile.mkdtemp(prefix="gearfem-ranks-"))
    env = _job_env(tmp, log_dir)
    try:
        t4 = _case(tmp, "torque4", torque_Nm=4.0)
        cmd = gearfem_command(2, "cycle", str(t4), "--out", str(tmp / "compliances"))
        run_command(cmd, env, name="compliances", log_dir=log_dir)
        rows = measure_ranks(env, tmp, t4, log_dir)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return rows


#: dev.sh's lines with the time of each tier (``[dev.sh] ... passed in N s``)
_TIER_LINES = {
    "one_rank_s": re.compile(r"serial tests passed in (\d+) s"),
    "mpi_s": re.compile(r"mpirun -n \d+ tests passed in (\d+) s"),
}


_DURATION = re.compile(r"^([\d.]+)s (setup|call|teardown)\s+tests/([^:\s]+)::(\S+)", re.M)


def module_times(stdout: str) -> list[tuple[str, str, str, str]]:
    """Where the suite's time goes, from pytest's ``--durations=0`` report of each tier (the
    1-rank tier's report first, the mpirun tier's second): per test module, its seconds in each
    tier (the 1-rank tier's are worker seconds: its wall time is about half their sum on 2
    workers) and its longest item, longest modules first."""
    sections = re.split(r"slowest (?:\d+ )?durations", stdout)[1:]
    per: dict[str, list[float]] = {}
    longest: dict[str, tuple[float, str]] = {}
    for tier, text in enumerate(sections[:2]):
        for m in _DURATION.finditer(text):
            t, phase, module, test = float(m.group(1)), m.group(2), m.group(3), m.group(4)
            per.setdefault(module, [0.0, 0.0])[tier] += t
            if t > longest.get(module, (0.0, ""))[0]:
                longest[module] = (t, f"{test} ({phase}, {t:.0f} s)")
    order = sorted(per, key=lambda k: -sum(per[k]))
    total = [sum(v[i] for v in per.values()) for i in (0, 1)]
    rows = [(f"`{k}`", f"{per[k][0]:.0f}", f"{per[k][1]:.0f}", longest[k][1]) for k in order[:15]]
    rest = [sum(per[k][i] for k in order[15:]) for i in (0, 1)]
    rows.append((f"{len(order) - 15} other modules", f"{rest[0]:.0f}", f"{rest[1]:.0f}", ""))
    rows.append(("all", f"{total[0]:.0f}", f"{total[1]:.0f}", ""))
    return rows


def measure_tests(log_dir: Path | None) -> tuple[list[tuple[str, str, str, str]], dict]:
    """``./dev.sh test`` and ``./dev.sh test --quick``, each in a fresh clone of HEAD with an empty
    FFCx cache, as on a CI machine: set-up (the venv) and the forms' compilation included. The
    full suite runs with pytest's ``--durations=0``: ``facts["modules"]`` holds
    :func:`module_times`."""
    rows: list[tuple[str, str, str, str]] = []
    facts: dict = {}
    tmp = Path(tempfile.mkdtemp(prefix="gearfem-tests-"))
    senv = {k: v for k, v in os.environ.items() if not k.startswith("GEARFEM_")}
    try:
        for key, args, label, target in (
            ("suite", [], "./dev.sh test", "15 min"),
            ("quick", ["--quick"], "./dev.sh test --quick", "3 min"),
        ):
            clone = tmp / f"clone_{key}"
            subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
            senv["XDG_CACHE_HOME"] = str(tmp / f"xdg_{key}")
            report = ["--durations=0"] if key == "suite" else []
            cmd = ["./dev.sh", "test", *args, *report]
            r = run_command(cmd, senv, cwd=clone, name=f"tests_{key}", log_dir=log_dir)
            tiers = {}
            for name, pattern in _TIER_LINES.items():
                m = pattern.search(r["stderr"])
                if m is None:
                    raise SystemExit(f"{label}: dev.sh did not report {name} ({pattern.pattern})")
                tiers[name] = float(m.group(1))
            setup = r["wall_s"] - tiers["one_rank_s"] - tiers["mpi_s"]
            facts[f"{key}_s"] = r["wall_s"]
            if key == "suite":
                facts["modules"] = module_times(r["stdout"])
            rows.append(
                (
                    f"{label}, fresh clone",
                    f"{r['wall_s'] / 60:.1f} min",
                    target,
                    f"set-up {setup:.0f} s, 1-rank tier {tiers['one_rank_s']:.0f} s, "
                    f"mpirun -n 2 tier {tiers['mpi_s']:.0f} s",
                )
            )
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return rows, facts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    what = ap.add_mutually_exclusive_group()
    what.add_argument("--suite", action="store_true", help="the jobs, then the tests")
    what.add_argument("--tests", action="store_true", help="only the tests (fresh clones)")
    what.add_argument(
        "--ranks", action="store_true", help="only the comparison of 1 and 2 ranks (empty caches)"
    )
    ap.add_argument("--docs", action="store_true", help="write docs/performance.md and README.md")
    ap.add_argument("--log-dir", default=None, help="keep each command's output in DIR/NAME.log")
    a = ap.parse_args()
    log_dir = Path(a.log_dir) if a.log_dir else None
    today = datetime.date.today().isoformat()
    commit = git_hash(ROOT)
    reference_start = machine_reference_s()

    def measured(flag: str, reference_end: float) -> str:
        return measured_by(
            f"benchmarks/performance/loops.py{flag}", commit, (reference_start, reference_end)
        )

    def publish_block(head, rows, flag: str, block: str, reference_end: float) -> None:
        """Print the table; with --docs, write it into block ``block`` of docs/performance.md."""
        text = f"{markdown_table(head, rows)}\n\n{measured(flag, reference_end)}"
        print(text)
        if a.docs:
            replace_block(ROOT / "docs" / "performance.md", block, text)

    def publish(head, rows, flag, block, reference_end, readme_block: str, line: str, link: str):
        """:func:`publish_block`, and with --docs ``line`` with the commit and date (and
        ``link``) into the README's ``readme_block``."""
        publish_block(head, rows, flag, block, reference_end)
        if a.docs:
            stamp = (
                f"Measured at {commit} on {today} (machine reference {reference_start:.2f} s: "
                f"docs/performance.md) by `benchmarks/performance/loops.py{flag}`"
            )
            replace_block(ROOT / "README.md", readme_block, f"{line} {stamp}{link}.")

    ranks_head = ("comparison", "time", "target", "note")
    if a.ranks:
        rows = measure_ranks_alone(log_dir)
        publish_block(ranks_head, rows, " --ranks", "loops_ranks", machine_reference_s())
    elif not a.tests:
        rows, facts = measure_jobs(log_dir)
        reference_end = machine_reference_s()
        publish(
            ("loop", "time", "target", "note"), rows, "", "loops", reference_end, "readme_timings",
            f"On this project's machine ({machine_name()}): the main job takes "
            f"{facts['main_s'] / 60:.1f} min with empty caches, the bench diagnosis "
            f"{facts['diagnosis_s'] / 60:.1f} min.",
            " ([docs/performance.md](docs/performance.md))",
        )  # fmt: skip
        publish_block(ranks_head, facts["ranks"], "", "loops_ranks", reference_end)
    if a.suite or a.tests:
        rows, facts = measure_tests(log_dir)
        reference_end = machine_reference_s()
        publish(
            ("tests", "time", "target", "of which"), rows, " --tests", "test_tiers",
            reference_end, "readme_test_timings",
            f"The tests take {facts['suite_s'] / 60:.1f} min from a fresh clone (quick tier "
            f"{facts['quick_s'] / 60:.1f} min), set-up included.",
            "",
        )  # fmt: skip
        text = (
            markdown_table(
                ("test module", "1-rank tier (worker s)", "mpirun -n 2 tier (s)", "longest item"),
                facts["modules"],
            )
            + "\n\nThe full suite's run above, from pytest's `--durations=0`: setup, call and "
            "teardown of every item, summed per module. " + measured(" --tests", reference_end)
        )
        print(text)
        if a.docs:
            replace_block(ROOT / "docs" / "performance.md", "test_modules", text)


if __name__ == "__main__":
    main()
