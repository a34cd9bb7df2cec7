"""Synthetic measurements with a hidden effect, for the diagnosis tests (NOT imported by gearfem).

The data come from gearfem's full forward model (:class:`gearfem.diagnose.forward.FullModel`) with
one or more candidates of the library switched on at a random value inside their prior, at several
operating points, with Gaussian noise and a random recorded ambient temperature per run. The truth
is returned separately from the data; the analysis only sees the :class:`Dataset`.

Effect sizes are drawn from the part of the prior at least ``margin`` (in the prior's unit
coordinate) away from the null value: an effect much smaller than the noise is a null case, tested
separately.
"""

from __future__ import annotations

import numpy as np

from gearfem.diagnose.candidates import by_name
from gearfem.diagnose.data import Dataset, Measurement

SPEEDS_RPM = (300.0, 600.0, 1000.0)
TORQUE_NM = 8.0
TIMES_S = (60.0,)
QUANTITIES = ("max_surface", "mean_bulk", "root_mean")


def draw(name: str, rng: np.random.Generator, margin: float = 0.3) -> float:
    p = by_name(name).parameter
    un = p.to_unit(p.null)
    sides = [(a, b) for a, b in ((0.0, un - margin), (un + margin, 1.0)) if b - a > 0.05]
    lengths = np.array([b - a for a, b in sides])
    a, b = sides[rng.choice(len(sides), p=lengths / lengths.sum())]
    return p.from_unit(rng.uniform(a, b))


def synthetic(
    full,
    effects: dict[str, float],
    rng: np.random.Generator,
    noise_K: float = 1.0,
    ambient_C: tuple[float, float] = (18.0, 28.0),
    speeds=SPEEDS_RPM,
    torque_Nm: float = TORQUE_NM,
    quantities=QUANTITIES,
    end_only: bool = False,
    points: tuple[tuple[float, float], ...] | None = None,
) -> Dataset:
    """``points`` (speed, torque) pairs replace ``speeds`` at ``torque_Nm``."""
    rows = []
    for sp, tq in points or tuple((s, torque_Nm) for s in speeds):
        amb = float(np.round(rng.uniform(*ambient_C), 1))
        res = full.evaluate(sp, tq, amb, effects)
        for q in quantities:
            for t in (None,) if end_only else (*full.times_s, None):
                rows.append(
                    Measurement(
                        sp,
                        tq,
                        t,
                        q,
                        float(res[(q, t)] + rng.normal(0.0, noise_K)),
                        noise_K,
                        amb,
                    )
                )
    return Dataset(tuple(rows), "synthetic")
