"""A contact interface between two surfaces: search, segmentation, gaps, tractions, linearisation.

Formulation (Gauss-point-to-surface with segmentation, two-pass):

* Each pass takes one surface as slave and the other as master. Each owned slave facet is split
  into the pieces covered by nearby master facets (:func:`~gearfem.contact.kinematics.segment`),
  and a triangle rule is placed on every piece. At each slave point the gap
  g = (x_s − x_m(ζ))·n_m is taken from the closest-point projection ζ onto the curved master facet
  in the current configuration (body displacement plus rigid motion).
* Pressure p = ⟨λ − εg⟩ (λ = 0: penalty). λ lives at the standard Gauss points of each slave facet
  (as many as the facet element has nodes: 6 on a P2 triangle) and is carried to the segment
  points by a field over the facet (:meth:`ContactInterface.multipliers_at`), so the multipliers
  survive re-segmentation when surfaces slide: on a facet inside the contact zone (all its
  multipliers positive) the facet-element interpolant (quadratic on P2, exact for quadratic
  pressures), on a facet cut by the contact boundary the linear least-squares fit (which does not
  overshoot the multipliers that the Uzawa update clipped to zero).
* Traction on the slave t = p (n_m − μ ŝ); the master receives −t at the projected point.
* Virtual work: ∫ t·(δu_s − δu_m) dA with δg = (δu_s − δu_m)·n (normal and projection point frozen
  in the linearisation: the tangent is ε ∫ [ρ][γ]ᵀ dA with ρ = N⊗(n − μŝ), γ = N⊗n on the slave and
  their negatives with N(ζ) on the master, rotated into each body frame. It omits the variation
  of n and ζ (curvature terms): Newton converges superlinearly rather than quadratically on curved
  surfaces; the residual is exact.)

With segmentation, both the slave and the master integrals of a uniform pressure over flat facets
are exact, so the contact patch test is passed to solver tolerance with non-matching meshes.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from gearfem.contact.kinematics import _affine_coords, evaluate, project, segment, unit_normal
from gearfem.contact.options import ContactOptions
from gearfem.contact.rigid import RigidMotion
from gearfem.contact.surface import ContactSurface
from gearfem.contact.tangent import PointGeometry, geometric_factors, torque_border
from gearfem.core.errors import GearfemError


@dataclasses.dataclass
class ContactPoints:
    """Per-point state of one pass on this rank (all arrays of length n unless noted)."""

    slave: str
    master: str
    facet: np.ndarray  # local slave facet
    mfacet: np.ndarray  # gathered master facet
    xi: np.ndarray  # (n, 2) slave reference coordinates
    zeta: np.ndarray  # (n, 2) master reference coordinates
    dA: np.ndarray  # integration weight incl. the pass weight, m^2
    x: np.ndarray  # (n, 3) current slave point
    normal: np.ndarray  # (n, 3) master outward normal
    gap: np.ndarray  # m (negative: penetration)
    pressure: np.ndarray  # Pa
    active: np.ndarray  # bool
    slip_direction: np.ndarray  # (n, 3) ŝ (regularised unit slip direction)
    mu: np.ndarray  # friction coefficient at each point (its slave facet's)
    slip_velocity: (
        np.ndarray
    )  # (n, 3) v_T, kinematic tangential relative velocity (slave - master), m/s
    traction: np.ndarray  # (n, 3) traction on the slave, Pa
    eps: np.ndarray  # penalty, Pa/m
    slope: np.ndarray  # dp/d(λ − εg): 1 where active (0..1 with pressure smoothing)
    Ns: np.ndarray  # (n, nn)
    Nm: np.ndarray  # (n, nn)
    # for the geometric tangent (gearfem.contact.tangent)
    frozen_slip: np.ndarray | None = None  # (n, 3) the frozen s₀ ŝ is made from (None: not frozen)
    nodes: np.ndarray | None = None  # (n, 2 nn, 3) placed slave, then master facet nodes
    # the active points' (indices, U, V, e_β) once assembled (rotation_terms reuses them)
    geometric: tuple | None = None

    @property
    def num_points(self) -> int:
        return len(self.dA)

    @property
    def slip_speed(self) -> np.ndarray:
        return np.linalg.norm(self.slip_velocity, axis=1)

    def dissipation_speed(self) -> np.ndarray:
        """ŝ·v_T (m/s): the slip speed along the friction direction, the friction power per unit
        area is μ p times it."""
        return np.einsum("pd,pd->p", self.slip_direction, self.slip_velocity)

    def friction_power_density(self, mu: np.ndarray | float | None = None) -> np.ndarray:
        """Power dissipated by friction per unit area, −t_T·v_T = μ p ŝ·v_T (W/m²), with each
        point's μ (``mu``: another μ, 1.0 for the power per unit μ)."""
        return (self.mu if mu is None else mu) * self.pressure * self.dissipation_speed()

    @property
    def direction(self) -> np.ndarray:
        """d = n − μ ŝ (n, 3): the traction on the slave is p d."""
        return self.normal - self.mu[:, None] * self.slip_direction


@dataclasses.dataclass
class _Pass:
    slave: ContactSurface
    master: ContactSurface
    weight: float
    eps: np.ndarray  # per local slave facet
    lam: np.ndarray  # (nf, n_fixed) multipliers at the fixed points
    mu: np.ndarray | None = None  # per local slave facet (None: the options' friction coefficient)


@dataclasses.dataclass(frozen=True)
class MasterCandidates:
    """Master facets overlapping each local slave facet in the segmentation (CSR layout: the
    masters of slave facet f are ``facets[ptr[f]:ptr[f + 1]]``)."""

    ptr: np.ndarray
    facets: np.ndarray

    def of(self, slave_facets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(row, master facet) for every candidate of every entry of ``slave_facets``."""
        cnt = self.ptr[slave_facets + 1] - self.ptr[slave_facets]
        rows = np.repeat(np.arange(len(slave_facets)), cnt)
        if not len(slave_facets):
            return rows, np.zeros(0, np.int64)
        start = np.repeat(self.ptr[slave_facets], cnt)
        first = np.repeat(np.cumsum(cnt) - cnt, cnt)
        return rows, self.facets[start + np.arange(len(rows)) - first]


@dataclasses.dataclass
class Segmentation:
    """The integration points of one pass, fixed between re-segmentations (one Newton solve).

    ``slip_direction`` is the frozen friction slip direction ŝ at the points (set by
    :meth:`ContactInterface.update_slip`; ``None`` until then).
    """

    slave_facet: np.ndarray  # local slave facet of each point
    master_facet: np.ndarray  # gathered master facet it was segmented against
    xi: np.ndarray  # (n, 2) slave reference coordinates
    weight_ref: np.ndarray  # reference-facet quadrature weight
    candidates: MasterCandidates
    slip_direction: np.ndarray | None = None
    # the closest-point foot of each point on its segmented master facet at the last evaluation:
    # the next projection starts there (within a solve the surfaces move little)
    foot_guess: np.ndarray | None = None
    # |T1 × T2| of the slave map in the reference configuration at the points (small strain)
    area_scale: np.ndarray | None = None
    # a point whose foot had left its segmented master facet at the last evaluation: the facet
    # it took instead (-1: none) and its foot there (see ContactInterface._master_feet)
    moved_facet: np.ndarray | None = None
    moved_foot: np.ndarray | None = None


@dataclasses.dataclass(frozen=True)
class _Placement:
    """The current configuration of one pass: nodal data and placed node coordinates of the slave
    (local facets) and master (gathered facets) surfaces, and the bodies' rigid motions."""

    slave_data: object
    xs: np.ndarray
    master_data: object
    xm: np.ndarray
    slave_motion: RigidMotion
    master_motion: RigidMotion


def _closest_master_points(
    ref_m, xm: np.ndarray, fm: np.ndarray, x: np.ndarray, zeta0: np.ndarray | None = None
):
    """Closest-point projection of the points ``x`` onto the master facets ``fm`` (Newton on the
    curved facet from ``zeta0``, by default an affine first guess on the facet's vertex
    triangle): (ζ, distance)."""
    if zeta0 is None:
        nv = ref_m.num_vertices
        v = xm[fm, :nv]
        zeta0 = _affine_coords(v[:, 0], v[:, 1] - v[:, 0], v[:, 2] - v[:, 0], x[:, None, :])[
            :, 0, :
        ]
    return project(ref_m, xm[fm], x, zeta0)


def _nearest_candidates(ref_m, xm, x, seg, bad, fm, zeta, valid, tol: float) -> None:
    """For the points ``bad`` (feet off their segmented facets ``fm``): the candidate facet
    nearest to each, among those whose foot lies on them within ``tol``
    (see :meth:`ContactInterface._master_feet`); writes ``fm``, ``zeta`` and ``valid`` in
    place."""
    rows, mcand = seg.candidates.of(seg.slave_facet[bad])
    rows = bad[rows]
    keep = mcand != fm[rows]
    rows, mcand = rows[keep], mcand[keep]
    z, _ = _closest_master_points(ref_m, xm, mcand, x[rows]) if len(rows) else (None, None)
    # every candidate foot within the tolerance, the segmented facet's among them
    rows = np.concatenate([bad, rows])
    mcand = np.concatenate([fm[bad], mcand])
    z = zeta[bad] if z is None else np.concatenate([zeta[bad], z])
    ok = ref_m.inside(z, tol=tol)
    rows, mcand, z = rows[ok], mcand[ok], z[ok]
    if len(rows):
        xc, _, _, _ = evaluate(ref_m, xm[mcand], ref_m.clamp(z))
        dist = np.linalg.norm(x[rows] - xc, axis=1)
        order = np.lexsort((dist, rows))
        pick = order[np.unique(rows[order], return_index=True)[1]]
        fm[rows[pick]] = mcand[pick]
        zeta[rows[pick]] = z[pick]
        valid[rows[pick]] = True


class ContactInterface:
    """Two surfaces that may touch, with their penalty parameters and multipliers.

    Args:
        a, b: The two surfaces (different bodies).
        options: Contact options.
        youngs_modulus_Pa: dict body name -> Young's modulus, used to scale the penalty.
    """

    def __init__(
        self,
        a: ContactSurface,
        b: ContactSurface,
        options: ContactOptions,
        youngs_modulus_Pa: dict[str, float],
    ) -> None:
        self.a, self.b, self.options = a, b, options
        shared = np.intersect1d(a.gathered().blocks, b.gathered().blocks)
        if len(shared):
            raise GearfemError(
                f"contact surfaces {a.name!r} and {b.name!r} share {len(shared)} mesh node(s): "
                f"the bodies are "
                "joined in the mesh (coincident vertices fused by the mesher); mesh them as "
                "separate volumes"
            )
        roles = [(a, b), (b, a)] if options.two_pass else [(a, b)]
        w = 0.5 if options.two_pass else 1.0
        # multiplier points: a rule with at least as many points as the facet element has nodes
        # (degree 2·p: 6 points on P2 triangles, 9 on Q2 quadrilaterals), so that the
        # facet-element field through them is determined
        self.fixed_points, self.fixed_weights = a.ref.quadrature(
            max(2 * a.ref.degree, options.quadrature_degree)
        )
        self._linear_fit = a.ref.linear_fit(self.fixed_points)  # (3, n_fixed)
        self._nodal_fit = a.ref.nodal_fit(self.fixed_points)  # (n_nodes, n_fixed)
        self.passes: list[_Pass] = []
        for s, m in roles:
            if options.penalty_Pa_m is not None:
                eps = np.full(s.local.num_facets, options.penalty_Pa_m)
            else:
                eps = options.penalty_factor * youngs_modulus_Pa[s.body] / s.local.size
            lam = np.zeros((s.local.num_facets, len(self.fixed_points)))
            self.passes.append(_Pass(s, m, w, eps, lam))
        self._tri_points, self._tri_weights = _triangle_rule(options.quadrature_degree)
        self._segments: list[Segmentation] | None = None

    # -------------------------------------------------------------------------------------------
    def set_friction(self, facet_mu: list[np.ndarray] | None) -> None:
        """The friction coefficient of the next solves: per pass, mu on each local slave facet
        (a cycle solved with a friction law's mu,
        :class:`gearfem.cycle.friction_field.FrictionField`), or None:
        ``options.friction_coefficient`` everywhere."""
        if facet_mu is None:
            for ps in self.passes:
                ps.mu = None
            return
        if len(facet_mu) != len(self.passes):
            raise GearfemError(
                f"set_friction: {len(facet_mu)} arrays of mu for {len(self.passes)} passes"
            )
        out = []
        for ps, mu in zip(self.passes, facet_mu):
            mu = np.asarray(mu, dtype=float)
            if mu.shape != (ps.slave.local.num_facets,):
                raise GearfemError(
                    f"set_friction: mu of shape {mu.shape} for the {ps.slave.local.num_facets} "
                    f"local facets of {ps.slave.name!r}"
                )
            if not np.all(np.isfinite(mu)) or np.any(mu < 0.0):
                raise GearfemError(f"set_friction: mu on {ps.slave.name!r} not finite and >= 0")
            out.append(mu)
        for ps, mu in zip(self.passes, out):
            ps.mu = mu

    def facet_centroids(self) -> list[np.ndarray]:
        """Per pass, the reference centroid (body frame as built) of each local slave facet
        (nf, 3): where :meth:`set_friction`'s mu of a facet is looked up."""
        return [ps.slave.local.X.mean(axis=1) for ps in self.passes]

    # -------------------------------------------------------------------------------------------
    def reset_multipliers(self) -> None:
        for ps in self.passes:
            ps.lam[:] = 0.0

    def penetration_tolerance(self) -> float:
        """Allowed penetration (m) for the augmented Lagrangian stop (global, same on all ranks)."""
        if self.options.penetration_tolerance_m is not None:
            return self.options.penetration_tolerance_m
        hmin = min(
            self.a.comm.allreduce(float(ps.slave.local.size.min(initial=np.inf)), op=_mpi_min())
            for ps in self.passes
        )
        return self.options.penetration_tolerance_rel * hmin

    # -------------------------------------------------------------------------------------------
    def _nodes(
        self, surf: ContactSurface, u_array: np.ndarray, motion: RigidMotion, gathered: bool
    ):
        if gathered:
            data = surf.gathered()
            u = surf.gathered_displacement(u_array)
        else:
            data = surf.local
            u = surf.local_displacement(u_array)
        return data, motion.place(data.X + u)

    def _candidate_pairs(
        self, ps: _Pass, xs: np.ndarray, xm: np.ndarray, mdata
    ) -> tuple[np.ndarray, np.ndarray]:
        """Slave/master facet pairs that are close and face each other.

        A pair is kept when (i) the facets' bounding boxes and their bounding spheres, grown by the
        search margin (the slave facet size times ``search_distance_rel``), overlap (the boxes
        first: a layered face width makes the flank facets long and thin, and spheres alone pair
        every facet with most of its tooth), (ii) their normals are opposed
        within ``max_normal_angle_deg`` and (iii) the slave facet reaches into the slab of
        ± margin around the master facet's plane.
        """
        nv = ps.slave.ref.num_vertices
        if xs.shape[0] == 0 or xm.shape[0] == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        cs, cm = xs[:, :nv].mean(axis=1), xm[:, :nv].mean(axis=1)
        rs = np.linalg.norm(xs[:, :nv] - cs[:, None], axis=2).max(axis=1)
        rm = np.linalg.norm(xm[:, :nv] - cm[:, None], axis=2).max(axis=1)
        margin = self.options.search_distance_rel * ps.slave.local.size
        si, mj = _box_pairs(xs, xm, margin)
        if len(si) == 0:
            return si, mj
        keep = np.linalg.norm(cs[si] - cm[mj], axis=1) < rs[si] + rm[mj] + margin[si]
        si, mj = si[keep], mj[keep]
        ns = _facet_normal(ps.slave.ref, xs, ps.slave.local.orientation)
        nm = _facet_normal(ps.master.ref, xm, mdata.orientation)
        cos_max = math.cos(math.radians(self.options.max_normal_angle_deg))
        keep = np.einsum("pd,pd->p", ns[si], nm[mj]) < -cos_max
        si, mj = si[keep], mj[keep]
        # signed distances of the slave vertices from the master facet plane
        d = np.einsum("pkd,pd->pk", xs[si, :nv] - cm[mj][:, None, :], nm[mj])
        keep = (d.min(axis=1) < margin[si]) & (d.max(axis=1) > -margin[si])
        return si[keep], mj[keep]

    def update_segmentation(self, u_array: np.ndarray, motions: dict[str, RigidMotion]) -> None:
        """Find candidate pairs and integration points for the current configuration (collective).

        The segmentation is kept until the next call: within one Newton solve only gaps, normals and
        projections follow the iterates, so the residual is a piecewise-smooth function of u (a
        re-segmentation re-lays the quadrature points and would make it jump at the level of the
        quadrature error). Callers re-segment at the start of every solve (load step, position).
        """
        self._segments = []
        for ps in self.passes:
            ms, mm = motions[ps.slave.body], motions[ps.master.body]
            _, xs = self._nodes(ps.slave, u_array, ms, gathered=False)
            mdata, xm = self._nodes(ps.master, u_array, mm, gathered=True)
            si, mj, xi, wref = self._overlaps(ps, xs, xm, mdata)
            # master facets overlapping each slave facet (for re-projection across facet edges)
            used = _unique_pairs(si, mj)
            ptr = np.searchsorted(used[:, 0], np.arange(xs.shape[0] + 1))
            cand = MasterCandidates(ptr, used[:, 1])
            self._segments.append(Segmentation(si, mj, xi, wref, cand))
        self.update_slip(u_array, motions)

    def _overlaps(self, ps: _Pass, xs: np.ndarray, xm: np.ndarray, mdata):
        """The segment points of one pass in the configuration (xs, xm): slave facet, master facet,
        slave reference coordinates and reference weight of every point."""
        si, mj = self._candidate_pairs(ps, xs, xm, mdata)
        nv = ps.slave.ref.num_vertices
        pair, xi, wref = segment(
            ps.slave.ref, xs[si, :nv], xm[mj, :nv], self._tri_points, self._tri_weights
        )
        return si[pair], mj[pair], xi, wref

    def segmentation_blocks(self) -> np.ndarray:
        """Global node (block) numbers of every facet the current segmentation can involve until
        the next :meth:`update_segmentation`: this rank's slave facets that carry integration points
        and every master facet they may be projected on (sorted; local to this rank's points)."""
        out = [np.zeros(0, np.int64)]
        for ps, seg in zip(self.passes, self._segments or []):
            out.append(ps.slave.local.blocks[np.unique(seg.slave_facet)].ravel())
            out.append(ps.master.gathered().blocks[np.unique(seg.candidates.facets)].ravel())
        return np.unique(np.concatenate(out))

    def update_slip(self, u_array: np.ndarray, motions: dict[str, RigidMotion]) -> float:
        """Freeze the friction slip directions ŝ at the current configuration (collective).

        ŝ = v_T / sqrt(|v_T|² + v_ε²) from the bodies' kinematic velocities at the slave points.
        Near rolling (small |v_T|) it depends on the deformed position, which the Newton tangent
        does not follow; it is therefore held fixed within a Newton solve and updated between
        solves like the multipliers (:meth:`ContactProblem.solve`) until it settles. Returns the
        largest change of ŝ at points in contact (global).
        """
        worst = 0.0
        for ps, seg in zip(self.passes, self._segments):
            old = seg.slip_direction
            pts = self._points(ps, self._placement(ps, u_array, motions), seg, frozen=False)
            if old is not None and len(old) == pts.num_points:
                on = pts.pressure > 0.0
                if on.any():
                    worst = max(worst, float(np.abs(pts.slip_direction[on] - old[on]).max()))
            seg.slip_direction = pts.slip_direction
        return self.a.comm.allreduce(worst, op=_mpi_max())

    def _placement(
        self, ps: _Pass, u_array: np.ndarray, motions: dict[str, RigidMotion]
    ) -> _Placement:
        ms, mm = motions[ps.slave.body], motions[ps.master.body]
        sdata, xs = self._nodes(ps.slave, u_array, ms, gathered=False)
        mdata, xm = self._nodes(ps.master, u_array, mm, gathered=True)
        return _Placement(sdata, xs, mdata, xm, ms, mm)

    def evaluate(self, u_array: np.ndarray, motions: dict[str, RigidMotion]) -> list[ContactPoints]:
        """Contact state at all slave points of all passes for displacement ``u_array``
        (collective).

        Uses the segmentation of the last :meth:`update_segmentation` (made now if there is none).
        """
        if self._segments is None:
            self.update_segmentation(u_array, motions)
        return [
            self._points(ps, self._placement(ps, u_array, motions), seg, frozen=True)
            for ps, seg in zip(self.passes, self._segments)
        ]

    def _points(
        self, ps: _Pass, place: _Placement, seg: Segmentation, frozen: bool
    ) -> ContactPoints:
        """Contact state at the points of ``seg`` in the configuration ``place``. ``frozen``: use
        the segmentation's frozen slip direction (within a Newton solve) if it has one."""
        ref_s, ref_m = ps.slave.ref, ps.master.ref
        fs, xi = seg.slave_facet, seg.xi
        x, _, _, Ns = evaluate(ref_s, place.xs[fs], xi)
        if seg.area_scale is None:  # reference area (small strain): fixed with the points
            _, T1, T2, _ = evaluate(ref_s, place.slave_data.X[fs], xi)
            seg.area_scale = np.linalg.norm(np.cross(T1, T2), axis=1)
        jac = seg.area_scale
        fm, zeta, valid = self._master_feet(ref_m, place.xm, x, seg)
        xmp, t1, t2, Nm = evaluate(ref_m, place.xm[fm], zeta)
        normal, _ = unit_normal(t1, t2, place.master_data.orientation[fm])
        gap = np.einsum("pd,pd->p", x - xmp, normal)
        gap = np.where(valid, gap, np.inf)
        eps = ps.eps[fs]
        lam = self.multipliers_at(ps.lam, fs, xi, Ns)
        trial = np.where(valid, lam - eps * np.where(valid, gap, 0.0), -np.inf)
        pressure, slope, active = self._pressure(trial, valid)
        vrel = place.slave_motion.velocity(x) - place.master_motion.velocity(x)
        vt = vrel - np.einsum("pd,pd->p", vrel, normal)[:, None] * normal
        frozen_slip = seg.slip_direction if frozen else None
        s_hat = self._slip_direction(vt, normal, frozen_slip)
        mu = np.full(len(fs), self.options.friction_coefficient) if ps.mu is None else ps.mu[fs]
        traction = pressure[:, None] * (normal - mu[:, None] * s_hat)
        return ContactPoints(
            slave=ps.slave.name,
            master=ps.master.name,
            facet=fs,
            mfacet=fm,
            xi=xi,
            zeta=zeta,
            dA=ps.weight * seg.weight_ref * jac,
            x=x,
            normal=normal,
            gap=gap,
            pressure=pressure,
            active=active,
            slip_direction=s_hat,
            mu=mu,
            slip_velocity=vt,
            traction=traction,
            eps=eps,
            slope=slope,
            Ns=Ns,
            Nm=Nm,
            frozen_slip=frozen_slip,
            nodes=np.concatenate([place.xs[fs], place.xm[fm]], axis=1),
        )

    def multipliers_at(
        self, lam: np.ndarray, facet: np.ndarray, xi: np.ndarray, N: np.ndarray
    ) -> np.ndarray:
        """The multiplier field at points ``xi`` of the slave facets ``facet`` (N: the facet
        element's shape functions there), from the values ``lam`` (nf, n_fixed) at the fixed points.

        Inside the contact zone (every multiplier of the facet positive) the field is the
        facet-element interpolant of the fixed-point values: on P2 facets the quadratic through the
        6 points, exact for quadratic pressure fields (the Hertz pressure near its apex). A linear
        least-squares fit there would overshoot a concave peak at the facet vertices by about
        (h/a)²/12 of p0 (the L2 error of a linear fit of a parabola at the ends of the interval) and
        carry that error to the peak pressure. On facets cut by the contact boundary (some
        multipliers clipped to zero by the Uzawa update) the pressure has its square-root edge,
        which a polynomial through the clipped values would overshoot (by up to 1.9 times a single
        positive value, the peak of a quadratic Lagrange function): there the linear least-squares
        fit is used.
        """
        if not len(facet):
            return np.zeros(0)
        lin = np.einsum("kq,fq->fk", self._linear_fit, lam)[facet]
        linear = lin[:, 0] + lin[:, 1] * xi[:, 0] + lin[:, 2] * xi[:, 1]
        nodal = np.einsum("pk,pk->p", N, (lam @ self._nodal_fit.T)[facet])
        inside = (lam > 0.0).all(axis=1)[facet]
        return np.where(inside, nodal, linear)

    def _master_feet(self, ref_m, xm: np.ndarray, x: np.ndarray, seg: Segmentation):
        """Master facet, reference coordinates and validity of the closest-point foot of each
        slave point.

        A point whose foot left the master facet it was segmented against (even within
        ``projection_tolerance``) is projected onto the other master facets overlapping the same
        slave facet, and takes the facet nearest to it: the one whose foot, clamped to the
        reference facet, is closest in space, among the facets whose foot lies on them within the
        tolerance. The gap stays the (continuous) distance to the master surface, the segmentation
        only partitions the slave facet for integration, and a point crossing the edge between two
        master facets changes facet where both feet are on that edge, so that its force moves
        continuously from one facet's nodes to the other's. (Keeping a foot up to the tolerance
        outside its facet instead, as long as it is within it, makes the switch happen at the
        tolerance: the force jumps between the extrapolated and the true shape functions, and
        Newton can cycle at a residual of that jump.) Points with no foot on any candidate facet
        within the tolerance (beyond the master surface) carry no contact; without this test
        facets that overlap in the slave plane but are not closest-point neighbours would
        extrapolate the master polynomial and invent penetrations.

        A point that had taken another facet at the last evaluation is first projected onto that
        facet again (from its foot there): a foot strictly inside it is the closest point of the
        surface near the point, which is the facet the search over all candidates would pick; the
        search runs for the others.
        """
        fm = seg.master_facet
        zeta, _ = _closest_master_points(ref_m, xm, fm, x, seg.foot_guess)
        seg.foot_guess = zeta
        valid = ref_m.inside(zeta)  # on its segmented facet; the others get a facet below
        if valid.all():
            seg.moved_facet = None
            return fm, zeta, valid
        bad = np.nonzero(~valid)[0]
        fm, zeta = fm.copy(), zeta.copy()
        if seg.moved_facet is not None:
            again = bad[seg.moved_facet[bad] >= 0]
            z, _ = _closest_master_points(
                ref_m, xm, seg.moved_facet[again], x[again], seg.moved_foot[again]
            )
            on = ref_m.inside(z)
            back = again[on]
            fm[back], zeta[back], valid[back] = seg.moved_facet[back], z[on], True
            bad = np.nonzero(~valid)[0]
        _nearest_candidates(
            ref_m, xm, x, seg, bad, fm, zeta, valid, self.options.projection_tolerance
        )
        moved = valid & (fm != seg.master_facet)
        seg.moved_facet = np.where(moved, fm, -1)
        seg.moved_foot = zeta
        return fm, zeta, valid

    def _pressure(self, trial: np.ndarray, valid: np.ndarray):
        """Pressure p = ⟨trial⟩, its slope dp/d(trial) and the active set; with the C1 ramp
        p = (t + sqrt(t² + δ²)) / 2 when ``pressure_smoothing_Pa`` δ > 0 (see
        :class:`ContactOptions`)."""
        delta = self.options.pressure_smoothing_Pa
        if delta > 0.0:
            tt = np.where(valid, trial, 0.0)
            root = np.sqrt(tt * tt + delta * delta)
            pressure = np.where(valid, 0.5 * (tt + root), 0.0)
            slope = np.where(valid, 0.5 * (1.0 + tt / root), 0.0)
            active = slope > 1e-6
            return pressure, np.where(active, slope, 0.0), active
        active = trial > 0.0
        return np.where(active, trial, 0.0), active.astype(np.float64), active

    def _slip_direction(
        self, vt: np.ndarray, normal: np.ndarray, frozen: np.ndarray | None
    ) -> np.ndarray:
        """Regularised slip direction ŝ = v_T / sqrt(|v_T|² + v_ε²), or the ``frozen`` one kept in
        the current tangent plane with its magnitude."""
        if frozen is None:
            vt2 = np.einsum("pd,pd->p", vt, vt)
            if not len(vt):
                return np.zeros((0, 3))
            return vt / np.sqrt(vt2 + self.options.slip_regularization_m_s**2)[:, None]
        mag = np.linalg.norm(frozen, axis=1)
        st = frozen - np.einsum("pd,pd->p", frozen, normal)[:, None] * normal
        nst = np.linalg.norm(st, axis=1)
        return st * np.where(nst > 0.0, mag / np.where(nst > 0.0, nst, 1.0), 0.0)[:, None]

    # -------------------------------------------------------------------------------------------
    def assemble(self, points: list[ContactPoints], motions: dict[str, RigidMotion], matrix: bool):
        """Residual entries (dofs, values) and, if ``matrix``, tangent COO (rows, cols, values).

        Residual convention: R = K u − f + R_c, with R_c = −∫ t·(N_s, −N_m) dA in body frames.
        Dofs are global; Dirichlet-fixed dofs are left out.
        """
        rdofs, rvals, rows, cols, vals = [], [], [], [], []
        for ps, pts in zip(self.passes, points):
            if pts.num_points == 0:
                continue
            sdata, mdata = ps.slave.local, ps.master.gathered()
            Rs, Rm = motions[ps.slave.body].R, motions[ps.master.body].R
            # only the points that carry pressure (the residual) or are active (the tangent:
            # the pressure's slope, and with it every entry, vanishes elsewhere)
            pos = pts.pressure > 0.0
            keep = np.flatnonzero(pos | pts.active if matrix else pos)
            if len(keep) == 0:
                continue
            dirn = pts.direction[keep]
            rho_s, rho_m = dirn @ Rs, -(dirn @ Rm)  # R^T v for row vectors
            Ns, Nm = pts.Ns[keep], pts.Nm[keep]
            facet, mfacet = pts.facet[keep], pts.mfacet[keep]
            dofs_s = 3 * sdata.blocks[facet][:, :, None] + np.arange(3)  # (n, nn, 3)
            dofs_m = 3 * mdata.blocks[mfacet][:, :, None] + np.arange(3)
            free = np.stack([~sdata.fixed[facet], ~mdata.fixed[mfacet]], axis=1)
            # rho vectors per point: (n, 2, nn, 3)
            rho = np.stack(
                [Ns[:, :, None] * rho_s[:, None, :], Nm[:, :, None] * rho_m[:, None, :]], axis=1
            )
            dofs = np.stack([dofs_s, dofs_m], axis=1).reshape(len(keep), -1)
            rho = np.where(free, rho, 0.0).reshape(len(keep), -1)
            sel = pos[keep]
            r = -(pts.dA[keep][sel] * pts.pressure[keep][sel])[:, None] * rho[sel]
            rdofs.append(dofs[sel].ravel())
            rvals.append(r.ravel())
            if matrix:
                act = np.nonzero(pts.active[keep])[0]
                if len(act) == 0:
                    continue
                g_n = pts.normal[keep[act]]
                gam = np.stack(
                    [Ns[act][:, :, None] * (g_n @ Rs)[:, None, :],
                     -Nm[act][:, :, None] * (g_n @ Rm)[:, None, :]],
                    axis=1,
                )  # fmt: skip
                gam = np.where(free[act], gam, 0.0).reshape(len(act), -1)
                k = len(act)
                m = dofs.shape[1]
                local_ids, inv = np.unique(dofs[act].ravel(), return_inverse=True)
                inv = inv.reshape(k, m)
                ptr = np.repeat(np.arange(k), m)
                B = sp.csr_matrix((rho[act].ravel(), (ptr, inv.ravel())), shape=(k, len(local_ids)))
                ia = keep[act]
                C = sp.csr_matrix(
                    (
                        (gam * (pts.dA[ia] * pts.eps[ia] * pts.slope[ia])[:, None]).ravel(),
                        (ptr, inv.ravel()),
                    ),
                    shape=(k, len(local_ids)),
                )
                if self.options.geometric_tangent:
                    U, V = self._geometric_factors(ps, pts, ia, dirn[act], Rs, Rm, free[act])
                    r4 = np.repeat(np.arange(4 * k).reshape(k, 4), m, axis=0).reshape(k, m, 4)
                    shape = (4 * k, len(local_ids))
                    cols4 = np.broadcast_to(inv[:, :, None], (k, m, 4))
                    Ub = sp.csr_matrix((U.ravel(), (r4.ravel(), cols4.ravel())), shape=shape)
                    Vb = sp.csr_matrix((V.ravel(), (r4.ravel(), cols4.ravel())), shape=shape)
                    K = (B.T @ C + Ub.T @ Vb).tocoo()
                else:
                    K = (B.T @ C).tocoo()
                nz = K.data != 0.0
                rows.append(local_ids[K.row[nz]])
                cols.append(local_ids[K.col[nz]])
                vals.append(K.data[nz])
        cat = lambda a, dt: np.concatenate(a).astype(dt) if a else np.zeros(0, dt)
        res = (cat(rdofs, np.int64), cat(rvals, np.float64))
        if not matrix:
            return res, None
        return res, (cat(rows, np.int64), cat(cols, np.int64), cat(vals, np.float64))

    def _geometric_factors(self, ps, pts, act, dirn, Rs, Rm, free):
        """The geometric tangent's factors (U, V), each (k, m, 4), of the active points ``act``
        (``dirn`` their directions d, ``free`` their dofs' mask)
        (:func:`gearfem.contact.tangent.geometric_tangent`) in the bodies' frames over the points'
        dofs (slave nodes, then master nodes, 3 each), masked where the dofs are fixed: the
        variation of the closest point, the normal and the frozen slip direction that the
        tangent W ε ρ γᵀ leaves out. The global-frame factors are kept on ``pts`` for
        :meth:`rotation_terms`."""
        geo, frozen = _point_geometry(pts, act, ps.master.ref)
        U, V, e = geometric_factors(
            geo, pts.dA[act] * pts.pressure[act], dirn, pts.mu[act], frozen,
        )  # fmt: skip
        pts.geometric = (act, geo, frozen, (U, V, e))
        k, nn = len(act), pts.Ns.shape[1]
        mask = free[..., None]  # (k, 2, nn, 3, 1): per dof
        return tuple(
            np.where(mask, _to_body_frames(F.reshape(k, 2, nn, 3, 4), Rs, Rm), 0.0).reshape(
                k, -1, 4
            )
            for F in (U, V)
        )

    # -------------------------------------------------------------------------------------------
    def rotation_terms(
        self, points: list[ContactPoints], motions: dict[str, RigidMotion], body: str
    ):
        """Moment of the contact forces on ``body`` about its motion axis and its linearisation.

        With ψ the rotation of ``body`` about its axis, at every contact point β = ∂g/∂ψ
        (= ±(a × (x − c))·n, + when the body is the slave) and the moment coefficient
        m = ±a·((x − c) × (n − μŝ)), so that the moment is M = Σ W p m. Returns
        ``(M, k_psipsi, (dofs, k_upsi), (dofs, k_psiu))`` with k_upsi = ∂R_u/∂ψ = Σ W ε ρ β,
        k_psiu = ∂(−M)/∂u = Σ W ε m γ and k_psipsi = ∂(−M)/∂ψ = Σ W ε m β (active points;
        lever-arm and normal variations omitted as in the displacement tangent). Local sums.
        """
        mot = motions[body]
        axis = np.asarray(mot.axis, float) / np.linalg.norm(mot.axis)
        c = np.asarray(mot.center) + np.asarray(mot.translation_m)
        M = kpp = 0.0
        d_up, v_up, d_pu, v_pu = [], [], [], []
        for ps, pts in zip(self.passes, points):
            if pts.num_points == 0 or body not in (ps.slave.body, ps.master.body):
                continue
            sign = 1.0 if ps.slave.body == body else -1.0
            lever = pts.x - c
            beta = sign * np.einsum("pd,pd->p", np.cross(axis, lever), pts.normal)
            dirn = pts.direction
            mcoef = sign * np.einsum("d,pd->p", axis, np.cross(lever, dirn))
            M += float(np.sum(pts.dA * pts.pressure * mcoef))
            w = pts.dA * pts.eps * pts.slope
            kpp += float(np.sum(w * mcoef * beta))
            # the border's entries, over the active points only (w vanishes elsewhere)
            a_idx = np.flatnonzero(pts.active)
            if len(a_idx) == 0:
                continue
            sdata, mdata = ps.slave.local, ps.master.gathered()
            Rs, Rm = motions[ps.slave.body].R, motions[ps.master.body].R
            facet, mfacet = pts.facet[a_idx], pts.mfacet[a_idx]
            Ns, Nm = pts.Ns[a_idx], pts.Nm[a_idx]
            dofs_s = 3 * sdata.blocks[facet][:, :, None] + np.arange(3)
            dofs_m = 3 * mdata.blocks[mfacet][:, :, None] + np.arange(3)
            free = np.stack([~sdata.fixed[facet], ~mdata.fixed[mfacet]], axis=1)
            k = len(a_idx)
            dofs = np.stack([dofs_s, dofs_m], axis=1).reshape(k, -1)
            d, nrm = dirn[a_idx], pts.normal[a_idx]
            rho = np.stack(
                [Ns[:, :, None] * (d @ Rs)[:, None, :], -Nm[:, :, None] * (d @ Rm)[:, None, :]],
                axis=1,
            )
            gam = np.stack(
                [Ns[:, :, None] * (nrm @ Rs)[:, None, :], -Nm[:, :, None] * (nrm @ Rm)[:, None, :]],
                axis=1,
            )
            rho = np.where(free, rho, 0.0).reshape(k, -1)
            gam = np.where(free, gam, 0.0).reshape(k, -1)
            v_up_pts = (w * beta)[a_idx][:, None] * rho
            v_pu_pts = (w * mcoef)[a_idx][:, None] * gam
            if self.options.geometric_tangent:
                kept = pts.geometric
                if kept is not None and np.array_equal(kept[0], a_idx):
                    _, geo, frozen, factors = kept
                else:
                    geo, frozen = _point_geometry(pts, a_idx, ps.master.ref)
                    factors = None
                wp = pts.dA[a_idx] * pts.pressure[a_idx]
                nn = pts.Ns.shape[1]
                r_glob = -wp[:, None, None] * np.concatenate(
                    [Ns[:, :, None] * d[:, None, :], -Nm[:, :, None] * d[:, None, :]], axis=1
                )
                g_up, g_pu, g_pp = torque_border(
                    geo, wp, d, pts.mu[a_idx], frozen, r_glob.reshape(k, -1),
                    pts.nodes[a_idx], pts.x[a_idx], axis, c, "slave" if sign > 0 else "master",
                    factors,
                )  # fmt: skip
                for v_pts, g in ((v_up_pts, g_up), (v_pu_pts, g_pu)):
                    g = _to_body_frames(g.reshape(k, 2, nn, 3), Rs, Rm)
                    v_pts += np.where(free, g, 0.0).reshape(k, -1)
                kpp += float(np.sum(g_pp))
            d_up.append(dofs.ravel())
            v_up.append(v_up_pts.ravel())
            d_pu.append(dofs.ravel())
            v_pu.append(v_pu_pts.ravel())
        cat = lambda a, dt: np.concatenate(a).astype(dt) if a else np.zeros(0, dt)
        return (
            M,
            kpp,
            (cat(d_up, np.int64), cat(v_up, np.float64)),
            (cat(d_pu, np.int64), cat(v_pu, np.float64)),
        )

    # -------------------------------------------------------------------------------------------
    def update_multipliers(
        self,
        u_array: np.ndarray,
        motions: dict[str, RigidMotion],
        hold_within_m: float | None = None,
    ) -> float:
        """Uzawa step λ ← ⟨λ − εg⟩ at the fixed points; returns the largest penetration (global,
        m). With ``hold_within_m``, the multipliers are kept as they are when that penetration is
        within it (collective decision)."""
        worst = 0.0
        updated = []
        for ps in self.passes:
            ms, mm = motions[ps.slave.body], motions[ps.master.body]
            _sdata, xs = self._nodes(ps.slave, u_array, ms, gathered=False)
            mdata, xm = self._nodes(ps.master, u_array, mm, gathered=True)
            # the facet pairs that overlap in the current configuration: not those of the
            # segmentation made at the start of the Newton solve, which the surfaces may have
            # left since (tangential shear under friction: 0.6 mm, 4-9 % of a facet, in the
            # Hertz case with μ = 0.3); fixed points facing a facet that was not paired then
            # found no gap and had their multiplier reset to zero
            pairs = _unique_pairs(*self._overlaps(ps, xs, xm, mdata)[:2])
            si, mj = pairs[:, 0], pairs[:, 1]
            nf, nq = ps.lam.shape
            gaps = np.full((nf, nq), np.inf)
            if len(si):
                q = len(self.fixed_points)
                fs = np.repeat(si, q)
                fm = np.repeat(mj, q)
                xi = np.tile(self.fixed_points, (len(si), 1))
                x = evaluate(ps.slave.ref, xs[fs], xi)[0]
                zeta, _ = _closest_master_points(ps.master.ref, xm, fm, x)
                # the same foot tolerance as the contact points (_master_feet): the pairs are
                # those of the segmentation made at the start of the solve, and a fixed point whose
                # foot has since moved just past a paired facet's edge (tangential shear under
                # friction) would otherwise find no gap and have its multiplier reset to zero
                inside = ps.master.ref.inside(zeta, tol=self.options.projection_tolerance)
                xmp, t1, t2, _ = evaluate(ps.master.ref, xm[fm], zeta)
                normal, _ = unit_normal(t1, t2, mdata.orientation[fm])
                g = np.einsum("pd,pd->p", x - xmp, normal)
                # a fixed point takes the gap from the master facet it projects into (smallest |g|)
                key = fs * nq + np.tile(np.arange(q), len(si))
                key, g = key[inside], g[inside]
                order = np.lexsort((np.abs(g), key))
                first = np.unique(key[order], return_index=True)[1]
                chosen = order[first]
                gaps.ravel()[key[chosen]] = g[chosen]
            has = np.isfinite(gaps)
            new = np.where(
                has, np.maximum(0.0, ps.lam - ps.eps[:, None] * np.where(has, gaps, 0.0)), 0.0
            )
            pen = np.where(has & (new > 0.0), -gaps, 0.0)
            worst = max(worst, float(pen.max(initial=0.0)))
            updated.append(new)
        worst = self.a.comm.allreduce(worst, op=_mpi_max())
        if hold_within_m is None or worst > hold_within_m:
            for ps, new in zip(self.passes, updated):
                ps.lam[:] = new
        return worst


def _point_geometry(
    pts: ContactPoints, idx: np.ndarray, ref_m
) -> tuple[PointGeometry, np.ndarray | None]:
    """What :mod:`gearfem.contact.tangent` needs of the points ``idx`` (the master facet's shape
    functions, tangents and curvature at the foot, from one tabulation with second derivatives),
    and their frozen slip directions (None when ŝ is not frozen)."""
    nn = pts.Ns.shape[1]
    xm = pts.nodes[idx, nn:]
    tab = ref_m.tabulate(pts.zeta[idx], 2)  # N, N_,1, N_,2, N_,11, N_,12, N_,22: (6, k, nn)
    xd = np.matmul(tab[:, :, None, :], xm[None])[:, :, 0, :]  # (6, k, 3)
    normal = pts.normal[idx]
    b = np.einsum("jkd,kd->kj", xd[3:], normal)  # n·x_11, n·x_12, n·x_22
    geo = PointGeometry(
        Ns=pts.Ns[idx],
        Nm=pts.Nm[idx],
        dNm=np.moveaxis(tab[1:3], 0, 1),
        tau=np.moveaxis(xd[1:3], 0, 1),
        curvature=np.stack([b[:, [0, 1]], b[:, [1, 2]]], axis=1),
        normal=normal,
        gap=pts.gap[idx],
    )
    return geo, None if pts.frozen_slip is None else pts.frozen_slip[idx]


def _to_body_frames(F: np.ndarray, Rs: np.ndarray, Rm: np.ndarray) -> np.ndarray:
    """Per-point arrays over the global coordinates of the slave's and the master's nodes,
    ``(k, 2, nn, 3, ...)``, in the bodies' frames: each node's 3-block times R_bᵀ (residual rows
    R_bᵀ r; displacement columns, Δx = R_b Δu)."""
    out = np.empty_like(F)
    for b, R in ((0, Rs), (1, Rm)):
        if F.ndim == 4:  # (k, 2, nn, 3): vectors
            out[:, b] = F[:, b] @ R
        else:  # (k, 2, nn, 3, c): columns of vectors
            out[:, b] = np.matmul(R.T, F[:, b])
    return out


def _box_pairs(xs: np.ndarray, xm: np.ndarray, margin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(slave, master) facet pairs whose axis-aligned bounding boxes (of all facet nodes; the
    slave's grown by ``margin``) overlap, sorted by slave then master facet.

    Candidates come from one k-d tree query in coordinates scaled per axis by the largest sum of
    half-widths (Chebyshev radius 1: every overlapping pair is found), then the exact test."""
    lo_s, hi_s = xs.min(axis=1) - margin[:, None], xs.max(axis=1) + margin[:, None]
    lo_m, hi_m = xm.min(axis=1), xm.max(axis=1)
    cs, hs = 0.5 * (lo_s + hi_s), 0.5 * (hi_s - lo_s)
    cm, hm = 0.5 * (lo_m + hi_m), 0.5 * (hi_m - lo_m)
    scale = hs.max(axis=0) + hm.max(axis=0)
    scale = np.where(scale > 0.0, scale, 1.0)
    near = cKDTree(cs / scale).sparse_distance_matrix(
        cKDTree(cm / scale), 1.0 + 1e-12, p=np.inf, output_type="ndarray"
    )
    si, mj = near["i"].astype(np.int64), near["j"].astype(np.int64)
    keep = np.all(np.abs(cs[si] - cm[mj]) <= hs[si] + hm[mj], axis=1)
    si, mj = si[keep], mj[keep]
    order = np.lexsort((mj, si))
    return si[order], mj[order]


def _unique_pairs(slave: np.ndarray, master: np.ndarray) -> np.ndarray:
    """The distinct (slave facet, master facet) rows, sorted, (n, 2)."""
    if not len(slave):
        return np.zeros((0, 2), np.int64)
    return np.unique(np.stack([slave, master], axis=1), axis=0)


def _facet_normal(ref, nodes: np.ndarray, orientation: np.ndarray) -> np.ndarray:
    centre = np.tile(ref.reference_polygon.mean(axis=0), (nodes.shape[0], 1))
    _, t1, t2, _ = evaluate(ref, nodes, centre)
    return unit_normal(t1, t2, orientation)[0]


def _triangle_rule(degree: int) -> tuple[np.ndarray, np.ndarray]:
    import basix

    pts, wts = basix.make_quadrature(basix.CellType.triangle, degree)
    return np.asarray(pts), np.asarray(wts)


def _mpi_max():
    from mpi4py import MPI

    return MPI.MAX


def _mpi_min():
    from mpi4py import MPI

    return MPI.MIN
