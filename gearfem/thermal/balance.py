"""Heat balance of one time step (or of the steady state), W.

Every term is the integral of the same integrand the solver's residual uses, with the same
quadrature and the same time discretisation; the residual tested with v = 1 (the sum of the
Lagrange basis functions) is exactly ``generated - stored - convected - radiated - bore``, so
the imbalance is zero up to the Newton tolerance. ``stored`` is the BDF2 (first step: backward
Euler) difference quotient of the heat content, not its exact rate.
"""

from __future__ import annotations

import dataclasses
import math


@dataclasses.dataclass(frozen=True)
class HeatBalance:
    """Heat flows of one step, W (positive as named)."""

    hysteresis_W: float = 0.0
    friction_W: float = 0.0
    volumetric_W: float = 0.0
    stored_W: float = 0.0
    convected_W: float = 0.0
    radiated_W: float = 0.0
    bore_W: float = 0.0

    @property
    def generated_W(self) -> float:
        return self.hysteresis_W + self.friction_W + self.volumetric_W

    @property
    def imbalance_W(self) -> float:
        return self.generated_W - self.stored_W - self.convected_W - self.radiated_W - self.bore_W

    @property
    def scale_W(self) -> float:
        """Largest flow, the reference for the relative imbalance."""
        return max(
            abs(self.generated_W),
            abs(self.stored_W),
            abs(self.convected_W) + abs(self.radiated_W) + abs(self.bore_W),
        )

    @property
    def relative_imbalance(self) -> float:
        s = self.scale_W
        return abs(self.imbalance_W) / s if s > 0.0 else 0.0

    def as_dict(self) -> dict[str, float]:
        d = dataclasses.asdict(self)
        d["generated_W"] = self.generated_W
        d["imbalance_W"] = self.imbalance_W
        return d

    @classmethod
    def undefined(cls) -> HeatBalance:
        nan = math.nan
        return cls(nan, nan, nan, nan, nan, nan, nan)
