"""The library of candidate model extensions: named, physical, one parameter each, with a prior.

Each candidate is a frozen dataclass with class attributes ``name``, ``parameter`` (name, unit,
value that leaves the model unchanged, prior range, whether the prior is logarithmic) and a method
:meth:`Candidate.apply` that turns a :class:`~gearfem.config.Case` (already at the operating point)
and a parameter value into the modified case that the real forward model then runs. Most change
only the thermal problem, so the cached structural cycle of each torque is reused.

Adding a candidate (the documented step):
  1. write a subclass of :class:`Candidate` with ``name``, ``parameter``, a docstring saying the
     physics and where it comes from, and ``apply(case, value)`` returning the modified case
     (through ``dataclasses.replace`` of the case's frozen option tables; if the effect needs a
     new knob, add it to the owning options dataclass first, with a test);
  2. add an instance to :data:`LIBRARY`. The generator tests then hide it in synthetic data
     (``tests/test_diagnose.py`` loops over the library) and require it to be found.

``additive = True`` marks a candidate that shifts all temperatures by its value (the surrogate
then adds it exactly instead of tabulating it).
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

from gearfem.config import Case
from gearfem.core.errors import ParameterError


@dataclasses.dataclass(frozen=True)
class Parameter:
    """A candidate's parameter: ``null`` leaves the model unchanged; prior [lo, hi] (log: uniform in
    log)."""

    name: str
    unit: str
    null: float
    lo: float
    hi: float
    log: bool = False

    def __post_init__(self) -> None:
        if not (self.lo <= self.null <= self.hi and self.lo < self.hi):
            raise ParameterError(
                f"candidate parameter {self.name}",
                (self.lo, self.null, self.hi),
                "lo <= null <= hi",
            )
        if self.log and self.lo <= 0.0:
            raise ParameterError(
                f"candidate parameter {self.name}.lo", self.lo, "> 0 for a logarithmic prior"
            )

    def to_unit(self, value: float) -> float:
        """Position in the prior, 0 at lo, 1 at hi (log-uniform when ``log``)."""
        if self.log:
            return math.log(value / self.lo) / math.log(self.hi / self.lo)
        return (value - self.lo) / (self.hi - self.lo)

    def from_unit(self, u: float) -> float:
        if self.log:
            return self.lo * (self.hi / self.lo) ** u
        return self.lo + u * (self.hi - self.lo)

    def check(self, value: float) -> float:
        if not (self.lo - 1e-12 * abs(self.hi) <= value <= self.hi + 1e-12 * abs(self.hi)):
            raise ParameterError(
                f"candidate parameter {self.name}", value, f"[{self.lo:g}, {self.hi:g}] {self.unit}"
            )
        return float(value)


@dataclasses.dataclass(frozen=True)
class Candidate:
    """Base class: see the module docstring."""

    name: ClassVar[str] = ""
    parameter: ClassVar[Parameter]
    additive: ClassVar[bool] = False
    n_nodes: ClassVar[int] = 4  # surrogate nodes over the prior (the null value is one of them)

    def apply(self, case: Case, value: float) -> Case:  # pragma: no cover - abstract
        raise NotImplementedError

    def nodes(self) -> tuple[float, ...]:
        """Parameter values at which the surrogate runs the full model (null value included)."""
        p = self.parameter
        u = [i / (self.n_nodes - 1) for i in range(self.n_nodes)]
        un = p.to_unit(p.null)
        k = min(range(len(u)), key=lambda i: abs(u[i] - un))
        u[k] = un
        return tuple(p.null if x == un else p.from_unit(x) for x in sorted(set(u)))

    def describe(self) -> str:
        return (self.__doc__ or self.name).strip().splitlines()[0]


def _thermal(case: Case, **kw) -> Case:
    return dataclasses.replace(case, thermal=dataclasses.replace(case.thermal, **kw))


def _friction(case: Case, **kw) -> Case:
    return dataclasses.replace(case, friction=dataclasses.replace(case.friction, **kw))


def _sources(case: Case, **kw) -> Case:
    return dataclasses.replace(case, sources=dataclasses.replace(case.sources, **kw))


@dataclasses.dataclass(frozen=True)
class ConvectionScale(Candidate):
    """Convection coefficients of teeth and sides multiplied by k (air trapped between the meshing
    teeth and shrouded by the bench, thesis 6.2, where the author lowered h by hand; k > 1: the
    rotating gear pumps more air than the flat-plate / rotating-disk correlations 5.1-5.6 say)."""

    name: ClassVar[str] = "convection_scale"
    parameter: ClassVar[Parameter] = Parameter("k_h", "-", 1.0, 0.3, 3.0, log=True)

    def apply(self, case: Case, value: float) -> Case:
        k = self.parameter.check(value)
        th = case.thermal
        return _thermal(
            case, h_teeth_factor=th.h_teeth_factor * k, h_sides_factor=th.h_sides_factor * k
        )


@dataclasses.dataclass(frozen=True)
class ConvectionSpeedExponent(Candidate):
    """Convection coefficients multiplied by (n / 1000 rpm)^s: the correlations' speed dependence
    is wrong (thesis 5.1.3/6.2: flat-plate and rotating-disk laws applied to a gear in a housing);
    s < 0: h grows more slowly with speed than the correlations say."""

    name: ClassVar[str] = "convection_speed_exponent"
    parameter: ClassVar[Parameter] = Parameter("s_h", "-", 0.0, -0.8, 0.8)
    n_nodes: ClassVar[int] = 3
    reference_rpm: ClassVar[float] = 1000.0

    def apply(self, case: Case, value: float) -> Case:
        s = self.parameter.check(value)
        f = (case.operating.speed_rpm / self.reference_rpm) ** s
        th = case.thermal
        return _thermal(
            case, h_teeth_factor=th.h_teeth_factor * f, h_sides_factor=th.h_sides_factor * f
        )


@dataclasses.dataclass(frozen=True)
class FrictionScale(Candidate):
    """Friction heat multiplied by m: a different mean friction coefficient than the cycle's 0.5
    (thesis 4.3.5: PEEK-PEEK mu between about 0.4 and 0.55 on the pin-on-disk; literature 0.1-0.5,
    thesis 4.2), or a heat partition other than one half into each gear."""

    name: ClassVar[str] = "friction_scale"
    parameter: ClassVar[Parameter] = Parameter("m_f", "-", 1.0, 0.2, 1.5)
    n_nodes: ClassVar[int] = 3

    def apply(self, case: Case, value: float) -> Case:
        m = self.parameter.check(value)
        return _sources(case, flux_scale=case.sources.flux_scale * m)


@dataclasses.dataclass(frozen=True)
class FrictionTemperature(Candidate):
    """Friction coefficient changing exponentially with the contact temperature,
    mu = mu_T exp(-beta (T - 25 C)) ([friction] temperature_coefficient_per_K; beta > 0 falls:
    thesis 4.3.5, PEEK-PEEK mu fell from 0.55 at 50 C to 0.40 at 75 C, about 0.013 /K, and kept
    falling up to 175 C; beta < 0 rises, as the twin-disk and pin-on-disk results across T_g quoted
    in thesis 4.2.1-4.2.2). Prior [-0.002, 0.008] /K: the upper end is the pin-on-disk's mean
    slope over 25-175 C, the lower end the steepest rise that keeps mu <= 2 with the other friction
    candidates up to 400 C. Acts like extra cooling (or heating) that scales with the friction
    power."""

    name: ClassVar[str] = "friction_temperature"
    parameter: ClassVar[Parameter] = Parameter("beta_mu", "1/K", 0.0, -0.002, 0.008)

    def apply(self, case: Case, value: float) -> Case:
        return _friction(case, temperature_coefficient_per_K=self.parameter.check(value))


@dataclasses.dataclass(frozen=True)
class HysteresisScale(Candidate):
    """Hysteresis heat multiplied by s: loss at the actual loading frequency rather than E''/E* at
    100 Hz with f = n/60 (thesis 3.4, 5.2.2: the tooth is loaded once per revolution for a few
    hundredths of it, a tooth-pass frequency z n/60 is 30 times higher; the WLF/Arrhenius shift
    changes H(T) near Tg)."""

    name: ClassVar[str] = "hysteresis_scale"
    parameter: ClassVar[Parameter] = Parameter("s_hyst", "-", 1.0, 1.0, 60.0)
    n_nodes: ClassVar[int] = 3

    def apply(self, case: Case, value: float) -> Case:
        s = self.parameter.check(value)
        return _sources(case, hysteresis_scale=case.sources.hysteresis_scale * s)


@dataclasses.dataclass(frozen=True)
class BoreHeatPath(Candidate):
    """Heat path from the bore through the hub and shaft to the ambient, h_b in W/(m^2 K) on the
    bore (the thesis modelled the bore adiabatic, 5.2.4; the bench gears sit on steel shafts)."""

    name: ClassVar[str] = "bore_heat_path"
    parameter: ClassVar[Parameter] = Parameter("h_bore", "W/(m^2 K)", 0.0, 0.0, 400.0)
    n_nodes: ClassVar[int] = 3

    def apply(self, case: Case, value: float) -> Case:
        return _thermal(case, bore_h_W_m2K=self.parameter.check(value), bore_C=None)


@dataclasses.dataclass(frozen=True)
class AmbientOffset(Candidate):
    """Air around the gears warmer than the recorded ambient by dT (the housing and the other gear
    heat it; the camera's atmospheric temperature was set to 21 C, thesis 6.1)."""

    name: ClassVar[str] = "ambient_offset"
    parameter: ClassVar[Parameter] = Parameter("dT_amb", "K", 0.0, -5.0, 15.0)
    additive: ClassVar[bool] = True

    def apply(self, case: Case, value: float) -> Case:
        d = self.parameter.check(value)
        th = case.thermal
        return _thermal(
            case,
            ambient_C=th.ambient_C + d,
            initial_C=None if th.initial_C is None else th.initial_C + d,
        )


LIBRARY: tuple[Candidate, ...] = (
    ConvectionScale(),
    ConvectionSpeedExponent(),
    FrictionScale(),
    FrictionTemperature(),
    HysteresisScale(),
    BoreHeatPath(),
    AmbientOffset(),
)


def by_name(name: str, library: tuple[Candidate, ...] = LIBRARY) -> Candidate:
    for c in library:
        if c.name == name:
            return c
    raise ParameterError("diagnose.candidate", name, f"one of {', '.join(c.name for c in library)}")


def apply_all(
    case: Case, model: dict[str, float], library: tuple[Candidate, ...] = LIBRARY
) -> Case:
    """The case with every candidate of ``model`` (name -> value) applied."""
    for name, value in model.items():
        case = by_name(name, library).apply(case, value)
    return case
