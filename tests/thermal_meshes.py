"""Small meshes with gear-like facet groups for the thermal tests (no gmsh needed)."""

from __future__ import annotations

import math

import numpy as np
from dolfinx import mesh as dmesh

import gearfem  # noqa: F401
from gearfem.thermal.domain import ThermalDomain


def _tag(msh, groups_markers):
    """MeshTags from [(name, marker)], markers on facet midpoints; returns (tags, groups)."""
    fdim = msh.topology.dim - 1
    msh.topology.create_connectivity(fdim, msh.topology.dim)
    idx, vals, groups = [], [], {}
    taken = np.zeros(0, dtype=np.int32)
    for i, (name, marker) in enumerate(groups_markers, start=1):
        f = dmesh.locate_entities_boundary(msh, fdim, marker)
        f = np.setdiff1d(f, taken)
        taken = np.union1d(taken, f)
        idx.append(f)
        vals.append(np.full(len(f), i, dtype=np.int32))
        groups[name] = (i,)
    idx = np.concatenate(idx)
    vals = np.concatenate(vals)
    order = np.argsort(idx)
    return dmesh.meshtags(msh, fdim, idx[order], vals[order]), groups


def box_domain(comm, n=(4, 4, 4), size=(0.02, 0.02, 0.01), cell=dmesh.CellType.tetrahedron):
    """Box [0,Lx]x[0,Ly]x[0,Lz]: z faces are 'sides', the four others 'teeth'."""
    _Lx, _Ly, Lz = size
    msh = dmesh.create_box(comm, [np.zeros(3), np.array(size)], list(n), cell)
    ft, groups = _tag(
        msh,
        [
            ("side_back", lambda x: np.isclose(x[2], 0.0)),
            ("side_front", lambda x: np.isclose(x[2], Lz)),
            ("outer", lambda x: np.full(x.shape[1], True)),
        ],
    )
    return ThermalDomain(
        msh,
        ft,
        groups,
        teeth=("outer",),
        sides=("side_back", "side_front"),
        monitors={"outer": ("outer",)},
    )


def square_domain(comm, n):
    """Unit square: bottom/top edges 'sides', left/right 'teeth' (2D, for refinement studies)."""
    msh = dmesh.create_unit_square(comm, n, n, dmesh.CellType.triangle)
    ft, groups = _tag(
        msh,
        [
            ("bottom", lambda x: np.isclose(x[1], 0.0)),
            ("top", lambda x: np.isclose(x[1], 1.0)),
            ("left", lambda x: np.isclose(x[0], 0.0)),
            ("right", lambda x: np.isclose(x[0], 1.0)),
        ],
    )
    return ThermalDomain(
        msh,
        ft,
        groups,
        teeth=("left", "right"),
        sides=("bottom", "top"),
        monitors={"right": ("right",)},
    )


def annular_sector(
    comm, teeth=2, r_in=0.015, r_out=0.031, width=0.0129, pitch_deg=12.0, n=(4, 4, 3), body="pinion"
):
    """Annular sector of ``teeth`` pitches named like a gearfem gear mesh.

    The box (r, theta, z) is meshed with n = (radial, per pitch, axial) cells and mapped to the
    annulus; the outer arc of every pitch is split into root | drive flank | tip | coast flank.
    """
    span = math.radians(pitch_deg) * teeth
    nr, nt, nz = n
    msh = dmesh.create_box(
        comm,
        [np.array([r_in, 0.0, 0.0]), np.array([r_out, span, width])],
        [nr, nt * teeth, nz],
        dmesh.CellType.tetrahedron,
    )
    pitch = span / teeth
    markers = [
        (f"{body}_bore", lambda x: np.isclose(x[0], r_in)),
        (f"{body}_side_back", lambda x: np.isclose(x[2], 0.0)),
        (f"{body}_side_front", lambda x: np.isclose(x[2], width)),
        (f"{body}_cut_start", lambda x: np.isclose(x[1], 0.0)),
        (f"{body}_cut_end", lambda x: np.isclose(x[1], span)),
    ]
    for k in range(teeth):
        for j, kind in enumerate(("root", "drive_flank", "tip", "coast_flank")):
            lo, hi = pitch * (k + 0.25 * j), pitch * (k + 0.25 * (j + 1))
            markers.append(
                (
                    f"{body}_tooth{k}_{kind}",
                    lambda x, lo=lo, hi=hi: (
                        np.isclose(x[0], r_out) & (x[1] >= lo - 1e-12) & (x[1] <= hi + 1e-12)
                    ),
                )
            )
    ft, groups = _tag(msh, markers)
    r, th = msh.geometry.x[:, 0].copy(), msh.geometry.x[:, 1].copy()
    msh.geometry.x[:, 0] = r * np.cos(th)
    msh.geometry.x[:, 1] = r * np.sin(th)
    return msh, ft, groups


def sector_domain(comm, teeth=2, total_teeth=30, **kw):
    msh, ft, groups = annular_sector(comm, teeth=teeth, **kw)
    return ThermalDomain.from_gear_groups(
        msh, ft, groups, body=kw.get("body", "pinion"), total_teeth=total_teeth
    )
