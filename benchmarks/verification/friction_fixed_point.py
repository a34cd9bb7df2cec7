"""The cycle ↔ heat fixed point of a friction law in the cycle's mu: how far the structural
cycle's constant mu moves the readings of a law whose contacts run at another mu, with the law's
mu at each contact in the cycle or one effective mu for all of them.

The structural cycle is solved with one constant mu (``[contact] friction_coefficient``, 0.5 as
in the thesis); the heat and the torque meters follow the case's friction law at every contact
point, at its contact temperature (gearfem.coupling.friction_heat). docs/friction.md (block
``friction_tractions``) shows that a cycle at a glassy mu differs from one at 0.5 by more than
u_num. This script runs the loop ``gearfem run`` runs with ``[friction] cycle_mu = "law"``
(``--cycle-mu law``, the default: the law's mu at each contact band of the cycle) or
``"effective"`` (one effective mu for every contact) (gearfem.pipeline.thermal_stages), at each
bench point (1000 rpm / 8 N m, 2000 rpm / 4 N m) of the built-in case under the glass-transition
law:

1. solve the cycle at mu_c everywhere (first the case's 0.5, or with ``--start glassy`` the glassy
   mu: the mu of every contact of a gear at ambient, where a run from ambient starts), after the
   first pass of ``law`` with the law's mu of the previous pass at each contact band;
2. on it, the law's steady state (gearfem.thermal.branches: the lowest branch, by continuation),
   and beside it the run from ambient to 900 s;
3. read the law's effective mu as the torque meters read it, mu_eff = mu_c · P_law / P_cycle (the
   law's friction power at the steady state over the cycle's own at mu_c: the mu of a
   constant-mu cycle that dissipates what the law does);
4. mu_c <- mu_eff (``law``: and the field of the band mu) and repeat until mu_c (``law``: the
   band mu, heat-weighted mean move) changes by less than ``--tol`` (at most ``--max-iter``
   cycles; not converged is an error).

Per iteration it prints mu_c, mu_eff, each gear's heat-weighted mu (its branch: above the glassy
and rubbery mean, the gear runs hot), the law's friction heat, the torque loss, the transmission
error, the largest tooth-pair load and the camera reading at 900 s (when the bench read it) and
in the steady state, with the u_num of the case's
resolution where a filed study measures the quantity; with ``law`` also the range of the law's
band mu and how far it moved from the mu the cycle had at the bands (heat-weighted mean, largest).
One effective mu is a first-order coupling: the law's mu differs between contacts (a hot and a
cool gear run at different mu at the same time) and the cycle takes one value for all of them.

Prints the table and, with ``--docs PAGE``, writes it into block ``--block`` (default
``friction_fixed_point``) of PAGE.

    mpirun -n 2 python benchmarks/verification/friction_fixed_point.py --mu-glassy 0.13 [0.17 ...] \
        [--start glassy] [--points 2000/4] [--cycle-mu law|effective] \
        [--docs docs/friction.md --block friction_fixed_point]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

from mpi4py import MPI
from one_case import CycleLoads, observed_fields, scratch_directory, steady_case

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import load_case
from gearfem.contact.friction import FrictionOptions
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.log import setup_logging
from gearfem.instruments.evaluate import evaluate
from gearfem.study import parse_points
from gearfem.uncertainty import provenance, run_uncertainty

#: The bench points (speed rpm, torque N m).
POINTS = ((1000.0, 8.0), (2000.0, 4.0))
DEFAULT_POINTS = ",".join(f"{s:g}/{t:g}" for s, t in POINTS)
#: When the bench camera was read (s from a cold start).
BENCH_TIME_S = 900.0


@dataclasses.dataclass(frozen=True)
class Iterate:
    """One pass of the loop at one bench point."""

    mu_cycle: float  # with a mu per contact: the mu of contacts without a band
    mu_cycle_mean: float  # the constant mu that dissipates the cycle's friction power
    mu_effective: float
    mu_pinion: float
    mu_wheel: float
    friction_heat_W: float
    torque_loss_Nm: float
    te_mean_um: float
    largest_load_N: float
    camera_C: float
    camera_900_C: float
    wall_s: float
    mu_band_range: tuple[float, float] | None  # the law's mu per band (None: one mu)
    band_move: tuple[float, float] | None  # its move from the cycle's: weighted mean, largest


def _end_reading(case, snap, comm):
    """The camera's reading (C) and the torque meters' reading of ``snap`` at its end value
    (collective; rank 0's, broadcast)."""

    def read():
        r = evaluate(case.instruments, snap)
        label = snap.label_of(None)
        return r.camera[label].max_C, r.torque_at.get(label, r.torque)

    return pipeline.on_root(comm, read)


def _camera_at(case, cyc, comm):
    """The camera's reading (C) of the thermal runs of ``case`` on ``cyc`` at their end value
    (collective)."""
    return _end_reading(case, observed_fields(case, comm, cyc, steady=False), comm)[0]


def fixed_point(case, start_mu: float, comm) -> list[Iterate]:
    """The passes of the cycle ↔ heat fixed point of ``case`` (``[friction] cycle_mu = "law"``,
    steady) from ``start_mu`` (gearfem.pipeline.thermal_stages), each with the camera at 900 s
    from ambient on its cycle (collective)."""
    rows: list[Iterate] = []

    def on_pass(k, c, stages, p):
        # the camera of the steady state the pass's cycle leads to, each gear's heat-weighted mu
        cam, torque = _end_reading(c, stages.snapshot, comm)
        # from ambient to 900 s, when the bench camera was read
        bench = dataclasses.replace(
            c.thermal,
            mode="transient",
            duration_s=BENCH_TIME_S,
            output_times_s=(BENCH_TIME_S,),
            dt_initial_s=min(c.thermal.dt_initial_s, BENCH_TIME_S),
        )
        cam_900 = _camera_at(dataclasses.replace(c, thermal=bench), stages.cycle, comm)
        mu_of = {c.thermal.body: stages.thermal["friction"]["mu_heat_weighted"]}
        for body, summ in stages.others.items():
            mu_of[body] = summ["friction"]["mu_heat_weighted"]
        loads = CycleLoads.of(stages.cycle, c.operating.speed_rpm)
        rows.append(
            Iterate(
                mu_cycle=p.mu_cycle,
                mu_cycle_mean=p.mu_cycle_mean,
                mu_effective=p.mu_effective,
                mu_pinion=float(mu_of["pinion"]),
                mu_wheel=float(mu_of["wheel"]),
                friction_heat_W=p.friction_power_law_W,
                torque_loss_Nm=torque.torque_loss_Nm,
                te_mean_um=loads.te_mean_um,
                largest_load_N=loads.largest_load_N,
                camera_C=cam,
                camera_900_C=cam_900,
                wall_s=p.wall_time_s,
                mu_band_range=p.mu_band_range,
                band_move=None if p.field_change is None else (p.field_change, p.field_change_max),
            )
        )
        if comm.rank == 0:
            print(f"{c.operating.speed_rpm:g} rpm / {c.operating.torque_Nm:g} N m, pass {k}: "
                  f"{rows[-1]}", flush=True)  # fmt: skip

    with scratch_directory(comm) as out:
        pipeline.thermal_stages(
            steady_case(case),
            out,
            comm,
            progress=False,
            write_fields=False,
            write_plot=False,
            start_mu=start_mu,
            on_pass=on_pass,
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--mu-glassy", type=float, nargs="+", default=[0.13], help="the law's glassy mu (several)"
    )
    ap.add_argument(
        "--points",
        default=DEFAULT_POINTS,
        help="operating points 'rpm/Nm,rpm/Nm' (default: the bench points)",
    )
    ap.add_argument("--tol", type=float, default=0.005, help="stop when mu_c moves less")
    ap.add_argument(
        "--cycle-mu",
        choices=("law", "effective"),
        default="law",
        help="the cycle's mu: the law's at each contact band, or one effective mu",
    )
    ap.add_argument("--max-iter", type=int, default=4, help="cycles per bench point at most")
    ap.add_argument(
        "--start",
        choices=("rubbery", "glassy"),
        default="rubbery",
        help="the first cycle's mu: the case's (rubbery, the constant-mu cycle's) or the glassy "
        "mu (every contact of a gear at ambient)",
    )
    ap.add_argument(
        "--block",
        choices=(
            "friction_fixed_point",
            "friction_fixed_point_scan",
            "friction_fixed_point_effective",
        ),
        default="friction_fixed_point",
        help="block of --docs to write",
    )
    ap.add_argument("--case", default=None, help="case TOML (default: the built-in case)")
    ap.add_argument("--docs", default=None)
    a = ap.parse_args()
    setup_logging("WARNING")
    comm = MPI.COMM_WORLD
    base = load_case(a.case)
    points = parse_points(a.points, "--points")
    mu_r = base.contact.friction_coefficient
    t_start = time.perf_counter()
    rows = []
    tg_C = dataclasses.replace(
        base, friction=FrictionOptions(law="glass_transition", mu_glassy=0.1)
    ).friction.glass_transition_C  # the pair's polymer's
    for mu_g in a.mu_glassy:
        law = FrictionOptions(
            law="glass_transition",
            mu_glassy=mu_g,
            cycle_mu=a.cycle_mu,
            cycle_mu_tolerance=a.tol,
            cycle_mu_max_passes=a.max_iter,
        )
        for speed, torque in points:
            case = dataclasses.replace(
                base.with_operating(speed_rpm=speed, torque_Nm=torque), friction=law
            )
            start = mu_r if a.start == "rubbery" else mu_g
            for k, it in enumerate(fixed_point(case, start, comm)):
                rows.append((mu_g, speed, torque, k, it))
    # u_num of the case's resolution, for the quantities its filed studies follow
    first = rows[0][4]
    unc = run_uncertainty(
        base,
        {"camera_max": first.camera_C, "transmission_error_mean_um": first.te_mean_um},
    )
    u_cam = unc.u_num("camera_max") if unc is not None else None
    u_te = unc.u_num("transmission_error_mean_um") if unc is not None else None

    def branch(mu: float, mu_g: float) -> str:
        return "hot" if mu > 0.5 * (mu_g + mu_r) else "cool"

    per_band = a.cycle_mu == "law"

    def band_columns(it: Iterate) -> tuple[str, ...]:
        if not per_band:
            return ()
        lo, hi = it.mu_band_range
        mean, largest = it.band_move
        return (f"{lo:.3f}-{hi:.3f}", f"{mean:.4f} ({largest:.3f})")

    table = markdown_table(
        ("glassy mu", "operating point", "pass")
        + (("cycle mu (no band)", "cycle mu (mean)") if per_band else ("cycle mu",))
        + ("law's effective mu",)
        + (("law's mu per band", "its move from the cycle's (largest)") if per_band else ())
        + ("pinion mu (branch)", "wheel mu (branch)", "friction heat (W)", "torque loss (N m)",
         "TE mean (um)", "largest tooth-pair load (N)", "camera_max, 900 s (C)",
         "camera_max, steady (C)"),
        [
            (
                f"{g:g}",
                f"{s:g} rpm, {t:g} N m",
                str(k),
                f"{it.mu_cycle:.4f}",
                *((f"{it.mu_cycle_mean:.4f}",) if per_band else ()),
                f"{it.mu_effective:.4f}",
                *band_columns(it),
                f"{it.mu_pinion:.3f} ({branch(it.mu_pinion, g)})",
                f"{it.mu_wheel:.3f} ({branch(it.mu_wheel, g)})",
                f"{it.friction_heat_W:.2f}",
                f"{it.torque_loss_Nm:.4f}",
                f"{it.te_mean_um:.2f}",
                f"{it.largest_load_N:.1f}",
                f"{it.camera_900_C:.2f}",
                f"{it.camera_C:.2f}",
            )
            for g, s, t, k, it in rows
        ],
    )  # fmt: skip
    u_text = (
        f"u_num of the resolution at the first pass: camera {u_cam:.2g} K, TE {u_te:.2g} um"
        if u_cam is not None and u_te is not None
        else "no u_num filed for this resolution"
    )
    which = "The built-in case" if a.case is None else f"Case {a.case}"
    mus = " ".join(f"{g:g}" for g in a.mu_glassy)
    command = (
        f"mpirun -n {comm.size} python benchmarks/verification/friction_fixed_point.py "
        f"--mu-glassy {mus}"
        + ("" if a.points == DEFAULT_POINTS else f" --points {a.points}")
        + ("" if a.start == "rubbery" else f" --start {a.start}")
        + ("" if a.cycle_mu == "law" else f" --cycle-mu {a.cycle_mu}")
        + ("" if a.case is None else f" --case {a.case}")
    )
    note = (
        f"\n\n{which}, glass-transition friction (T_g {tg_C:g} C, rubbery mu "
        f"{mu_r:g}), ambient "
        f"{base.thermal.ambient_C:g} C; the first cycle at the {a.start} mu everywhere; "
        + (
            "each later pass solves the cycle with the law's mu of the pass before at each "
            "contact band (each gear's pass at its own contact temperature; the cycle mu, the "
            "effective mu of the pass before, where a contact has no band), "
            if per_band
            else "each later pass solves the cycle at the effective mu of the pass before "
            "everywhere, "
        )
        + "the run from ambient to 900 s and the steady state it leads to, and reads the law's "
        "effective mu, m_c P_law / P_cycle (m_c the constant mu that dissipates the cycle's "
        "friction power"
        + (": the heat-weighted mean of its mu per contact" if per_band else "")
        + "), from the torque meters"
        + (
            " and the law's mu per band at the steady state, with its heat-weighted mean move "
            "from the mu the cycle had at the bands (and the largest at a band carrying 0.1 % "
            "of the largest band's heat)"
            if per_band
            else ""
        )
        + "; a gear's mu is its heat-weighted mean at "
        "the steady state (hot above the mean of the glassy and the rubbery mu). "
        f"{u_text}. `{command}`, {time.perf_counter() - t_start:.0f} s."
    )
    if comm.rank == 0:
        print(table + note)
        if a.docs:
            replace_block(a.docs, a.block, table + note, provenance(base))


if __name__ == "__main__":
    main()
