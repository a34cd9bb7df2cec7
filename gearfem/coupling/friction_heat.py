"""Friction heat of any friction law from the cycle's contact history, with flash temperatures.

Physical model. Every contact point e of the cycle's history (:mod:`gearfem.cycle.history`) at
every position dissipates q_e = mu_e p_e (ŝ·v_T)_e per unit area; its revolution average on a flank
facet j of the reference tooth is (thesis eq. 5.10, as :func:`gearfem.cycle.solve.solve_cycle`)

    q_j = 1/(2 pi) sum_(images m, positions i) sum_(e on the image facet) mu_e p_e (ŝ·v_T)_e dA_e
          / A_(image facet) * dphi * c,

with c the cycle's normalisation of its two contact passes
(``info[<gear>_flank_heat_raw_over_total]``, law-independent). The pressures are those of the
cycle's constant mu (first order: the law's effect on the pressure field is neglected). With the
cycle's own constant mu this is the cycle's flux to round-off.

mu_e = mu(T_c,e, p_e, v_s,e) is evaluated at the **contact temperature** T_c = T_flank + theta:
T_flank is the temperature of the flank where the point lies (from the thermal field, or given),
theta the **flash temperature** of the point's band (the contact across the profile at that
position and slice of the face width, :mod:`gearfem.cycle.history`): a semi-elliptic band source
of half-width a (from the band's pressure profile) and mean flux q_bar moving over the flank at
the rolling speed v (the speed of the contact over that surface),

    theta = q_bar a / k * g(L),   L = v a / (2 kappa),

with g the exact 2D moving band-source solution for any Peclet number L
(:func:`gearfem.baselines.band_source_rise`; Blok's 1.11 q_bar sqrt(2a/v)/b for L > 5). The heat
of a band goes into the two gears either by a **fixed** fraction (``[sources]
heat_fraction_pinion`` or the effusivity ratio, today's default) or by **Blok's partition**
(``heat_partition = "blok"``): the share that makes both surfaces' flash temperatures equal,
f = (k1/g1) / (k1/g1 + k2/g2), and then theta = q_bar a / (k1/g1 + k2/g2).

Because the flash temperature grows with mu and mu with it, mu follows the surface temperature
along the contact: a point of the flank passes under the band in the time 2a/v and heats as a
semi-infinite body under the flux it receives (Blok's picture, heat normal to the surface), so
with xi in [-1, 1] across the band, the semi-elliptic pressure shape f(xi) (mean 1) and the
band's mean flank temperature T_b,

    theta(xi) = K int_-1^xi mu_T(T_b + theta(xi')) f(xi') / sqrt(xi - xi') dxi',

a Volterra equation with a unique, continuous solution (solved marching across the band, 48
intervals, product integration of the Abel kernel, mu of each interval at its leading node). K
makes a constant mu = 1 reach the band's flash temperature per unit mu, theta_max = q_bar0 a g / k
(which carries the 2D correction g(L) and the partition); the friction coefficient of a point is
the pressure-weighted mean of mu_T over the profile at the flank temperature T_b of the point's
place, its contact temperature T_b + max theta. The solution depends on T_b and theta0 only, so it
is tabulated once per law (:class:`FlashTable`). (A single band-mean contact temperature would
make mu = mu_T(T_b + theta(mu)) bistable for a steep law: the contact would switch all at once,
and the flux jump with the flank temperature.)

:class:`FrictionFlux` evaluates this for a set of **targets** (reference facets, or the cells of the
thermal mesh next to the flanks) at given target temperatures: flux, its temperature derivative (for
the thermal Newton Jacobian: the derivative through the target's own share of its band's mean flank
temperature), and per point mu, flash and contact temperatures (for the maps). On the thermal mesh
it is the :class:`gearfem.thermal.source_terms.SurfaceFluxModel` that the thermal solver updates at
every residual evaluation (:class:`ThermalFrictionFlux`).
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math

import numpy as np
from mpi4py import MPI

from gearfem.baselines import band_source_rise, peclet_regime
from gearfem.contact.friction import DEFAULT_BAND_MODEL, BandModel, FrictionLaw
from gearfem.core.errors import ParameterError
from gearfem.core.kept import Kept
from gearfem.core.materials import Material
from gearfem.geometry.options import BODIES

log = logging.getLogger(__name__)

PARTITIONS = ("fixed", "blok")
#: A point whose heat weight is below this fraction of the gear's total is left out of the
#: temperature-dependent evaluation (the points outside the loaded zone that the C1 pressure ramp
#: gives a pressure of a few pascal); the heat they carry is reported.
NEGLIGIBLE_HEAT = 1e-12
#: Below this Peclet number the tabulated band solution ends (semi-elliptic band); a band that slow
#: uses the uniform-band low-Peclet solution (reported).
MIN_TABULATED_PECLET = 1e-3


@dataclasses.dataclass(frozen=True)
class ContactBands:
    """One gear's contact points (its pass of the history) at an operating speed, with the flash
    temperature per unit flux and the heat partition of each band.

    Per point (arrays over the kept points): ``event`` (index into the history), ``heat`` = p ŝ·v_T
    at the speed (W/m² per unit mu), ``pressure_Pa``, ``slip_speed_m_s`` (|v_T| at the speed),
    ``band`` (0..n_bands-1), ``facet`` (gathered contact-surface facet), ``weight_m2``.
    Per band: ``q0_W_m2`` (mean flux over the band per unit mu), ``flash_per_flux_K_m2_W``
    (theta / q_bar for this gear's surface), ``fraction`` (share of the band's heat into this gear),
    ``peclet`` and ``mate_peclet``, ``half_width_m``, ``hertz_half_width_m``,
    ``load_per_length_N_m``, ``position``, ``tooth``. A band whose points all lie at one profile
    coordinate (a contact narrower than the quadrature spacing) has no measurable profile width:
    its half-width is the Hertz half-width of its load (``hertz_width_used`` marks them).
    """

    body: str
    speed_rpm: float
    partition: str
    event: np.ndarray
    heat: np.ndarray
    pressure_Pa: np.ndarray
    slip_speed_m_s: np.ndarray
    band: np.ndarray
    facet: np.ndarray
    weight_m2: np.ndarray
    q0_W_m2: np.ndarray
    flash_per_flux_K_m2_W: np.ndarray
    fraction: np.ndarray
    peclet: np.ndarray
    mate_peclet: np.ndarray
    half_width_m: np.ndarray
    hertz_half_width_m: np.ndarray
    load_per_length_N_m: np.ndarray
    position: np.ndarray
    tooth: np.ndarray
    dropped_heat_fraction: float
    low_peclet_bands: int
    hertz_width_used: np.ndarray  # per band: a is the Hertz width (asked for, or no profile width)
    heat_norm: float = 1.0  # the cycle's pass heat over the scaled pass's (pass_balance)

    @property
    def num_bands(self) -> int:
        return len(self.q0_W_m2)

    def peclet_summary(self) -> dict[str, float | int | str]:
        """Smallest, median and largest Peclet number of the loaded bands on either surface and the
        regime of the smallest (Jaeger's ranges: low < 0.1 < intermediate < 5 < high)."""
        if not self.num_bands:
            return {"bands": 0}
        both = np.concatenate([self.peclet, self.mate_peclet])
        lo = float(both.min())
        return {
            "bands": self.num_bands,
            "min": lo,
            "median": float(np.median(both)),
            "max": float(both.max()),
            "regime_of_min": peclet_regime(lo),
            "low_peclet_bands": self.low_peclet_bands,
        }


def _rise(peclet: np.ndarray) -> tuple[np.ndarray, int]:
    """g(L) of the semi-elliptic band; below the table the uniform band's low-Peclet form."""
    low = peclet < MIN_TABULATED_PECLET
    g = np.empty_like(peclet)
    if np.any(~low):
        g[~low] = band_source_rise(peclet[~low], "semi_elliptic", "max")
    if np.any(low):
        g[low] = band_source_rise(np.maximum(peclet[low], 1e-300), "uniform", "max")
    return g, int(np.count_nonzero(low))


def tooth_balance(history, pair_distance_m: float) -> np.ndarray:
    """Per point of the contact history: the scale that makes its pass carry the load of its
    tooth pair at its position (``[friction] pass_balance = "tooth"``).

    Each gear's pass estimates the contact pressure from its own side (it is the slave); the load
    the solver balances, and the cycle's tooth loads report, is the passes' weighted sum,
    L = sum over both passes of w_pass int p dA over the pair's contact. Where the two passes
    disagree about a pair's contact (near a corner, one side's points see a penetration the
    other's do not) a gear's pass alone carries more or less than L there; the cycle scales each
    pass once, over the whole cycle (its heat to the mesh's friction power). This scale instead
    makes each (position, gear, tooth) group of the pass integrate to L, the pair's own load:
    s = L / int p dA. A gear's tooth and the mate's tooth it meshes with at a position are the two
    passes' groups whose pressure-weighted centroids lie within ``pair_distance_m`` (the pairs in
    contact at one position are a base pitch apart); a group the other pass saw no contact for
    carries its own weighted share."""
    h = history
    w = h.pressure_Pa * h.weight_m2
    key = np.stack([h.position, h.body, h.tooth], axis=1)
    groups, g = np.unique(key, axis=0, return_inverse=True)
    g = g.ravel()
    n = len(groups)
    own = np.bincount(g, weights=w, minlength=n)
    share = np.bincount(g, weights=w * h.pass_weight, minlength=n)
    centroid = (
        np.stack(
            [np.bincount(g, weights=w * h.point_m[:, d], minlength=n) for d in range(3)], axis=1
        )
        / np.maximum(own, 1e-300)[:, None]
    )
    load = share.copy()
    for i in np.flatnonzero(own > 0):
        mates = np.flatnonzero(
            (groups[:, 0] == groups[i, 0]) & (groups[:, 1] != groups[i, 1]) & (own > 0)
        )
        if len(mates):
            d = np.linalg.norm(centroid[mates] - centroid[i], axis=1)
            if d.min() < pair_distance_m:
                load[i] += share[mates[np.argmin(d)]]
    return np.where(own > 0, load / np.where(own > 0, own, 1.0), 1.0)[g]


def contact_bands(
    cycle,
    body: str,
    materials: dict[str, Material],
    speed_rpm: float,
    partition: str = "fixed",
    fixed_fraction: float = 0.5,
    negligible: float = 0.0,
    band_model: BandModel = DEFAULT_BAND_MODEL,
) -> ContactBands:
    """The contact points of ``body``'s pass and its bands at pinion speed ``speed_rpm``; points
    carrying less than ``negligible`` of the gear's heat are left out (0: only those carrying
    none). ``band_model``: the bands' half-width a (flux q̄ = heat / (2 a dz), flash ∝ q̄ a g(L)):
    ``"hertz"``, the Hertz half-width of the band's load on the local radii (tip rounds
    included), ``"profile"``, the width of its pressure profile (the Hertz width where the
    profile has none), or ``"stated"``, one half-width for every band; and the scale of the pass
    (``pass_balance``: :func:`tooth_balance`): see
    :class:`~gearfem.contact.friction.FrictionOptions`."""
    flash_width = band_model.flash_width
    if partition not in PARTITIONS:
        raise ParameterError("sources.heat_partition", partition, f"one of {PARTITIONS}")
    h = cycle.history
    if h is None:
        raise ParameterError(
            "cycle history", None, "a cycle solved with the contact history (re-run the cycle)"
        )
    omega = 2.0 * math.pi * speed_rpm / 60.0
    sel = np.flatnonzero(h.of(body))
    work = h.dissipation_speed_m_s[sel] * h.weight_m2[sel]  # heat per unit pressure and omega
    if band_model.pass_balance == "tooth":
        scale = tooth_balance(h, 0.5 * cycle.base_pitch_m)
        pressure = h.pressure_Pa * scale
        # the scaled pass's heat is normalised as the cycle's was (to the mesh's friction power)
        scaled = float(np.sum(pressure[sel] * work))
        heat_norm = float(np.sum(h.pressure_Pa[sel] * work)) / scaled if scaled > 0 else 1.0
    else:  # the cycle's own scale of the pass
        scale, pressure, heat_norm = None, h.pressure_Pa, 1.0
    heat_all = pressure[sel] * work * omega
    total = float(np.sum(heat_all))
    keep = heat_all > negligible * total if total > 0 else heat_all > 0
    dropped = float(np.sum(heat_all[~keep]) / total) if total > 0 else 0.0
    ev = sel[keep]
    bands, band = np.unique(h.band[ev], return_inverse=True)
    band = band.ravel()
    nb = len(bands)
    heat = pressure[ev] * h.dissipation_speed_m_s[ev] * omega
    dA = h.weight_m2[ev]
    hw = heat * dA
    hb = np.maximum(np.bincount(band, weights=hw, minlength=nb), 1e-300)
    first = np.zeros(nb, dtype=np.int64)
    first[band[::-1]] = np.arange(len(band))[::-1]
    # one scale per band (a band lies on one tooth)
    band_scale = scale[ev][first] if scale is not None else np.ones(nb)
    a_hertz = h.hertz_half_width_m[ev][first] * np.sqrt(band_scale)  # a ~ sqrt(load)
    a = h.half_width_m[ev][first]
    if flash_width == "stated":
        unresolved = np.zeros(nb, dtype=bool)
        a = np.full(nb, float(band_model.flash_half_width_m))
    else:
        unresolved = ~(a > 0.0) if flash_width == "profile" else np.ones(nb, dtype=bool)
        a = np.where(unresolved, a_hertz, a)
    q0 = hb / (2.0 * a * h.z_bin_m)
    mate = BODIES[1 - BODIES.index(body)]
    ms, mm = materials[body], materials[mate]
    v_s = np.bincount(band, weights=hw * h.rolling_speed_m_s[ev], minlength=nb) / hb * omega
    v_m = np.bincount(band, weights=hw * h.mate_rolling_speed_m_s[ev], minlength=nb) / hb * omega
    pe_s = v_s * a / (2.0 * ms.thermal_diffusivity_m2_s)
    pe_m = v_m * a / (2.0 * mm.thermal_diffusivity_m2_s)
    g_s, low_s = _rise(pe_s)
    g_m, low_m = _rise(pe_m)
    if partition == "fixed":
        frac = np.full(nb, float(fixed_fraction))
        flash = frac * a * g_s / ms.thermal_conductivity_W_mK
    else:
        phi_s = ms.thermal_conductivity_W_mK / g_s
        phi_m = mm.thermal_conductivity_W_mK / g_m
        frac = phi_s / (phi_s + phi_m)
        flash = a / (phi_s + phi_m)
    return ContactBands(
        body=body,
        speed_rpm=float(speed_rpm),
        partition=partition,
        event=ev,
        heat=heat,
        pressure_Pa=pressure[ev],
        slip_speed_m_s=h.slip_speed_m_s[ev] * omega,
        band=band,
        facet=h.facet[ev],
        weight_m2=dA,
        q0_W_m2=q0,
        flash_per_flux_K_m2_W=flash,
        fraction=frac,
        peclet=pe_s,
        mate_peclet=pe_m,
        half_width_m=a,
        hertz_half_width_m=a_hertz,
        load_per_length_N_m=h.load_per_length_N_m[ev][first] * band_scale,
        position=h.position[ev][first],
        tooth=h.tooth[ev][first],
        dropped_heat_fraction=dropped,
        low_peclet_bands=low_s + low_m,
        hertz_width_used=unresolved,
        heat_norm=heat_norm,
    )


@dataclasses.dataclass(frozen=True)
class Instances:
    """Which contact point feeds which target, with what weight (W/m² of target flux per W/m² of
    the point's heat p ŝ·v_T mu), and in which group (band on one tooth) it is."""

    point: np.ndarray  # index into ContactBands' point arrays
    target: np.ndarray
    weight: np.ndarray
    group: np.ndarray
    group_band: np.ndarray  # band of each group
    num_targets: int


def reference_instances(cycle, bands: ContactBands) -> Instances:
    """The points of every image of each sector facet of the reference tooth (targets: the
    facets of ``cycle.fields[body]``), weighted as the cycle's revolution average (generated heat
    times the band's partition fraction: the flux into this gear)."""
    body = bands.body
    f = cycle.fields[body]
    index, area = f.facet_image_index, f.facet_image_area_m2
    n_ref = index.shape[1]
    dphi = cycle.pitch_angle_rad / len(cycle.phi_rad)
    raw = cycle.info.get(f"{body}_flank_heat_raw_over_total", 1.0)
    norm = 1.0 / raw if raw and raw > 0 and math.isfinite(raw) else 1.0
    order = np.argsort(bands.facet, kind="stable")
    sf = bands.facet[order]
    pts, tgt, wts = [], [], []
    for m in range(index.shape[0]):
        valid = np.flatnonzero(index[m] >= 0)
        g = index[m][valid]
        lo = np.searchsorted(sf, g, side="left")
        hi = np.searchsorted(sf, g, side="right")
        cnt = hi - lo
        if not np.any(cnt):
            continue
        rows = np.repeat(np.arange(len(valid)), cnt)
        starts = np.repeat(lo, cnt)
        offs = np.arange(len(rows)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        p = order[starts + offs]
        j = valid[rows]
        pts.append(p)
        tgt.append(j)
        wts.append(bands.weight_m2[p] / area[m][j])
    p = np.concatenate(pts) if pts else np.zeros(0, dtype=np.int64)
    j = np.concatenate(tgt) if tgt else np.zeros(0, dtype=np.int64)
    w = np.concatenate(wts) if wts else np.zeros(0)
    # over this gear's revolution: 2π z_b / z_1 of the pinion's angle (as the cycle's average)
    revolution = 2.0 * math.pi * cycle.pitch_angle_rad / f.pitch_angle_rad
    w = w * dphi / revolution * norm * bands.heat_norm * bands.fraction[bands.band[p]]
    return Instances(p, j, w, bands.band[p], np.arange(bands.num_bands), n_ref)


@dataclasses.dataclass
class FluxState:
    """The flux of a law at given target temperatures (see :class:`FrictionFlux`): per target the
    flux and its derivative; per instance (computed when first read) mu, the contact temperature
    (flank temperature of its target + flash) and the flash temperature."""

    flux_W_m2: np.ndarray  # per target
    dflux_dT_W_m2K: np.ndarray  # per target
    _pair: np.ndarray  # the (target, group) pair of each instance
    _pair_mu_T: np.ndarray  # mu_T per pair (before the pressure/speed factor)
    _pair_flank_K: np.ndarray  # flank temperature per pair
    _pair_flash_K: np.ndarray  # flash temperature per pair
    _factor: np.ndarray  # pressure/speed factor per instance

    @functools.cached_property
    def mu(self) -> np.ndarray:
        return self._pair_mu_T[self._pair] * self._factor

    @functools.cached_property
    def flash_K(self) -> np.ndarray:
        return self._pair_flash_K[self._pair]

    @functools.cached_property
    def contact_K(self) -> np.ndarray:
        return self._pair_flank_K[self._pair] + self.flash_K


@dataclasses.dataclass(frozen=True)
class _Volterra:
    """Product-integration weights of the Abel kernel on [-1, 1] (N intervals): W[k, j] =
    int_{xi_j}^{xi_j+1} dxi' / sqrt(xi_k - xi'), j < k; the semi-elliptic shape at the interval
    midpoints; i_max = max_k sum_j W[k, j] f_j (the constant-mu maximum)."""

    W: np.ndarray
    f_mid: np.ndarray
    i_max: float

    @classmethod
    def build(cls, n: int = 48) -> _Volterra:
        xi = np.linspace(-1.0, 1.0, n + 1)
        d = xi[:, None] - xi[None, :]
        W = np.zeros((n + 1, n))
        for k in range(1, n + 1):
            j = np.arange(k)
            W[k, :k] = 2.0 * (np.sqrt(d[k, j]) - np.sqrt(np.maximum(d[k, j + 1], 0.0)))
        mid = 0.5 * (xi[1:] + xi[:-1])
        f = 4.0 / math.pi * np.sqrt(1.0 - mid * mid)
        return cls(W, f, float(np.max(W @ f)))


_VOLTERRA = _Volterra.build()


#: :meth:`FlashTable.of` builds a law's table to the next multiple of this flash per unit mu (K):
#: a table 1-128 K further than asked for (32 rows of about 160 for a reach of 512 K) is
#: reused by every evaluation of the law whose bands' flashes fall under the same multiple.
FLASH_TABLE_REACH_K = 128.0
#: How many bytes of tables :meth:`FlashTable.of` keeps, the most recently used (a table is about
#: 1 MB at a reach of 128 K, 4 MB at 512 K): a diagnosis's surrogate evaluates the same laws (its
#: nodes) at every operating point, 10-20 of them per point, so a count of 8 kept none of them
#: from one point to the next.
KEPT_FLASH_TABLE_BYTES = 256 * 2**20
_FLASH_TABLES: dict[tuple, FlashTable] = {}


@dataclasses.dataclass(frozen=True)
class FlashTable:
    """The Volterra solution tabulated once per law: the profile-mean mu_T and the largest flash
    temperature of a band as functions of its flank temperature T (uniform grid) and its flash
    temperature per unit mu, theta0, bilinear interpolation; flank temperatures 200-1000 K in
    0.5 K steps (constant beyond). theta0 lies on a fixed lattice, 0, 12 geometric steps from
    0.01 to 10 K, then 10 + 4 k K up to the largest band's, so the rows of a table do not depend
    on how far it reaches: :meth:`of` keeps the tables of the laws used last, up to
    :data:`KEPT_FLASH_TABLE_BYTES` (each reaching a multiple of :data:`FLASH_TABLE_REACH_K`), and
    a law evaluated again (another operating point, a refinement of the diagnosis) reuses its
    table. A constant mu_T is
    reproduced exactly (every entry equals it)."""

    T_K: np.ndarray
    theta0_K: np.ndarray
    mu: np.ndarray  # (n_theta0, n_T)
    theta_max_K: np.ndarray  # (n_theta0, n_T)

    @classmethod
    def build(
        cls,
        law: FrictionLaw,
        theta0_max_K: float,
        T_range_K=(200.0, 1000.0),
        dT_K: float = 0.5,
        dtheta0_K: float = 4.0,
    ) -> FlashTable:
        T = np.arange(T_range_K[0], T_range_K[1] + 0.5 * dT_K, dT_K)
        # geometric near 0, then steps of dtheta0_K (a flash theta0 mu changes mu_T over a few
        # kelvin in a steep law), on a lattice that does not depend on theta0_max_K
        small = np.geomspace(1e-2, 10.0, 12)
        steps = max(math.ceil((float(theta0_max_K) - 10.0) / dtheta0_K), 0)
        th = np.concatenate([[0.0], small, 10.0 + dtheta0_K * np.arange(1, steps + 1)])
        Tg = np.tile(T, len(th))
        f0 = np.repeat(th, len(T))
        mbar, theta = _profile(law, Tg, f0)
        return cls(T, th, mbar.reshape(len(th), len(T)), theta.reshape(len(th), len(T)))

    @classmethod
    def of(cls, law: FrictionLaw, theta0_max_K: float) -> FlashTable:
        """The table of ``law`` reaching at least ``theta0_max_K``: built up to the next multiple
        of :data:`FLASH_TABLE_REACH_K` and kept by the law's options and the cycle's mu (what
        mu_T depends on) and that reach, the most recently used up to
        :data:`KEPT_FLASH_TABLE_BYTES`. The same
        law and reach give the same table, whichever was asked for first."""
        reach = FLASH_TABLE_REACH_K * max(math.ceil(theta0_max_K / FLASH_TABLE_REACH_K), 1)
        key = (law.options, law.cycle_mu, reach)
        try:
            hash(key)
        except TypeError:  # options built in code with lists: not kept
            return cls.build(law, reach)
        table = _FLASH_TABLES.pop(key, None)
        if table is None:
            table = cls.build(law, reach)
        _FLASH_TABLES[key] = table  # the most recent last
        kept = sum(t.nbytes for t in _FLASH_TABLES.values())
        while len(_FLASH_TABLES) > 1 and kept > KEPT_FLASH_TABLE_BYTES:
            kept -= _FLASH_TABLES.pop(next(iter(_FLASH_TABLES))).nbytes
        return table

    @property
    def nbytes(self) -> int:
        """Memory of the table's arrays (bytes)."""
        return sum(a.nbytes for a in (self.T_K, self.theta0_K, self.mu, self.theta_max_K))

    def weights(self, theta0_K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Row index and weight of each theta0 in the table."""
        th = self.theta0_K
        a = np.clip(np.searchsorted(th, theta0_K, side="right") - 1, 0, len(th) - 2)
        s = np.clip((theta0_K - th[a]) / (th[a + 1] - th[a]), 0.0, 1.0)
        return a, s

    def lookup(self, a: np.ndarray, s: np.ndarray, T_K: np.ndarray):
        """(mu_T, d mu_T / dT, theta_max) at rows (a, s) and flank temperatures T (constant in T
        beyond the grid, where the derivative is 0)."""
        T0, dT, n = self.T_K[0], self.T_K[1] - self.T_K[0], len(self.T_K)
        x = (np.asarray(T_K, dtype=float) - T0) / dT
        inside = (x >= 0.0) & (x <= n - 1)
        x = np.clip(x, 0.0, n - 1.0)
        i = np.minimum(x.astype(np.int64), n - 2)
        t = x - i
        M, Th = self.mu, self.theta_max_K

        def bil(F):
            lo = (1.0 - s) * F[a, i] + s * F[a + 1, i]
            hi = (1.0 - s) * F[a, i + 1] + s * F[a + 1, i + 1]
            return lo, hi

        m0, m1 = bil(M)
        h0, h1 = bil(Th)
        mu = (1.0 - t) * m0 + t * m1
        dmu = np.where(inside, (m1 - m0) / dT, 0.0)
        return mu, dmu, (1.0 - t) * h0 + t * h1


#: Largest number of (target, group) keys for which :func:`target_group_pairs` marks them in a
#: dense array (8 bytes a key for the moment it takes); beyond, it sorts.
DENSE_PAIR_KEYS = 50_000_000


def target_group_pairs(
    target: np.ndarray, group: np.ndarray, num_targets: int, num_groups: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The distinct (target, group) pairs of the instances, ordered by target then group: each
    instance's pair index, and each pair's target and group (what ``np.unique`` of the keys
    target * num_groups + group with ``return_inverse`` gives). The keys lie in
    [0, num_targets * num_groups): below :data:`DENSE_PAIR_KEYS` they are marked in a dense array,
    linear in the instances (on the built-in case 6 million instances of 1.9 million keys: 0.05 s
    instead of 0.9 s for the sort)."""
    stride = max(num_groups, 1)
    key = target.astype(np.int64) * stride + group
    n_keys = max(num_targets, 1) * stride
    if n_keys > DENSE_PAIR_KEYS:
        unique, pair = np.unique(key, return_inverse=True)
        pair = pair.ravel()
    else:
        seen = np.zeros(n_keys, dtype=bool)
        seen[key] = True
        unique = np.flatnonzero(seen)
        index = np.cumsum(seen, dtype=np.int64) - 1
        pair = index[key]
    return (pair, *np.divmod(unique, stride))


def _profile(law: FrictionLaw, Tb: np.ndarray, flash0: np.ndarray, n_chunk: int = 50000):
    """Profile-mean mu_T and largest flash temperature of bands at flank temperatures Tb with flash
    temperatures per unit mu flash0 (the Volterra equation of the module docstring). The bands are
    the columns of ``mu`` (one row per node of the profile), so each step is one contiguous
    vector-matrix product over a chunk of bands."""
    W, fm = _VOLTERRA.W, _VOLTERRA.f_mid
    n = len(fm)
    Wf = W * fm[None, :]
    out_m, out_t = np.empty(len(Tb)), np.empty(len(Tb))
    for c0 in range(0, len(Tb), n_chunk):
        tb, K = Tb[c0 : c0 + n_chunk], flash0[c0 : c0 + n_chunk] / _VOLTERRA.i_max
        mu = np.empty((n, len(tb)))
        theta = np.zeros(len(tb))
        theta_max = np.zeros(len(tb))
        for k in range(1, n + 1):
            mu[k - 1] = law.mu_of_T(tb + theta)
            theta = K * (Wf[k, :k] @ mu[:k])
            np.maximum(theta_max, theta, out=theta_max)
        out_m[c0 : c0 + n_chunk] = fm @ mu / np.sum(fm)
        out_t[c0 : c0 + n_chunk] = theta_max
    return out_m, out_t


class FrictionFlux:
    """The flux of a friction law into a set of targets (see the module docstring).

    Each instance (a contact point feeding a target) takes the flank temperature of its target;
    with flash temperatures the band's Volterra solution at that flank temperature comes from a
    :class:`FlashTable`. A target's flux then depends on its own temperature only, and its
    derivative is exact (up to the table's interpolation). ``comm``: the communicator across which
    the instances are distributed (the group sums of the pressure/speed factors are reduced over
    it once, at construction). ``pairs``: the (target, group) pairs of ``inst`` as another
    instance's :attr:`pairs` gives them (they do not depend on the law: :meth:`with_law`).
    """

    def __init__(
        self,
        law: FrictionLaw,
        bands: ContactBands,
        inst: Instances,
        contact_temperature: str = "flash",
        comm: MPI.Comm | None = None,
        num_groups: int | None = None,
        pairs: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    ) -> None:
        self.law, self.bands, self.inst = law, bands, inst
        self.flash = contact_temperature == "flash"
        self.comm = comm
        p = inst.point
        self._hw = bands.heat[p] * inst.weight
        self._fpv = law.pressure_factor(bands.pressure_Pa[p]) * law.speed_factor(
            bands.slip_speed_m_s[p]
        )
        ng = num_groups if num_groups is not None else len(inst.group_band)
        self.num_groups = ng
        s0 = np.bincount(inst.group, weights=self._hw, minlength=ng)
        s1 = np.bincount(inst.group, weights=self._hw * self._fpv, minlength=ng)
        s0, s1 = self._reduce(s0), self._reduce(s1)
        safe = np.where(s0 > 0, s0, 1.0)
        fg = np.where(s0 > 0, s1 / safe, 0.0)
        gb = inst.group_band
        # flash temperature per unit mu_T of each group (the band's mean pressure/speed factor)
        self._flash0 = bands.flash_per_flux_K_m2_W[gb] * bands.q0_W_m2[gb] * fg
        # the (target, group) pairs: mu_T and the flash temperature are evaluated per pair
        if pairs is None:
            pairs = target_group_pairs(inst.target, inst.group, inst.num_targets, ng)
        self._pair, self._pair_target, self._pair_group = pairs
        self._pair_weight = np.bincount(
            self._pair, weights=self._hw * self._fpv, minlength=len(self._pair_target)
        )
        self.table = None
        if self.flash and law.depends_on_temperature:
            top = float(np.max(self._flash0)) if len(self._flash0) else 0.0
            self.table = FlashTable.of(law, top)
            a, s = self.table.weights(self._flash0)
            self._row, self._sw = a[self._pair_group], s[self._pair_group]

    @property
    def pairs(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The instances' (target, group) pairs: each instance's pair, each pair's target and
        group."""
        return self._pair, self._pair_target, self._pair_group

    def with_law(self, law: FrictionLaw) -> FrictionFlux:
        """The flux of another law on the same instances (the pairs kept; collective)."""
        return FrictionFlux(
            law,
            self.bands,
            self.inst,
            "flash" if self.flash else "flank",
            self.comm,
            self.num_groups,
            pairs=self.pairs,
        )

    def _reduce(self, a: np.ndarray) -> np.ndarray:
        if self.comm is None or self.comm.size == 1:
            return a
        return self.comm.allreduce(a, op=MPI.SUM)

    def evaluate(self, T_target_K: np.ndarray) -> FluxState:
        """Flux (and derivative) at the targets' flank temperatures ``T_target_K``. mu_T and the
        flash temperature of an instance depend only on its group (band on one tooth) and its
        target's temperature, so they are evaluated once per (target, group) pair and the
        instances' pressure/speed factors and weights summed per pair beforehand (exact: the same
        sums in another order)."""
        law = self.law
        T = np.asarray(T_target_K, dtype=float)[self._pair_target]
        if self.table is not None:
            muT, dmuT, theta = self.table.lookup(self._row, self._sw, T)
        elif self.flash:  # mu independent of T: the flash temperature is flash0 mu
            muT = law.mu_of_T(T)
            dmuT = np.zeros_like(T)
            theta = self._flash0[self._pair_group] * muT
        else:
            muT, dmuT, theta = law.mu_of_T(T), law.dmu_of_T_dT(T), np.zeros_like(T)
        n = self.inst.num_targets
        q = np.bincount(self._pair_target, weights=muT * self._pair_weight, minlength=n)
        dq = np.bincount(self._pair_target, weights=dmuT * self._pair_weight, minlength=n)
        return FluxState(q, dq, self._pair, muT, T, theta, self._fpv)

    def band_mu(self, state: FluxState) -> tuple[np.ndarray, np.ndarray]:
        """Per band of :attr:`bands` (its order): the heat-weighted mean mu of the band's
        instances at ``state``, Σ h mu / Σ h with h an instance's heat per unit mu (the one mu
        that dissipates on the band what the law does there), and Σ h (collective: the sums are
        reduced over the instances' ranks). A band without heat has mu NaN."""
        nb = self.bands.num_bands
        b = self.bands.band[self.inst.point]
        s0 = self._reduce(np.bincount(b, weights=self._hw, minlength=nb))
        s1 = self._reduce(np.bincount(b, weights=self._hw * state.mu, minlength=nb))
        mu = np.full(nb, np.nan)
        np.divide(s1, s0, out=mu, where=s0 > 0)
        return mu, s0


def reference_flux(
    cycle,
    body: str,
    law: FrictionLaw,
    materials: dict[str, Material],
    speed_rpm: float,
    flank_K: float | np.ndarray,
    partition: str = "fixed",
    fixed_fraction: float = 1.0,
    contact_temperature: str = "flash",
    band_model: BandModel = DEFAULT_BAND_MODEL,
) -> tuple[np.ndarray, FluxState, ContactBands]:
    """Revolution-averaged friction flux (W/m²) into ``body`` on the sector facets of its reference
    tooth (``cycle.fields[body]``) at pinion speed ``speed_rpm`` for the law ``law``, with the flank
    temperature ``flank_K`` (one value, or one per sector facet) and the contact temperature
    ``contact_temperature`` (the bands read by ``band_model``). ``fixed_fraction = 1`` gives
    the heat generated (the cycle's ``generated_flux_W_m2_per_rad_s`` times omega for its own
    constant mu)."""
    bands = contact_bands(
        cycle,
        body,
        materials,
        speed_rpm,
        partition,
        fixed_fraction,
        band_model=band_model,
    )
    inst = reference_instances(cycle, bands)
    model = FrictionFlux(law, bands, inst, contact_temperature)
    T = np.broadcast_to(np.asarray(flank_K, dtype=float), (inst.num_targets,))
    state = model.evaluate(T)
    return state.flux_W_m2, state, bands


#: The contact bands and instances of the last thermal friction models (as a flux of the first
#: law built on them), kept by :meth:`ThermalFrictionFlux._build`.
KEPT_INSTANCES: Kept[FrictionFlux] = Kept(2)


class ThermalFrictionFlux:
    """The friction heat of a temperature-dependent friction law as a
    :class:`gearfem.thermal.source_terms.SurfaceFluxModel` on the thermal mesh of one gear.

    Targets are the local cells next to the flanks
    (:class:`gearfem.coupling.transfer.FlankTransfer`); each flank facet takes the points of the
    reference facets it is linked to (its nearest, or with the flux reconstruction its neighbours
    with their weights), weighted by the revolution average, the heat partition, the per-tooth
    geometric scale of the transfer (computed once from the law-independent flux per unit mu) and
    the facet's share of its cell's flank area. Groups are a band on one thermal tooth: its flash
    temperature is solved on that tooth's flank temperatures. ``update`` (collective) fills
    :attr:`value` and :attr:`slope`; :attr:`state` keeps the last evaluation (mu, contact and flash
    temperatures per point) for the outputs.
    """

    def __init__(
        self,
        transfer,
        cycle,
        body: str,
        law: FrictionLaw,
        materials: dict[str, Material],
        speed_rpm: float,
        partition: str,
        fixed_fraction: float,
        contact_temperature: str,
        band_model: BandModel = DEFAULT_BAND_MODEL,
    ) -> None:
        from dolfinx import fem

        self.transfer, self.law, self.body = transfer, law, body
        self._contact = (cycle, materials, speed_rpm, partition, fixed_fraction)
        self._contact_temperature = contact_temperature
        self._build(band_model)
        self.surfaces = transfer.names
        self.value = fem.Function(transfer.Q, name="flank_flux_W_m2")
        self.slope = fem.Function(transfer.Q, name="flank_flux_slope_W_m2K")
        self.may_rise_with_temperature = law.may_rise_with_temperature
        self.state: FluxState | None = None
        self.evaluations = 0

    def _build(self, band_model: BandModel) -> None:
        """The contact bands read by ``band_model``, the instances on the thermal cells and the
        flux of the law on them (collective). The bands and instances do not depend on the law:
        they are kept (:data:`KEPT_INSTANCES`) for the next model on the same transfer and cycle
        with the same materials, speed, partition, band model and contact temperature."""
        cycle, materials, speed_rpm, partition, fixed_fraction = self._contact
        key = (
            self.body,
            repr(sorted(materials.items())),  # a material's tables may be lists
            float(speed_rpm),
            partition,
            float(fixed_fraction),
            band_model,
            self._contact_temperature,
        )
        flux = KEPT_INSTANCES.get(key, (self.transfer, cycle), lambda: self._flux_of(band_model))
        self.bands, self.band_model = flux.bands, band_model
        self.flux = flux if flux.law is self.law else flux.with_law(self.law)

    def _flux_of(self, band_model: BandModel) -> FrictionFlux:
        """:meth:`_build` without the kept instances: the flux of the law (collective)."""
        transfer = self.transfer
        cycle, materials, speed_rpm, partition, fixed_fraction = self._contact
        bands = contact_bands(
            cycle,
            self.body,
            materials,
            speed_rpm,
            partition,
            fixed_fraction,
            NEGLIGIBLE_HEAT,
            band_model,
        )
        ref = reference_instances(cycle, bands)
        q_ref0 = np.bincount(
            ref.target, weights=bands.heat[ref.point] * ref.weight, minlength=ref.num_targets
        )
        scale = transfer.tooth_scale(q_ref0)
        # CSR of the reference instances by reference facet
        order = np.argsort(ref.target, kind="stable")
        starts = np.searchsorted(ref.target[order], np.arange(ref.num_targets + 1))
        # every link (thermal facet, reference facet, weight) takes that reference facet's points
        lf, lj, lw = transfer.links
        cnt = starts[lj + 1] - starts[lj]
        f = np.repeat(lf, cnt)
        offs = np.arange(len(f)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        r = order[np.repeat(starts[lj], cnt) + offs]
        nt = transfer.num_teeth
        share = transfer.area / np.where(transfer.cell_area > 0, transfer.cell_area, 1.0)
        inst = Instances(
            point=ref.point[r],
            target=transfer.cells[f],
            weight=ref.weight[r] * np.repeat(lw, cnt) * scale[transfer.tooth[f]] * share[f],
            group=ref.group[r] * nt + transfer.tooth[f],
            group_band=np.repeat(np.arange(bands.num_bands), nt),
            num_targets=transfer.num_cells,
        )
        return FrictionFlux(
            self.law,
            bands,
            inst,
            self._contact_temperature,
            transfer.comm,
            bands.num_bands * nt,
        )

    def set_band_model(self, band_model: BandModel) -> None:
        """Read the contact history's bands with another :class:`BandModel` from now on (the
        flash half-width, the passes' balance; the bands, instances and flux built anew, the law
        kept; collective): the stated flash half-width can be varied on one thermal problem, as
        the fold margins of :mod:`gearfem.diagnose.margins` do."""
        self._build(band_model)

    def set_law(self, law: FrictionLaw) -> None:
        """Evaluate another friction law on the same contact points from now on (its flash table
        and pressure/speed factors built anew; collective): a parameter of the law can be varied
        on one thermal problem, as the fold margins of :mod:`gearfem.diagnose.margins` do."""
        if law.may_rise_with_temperature != self.may_rise_with_temperature:
            raise ParameterError(
                "friction law",
                "a law whose heat "
                + ("may" if law.may_rise_with_temperature else "cannot")
                + " rise with temperature",
                "one like the model's (the thermal solver was chosen for it)",
            )
        self.law = law
        self.flux = self.flux.with_law(law)

    def history_band_mu(self, state: FluxState) -> tuple[np.ndarray, np.ndarray]:
        """The law's mu at ``state`` per band of the cycle's contact history that heats this
        gear: (history band indices, mu) (:meth:`FrictionFlux.band_mu`; bands without heat left
        out; collective)."""
        bands = self.bands
        mu, _ = self.flux.band_mu(state)
        history_band = np.empty(bands.num_bands, dtype=np.int64)
        history_band[bands.band] = self._contact[0].history.band[bands.event]
        keep = np.isfinite(mu)
        return history_band[keep], mu[keep]

    def update(self, surface_mean_K: np.ndarray) -> None:
        tr = self.transfer
        T = np.asarray(surface_mean_K)[tr.dofs]
        st = self.flux.evaluate(T)
        self.value.x.array[tr.dofs] = st.flux_W_m2
        self.slope.x.array[tr.dofs] = st.dflux_dT_W_m2K
        self.value.x.scatter_forward()
        self.slope.x.scatter_forward()
        self.state = st
        self.evaluations += 1


__all__ = [
    "NEGLIGIBLE_HEAT",
    "PARTITIONS",
    "ContactBands",
    "FluxState",
    "FrictionFlux",
    "Instances",
    "ThermalFrictionFlux",
    "contact_bands",
    "reference_flux",
    "reference_instances",
    "tooth_balance",
]
