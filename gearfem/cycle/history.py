"""The contact history of the meshing cycle: the state of every contact integration point at every
position, kept so that the friction heat of any friction law can be recomputed without a new
structural solve.

Per contact point and position, for both passes of the two-pass contact (each gear is the slave in
one): the pressure p, the sliding velocity per unit pinion speed (the kinematic slip speed |v_T|
and the one the Coulomb law dissipates with, ŝ·v_T, which the slip regularisation makes smaller
near the pitch point), the rolling speeds of the two surfaces (the speeds at which the contact
moves over each flank, for the flash temperature), the facet and integration weight, and the
point on the flank (body frame, as built). Points are grouped into **bands**: the contact across
the profile of one tooth at one position within one slice of the face width. Per band: the load per
unit length w = ∫ p ds and the contact half-width from the pressure profile,

    a = 2 sqrt( ∫ p (s - s̄)² ds / ∫ p ds ),

which is exact for the Hertz profile p = p0 sqrt(1 - s²/a²) (its second moment is a²/4) and, for
other profiles, the half-width of the Hertz profile with the same spread; beside it the Hertz
half-width of the same load on the local radii of curvature of the two surfaces (the involute's,
or a tip round's where the contact lies on it). The profile width resolves a smooth flank contact
but not a corner: where a tip round enters, the pressure peaks over a few elements and the
profile width shrinks with the mesh, while the Hertz width of the band's load (an integral,
which converges) on the round's radius does not.

The recorder is solver-independent: it reads the :class:`~gearfem.contact.interface.ContactPoints`
that the contact problem leaves after each solve (``model.problem.last_points``) and the bodies'
rigid motions. Kinematics are per unit pinion speed (ω₁ = 1 rad/s), like the rest of the cycle.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from gearfem.contact.kinematics import evaluate
from gearfem.geometry.options import BODIES

#: Slices of the face width in which a band's profile is taken.
Z_BINS = 8

_FIELDS = (
    "position",
    "body",
    "facet",
    "xi",
    "point_m",
    "weight_m2",
    "pass_weight",
    "pressure_Pa",
    "slip_speed_m_s",
    "dissipation_speed_m_s",
    "rolling_speed_m_s",
    "mate_rolling_speed_m_s",
    "tooth",
    "band",
    "half_width_m",
    "load_per_length_N_m",
    "hertz_half_width_m",
)


@dataclasses.dataclass
class ContactHistory:
    """The contact points of every position (replicated on all ranks), both passes.

    Speeds are per unit pinion speed (m/s per rad/s). ``body`` is the slave gear of the point's
    pass (0 pinion, 1 wheel); ``facet`` its facet in the gathered order of that gear's contact
    surface (:meth:`ContactSurface.gathered`); ``xi`` the reference coordinates on it and
    ``point_m`` the point in the gear's body frame as built. ``weight_m2`` is the point's area in
    its own pass (the friction power of the cycle weights it by ``pass_weight``). Bands: see the
    module docstring (``band`` is an index into the band arrays ``band_*``).
    """

    position: np.ndarray
    body: np.ndarray
    facet: np.ndarray
    xi: np.ndarray
    point_m: np.ndarray
    weight_m2: np.ndarray
    pass_weight: np.ndarray
    pressure_Pa: np.ndarray
    slip_speed_m_s: np.ndarray  # |v_T| per unit ω₁
    dissipation_speed_m_s: np.ndarray  # ŝ·v_T per unit ω₁ (friction power = μ p × this)
    rolling_speed_m_s: np.ndarray  # speed of the contact over the slave's flank per unit ω₁
    mate_rolling_speed_m_s: np.ndarray  # ... over the master's flank
    tooth: np.ndarray
    band: np.ndarray
    half_width_m: np.ndarray  # of the point's band
    load_per_length_N_m: np.ndarray  # of the point's band
    hertz_half_width_m: np.ndarray  # of the point's band
    z_bin_m: float = 0.0

    @property
    def num_points(self) -> int:
        return len(self.position)

    def of(self, body: str) -> np.ndarray:
        """Mask of the points whose slave is ``body``."""
        return self.body == BODIES.index(body)

    def friction_power_W_per_rad_s(self, mu: np.ndarray | float, positions: int) -> np.ndarray:
        """∫ μ p ŝ·v_T dA of each position (both passes, pass-weighted), per unit ω₁."""
        q = np.asarray(mu) * self.pressure_Pa * self.dissipation_speed_m_s
        return np.bincount(
            self.position, weights=q * self.weight_m2 * self.pass_weight, minlength=positions
        )

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: getattr(self, k) for k in _FIELDS}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], z_bin_m: float) -> ContactHistory:
        return cls(**{k: np.asarray(arrays[k]) for k in _FIELDS}, z_bin_m=float(z_bin_m))


class HistoryRecorder:
    """Collects the contact points after each solved position (``record``) and builds the
    :class:`ContactHistory` (``finish``, collective)."""

    def __init__(self, model, z_bins: int = Z_BINS) -> None:
        self.model = model
        self.z_bins = z_bins
        self._chunks: list[dict[str, np.ndarray]] = []
        comm = model.comm
        self._offset = {}
        for b in BODIES:
            counts = np.array(comm.allgather(model.surfaces[b].local.num_facets))
            self._offset[b] = int(np.sum(counts[: comm.rank]))

    def record(self, position: int) -> None:
        """Keep the loaded points of the last solve as position ``position`` (local, no
        communication)."""
        model = self.model
        motions = model.problem.motions
        for ps, pts in zip(model.interface.passes, model.problem.last_points[0]):
            keep = pts.pressure > 0.0
            if not np.any(keep):
                continue
            slave, master = ps.slave.body, ps.master.body
            x, n = pts.x[keep], pts.normal[keep]
            vt = pts.slip_velocity[keep]

            def tangential_speed(body: str) -> np.ndarray:
                v = motions[body].velocity(x)
                return np.linalg.norm(v - np.einsum("pd,pd->p", v, n)[:, None] * n, axis=1)

            facet = pts.facet[keep]
            self._chunks.append(
                {
                    "position": np.full(len(facet), position, dtype=np.int64),
                    "body": np.full(len(facet), BODIES.index(slave), dtype=np.int64),
                    "facet": (facet + self._offset[slave]).astype(np.int64),
                    "xi": pts.xi[keep],
                    "x": x,
                    "normal": n,
                    "weight_m2": pts.dA[keep] / ps.weight,
                    "pass_weight": np.full(len(facet), ps.weight),
                    "pressure_Pa": pts.pressure[keep],
                    "slip_speed_m_s": np.linalg.norm(vt, axis=1),
                    "dissipation_speed_m_s": pts.dissipation_speed()[keep],
                    "rolling_speed_m_s": tangential_speed(slave),
                    "mate_rolling_speed_m_s": tangential_speed(master),
                    "tooth": model.tooth_of_facet[slave]["local"][facet].astype(np.int64),
                }
            )

    def finish(self, world=None) -> ContactHistory:
        """Gather the points to every rank and compute the bands (collective on the model's
        communicator, or on ``world`` when its ranks each recorded other positions of a model on
        one rank)."""
        model = self.model
        comm = world if world is not None else model.comm
        keys = (
            "position",
            "body",
            "facet",
            "xi",
            "x",
            "normal",
            "weight_m2",
            "pass_weight",
            "pressure_Pa",
            "slip_speed_m_s",
            "dissipation_speed_m_s",
            "rolling_speed_m_s",
            "mate_rolling_speed_m_s",
            "tooth",
        )
        shapes = {"xi": (0, 2), "x": (0, 3), "normal": (0, 3)}
        ints = ("position", "body", "facet", "tooth")
        local = {
            k: (
                np.concatenate([c[k] for c in self._chunks])
                if self._chunks
                else np.zeros(shapes.get(k, (0,)), dtype=np.int64 if k in ints else float)
            )
            for k in keys
        }
        data = {
            k: np.concatenate(comm.allgather(np.ascontiguousarray(v))) for k, v in local.items()
        }
        point = np.zeros_like(data["x"])
        for i, b in enumerate(BODIES):
            sel = data["body"] == i
            if np.any(sel):
                surf = model.surfaces[b]
                X = surf.gathered().X[data["facet"][sel]]
                point[sel] = evaluate(surf.ref, X, data["xi"][sel])[0]
        # a canonical order, independent of the partition: position, body, place on the flank
        order = np.lexsort(
            (
                np.round(point[:, 2], 10),
                np.round(point[:, 1], 10),
                np.round(point[:, 0], 10),
                data["body"],
                data["position"],
            )
        )
        data = {k: v[order] for k, v in data.items()}
        point = point[order]
        face_width = model.gm.geometry.face_width_mm * 1e-3
        dz = face_width / self.z_bins
        band, a, w, a_h = _bands(model, data, point, dz)
        return ContactHistory(
            position=data["position"],
            body=data["body"],
            facet=data["facet"],
            xi=data["xi"],
            point_m=point,
            weight_m2=data["weight_m2"],
            pass_weight=data["pass_weight"],
            pressure_Pa=data["pressure_Pa"],
            slip_speed_m_s=data["slip_speed_m_s"],
            dissipation_speed_m_s=data["dissipation_speed_m_s"],
            rolling_speed_m_s=data["rolling_speed_m_s"],
            mate_rolling_speed_m_s=data["mate_rolling_speed_m_s"],
            tooth=data["tooth"],
            band=band,
            half_width_m=a[band],
            load_per_length_N_m=w[band],
            hertz_half_width_m=a_h[band],
            z_bin_m=dz,
        )


def _bands(model, data: dict[str, np.ndarray], point: np.ndarray, dz: float):
    """Band index of every point and, per band, the profile half-width, the load per unit length
    and the Hertz half-width of that load on the local involute radii."""
    n = len(data["position"])
    if n == 0:
        z = np.zeros(0)
        return np.zeros(0, dtype=np.int64), z, z, z
    nz = max(1, round(model.gm.geometry.face_width_mm * 1e-3 / dz))
    zbin = np.clip(np.floor(point[:, 2] / dz).astype(np.int64), 0, nz - 1)
    key = np.stack([data["position"], data["body"], data["tooth"], zbin], axis=1)
    _, band = np.unique(key, axis=0, return_inverse=True)
    band = band.ravel()
    nb = int(band.max()) + 1
    p, dA = data["pressure_Pa"], data["weight_m2"]
    pw = p * dA
    P = np.bincount(band, weights=pw, minlength=nb)  # ∫ p dA over the band
    # profile coordinate: along t = e_z × n (in the section plane)
    nrm = data["normal"]
    t = np.cross(np.array([0.0, 0.0, 1.0]), nrm)
    t /= np.maximum(np.linalg.norm(t, axis=1), 1e-300)[:, None]
    # the band's mean tangent (pressure-weighted), so that every point uses the same direction
    tb = np.stack([np.bincount(band, weights=pw * t[:, d], minlength=nb) for d in range(3)], 1)
    tb /= np.maximum(np.linalg.norm(tb, axis=1), 1e-300)[:, None]
    x = data["x"]
    xb = np.stack([np.bincount(band, weights=pw * x[:, d], minlength=nb) for d in range(3)], 1)
    xb /= np.maximum(P, 1e-300)[:, None]
    s = np.einsum("pd,pd->p", x - xb[band], tb[band])
    m2 = np.bincount(band, weights=pw * s * s, minlength=nb) / np.maximum(P, 1e-300)
    a = 2.0 * np.sqrt(m2)
    w = P / dz
    # Hertz half-width of the same load per length on the local radii of curvature (the involute's,
    # or the tip round's where the contact lies on it: a converged width for a corner contact,
    # whose profile width shrinks with the mesh)
    mats = model.materials
    es = {b: mats[b].youngs_modulus_Pa / (1.0 - mats[b].poissons_ratio ** 2) for b in BODIES}
    e_star = 1.0 / (1.0 / es["pinion"] + 1.0 / es["wheel"])
    rho = {}
    for b in BODIES:
        c = np.asarray(model.gm.center(b))
        r = np.linalg.norm((x - c)[:, :2], axis=1)
        rb = model.base_radius_m[b]
        rho[b] = np.sqrt(np.maximum(r * r - rb * rb, 0.0))
        # beyond the tip form circle the surface is the tip round, not the involute
        prof = model.pair.profile(b)
        if prof.tip_round_radius_m > 0.0:
            rho[b] = np.where(r > prof.tip_form_radius_m, prof.tip_round_radius_m, rho[b])
    inv_r = 1.0 / np.maximum(rho["pinion"], 1e-9) + 1.0 / np.maximum(rho["wheel"], 1e-9)
    inv_rb = np.bincount(band, weights=pw * inv_r, minlength=nb) / np.maximum(P, 1e-300)
    a_h = np.sqrt(4.0 * w / (math.pi * e_star * np.maximum(inv_rb, 1e-300)))
    return band, a, w, a_h


__all__ = ["Z_BINS", "ContactHistory", "HistoryRecorder"]
