"""Does the contact temperature that decides a glass-transition branch converge with the mesh?

Under a friction law that steps at the glass transition, a gear switches to its hot branch where
its contacts' temperature (flank + flash) crosses T_g. This script takes the structural cycles of
the built-in case at the three entry refinements of the branch study (``[mesh] size_entry_mm``
x 1.5, x 1, / 1.5) and evaluates, with the flank held at one temperature (``--flank-C``, the
same for every mesh, so that only the cycle's pressures differ), per bench point and gear, per
flash width (``[friction] flash_width``: the Hertz width of each band's load, its pressure
profile's width, or stated half-widths) and per scale of each gear's pass of the contact history
(``[friction] pass_balance``: the cycle's, once per gear, or each tooth pair's load at every
position):

* the largest contact temperature of any contact point and the gear's friction heat (W) at the
  flank temperature ``--flank-C``;
* the flank temperature at which 10 % and 50 % of the gear's friction heat is generated above T_g
  (the contacts already rubbery: where the switching to the hot branch starts), with its GCI over
  the three entry sizes, and at the tip-round radii 0.1 / 0.2 / 0.3 mm.

A quantity that decides a branch should move less between the two finer meshes than between the
two coarser ones, and by less than its distance to T_g. No thermal solve: the cycles are read
from the cache (or solved).

    python benchmarks/verification/flash_convergence.py [--stated-um 100 300]
        [--pass-balance cycle tooth] [--docs PAGE]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time

import numpy as np

# the branch study's bench points and variants (this script's folder is on sys.path when run)
from branch_switching import POINTS, TIP_ROUND_COEFFICIENTS, entry_variants, tip_round_variants
from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.baselines import effective_modulus_Pa, hertz_line_contact
from gearfem.config import load_case
from gearfem.contact.friction import PASS_BALANCES, FrictionOptions
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.gci import convergence
from gearfem.core.log import setup_logging
from gearfem.core.materials import ZERO_CELSIUS_K
from gearfem.coupling.friction_heat import (
    NEGLIGIBLE_HEAT,
    FrictionFlux,
    contact_bands,
    reference_instances,
)
from gearfem.geometry.options import BODIES
from gearfem.uncertainty import provenance


def nominal_half_width_m(case, torque_Nm: float) -> float:
    """Hertz half-width of the nominal normal load (torque over the pinion's base radius, over
    the face width) on the two involutes' radii of curvature at the pitch point (m)."""
    g, mats = case.geometry, case.materials
    alpha = math.radians(g.pressure_angle_deg)
    r1 = 0.5 * g.module_mm * 1e-3 * g.teeth_pinion
    r2 = 0.5 * g.module_mm * 1e-3 * g.teeth_wheel
    load = torque_Nm / (r1 * math.cos(alpha)) / (g.face_width_mm * 1e-3)
    e_star = effective_modulus_Pa(
        mats["pinion"].youngs_modulus_Pa,
        mats["pinion"].poissons_ratio,
        mats["wheel"].youngs_modulus_Pa,
        mats["wheel"].poissons_ratio,
    )
    a, _ = hertz_line_contact(load, r1 * math.sin(alpha), r2 * math.sin(alpha), e_star)
    return float(a)


class GearFriction:
    """One gear's friction heat under the case's law at a uniform flank temperature."""

    def __init__(self, case, cyc, speed: float, body: str) -> None:
        f = case.friction
        self.law = case.friction_law()
        self.bands = contact_bands(
            cyc,
            body,
            case.materials,
            speed,
            case.sources.heat_partition,
            case.sources.heat_fractions(case.materials)[body],
            NEGLIGIBLE_HEAT,
            f.band_model,
        )
        self.inst = reference_instances(cyc, self.bands)
        self.model = FrictionFlux(self.law, self.bands, self.inst, f.contact_temperature)
        self.area = cyc.fields[body].facet_area_m2
        self.teeth = 2.0 * np.pi / cyc.pitch_angle_rad

    def at(self, flank_K: float) -> tuple[float, float, float]:
        """(largest contact temperature C, share of the heat above T_g, the gear's heat W)."""
        state = self.model.evaluate(np.full(self.inst.num_targets, flank_K))
        heat = self.bands.heat[self.inst.point] * self.inst.weight * state.mu
        tc = state.contact_K
        above = float(np.sum(heat[tc > self.law.tg_K]) / np.sum(heat))
        watts = float(self.teeth * np.sum(state.flux_W_m2 * self.area))
        return float(np.max(tc)) - ZERO_CELSIUS_K, above, watts

    def switching_flank_C(self, share: float) -> float:
        """The uniform flank temperature (C) at which ``share`` of the heat is generated above
        T_g (bisection to 0.05 K between ambient and T_g; NaN: outside)."""
        lo, hi = 0.0 + ZERO_CELSIUS_K, self.law.tg_K
        if self.at(lo)[1] >= share:
            return float("nan")
        while hi - lo > 0.05:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if self.at(mid)[1] >= share else (mid, hi)
        return 0.5 * (lo + hi) - ZERO_CELSIUS_K


def pinion_pass_share(cyc) -> tuple[float, float, int]:
    """The pinion's pass's weighted share of each pinion tooth's load (the cycle's tooth loads,
    both passes' weighted sum) over the positions where that tooth carries at least a tenth of
    the largest tooth load: (smallest, largest, position of the largest). 0.5 where the two
    passes agree."""
    h = cyc.history
    w = h.pressure_Pa * h.weight_m2 * h.pass_weight
    peak = max(float(np.max(v)) for v in cyc.tooth_load_N.values())
    shares, where = [], []
    for k, load in cyc.tooth_load_N.items():
        for i in np.flatnonzero(load >= 0.1 * peak):
            own = np.sum(w[(h.position == i) & (h.body == 0) & (h.tooth == k)])
            shares.append(own / load[i])
            where.append(int(i))
    j = int(np.argmax(shares))
    return float(min(shares)), float(shares[j]), where[j]


def gear_rows(case, comm, mu_glassy: float, models, flank_K: float) -> dict:
    """Per (width, half-width, pass balance, speed, torque, body) of ``models`` (width,
    half-width, pass balance): the figures of :class:`GearFriction` on this case's cycles
    (collective: the cycles)."""
    out = {}
    for speed, torque in POINTS:
        c0 = case.with_operating(speed_rpm=speed, torque_Nm=torque)
        cyc, _, _ = pipeline.cycle(c0, comm)
        out[("pass share", torque)] = pinion_pass_share(cyc)
        for width, half, balance in models:
            fr = FrictionOptions(
                law="glass_transition",
                mu_glassy=mu_glassy,
                flash_width=width,
                flash_half_width_um=half,
                pass_balance=balance,
            )
            c = dataclasses.replace(c0, friction=fr)
            for body in BODIES:
                g = GearFriction(c, cyc, speed, body)
                tmax, _, watts = g.at(flank_K)
                out[(width, half, balance, speed, torque, body)] = (
                    tmax,
                    watts,
                    g.switching_flank_C(0.1),
                    g.switching_flank_C(0.5),
                )
    return out


def _join(values, fmt: str) -> str:
    return " / ".join(format(x, fmt) for x in values)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mu-glassy", type=float, default=0.13)
    ap.add_argument("--flank-C", type=float, default=60.0, help="the flank temperature (C)")
    ap.add_argument("--stated-um", type=float, nargs="*", default=[100.0, 300.0])
    ap.add_argument("--pass-balance", choices=PASS_BALANCES, nargs="*", default=list(PASS_BALANCES))
    ap.add_argument("--docs", default=None, help="write the table into this page")
    a = ap.parse_args()
    setup_logging("WARNING")
    comm = MPI.COMM_WORLD
    base = load_case(None)
    widths = [("hertz", None), ("profile", None)] + [("stated", s) for s in a.stated_um]
    models = [(w, half, b) for b in a.pass_balance for w, half in widths]
    flank_K = a.flank_C + ZERO_CELSIUS_K
    t0 = time.perf_counter()
    g = base.geometry
    entries = entry_variants(base)
    entry = [e for e, _ in entries]
    # one gear_rows per variant case: the entry refinement (coarse to fine), the tip rounds
    levels = [gear_rows(c, comm, a.mu_glassy, models, flank_K) for _, c in entries]
    rounds = {
        k: gear_rows(c, comm, a.mu_glassy, models, flank_K) for k, c in tip_round_variants(base)
    }
    rows = []
    split = []
    for e, lv in zip(entry, levels, strict=True):
        for _, torque in POINTS:
            lo, hi, at = lv[("pass share", torque)]
            split.append(
                (f"{torque:g} N m", f"{e * 1e3:.1f}", f"{100 * lo:.0f}-{100 * hi:.0f}", str(at))
            )
    for key in levels[0]:
        if key[0] == "pass share":
            continue
        width, half, balance, speed, torque, body = key
        v = np.array([lv[key] for lv in levels])  # coarse to fine
        conv = convergence(v[:, 2], entry)
        tip = [
            rounds[c][key][2] if c != g.tip_round_coefficient else v[1, 2]
            for c in sorted(rounds | {g.tip_round_coefficient: None})
        ]
        rows.append(
            (
                (f"stated {half:g} um" if width == "stated" else width) + f", {balance}",
                f"{speed:g} rpm, {torque:g} N m",
                body,
                _join(v[:, 0], ".0f"),
                _join(v[:, 1], ".2f"),
                _join(v[:, 2], ".1f"),
                f"{conv.values[0]:.1f} ± {conv.u_num:.1f}"
                + ("" if conv.asymptotic else " (not asymptotic)"),
                _join(tip, ".1f"),
                _join(v[:, 3], ".1f"),
            )
        )
    radii = sorted(set(TIP_ROUND_COEFFICIENTS) | {g.tip_round_coefficient})
    head = (
        "flash width, pass balance",
        "bench point",
        "gear",
        f"largest contact at {a.flank_C:g} C flank (C)",
        f"friction heat at {a.flank_C:g} C flank (W)",
        "flank where 10 % of the heat is rubbery (C)",
        "finest ± u_num (C)",
        "10 %, tip round " + " / ".join(f"{c * g.module_mm:.1f}" for c in radii) + " mm (C)",
        "50 % (C)",
    )
    law = dataclasses.replace(
        base, friction=FrictionOptions(law="glass_transition", mu_glassy=a.mu_glassy)
    ).friction_law()
    sizes = " / ".join(f"{e * 1e3:.1f}" for e in entry)
    nominal = ", ".join(
        f"{nominal_half_width_m(base, t) * 1e6:.0f} um at {t:g} N m" for _, t in POINTS
    )
    note = (
        f"\n\nBuilt-in case; three entries per cell: entry elements {sizes} um (the entry "
        f"refinement of the branch study); glass-transition friction, glassy mu {a.mu_glassy:g} "
        f"(T_g {law.tg_K - ZERO_CELSIUS_K:g} C); every flank at one temperature (no thermal "
        "solve: only the cycles' pressures differ). The Hertz half-width of the nominal load "
        f"at the pitch point: {nominal}. u_num: GCI of the finest entry size / 1.15 "
        "(gearfem.core.gci). `python benchmarks/verification/flash_convergence.py"
        + (
            f" --stated-um {' '.join(f'{s:g}' for s in a.stated_um)}"
            if a.stated_um != [100.0, 300.0]
            else ""
        )
        + (
            f" --pass-balance {' '.join(a.pass_balance)}"
            if a.pass_balance != list(PASS_BALANCES)
            else ""
        )
        + f"`, {time.perf_counter() - t0:.0f} s."
    )
    split_head = (
        "torque",
        "entry elements (um)",
        "pinion pass's share of a tooth's load (%)",
        "position of the largest share",
    )
    table = (
        markdown_table(head, rows)
        + "\n\nEach gear's pass of the two-pass contact, against the load the cycle reports per "
        "tooth (both passes' weighted sum; 50 % where they agree), over the positions where the "
        "tooth carries a tenth of the largest load or more:\n\n"
        + markdown_table(split_head, sorted(split))
    )
    if comm.rank == 0:
        print(table + note)
        if a.docs:
            replace_block(a.docs, "flash_convergence", table + note, provenance(base))


if __name__ == "__main__":
    main()
