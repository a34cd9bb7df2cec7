"""Contact verification cases: two blocks (patch test, sliding) and two cylinders (Hertz).

Each function builds a gmsh model on rank 0 of ``comm`` and returns DOLFINx ``MeshData`` whose
physical groups are looked up by name. Bodies are separate gmsh volumes (no shared nodes), so
their interface meshes do not match.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import time

import gmsh
import numpy as np
from mpi4py import MPI

from gearfem.contact.condensed import CondensedContactProblem
from gearfem.contact.interface import ContactInterface
from gearfem.contact.problem import ContactProblem, fixed_mask
from gearfem.contact.rigid import RigidMotion
from gearfem.contact.surface import ContactSurface
from gearfem.core.params import require_choice, require_int, require_positive

INITIAL_GAP = 1e-6  # relative to the radius, see hertz_cylinders


@contextlib.contextmanager
def _gmsh_model(name: str):
    """An initialised gmsh with a fresh model (rank-local)."""
    started = not gmsh.isInitialized()
    if started:
        gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(name)
    try:
        yield gmsh.model
    finally:
        gmsh.model.remove()
        if started:
            gmsh.finalize()


def _to_dolfinx(comm: MPI.Comm, build) -> object:
    from dolfinx.io import gmsh as gmshio

    with _gmsh_model("gearfem_example"):
        if comm.rank == 0:
            build()
        return gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=3)


def _box_surfaces(vol: int) -> dict[str, int]:
    """Bounding-box named faces of an axis-aligned box volume: xmin, xmax, ymin, ... -> surface
    tag."""
    out = {}
    for dim, tag in gmsh.model.getBoundary([(3, vol)], oriented=False):
        xmin, ymin, zmin, xmax, ymax, zmax = gmsh.model.getBoundingBox(dim, tag)
        c = np.array([xmin + xmax, ymin + ymax, zmin + zmax]) / 2
        ext = np.array([xmax - xmin, ymax - ymin, zmax - zmin])
        k = int(np.argmin(ext))
        lo, hi = gmsh.model.getBoundingBox(3, vol)[k], gmsh.model.getBoundingBox(3, vol)[k + 3]
        out[("xyz"[k]) + ("min" if abs(c[k] - lo) < abs(c[k] - hi) else "max")] = tag
    return out


def two_blocks(
    comm: MPI.Comm,
    size_lower: float = 0.25,
    size_upper: float = 0.17,
    order: int = 2,
    hexahedra: bool = False,
    width: float = 1.0,
    height: float = 0.5,
):
    """Two blocks [0, w]² × [−h, 0] ("lower") and [0, w]² × [0, h] ("upper"), non-matching meshes.

    Physical groups: volumes ``lower``, ``upper``; faces ``{body}_{x,y,z}{min,max}``.
    """
    require_positive("size_lower", size_lower)
    require_positive("size_upper", size_upper)
    require_int("order", order, 1, 2)

    def build():
        occ = gmsh.model.occ
        lo = occ.addBox(0, 0, -height, width, width, height)
        up = occ.addBox(0, 0, 0, width, width, height)
        occ.synchronize()
        for name, vol, h in (("lower", lo, size_lower), ("upper", up, size_upper)):
            gmsh.model.addPhysicalGroup(3, [vol], name=name)
            for face, tag in _box_surfaces(vol).items():
                gmsh.model.addPhysicalGroup(2, [tag], name=f"{name}_{face}")
            pts = gmsh.model.getBoundary([(3, vol)], recursive=True)
            gmsh.model.mesh.setSize(pts, h)
            if hexahedra:
                for dim, tag in gmsh.model.getBoundary([(3, vol)], recursive=False):
                    for _, c in gmsh.model.getBoundary([(dim, tag)], recursive=False):
                        gmsh.model.mesh.setTransfiniteCurve(abs(c), max(2, round(width / h) + 1))
                    gmsh.model.mesh.setTransfiniteSurface(tag)
                    gmsh.model.mesh.setRecombine(2, tag)
                gmsh.model.mesh.setTransfiniteVolume(vol)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(order)

    return _to_dolfinx(comm, build)


def hertz_cylinders(
    comm: MPI.Comm,
    radius: float = 1.0,
    thickness: float = 0.05,
    contact_size: float = 0.02,
    far_size: float = 0.25,
    refine_half_width: float = 0.15,
    layers: int = 1,
    order: int = 2,
):
    """Two equal half-cylinders (axis z) touching along the z axis: plane-strain Hertz line contact.

    The upper body is the lower half of a disc of ``radius`` centred at (0, R), the lower body the
    upper half of a disc centred at (0, −R(1 + INITIAL_GAP)) (a 1e-6 R initial gap keeps the mesher
    from joining the bodies; it is negligible next to the displacements); both extruded over
    ``thickness`` in z with ``layers``
    element layers (tetrahedra). The mesh is graded from ``contact_size`` within
    ``refine_half_width`` of the contact line to ``far_size``.

    Physical groups: ``upper``, ``lower`` (volumes); ``upper_flat``, ``lower_flat`` (the cut
    planes y = ±R), ``upper_curved``, ``lower_curved`` (cylindrical faces), ``{body}_front`` (z =
    0),
    ``{body}_back`` (z = t).
    """
    for name, val in (
        ("radius", radius),
        ("thickness", thickness),
        ("contact_size", contact_size),
        ("far_size", far_size),
        ("refine_half_width", refine_half_width),
    ):
        require_positive(name, val)
    require_int("layers", layers, 1, 1000)
    require_int("order", order, 1, 2)
    R = radius

    def build():
        occ = gmsh.model.occ
        out, contact_points = {}, []
        # gmsh's structured extrusion identifies mesh vertices by position, which would join the
        # two bodies at coincident contact-line nodes: the lower body starts INITIAL_GAP below.
        for name, cy, sgn in (("upper", R, -1.0), ("lower", -R - INITIAL_GAP * R, 1.0)):
            # half disc: centre (0, cy), the half towards the contact point (origin)
            p0 = occ.addPoint(0, cy, 0)
            p1 = occ.addPoint(R, cy, 0)
            p2 = occ.addPoint(0, cy + sgn * R, 0)  # contact point
            p3 = occ.addPoint(-R, cy, 0)
            a1 = occ.addCircleArc(p1, p0, p2)
            a2 = occ.addCircleArc(p2, p0, p3)
            ln = occ.addLine(p3, p1)
            surf = occ.addPlaneSurface([occ.addCurveLoop([a1, a2, ln])])
            ext = occ.extrude([(2, surf)], 0, 0, thickness, numElements=[layers], recombine=False)
            out[name] = (surf, a1, a2, ln, ext)
            contact_points.append(p2)
        occ.synchronize()
        # grading toward the contact point
        f_dist = gmsh.model.mesh.field.add("Distance")
        gmsh.model.mesh.field.setNumbers(f_dist, "PointsList", contact_points)
        f_th = gmsh.model.mesh.field.add("Threshold")
        gmsh.model.mesh.field.setNumber(f_th, "InField", f_dist)
        gmsh.model.mesh.field.setNumber(f_th, "SizeMin", contact_size)
        gmsh.model.mesh.field.setNumber(f_th, "SizeMax", far_size)
        gmsh.model.mesh.field.setNumber(f_th, "DistMin", refine_half_width)
        gmsh.model.mesh.field.setNumber(
            f_th, "DistMax", refine_half_width + 4 * (far_size - contact_size) + R / 4
        )
        gmsh.model.mesh.field.setAsBackgroundMesh(f_th)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        for name, (surf, _a1, _a2, _ln, ext) in out.items():
            vol = next(t for d, t in ext if d == 3)
            gmsh.model.addPhysicalGroup(3, [vol], name=name)
            faces = {"front": [surf], "back": [ext[0][1]], "curved": [], "flat": []}
            for d, t in ext[2:]:
                if d != 2:
                    continue
                com = occ.getCenterOfMass(2, t)
                cy = R if name == "upper" else -R - INITIAL_GAP * R
                (faces["flat"] if abs(com[1] - cy) < 1e-9 * R else faces["curved"]).append(t)
            for face, tags in faces.items():
                gmsh.model.addPhysicalGroup(2, tags, name=f"{name}_{face}")
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(order)

    return _to_dolfinx(comm, build)


def hertz_line_contact(
    force_per_length_N_m: float,
    radius1_m: float,
    radius2_m: float,
    E1_Pa: float,
    nu1: float,
    E2_Pa: float,
    nu2: float,
) -> tuple[float, float]:
    """Hertz line contact of two parallel cylinders: (half-width a in m, peak pressure p0 in Pa).

    a = sqrt(4 P' R / (π E*)), p0 = 2 P' / (π a), 1/R = 1/R1 + 1/R2 (R2 = inf for a plane),
    1/E* = (1 − ν1²)/E1 + (1 − ν2²)/E2 (Johnson, Contact Mechanics, §4.2).
    """
    inv_R = 1.0 / radius1_m + (0.0 if math.isinf(radius2_m) else 1.0 / radius2_m)
    E_star = 1.0 / ((1 - nu1**2) / E1_Pa + (1 - nu2**2) / E2_Pa)
    a = math.sqrt(4.0 * force_per_length_N_m / (math.pi * E_star * inv_R))
    return a, 2.0 * force_per_length_N_m / (math.pi * a)


def peak_pressure_bound(contact_size_m: float, a_m: float) -> float:
    """Relative error of the peak pressure that the discretisation accounts for: (h/a)²/12.

    Near its apex the Hertz pressure is p0 (1 − x²/(2a²)). A quadratic displacement element has
    stresses, hence contact pressures, that vary linearly across it; the best such field in the
    L2 sense over an element of width h at the apex misses the parabola by p0 (h/a)²/12 at the
    element ends (the L2 error of a linear fit of t² on [0, 1] is t² − t + 1/6, 1/6 at the ends),
    and its nodal interpolant by p0 (h/a)²/16 at the middle. An FE peak pressure further from
    Hertz than that has an error the element's own stress space does not explain (such as a
    second approximation of the pressure on top of the solution). h: element size at the contact,
    a: Hertz half-width.
    """
    require_positive("contact_size_m", contact_size_m)
    require_positive("a_m", a_m)
    return (contact_size_m / a_m) ** 2 / 12.0


def hertz_pressure(x_m: np.ndarray, a_m: float, p0_Pa: float) -> np.ndarray:
    """Hertz's elliptical pressure p0 sqrt(1 − x²/a²) at distances ``x_m`` from the contact line
    (zero outside |x| < a), Pa. Its integral over x is the force per length π a p0 / 2."""
    s = 1.0 - (np.asarray(x_m, dtype=np.float64) / a_m) ** 2
    return p0_Pa * np.sqrt(np.maximum(s, 0.0))


# ------------------------------------------------------------------------------------------------
# ready-made problems (shared by tests, demos/hertz_contact.py, benchmarks/verification/)
# ------------------------------------------------------------------------------------------------


@dataclasses.dataclass
class ContactCase:
    """A built verification problem: the solver plus what is needed to read its results."""

    problem: object  # ContactProblem
    mesh_data: object  # dolfinx.io.gmsh.MeshData
    youngs_modulus_Pa: float
    poissons_ratio: float
    thickness_m: float = 1.0
    timings_s: dict[str, float] = dataclasses.field(
        default_factory=dict
    )  # "mesh", "setup": wall times, s

    @property
    def comm(self) -> MPI.Comm:
        return self.problem.comm

    def num_dofs(self) -> int:
        V = self.problem.V
        return V.dofmap.index_map.size_global * V.dofmap.index_map_bs


def _component_bc(V, md, name: str, comp: int, value: float):
    import dolfinx
    from dolfinx import fem

    facets = md.facet_tags.find(md.physical_groups[name].tag)
    dofs = fem.locate_dofs_topological(V.sub(comp), 2, facets)
    return fem.dirichletbc(dolfinx.default_scalar_type(value), dofs, V.sub(comp))


#: Contact solvers of the verification cases: the full volume system or the condensed surfaces.
SOLVERS = ("full", "condensed")


def _problem(solver: str, md, V, mu, lmbda, bcs, interfaces, motions, options, prefix: str):
    """The contact problem of a verification case with either solver (the bodies are the
    mesh volumes named by the surfaces' bodies)."""
    require_choice("solver", solver, SOLVERS)
    if solver == "full":
        return ContactProblem(
            V, mu, lmbda, bcs, interfaces, motions, options, petsc_options_prefix=prefix
        )
    bodies = {
        b: md.cell_tags.find(md.physical_groups[b].tag)
        for b in sorted({s.body for itf in interfaces for s in (itf.a, itf.b)})
    }
    return CondensedContactProblem(
        V,
        mu,
        lmbda,
        bcs,
        interfaces,
        motions,
        options,
        bodies=bodies,
        petsc_options_prefix=prefix + "condensed_",
    )


def _surface(V, md, name: str, body: str, mask):
    return ContactSurface(
        V, md.facet_tags.find(md.physical_groups[name].tag), body, mask, name=name
    )


def block_case(
    comm: MPI.Comm,
    options,
    compression_m: float = 1e-3,
    youngs_modulus_Pa: float = 1.0,
    poissons_ratio: float = 0.3,
    hexahedra: bool = False,
    upper_velocity_m_s: tuple[float, float, float] = (0.0, 0.0, 0.0),
    motion_angle_rad: float = 0.0,
    size_lower: float = 0.25,
    size_upper: float = 0.17,
    clamped: bool = False,
    solver: str = "full",
) -> ContactCase:
    """Two unit blocks pressed together by moving the top of the upper one down by
    ``compression_m``.

    Default supports: symmetry planes x = 0 and y = 0 (both bodies), bottom of the lower block on
    rollers: the exact solution is uniaxial compression, so the interface pressure is uniform
    (patch test). ``clamped``: instead, the lower block's bottom is fixed and the upper block's top
    is held in x and y while moved down, with free sides, so each body is supported only away from
    the interface (equilibrium checks). With an upper-body velocity the interface is in gross slip
    (friction test); ``motion_angle_rad`` rotates both bodies rigidly about the axis (1, 2, 3) (the
    contact state must not change).
    """
    from dolfinx import fem

    t0 = time.perf_counter()
    md = two_blocks(comm, size_lower, size_upper, hexahedra=hexahedra)
    t1 = time.perf_counter()
    V = fem.functionspace(md.mesh, ("Lagrange", md.mesh.geometry.cmaps[0].degree, (3,)))
    E, nu = youngs_modulus_Pa, poissons_ratio
    bcs = [
        _component_bc(V, md, "lower_zmin", 2, 0.0),
        _component_bc(V, md, "upper_zmax", 2, -compression_m),
    ]
    if clamped:
        bcs += [
            _component_bc(V, md, f"{face}", c, 0.0)
            for face in ("lower_zmin", "upper_zmax")
            for c in (0, 1)
        ]
    else:
        for b in ("lower", "upper"):
            bcs += [
                _component_bc(V, md, f"{b}_xmin", 0, 0.0),
                _component_bc(V, md, f"{b}_ymin", 1, 0.0),
            ]
    mask = fixed_mask(V, bcs)
    lower, upper = (
        _surface(V, md, "lower_zmax", "lower", mask),
        _surface(V, md, "upper_zmin", "upper", mask),
    )
    itf = ContactInterface(lower, upper, options, {"lower": E, "upper": E})
    motions = {
        "lower": RigidMotion(axis=(1.0, 2.0, 3.0), angle_rad=motion_angle_rad),
        "upper": RigidMotion(
            axis=(1.0, 2.0, 3.0),
            angle_rad=motion_angle_rad,
            velocity_m_s=tuple(
                RigidMotion(axis=(1.0, 2.0, 3.0), angle_rad=motion_angle_rad).R
                @ np.asarray(upper_velocity_m_s)
            ),
        ),
    }
    mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    prob = _problem(solver, md, V, mu, lmbda, bcs, [itf], motions, options, "gearfem_blocks_")
    return ContactCase(
        prob, md, E, nu, timings_s={"mesh": t1 - t0, "setup": time.perf_counter() - t1}
    )


def hertz_case(
    comm: MPI.Comm,
    options,
    contact_size: float = 0.01,
    compression_m: float = 0.004,
    radius: float = 1.0,
    youngs_modulus_Pa: float = 1.0,
    poissons_ratio: float = 0.3,
    layers: int = 1,
    thickness_m: float | None = None,
    far_size: float = 0.2,
    solver: str = "full",
) -> ContactCase:
    """Two equal half-cylinders (radius 1) pressed together in plane strain (u_z = 0 on both faces).

    The lower flat face is clamped, the upper flat face moves down by ``compression_m``. The
    default load gives a contact half-width a ≈ 0.031 R; ``contact_size`` is the element size
    near the contact (default a/3), ``thickness_m`` the slab thickness (default 2 contact sizes).
    """
    from dolfinx import fem

    t = thickness_m if thickness_m is not None else 2.0 * contact_size
    t0 = time.perf_counter()
    md = hertz_cylinders(
        comm,
        radius=radius,
        thickness=t,
        contact_size=contact_size,
        far_size=far_size,
        refine_half_width=0.12 * radius,
        layers=layers,
    )
    t1 = time.perf_counter()
    V = fem.functionspace(md.mesh, ("Lagrange", 2, (3,)))
    E, nu = youngs_modulus_Pa, poissons_ratio
    bcs = []
    for b in ("upper", "lower"):
        bcs += [
            _component_bc(V, md, f"{b}_front", 2, 0.0),
            _component_bc(V, md, f"{b}_back", 2, 0.0),
        ]
    bcs += [_component_bc(V, md, "lower_flat", c, 0.0) for c in range(2)]
    bcs += [
        _component_bc(V, md, "upper_flat", 0, 0.0),
        _component_bc(V, md, "upper_flat", 1, -compression_m),
    ]
    mask = fixed_mask(V, bcs)
    lower, upper = (
        _surface(V, md, "lower_curved", "lower", mask),
        _surface(V, md, "upper_curved", "upper", mask),
    )
    itf = ContactInterface(lower, upper, options, {"lower": E, "upper": E})
    mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    motions = {"lower": RigidMotion(), "upper": RigidMotion()}
    prob = _problem(solver, md, V, mu, lmbda, bcs, [itf], motions, options, "gearfem_hertz_")
    return ContactCase(
        prob,
        md,
        E,
        nu,
        thickness_m=t,
        timings_s={"mesh": t1 - t0, "setup": time.perf_counter() - t1},
    )


@dataclasses.dataclass(frozen=True)
class HertzComparison:
    """FE line-contact result against Hertz for the force the FE model carries.

    Positions across the contact are those of the slave points in the reference (undeformed)
    configuration, where Hertz's small-strain theory measures the contact: in the current
    configuration the surfaces have also moved tangentially, by u_x = −(1 − 2ν)(1 + ν) P'/(2E) at
    the contact edges (Johnson eq. 2.25b; 0.7 % of a for ν = 0.3 and the default load), which would
    bias a half-width read from current positions by that much.
    """

    force_per_length_N_m: float
    a_analytic_m: float
    p0_analytic_Pa: float
    a_fe_m: (
        float  # from the pressure moments: a = 2 sqrt(∫x²p dA / ∫p dA) (exact for Hertz's ellipse)
    )
    p0_fe_Pa: float  # largest pressure at a contact point
    a_fit_m: (
        float  # from an elliptical fit p² = p0² (1 − x²/a²) of the pressures above 20 % of the peak
    )
    x_m: np.ndarray  # (every rank: all points) reference position across the contact
    p_Pa: np.ndarray  # pressure at those points
    a_current_m: float = float(
        "nan"
    )  # pressure moments over the current positions (for comparison)

    @property
    def a_error(self) -> float:
        return self.a_fe_m / self.a_analytic_m - 1.0

    @property
    def p0_error(self) -> float:
        return self.p0_fe_Pa / self.p0_analytic_Pa - 1.0


def compare_hertz(case: ContactCase, radius: float = 1.0) -> HertzComparison:
    """Read the pressure distribution of a solved :func:`hertz_case` and compare with Hertz
    (collective)."""
    prob, comm = case.problem, case.comm
    fn, _ = prob.contact_force()
    P = abs(fn[1]) / case.thickness_m
    a, p0 = hertz_line_contact(
        P,
        radius,
        radius,
        case.youngs_modulus_Pa,
        case.poissons_ratio,
        case.youngs_modulus_Pa,
        case.poissons_ratio,
    )
    x, xc, pr, dA = [np.zeros(0)], [np.zeros(0)], [np.zeros(0)], [np.zeros(0)]
    for ps, p in zip(prob.interfaces[0].passes, prob.last_points[0]):
        X = np.einsum("pk,pkd->pd", p.Ns, ps.slave.local.X[p.facet])  # body frame, undeformed
        x.append(prob.motions[ps.slave.body].place(X)[:, 0])
        xc.append(p.x[:, 0])
        pr.append(p.pressure)
        dA.append(p.dA)
    x, xc, pr, dA = (np.concatenate(v) for v in (x, xc, pr, dA))
    m0 = comm.allreduce(float(np.sum(dA * pr)), op=MPI.SUM)
    m2 = comm.allreduce(float(np.sum(dA * pr * x**2)), op=MPI.SUM)
    m2c = comm.allreduce(float(np.sum(dA * pr * xc**2)), op=MPI.SUM)
    a_mom = 2.0 * float(np.sqrt(m2 / m0)) if m0 > 0 else float("nan")
    a_cur = 2.0 * float(np.sqrt(m2c / m0)) if m0 > 0 else float("nan")
    x_all = np.concatenate(comm.allgather(x))
    p_all = np.concatenate(comm.allgather(pr))
    order = np.lexsort((p_all, x_all))  # deterministic order, independent of the partition
    x_all, p_all = x_all[order], p_all[order]
    p0_fe = float(p_all.max(initial=0.0))
    sel = p_all > 0.2 * p0_fe
    # p^2 = p0^2 - (p0^2/a^2) x^2: linear least squares in x^2
    A = np.column_stack([np.ones(sel.sum()), x_all[sel] ** 2])
    c0, c1 = np.linalg.lstsq(A, p_all[sel] ** 2, rcond=None)[0]
    a_fe = float(np.sqrt(-c0 / c1)) if c1 < 0 < c0 else float("nan")
    return HertzComparison(P, a, p0, a_mom, p0_fe, a_fe, x_all, p_all, a_cur)
