"""Gear-pair meshes: named groups, exact geometry of the P2 nodes, conjugate placement, volumes,
1 vs 2 ranks, hex and full-gear variants, cache, CLI."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import dolfinx
import numpy as np
import pytest
import ufl
from mpi4py import MPI
from scipy.spatial import cKDTree

from gearfem.config import load_case
from gearfem.core.errors import ParameterError
from gearfem.core.params import to_dict
from gearfem.core.rotation import rotate_xy
from gearfem.geometry.extrude import GMSH_REF, layer_planes
from gearfem.geometry.gmsh_pair import gmsh_session
from gearfem.geometry.involute import GearPair, GearPairGeometry
from gearfem.geometry.mesh import (
    analytic_areas_mm2,
    body_volumes_m3,
    build_gear_mesh,
    cache_key,
    mesh_report,
)
from gearfem.geometry.options import (
    ENTRY_MARGIN_MODULES,
    TOOTH_KINDS,
    MeshOptions,
    check_options,
)
from gearfem.geometry.placement import placement

THESIS = GearPairGeometry()
COARSE = MeshOptions(
    size_flank_mm=0.3,
    size_tip_mm=0.3,
    size_root_mm=0.3,
    size_tooth_mm=0.8,
    size_body_mm=3.0,
    layers=2,
)


@pytest.fixture(scope="module")
def cache(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    path = str(tmp_path_factory.mktemp("meshcache")) if comm.rank == 0 else None
    return Path(comm.bcast(path, root=0))


@pytest.fixture(scope="module")
def default_mesh(cache):
    return build_gear_mesh(THESIS, MeshOptions(), MPI.COMM_WORLD, cache_dir=cache)


@pytest.fixture(scope="module")
def coarse_mesh(cache):
    return build_gear_mesh(THESIS, COARSE, MPI.COMM_WORLD, cache_dir=cache)


def _global_nodes(gm, names) -> np.ndarray:
    """Coordinates of all geometry nodes of the named facet groups, gathered on every rank."""
    f = gm.facets(*names)
    g = dolfinx.mesh.entities_to_geometry(gm.mesh, 2, f, False)
    x = gm.mesh.geometry.x[np.unique(g)] if len(f) else np.empty((0, 3))
    allx = np.vstack(gm.mesh.comm.allgather(x))
    return np.unique(allx, axis=0)


def _to_tooth_frame(gm, body: str, k: int, X: np.ndarray) -> np.ndarray:
    th = gm.tooth_angles(body)[k]
    xy = X[:, :2] - gm.center(body)[:2]
    c, s = math.cos(-th), math.sin(-th)
    return np.column_stack([c * xy[:, 0] - s * xy[:, 1], s * xy[:, 0] + c * xy[:, 1]])


def _max_profile_edge(gm, name: str) -> float:
    """Largest in-plane (constant z) edge of the facets of a group [m] (the profile-direction
    size)."""
    f = gm.facets(name)
    g = (
        dolfinx.mesh.entities_to_geometry(gm.mesh, 2, f, False)[:, :3]
        if len(f)
        else np.empty((0, 3), dtype=np.int32)
    )
    x = gm.mesh.geometry.x
    h = 0.0
    for a, b in ((0, 1), (1, 2), (0, 2)):
        same_z = np.abs(x[g[:, a], 2] - x[g[:, b], 2]) < 1e-12
        if np.any(same_z):
            h = max(
                h, float(np.max(np.linalg.norm(x[g[same_z, a], :2] - x[g[same_z, b], :2], axis=1)))
            )
    return gm.mesh.comm.allreduce(h, op=MPI.MAX)


def _expected_names(
    options: MeshOptions, bodies: tuple[str, ...] = ("pinion", "wheel"), full: bool = False
) -> set[str]:
    names = set()
    for body in bodies:
        names.add(body)
        names |= {
            f"{body}_tooth{k}_{kind}" for k in range(options.teeth_in_model) for kind in TOOTH_KINDS
        }
        names |= {f"{body}_side_front", f"{body}_side_back", f"{body}_bore"}
        if not full:
            names |= {f"{body}_cut_start", f"{body}_cut_end"}
    return names


# --- gmsh conventions ----------------------------------------------------------------------------


def test_gmsh_reference_node_orderings():
    with gmsh_session() as gmsh:
        for t, (nv, ref) in GMSH_REF.items():
            _, dim, _, nn, coords, npv = gmsh.model.mesh.getElementProperties(t)
            assert (nn, npv) == (len(ref), nv)
            assert np.allclose(np.asarray(coords).reshape(nn, dim), np.asarray(ref, dtype=float))


# --- groups --------------------------------------------------------------------------------------


def _check_groups(gm, full: bool = False) -> None:
    comm = gm.mesh.comm
    assert set(gm.physical_groups) == _expected_names(gm.options, gm.bodies, full)
    tdim = gm.mesh.topology.dim
    gm.mesh.topology.create_connectivity(tdim - 1, tdim)
    n_owned = gm.mesh.topology.index_map(tdim - 1).size_local
    for name, (dim, tag) in gm.physical_groups.items():
        tags = gm.facet_tags if dim == 2 else gm.cell_tags
        local = tags.find(tag)
        count = comm.allreduce(
            int(np.count_nonzero(local < n_owned)) if dim == 2 else len(local), op=MPI.SUM
        )
        assert count > 0, f"group {name} is empty"
    # one value per facet, and exactly the exterior facets are tagged
    ft = gm.facet_tags
    assert len(np.unique(ft.indices)) == len(ft.indices)
    ext = dolfinx.mesh.exterior_facet_indices(gm.mesh.topology)
    owned_tagged = ft.indices[ft.indices < n_owned]
    assert np.array_equal(np.sort(owned_tagged), np.sort(ext))
    # every cell in exactly one body
    ct = gm.cell_tags
    n_cells = gm.mesh.topology.index_map(tdim).size_local
    assert len(np.unique(ct.indices)) == len(ct.indices) == n_cells
    assert set(np.unique(ct.values)) <= {gm.tag(b) for b in gm.bodies}


@pytest.mark.mpi
def test_named_groups_complete_disjoint_and_non_empty(default_mesh):
    _check_groups(default_mesh)


def test_group_name_api(default_mesh):
    gm = default_mesh
    assert gm.names(body="wheel", kind="root") == [f"wheel_tooth{k}_root" for k in range(8)]
    assert gm.names(tooth=4, kind="drive_flank") == [
        "pinion_tooth4_drive_flank",
        "wheel_tooth4_drive_flank",
    ]
    assert gm.names(body="pinion", kind="volume") == ["pinion"]
    assert gm.reference_tooth("pinion") == 4 and gm.reference_tooth("wheel") == 3
    assert np.allclose(gm.center("wheel"), [0.06, 0.0, 0.0])
    f = gm.facets("pinion_tooth4_tip", "pinion_tooth4_drive_flank")
    assert np.all(np.diff(f) > 0)
    with pytest.raises(KeyError, match="pinion_tooth9_tip"):
        gm.tag("pinion_tooth9_tip")
    # the tooth and kind of each facet, read back from its group
    tip, flank, bore = (
        gm.facets(n) for n in ("pinion_tooth4_tip", "wheel_tooth2_drive_flank", "pinion_bore")
    )
    teeth, kinds = gm.facet_groups("pinion", np.concatenate([tip, bore]))
    assert list(teeth) == [4] * len(tip) + [-1] * len(bore)
    assert list(kinds) == ["tip"] * len(tip) + ["bore"] * len(bore)
    teeth, kinds = gm.facet_groups("pinion", flank)  # a wheel facet is in no pinion group
    assert np.all(teeth == -1) and np.all(kinds == "")
    teeth, kinds = gm.facet_groups("wheel", flank)
    assert np.all(teeth == 2) and np.all(kinds == "drive_flank")


# --- geometry ------------------------------------------------------------------------------------


@pytest.mark.mpi
def test_sector_volume_equals_profile_area_times_width(default_mesh):
    pair = GearPair(THESIS)
    vols = body_volumes_m3(default_mesh)
    for body, v in vols.items():
        exact = pair.profile(body).body_area_m2(8) * pair.face_width_m
        # issue: within 0.5 %; the curved P2 geometry gets ~1e-6 (spline through exact points)
        assert abs(v - exact) / exact < 1e-5


@pytest.mark.mpi
def test_p2_nodes_lie_on_the_exact_tooth_outline(default_mesh):
    gm = default_mesh
    pair = GearPair(THESIS)
    for body in gm.bodies:
        prof = pair.profile(body)
        root_exact = np.vstack(
            [prof.root_points("coast", 20000, 2000), prof.root_points("drive", 20000, 2000)]
        )
        for k in (0, gm.reference_tooth(body), 7):
            f = gm.facets(f"{body}_tooth{k}_drive_flank")
            if len(f):
                assert (
                    dolfinx.mesh.entities_to_geometry(gm.mesh, 2, f, False).shape[1] == 6
                )  # curved P2 facets
            for side in ("drive", "coast"):
                xy = _to_tooth_frame(
                    gm, body, k, _global_nodes(gm, [f"{body}_tooth{k}_{side}_flank"])
                )
                assert prof.distance_to_flank(xy, side).max() < 1e-9  # metres
                assert np.hypot(*xy.T).max() <= prof.tip_form_radius_m * (
                    1 + 1e-12
                )  # the involute ends there
            _check_tip_nodes(
                prof, gm, _to_tooth_frame(gm, body, k, _global_nodes(gm, [f"{body}_tooth{k}_tip"]))
            )
            root = _to_tooth_frame(gm, body, k, _global_nodes(gm, [f"{body}_tooth{k}_root"]))
            d = np.min(np.linalg.norm(root[:, None, :] - root_exact[None, ::4, :], axis=2), axis=1)
            assert d.max() < 2e-7  # dense polyline (1e-7 m spacing) vs spline


def _check_tip_nodes(prof, gm, xy: np.ndarray) -> None:
    """Tip nodes (tooth frame) lie on the tip circle over the land (|theta| <= theta_C) and on the
    round circles (centre C, radius rho) between the land and the end of the involute; every round
    is spanned by at least two P2 edges (>= 4 nodes besides its land end on each node plane)."""
    r, th = np.hypot(*xy.T), np.arctan2(xy[:, 1], xy[:, 0])
    land = np.abs(th) <= prof.tip_land_half_angle_rad * (1 + 1e-9)
    assert np.allclose(r[land], prof.tip_radius_m, rtol=1e-12, atol=0.0)
    planes = gm.options.order * gm.options.layers + 1
    psi_end = prof.half_thickness_angle(prof.tip_form_radius_m)  # polar angle of the involute's end
    for side, sign in (("drive", 1.0), ("coast", -1.0)):
        on = ~land & (sign * th > 0)
        d = np.linalg.norm(xy[on] - prof.tip_round_center(side), axis=1)
        assert np.allclose(d, prof.tip_round_radius_m, rtol=0.0, atol=1e-12)  # ~1e-17 m measured
        assert np.all(sign * th[on] <= psi_end + 1e-12)
        assert np.count_nonzero(on) >= 4 * planes


def _drive_contact_check(gm, pinion_angle_rad: float) -> None:
    """Wheel reference drive-flank nodes vs. the exact pinion drive flank: no penetration, and
    touching within the bound of the node spacing h: gap(s) = s^2/2 (1/rho1 + 1/rho2), s <= h/4."""
    pair = GearPair(gm.geometry)
    kp, kw = gm.reference_tooth("pinion"), gm.reference_tooth("wheel")
    W = _global_nodes(gm, [f"wheel_tooth{kw}_drive_flank"])
    xy = _to_tooth_frame(gm, "pinion", kp, W)
    r = np.hypot(*xy.T)
    prof = pair.pinion
    inside = (r > prof.base_radius_m) & (r < prof.tip_form_radius_m)
    theta = np.arctan2(xy[:, 1], xy[:, 0])
    dist = prof.distance_to_flank(xy, "drive")
    penetrating = inside & (theta < prof.half_thickness_angle(np.maximum(r, prof.base_radius_m)))
    assert np.all(dist[penetrating] < 1e-9), "wheel nodes inside the pinion tooth"
    h = max(
        _max_profile_edge(gm, f"pinion_tooth{kp}_drive_flank"),
        _max_profile_edge(gm, f"wheel_tooth{kw}_drive_flank"),
    )
    S = float(pair.contact_parameter(pinion_angle_rad))
    aw = pair.operating_pressure_angle_rad
    rho1 = pair.pinion.operating_pitch_radius_m * math.sin(aw) + S
    rho2 = pair.wheel.operating_pitch_radius_m * math.sin(aw) - S
    bound = 0.5 * (h / 4) ** 2 * (1 / rho1 + 1 / rho2)
    assert dist.min() <= bound
    # the closest wheel node is at the contact point of the line of action (S = r_b1 phi)
    X = pair.path_of_contact().point(np.array([S]))[0]
    nearest = W[np.argmin(dist), :2]
    assert np.linalg.norm(nearest - X) < h


@pytest.mark.mpi
def test_conjugate_pair_touches_at_the_pitch_point(default_mesh):
    _drive_contact_check(default_mesh, 0.0)


def test_conjugate_pair_touches_at_a_rotated_position(cache):
    options = dataclasses.replace(COARSE, pinion_angle_deg=4.0)
    gm = build_gear_mesh(THESIS, options, MPI.COMM_WORLD, cache_dir=cache)
    _drive_contact_check(gm, math.radians(4.0))


@pytest.mark.mpi
def test_coast_side_clearance_is_the_normal_backlash(default_mesh):
    """Backlash is all on the coast side: the coast flanks of the engaged teeth are j_n apart
    (exact surfaces); the nodes are within the node-spacing bound of that."""
    gm = default_mesh
    pair = GearPair(THESIS)
    kp, kw = gm.reference_tooth("pinion"), gm.reference_tooth("wheel")
    W = _global_nodes(gm, [f"wheel_tooth{kw}_coast_flank"])
    xy = _to_tooth_frame(gm, "pinion", kp + 1, W)
    d = pair.pinion.distance_to_flank(xy, "coast")
    i = int(np.argmin(d))
    jn = pair.backlash_normal_m
    h = max(
        _max_profile_edge(gm, f"wheel_tooth{kw}_coast_flank"),
        _max_profile_edge(gm, f"pinion_tooth{kp + 1}_coast_flank"),
    )
    rb = pair.pinion.base_radius_m
    rho_w = math.sqrt(
        np.sum((W[i, :2] - gm.center("wheel")[:2]) ** 2) - rb**2
    )  # wheel flank curvature radius there
    rho_p = (
        math.sqrt(np.sum(xy[i] ** 2) - rb**2) - jn
    )  # pinion flank, at most j_n lower along the normal
    bound = 0.5 * (h / 4) ** 2 * (1 / rho_w + 1 / rho_p)
    assert jn - 1e-9 <= d[i] <= jn + bound


def _exact_body_outline(gm, body: str, spacing: float = 1e-6) -> np.ndarray:
    """Closed polygon of the exact section of a body (teeth, cut lines, bore arc) in the pair
    frame."""
    prof = GearPair(gm.geometry).profile(body)
    c = gm.center(body)[:2]
    n = int(0.02 / spacing)  # dense: the tooth outline is ~15 mm long
    one = prof.outline_polyline(n_flank=n // 4, n_fillet=n // 8, n_land=n // 40, n_tip=n // 40)
    pts = [c + _rotate_xy(one, th) for th in gm.tooth_angles(body)]
    t0 = gm.tooth_angles(body)[0] - math.pi / prof.teeth
    t1 = gm.tooth_angles(body)[-1] + math.pi / prof.teeth
    arc = np.linspace(t1, t0, 2000)
    pts.append(c + prof.bore_radius_m * np.column_stack([np.cos(arc), np.sin(arc)]))
    return np.vstack(pts)


def _rotate_xy(xy, angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.column_stack([c * xy[:, 0] - s * xy[:, 1], s * xy[:, 0] + c * xy[:, 1]])


@pytest.mark.mpi
def test_no_penetration_and_positive_gap_elsewhere(default_mesh):
    """No boundary node of one body lies inside the exact section of the other; away from the
    pitch line every node keeps a positive gap to the other body."""
    from matplotlib.path import Path as MplPath
    from scipy.spatial import cKDTree

    gm = default_mesh
    for body, other in (("pinion", "wheel"), ("wheel", "pinion")):
        X = _global_nodes(gm, gm.names(body=body)[1:])
        dist, _ = cKDTree(_exact_body_outline(gm, other)).query(
            X[:, :2]
        )  # dense polyline, 1 um spacing
        coarse = _exact_body_outline(gm, other, spacing=1e-4)  # polygon within 5 um of the curves
        inside = MplPath(coarse).contains_points(X[:, :2])
        assert not np.any(inside & (dist > 1e-5)), f"{body} nodes inside the {other}"
        away = np.hypot(X[:, 0] - 30e-3, X[:, 1]) > 0.5e-3
        assert dist[away].min() > 1e-5  # positive gap (the nearest: an approaching tip, ~0.13 mm)
        assert dist[~away].min() < 1e-6  # and contact at the pitch line


# --- report, variants ----------------------------------------------------------------------------


@pytest.mark.mpi
def test_mesh_report(default_mesh):
    rep = mesh_report(default_mesh)
    assert (
        rep["counts"]["dofs_p2_vector"] == 3 * rep["counts"]["nodes"]
    )  # P2 geometry nodes = P2 dofs
    assert rep["quality"]["min_scaled_jacobian"] > 0.0  # no inverted (curved) cell
    assert rep["element"]["cell_type"] == "Tetrahedron 10"
    for name, g in rep["groups"].items():
        if g["dim"] == 2:
            assert g["facets"] > 0
            assert g["area_mm2"] == pytest.approx(g["analytic_mm2"], rel=2e-4), name
    # the same areas from DOLFINx
    gm = default_mesh
    one = dolfinx.fem.Constant(gm.mesh, 1.0)
    for name in ("pinion_tooth4_drive_flank", "wheel_tooth3_root", "pinion_bore"):
        a = gm.mesh.comm.allreduce(
            dolfinx.fem.assemble_scalar(dolfinx.fem.form(one * gm.ds(name))), op=MPI.SUM
        )
        assert a * 1e6 == pytest.approx(rep["groups"][name]["area_mm2"], rel=1e-9)


@pytest.mark.mpi
def test_one_and_two_ranks_give_the_same_mesh(cache, comms):
    results = []
    for comm in reversed(
        comms
    ):  # world first: rank 0 builds, then every rank reads the cache serially
        gm = build_gear_mesh(THESIS, COARSE, comm, cache_dir=cache)
        one = dolfinx.fem.Constant(gm.mesh, 1.0)
        areas = [
            comm.allreduce(
                dolfinx.fem.assemble_scalar(dolfinx.fem.form(one * gm.ds(n))), op=MPI.SUM
            )
            for n in ("pinion_tooth4_drive_flank", "wheel_cut_end")
        ]
        results.append((body_volumes_m3(gm), areas, gm.mesh.topology.index_map(3).size_global))
    (v2, a2, n2), (v1, a1, n1) = results
    assert n1 == n2
    for body in v1:
        assert v2[body] == pytest.approx(v1[body], rel=1e-12)
    assert np.allclose(a2, a1, rtol=1e-12)


def test_hex_variant(cache):
    options = dataclasses.replace(COARSE, element="hex")
    gm = build_gear_mesh(THESIS, options, MPI.COMM_WORLD, cache_dir=cache)
    assert gm.mesh.topology.cell_type == dolfinx.mesh.CellType.hexahedron
    assert gm.mesh.geometry.cmaps[0].degree == 2
    _check_groups(gm)
    pair = GearPair(THESIS)
    for body, v in body_volumes_m3(gm).items():
        exact = pair.profile(body).body_area_m2(8) * pair.face_width_m
        assert abs(v - exact) / exact < 1e-5
    f = gm.facets("pinion_tooth4_drive_flank")
    assert (
        dolfinx.mesh.entities_to_geometry(gm.mesh, 2, f, False).shape[1] == 9
    )  # 9-node curved quads
    xy = _to_tooth_frame(gm, "pinion", 4, _global_nodes(gm, ["pinion_tooth4_drive_flank"]))
    assert pair.pinion.distance_to_flank(xy, "drive").max() < 1e-9
    for k in (0, 4):
        _check_tip_nodes(
            pair.pinion,
            gm,
            _to_tooth_frame(gm, "pinion", k, _global_nodes(gm, [f"pinion_tooth{k}_tip"])),
        )
    # no quadrilateral corner on a tangent curve junction (tip round / land / flank): such a corner
    # is 180 degrees once curved and its scaled Jacobian ~ 1e-4 (what blossom recombination gave)
    assert gm.build_info["quality"]["min_scaled_jacobian"] > 0.2


def test_layer_planes_uniform_and_graded():
    b = 12.934e-3
    assert np.array_equal(layer_planes(b, 2, 2), np.linspace(0.0, b, 5))  # equal: as before
    assert np.array_equal(layer_planes(b, 3, 2, 1.0), np.linspace(0.0, b, 7))
    for layers, g in ((4, 8.0), (5, 20.0), (7, 3.0)):
        z = layer_planes(b, layers, 2, g)
        bounds, t = z[::2], np.diff(z[::2])
        assert z[0] == 0.0 and z[-1] == b and np.all(np.diff(z) > 0)
        assert np.allclose(z[1::2], 0.5 * (bounds[:-1] + bounds[1:]), rtol=0, atol=1e-16)
        assert np.allclose(t, t[::-1], rtol=1e-12)  # symmetric about the middle
        # thinnest at the side faces, growing geometrically towards the middle: the layers of
        # the front half in the neighbour ratio G^(2 / layers) of the size function s(xi)
        front = t[: layers // 2]
        assert np.allclose(front[1:] / front[:-1], g ** (2.0 / layers), rtol=1e-12)
        assert t.min() == pytest.approx(t[0], rel=1e-12) == t[-1]
        side = b * (g ** (2.0 / layers) - 1.0) / (2.0 * (g - 1.0))
        assert t[0] == pytest.approx(side, rel=1e-12)
    # refining the count keeps the size function: 4 -> 8 layers halves every layer (nested)
    z4, z8 = layer_planes(b, 4, 1, 8.0), layer_planes(b, 8, 1, 8.0)
    assert np.allclose(z8[::2], z4, rtol=0, atol=1e-15)
    # the discrete middle-to-side ratio, G^(1 - 2 / layers), tends to G as the layers multiply
    for layers in (4, 40):
        t = np.diff(layer_planes(b, layers, 1, 8.0))
        assert t[layers // 2 - 1] / t[0] == pytest.approx(8.0 ** (1.0 - 2.0 / layers), rel=1e-12)


@pytest.mark.parametrize("grading", [1.0, 0.5, 2000.0])
def test_layer_grading_is_checked(grading):
    if grading == 1.0:  # equal layers: stored as None, so equal layers keep one cache key
        assert MeshOptions(layer_grading=grading).layer_grading is None
        assert cache_key(THESIS, MeshOptions(layer_grading=1.0)) == cache_key(THESIS, MeshOptions())
        return
    with pytest.raises(ParameterError) as err:
        MeshOptions(layer_grading=grading)
    assert err.value.name == "mesh.layer_grading" and "1" in err.value.allowed


def test_graded_layers_mesh(cache):
    options = dataclasses.replace(COARSE, layers=4, layer_grading=8.0)
    gm = build_gear_mesh(THESIS, options, MPI.COMM_WORLD, cache_dir=cache, bodies=("pinion",))
    assert gm.cache_key != cache_key(THESIS, dataclasses.replace(options, layer_grading=None))
    _check_groups(gm)
    b = THESIS.face_width_mm * 1e-3
    z = np.unique(np.round(gm.mesh.geometry.x[:, 2], 12))
    z = np.unique(np.round(np.concatenate(gm.mesh.comm.allgather(z)), 12))
    assert np.allclose(z, layer_planes(b, 4, 2, 8.0), rtol=0, atol=1e-12)
    v = body_volumes_m3(gm)["pinion"]
    exact = GearPair(THESIS).pinion.body_area_m2(8) * b
    assert abs(v - exact) / exact < 1e-5
    q = gm.build_info["quality"]
    assert q["side_layer_thickness_mm"] == pytest.approx(1e3 * layer_planes(b, 4, 1, 8.0)[1])
    assert q["layer_thickness_mm"] == pytest.approx(1e3 * np.diff(layer_planes(b, 4, 1, 8.0)).max())


def test_full_gear_is_closed(cache):
    g = GearPairGeometry(teeth_pinion=16, teeth_wheel=16, bore_radius_mm=8.0)
    options = dataclasses.replace(COARSE, teeth_in_model=16)
    gm = build_gear_mesh(g, options, MPI.COMM_WORLD, cache_dir=cache, bodies=("pinion",))
    _check_groups(gm, full=True)
    prof = GearPair(g).pinion
    v = body_volumes_m3(gm)["pinion"]
    exact = 16 * prof.tooth_sector_area_m2(prof.bore_radius_m) * g.face_width_mm * 1e-3
    assert abs(v - exact) / exact < 1e-4  # coarse: 3 mm quadratic edges on the 8 mm bore
    # closed surface: the integral of the normal over the whole boundary vanishes
    n = ufl.FacetNormal(gm.mesh)
    ds = gm.ds(*gm.names(body="pinion")[1:])
    total_area = gm.mesh.comm.allreduce(
        dolfinx.fem.assemble_scalar(dolfinx.fem.form(1.0 * ds)), op=MPI.SUM
    )
    for i in range(3):
        ni = gm.mesh.comm.allreduce(
            dolfinx.fem.assemble_scalar(dolfinx.fem.form(n[i] * ds)), op=MPI.SUM
        )
        assert abs(ni) < 1e-10 * total_area


def test_single_body_mesh(cache):
    gm = build_gear_mesh(THESIS, COARSE, MPI.COMM_WORLD, cache_dir=cache, bodies=("wheel",))
    assert set(gm.physical_groups) == _expected_names(gm.options, gm.bodies)
    assert all(n.startswith("wheel") for n in gm.physical_groups)


def test_analytic_areas_of_body_faces():
    areas = analytic_areas_mm2(THESIS, MeshOptions())
    b = THESIS.face_width_mm
    assert areas["pinion_bore"] == pytest.approx(15.0 * 8 * 2 * math.pi / 30 * b, rel=1e-14)
    assert areas["wheel_cut_start"] == pytest.approx((27.5 - 15.0) * b, rel=1e-14)


# --- cache, errors, CLI --------------------------------------------------------------------------


def test_cache_dir_from_environment(monkeypatch, tmp_path):
    from gearfem.geometry.mesh import ENV_CACHE, default_cache_dir

    monkeypatch.setenv(ENV_CACHE, str(tmp_path / "elsewhere"))
    assert default_cache_dir() == tmp_path / "elsewhere"
    monkeypatch.delenv(ENV_CACHE)
    assert default_cache_dir() == Path("meshes") / "cache"


@pytest.mark.parametrize("element", ["tet", "hex"])
def test_first_order_meshes(element, cache):
    options = dataclasses.replace(COARSE, order=1, element=element, teeth_in_model=3)
    gm = build_gear_mesh(THESIS, options, MPI.COMM_WORLD, cache_dir=cache)
    assert gm.mesh.geometry.cmaps[0].degree == 1
    _check_groups(gm)
    pair = GearPair(THESIS)
    for body, v in body_volumes_m3(gm).items():
        prof = pair.profile(body)
        exact = prof.body_area_m2(3) * pair.face_width_m
        # straight edges on curved boundaries: segment areas L h^2 / (12 R), dominated by the bore
        # (3 mm edges on R = 15 mm over L = 3 tau R); twice that covers the (finer) tooth curves
        L, h, R = 3 * prof.pitch_angle_rad * prof.bore_radius_m, 3e-3, prof.bore_radius_m
        bound = 2 * L * h**2 / (12 * R) / prof.body_area_m2(3)
        assert abs(v - exact) / exact < bound


def test_cache_key_depends_on_the_tip_rounds():
    sharp = dataclasses.replace(THESIS, tip_round_coefficient=0.0)
    small = dataclasses.replace(THESIS, tip_round_coefficient=0.05)
    keys = {cache_key(g, MeshOptions()) for g in (THESIS, sharp, small)}
    assert len(keys) == 3


def test_cache_hit_and_interrupted_build(tmp_path, monkeypatch):
    opts = dataclasses.replace(COARSE, teeth_in_model=3)
    pinion = ("pinion",)
    gm = build_gear_mesh(THESIS, opts, MPI.COMM_SELF, cache_dir=tmp_path, bodies=pinion)
    mtime = gm.msh_path.stat().st_mtime_ns
    again = build_gear_mesh(THESIS, opts, MPI.COMM_SELF, cache_dir=tmp_path, bodies=pinion)
    assert again.cache_key == gm.cache_key and again.msh_path.stat().st_mtime_ns == mtime

    import gearfem.geometry.mesh as meshmod

    def broken(path, geometry, options, bodies):
        Path(path).write_text("partial")
        raise RuntimeError("interrupted")

    monkeypatch.setattr(meshmod, "write_model", broken)
    other = dataclasses.replace(opts, layers=1)
    with pytest.raises(RuntimeError, match="interrupted"):
        build_gear_mesh(THESIS, other, MPI.COMM_SELF, cache_dir=tmp_path, bodies=pinion)
    assert sorted(p.name for p in tmp_path.iterdir()) == [gm.cache_key]  # nothing half-built left


@pytest.mark.parametrize(
    "changes, name",
    [
        (dict(teeth_in_model=31), "mesh.teeth_in_model"),  # N > Z = 30
        (dict(teeth_in_model=0), "mesh.teeth_in_model"),
        (dict(size_flank_mm=0.0), "mesh.size_flank_mm"),
        (dict(size_body_mm=-3.0), "mesh.size_body_mm"),
        (dict(layers=0), "mesh.layers"),
        (dict(element="prism"), "mesh.element"),
        (dict(order=3), "mesh.order"),
        (dict(size_entry_mm=0.0), "mesh.size_entry_mm"),
        (dict(size_entry_mm=0.2), "mesh.size_entry_mm"),  # > size_flank_mm = 0.12
    ],
)
def test_bad_mesh_options_raise_parameter_error(changes, name, tmp_path):
    with pytest.raises(ParameterError) as err:
        options = dataclasses.replace(MeshOptions(), **changes)
        build_gear_mesh(THESIS, options, MPI.COMM_SELF, cache_dir=tmp_path)
    assert err.value.name == name
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("bodies", [("gear",), (), ("pinion", "pinion")])
def test_bad_bodies_raise_parameter_error(bodies, tmp_path):
    """Which bodies to mesh is an argument of the build (not a case-file key)."""
    with pytest.raises(ParameterError) as err:
        build_gear_mesh(THESIS, MeshOptions(), MPI.COMM_SELF, cache_dir=tmp_path, bodies=bodies)
    assert err.value.name == "bodies"
    assert not any(tmp_path.iterdir())


def test_bodies_is_not_a_case_file_key(tmp_path):
    """The old ``[mesh] bodies`` key, which every caller overwrote, is rejected by name."""
    case = tmp_path / "case.toml"
    case.write_text('[mesh]\nbodies = ["pinion"]\n')
    with pytest.raises(ParameterError) as err:
        load_case(case)
    assert "bodies" in err.value.name


def test_cli_mesh_writes_mesh_json_and_picture(tmp_path, capsys):
    from gearfem.cli import main

    case = tmp_path / "case.toml"
    case.write_text(
        "name = 'mesh only: the material is validated, not used'\n\n"
        "[geometry]\nteeth_pinion = 30\n\n"
        "[mesh]\nteeth_in_model = 5\nsize_flank_mm = 0.4\nsize_tip_mm = 0.4\nsize_root_mm = "
        "0.4\nlayers = 1\n\n"
        "[material]\nname = 'POM'\nhysteresis = [[20.0, 100.0], [0.01, 0.02]]\n"
    )
    out = tmp_path / "out"
    assert main(["mesh", str(case), "--out", str(out), "--cache-dir", str(tmp_path / "cache")]) == 0
    rep = json.loads((out / "mesh.json").read_text())
    assert rep["mesh_options"]["teeth_in_model"] == 5
    assert len(rep["groups"]) == 2 * (1 + 5 * 4 + 5)
    assert (out / "mesh.msh").stat().st_size > 0
    png = (out / "gear_pair_mesh.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 50_000
    assert "P2 vector DOFs" in capsys.readouterr().out
    case.write_text("[mesh]\nsize_flnk_mm = 0.2\n")
    assert main(["mesh", str(case), "--out", str(out), "--cache-dir", str(tmp_path / "cache")]) == 2
    assert "mesh.size_flnk_mm" in capsys.readouterr().err


def _section_edges(gm, body: str, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Midpoints (tooth frame, m) and lengths (m) of the z = 0 edges of tooth ``k``'s drive flank
    facets, gathered on every rank."""
    f = gm.facets(f"{body}_tooth{k}_drive_flank")
    g = (
        dolfinx.mesh.entities_to_geometry(gm.mesh, 2, f, False)[:, :3]
        if len(f)
        else np.empty((0, 3), dtype=np.int32)
    )
    x = gm.mesh.geometry.x
    mids, lengths = [], []
    for a, b in ((0, 1), (1, 2), (0, 2)):
        on = (np.abs(x[g[:, a], 2]) < 1e-12) & (np.abs(x[g[:, b], 2]) < 1e-12)
        mids.append(0.5 * (x[g[on, a]] + x[g[on, b]]))
        lengths.append(np.linalg.norm(x[g[on, a]] - x[g[on, b]], axis=1))
    mid = np.vstack(gm.mesh.comm.allgather(np.vstack(mids)))
    length = np.concatenate(gm.mesh.comm.allgather(np.concatenate(lengths)))
    return _to_tooth_frame(gm, body, k, mid), length


def test_entry_refinement_refines_the_flank_foot_only(cache):
    """``size_entry_mm``: the drive flank's edges from its foot up to 0.15 modules above the
    start of active profile take that size, the rest of the flank keeps ``size_flank_mm`` (edges
    0.29 / 0.30 mm measured); off (None), the option is no part of the keys."""
    base = dataclasses.replace(COARSE, teeth_in_model=3, refined_teeth=1)
    fine = dataclasses.replace(base, size_entry_mm=0.1)
    assert "size_entry_mm" not in to_dict(base)  # off: the keys of meshes, cycles, studies kept
    assert cache_key(THESIS, fine) != cache_key(THESIS, base)
    pair = GearPair(THESIS)
    top = pair.start_of_active_profile_m("pinion") + ENTRY_MARGIN_MODULES * THESIS.module_mm * 1e-3
    pinion = ("pinion",)
    sizes = {}
    for name, opts in (("base", base), ("fine", fine)):
        gm = build_gear_mesh(THESIS, opts, MPI.COMM_WORLD, cache_dir=cache, bodies=pinion)
        mid, length = _section_edges(gm, "pinion", 1)
        r = np.linalg.norm(mid, axis=1)
        sizes[name] = (length[r < top - 0.05e-3], length[r > top + 0.5e-3])
    foot, rest = sizes["fine"]
    assert len(foot) >= 6 and np.max(foot) < 1.15 * 0.1e-3  # measured 0.1015 mm
    assert np.max(sizes["base"][0]) > 1.5 * np.max(foot)
    assert np.max(rest) == pytest.approx(np.max(sizes["base"][1]), rel=0.1)


def _cut_nodes(gm, kind: str) -> np.ndarray:
    """Geometry nodes (m) on the pinion's cut face ``kind`` (this rank's facets)."""
    msh = gm.mesh
    fdim = msh.topology.dim - 1
    facets = gm.facet_tags.find(int(gm.physical_groups[f"pinion_{kind}"].tag))
    nodes = dolfinx.mesh.entities_to_geometry(msh, fdim, facets, False)
    return msh.geometry.x[np.unique(nodes.ravel())]


@pytest.mark.parametrize("periodic", [True, None])
def test_periodic_cuts_mesh_the_cut_faces_alike(cache, periodic):
    """``periodic_cuts``: the nodes of the sector's cut_end face are those of cut_start turned
    by the sector's angle about the gear's centre (to round-off). Without it the two faces are
    meshed independently: alike where the size field is symmetric about the sector's middle
    (the built-in meshes), not here, where one of the two teeth is refined (measured: 93 and 81
    nodes)."""
    opts = dataclasses.replace(
        COARSE,
        teeth_in_model=2,
        refined_teeth=1,
        size_flank_mm=0.21,
        size_root_mm=0.28,
        size_body_mm=1.0,
        size_tooth_mm=0.6,
        layers=1,
        periodic_cuts=periodic,
    )
    gm = build_gear_mesh(
        GearPairGeometry(), opts, MPI.COMM_SELF, cache_dir=cache, bodies=("pinion",)
    )
    place = placement(gm.pair, opts, "pinion")
    t0, t1 = place.sector_rad
    start, end = _cut_nodes(gm, "cut_start"), _cut_nodes(gm, "cut_end")
    dist, _ = cKDTree(end).query(rotate_xy(start, place.center_m, t1 - t0))
    matched = len(start) == len(end) and float(dist.max()) < 1e-12
    assert matched == bool(periodic), (len(start), len(end), float(dist.max()))


def test_periodic_cuts_need_a_sector():
    """A whole gear has no cut faces to make periodic."""
    g = GearPairGeometry()
    with pytest.raises(ParameterError, match="periodic_cuts"):
        check_options(g, MeshOptions(teeth_in_model=g.teeth_pinion, periodic_cuts=True))


# --- a profile-shifted pair ----------------------------------------------------------------------

#: A 20/40 pair at 20 deg with x1 = 0.4, x2 = 0.1 (ISO 21771), the default tip rounds, thinned as
#: the thesis teeth; four teeth per gear on the coarse sizes.
SHIFTED = GearPairGeometry(
    module_mm=2.0,
    teeth_pinion=20,
    teeth_wheel=40,
    pressure_angle_deg=20.0,
    tooth_thickness_mm=2.995,
    root_fillet_coefficient=0.3,
    bore_radius_mm=10.0,
    profile_shift_pinion=0.4,
    profile_shift_wheel=0.1,
)


def test_a_profile_shifted_pair_is_meshed_exactly_and_conjugate(cache):
    """The shifted pair's mesh: each body's volume is its shifted profile's area times the face
    width, the flank nodes lie on the shifted involutes and the root nodes on the shifted rack's
    trochoid, the tip nodes reach the shortened tip circle, and the rotated pair touches on the
    line of action of the working pressure angle without penetrating (the checks of the unshifted
    pair above)."""
    # the other teeth at 0.4 mm: at the coarse 0.8 mm the 20-tooth pinion's curved P2 boundary is
    # 1.1e-5 short of the exact volume (thesis pair 8.5e-7), 1.7e-6 at 0.4 mm
    options = dataclasses.replace(
        COARSE, teeth_in_model=4, refined_teeth=2, size_tooth_mm=0.4, pinion_angle_deg=3.0
    )
    gm = build_gear_mesh(SHIFTED, options, MPI.COMM_WORLD, cache_dir=cache)
    pair = GearPair(SHIFTED)
    for body, v in body_volumes_m3(gm).items():
        exact = pair.profile(body).body_area_m2(4) * pair.face_width_m
        assert abs(v - exact) / exact < 1e-5, body
    for body in gm.bodies:
        prof = pair.profile(body)
        k = gm.reference_tooth(body)
        for side in ("drive", "coast"):
            xy = _to_tooth_frame(gm, body, k, _global_nodes(gm, [f"{body}_tooth{k}_{side}_flank"]))
            assert prof.distance_to_flank(xy, side).max() < 1e-9
        tip = _to_tooth_frame(gm, body, k, _global_nodes(gm, [f"{body}_tooth{k}_tip"]))
        assert np.hypot(*tip.T).max() == pytest.approx(prof.tip_radius_m, rel=1e-12)
        root = _to_tooth_frame(gm, body, k, _global_nodes(gm, [f"{body}_tooth{k}_root"]))
        exact = np.vstack([prof.root_points(s, 40000, 20000) for s in ("coast", "drive")])
        spacing = np.linalg.norm(np.diff(exact, axis=0), axis=1)
        d, _ = cKDTree(exact).query(root)
        # within the dense polyline's half spacing of its vertices (the P2 nodes lie on the curve)
        assert d.max() < 0.5 * spacing[spacing < 1e-5].max() + 1e-9
    _drive_contact_check(gm, math.radians(3.0))
