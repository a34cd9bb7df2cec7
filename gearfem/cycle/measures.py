"""Measures derived from a solved cycle after the fact, which the solve itself does not use.

They read the :class:`~gearfem.cycle.result.CycleResult` (its contact history) and are not
imported by the solve, so they are not part of the cycle cache's code key: a new measure does not
invalidate stored cycles.

**The pitch point's band pressure.** The largest pointwise contact pressure at the pitch point
(``CycleResult.p_max_mid_Pa[0]``) is a maximum over integration points: as the elements shrink it
samples an ever narrower peak of the discrete pressure and keeps moving (docs/refinement.md). The
contact history groups the points into bands (one tooth, one position, one slice of the face
width; :mod:`gearfem.cycle.history`) with the load per unit length w = ∫ p ds and the half-width
a = 2 sqrt(∫ p (s − s̄)² ds / ∫ p ds). The peak of the Hertz profile with that load and spread,

    p̂0 = 2 w / (π a)         (exact for p = p0 sqrt(1 − s²/a²)),

is a ratio of integrals of the pressure and converges as the contact is resolved.
"""

from __future__ import annotations

import math

import numpy as np

from gearfem.cycle.history import Z_BINS, ContactHistory
from gearfem.cycle.result import CycleResult


def hertz_peak_pressure_Pa(history: ContactHistory) -> np.ndarray:
    """Per contact point: p̂0 = 2 w / (π a) of its band (module docstring)."""
    a = np.maximum(history.half_width_m, 1e-300)
    return 2.0 * history.load_per_length_N_m / (math.pi * a)


def pitch_point_bands(cycle: CycleResult) -> np.ndarray | None:
    """One contact point (an index into the history) of each band of the pitch point: at the
    first position (the pitch point, where ``p_max_mid_Pa[0]`` is the largest pointwise
    pressure), the bands of the pinion tooth that carries the most load there, in the middle half
    of the face width (each band one slice of it, :data:`~gearfem.cycle.history.Z_BINS` slices
    across the face). None without a contact history or contact there."""
    h = cycle.history
    if h is None or h.num_points == 0:
        return None
    width = Z_BINS * h.z_bin_m  # the recorder's slices span the face width
    mid = np.abs(h.point_m[:, 2] - 0.5 * width) <= 0.25 * width
    sel = np.nonzero((h.position == 0) & h.of("pinion") & mid)[0]
    if len(sel) == 0:
        return None
    _, first = np.unique(h.band[sel], return_index=True)
    bands = sel[first]
    teeth = h.tooth[bands]
    load = {k: float(np.sum(h.load_per_length_N_m[bands][teeth == k])) for k in np.unique(teeth)}
    return bands[teeth == max(load, key=load.get)]


def pitch_point_band_pressure_Pa(cycle: CycleResult) -> float | None:
    """The pitch point's band pressure: the mean p̂0 over :func:`pitch_point_bands`. A mean over
    the slices, not their largest: a slice's load samples the facet rows it cuts, which alternate
    by a few per cent (docs/refinement.md)."""
    bands = pitch_point_bands(cycle)
    if bands is None:
        return None
    return float(np.mean(hertz_peak_pressure_Pa(cycle.history)[bands]))
