"""Hertz line contact side by side with CalculiX (ccx 2.20) on the identical nodes: p0 error and
wall time of both codes at each mesh size.

The problem is ``gearfem.contact.verification.hertz_case``: two equal half-cylinders (R = 1 m,
E = 1 Pa, ν = 0.3) pressed together by 4 mm in plane strain (1-layer P2 slab, thickness 2h,
u_z = 0 on the front and back faces, the lower flat face clamped in the plane, the upper flat face
moved down). For CalculiX the DOLFINx mesh of that case is written as C3D10 elements (the same
10-node tetrahedra, node for node: the gmsh nodes DOLFINx holds, renumbered), with the same
boundary conditions and one-pass surface-to-surface penalty contact (slave: the lower cylinder,
master: the upper one), linear pressure-overclosure with K = 10 E/h, frictionless.

Both codes are compared with Hertz (Johnson §4.2) for the force per length their own model
carries: CalculiX's from the reaction force of the clamped face (*NODE PRINT, TOTALS=ONLY),
gearfem's from its contact force. p0 is the largest contact pressure: gearfem's at its contact
integration points, CalculiX's at the slave nodes (CPRESS of *CONTACT FILE, the .frd file).

Wall times: gearfem's set-up (function space, elastic matrices, contact surfaces) plus contact
solve, measured by ``benchmarks/verification/contact_hertz.py --refinement`` on 1 and on 2
ranks (mpirun);
CalculiX's the whole ``ccx`` run (reading the deck, assembly, contact iterations, output) with 1
and with 2 threads (OMP_NUM_THREADS, CCX_NPROC_EQUATION_SOLVER). Meshing is left out of both (the
mesh is given to CalculiX). The machine is shared: the 1-minute load average is printed and goes
into the table caption.

Set-up: when ``ccx`` is not on the PATH the script installs the Debian package ``calculix-ccx``
(``apt-get install -y calculix-ccx``, as root or through ``sudo -n``) and stops with a message
saying what to do when that is impossible. CalculiX is not needed by the tests.

Usage:
    python benchmarks/performance/calculix_hertz.py                          # h = 14, 10, 7, 5 mm
    python benchmarks/performance/calculix_hertz.py --sizes 0.014 0.01 --docs docs/contact.md
    python benchmarks/performance/calculix_hertz.py --keep work/ccx  # keep the decks and results

Purpose: performance (gearfem and CalculiX side by side on the same Hertz mesh).
Writes: block ``calculix_hertz`` of docs/contact.md (``--docs docs/contact.md``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)

# isort: split
import dolfinx
import numpy as np

from gearfem.contact import ContactOptions
from gearfem.contact.verification import ContactCase, hertz_case, hertz_line_contact
from gearfem.core.doctables import markdown_table, replace_block

HERE = Path(__file__).resolve().parent
SIZES_M = (0.014, 0.01, 0.007, 0.005)
COMPRESSION_M = 0.004
PENALTY_FACTOR = 10.0  # K = 10 E / h
E_PA, NU = 1.0, 0.3

# DOLFINx (basix) P2 tetrahedron: vertices 0-3, then the midside nodes of the edges (2,3), (1,3),
# (1,2), (0,3), (0,2), (0,1). Abaqus/CalculiX C3D10: vertices 1-4, then the edges 1-2, 2-3, 3-1,
# 1-4, 2-4, 3-4.
_BASIX_EDGES = [(2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1)]
_C3D10_EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]
# C3D10 face number by the vertex (0-based, C3D10 order) the face does not contain
_FACE_OPPOSITE = {3: "S1", 2: "S2", 0: "S3", 1: "S4"}


# ------------------------------------------------------------------------------------------------
# set-up
# ------------------------------------------------------------------------------------------------


def ensure_ccx() -> str:
    """Path of ``ccx``; installs the Debian package ``calculix-ccx`` when it is missing."""
    found = shutil.which("ccx")
    if found:
        return found
    apt = shutil.which("apt-get")
    if apt is None:
        sys.exit(
            "CalculiX (ccx) is not installed and this system has no apt-get: install CalculiX "
            "2.20 (the 'ccx' executable) by the system's own means and run again."
        )
    prefix: list[str] = []
    if os.geteuid() != 0:
        if shutil.which("sudo") is None:
            sys.exit(
                "CalculiX (ccx) is not installed and installing it needs root: run "
                "'apt-get install calculix-ccx' as root, then run this script again."
            )
        prefix = ["sudo", "-n"]
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    for cmd in (
        [*prefix, apt, "install", "-y", "--no-install-recommends", "calculix-ccx"],
        [*prefix, apt, "update"],
        [*prefix, apt, "install", "-y", "--no-install-recommends", "calculix-ccx"],
    ):
        print(f"$ {' '.join(cmd)}", flush=True)
        subprocess.run(cmd, env=env, check=False)
        found = shutil.which("ccx")
        if found:
            return found
    sys.exit(
        "could not install the Debian package calculix-ccx (see apt-get's messages above; "
        "without root, run 'sudo apt-get install calculix-ccx' yourself) - CalculiX side by "
        "side not measured"
    )


def ccx_version(ccx: str) -> str:
    out = subprocess.run([ccx, "-v"], capture_output=True, text=True, check=False).stdout
    for line in out.splitlines():
        if "Version" in line:
            return line.strip().split()[-1]
    return "unknown"


# ------------------------------------------------------------------------------------------------
# the deck
# ------------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Deck:
    """A written CalculiX input file and what it holds."""

    path: Path
    nodes: int
    elements: int
    slave_faces: int
    master_faces: int
    penalty_Pa_m: float
    thickness_m: float


def _c3d10_cells(x: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """C3D10 connectivity (0-based node indices) of DOLFINx P2 tetrahedra, positively oriented."""
    verts = cells[:, :4].copy()
    mids = {}
    for k, (i, j) in enumerate(_BASIX_EDGES):
        mids[(i, j)] = mids[(j, i)] = cells[:, 4 + k]
    # CalculiX wants (x2 - x1) x (x3 - x1) . (x4 - x1) > 0: swap vertices 1 and 2 where negative
    v = x[verts]
    vol = np.einsum("pd,pd->p", np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), v[:, 3] - v[:, 0])
    flip = vol < 0.0
    order = np.tile(np.arange(4), (len(cells), 1))
    order[flip, 1], order[flip, 2] = 2, 1
    out = np.empty((len(cells), 10), dtype=np.int64)
    out[:, :4] = np.take_along_axis(verts, order, axis=1)
    for k, (i, j) in enumerate(_C3D10_EDGES):
        a, b = order[:, i], order[:, j]
        col = np.empty(len(cells), dtype=np.int64)
        for ia in range(4):
            for ib in range(4):
                if ia == ib:
                    continue
                sel = (a == ia) & (b == ib)
                col[sel] = mids[(ia, ib)][sel]
        out[:, 4 + k] = col
    # the midside nodes lie between their vertices (curved boundary edges: within 1 % of the edge)
    for k, (i, j) in enumerate(_C3D10_EDGES):
        mid = 0.5 * (x[out[:, i]] + x[out[:, j]])
        edge = np.linalg.norm(x[out[:, i]] - x[out[:, j]], axis=1)
        if np.any(np.linalg.norm(x[out[:, 4 + k]] - mid, axis=1) > 0.05 * edge):
            raise RuntimeError("C3D10 node order check failed: a midside node is off its edge")
    return out


def _faces(mesh, facets: np.ndarray, c3d10: np.ndarray) -> list[tuple[int, str]]:
    """(element number, face label) of each boundary facet, CalculiX numbering (1-based)."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    facet_nodes = dolfinx.mesh.entities_to_geometry(mesh, tdim - 1, facets)[:, :3]
    out = []
    for f, fn in zip(facets, facet_nodes):
        c = int(f2c.links(f)[0])
        missing = [k for k in range(4) if c3d10[c, k] not in set(fn.tolist())]
        if len(missing) != 1:
            raise RuntimeError(f"facet {f} is not a face of cell {c}")
        out.append((c + 1, _FACE_OPPOSITE[missing[0]]))
    return out


def _nodes_of(mesh, facets: np.ndarray) -> np.ndarray:
    return np.unique(dolfinx.mesh.entities_to_geometry(mesh, mesh.topology.dim - 1, facets))


def _lines(values, per_line: int = 16) -> str:
    vals = [str(v) for v in values]
    return "\n".join(", ".join(vals[i : i + per_line]) for i in range(0, len(vals), per_line))


def write_deck(case: ContactCase, contact_size_m: float, path: Path) -> Deck:
    """Write the Hertz case's mesh, supports, material, contact and load as a CalculiX deck."""
    md = case.mesh_data
    mesh = md.mesh
    if MPI.COMM_WORLD.size != 1 or mesh.comm.size != 1:
        raise RuntimeError("the deck is written from a serial mesh")
    x = mesh.geometry.x
    cells = mesh.geometry.dofmaps[0]
    c3d10 = _c3d10_cells(x, cells)

    def facets(name: str) -> np.ndarray:
        return md.facet_tags.find(md.physical_groups[name].tag)

    planes = np.concatenate(
        [facets(f"{b}_{s}") for b in ("upper", "lower") for s in ("front", "back")]
    )
    slave = _faces(mesh, facets("lower_curved"), c3d10)
    master = _faces(mesh, facets("upper_curved"), c3d10)
    K = PENALTY_FACTOR * E_PA / contact_size_m
    parts = [
        "*HEADING",
        f"gearfem Hertz line contact, h = {contact_size_m} m (gearfem calculix_hertz benchmark)",
        "*NODE, NSET=NALL",
        # CalculiX reads at most 20 characters per number: 14 significant digits
        "\n".join(f"{i + 1}, {p[0]:.13e}, {p[1]:.13e}, {p[2]:.13e}" for i, p in enumerate(x)),
        "*ELEMENT, TYPE=C3D10, ELSET=EALL",
        "\n".join(f"{e + 1}, " + ", ".join(str(n + 1) for n in row) for e, row in enumerate(c3d10)),
    ]
    for name, nodes in (
        ("NPLANES", _nodes_of(mesh, planes)),
        ("NLOWFLAT", _nodes_of(mesh, facets("lower_flat"))),
        ("NUPFLAT", _nodes_of(mesh, facets("upper_flat"))),
    ):
        parts += [f"*NSET, NSET={name}", _lines(nodes + 1)]
    for name, faces in (("SLAVE", slave), ("MASTER", master)):
        parts += [f"*SURFACE, NAME={name}, TYPE=ELEMENT", "\n".join(f"{e}, {s}" for e, s in faces)]
    parts += [
        "*MATERIAL, NAME=BODY",
        "*ELASTIC",
        f"{E_PA:.13e}, {NU:.13e}",
        "*SOLID SECTION, ELSET=EALL, MATERIAL=BODY",
        "*SURFACE INTERACTION, NAME=SI",
        "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR",
        f"{K:.13e}",
        "*CONTACT PAIR, INTERACTION=SI, TYPE=SURFACE TO SURFACE",
        "SLAVE, MASTER",
        "*STEP, INC=1000",
        "*STATIC",
        "1., 1.",
        "*BOUNDARY",
        "NPLANES, 3, 3, 0.",
        "NLOWFLAT, 1, 2, 0.",
        "NUPFLAT, 1, 1, 0.",
        f"NUPFLAT, 2, 2, {-COMPRESSION_M:.13e}",
        "*NODE PRINT, NSET=NLOWFLAT, TOTALS=ONLY",
        "RF",
        "*CONTACT FILE",
        "CSTR",
        "*END STEP",
    ]
    path.write_text("\n".join(parts) + "\n")
    return Deck(path, len(x), len(c3d10), len(slave), len(master), K, case.thickness_m)


# ------------------------------------------------------------------------------------------------
# running and reading CalculiX
# ------------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class CcxResult:
    threads: int
    wall_s: float
    force_per_length_N_m: float
    p0_Pa: float
    contact_nodes: int
    iterations: int

    @property
    def p0_error(self) -> float:
        _, p0 = hertz_line_contact(self.force_per_length_N_m, 1.0, 1.0, E_PA, NU, E_PA, NU)
        return self.p0_Pa / p0 - 1.0


def read_frd_cpress(path: Path) -> np.ndarray:
    """CPRESS at the slave nodes of the last CONTACT block of a CalculiX .frd file."""
    blocks, current, names = [], None, []
    for line in path.read_text().splitlines():
        if line.startswith(" -4"):
            current = [] if line.split()[1] == "CONTACT" else None
            names = []
            if current is not None:
                blocks.append(current)
        elif current is not None and line.startswith(" -5"):
            names.append(line.split()[1])
        elif current is not None and line.startswith(" -1"):
            vals = [float(line[13 + 12 * k : 25 + 12 * k]) for k in range(len(names))]
            current.append(vals)
        elif line.startswith(" -3"):
            current = None
    if not blocks:
        raise RuntimeError(f"no CONTACT results in {path}")
    data = np.array(blocks[-1])
    return data[:, names.index("CPRESS")] if len(data) else np.zeros(0)


def read_dat_total_force(path: Path) -> np.ndarray:
    """The last 'total force' line of a CalculiX .dat file (fx, fy, fz)."""
    lines = path.read_text().splitlines()
    for k in range(len(lines) - 1, -1, -1):
        if lines[k].strip().startswith("total force"):
            vals = next(ln for ln in lines[k + 1 :] if ln.strip()).split()
            return np.array([float(v) for v in vals[-3:]])
    raise RuntimeError(f"no total force in {path}")


def run_ccx(ccx: str, deck: Deck, threads: int) -> CcxResult:
    work = deck.path.parent
    job = deck.path.stem
    env = dict(
        os.environ,
        OMP_NUM_THREADS=str(threads),
        CCX_NPROC_EQUATION_SOLVER=str(threads),
        CCX_NPROC_RESULTS=str(threads),
        CCX_NPROC_STIFFNESS=str(threads),
    )
    t0 = time.perf_counter()
    proc = subprocess.run(
        [ccx, "-i", job], cwd=work, env=env, capture_output=True, text=True, check=False
    )
    wall = time.perf_counter() - t0
    (work / f"{job}.{threads}.log").write_text(proc.stdout + proc.stderr)
    if proc.returncode != 0 or "Job finished" not in proc.stdout:
        tail = "\n".join((proc.stdout + proc.stderr).splitlines()[-20:])
        raise RuntimeError(f"ccx failed (exit {proc.returncode}) on {deck.path}:\n{tail}")
    iterations = sum(1 for ln in proc.stdout.splitlines() if ln.strip().startswith("iteration "))
    cpress = read_frd_cpress(work / f"{job}.frd")
    force = read_dat_total_force(work / f"{job}.dat")
    return CcxResult(
        threads,
        wall,
        abs(float(force[1])) / deck.thickness_m,
        float(cpress.max(initial=0.0)),
        int(np.count_nonzero(cpress > 0.0)),
        iterations,
    )


# ------------------------------------------------------------------------------------------------
# gearfem (benchmarks/verification/contact_hertz.py on 1 and 2 ranks)
# ------------------------------------------------------------------------------------------------


def run_gearfem(sizes: list[float], ranks: int, tmp: Path) -> list[dict]:
    local = Path(sys.executable).with_name("mpirun")
    mpirun = str(local) if local.is_file() else shutil.which("mpirun")
    out = tmp / f"gearfem_np{ranks}.json"
    hertz = HERE.parent / "verification" / "contact_hertz.py"
    cmd = [mpirun, "-n", str(ranks), sys.executable, str(hertz)]
    cmd += ["--refinement", "--sizes", *map(str, sizes), "--json", str(out)]
    print(f"$ {' '.join(cmd)}", flush=True)
    subprocess.run(cmd, check=True)
    return json.loads(out.read_text())["rows"]


# ------------------------------------------------------------------------------------------------


def _pct(v: float) -> str:
    return f"{100 * v:+.2f} %".replace("-", "−")


def side_by_side_markdown(rows: list[dict], version: str, loads: list[float]) -> str:
    head = [
        "h (mm)",
        "DOFs",
        "gearfem p0 error",
        "gearfem 1 rank (s)",
        "gearfem 2 ranks (s)",
        "CalculiX p0 error",
        "CalculiX 1 thread (s)",
        "CalculiX 2 threads (s)",
        "CalculiX / gearfem, 1 core",
        "CalculiX / gearfem, 2 cores",
    ]
    body = []
    for r in rows:
        g1, g2 = r["gearfem"][1], r["gearfem"][2]
        c1, c2 = r["ccx"][1], r["ccx"][2]
        t_g1 = g1["setup_s"] + g1["solve_s"]
        t_g2 = g2["setup_s"] + g2["solve_s"]
        body.append(
            [
                f"{1e3 * r['h']:g}",
                f"{g1['dofs']:,}".replace(",", " "),
                _pct(g1["p0_error"]),
                f"{t_g1:.1f}",
                f"{t_g2:.1f}",
                _pct(c1["p0_error"]),
                f"{c1['wall_s']:.1f}",
                f"{c2['wall_s']:.1f}",
                f"{c1['wall_s'] / t_g1:.2f}",
                f"{c2['wall_s'] / t_g2:.2f}",
            ]
        )
    return (
        f"{markdown_table(head, body)}\n\n`python benchmarks/performance/calculix_hertz.py` "
        f"(CalculiX "
        f"{version}, Debian package calculix-ccx; load average {loads[0]:.1f} before, "
        f"{loads[-1]:.1f} after)"
    )


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", type=float, nargs="+", default=list(SIZES_M), help="contact sizes, m")
    p.add_argument("--docs", type=Path, default=None, help="page whose calculix_hertz block to set")
    p.add_argument("--keep", type=Path, default=None, help="keep the decks and results here")
    p.add_argument("--json", type=Path, default=None, help="also write the rows as JSON")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if MPI.COMM_WORLD.size != 1:
        sys.exit("run serially: the script launches gearfem on 1 and 2 ranks itself")
    ccx = ensure_ccx()
    version = ccx_version(ccx)
    print(f"CalculiX {version}: {ccx}", flush=True)
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        work = args.keep or tmp
        work.mkdir(parents=True, exist_ok=True)
        rows = []
        opts = ContactOptions(search_distance_rel=2.0)
        for h in args.sizes:
            case = hertz_case(MPI.COMM_SELF, opts, contact_size=h)
            deck = write_deck(case, h, work / f"hertz_h{1e3 * h:g}mm.inp")
            print(
                f"h = {h} m: {deck.nodes} nodes ({3 * deck.nodes} DOFs), {deck.elements} C3D10, "
                f"{deck.slave_faces}/{deck.master_faces} slave/master faces, K = "
                f"{deck.penalty_Pa_m:g} Pa/m",
                flush=True,
            )
            res = {}
            for threads in (1, 2):
                r = run_ccx(ccx, deck, threads)
                res[threads] = dict(dataclasses.asdict(r), p0_error=r.p0_error)
                print(
                    f"  ccx, {threads} thread(s): {r.wall_s:.1f} s, {r.iterations} iterations, "
                    f"P' = {r.force_per_length_N_m:.6e} N/m, p0 error {_pct(r.p0_error)}",
                    flush=True,
                )
            rows.append({"h": h, "ccx": res, "dofs": 3 * deck.nodes})
        for ranks in (1, 2):
            for row, g in zip(rows, run_gearfem(args.sizes, ranks, tmp)):
                if g["dofs"] != row["dofs"]:
                    raise RuntimeError(f"different meshes: {g['dofs']} vs {row['dofs']} DOFs")
                row.setdefault("gearfem", {})[ranks] = g
    load1 = os.getloadavg()[0]
    text = side_by_side_markdown(rows, version, [load0, load1])
    print(text)
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "load_average": [load0, load1]}, indent=2))
    if args.docs is not None:
        replace_block(args.docs, "calculix_hertz", text)
        print(f"wrote block calculix_hertz of {args.docs}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
