"""The friction coefficient at every contact of a cycle: a field of mu over the positions and the
flanks, for a cycle solved with a friction law's mu instead of one constant
(``[friction] cycle_mu = "law"``).

A friction law gives mu at a contact from its contact temperature, pressure and sliding speed
(:mod:`gearfem.contact.friction`); the thermal runs evaluate it on the contact history of a cycle
(:mod:`gearfem.coupling.friction_heat`). The structural cycle that follows takes that mu back at
each contact point. The unit it is carried in is the **band** of the history
(:mod:`gearfem.cycle.history`): the contact across the profile of one tooth at one position within
one slice of the face width, whose points share a flash temperature. Per band the field holds

* its position (index of the cycle's pinion angle), the slave gear of its pass (each gear's pass
  takes the law's mu at that gear's contact temperature), its slice of the face width and its
  flank radius r_b, the heat-weighted mean of its points' distance from the gear's axis (in the
  body frame as built, so that a tooth a pitch further round has the same r; the mean, not the
  band's extent, which the smoothed pressure's faint tails stretch over millimetres);
* mu_b = Σ h_i mu_i / Σ h_i over its instances (each thermal tooth and flank cell it heats),
  h_i the heat per unit mu: the one mu that dissipates on the band what the law does there.

A contact facet of the next cycle at position k takes the mu of the band of k of its gear's pass
in its slice of the face width whose radius r_b is nearest to the facet centroid's (the contacts
of one position lie a base pitch apart along the line of action, millimetres apart in r), or of
any slice when its own has none, and the field's mean where the position has no band (a contact
the previous cycle did not have). The check position one pitch after the start takes the first
position's bands (the same contact, a tooth further round). Each mu is rounded to ``step``
(:meth:`~gearfem.contact.friction.FrictionOptions.cycle_mu_step`), so that fields that differ in
round-off give the same cycle and the same cache key (:meth:`digest`).
Numpy only: the interface evaluates it per local facet without communication.
"""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np

from gearfem.core.errors import ParameterError
from gearfem.cycle.history import ContactHistory
from gearfem.geometry.options import BODIES

_FIELDS = ("position", "body", "z_bin", "radius_m", "mu", "heat")


@dataclasses.dataclass(frozen=True, eq=False)
class FrictionField:
    """mu per contact band of a cycle (see the module docstring); arrays over the bands.

    ``heat`` is each band's heat per unit mu (W per rad/s of the pinion: the weight of its mu in
    :attr:`mean`), ``z_bin_m`` the width of a face-width slice, ``mean`` the heat-weighted mean
    mu, ``step`` the rounding of the mu values."""

    position: np.ndarray
    body: np.ndarray  # 0 pinion, 1 wheel: the slave gear of the band's pass
    z_bin: np.ndarray
    radius_m: np.ndarray  # heat-weighted mean distance of the band's points from the axis
    mu: np.ndarray
    heat: np.ndarray
    z_bin_m: float
    step: float

    @property
    def num_bands(self) -> int:
        return len(self.mu)

    @property
    def mean(self) -> float:
        """The heat-weighted mean mu of the bands (the mu where a position has no band)."""
        w = float(np.sum(self.heat))
        return float(np.sum(self.heat * self.mu) / w) if w > 0 else float(np.mean(self.mu))

    @classmethod
    def from_bands(
        cls,
        history: ContactHistory,
        centres_m: dict[str, np.ndarray],
        band: np.ndarray,
        mu: np.ndarray,
        step: float,
    ) -> FrictionField:
        """The field of the history bands ``band`` (indices into the history's band numbering)
        with their mu ``mu``; the bands' radii and heat from the history's points,
        ``centres_m`` each gear's axis point (the cycle's ``info["centres_m"]``)."""
        band = np.asarray(band, dtype=np.int64)
        mu = np.asarray(mu, dtype=float)
        if band.shape != mu.shape:
            raise ParameterError(
                "friction field", f"{band.shape} bands, {mu.shape} mu", "one mu per band"
            )
        if not np.all(np.isfinite(mu)) or np.any(mu < 0.0):
            raise ParameterError("friction field mu", mu, "finite and >= 0 at every band")
        if not step > 0.0:
            raise ParameterError("friction field step", step, "> 0")
        h = history
        nb = int(h.band.max()) + 1 if h.num_points else 0
        if len(band) and (band.min() < 0 or band.max() >= nb):
            raise ParameterError(
                "friction field band", band, f"indices of the history's {nb} bands"
            )
        radius = np.empty(h.num_points)
        for i, b in enumerate(BODIES):
            sel = h.body == i
            c = np.asarray(centres_m[b], dtype=float)
            radius[sel] = np.linalg.norm(h.point_m[sel, :2] - c[:2], axis=1)
        pos = np.zeros(nb, dtype=np.int64)
        bod = np.zeros(nb, dtype=np.int64)
        pos[h.band], bod[h.band] = h.position, h.body
        zb = np.zeros(nb, dtype=np.int64)
        dz = h.z_bin_m if h.z_bin_m > 0 else 1.0
        zb[h.band] = np.floor(h.point_m[:, 2] / dz).astype(np.int64)
        q = h.pressure_Pa * h.dissipation_speed_m_s * h.weight_m2 * h.pass_weight
        heat = np.bincount(h.band, weights=q, minlength=nb)
        r_mean = np.bincount(h.band, weights=q * radius, minlength=nb) / np.where(
            heat > 0, heat, 1.0
        )
        return cls(
            position=pos[band],
            body=bod[band],
            z_bin=zb[band],
            radius_m=r_mean[band],
            # on the step's grid, without the round-off of the product (0.3, not 0.300...04)
            mu=np.round(np.round(mu / step) * step, 12),
            heat=heat[band],
            z_bin_m=float(h.z_bin_m),
            step=float(step),
        )

    def digest(self) -> str:
        """A hash of what the cycle is solved with: the bands (their place to 0.1 um) and their
        rounded mu (the cycle's cache key holds it)."""
        data = np.concatenate(
            [
                self.position,
                self.body,
                self.z_bin,
                np.round(self.radius_m * 1e7).astype(np.int64),
                np.round(self.mu / self.step).astype(np.int64),
            ]
        )
        text = f"{self.step!r}|{self.z_bin_m!r}|".encode() + data.astype("<i8").tobytes()
        return hashlib.sha256(text).hexdigest()[:16]

    def at(self, position: int, body: str, radius_m: np.ndarray, z_m: np.ndarray) -> np.ndarray:
        """mu at points of ``body``'s flanks (its pass) at radius ``radius_m`` from its axis and
        face-width coordinate ``z_m``, at the cycle's position ``position`` (see the module
        docstring)."""
        radius_m = np.asarray(radius_m, dtype=float)
        out = np.full(radius_m.shape, self.mean)
        mine = np.flatnonzero((self.position == position) & (self.body == BODIES.index(body)))
        if not len(mine) or not radius_m.size:
            return out
        zb = np.floor(np.asarray(z_m, dtype=float) / (self.z_bin_m or 1.0)).astype(np.int64)
        d = np.abs(radius_m[:, None] - self.radius_m[mine][None, :])  # (n, bands)
        other_slice = zb[:, None] != self.z_bin[mine][None, :]
        has_own = ~np.all(other_slice, axis=1)
        d = np.where(other_slice & has_own[:, None], np.inf, d)
        return self.mu[mine][np.argmin(d, axis=1)]

    def band_mu(self, other: FrictionField) -> np.ndarray:
        """mu this field gives at the bands of ``other`` (the mu a cycle solved with this field
        had where ``other``'s contacts lie: at each band's radius and slice)."""
        out = np.empty(other.num_bands)
        mid = other.radius_m
        z = (other.z_bin + 0.5) * other.z_bin_m
        for k in np.unique(other.position):
            for i, b in enumerate(BODIES):
                sel = (other.position == k) & (other.body == i)
                if np.any(sel):
                    out[sel] = self.at(int(k), b, mid[sel], z[sel])
        return out

    def change_from(
        self, previous: FrictionField | float, heat_share: float = 1e-3
    ) -> tuple[float, float]:
        """How far the mu the law gives at this field's bands moved from the mu the cycle was
        solved with there (``previous``: that cycle's field, or its one mu): the heat-weighted
        mean of |mu - mu_previous| over the bands (what moves the mesh's friction forces), and
        the largest over the bands carrying at least ``heat_share`` of the largest band's heat."""
        if not self.num_bands:
            return 0.0, 0.0
        before = (
            previous.band_mu(self)
            if isinstance(previous, FrictionField)
            else np.full(self.num_bands, float(previous))
        )
        d = np.abs(self.mu - before)
        loaded = self.heat >= heat_share * float(np.max(self.heat))
        w = float(np.sum(self.heat))
        mean = float(np.sum(self.heat * d) / w) if w > 0 else float(np.mean(d))
        return mean, float(np.max(d[loaded]))

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: getattr(self, k) for k in _FIELDS}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], z_bin_m: float, step: float):
        return cls(**{k: np.asarray(arrays[k]) for k in _FIELDS}, z_bin_m=z_bin_m, step=step)


__all__ = ["FrictionField"]
