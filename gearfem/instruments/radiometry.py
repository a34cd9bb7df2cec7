"""Band radiance: what a thermal camera's detector measures, and how the camera turns it back into
a temperature (numpy only).

Planck's spectral radiance of a black body, W/(m² sr m)::

    L_λ(λ, T) = 2 h c² / λ⁵ / (exp(h c / (λ k T)) − 1)

The detector responds to the band radiance L(T) = ∫ L_λ dλ over its band (flat response inside
the band, none outside; Gauss-Legendre quadrature, exact to rounding for the smooth integrand).
A gray surface of emissivity ε at T that reflects surroundings at T_s sends

    S = ε L(T) + (1 − ε) L(T_s),

and a camera told the emissivity ε_set and the reflected temperature T_r reports

    T_read = L⁻¹[(S − (1 − ε_set) L(T_r)) / ε_set]

(the atmosphere between camera and gear, 1 m of air, is taken as transparent, as the camera's own
correction at that distance nearly does). L⁻¹ is found by Newton's method on L, which is smooth
and strictly increasing, started from a tabulated inverse. Because L is convex in T over the band,
averaging radiance over a pixel reads hotter than averaging temperature: a hot sub-pixel feature
is not averaged away linearly.

:func:`directional_emissivity` gives the Fresnel emissivity of a smooth dielectric with a given
normal emissivity, for surfaces seen at grazing angles.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gearfem.core.errors import ParameterError

H_J_s = 6.62607015e-34
C_m_s = 299_792_458.0
K_J_K = 1.380649e-23
_C1 = 2.0 * H_J_s * C_m_s**2  # W m² / sr
_C2 = H_J_s * C_m_s / K_J_K  # m K

T_MIN_K = 30.0
T_MAX_K = 3000.0
FAST_LO_K, FAST_HI_K, FAST_STEP_K = 150.0, 1500.0, 0.02


@dataclasses.dataclass(frozen=True)
class Band:
    """A spectral band [λ1, λ2] (micrometres) with its band-radiance function and inverse."""

    lower_um: float
    upper_um: float
    nodes: int = 64

    def __post_init__(self) -> None:
        if not 0.0 < self.lower_um < self.upper_um:
            raise ParameterError("band_um", (self.lower_um, self.upper_um), "0 < lower < upper")
        x, w = np.polynomial.legendre.leggauss(self.nodes)
        a, b = self.lower_um * 1e-6, self.upper_um * 1e-6
        object.__setattr__(self, "_lam", 0.5 * (b - a) * x + 0.5 * (b + a))
        object.__setattr__(self, "_w", 0.5 * (b - a) * w)
        T = np.geomspace(T_MIN_K, T_MAX_K, 2000)
        object.__setattr__(self, "_table_T", T)
        object.__setattr__(self, "_table_logL", np.log(self.radiance(T)))
        fine = np.arange(FAST_LO_K, FAST_HI_K + FAST_STEP_K / 2, FAST_STEP_K)
        object.__setattr__(self, "_fast", self.radiance(fine))

    def radiance(self, T_K) -> np.ndarray:
        """Band radiance L(T) of a black body, W/(m² sr)."""
        T = np.asarray(T_K, dtype=float)
        lam = self._lam
        x = _C2 / (lam * T[..., None])
        with np.errstate(over="ignore"):
            spectral = _C1 / lam**5 / np.expm1(x)
        return spectral @ self._w

    def radiance_fast(self, T_K) -> np.ndarray:
        """:meth:`radiance` by linear interpolation in a table of 0.02 K steps over
        [150, 1500] K (relative error < 1e-7, i.e. < 1e-5 K in the temperature it stands for);
        the exact formula outside the table."""
        T = np.asarray(T_K, dtype=float)
        pos = (T - FAST_LO_K) / FAST_STEP_K
        i = np.floor(pos).astype(np.int64)
        inside = (i >= 0) & (i < len(self._fast) - 1)
        if not np.all(inside):
            out = np.empty_like(T)
            out[~inside] = self.radiance(T[~inside])
            out[inside] = self.radiance_fast(T[inside])
            return out
        f = pos - i
        return (1.0 - f) * self._fast[i] + f * self._fast[i + 1]

    def temperature_fast(self, radiance) -> np.ndarray:
        """:meth:`temperature` by linear interpolation of the inverse of the :meth:`radiance_fast`
        table (error < 1e-5 K in [150, 1500] K); the exact inversion outside it."""
        rad = np.asarray(radiance, dtype=float)
        fast = self._fast
        inside = (rad >= fast[0]) & (rad <= fast[-1])
        if not np.all(inside):
            out = np.empty_like(rad)
            out[~inside] = self.temperature(rad[~inside])
            out[inside] = self.temperature_fast(rad[inside])
            return out
        i = np.clip(np.searchsorted(fast, rad) - 1, 0, len(fast) - 2)
        f = (rad - fast[i]) / (fast[i + 1] - fast[i])
        return FAST_LO_K + (i + f) * FAST_STEP_K

    def derivative(self, T_K) -> np.ndarray:
        """dL/dT, W/(m² sr K)."""
        T = np.asarray(T_K, dtype=float)
        lam = self._lam
        x = _C2 / (lam * T[..., None])
        with np.errstate(over="ignore", invalid="ignore"):
            e = np.expm1(x)
            d = _C1 / lam**5 * x * (e + 1.0) / (e * e) / T[..., None]
        d = np.where(np.isfinite(d), d, 0.0)
        return d @ self._w

    def temperature(self, radiance) -> np.ndarray:
        """The black-body temperature (K) of a band radiance: the inverse of :meth:`radiance`
        (Newton from the tabulated inverse; relative accuracy 1e-12). Radiances outside
        [L(30 K), L(3000 K)] are an error: they are no temperature a camera reports."""
        rad = np.asarray(radiance, dtype=float)
        lo, hi = np.exp(self._table_logL[0]), np.exp(self._table_logL[-1])
        bad = ~np.isfinite(rad) | (rad < lo) | (rad > hi)
        if np.any(bad):
            raise ParameterError(
                "band radiance",
                float(rad[bad].flat[0]),
                f"[{lo:.3g}, {hi:.3g}] W/(m^2 sr), temperatures {T_MIN_K:g}-{T_MAX_K:g} K",
                "a signal that no black-body temperature explains (check emissivities)",
            )
        T = np.interp(np.log(rad), self._table_logL, self._table_T)
        for _ in range(8):
            step = (self.radiance(T) - rad) / self.derivative(T)
            T = T - step
            if np.all(np.abs(step) <= 1e-12 * T):
                break
        return T


def surface_signal(band: Band, T_K, emissivity, surroundings_K: float) -> np.ndarray:
    """Band radiance leaving a gray surface at T that reflects surroundings at T_s."""
    eps = np.asarray(emissivity, dtype=float)
    return eps * band.radiance(T_K) + (1.0 - eps) * band.radiance(surroundings_K)


def camera_temperature(
    band: Band, signal, emissivity_setting: float, reflected_K: float, fast: bool = False
) -> np.ndarray:
    """The temperature (K) a camera reports for a band radiance ``signal`` with its emissivity
    and reflected-temperature settings (module docstring); ``fast``: by the tabulated inverse
    (:meth:`Band.temperature_fast`, error < 1e-5 K)."""
    S = np.asarray(signal, dtype=float)
    L = (S - (1.0 - emissivity_setting) * band.radiance(reflected_K)) / emissivity_setting
    return band.temperature_fast(L) if fast else band.temperature(L)


def refractive_index(normal_emissivity: float) -> float:
    """Refractive index n of the smooth dielectric whose normal emissivity is ε_n:
    ε_n = 1 − ((n − 1)/(n + 1))²."""
    if not 0.0 < normal_emissivity <= 1.0:
        raise ParameterError("emissivity", normal_emissivity, "(0, 1]")
    r = np.sqrt(1.0 - normal_emissivity)
    return float((1.0 + r) / (1.0 - r))


def directional_emissivity(normal_emissivity: float, cos_theta) -> np.ndarray:
    """Emissivity at the angle θ from the surface normal (cos θ given) of a smooth dielectric with
    normal emissivity ε_n: 1 − (R_s + R_p)/2 from the Fresnel equations (unpolarised; a
    microbolometer is not polarisation-sensitive). 0 at grazing incidence, ε_n at normal."""
    c = np.clip(np.abs(np.asarray(cos_theta, dtype=float)), 0.0, 1.0)
    if normal_emissivity >= 1.0:
        return np.ones_like(c)
    n = refractive_index(normal_emissivity)
    s2 = 1.0 - c * c
    ct = np.sqrt(np.maximum(1.0 - s2 / (n * n), 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        rs = ((c - n * ct) / (c + n * ct)) ** 2
        rp = ((ct - n * c) / (ct + n * c)) ** 2
    R = np.where(c > 0.0, 0.5 * (rs + rp), 1.0)
    return 1.0 - R
