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

import dataclasses
import logging
import math
import time

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI

from gearfem.contact.elasticity import elastic_stress
from gearfem.contact.kinematics import evaluate
from gearfem.core.errors import GearfemError
from gearfem.core.facets import FacetReference
from gearfem.cycle.friction_field import FrictionField
from gearfem.cycle.history import HistoryRecorder
from gearfem.cycle.model import GearContactModel
from gearfem.cycle.periodic import (
    SHIFT_SIGN,
    image_map,
    in_sector,
    periodic_max,
    periodic_sum,
)
from gearfem.cycle.result import BodyFields, CycleResult, PeriodicityCheck, SectorEnergy
from gearfem.geometry.options import BODIES

log = logging.getLogger(__name__)

#: The flank heat the revolution average collects on a reference tooth, relative to the friction
#: power generated in the mesh, before it is normalised to it: the two passes' pressures make it a
#: few per cent off 1 (built-in case: 1.031 and 0.969); outside this range images are missing.
RAW_FLANK_HEAT_RANGE = (0.8, 1.25)


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


@dataclasses.dataclass(frozen=True)
class PositionRecord:
    """What one pinion position of the cycle gives (global values, replicated on all ranks, except
    the per-facet and per-cell arrays, which are this rank's)."""

    phi_rad: float
    te_m: float  # transmission error (wheel lag along the line of action)
    pinion_torque_Nm: float
    wheel_torque_Nm: float  # contact moment on the wheel
    friction_power_W_per_rad_s: float  # ∫ μ p v_s dA per unit ω₁
    friction_power_per_mu_W_per_rad_s: float  # ∫ p v_s dA per unit ω₁ (per unit μ)
    p_max_Pa: float
    p_max_mid_Pa: float  # largest pressure in the middle half of the face width
    root_stress_Pa: dict[str, float]  # largest principal root stress per gear
    tooth_load_N: dict[int, float]  # normal load per pinion tooth
    tooth_S_m: dict[int, float]  # load-weighted contact position on the line of action (NaN: none)
    newton_iterations: int
    uzawa_iterations: int
    wall_time_s: float
    facet_heat_W_per_rad_s: dict[str, np.ndarray]  # friction heat per local slave facet
    facet_heat_per_mu_W_per_rad_s: dict[str, np.ndarray]  # the same per unit μ
    facet_pressure_Pa: dict[str, np.ndarray]  # mean pressure per local slave facet
    cell_strain_energy_J_m3: np.ndarray  # per local cell


class _PositionProbe:
    """Solves the model at a pinion angle and measures the position (collective)."""

    def __init__(self, model: GearContactModel, se: _StrainEnergy) -> None:
        self.model, self.se = model, se
        self.root_stress = _RootStress(model)
        gm, pair = model.gm, model.pair
        self.teeth = list(model.teeth["pinion"])  # every modelled tooth, loaded or not
        self.z_mid_m = 0.5 * gm.geometry.face_width_mm * 1e-3
        self.rw1_sin = pair.pinion.operating_pitch_radius_m * math.sin(
            pair.operating_pressure_angle_rad
        )
        self.rb1 = pair.pinion.base_radius_m
        self.center1 = np.asarray(gm.center("pinion"))

    def solve(self, phi: float) -> PositionRecord:
        model, comm, teeth = self.model, self.model.comm, self.teeth
        t0 = time.perf_counter()
        rep = model.solve_position(phi, f"pinion angle {math.degrees(phi):.3f} deg")
        points = model.problem.last_points[0]
        pf = pf1 = pmax = pmid = 0.0
        load = dict.fromkeys(teeth, 0.0)
        load_S = dict.fromkeys(teeth, 0.0)
        facet_heat, facet_heat1, facet_press = {}, {}, {}
        for ps, pts in zip(model.interface.passes, points):
            slave = ps.slave.body
            q = pts.friction_power_density()
            q1 = pts.friction_power_density(mu=1.0)
            pf += float(np.sum(pts.dA * q))
            pf1 += float(np.sum(pts.dA * q1))
            if pts.num_points:
                pmax = max(pmax, float(pts.pressure.max()))
                mid = np.abs(pts.x[:, 2] - self.z_mid_m) <= 0.5 * self.z_mid_m
                if mid.any():
                    pmid = max(pmid, float(pts.pressure[mid].max()))
            nf = ps.slave.local.num_facets
            # heat and pressure per slave facet from this pass alone (undo the pass weight)
            dA = pts.dA / ps.weight
            facet_heat[slave] = np.bincount(pts.facet, weights=dA * q, minlength=nf)
            facet_heat1[slave] = np.bincount(pts.facet, weights=dA * q1, minlength=nf)
            area = np.bincount(pts.facet, weights=dA, minlength=nf)
            pint = np.bincount(pts.facet, weights=dA * pts.pressure, minlength=nf)
            facet_press[slave] = np.where(area > 0, pint / np.where(area > 0, area, 1.0), 0.0)
            # normal load per pinion tooth: the pinion is the slave in one pass, the master in the
            # other
            if slave == "pinion":
                tooth = model.tooth_of_facet["pinion"]["local"][pts.facet]
            else:
                tooth = model.tooth_of_facet["pinion"]["gathered"][pts.mfacet]
            fp = pts.dA * pts.pressure
            # contact position on the pinion along the line of action
            r = np.linalg.norm((pts.x - self.center1)[:, :2], axis=1)
            S = np.sqrt(np.maximum(r * r - self.rb1 * self.rb1, 0.0)) - self.rw1_sin
            for k in teeth:
                sel = tooth == k
                load[k] += float(np.sum(fp[sel]))
                load_S[k] += float(np.sum(fp[sel] * S[sel]))
        load = {k: comm.allreduce(v, op=MPI.SUM) for k, v in load.items()}
        load_S = {k: comm.allreduce(v, op=MPI.SUM) for k, v in load_S.items()}
        te = model.transmission_error_m()
        pinion_torque = model.pinion_torque_Nm()
        root = self.root_stress.max_principal()
        w = self.se.values()
        return PositionRecord(
            phi_rad=float(phi),
            te_m=te,
            pinion_torque_Nm=pinion_torque,
            wheel_torque_Nm=model.problem.last_state.moment_Nm,
            friction_power_W_per_rad_s=comm.allreduce(pf, op=MPI.SUM),
            friction_power_per_mu_W_per_rad_s=comm.allreduce(pf1, op=MPI.SUM),
            p_max_Pa=comm.allreduce(pmax, op=MPI.MAX),
            p_max_mid_Pa=comm.allreduce(pmid, op=MPI.MAX),
            root_stress_Pa=dict(root),
            tooth_load_N=load,
            tooth_S_m={k: load_S[k] / load[k] if load[k] > 0 else np.nan for k in teeth},
            newton_iterations=rep.newton_iterations,
            uzawa_iterations=rep.uzawa_iterations,
            wall_time_s=time.perf_counter() - t0,
            facet_heat_W_per_rad_s=facet_heat,
            facet_heat_per_mu_W_per_rad_s=facet_heat1,
            facet_pressure_Pa=facet_press,
            cell_strain_energy_J_m3=w,
        )


def _log_position(i: int, n: int, phi: float, rec: PositionRecord, rank: int | None = None) -> None:
    log.info(
        "position %d/%d%s: pinion %.3f deg, TE %.3f um, loads %s N, p_max %.1f MPa, %d Newton, "
        "%.1f s",
        i + 1,
        n,
        "" if rank is None else f" (rank {rank})",
        math.degrees(phi),
        rec.te_m * 1e6,
        ", ".join(f"{k}:{v:.0f}" for k, v in rec.tooth_load_N.items() if v > 0),
        rec.p_max_Pa / 1e6,
        rec.newton_iterations,
        rec.wall_time_s,
    )


class _FacetFriction:
    """mu of a :class:`FrictionField` on the interface's local slave facets, per position
    (looked up at each facet's reference centroid: its radius from its gear's axis and its
    face-width coordinate)."""

    def __init__(self, model: GearContactModel, field: FrictionField) -> None:
        self.model, self.field = model, field
        self.places = []
        for ps, c in zip(model.interface.passes, model.interface.facet_centroids()):
            axis = np.asarray(model.gm.center(ps.slave.body))
            self.places.append(
                (ps.slave.body, np.linalg.norm(c[:, :2] - axis[:2], axis=1), c[:, 2])
            )

    def use(self, position: int) -> None:
        """Solve the next positions with the field's mu of cycle position ``position``."""
        self.model.interface.set_friction(
            [self.field.at(position, body, r, z) for body, r, z in self.places]
        )


def position_blocks(n: int, size: int) -> list[range]:
    """Contiguous blocks of the ``n`` positions of a cycle over ``size`` ranks, in order.

    Each block warm-starts from its own previous position; a block after the first begins with
    the position before it, solved again and not kept (:func:`solve_cycle`), so that its first
    kept position starts from a converged neighbour as in a one-rank cycle. The blocks are sized
    so that every rank solves about as many positions, that warm-up included."""
    if size <= 1:
        return [range(n)]
    solves = n + size - 1  # the warm-ups of the blocks after the first
    counts = [solves // size + (1 if k < solves % size else 0) for k in range(size)]
    sizes = [counts[0]] + [c - 1 for c in counts[1:]]
    edges = np.concatenate([[0], np.cumsum(sizes)])
    return [range(int(edges[k]), int(edges[k + 1])) for k in range(size)]


def solve_cycle(
    model: GearContactModel,
    positions_per_pitch: int | None = None,
    pitches: float | None = None,
    start_angle_deg: float | None = None,
    check_periodicity: bool | None = None,
    progress=None,
    world: MPI.Comm | None = None,
    friction_field: FrictionField | None = None,
) -> CycleResult:
    """Step the pinion angle through the cycle and collect the cycle results (collective).

    Args:
        model: The gear contact model (its torque and contact options).
        friction_field: mu at each contact of each position (:mod:`gearfem.cycle.friction_field`:
            a friction law's, from the thermal state of an earlier cycle); None: the model's
            ``contact.friction_coefficient`` everywhere. The check position one pitch after the
            start takes the first position's.
        progress: Optional callable(i, n, label) called after every position (rank 0 may print).
        world: With a model on one rank (``model.comm`` of size 1): the communicator of the ranks
            that each hold a copy of the same model. The positions are then dealt out over its
            ranks in contiguous blocks (:func:`position_blocks`), each rank solving its own, and
            the records gathered: the positions are independent once the compliances exist,
            so the cycle scales with the ranks instead of waiting on one rank's dense algebra.
            The result is the same on every rank and equals the one-rank cycle's within the
            contact solver's tolerance (a block's first position starts cold).
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
    mu = model.contact.friction_coefficient
    spread = world is not None and world.size > 1
    if spread and comm.size != 1:
        raise GearfemError(
            f"solve_cycle: positions are spread over {world.size} ranks only for a model on one "
            f"rank (this model is on {comm.size})"
        )
    mine = position_blocks(n, world.size)[world.rank] if spread else range(n)
    se = _StrainEnergy(model)
    probe = _PositionProbe(model, se)
    records: list[PositionRecord] = []
    recorder = HistoryRecorder(model)
    friction = _FacetFriction(model, friction_field) if friction_field is not None else None

    def use_friction(position: int) -> None:
        if friction is not None:
            friction.use(position)

    if mine.start > 0 and len(mine):  # warm-up: the position before the block, not kept
        t0 = time.perf_counter()
        use_friction(mine.start - 1)
        model.solve_position(
            phis[mine.start - 1],
            f"pinion angle {math.degrees(phis[mine.start - 1]):.3f} deg (warm-up)",
        )
        log.debug("warm-up position %d: %.1f s", mine.start, time.perf_counter() - t0)
    for i in mine:
        use_friction(i)
        records.append(probe.solve(phis[i]))
        recorder.record(i)
        _log_position(i, n, phis[i], records[-1])
        if progress is not None:
            progress(i + 1 - mine.start, len(mine), f"{math.degrees(phis[i]):.2f} deg")
    teeth = probe.teeth

    periodicity = None
    shifted = None
    # the check position one pitch after the start: by the rank that solved the last position
    # (a warm start from it)
    if check and (not spread or world.rank == world.size - 1):
        use_friction(0)  # the first position's contact, a tooth further round
        shifted = probe.solve(start + pitch)
        _log_position(n, n, start + pitch, shifted)
    if spread:
        parts = world.allgather(records)
        for r, part in enumerate(parts[1:], start=1):  # rank 0 logged its own as they came
            for i, rec in zip(position_blocks(n, world.size)[r], part):
                _log_position(i, n, phis[i], rec, rank=r)
        records = [rec for part in parts for rec in part]
        if check:
            shifted = world.bcast(shifted, root=world.size - 1)

    w_cells = np.array([r.cell_strain_energy_J_m3 for r in records])
    facet_heat = {b: [r.facet_heat_W_per_rad_s[b] for r in records] for b in BODIES}
    facet_heat1 = {b: [r.facet_heat_per_mu_W_per_rad_s[b] for r in records] for b in BODIES}
    facet_press = {b: [r.facet_pressure_Pa[b] for r in records] for b in BODIES}
    friction_power = np.array([r.friction_power_W_per_rad_s for r in records])
    fields, tooth_heat1 = _sector_fields(
        model, se, w_cells, facet_heat, facet_heat1, facet_press, pitch
    )
    # Each gear's flux distribution comes from the pass in which it is the slave, with that
    # pass's mu. The two passes' pressures differ by a few per cent (and the periodic mapping
    # collects the images only approximately): each gear's heat per unit mu is scaled to the
    # mesh's, ∫ p ŝ·v_T dA of both passes, the raw ratio reported. With one mu everywhere each
    # gear then carries exactly the friction power generated in the mesh; with a mu per contact
    # (a friction field), the power its own pass's mu dissipates. How that heat is split between
    # the gears is the coupling's business (gearfem.coupling.options.SourceOptions.heat_fractions),
    # not the cycle's.
    target = float(np.mean([r.friction_power_per_mu_W_per_rad_s for r in records]))
    heated = float(np.mean(friction_power)) > 0.0
    balance = {}
    for b in BODIES:
        raw = gm.geometry.teeth(b) * tooth_heat1[b] / target if target > 0 else float("nan")
        if raw > 0.0:
            fields[b].generated_flux_W_m2_per_rad_s /= raw
        balance[f"{b}_flank_heat_raw_over_total"] = raw if heated else float("nan")
        if heated and not RAW_FLANK_HEAT_RANGE[0] <= raw <= RAW_FLANK_HEAT_RANGE[1]:
            raise GearfemError(
                f"the revolution average collects {raw:.3f} of the friction power "
                f"generated in the mesh on the {b}'s reference tooth, outside "
                f"{RAW_FLANK_HEAT_RANGE} (the two passes' pressures differ by a few per cent): "
                "images of the heated facets are missing from the reference tooth"
            )
    if check:
        first = records[0]
        periodicity = PeriodicityCheck(
            te_first_m=float(first.te_m),
            te_shifted_m=float(shifted.te_m),
            p_max_first_Pa=float(first.p_max_Pa),
            p_max_shifted_Pa=float(shifted.p_max_Pa),
            # the pinion's tooth k at start+pitch carries what tooth k+1 carried at start
            tooth_load_first_N={int(k): float(v) for k, v in first.tooth_load_N.items()},
            tooth_load_shifted_N={int(k): float(v) for k, v in shifted.tooth_load_N.items()},
            sector_energy_J=_sector_energies(
                model, se, w_cells[0], shifted.cell_strain_energy_J_m3, pitch
            ),
        )
    history = recorder.finish(world if spread else None)

    return CycleResult(
        torque_Nm=model.torque_Nm,
        friction_coefficient=mu,
        pitch_angle_rad=pitch,
        phi_rad=np.asarray(phis),
        te_m=np.array([r.te_m for r in records]),
        pinion_torque_Nm=np.array([r.pinion_torque_Nm for r in records]),
        wheel_torque_Nm=np.array([r.wheel_torque_Nm for r in records]),
        friction_power_W_per_rad_s=friction_power,
        p_max_Pa=np.array([r.p_max_Pa for r in records]),
        p_max_mid_Pa=np.array([r.p_max_mid_Pa for r in records]),
        root_stress_Pa={b: np.array([r.root_stress_Pa[b] for r in records]) for b in BODIES},
        tooth_load_N={k: np.array([r.tooth_load_N[k] for r in records]) for k in teeth},
        tooth_S_m={k: np.array([r.tooth_S_m[k] for r in records]) for k in teeth},
        newton_iterations=np.array([r.newton_iterations for r in records]),
        uzawa_iterations=np.array([r.uzawa_iterations for r in records]),
        wall_time_s=np.array([r.wall_time_s for r in records]),
        fields=fields,
        reference_tooth={b: gm.reference_tooth(b) for b in BODIES},
        theoretical_contact_ratio=pair.contact_ratio,
        base_pitch_m=pair.base_pitch_m,
        periodicity=periodicity,
        info={
            "dofs": model.V.dofmap.index_map.size_global * 3,
            "positions": n,
            "mpi_size": world.size if spread else comm.size,
            "positions_over_ranks": spread,
            "solver": o.solver,
            "contact_teeth": {b: list(v) for b, v in model.contact_teeth.items()},
            **_solver_info(model, world if spread else None),
            "creep_ratio": model.creep_ratio,
            "speed_ratio": model.ratio,
            "slip_regularization_m_s": model.contact.slip_regularization_m_s,
            # each gear's axis point (body frame as built): where a friction field's radii start
            "centres_m": {b: [float(v) for v in gm.center(b)] for b in BODIES},
            **balance,
        },
        history=history,
        friction_field=friction_field,
    )


#: Solver statistics that add up over the ranks that solved positions (the others: the largest, or
#: the mean for the ``*_mean`` figures).
_ADDITIVE_INFO = frozenset(
    {
        "dense_factorizations",
        "newton_directions",
        "dense_solve_s",
        "direction_s",
        "state_s",
        "stalled_newton_solves",
        "factorizations",
        "linear_solves",
    }
)


def _solver_info(model: GearContactModel, world: MPI.Comm | None) -> dict:
    """The contact solver's statistics of the cycle: of this model, or merged over the ranks of
    ``world`` that each solved a block of positions (collective on ``world``)."""
    p = model.problem
    info = {
        **(p.info if model.options.solver == "condensed" else {}),
        "stalled_newton_solves": p.stalled,
        "factorizations": p.factorizations,
        "linear_solves": p.linear_solves,
    }
    if world is None:
        return info
    parts = world.allgather(info)
    out = {}
    for k, v in info.items():
        vals = [part[k] for part in parts]
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            out[k] = v
        elif k in _ADDITIVE_INFO:
            out[k] = type(v)(sum(vals))
        elif k.endswith("_mean"):
            out[k] = float(np.mean(vals))
        else:
            out[k] = max(vals)
    return out


def _cell_data(model: GearContactModel, se: _StrainEnergy, body: str):
    """Global (gathered) centroids, volumes and the local->global position map of a body's cells."""
    gm, comm = model.gm, model.comm
    mesh = gm.mesh
    cells = gm.cells(body)
    cells = cells[cells < se.n_owned]
    x = mesh.geometry.x[mesh.geometry.dofmaps[0][cells]].mean(axis=1)
    return cells, _gather(x, comm), _gather(se.volume[cells], comm)


def _sector_fields(
    model, se, w_cells, facet_heat, facet_heat_per_mu, facet_press, pitch
) -> tuple[dict[str, BodyFields], dict[str, float]]:
    """Each gear's fields on its reference tooth sector, and the revolution-averaged friction
    heat per unit mu its reference tooth collects (W per rad/s)."""
    gm, comm = model.gm, model.comm
    out, heat_per_mu = {}, {}
    for b in BODIES:
        center = np.asarray(gm.center(b))
        z = gm.geometry.teeth(b)
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
        # facets: of the contact surface (where the heat is generated) and of the reference tooth
        # (where its revolution average is collected from the images)
        ref = model.surfaces[b].ref
        data = model.surfaces[b].gathered()
        sec_data = model.reference_surfaces[b].gathered()
        fx, area = _facet_centres_and_areas(ref, data.X)
        sx, sec_area = _facet_centres_and_areas(ref, sec_data.X)
        H = np.stack([_gather(h, comm) for h in facet_heat[b]])  # (n_pos, n_facets) W per rad/s
        P = np.stack([_gather(p, comm) for p in facet_press[b]])
        fmap = image_map(sx, fx, center, shift, 2.0 * np.sqrt(sec_area))
        dphi = pitch / H.shape[0]
        # revolution average over this gear's revolution, 2π z_b / z_1 of the pinion's angle φ
        # (the images span it: z_b images of a pinion pitch each), per unit ω₁:
        # (z_1 / (2π z_b)) Σ_positions Σ_images (heat density at the image) Δφ
        revolution = 2.0 * math.pi * pitch / pitch_b
        flux = periodic_sum(H / area[None, :], fmap) * dphi / revolution
        H1 = np.stack([_gather(h, comm) for h in facet_heat_per_mu[b]])
        flux1 = periodic_sum(H1 / area[None, :], fmap) * dphi / revolution
        heat_per_mu[b] = float(np.sum(flux1 * sec_area))
        pmax = periodic_max(P, fmap)
        kinds = _facet_kinds(model, b, model.reference_surfaces[b])
        out[b] = BodyFields(
            center,
            tooth_angle,
            pitch_b,
            xc[sec],
            vol[sec],
            u_max,
            sx,
            sec_area,
            kinds,
            flux,
            pmax,
            u_hist,
            hist_phi,
            np.stack([np.where(fmap.valid[m], fmap.index[m], -1) for m in fmap.images]),
            np.stack([np.where(fmap.valid[m], area[fmap.index[m]], 0.0) for m in fmap.images]),
        )
    return out, heat_per_mu


def _facet_centres_and_areas(ref, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertex centroid and area (degree-2 quadrature) of facets with node coordinates ``X``."""
    area = np.zeros(len(X))
    qp, qw = ref.quadrature(2)
    for p_, w_ in zip(qp, qw):
        _, a1, a2, _ = evaluate(ref, X, np.tile(p_, (len(X), 1)))
        area += w_ * np.linalg.norm(np.cross(a1, a2), axis=1)
    return X[:, : ref.num_vertices].mean(axis=1), area


def _facet_kinds(model: GearContactModel, body: str, surf) -> np.ndarray:
    """Group kind (drive_flank, tip, root) of every facet of ``surf``, gathered order."""
    local = model.gm.facet_groups(body, surf.facets)[1]
    return np.concatenate(model.comm.allgather(local))


def _sector_energies(
    model, se, w_first: np.ndarray, w_shifted: np.ndarray, pitch: float
) -> dict[str, tuple[SectorEnergy, ...]]:
    """Strain energy per tooth sector at start + pitch against the start, one tooth over.

    By periodicity the pinion's sector k at start + pitch holds what sector k + 1 held at the start
    (the wheel's sector k what its sector k − 1 held). Interior sectors only (away from the cuts).
    """
    gm, comm = model.gm, model.comm
    out = {}
    for b in BODIES:
        center = np.asarray(gm.center(b))
        angles = gm.tooth_angles(b)
        pitch_b = 2.0 * math.pi / gm.geometry.teeth(b)
        cells, xc, vol = _cell_data(model, se, b)
        W0, W1 = _gather(w_first[cells], comm), _gather(w_shifted[cells], comm)
        step = 1 if b == "pinion" else -1
        sectors = []
        for k in range(1, len(angles) - 1):
            j = k + step
            if not 1 <= j <= len(angles) - 2:
                continue
            sk = in_sector(xc, center, angles[k], pitch_b)
            sj = in_sector(xc, center, angles[j], pitch_b)
            sectors.append(
                SectorEnergy(
                    sector=k,
                    shifted_J=float(np.sum(W1[sk] * vol[sk])),
                    mapped_J=float(np.sum(W0[sj] * vol[sj])),
                )
            )
        out[b] = tuple(sectors)
    return out
