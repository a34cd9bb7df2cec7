"""The gear-pair mesh the solvers use: build (gmsh, rank 0), cache, import into DOLFINx.

:func:`build_gear_mesh` returns a :class:`GearMesh`: the DOLFINx mesh (coordinates in metres),
its cell and facet tags and the named physical groups of :mod:`gearfem.geometry.gmsh_pair`.
Solvers find surfaces by name (``gm.ds("pinion_tooth4_drive_flank")``,
``gm.names(body="wheel", kind="root")``), never by tag numbers.

Cache: ``<cache_dir>/<key>/mesh.msh`` + ``build.json``, with ``key`` a hash of every geometry and
mesh parameter, the gearfem geometry-code version, the source of the mesh-generating modules and
the gmsh version. A build goes into a
temporary directory that is renamed into place when complete, so an interrupted build never looks
cached. ``cache_dir``: the argument, else ``$GEARFEM_MESH_CACHE``, else ``meshes/cache`` in the
current working directory (the project root when run from there).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import re
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gearfem.core.params import to_dict
from gearfem.core.provenance import code_hash
from gearfem.geometry.extrude import GMSH_REF
from gearfem.geometry.gmsh_pair import gmsh_session, placement, write_model
from gearfem.geometry.involute import GearPair, GearPairGeometry
from gearfem.geometry.options import (
    BODIES,
    BODY_KINDS,
    GEOMETRY_CODE_VERSION,
    TOOTH_KINDS,
    MeshOptions,
    check_bodies,
    check_options,
    reference_tooth,
)

log = logging.getLogger(__name__)

ENV_CACHE = "GEARFEM_MESH_CACHE"
MSH_NAME = "mesh.msh"
BUILD_NAME = "build.json"

_NAME_RE = re.compile(r"^(pinion|wheel)(?:_tooth(\d+))?_(\w+)$")


def default_cache_dir() -> Path:
    """``$GEARFEM_MESH_CACHE`` if set, else ``meshes/cache`` (relative to the working directory)."""
    env = os.environ.get(ENV_CACHE)
    return Path(env) if env else Path("meshes") / "cache"


def _source_hash() -> str:
    """Hash of the code of the modules that generate meshes (gmsh_pair and what it imports,
    transitively; docstrings and comments aside): an edit of the code there invalidates the
    cache."""
    return code_hash("gearfem.geometry.gmsh_pair", length=16)


def cache_key(
    geometry: GearPairGeometry, options: MeshOptions, bodies: tuple[str, ...] = BODIES
) -> str:
    """Hash of everything that determines the mesh (16 hex digits): all parameters, the
    geometry-code version and source, and the gmsh version."""
    import gmsh

    g = to_dict(geometry)
    g["center_distance_mm"] = (
        geometry.center_distance
    )  # None and the explicit default are the same mesh
    payload = {
        "geometry": g,
        "mesh": to_dict(options),
        "bodies": list(check_bodies(bodies)),
        "code": GEOMETRY_CODE_VERSION,
        "source": _source_hash(),
        "gmsh": gmsh.__version__,
    }
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:16]


def parse_group_name(name: str) -> tuple[str, int | None, str]:
    """``"wheel_tooth3_root"`` -> ``("wheel", 3, "root")``; ``"pinion_bore"`` -> ``("pinion",
    None, "bore")``; a volume ``"pinion"`` -> ``("pinion", None, "volume")``."""
    if name in BODIES:
        return name, None, "volume"
    m = _NAME_RE.match(name)
    if not m:
        raise ValueError(f"not a gearfem group name: {name!r}")
    return m.group(1), (int(m.group(2)) if m.group(2) is not None else None), m.group(3)


@dataclass(frozen=True)
class GearMesh:
    """A meshed gear pair (or single gear) in DOLFINx, with named groups.

    Coordinates are in metres, in the pair frame (pinion axis = z axis, wheel axis through
    ``(a, 0, 0)``, face width ``z in [0, b]``; see :mod:`gearfem.geometry.gmsh_pair`).

    Attributes:
        mesh: The distributed DOLFINx mesh (second-order geometry at ``order = 2``).
        cell_tags, facet_tags: Meshtags with the physical-group tags.
        physical_groups: name -> ``dolfinx.io.gmsh.PhysicalGroup(dim, tag)``.
        geometry, options: The parameters it was built from.
        bodies: The meshed bodies (``("pinion", "wheel")`` or one of them).
        cache_key: Hash of the parameters (the cache directory name).
        msh_path: The cached ``.msh`` file (metres).
        build_info: Counts, quality and timings recorded when the mesh was generated.
    """

    mesh: Any
    cell_tags: Any
    facet_tags: Any
    physical_groups: dict[str, Any]
    geometry: GearPairGeometry
    options: MeshOptions
    bodies: tuple[str, ...]
    cache_key: str
    msh_path: Path
    build_info: dict[str, Any] = field(default_factory=dict, repr=False)

    # --- names -----------------------------------------------------------------------------------
    def tag(self, name: str) -> int:
        """Integer tag of a named group (for meshtags); KeyError names the known groups."""
        try:
            return int(self.physical_groups[name].tag)
        except KeyError:
            raise KeyError(
                f"no group {name!r}; known: {', '.join(sorted(self.physical_groups))}"
            ) from None

    def names(
        self, body: str | None = None, kind: str | None = None, tooth: int | None = None
    ) -> list[str]:
        """Group names filtered by body (``pinion``/``wheel``), kind (``drive_flank``,
        ``coast_flank``, ``tip``, ``root``, ``side_front``, ``side_back``, ``bore``,
        ``cut_start``, ``cut_end``, ``volume``) and tooth index; sorted by body, tooth, kind."""
        allowed = set(TOOTH_KINDS) | set(BODY_KINDS) | {"volume"}
        if kind is not None and kind not in allowed:
            raise ValueError(f"kind must be one of {sorted(allowed)}, got {kind!r}")
        out = []
        for name in self.physical_groups:
            b, k, kd = parse_group_name(name)
            if (
                (body is None or b == body)
                and (kind is None or kd == kind)
                and (tooth is None or k == tooth)
            ):
                out.append(name)

        def key(n: str) -> tuple:
            b, k, kd = parse_group_name(n)
            kinds = ("volume", *TOOTH_KINDS, *BODY_KINDS)
            return (BODIES.index(b), -1 if k is None else k, kinds.index(kd) if kd in kinds else 99)

        return sorted(out, key=key)

    # --- entities --------------------------------------------------------------------------------
    def facets(self, *names: str) -> np.ndarray:
        """Process-local facet indices of the named facet groups (sorted, unique, int32)."""
        parts = [self.facet_tags.find(self.tag(n)) for n in names]
        return (
            np.unique(np.concatenate(parts)).astype(np.int32)
            if parts
            else np.empty(0, dtype=np.int32)
        )

    def facet_groups(self, body: str, facets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tooth index (-1: not on a tooth) and group kind ("": in no group of ``body``) of each
        of the process-local tagged ``facets``: the parsed name of its facet group."""
        named = ((self.tag(n), parse_group_name(n)) for n in self.names(body=body))
        # facet groups only (a cell tag may coincide with a facet tag)
        parsed = {tag: g for tag, g in named if g[2] != "volume"}
        order = np.argsort(self.facet_tags.indices)
        pos = np.searchsorted(self.facet_tags.indices[order], facets)
        groups = [parsed.get(int(v)) for v in self.facet_tags.values[order][pos]]
        teeth = np.array([-1 if g is None or g[1] is None else g[1] for g in groups], np.int64)
        kinds = np.array(["" if g is None else g[2] for g in groups], dtype="U16")
        return teeth, kinds

    def cells(self, body: str) -> np.ndarray:
        """Process-local cell indices of a body."""
        return np.sort(self.cell_tags.find(self.tag(body))).astype(np.int32)

    def ds(self, *names: str):
        """Exterior-facet measure over the union of the named facet groups."""
        import ufl

        tags = tuple(self.tag(n) for n in names)
        return ufl.Measure("ds", domain=self.mesh, subdomain_data=self.facet_tags)(tags)

    def dx(self, body: str | None = None):
        """Cell measure of one body (``None``: the whole mesh)."""
        import ufl

        m = ufl.Measure("dx", domain=self.mesh, subdomain_data=self.cell_tags)
        return m if body is None else m(self.tag(body))

    # --- placement -------------------------------------------------------------------------------
    @property
    def pair(self) -> GearPair:
        """Tooth forms and kinematics (:class:`gearfem.geometry.involute.GearPair`, SI)."""
        return GearPair(self.geometry)

    def center(self, body: str) -> np.ndarray:
        """Point of the body's axis at z = 0 [m], ``(3,)``."""
        return placement(self.pair, self.options, body).center_m.copy()

    def reference_tooth(self, body: str) -> int:
        """Index of the tooth that touches at the pitch point in the reference position."""
        return reference_tooth(body, self.options.teeth_in_model)

    def tooth_angles(self, body: str) -> np.ndarray:
        """Polar angles of the tooth centre lines about the body's own axis [rad] (mesh as
        built)."""
        return placement(self.pair, self.options, body).tooth_angles_rad.copy()


# ------------------------------------------------------------------------------------------------
# build + cache
# ------------------------------------------------------------------------------------------------


def _build_into_cache(
    geometry: GearPairGeometry, options: MeshOptions, bodies: tuple[str, ...], final: Path
) -> dict[str, Any]:
    """Generate the mesh into a temporary directory next to ``final`` and rename it into place."""
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".tmp-{final.name}-", dir=final.parent))
    try:
        stats = write_model(tmp / MSH_NAME, geometry, options, bodies)
        info = {
            "geometry": to_dict(geometry),
            "mesh": to_dict(options),
            "bodies": list(bodies),
            "geometry_code_version": GEOMETRY_CODE_VERSION,
            **stats,
        }
        (tmp / BUILD_NAME).write_text(json.dumps(info, indent=2))
        try:
            os.replace(tmp, final)  # atomic: the entry appears complete or not at all
        except OSError:
            if not (final / BUILD_NAME).is_file():
                raise
            shutil.rmtree(tmp, ignore_errors=True)  # another process finished the same mesh first
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return info


def cache_gear_mesh(
    geometry: GearPairGeometry | None = None,
    options: MeshOptions | None = None,
    comm=None,
    cache_dir: Path | str | None = None,
    rebuild: bool = False,
    bodies: tuple[str, ...] = BODIES,
) -> tuple[Path, dict]:
    """Make sure the mesh of the pair is in the cache (gmsh on rank 0 of ``comm`` when it is not)
    and return its cache entry and build record, on every rank (collective). Bad parameters raise
    ParameterError on every rank. Arguments as for :func:`build_gear_mesh`."""
    from mpi4py import MPI

    geometry = geometry or GearPairGeometry()
    options = options or MeshOptions()
    comm = comm or MPI.COMM_WORLD
    bodies = check_bodies(bodies)  # on every rank, before any collective step
    check_options(geometry, options, bodies)
    root = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    key = cache_key(geometry, options, bodies)
    final = root / key
    error: str | None = None
    if comm.rank == 0:
        try:
            cached = (final / BUILD_NAME).is_file() and (final / MSH_NAME).is_file()
            if cached and not rebuild:
                log.info("mesh %s from the cache (%s)", key, final)
            else:
                if final.exists():
                    shutil.rmtree(final)
                log.info(
                    "building mesh %s (%s, %d teeth, order %d) ...",
                    key,
                    options.element,
                    options.teeth_in_model,
                    options.order,
                )
                _build_into_cache(geometry, options, bodies, final)
        except Exception as err:
            error = f"{type(err).__name__}: {err}"
            exc = err
    error = comm.bcast(error, root=0)
    if error is not None:
        if comm.rank == 0:
            raise exc
        raise RuntimeError(f"mesh build failed on rank 0: {error}")
    info = json.loads((final / BUILD_NAME).read_text()) if comm.rank == 0 else None
    return final, comm.bcast(info, root=0)


def build_gear_mesh(
    geometry: GearPairGeometry | None = None,
    options: MeshOptions | None = None,
    comm=None,
    cache_dir: Path | str | None = None,
    rebuild: bool = False,
    bodies: tuple[str, ...] = BODIES,
) -> GearMesh:
    """Build (or load from the cache) the mesh of the pair and distribute it on ``comm``.

    Collective on ``comm``: gmsh runs on rank 0 only (:func:`cache_gear_mesh`), every rank reads
    the result with ``dolfinx.io.gmsh.read_from_msh``. Bad parameters raise ParameterError on
    every rank.

    Args:
        geometry: Gear pair (default: the thesis pair).
        options: Meshing options (default: :class:`MeshOptions` defaults).
        comm: MPI communicator (default ``MPI.COMM_WORLD``).
        cache_dir: Cache root (default: see :func:`default_cache_dir`).
        rebuild: Regenerate even if cached (the old entry is replaced).
        bodies: The bodies to mesh: both (the contact cycle) or one (a thermal model of one gear,
            better balanced in parallel).
    """
    from dolfinx.io import gmsh as dgmsh
    from mpi4py import MPI

    geometry = geometry or GearPairGeometry()
    options = options or MeshOptions()
    comm = comm or MPI.COMM_WORLD
    bodies = check_bodies(bodies)
    t0 = time.perf_counter()
    final, info = cache_gear_mesh(geometry, options, comm, cache_dir, rebuild, bodies)
    key = final.name
    t1 = time.perf_counter()
    if (
        comm.rank == 0
    ):  # like dolfinx.io.gmsh.read_from_msh, but quiet and leaving a user's gmsh alone
        with gmsh_session("gearfem_read") as gmsh:
            gmsh.merge(str(final / MSH_NAME))
            data = dgmsh.model_to_mesh(gmsh.model, comm, 0, gdim=3)
    else:
        data = dgmsh.model_to_mesh(None, comm, 0, gdim=3)
    info["import_time_s"] = time.perf_counter() - t1
    info["total_time_s"] = time.perf_counter() - t0
    return GearMesh(
        mesh=data.mesh,
        cell_tags=data.cell_tags,
        facet_tags=data.facet_tags,
        physical_groups=dict(data.physical_groups),
        geometry=geometry,
        options=options,
        bodies=bodies,
        cache_key=key,
        msh_path=final / MSH_NAME,
        build_info=info,
    )


# ------------------------------------------------------------------------------------------------
# report (mesh.json)
# ------------------------------------------------------------------------------------------------


def analytic_areas_mm2(
    geometry: GearPairGeometry, options: MeshOptions, bodies: tuple[str, ...] = BODIES
) -> dict[str, float]:
    """Exact areas [mm^2] of the named facet groups of one tooth kind / body face, from the
    tooth outline (curve length x face width, or section area for the side faces)."""
    pair = GearPair(geometry)
    b = geometry.face_width_mm
    out: dict[str, float] = {}
    for body in check_bodies(bodies):
        prof = pair.profile(body)
        o = prof.outline(n_flank=4000, n_fillet=4000, n_land=400, n_tip=400)
        length = lambda xy: float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=1))) * 1e3
        lengths = {
            "drive_flank": length(o["drive_flank"]),
            "coast_flank": length(o["coast_flank"]),
            "tip": length(o["tip"]),
            "root": length(o["root_coast"]) + length(o["root_drive"]),
        }
        for k in range(options.teeth_in_model):
            for kind, L in lengths.items():
                out[f"{body}_tooth{k}_{kind}"] = L * b
        n = options.teeth_in_model
        section = prof.body_area_m2(n) * 1e6
        out[f"{body}_side_front"] = section
        out[f"{body}_side_back"] = section
        out[f"{body}_bore"] = prof.bore_radius_m * 1e3 * n * prof.pitch_angle_rad * b
        if n < prof.teeth:
            cut = (prof.root_radius_m - prof.bore_radius_m) * 1e3 * b
            out[f"{body}_cut_start"] = cut
            out[f"{body}_cut_end"] = cut
    return out


def body_volumes_m3(gm: GearMesh) -> dict[str, float]:
    """Volume of each body [m^3] integrated on the (curved) DOLFINx mesh, reduced over ranks."""
    import dolfinx.fem as fem
    from mpi4py import MPI

    one = fem.Constant(gm.mesh, 1.0)
    return {
        body: gm.mesh.comm.allreduce(fem.assemble_scalar(fem.form(one * gm.dx(body))), op=MPI.SUM)
        for body in gm.bodies
    }


def mesh_report(gm: GearMesh) -> dict[str, Any]:
    """Everything ``mesh.json`` records (collective: integrals are reduced over ranks)."""
    import dolfinx.fem as fem
    from mpi4py import MPI

    comm = gm.mesh.comm
    g, o = gm.geometry, gm.options
    pair = gm.pair
    b_mm = g.face_width_mm
    info = gm.build_info

    vol_fe = body_volumes_m3(gm)
    volumes = {}
    for body in gm.bodies:
        fe = vol_fe[body] * 1e9
        exact = pair.profile(body).body_area_m2(o.teeth_in_model) * 1e6 * b_mm
        volumes[body] = {"fe_mm3": fe, "analytic_mm3": exact, "rel_error": (fe - exact) / exact}
    exact_areas = analytic_areas_mm2(g, o, gm.bodies)
    groups = {}
    for name in gm.names():
        dim, tag = gm.physical_groups[name]
        entry: dict[str, Any] = {"dim": int(dim), "tag": int(tag)}
        if dim == 2:
            entry["area_mm2"] = info["areas_mm2"][name]
            if name in exact_areas:
                entry["analytic_mm2"] = exact_areas[name]
            n_owned = gm.mesh.topology.index_map(2).size_local
            owned = int(np.count_nonzero(gm.facet_tags.find(int(tag)) < n_owned))
            entry["facets"] = int(comm.allreduce(owned, op=MPI.SUM))
        groups[name] = entry
    V = fem.functionspace(gm.mesh, ("Lagrange", 2, (3,)))
    dofs = V.dofmap.index_map.size_global * V.dofmap.index_map_bs
    cells_global = gm.mesh.topology.index_map(3).size_global
    path = pair.path_of_contact()
    return {
        "cache_key": gm.cache_key,
        "geometry": to_dict(g),
        "mesh_options": to_dict(o),
        "element": {
            "cell_type": info.get("cell_type"),
            "order": o.order,
            "layers": o.layers,
            "kind": o.element,
            "coordinates": "metres, pair frame (pinion axis = z, wheel axis through (a, 0, 0))",
        },
        "counts": {
            "cells": int(cells_global),
            "cells_per_body": {k: v["cells"] for k, v in info["bodies"].items()},
            "nodes": info["nodes"],
            "vertices": info["vertices"],
            "dofs_p2_vector": int(dofs),
        },
        "volumes": volumes,
        "quality": info["quality"],
        "groups": groups,
        "reference": {
            "reference_tooth": {body: gm.reference_tooth(body) for body in gm.bodies},
            "pitch_point_mm": [1e3 * path.pitch_xy[0], 0.0],
            "contact_ratio": pair.contact_ratio,
            "eps_1": pair.eps_1,
            "eps_2": pair.eps_2,
            "base_pitch_mm": 1e3 * pair.base_pitch_m,
            "backlash_circular_mm": 1e3 * pair.backlash_circular_m,
            "backlash_normal_mm": 1e3 * pair.backlash_normal_m,
        },
        "timing": {
            "build_time_s": info.get("build_time_s"),
            "section_mesh_time_s": info.get("section_mesh_time_s"),
            "import_time_s": info.get("import_time_s"),
            "mpi_ranks": comm.size,
        },
    }


# ------------------------------------------------------------------------------------------------
# picture
# ------------------------------------------------------------------------------------------------


def _surface_polydata(msh_path: Path):
    """Boundary surfaces of each body from the .msh (corner nodes), as pyvista PolyData in mm."""
    import pyvista as pv

    out: dict[str, Any] = {}
    with gmsh_session("gearfem_plot") as gmsh:
        gmsh.merge(str(msh_path))
        tags, coords, _ = gmsh.model.mesh.getNodes()
        order = np.argsort(tags)
        tags = np.asarray(tags)[order]
        pts = np.asarray(coords).reshape(-1, 3)[order] * 1e3
        per_body: dict[str, list[np.ndarray]] = {}
        flank: dict[str, list[np.ndarray]] = {}
        for dim, tag in gmsh.model.getPhysicalGroups(2):
            name = gmsh.model.getPhysicalName(dim, tag)
            body = parse_group_name(name)[0]
            for ent in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
                types, _, enodes = gmsh.model.mesh.getElements(dim, ent)
                for t, en in zip(types, enodes):
                    nv, ref = GMSH_REF[int(t)][0], GMSH_REF[int(t)][1]
                    conn = np.searchsorted(tags, np.asarray(en)).reshape(-1, len(ref))[:, :nv]
                    faces = np.column_stack([np.full(len(conn), nv), conn]).ravel()
                    per_body.setdefault(body, []).append(faces)
                    if name.endswith("drive_flank"):
                        flank.setdefault(body, []).append(faces)
    for body, faces in per_body.items():
        out[body] = pv.PolyData(pts, np.concatenate(faces)).clean()
    for body, faces in flank.items():
        out[body + "_drive_flanks"] = pv.PolyData(pts, np.concatenate(faces)).clean()
    return out


def plot_pair(
    msh_path: Path,
    png: Path,
    focus_mm: tuple[float, float] = (30.0, 0.0),
    face_width_mm: float = 12.934,
    title: str = "",
) -> Path:
    """Off-screen picture of the meshed pair (rank 0 only; pyvista): an oblique overall view and a
    close-up of the back face (z = b, seen along -z) around ``focus_mm`` (the pitch point).
    Drive flanks are drawn in a darker shade of the body colour."""
    os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
    import pyvista as pv

    surf = _surface_polydata(msh_path)
    colors = {"pinion": ("#6f9fd8", "#2f5f9f"), "wheel": ("#f0b860", "#b8781a")}
    png = Path(png)
    png.parent.mkdir(parents=True, exist_ok=True)
    pl = pv.Plotter(off_screen=True, shape=(1, 2), window_size=(1600, 800), border=False)
    for col in (0, 1):
        pl.subplot(0, col)
        pl.set_background("white")
        zoom = col == 1
        for body in BODIES:
            if body not in surf:
                continue
            pl.add_mesh(
                surf[body],
                color=colors[body][0],
                show_edges=True,
                edge_color="#1a1a1a" if zoom else "#303030",
                line_width=0.8 if zoom else 0.3,
                lighting=True,
            )
            if body + "_drive_flanks" in surf:
                pl.add_mesh(
                    surf[body + "_drive_flanks"],
                    color=colors[body][1],
                    show_edges=True,
                    edge_color="#1a1a1a",
                    line_width=0.8 if zoom else 0.4,
                )
        if zoom:
            fx, fy = focus_mm
            pl.camera.position = (fx, fy, face_width_mm + 100.0)
            pl.camera.focal_point = (fx, fy, face_width_mm)
            pl.camera.up = (0.0, 1.0, 0.0)
            pl.enable_parallel_projection()
            pl.camera.parallel_scale = 7.5
            pl.add_text("close-up at the pitch point (face z = b)", font_size=11, color="black")
        else:
            pl.view_vector((0.15, -0.75, 0.65), viewup=(0.0, 0.0, 1.0))
            pl.reset_camera()
            pl.camera.zoom(1.15)
            pl.add_text(title or "gear pair mesh", font_size=11, color="black")
    pl.screenshot(str(png))
    pl.close()
    return png
