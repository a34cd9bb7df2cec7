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


def _plain_friction(case: Case, name: str, key: str) -> None:
    """A candidate that sets one part of the friction law needs that part unset in the case."""
    f = case.friction
    busy = {
        "law": f.law != "constant" or f.mu is not None,
        "pressure": f.pressure != "none",
        "sliding_speed": f.sliding_speed != "none",
    }[key]
    if busy:
        raise ParameterError(
            f"candidate {name}",
            getattr(f, key),
            f"a case whose [friction] {key} is the default",
            "the candidate replaces it",
        )


@dataclasses.dataclass(frozen=True)
class FrictionGlassTransition(Candidate):
    """Friction coefficient stepping up across the glass transition at the contact temperature:
    mu = mu_g + (mu_r - mu_g) s((T - T_g)/w), T_g = 143 C from the DMA data (viscoelastic.toml),
    w = 5 K, mu_r = the cycle's mu (0.5). Thesis 4.2.1-4.2.2: Hanchi (pin-on-disk, PEEK 380G on
    steel) and Hoskins (twin disk, PEEK 450G) saw mu rise from 0.2 and 0.1 below T_g to about 0.5
    above it; prior mu_g in [0.1, 0.5] (0.5: no step, the model unchanged). With flash
    temperatures a cool, glassy branch and a hot, rubbery one can both be steady."""

    name: ClassVar[str] = "friction_glass_transition"
    parameter: ClassVar[Parameter] = Parameter("mu_g", "-", 0.5, 0.1, 0.5)

    def apply(self, case: Case, value: float) -> Case:
        v = self.parameter.check(value)
        if v == self.parameter.null:
            return case
        _plain_friction(case, self.name, "law")
        return _friction(case, law="glass_transition", mu=None, mu_glassy=v)


@dataclasses.dataclass(frozen=True)
class FrictionPressure(Candidate):
    """Friction coefficient falling (or rising) with the contact pressure, mu = mu_c (p / 30
    MPa)^e, constant below 15 and above 400 MPa. Thesis 4.3.5: PEEK-PEEK mu fell from 0.55 at 20
    MPa to 0.42 at 70 MPa, e = -0.215; the pin-on-disk's temperature and speed sweeps ran at 30 MPa,
    where mu_c holds. Prior e in [-0.45, 0.1] (about twice the measured fall, and a slight rise).
    Needs operating points at different torques to be told from friction_scale."""

    name: ClassVar[str] = "friction_pressure"
    parameter: ClassVar[Parameter] = Parameter("e_p", "-", 0.0, -0.45, 0.1)

    def apply(self, case: Case, value: float) -> Case:
        v = self.parameter.check(value)
        if v == self.parameter.null:
            return case
        _plain_friction(case, self.name, "pressure")
        return _friction(
            case,
            pressure="power",
            pressure_exponent=v,
            pressure_reference_MPa=30.0,
            pressure_range_MPa=(15.0, 400.0),
        )


@dataclasses.dataclass(frozen=True)
class FrictionSlidingSpeed(Candidate):
    """Friction coefficient changing with the sliding speed, mu = mu_c (v_s / 0.1 m/s)^e,
    constant below 0.02 and above 2 m/s. Thesis 4.3.5: PEEK-PEEK nearly constant from 1 to
    100 mm/s, steel-PEEK 0.48 -> 0.56 (e = 0.034); the gear slides at up to about 1 m/s, ten
    times faster than the tribometer could. Prior e in [-0.15, 0.15]: four times the measured
    slope, for the extrapolation by a decade."""

    name: ClassVar[str] = "friction_sliding_speed"
    parameter: ClassVar[Parameter] = Parameter("e_v", "-", 0.0, -0.15, 0.15)
    n_nodes: ClassVar[int] = 3

    def apply(self, case: Case, value: float) -> Case:
        v = self.parameter.check(value)
        if v == self.parameter.null:
            return case
        _plain_friction(case, self.name, "sliding_speed")
        return _friction(
            case,
            sliding_speed="power",
            speed_exponent=v,
            speed_reference_m_s=0.1,
            speed_range_m_s=(0.02, 2.0),
        )


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


#: The candidates of the first diagnosis (issue 8): their hidden-effect tests use one torque.
CLASSIC_LIBRARY: tuple[Candidate, ...] = (
    ConvectionScale(),
    ConvectionSpeedExponent(),
    FrictionScale(),
    FrictionTemperature(),
    HysteresisScale(),
    BoreHeatPath(),
    AmbientOffset(),
)
#: Friction laws (issue 15): the pressure law acts like friction_scale at one torque, so these
#: need data at more than one torque (their hidden-effect tests use two).
FRICTION_LAWS: tuple[Candidate, ...] = (
    FrictionGlassTransition(),
    FrictionPressure(),
    FrictionSlidingSpeed(),
)
LIBRARY: tuple[Candidate, ...] = CLASSIC_LIBRARY + FRICTION_LAWS


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
