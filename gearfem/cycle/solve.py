"""Solve the contact problem at each pinion angle of the mesh cycle and extract load sharing and
heat sources.

Per position: transmission error, normal load per tooth pair, contact pressure, root stress,
friction power and the torque balance. Per cell: strain energy density, whose maximum over the
cycle (U_max, DG0) drives hysteresis heating (thesis 5.2.2). Per contact facet: the friction heat
μ p v_s, averaged over one revolution (thesis eq. 5.10). Kinematics are per unit pinion speed
(ω₁ = 1 rad/s): the structure is quasi-static, so one cycle solve per torque serves every speed
(friction heat scales with ω₁).

With ``pitches = 1`` the rotational periodicity (:mod:`gearfem.cycle.periodic`) turns one pitch of
positions into every tooth's whole engagement; the per-entity results are reported for the
reference tooth of each gear (the one at the pitch point in the mesh as built).
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI

from gearfem.contact.kinematics import evaluate
from gearfem.contact.problem import elastic_stress
from gearfem.core.facets import FacetReference
from gearfem.cycle.model import GearContactModel
from gearfem.cycle.periodic import (
    SHIFT_SIGN,
    image_map,
    in_sector,
    periodic_max,
    periodic_sum,
)
from gearfem.cycle.result import BodyFields, CycleResult
from gearfem.geometry.mesh import parse_group_name
from gearfem.geometry.options import BODIES

log = logging.getLogger(__name__)


class _RootStress:
    """Largest principal stress on the root surfaces of each body (sampled at the facet nodes)."""

    def __init__(self, model: GearContactModel) -> None:
        import basix

        gm, mesh = model.gm, model.gm.mesh
        tdim = mesh.topology.dim
        cell_type = {
            "tetrahedron": basix.CellType.tetrahedron,
            "hexahedron": basix.CellType.hexahedron,
        }[mesh.topology.cell_name()]
        ref = FacetReference.create(cell_type, 2)
        cell_points = basix.create_element(
            basix.ElementFamily.P, cell_type, 2, basix.LagrangeVariant.equispaced
        ).points
        sigma = elastic_stress(model.problem.u, model.lame_mu, model.lame_lambda)
        mesh.topology.create_connectivity(tdim - 1, tdim)
        n_owned = mesh.topology.index_map(tdim - 1).size_local
        self.groups: dict[str, list] = {}
        for b in BODIES:
            facets = gm.facets(*gm.names(body=b, kind="root"))
            facets = facets[facets < n_owned]
            cf = np.asarray(
                fem.compute_integration_domains(
                    fem.IntegralType.exterior_facet, mesh.topology, facets
                )
            ).reshape(-1, 2)
            groups = []
            for lf in np.unique(cf[:, 1]):
                cells = cf[cf[:, 1] == lf, 0].astype(np.int32)
                expr = fem.Expression(sigma, cell_points[ref.facet_nodes[lf]])
                groups.append((expr, cells))
            self.groups[b] = groups
        self.mesh, self.comm = mesh, mesh.comm

    def max_principal(self) -> dict[str, float]:
        out = {}
        for b, groups in self.groups.items():
            m = -np.inf
            for expr, cells in groups:
                if len(cells) == 0:
                    continue
                vals = expr.eval(self.mesh, cells).reshape(-1, 3, 3)
                m = max(
                    m,
                    float(np.linalg.eigvalsh(0.5 * (vals + vals.transpose(0, 2, 1)))[:, -1].max()),
                )
            out[b] = self.comm.allreduce(m, op=MPI.MAX)
        return out


class _StrainEnergy:
    """Cell-average strain energy density ½σ:ε per cell (DG0, J/m³)."""

    def __init__(self, model: GearContactModel) -> None:
        mesh = model.gm.mesh
        self.Q = fem.functionspace(mesh, ("DG", 0))
        v = ufl.TestFunction(self.Q)
        u = model.problem.u
        w = 0.5 * ufl.inner(
            elastic_stress(u, model.lame_mu, model.lame_lambda), ufl.sym(ufl.grad(u))
        )
        self.form = fem.form(w * v * ufl.dx)
        vol = fem_petsc.assemble_vector(fem.form(v * ufl.dx))
        self.n_owned = self.Q.dofmap.index_map.size_local
        self.volume = vol.array[: self.n_owned].copy()
        vol.destroy()

    def values(self) -> np.ndarray:
        b = fem_petsc.assemble_vector(self.form)
        out = b.array[: self.n_owned] / self.volume
        b.destroy()
        return out


def _gather(a: np.ndarray, comm: MPI.Comm) -> np.ndarray:
    return np.concatenate(comm.allgather(np.ascontiguousarray(a)))


def solve_cycle(
    model: GearContactModel,
    positions_per_pitch: int | None = None,
    pitches: float | None = None,
    start_angle_deg: float | None = None,
    heat_fraction: dict[str, float] | None = None,
    check_periodicity: bool | None = None,
    progress=None,
) -> CycleResult:
    """Step the pinion angle through the cycle and collect the cycle results (collective).

    Args:
        model: The gear contact model (its torque and contact options).
        heat_fraction: Share of the friction heat going into each gear (default: by thermal
            effusivity b = sqrt(k ρ c_p), i.e. ½ each for equal materials, thesis 5.2.3).
        progress: Optional callable(i, n, label) called after every position (rank 0 may print).
    """
    o = model.options
    n_pitch = positions_per_pitch or o.positions_per_pitch
    pitches = pitches if pitches is not None else o.pitches
    start = math.radians(o.start_angle_deg if start_angle_deg is None else start_angle_deg)
    check = o.check_periodicity if check_periodicity is None else check_periodicity
    gm, comm = model.gm, model.comm
    pair = model.pair
    pitch = 2.0 * math.pi / gm.geometry.teeth_pinion
    n = max(1, round(n_pitch * pitches))
    phis = start + pitch * pitches * np.arange(n) / n
    if heat_fraction is None:
        b1, b2 = (model.materials[b].thermal_effusivity for b in BODIES)
        heat_fraction = {"pinion": b1 / (b1 + b2), "wheel": b2 / (b1 + b2)}
    mu = model.contact.friction_coefficient
    itf = model.interface
    se = _StrainEnergy(model)
    rs = _RootStress(model)
    teeth = sorted({int(k) for k in model.tooth_of_facet["pinion"]["gathered"] if k >= 0})
    zmid = 0.5 * gm.geometry.face_width_mm * 1e-3
    hist = {k: [] for k in ("te", "tp", "tw", "pf", "pmax", "pmid", "nit", "uz", "wall")}
    root = {b: [] for b in BODIES}
    loads = {k: [] for k in teeth}
    Ss = {k: [] for k in teeth}
    w_cells = []  # per position: local cell strain energy
    facet_heat = {b: [] for b in BODIES}  # per position: heat per local slave facet (W per rad/s)
    facet_press = {b: [] for b in BODIES}  # per position: mean pressure per local slave facet
    rw1_sin = pair.pinion.operating_pitch_radius_m * math.sin(pair.operating_pressure_angle_rad)
    rb1 = pair.pinion.base_radius_m
    cp = np.asarray(gm.center("pinion"))

    def solve_and_record(i: int, phi: float, record: bool = True):
        t0 = time.perf_counter()
        rep = model.solve_position(phi, f"pinion angle {math.degrees(phi):.3f} deg")
        pts_list = model.problem.last_points[0]
        st = model.problem.last_state
        te = model.transmission_error_m()
        tp = model.pinion_torque_Nm()
        tw = st.moment_Nm
        pf = pmax = pmid = 0.0
        tl = {k: 0.0 for k in teeth}
        tS = {k: 0.0 for k in teeth}
        per_facet_heat = {}
        per_facet_press = {}
        for ps, pts in zip(itf.passes, pts_list):
            slave = ps.slave.body
            q = pts.friction_power_density(mu)
            pf += float(np.sum(pts.dA * q))
            if pts.num_points:
                pmax = max(pmax, float(pts.pressure.max()))
                mid = np.abs(pts.x[:, 2] - zmid) <= 0.5 * zmid
                if mid.any():
                    pmid = max(pmid, float(pts.pressure[mid].max()))
            nf = ps.slave.local.num_facets
            # heat and pressure per slave facet from this pass alone (undo the pass weight)
            per_facet_heat[slave] = np.bincount(
                pts.facet, weights=pts.dA * q / ps.weight, minlength=nf
            )
            area = np.bincount(pts.facet, weights=pts.dA / ps.weight, minlength=nf)
            pint = np.bincount(pts.facet, weights=pts.dA * pts.pressure / ps.weight, minlength=nf)
            per_facet_press[slave] = np.where(area > 0, pint / np.where(area > 0, area, 1.0), 0.0)
            # normal load per pinion tooth: the pinion is the slave in one pass, the master in the
            # other
            if slave == "pinion":
                tooth = model.tooth_of_facet["pinion"]["local"][pts.facet]
            else:
                tooth = model.tooth_of_facet["pinion"]["gathered"][pts.mfacet]
            fp = pts.dA * pts.pressure
            # contact position on the pinion along the line of action
            r = np.linalg.norm((pts.x - cp)[:, :2], axis=1)
            S = np.sqrt(np.maximum(r * r - rb1 * rb1, 0.0)) - rw1_sin
            for k in teeth:
                sel = tooth == k
                tl[k] += float(np.sum(fp[sel]))
                tS[k] += float(np.sum(fp[sel] * S[sel]))
        pf = comm.allreduce(pf, op=MPI.SUM)
        pmax = comm.allreduce(pmax, op=MPI.MAX)
        pmid = comm.allreduce(pmid, op=MPI.MAX)
        tl = {k: comm.allreduce(v, op=MPI.SUM) for k, v in tl.items()}
        tS = {k: comm.allreduce(v, op=MPI.SUM) for k, v in tS.items()}
        rsv = rs.max_principal()
        w = se.values()
        dt = time.perf_counter() - t0
        if record:
            for key, val in (
                ("te", te),
                ("tp", tp),
                ("tw", tw),
                ("pf", pf),
                ("pmax", pmax),
                ("pmid", pmid),
                ("nit", rep.newton_iterations),
                ("uz", rep.uzawa_iterations),
                ("wall", dt),
            ):
                hist[key].append(val)
            for b in BODIES:
                root[b].append(rsv[b])
                facet_heat[b].append(per_facet_heat[b])
                facet_press[b].append(per_facet_press[b])
            for k in teeth:
                loads[k].append(tl[k])
                Ss[k].append(tS[k] / tl[k] if tl[k] > 0 else np.nan)
            w_cells.append(w)
        log.info(
            "position %d/%d: pinion %.3f deg, TE %.3f um, loads %s N, p_max %.1f MPa, %d Newton, "
            "%.1f s",
            i + 1,
            n,
            math.degrees(phi),
            te * 1e6,
            ", ".join(f"{k}:{tl[k]:.0f}" for k in teeth if tl[k] > 0),
            pmax / 1e6,
            rep.newton_iterations,
            dt,
        )
        return te, tl, pmax, w

    for i, phi in enumerate(phis):
        solve_and_record(i, phi)
        if progress is not None:
            progress(i + 1, n, f"{math.degrees(phi):.2f} deg")

    periodicity = None
    if check:
        te, tl, pmax, w = solve_and_record(n, start + pitch, record=False)
        periodicity = {
            "te_first_m": hist["te"][0],
            "te_shifted_m": te,
            "p_max_first_Pa": hist["pmax"][0],
            "p_max_shifted_Pa": pmax,
            # the pinion's tooth k at start+pitch carries what tooth k+1 carried at start
            "tooth_load_first_N": {k: loads[k][0] for k in teeth},
            "tooth_load_shifted_N": {k: tl[k] for k in teeth},
            "_w_shifted": w,
        }

    fields = _sector_fields(
        model, se, np.array(w_cells), facet_heat, facet_press, heat_fraction, pitch
    )
    # Each gear's flux distribution comes from the pass in which it is the slave; its magnitude is
    # made to carry exactly its share of the cycle-averaged friction power (the raw mismatch, from
    # the two passes' slightly different pressures and the periodic mapping, is reported).
    mean_pf = float(np.mean(hist["pf"]))
    balance = {}
    for b in BODIES:
        z = gm.geometry.teeth_pinion if b == "pinion" else gm.geometry.teeth_wheel
        raw = z * float(np.sum(fields[b].flux_W_m2_per_rad_s * fields[b].facet_area_m2))
        target = heat_fraction[b] * mean_pf
        if raw > 0.0:
            fields[b].flux_W_m2_per_rad_s *= target / raw
        balance[f"{b}_flank_heat_raw_over_share"] = raw / target if target > 0 else float("nan")
    if periodicity is not None:
        periodicity.update(
            _periodicity_of_cells(
                model, se, np.array(w_cells[0]), periodicity.pop("_w_shifted"), pitch
            )
        )

    return CycleResult(
        torque_Nm=model.torque_Nm,
        friction_coefficient=mu,
        heat_fraction=dict(heat_fraction),
        pitch_angle_rad=pitch,
        phi_rad=np.asarray(phis),
        te_m=np.array(hist["te"]),
        pinion_torque_Nm=np.array(hist["tp"]),
        wheel_torque_Nm=np.array(hist["tw"]),
        friction_power_W_per_rad_s=np.array(hist["pf"]),
        p_max_Pa=np.array(hist["pmax"]),
        p_max_mid_Pa=np.array(hist["pmid"]),
        root_stress_Pa={b: np.array(v) for b, v in root.items()},
        tooth_load_N={k: np.array(v) for k, v in loads.items()},
        tooth_S_m={k: np.array(v) for k, v in Ss.items()},
        newton_iterations=np.array(hist["nit"]),
        uzawa_iterations=np.array(hist["uz"]),
        wall_time_s=np.array(hist["wall"]),
        fields=fields,
        reference_tooth={b: gm.reference_tooth(b) for b in BODIES},
        theoretical_contact_ratio=pair.contact_ratio,
        base_pitch_m=pair.base_pitch_m,
        periodicity=periodicity,
        info={
            "dofs": model.V.dofmap.index_map.size_global * 3,
            "positions": n,
            "mpi_size": comm.size,
            "stalled_newton_solves": model.problem.stalled,
            "factorizations": model.problem.factorizations,
            "linear_solves": model.problem.linear_solves,
            "creep_ratio": model.creep_ratio,
            "speed_ratio": model.ratio,
            "slip_regularization_m_s": model.contact.slip_regularization_m_s,
            **balance,
        },
    )


def _cell_data(model: GearContactModel, se: _StrainEnergy, body: str):
    """Global (gathered) centroids, volumes and the local->global position map of a body's cells."""
    gm, comm = model.gm, model.comm
    mesh = gm.mesh
    cells = gm.cells(body)
    cells = cells[cells < se.n_owned]
    x = mesh.geometry.x[mesh.geometry.dofmaps[0][cells]].mean(axis=1)
    return cells, _gather(x, comm), _gather(se.volume[cells], comm)


def _sector_fields(
    model, se, w_cells, facet_heat, facet_press, heat_fraction, pitch
) -> dict[str, BodyFields]:
    gm, comm = model.gm, model.comm
    out = {}
    for b in BODIES:
        center = np.asarray(gm.center(b))
        z = gm.geometry.teeth_pinion if b == "pinion" else gm.geometry.teeth_wheel
        pitch_b = 2.0 * math.pi / z
        shift = SHIFT_SIGN[b] * pitch_b
        tooth_angle = float(gm.tooth_angles(b)[gm.reference_tooth(b)])
        # cells
        cells, xc, vol = _cell_data(model, se, b)
        W = np.stack([_gather(w[cells], comm) for w in w_cells])  # (n_pos, n_cells_body)
        sec = in_sector(xc, center, tooth_angle, pitch_b)
        tol = 2.0 * np.cbrt(vol[sec])  # an image must land within about a cell of a centroid
        imap = image_map(xc[sec], xc, center, shift, tol)
        u_max = periodic_max(W, imap)
        u_hist = np.concatenate(
            [np.where(imap.valid[m], W[:, imap.index[m]], 0.0) for m in imap.images]
        )
        # the state at φ + m·pitch at x equals that at φ at R^m x: image m lies m pitches later
        hist_phi = np.concatenate(
            [m * pitch + np.arange(W.shape[0]) * pitch / W.shape[0] for m in imap.images]
        )
        # facets of the contact surface
        surf = model.surfaces[b]
        data = surf.gathered()
        ref = surf.ref
        nv = ref.num_vertices
        fx = data.X[:, :nv].mean(axis=1)
        qp, qw = ref.quadrature(2)

        area = np.zeros(data.num_facets)
        for p_, w_ in zip(qp, qw):
            _, a1, a2, _ = evaluate(ref, data.X, np.tile(p_, (data.num_facets, 1)))
            area += w_ * np.linalg.norm(np.cross(a1, a2), axis=1)
        H = np.stack([_gather(h, comm) for h in facet_heat[b]])  # (n_pos, n_facets) W per rad/s
        P = np.stack([_gather(p, comm) for p in facet_press[b]])
        tooth = model.tooth_of_facet[b]["gathered"]
        fsec = tooth == gm.reference_tooth(b)
        ftol = 2.0 * np.sqrt(area[fsec])
        fmap = image_map(fx[fsec], fx, center, shift, ftol)
        dphi = pitch / H.shape[0]
        # revolution average: (1 / 2π) Σ_positions Σ_images (heat density at the image) Δφ
        flux = heat_fraction[b] * periodic_sum(H / area[None, :], fmap) * dphi / (2.0 * math.pi)
        pmax = periodic_max(P, fmap)
        kinds = _facet_kinds(model, b)
        out[b] = BodyFields(
            center,
            tooth_angle,
            pitch_b,
            xc[sec],
            vol[sec],
            u_max,
            fx[fsec],
            area[fsec],
            kinds[fsec],
            flux,
            pmax,
            u_hist,
            hist_phi,
        )
    return out


def _facet_kinds(model: GearContactModel, body: str) -> np.ndarray:
    gm, surf = model.gm, model.surfaces[body]
    tag_kind = {gm.tag(n): parse_group_name(n)[2] for n in gm.names(body=body)}
    ft = gm.facet_tags
    order = np.argsort(ft.indices)
    pos = np.searchsorted(ft.indices[order], surf.facets)
    local = np.array([tag_kind.get(int(v), "") for v in ft.values[order][pos]], dtype="U16")
    return np.concatenate(model.comm.allgather(local))


def _periodicity_of_cells(
    model, se, w_first: np.ndarray, w_shifted: np.ndarray, pitch: float
) -> dict:
    """Strain energy per tooth sector at start + pitch against the start, one tooth over.

    By periodicity the pinion's sector k at start + pitch holds what sector k + 1 held at the start
    (the wheel's sector k what its sector k − 1 held). Interior sectors only (away from the cuts).
    """
    gm, comm = model.gm, model.comm
    out = {}
    for b in BODIES:
        center = np.asarray(gm.center(b))
        angles = gm.tooth_angles(b)
        pitch_b = (
            2.0 * math.pi / (gm.geometry.teeth_pinion if b == "pinion" else gm.geometry.teeth_wheel)
        )
        cells, xc, vol = _cell_data(model, se, b)
        W0, W1 = _gather(w_first[cells], comm), _gather(w_shifted[cells], comm)
        step = 1 if b == "pinion" else -1
        pairs = []
        for k in range(1, len(angles) - 1):
            j = k + step
            if not 1 <= j <= len(angles) - 2:
                continue
            sk = in_sector(xc, center, angles[k], pitch_b)
            sj = in_sector(xc, center, angles[j], pitch_b)
            pairs.append((k, float(np.sum(W1[sk] * vol[sk])), float(np.sum(W0[sj] * vol[sj]))))
        out[f"{b}_sector_energy_J"] = [
            {"sector": k, "shifted": e1, "mapped": e0} for k, e1, e0 in pairs
        ]
    return out
