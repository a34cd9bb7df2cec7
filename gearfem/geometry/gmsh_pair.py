"""gmsh model of a spur-gear pair (fractional N-tooth sectors or full gears) with named groups.

The model is built with gmsh's built-in kernel in millimetres: each body's section at ``z = 0``
is bounded by spline curves through exact points of the tooth outline
(:meth:`gearfem.geometry.involute.ToothProfile.outline`), circle arcs for the tip land, the
tip-edge rounds (about their own centres) and the bore and, for
fractional models, two radial cut lines at mid-gap. The section is meshed in 2D (triangles, or
all-quadrilaterals for ``element="hex"``) with a graded size field and swept over the face width
with ``layers`` element layers (as the thesis did), giving tetrahedra (each prism split into three)
or hexahedra. Second-order nodes are placed on the curved geometry, so P2 facet nodes lie on the
(spline through the exact) involute. The mesh file is written in metres (``Mesh.ScalingFactor``).

Position (the mesh as built, ``pinion_angle_deg = 0``): one pinion tooth and one wheel tooth touch
at the pitch point ``(r_w1, 0, z)`` on their drive flanks; the backlash is all on the coast side.
Teeth of each body are numbered 0..N-1 counter-clockwise about the body's own axis (+z). The
reference (contact) tooth is ``N // 2`` on the pinion and ``(N - 1) // 2`` on the wheel (4 and 3
for N = 8): in forward drive the mesh zone moves, in body coordinates, to lower tooth numbers on
the pinion and to higher ones on the wheel, so one pitch of forward rotation loads pinion teeth
{N//2, N//2 - 1} and wheel teeth {(N-1)//2, (N-1)//2 + 1}, i.e. the two middle teeth (3 and 4 for
N = 8) of each sector. The sector of tooth k spans ``[theta_k - pi/z, theta_k + pi/z]``.

Physical groups (each mesh entity in exactly one group; names are the API, tags are not):
volumes ``pinion``, ``wheel``; facets ``{body}_tooth{k}_{drive_flank|coast_flank|tip|root}``
(root = both fillets and root-circle lands of the tooth's own sector, i.e. half a gap on each
side; tip = the tip land and both tip-edge rounds), ``{body}_side_front`` (z = 0),
``{body}_side_back`` (z = b), ``{body}_bore``, and for fractional models ``{body}_cut_start``
(at ``theta_0 - pi/z``) and ``{body}_cut_end`` (at ``theta_{N-1} + pi/z``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from gearfem.geometry.extrude import GMSH_REF, Section2D, SweptBody, extrude, layer_planes
from gearfem.geometry.involute import GearPair, GearPairGeometry, ToothProfile
from gearfem.geometry.options import (
    BODIES,
    BODY_KINDS,
    ENTRY_MARGIN_MODULES,
    TOOTH_KINDS,
    MeshOptions,
    check_bodies,
    check_options,
    refined_tooth_indices,
)
from gearfem.geometry.placement import BodyPlacement, placement
from gearfem.geometry.quality import SKEWNESS_BINS, hex_skewness, tet_max_dihedral_deg, tet_skewness

log = logging.getLogger(__name__)

# ------------------------------------------------------------------------------------------------
# gmsh session
# ------------------------------------------------------------------------------------------------


@contextlib.contextmanager
def gmsh_session(name: str = "gearfem"):
    """Initialise gmsh if needed, add a model, and clean up (finalise only if we initialised)."""
    import gmsh

    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(name)
    try:
        yield gmsh
    finally:
        with contextlib.suppress(Exception):
            gmsh.model.remove()
        if own:
            gmsh.finalize()


# ------------------------------------------------------------------------------------------------
# model
# ------------------------------------------------------------------------------------------------

# Points per spline piece (exact outline points; gmsh interpolates them). With 121 points the P2
# flank nodes lie within 1e-10 m of the exact involute (61: 2e-8 m, error ~ h^3 at the ends).
N_FLANK_POINTS = 121
N_FILLET_POINTS = 61
N_LAND_POINTS = 6
# Largest arc of a tip round spanned by one element edge: a P2 edge over 30 deg of a circle
# deviates from it by < 1.3e-4 rho (< 1e-4 in length); one edge over the whole round (about 55 deg
# on the thesis teeth) would deviate by 1.6e-3 rho. Caps the size on the rounds of every tooth.
ROUND_MAX_ARC_RAD = math.pi / 6


@dataclass
class _BodyCurves:
    """2D curve tags of one body's section, by (kind, tooth) and for the body boundaries."""

    tooth: dict[tuple[str, int], list[int]] = dataclasses.field(default_factory=dict)
    rounds: set[int] = dataclasses.field(
        default_factory=set
    )  # the tip-round curves (part of "tip")
    round_radius_mm: float = 0.0
    # the entry refinement (MeshOptions.size_entry_mm): per tooth the drive-side tip round and
    # the drive flank's outline points (mm, tip to foot); the body centre (mm) and the radius up
    # to which the flank is refined (mm)
    drive_round: dict[int, int] = dataclasses.field(default_factory=dict)
    drive_flank_mm: dict[int, np.ndarray] = dataclasses.field(default_factory=dict)
    center_mm: tuple[float, float] = (0.0, 0.0)
    entry_top_radius_mm: float = 0.0
    bore: list[int] = dataclasses.field(default_factory=list)
    cut_start: list[int] = dataclasses.field(default_factory=list)
    cut_end: list[int] = dataclasses.field(default_factory=list)
    surface: int = -1


def _to_global(xy: np.ndarray, angle: float, center: np.ndarray) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.column_stack(
        [c * xy[:, 0] - s * xy[:, 1] + center[0], s * xy[:, 0] + c * xy[:, 1] + center[1]]
    )


def _add_section(
    gmsh, prof: ToothProfile, place: BodyPlacement, entry_top_radius_mm: float
) -> _BodyCurves:
    """Add the z = 0 section of one body (built-in kernel, millimetres); the drive flank up to
    ``entry_top_radius_mm`` is where ``size_entry_mm`` applies."""
    geo = gmsh.model.geo
    mm = 1e3
    cx, cy = place.center_m[0] * mm, place.center_m[1] * mm
    center_pt = geo.addPoint(cx, cy, 0.0)
    outline = prof.outline(
        n_flank=N_FLANK_POINTS, n_fillet=N_FILLET_POINTS, n_land=N_LAND_POINTS, n_tip=2
    )
    rounded = prof.tip_round_radius_m > 0.0
    if rounded:  # tip: round (about its centre), land (about the gear centre), round
        tip_pieces = prof.tip_pieces(2)
        round_centers = {side: prof.tip_round_center(side)[None, :] for side in ("coast", "drive")}
    out = _BodyCurves()
    n = len(place.tooth_angles_rad)
    loop: list[int] = []
    first_pt: int | None = None
    prev_end: int | None = None

    def pts_of(xy: np.ndarray, start: int | None, end: int | None) -> list[int]:
        tags = []
        for i, (x, y) in enumerate(xy):
            if i == 0 and start is not None:
                tags.append(start)
            elif i == len(xy) - 1 and end is not None:
                tags.append(end)
            else:
                tags.append(geo.addPoint(x, y, 0.0))
        return tags

    for k, ang in enumerate(place.tooth_angles_rad):
        pieces = {key: _to_global(v, ang, place.center_m) * mm for key, v in outline.items()}
        last_tooth_full = place.full and k == n - 1
        # root_coast: mid-gap -> form point
        p = pts_of(pieces["root_coast"], prev_end, None)
        if k == 0:
            first_pt = p[0]
        root_c = geo.addSpline(p)
        p_cf = pts_of(pieces["coast_flank"], p[-1], None)
        coast = geo.addSpline(p_cf)
        tip_end = geo.addPoint(*pieces["tip"][-1], 0.0)
        if rounded:
            land = _to_global(tip_pieces["land"], ang, place.center_m) * mm
            land_start, land_end = geo.addPoint(*land[0], 0.0), geo.addPoint(*land[-1], 0.0)
            rc = {
                side: geo.addPoint(*(_to_global(xy, ang, place.center_m) * mm)[0], 0.0)
                for side, xy in round_centers.items()
            }
            tip = [
                geo.addCircleArc(p_cf[-1], rc["coast"], land_start),
                geo.addCircleArc(land_start, center_pt, land_end),
                geo.addCircleArc(land_end, rc["drive"], tip_end),
            ]
            out.rounds |= {tip[0], tip[2]}
            out.drive_round[k] = tip[2]
            out.round_radius_mm = prof.tip_round_radius_m * mm
        else:
            tip = [geo.addCircleArc(p_cf[-1], center_pt, tip_end)]
        out.drive_flank_mm[k] = pieces["drive_flank"]
        p_df = pts_of(pieces["drive_flank"], tip_end, None)
        drive = geo.addSpline(p_df)
        p_rd = pts_of(pieces["root_drive"], p_df[-1], first_pt if last_tooth_full else None)
        root_d = geo.addSpline(p_rd)
        prev_end = p_rd[-1]
        out.tooth[("root", k)] = [root_c, root_d]
        out.tooth[("coast_flank", k)] = [coast]
        out.tooth[("tip", k)] = tip  # the rounds belong to the tip
        out.tooth[("drive_flank", k)] = [drive]
        loop += [root_c, coast, *tip, drive, root_d]

    out.center_mm = (cx, cy)
    out.entry_top_radius_mm = entry_top_radius_mm
    rb = prof.bore_radius_m * mm

    def bore_point(theta: float) -> int:
        return geo.addPoint(cx + rb * math.cos(theta), cy + rb * math.sin(theta), 0.0)

    if place.full:
        outer = geo.addCurveLoop(loop)
        b_pts = [bore_point(place.sector_rad[0] + i * 0.5 * math.pi) for i in range(4)]
        out.bore = [geo.addCircleArc(b_pts[i], center_pt, b_pts[(i + 1) % 4]) for i in range(4)]
        inner = geo.addCurveLoop(out.bore)
        out.surface = geo.addPlaneSurface([outer, inner])
    else:
        t0, t1 = place.sector_rad
        b_end = bore_point(t1)
        b_start = bore_point(t0)
        out.cut_end = [geo.addLine(prev_end, b_end)]
        n_arc = max(1, math.ceil((t1 - t0) / (0.5 * math.pi)))
        th = np.linspace(t1, t0, n_arc + 1)
        b_pts = [b_end] + [bore_point(t) for t in th[1:-1]] + [b_start]
        out.bore = [geo.addCircleArc(b_pts[i], center_pt, b_pts[i + 1]) for i in range(n_arc)]
        out.cut_start = [geo.addLine(b_start, first_pt)]
        cl = geo.addCurveLoop(loop + out.cut_end + out.bore + out.cut_start)
        out.surface = geo.addPlaneSurface([cl])
    return out


def _size_field(
    gmsh,
    sections: dict[str, _BodyCurves],
    options: MeshOptions,
    refined: list[int],
    scale: float = 1.0,
) -> None:
    """Background size field: graded thresholds around fine curves, size_body elsewhere (all
    sizes times ``scale``). Tip rounds get the size of their tooth's tip, at most
    ``ROUND_MAX_ARC_RAD`` times their radius."""
    f = gmsh.model.mesh.field
    o = options
    groups: dict[float, list[int]] = {}

    def add(size: float, curves: list[int]) -> None:
        if curves:
            groups.setdefault(size, []).extend(curves)

    for sec in sections.values():
        round_cap = ROUND_MAX_ARC_RAD * sec.round_radius_mm
        for (kind, k), curves in sec.tooth.items():
            if k in refined:
                size = {
                    "drive_flank": o.size_flank_mm,
                    "tip": o.size_tip_mm,
                    "root": o.size_root_mm,
                    "coast_flank": o.size_tooth_mm,
                }[kind]
            else:
                size = o.size_tooth_mm
            size = min(size, o.size_body_mm)
            add(size, [c for c in curves if c not in sec.rounds])
            rounds = [c for c in curves if c in sec.rounds]
            if rounds:
                add(min(size, round_cap), rounds)
    fields = []
    for size, curves in sorted(groups.items()):
        d = f.add("Distance")
        f.setNumbers(d, "CurvesList", curves)
        f.setNumber(d, "Sampling", 200)
        fields.append(_threshold(f, d, scale * size, scale * o.size_body_mm, o.size_growth))
    if o.size_entry_mm is not None:
        fields += _entry_fields(gmsh, sections, o, refined, scale)
    mn = f.add("Min")
    f.setNumbers(mn, "FieldsList", fields)
    f.setAsBackgroundMesh(mn)


def _threshold(f, distance: int, size_min: float, size_max: float, growth: float) -> int:
    """A gmsh Threshold field on the Distance field ``distance``: ``size_min`` at distance 0,
    growing by ``growth`` per unit distance up to ``size_max``."""
    t = f.add("Threshold")
    f.setNumber(t, "InField", distance)
    f.setNumber(t, "SizeMin", size_min)
    f.setNumber(t, "SizeMax", size_max)
    f.setNumber(t, "DistMin", 0.0)
    f.setNumber(t, "DistMax", max((size_max - size_min) / growth, 1e-6))
    return t


def _entry_fields(
    gmsh, sections: dict[str, _BodyCurves], o: MeshOptions, refined: list[int], scale: float
) -> list[int]:
    """Size fields of the entry refinement (``size_entry_mm``) of the refined teeth: the
    drive-side tip round, and the drive flank from its foot up to the section's
    ``entry_top_radius_mm`` (a distance threshold around the flank, cut to that stretch by a disk
    around it: the larger of the two sizes, which is ``size_flank_mm`` outside the disk), graded
    at ``size_growth``."""
    f = gmsh.model.mesh.field
    size, body = scale * o.size_entry_mm, scale * o.size_body_mm
    out = []
    for sec in sections.values():
        cx, cy = sec.center_mm
        for k in refined:
            if k in sec.drive_round:
                d = f.add("Distance")
                f.setNumbers(d, "CurvesList", [sec.drive_round[k]])
                f.setNumber(d, "Sampling", 50)
                out.append(_threshold(f, d, size, body, o.size_growth))
            xy = sec.drive_flank_mm[k]
            band = xy[np.hypot(xy[:, 0] - cx, xy[:, 1] - cy) <= sec.entry_top_radius_mm]
            if len(band) < 2:
                continue
            ends = band[[0, -1]]
            mid = ends.mean(axis=0)
            d = f.add("Distance")
            f.setNumbers(d, "CurvesList", sec.tooth[("drive_flank", k)])
            f.setNumber(d, "Sampling", 400)
            near = _threshold(f, d, size, body, o.size_growth)
            disk = f.add("Ball")  # size_entry within the stretch, size_flank beyond it
            f.setNumber(disk, "XCenter", float(mid[0]))
            f.setNumber(disk, "YCenter", float(mid[1]))
            f.setNumber(disk, "ZCenter", 0.0)
            f.setNumber(disk, "Radius", 0.5 * float(np.linalg.norm(ends[1] - ends[0])))
            grading = scale * (o.size_flank_mm - o.size_entry_mm) / o.size_growth
            f.setNumber(disk, "Thickness", grading)
            f.setNumber(disk, "VIn", size)
            f.setNumber(disk, "VOut", scale * o.size_flank_mm)
            cut = f.add("Max")
            f.setNumbers(cut, "FieldsList", [near, disk])
            out.append(cut)
    return out


# ------------------------------------------------------------------------------------------------
# 2D section meshes
# ------------------------------------------------------------------------------------------------


def _periodic_cuts(gmsh, sec: _BodyCurves, place: BodyPlacement) -> None:
    """Mesh the section's ``cut_end`` line as ``cut_start`` turned about the gear's centre by the
    sector's angle (the extrusion then gives cut faces whose nodes match the same way)."""
    t0, t1 = place.sector_rad
    a = t1 - t0
    c, s = math.cos(a), math.sin(a)
    cx, cy = sec.center_mm
    # x' = R (x - centre) + centre, row-major 4 x 4 (millimetres, the model's unit)
    affine = [c, -s, 0.0, cx - c * cx + s * cy, s, c, 0.0, cy - s * cx - c * cy]
    affine += [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    gmsh.model.mesh.setPeriodic(1, sec.cut_end, sec.cut_start, affine)


def _curve_groups(body: str, sec: _BodyCurves) -> dict[str, list[int]]:
    out: dict[str, list[int]] = {}
    for (kind, k), curves in sec.tooth.items():
        out[f"{body}_tooth{k}_{kind}"] = curves
    out[f"{body}_bore"] = sec.bore
    if sec.cut_start:
        out[f"{body}_cut_start"] = sec.cut_start
        out[f"{body}_cut_end"] = sec.cut_end
    return out


def mesh_sections(
    gmsh, geometry: GearPairGeometry, options: MeshOptions, bodies: tuple[str, ...] = BODIES
) -> dict[str, Section2D]:
    """Mesh the z = 0 sections of ``bodies`` in 2D, in the current gmsh model (built in
    millimetres; the returned coordinates are in metres)."""
    bodies = check_bodies(bodies)
    check_options(geometry, options, bodies)
    pair = GearPair(geometry)
    geo = gmsh.model.geo
    gmsh.option.setNumber("Geometry.AutoCoherence", 0)
    sections: dict[str, _BodyCurves] = {}
    places: dict[str, BodyPlacement] = {}
    for body in bodies:
        places[body] = placement(pair, options, body)
        entry_top_mm = 1e3 * (
            pair.start_of_active_profile_m(body) + ENTRY_MARGIN_MODULES * geometry.module_mm * 1e-3
        )
        sections[body] = _add_section(gmsh, pair.profile(body), places[body], entry_top_mm)
    geo.synchronize()
    hex_ = options.element == "hex"
    opt = gmsh.option.setNumber
    opt("Mesh.MeshSizeExtendFromBoundary", 0)
    opt("Mesh.MeshSizeFromPoints", 0)
    opt("Mesh.MeshSizeFromCurvature", 0)
    opt(
        "Mesh.LcIntegrationPrecision", 1e-4
    )  # default 1e-9 makes 1D meshing with the size field take seconds
    opt(
        "Mesh.Algorithm", 5 if hex_ else 6
    )  # Delaunay (the best split quads here) / Frontal-Delaunay
    # hex: every triangle split into three quadrilaterals, so that no triangle (hence no prism)
    # survives; the split halves the sizes, so the size field is doubled. No blossom recombination
    # before the split: it merges the two triangles at a tangent curve junction (tip round / land,
    # tip round / flank) into one quadrilateral with both boundary edges there, whose corner becomes
    # 180 degrees once curved (scaled Jacobian ~ 0).
    opt("Mesh.RecombineAll", 0)
    opt("Mesh.SubdivisionAlgorithm", 1 if hex_ else 0)
    opt(
        "Mesh.SecondOrderIncomplete", 0
    )  # quad9 -> 27-node hexes (DOLFINx has no serendipity cells)
    opt("Mesh.SecondOrderLinear", 0)  # high-order nodes on the curved geometry
    opt("Mesh.HighOrderOptimize", 0)
    opt("Mesh.ElementOrder", 1)
    refined = refined_tooth_indices(options, options.teeth_in_model)
    _size_field(gmsh, sections, options, refined, scale=2.0 if hex_ else 1.0)
    if options.periodic_cuts:
        for body, sec in sections.items():
            _periodic_cuts(gmsh, sec, places[body])
    gmsh.model.mesh.generate(2)
    if options.order > 1:
        gmsh.model.mesh.setOrder(options.order)
    want = {("tet", 1): 2, ("tet", 2): 9, ("hex", 1): 3, ("hex", 2): 10}[
        (options.element, options.order)
    ]
    out: dict[str, Section2D] = {}
    for body, sec in sections.items():
        types, _, enodes = gmsh.model.mesh.getElements(2, sec.surface)
        if list(types) != [want]:
            names = [gmsh.model.mesh.getElementProperties(t)[0] for t in types]
            raise RuntimeError(
                f"gmsh produced 2D cells {names} on the {body} section, expected type {want}"
            )
        nn = gmsh.model.mesh.getElementProperties(want)[3]
        tags, coords, _ = gmsh.model.mesh.getNodes(2, sec.surface, includeBoundary=True)
        tags = np.asarray(tags, dtype=np.int64)
        order = np.argsort(tags)
        tags, xy = tags[order], np.asarray(coords).reshape(-1, 3)[order, :2] * 1e-3  # mm -> m
        local = lambda t: np.searchsorted(tags, np.asarray(t, dtype=np.int64))
        cells = local(enodes[0]).reshape(-1, nn)
        edges: dict[str, np.ndarray] = {}
        for name, curves in _curve_groups(body, sec).items():
            chunks = []
            for c in curves:
                ct, _, cn = gmsh.model.mesh.getElements(1, c)
                nl = gmsh.model.mesh.getElementProperties(ct[0])[3]
                chunks.append(local(cn[0]).reshape(-1, nl))
            edges[name] = np.vstack(chunks)
        out[body] = Section2D(body, xy, want, cells, edges, places[body])
    return out


# ------------------------------------------------------------------------------------------------
# extrusion over the face width
# ------------------------------------------------------------------------------------------------


# ------------------------------------------------------------------------------------------------
# the whole build
# ------------------------------------------------------------------------------------------------


def _write_discrete(
    gmsh, bodies: list[SweptBody]
) -> tuple[dict[str, tuple[int, int]], dict[str, np.ndarray], dict[str, int]]:
    """Put the swept bodies into the current (empty) gmsh model as discrete entities with
    physical groups. Returns the groups, the gmsh element tags of each body's cells and the
    discrete surface entity of each facet group."""
    groups: dict[str, tuple[int, int]] = {}
    cell_tags: dict[str, np.ndarray] = {}
    surfaces: dict[str, int] = {}
    offset = 0
    for sb in bodies:
        vol = gmsh.model.addDiscreteEntity(3)
        n = len(sb.nodes)
        gmsh.model.mesh.addNodes(3, vol, np.arange(offset + 1, offset + n + 1), sb.nodes.ravel())
        gmsh.model.mesh.addElementsByType(vol, sb.cell_type, [], (sb.cells + offset + 1).ravel())
        groups[sb.body] = (3, gmsh.model.addPhysicalGroup(3, [vol], name=sb.body))
        cell_tags[sb.body] = np.asarray(gmsh.model.mesh.getElementsByType(sb.cell_type, vol)[0])
        for name in sorted(sb.facets, key=_group_sort_key):
            surf = gmsh.model.addDiscreteEntity(2)
            gmsh.model.mesh.addElementsByType(
                surf, sb.facet_type[name], [], (sb.facets[name] + offset + 1).ravel()
            )
            groups[name] = (2, gmsh.model.addPhysicalGroup(2, [surf], name=name))
            surfaces[name] = surf
        offset += n
    return groups, cell_tags, surfaces


def _areas_mm2(gmsh, bodies: list[SweptBody], surfaces: dict[str, int]) -> dict[str, float]:
    """Area of each facet group of the (curved) mesh [mm^2], by Gauss quadrature in gmsh."""
    out = {}
    for sb in bodies:
        for name, t in sb.facet_type.items():
            pts, w = gmsh.model.mesh.getIntegrationPoints(t, "Gauss6")
            _, det, _ = gmsh.model.mesh.getJacobians(t, pts, tag=surfaces[name])
            out[name] = float(np.sum(np.asarray(det).reshape(-1, len(w)) @ np.asarray(w))) * 1e6
    return out


def _group_sort_key(name: str) -> tuple:
    import re

    m = re.match(r"(\w+?)_tooth(\d+)_(\w+)$", name)
    if m:
        return (m.group(1), 0, int(m.group(2)), TOOTH_KINDS.index(m.group(3)))
    body, _, kind = name.partition("_")
    return (body, 1, BODY_KINDS.index(kind) if kind in BODY_KINDS else 99, 0)


def section_angles_deg(sec: Section2D) -> tuple[float, float]:
    """Smallest and largest corner angle of the 2D section cells [deg] (their shape; the extrusion
    adds
    the face-width direction with the deliberate layer thickness)."""
    nv = GMSH_REF[sec.cell_type][0]
    P = sec.nodes[sec.cells[:, :nv]]
    lo, hi = 180.0, 0.0
    for i in range(nv):
        a = P[:, i - 1] - P[:, i]
        b = P[:, (i + 1) % nv] - P[:, i]
        cosang = np.einsum("ij,ij->i", a, b) / (
            np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)
        )
        ang = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
        lo, hi = min(lo, float(ang.min())), max(hi, float(ang.max()))
    return lo, hi


def _statistics(gmsh, bodies: list[SweptBody], cell_tags: dict[str, np.ndarray]) -> dict[str, Any]:
    stats: dict[str, Any] = {"bodies": {}}
    sj_all, skew_all, dih_all, gamma_all = [], [], [], []
    name = None
    for sb in bodies:
        name, _, _, _, _, nv = gmsh.model.mesh.getElementProperties(sb.cell_type)
        corners = sb.cells[:, :nv]
        cv = sb.nodes[corners]
        sj = np.asarray(gmsh.model.mesh.getElementQualities(cell_tags[sb.body], "minSJ"))
        if nv == 4:
            skew = tet_skewness(cv)
            dih_all.append(tet_max_dihedral_deg(cv))
            gamma_all.append(
                np.asarray(gmsh.model.mesh.getElementQualities(cell_tags[sb.body], "gamma"))
            )
        else:
            skew = hex_skewness(cv)
        sj_all.append(sj)
        skew_all.append(skew)
        stats["bodies"][sb.body] = {
            "cells": len(sb.cells),
            "nodes": len(sb.nodes),
            "vertices": len(np.unique(corners)),
            "min_scaled_jacobian": float(sj.min()),
            "max_skewness": float(skew.max()),
        }
    sj = np.concatenate(sj_all)
    skew = np.concatenate(skew_all)
    counts, _ = np.histogram(skew, bins=np.array(SKEWNESS_BINS))
    stats["cell_type"] = name
    stats["cells"] = int(sum(b["cells"] for b in stats["bodies"].values()))
    stats["nodes"] = int(sum(b["nodes"] for b in stats["bodies"].values()))
    stats["vertices"] = int(sum(b["vertices"] for b in stats["bodies"].values()))
    q = {
        "min_scaled_jacobian": float(sj.min()),
        "scaled_jacobian_definition": (
            "gmsh minSJ of the curved cells: > 0 means no inverted cell; for tetrahedra it is "
            "relative to the "
            "straight-sided cell (1 = straight, so it measures the curvature distortion only), "
            "for hexahedra "
            "it is the corner-normalised scaled Jacobian"
        ),
        "scaled_jacobian_percentiles": {f"p{p}": float(np.percentile(sj, p)) for p in (1, 5, 50)},
        "skewness_definition": (
            "tetrahedra: equilateral-volume skewness 1 - V/V_eq (V_eq: regular tetrahedron with "
            "the same "
            "circumradius); hexahedra: normalised equiangular skewness over the face corner "
            "angles; the "
            "ANSYS Meshing definitions behind thesis Fig. 43-44, computed on the corner vertices"
        ),
        "skewness_max": float(skew.max()),
        "skewness_mean": float(skew.mean()),
        "skewness_histogram": {"bins": list(SKEWNESS_BINS), "counts": [int(c) for c in counts]},
        "cells_skewness_above_0.95": int(np.count_nonzero(skew > 0.95)),
    }
    if dih_all:
        dih = np.concatenate(dih_all)
        gamma = np.concatenate(gamma_all)
        q["max_dihedral_angle_deg"] = float(dih.max())
        q["dihedral_angle_p99_deg"] = float(np.percentile(dih, 99))
        q["gamma_min"] = float(
            gamma.min()
        )  # inscribed / circumscribed radius ratio, normalised (gmsh)
        q["gamma_p50"] = float(np.percentile(gamma, 50))
    stats["quality"] = q
    return stats


def write_model(
    path: Path, geometry: GearPairGeometry, options: MeshOptions, bodies: tuple[str, ...] = BODIES
) -> dict[str, Any]:
    """Build the extruded mesh of ``bodies`` and write it to ``path`` (msh 4.1 binary, metres).

    Serial (gmsh): call on one rank. Returns counts, quality (:func:`_statistics`), the physical
    groups (name -> (dim, tag)) and ``mesh_time_s`` / ``build_time_s``.
    """
    t0 = time.perf_counter()
    sections: dict[str, Section2D] = {}
    bodies = check_bodies(bodies)
    for body in bodies:  # one model per body: each size field sees only its own curves
        with gmsh_session(f"gearfem_section_{body}") as gmsh:
            sections.update(mesh_sections(gmsh, geometry, options, bodies=(body,)))
    t_2d = time.perf_counter() - t0
    angles = [section_angles_deg(sec) for sec in sections.values()]
    b = geometry.face_width_mm * 1e-3
    bodies = [
        extrude(sections[body], b, options.layers, options.order, options.layer_grading)
        for body in bodies
    ]
    with gmsh_session("gearfem_pair") as gmsh:
        groups, cell_tags, surfaces = _write_discrete(gmsh, bodies)
        t_mesh = time.perf_counter() - t0
        stats = _statistics(gmsh, bodies, cell_tags)
        stats["areas_mm2"] = _areas_mm2(gmsh, bodies, surfaces)
        stats["quality"]["section_min_angle_deg"] = min(a[0] for a in angles)
        stats["quality"]["section_max_angle_deg"] = max(a[1] for a in angles)
        bounds = layer_planes(geometry.face_width_mm, options.layers, 1, options.layer_grading)
        stats["quality"]["layer_thickness_mm"] = float(np.max(np.diff(bounds)))
        stats["quality"]["side_layer_thickness_mm"] = float(bounds[1] - bounds[0])
        gmsh.option.setNumber("Mesh.Binary", 1)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.option.setNumber("Mesh.SaveAll", 0)
        gmsh.write(str(path))
    stats["section_mesh_time_s"] = t_2d
    stats["mesh_time_s"] = t_mesh
    stats["build_time_s"] = time.perf_counter() - t0
    stats["physical_groups"] = {name: list(dt) for name, dt in groups.items()}
    return stats
