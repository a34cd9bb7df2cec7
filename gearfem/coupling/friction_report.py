"""What a run reports about its friction: heat, mu and contact temperatures on the flank, branches.

* :func:`friction_model` gives the :class:`~gearfem.coupling.friction_heat.ThermalFrictionFlux` of
  any law on a thermal problem (the one the sources already use when the law depends on
  temperature, else one built for the report), and :func:`evaluate_at` evaluates it at the
  problem's current temperature (each flank cell's flank-mean temperature, as the solver does).
* :func:`flank_maps` gathers, for the flank cells of one tooth, the largest contact temperature
  over the engagement, the heat-weighted mean mu and the largest flash temperature, with the
  cell's radius and face-width position; :func:`plot_flank_maps` draws them (PNG).
* :func:`branch_starts` chooses the starts of the steady-state search of a law whose heat may rise
  with temperature: ambient, the end of the transient, and a hot uniform field.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_vector
from mpi4py import MPI
from petsc4py import PETSc

from gearfem.contact.friction import DEFAULT_BAND_MODEL, BandModel, FrictionLaw
from gearfem.core.forms import kept_form
from gearfem.core.materials import ZERO_CELSIUS_K
from gearfem.coupling.friction_heat import FluxState, ThermalFrictionFlux
from gearfem.coupling.heat_sources import flank_transfer
from gearfem.coupling.options import FluxReconstruction
from gearfem.coupling.transfer import FlankTransfer


def friction_model(
    problem, gear_mesh, body: str, cycle, law: FrictionLaw, materials, speed_rpm: float,
    partition: str, fixed_fraction: float, contact_temperature: str,
    reconstruction: FluxReconstruction | None = None, band_model: BandModel = DEFAULT_BAND_MODEL,
) -> ThermalFrictionFlux:  # fmt: skip
    """The temperature-dependent friction flux of ``law`` on ``problem``'s mesh (the sources' own
    model when they have one; collective)."""
    model = problem.sources.flank_flux_model
    if isinstance(model, ThermalFrictionFlux):
        return model
    tr = flank_transfer(
        problem.domain, gear_mesh, body, cycle.fields[body], reconstruction=reconstruction
    )
    return ThermalFrictionFlux(
        tr,
        cycle,
        body,
        law,
        materials,
        speed_rpm,
        partition,
        fixed_fraction,
        contact_temperature,
        band_model,
    )


def flank_mean_temperature(problem, transfer: FlankTransfer) -> np.ndarray:
    """Each local cell's mean temperature over its facets on the transfer's surfaces (K; 0 off
    them), with the thermal problem's surface quadrature (collective)."""
    dom = problem.domain
    ds = ufl.Measure(
        "ds",
        domain=dom.mesh,
        subdomain_data=dom.facet_tags,
        metadata={"quadrature_degree": 2 * problem.options.degree + 3},
    )(dom.tags(transfer.names))
    w = ufl.TestFunction(transfer.Q)
    out = []
    for expr in (problem.T * w * ds, w * ds):
        b = assemble_vector(kept_form(expr))
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        out.append(b.array.copy())
        b.destroy()
    f = fem.Function(transfer.Q)
    n = len(out[0])
    f.x.array[:n] = np.where(out[1] > 0, out[0] / np.where(out[1] > 0, out[1], 1.0), 0.0)
    f.x.scatter_forward()
    return f.x.array


def evaluate_at(problem, model: ThermalFrictionFlux) -> FluxState:
    """The model at the problem's current temperature (collective)."""
    model.update(flank_mean_temperature(problem, model.transfer))
    return model.state


@dataclasses.dataclass(frozen=True)
class FlankMaps:
    """Per flank facet of one tooth (rank 0; empty elsewhere): radius and face-width position (m),
    flank temperature, largest contact and flash temperatures over the engagement (C), heat-weighted
    mean mu, flux (W/m²)."""

    radius_m: np.ndarray
    z_m: np.ndarray
    flank_C: np.ndarray
    contact_max_C: np.ndarray
    flash_max_K: np.ndarray
    mu_mean: np.ndarray
    flux_W_m2: np.ndarray
    tooth: int


def flank_maps(model: ThermalFrictionFlux, state: FluxState, center, tooth: int | None = None):
    """The maps of :class:`FlankMaps` on ``tooth`` (default: the middle one; collective)."""
    tr, fx = model.transfer, model.flux
    inst = fx.inst
    n = tr.num_cells
    hw = fx._hw
    cmax = np.full(n, -np.inf)
    np.maximum.at(cmax, inst.target, state.contact_K)
    fmax = np.full(n, -np.inf)
    np.maximum.at(fmax, inst.target, state.flash_K)
    w = np.bincount(inst.target, weights=hw, minlength=n)
    mu = np.bincount(inst.target, weights=hw * state.mu, minlength=n) / np.where(w > 0, w, 1.0)
    T = np.zeros(n)
    T[inst.target] = state.contact_K - state.flash_K
    k = tr.num_teeth // 2 if tooth is None else tooth
    sel = tr.tooth == k
    c = tr.cells[sel]
    x = tr.centroid[sel] - np.asarray(center)
    parts = {
        "radius_m": np.linalg.norm(x[:, :2], axis=1),
        "z_m": x[:, 2],
        "flank_C": np.where(w[c] > 0, T[c] - ZERO_CELSIUS_K, np.nan),
        "contact_max_C": np.where(w[c] > 0, cmax[c] - ZERO_CELSIUS_K, np.nan),
        "flash_max_K": np.where(w[c] > 0, fmax[c], np.nan),
        "mu_mean": np.where(w[c] > 0, mu[c], np.nan),
        "flux_W_m2": state.flux_W_m2[c],
    }
    comm = tr.comm
    gathered = {key: comm.gather(v, root=0) for key, v in parts.items()}
    if comm.rank != 0:
        return None
    return FlankMaps(**{key: np.concatenate(v) for key, v in gathered.items()}, tooth=int(k))


def plot_flank_maps(maps: FlankMaps, path: str | Path, title: str = "") -> None:
    """Contact temperature (max over the engagement) and mean mu over one tooth's flank: radius
    against face-width position (rank 0)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8), sharey=True)
    ok = np.isfinite(maps.contact_max_C)
    panels = (
        (maps.contact_max_C, "max contact temperature (C)", "inferno"),
        (maps.flash_max_K, "max flash temperature (K)", "magma"),
        (maps.mu_mean, "mean mu (heat-weighted)", "viridis"),
    )
    for ax, (val, label, cmap) in zip(axes, panels):
        sc = ax.scatter(
            maps.z_m[ok] * 1e3, maps.radius_m[ok] * 1e3, c=val[ok], s=14, cmap=cmap, marker="s"
        )
        ax.scatter(maps.z_m[~ok] * 1e3, maps.radius_m[~ok] * 1e3, c="0.85", s=6, marker="s")
        fig.colorbar(sc, ax=ax, label=label)
        ax.set_xlabel("face width position (mm)")
        ax.set_title(label)
    axes[0].set_ylabel("radius (mm)")
    fig.suptitle(title or f"flank of tooth {maps.tooth}: where mu acts and how hot the contact is")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def summary(model: ThermalFrictionFlux, state: FluxState) -> dict[str, Any]:
    """Friction heat into the modelled sector (W, at the flank-mean temperatures), heat-weighted
    mu, contact and flash temperatures (largest and heat-weighted mean), Peclet numbers."""
    fx, tr = model.flux, model.transfer
    comm = tr.comm
    hw = fx._hw
    heat = state.flux_W_m2[tr.cells] * tr.area
    q = comm.allreduce(float(np.sum(heat)), op=MPI.SUM)

    def total(v):
        return comm.allreduce(float(np.sum(v)), op=MPI.SUM)

    def gmax(v):
        return comm.allreduce(float(np.max(v)) if len(v) else -math.inf, op=MPI.MAX)

    flash = state.flash_K
    w_mu = max(total(hw), 1e-300)  # mu weighted by the heat per unit mu
    w_heat = max(total(hw * state.mu), 1e-300)  # temperatures weighted by the heat
    return {
        "law": model.law.describe(),
        "contact_temperature": "flank + flash" if fx.flash else "flank",
        "partition": model.bands.partition,
        "friction_W_model": q,
        "mu_heat_weighted": total(hw * state.mu) / w_mu,
        "mu_min": -gmax(-state.mu),
        "mu_max": gmax(state.mu),
        "contact_C_heat_weighted": total(hw * state.mu * state.contact_K) / w_heat - ZERO_CELSIUS_K,
        "contact_C_max": gmax(state.contact_K) - ZERO_CELSIUS_K,
        "flash_K_heat_weighted": total(hw * state.mu * flash) / w_heat,
        "flash_K_max": gmax(flash),
        "peclet": model.bands.peclet_summary(),
        "dropped_heat_fraction": model.bands.dropped_heat_fraction,
        "evaluations": model.evaluations,
    }


def branch_starts(problem, law: FrictionLaw, transient_end: np.ndarray | None) -> dict[str, Any]:
    """Starts of the steady-state search: ambient, the transient's end (when there is one) and a
    hot uniform field, above both the transient's maximum and the law's transition."""
    amb = problem.initial_K
    starts: dict[str, Any] = {"cold": amb}
    hot = amb + 150.0
    if transient_end is not None:
        f = fem.Function(problem.V)
        f.x.array[:] = transient_end
        starts["transient"] = f
        top = problem.comm.allreduce(float(np.max(transient_end)), op=MPI.MAX)
        hot = max(hot, top + 100.0)
    tg = getattr(law, "tg_K", None)
    if tg is not None:
        hot = max(hot, tg + 60.0)
    starts["hot"] = hot
    return starts


__all__ = [
    "FlankMaps",
    "branch_starts",
    "evaluate_at",
    "flank_maps",
    "flank_mean_temperature",
    "friction_model",
    "plot_flank_maps",
    "summary",
]
