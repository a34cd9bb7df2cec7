"""Friction laws: the coefficient of friction as a function of the contact state (``[friction]``).

A law gives mu at a contact point from its **contact temperature** T (kelvin), its **contact
pressure** p (Pa) and its **sliding speed** v_s (m/s)::

    mu(T, p, v_s) = mu_T(T) * exp(-beta (T_b - T_ref)) * f_p(p_b) * f_v(v_b)

* ``mu_T(T)``, the law proper (``law``):

  - ``"constant"``: mu_T = ``mu`` (None: the cycle's ``contact.friction_coefficient``, today's
    model; the default reproduces it exactly);
  - ``"table"``: mu_T(T) linearly interpolated in a table (``table_file``, a CSV with columns
    ``temperature_C,mu``, or inline ``table_C = [[T_C...], [mu...]]``), constant beyond its ends;
  - ``"glass_transition"``: mu_T = mu_glassy + (mu_rubbery - mu_glassy) s((T - T_g)/w) with the
    smooth step s(x) = (1 + tanh x)/2 (10-90 % over 2.2 w), T_g = ``glass_transition_C`` (None:
    the DMA value of ``data/peek450g/viscoelastic.toml``, 143 C), w = ``transition_width_K``,
    mu_rubbery None: the cycle's mu (thesis 4.2.1-4.2.2: Hanchi and Hoskins saw 0.1-0.2 below and
    about 0.5 above T_g).

* ``exp(-beta (T_b - T_ref))``: an exponential temperature factor (``temperature_coefficient_per_K``
  beta, ``reference_C``; beta > 0 falls with T as thesis 4.3.5, beta < 0 rises); T_b is T bounded to
  ``temperature_range_C`` (the factor is constant beyond it, so the law stays bounded).
* ``f_p``: pressure factor (``pressure``): ``"none"``, ``"power"`` (p_b / p_ref)^e with
  ``pressure_exponent`` e and ``pressure_reference_MPa``, or ``"table"``
  (``pressure_table_MPa = [[p_MPa...], [factor...]]``, linear); p_b is p bounded to
  ``pressure_range_MPa`` (constant beyond). Thesis 4.3.5: PEEK-PEEK mu fell from 0.55 at 20 MPa to
  0.42 at 70 MPa, e = ln(0.42/0.55)/ln(70/20) = -0.215.
* ``f_v``: sliding-speed factor (``sliding_speed``), the same three forms with
  ``speed_exponent``, ``speed_reference_m_s``, ``speed_range_m_s``, ``speed_table_m_s`` (thesis
  4.3.5: PEEK-PEEK nearly constant over 1-100 mm/s, steel-PEEK 0.48 -> 0.56, e = 0.034).

Every law is checked on construction: mu within [0, 2] everywhere (the factors are constant beyond
their ranges, so the bound is exact up to the sampling of a smooth mu_T(T)), w > 0, tables strictly
increasing in their variable; a bad law raises :class:`~gearfem.core.errors.ParameterError` naming
the key. ``contact_temperature`` says which temperature the law sees: ``"flash"`` (flank
temperature + the Blok/Jaeger flash temperature of the contact, the default) or ``"flank"`` (the
flank temperature alone). ``flash_width`` says which contact half-width the flash temperature of a
band is computed with: ``"hertz"`` (default), the Hertz half-width of the band's load per unit
length on the local radii of curvature of the two surfaces (a tip round's radius where the contact
lies on the round), which converges with the mesh because the load is an integral; or
``"profile"``, the half-width of the band's pressure profile, which resolves a smooth flank contact
but shrinks with the mesh where a tip round enters (a corner, whose pressure peak does not
converge), so that the flash there, growing as the inverse square root of the width, is set by
the mesh; or ``"stated"``, one half-width for every band, ``flash_half_width_um`` (a length the
mesh does not change: the flash of a band is then its heat over that width, an integral of the
pressure, whatever the shape of its peak). ``pass_balance`` says how each gear's pass of the
two-pass contact lays its heat out: ``"cycle"`` (default), scaled once over the cycle to the mesh's
friction power, as the cycle's own flux; ``"tooth"``, scaled at every position and tooth to the
load of the tooth pair, which the passes split unevenly where they disagree
(:func:`gearfem.coupling.friction_heat.tooth_balance`).

How the law is used: the structural cycle is solved with the constant
``contact.friction_coefficient`` and records its contact history (:mod:`gearfem.cycle.history`); the
friction heat of any law is recomputed from that history with the pressures of the cycle and, when
the law depends on temperature, at every thermal step and Newton iteration
(:mod:`gearfem.coupling.friction_heat`). ``cycle_mu`` says which mu the cycle is solved with:
``"constant"`` (default), the case's ``contact.friction_coefficient`` (the law's effect on the
pressures is neglected); ``"law"`` and ``"effective"``, the cycle ↔ heat fixed point
(:func:`gearfem.pipeline.thermal_stages`). ``"law"``: the cycle is solved again with the law's mu
at each contact band at the run's thermal state (each gear's pass at that gear's contact
temperature, pressure and sliding speed; :mod:`gearfem.cycle.friction_field`), until the law's mu
at the contact bands moves by less than ``cycle_mu_tolerance`` (heat-weighted mean) from the mu
the cycle had there.
``"effective"``: one mu for every contact, the law's effective mu at the run's thermal state,
mu_eff = mu_c P_law / P_cycle (the constant mu that dissipates what the law does, as the torque
meters read it), until mu_c moves by less than the tolerance: a first-order coupling, kept to
measure what the law's mu per contact adds. Either stops after at most ``cycle_mu_max_passes``
cycles (not converged raises ConvergenceError). Each mu is rounded to a fiftieth of the
tolerance (:meth:`FrictionOptions.cycle_mu_step`), so that runs whose mu differs in round-off
solve and store the same cycle. Numpy only (no DOLFINx): ``config`` reads it.

**A new friction law** is a new value of ``law`` (or of a factor's form) here: its parameters as
fields with units in their names, validated in ``__post_init__``, its value and temperature
derivative in :class:`FrictionLaw`, and a test in ``tests/test_friction.py``.
"""

from __future__ import annotations

import csv
import dataclasses
import functools
import io
import math
from pathlib import Path

import numpy as np

from gearfem.core.errors import ParameterError
from gearfem.core.materials import ZERO_CELSIUS_K, read_toml
from gearfem.core.params import require_choice, require_int, require_positive, require_range

LAWS = ("constant", "table", "glass_transition")
FACTOR_FORMS = ("none", "power", "table")
CONTACT_TEMPERATURES = ("flash", "flank")
#: Contact half-widths the flash temperature of a band can be computed with (``flash_width``).
FLASH_WIDTHS = ("hertz", "profile", "stated")
#: Range of a stated flash half-width (um): from a tip round's Hertz width to a wide flank contact.
FLASH_HALF_WIDTH_RANGE_UM = (1.0, 5000.0)
#: How each gear's pass of the contact history is scaled (``pass_balance``).
PASS_BALANCES = ("cycle", "tooth")
#: Which mu the structural cycle is solved with (``cycle_mu``, see the module docstring).
CYCLE_MUS = ("constant", "law", "effective")
MU_MAX = 2.0
#: Width of the glass-transition step used by default (K): the DMA loss peak of PEEK 450G rises
#: from H = 0.014 at 129 C to 0.047 at 144 C (data/peek450g/hysteresis.csv), about 11 K for the
#: 10-90 % rise of a tanh step of w = 5 K.
DEFAULT_TRANSITION_WIDTH_K = 5.0


def dma_glass_transition_C() -> float:
    """T_g of PEEK 450G from the DMA data (``data/peek450g/viscoelastic.toml``, thesis 3.4)."""
    return float(read_toml("peek450g", "viscoelastic.toml")["dma"]["glass_transition_C"])


def _pair_table(name: str, value, var: str, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Validate a ``[[x...], [y...]]`` table: strictly increasing x within [lo, hi], y >= 0."""
    try:
        xs, ys = (np.asarray(v, dtype=float) for v in value)
    except (TypeError, ValueError) as err:
        raise ParameterError(name, value, f"[[{var}...], [values...]]") from err
    if xs.ndim != 1 or xs.shape != ys.shape or len(xs) < 1:
        raise ParameterError(name, value, f"two lists of equal length: [[{var}...], [values...]]")
    if not (np.all(np.isfinite(xs)) and np.all(np.isfinite(ys))):
        raise ParameterError(name, value, "finite numbers")
    if np.any(np.diff(xs) <= 0):
        raise ParameterError(name, value, f"a table strictly increasing in {var}")
    if xs[0] < lo or xs[-1] > hi:
        raise ParameterError(name, value, f"{var} within [{lo:g}, {hi:g}]")
    if np.any(ys < 0):
        raise ParameterError(name, value, "values >= 0")
    return xs, ys


def read_mu_table(path: str | Path) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """A mu(T) table from a CSV file with columns ``temperature_C,mu`` (``#`` comments)."""
    p = Path(path)
    if not p.is_file():
        raise ParameterError("friction.table_file", str(path), "an existing CSV file")
    lines = [ln for ln in p.read_text().splitlines() if ln.strip() and not ln.startswith("#")]
    rows = list(csv.DictReader(io.StringIO("\n".join(lines))))
    if not rows or {"temperature_C", "mu"} - set(rows[0]):
        raise ParameterError(
            "friction.table_file", str(path), "a CSV with columns temperature_C,mu"
        )
    try:
        t = tuple(float(r["temperature_C"]) for r in rows)
        m = tuple(float(r["mu"]) for r in rows)
    except ValueError as err:
        raise ParameterError("friction.table_file", str(path), "numbers in every row") from err
    return t, m


@dataclasses.dataclass(frozen=True)
class BandModel:
    """How the friction heat reads the bands of the contact history (from ``[friction]``, see
    :class:`FrictionOptions`): the flash half-width (``flash_width``; ``flash_half_width_m`` when
    ``"stated"``) and how each gear's pass is scaled (``pass_balance``)."""

    flash_width: str = "hertz"
    flash_half_width_m: float | None = None
    pass_balance: str = "cycle"

    def __post_init__(self) -> None:
        require_choice("friction.flash_width", self.flash_width, FLASH_WIDTHS)
        require_choice("friction.pass_balance", self.pass_balance, PASS_BALANCES)
        lo, hi = FLASH_HALF_WIDTH_RANGE_UM
        # the case's key is in um: its value as typed (to round-off of the m it is held in)
        um = None if self.flash_half_width_m is None else round(self.flash_half_width_m * 1e6, 6)
        if self.flash_width == "stated" and um is None:
            allowed = f"[{lo:g}, {hi:g}] um for flash_width 'stated'"
            raise ParameterError("friction.flash_half_width_um", None, allowed)
        if self.flash_width != "stated" and um is not None:
            raise ParameterError(
                "friction.flash_half_width_um",
                um,
                "absent unless flash_width = 'stated' (it would be ignored)",
            )
        if um is not None:
            require_range("friction.flash_half_width_um", um, lo, hi, unit="um")


#: The bands as the cycle reads them (its Hertz widths, its scale of the passes).
DEFAULT_BAND_MODEL = BandModel()


@dataclasses.dataclass(frozen=True)
class FrictionOptions:
    """``[friction]``: the friction law of the heat sources (see the module docstring).

    Keys that belong to another law than the chosen one must be left out (a key that would be
    silently ignored is an error). ``table_file`` is read on construction into ``table_C`` (the
    values are what the caches are keyed by); given together they must agree.

    Args:
        law: mu_T(T), the law proper: ``"constant"``, ``"table"`` or ``"glass_transition"``.
        mu: mu of the constant law (None: the cycle's ``[contact] friction_coefficient``).
        table_file, table_C: mu(T) of the table law: a CSV file with columns
            ``temperature_C,mu``, or inline ``[[T_C...], [mu...]]``; constant beyond its ends.
        mu_glassy, mu_rubbery: mu below and above the glass transition (``mu_rubbery`` None: the
            cycle's mu).
        glass_transition_C: T_g of the glass step (C; None: the gears' polymer's, 143 C for PEEK
            450G).
        transition_width_K: Width w of the glass step (K; None: 5 K, 10-90 % over 2.2 w).
        temperature_coefficient_per_K: beta of the factor exp(-beta (T - T_ref)) (1/K; > 0
            falls with temperature, 0: no factor).
        reference_C: T_ref of that factor (C).
        temperature_range_C: Temperatures (C) beyond which that factor stays constant.
        pressure: The pressure factor f_p: ``"none"``, ``"power"`` or ``"table"``.
        pressure_exponent, pressure_reference_MPa: e and p_ref of f_p = (p / p_ref)^e.
        pressure_range_MPa: Pressures (MPa) beyond which f_p stays constant.
        pressure_table_MPa: f_p as ``[[p_MPa...], [factor...]]``, linear between the points.
        sliding_speed: The sliding-speed factor f_v: ``"none"``, ``"power"`` or ``"table"``.
        speed_exponent, speed_reference_m_s: e and v_ref of f_v = (v_s / v_ref)^e.
        speed_range_m_s: Sliding speeds (m/s) beyond which f_v stays constant.
        speed_table_m_s: f_v as ``[[v_m_s...], [factor...]]``, linear between the points.
        contact_temperature: The temperature the law sees: ``"flash"`` (flank + flash
            temperature) or ``"flank"``.
        flash_width: The half-width a band's flash temperature is computed with: ``"hertz"``,
            ``"profile"`` or ``"stated"`` (the module docstring says what each converges to).
        flash_half_width_um: The half-width of ``flash_width = "stated"`` (um).
        pass_balance: How each gear's pass of the contact history lays its heat out:
            ``"cycle"`` (scaled once over the cycle) or ``"tooth"`` (at every position and tooth
            pair).
        cycle_mu: The mu the structural cycle is solved with: ``"constant"`` (``[contact]
            friction_coefficient``), ``"law"`` (the law's mu at each contact, iterated with the
            heat) or ``"effective"`` (the law's effective mu at every contact, iterated).
        cycle_mu_tolerance: The cycle ↔ heat iteration stops when the cycle's mu moves by less
            (``"law"``: the heat-weighted mean move at the contact bands).
        cycle_mu_max_passes: Cycles that iteration may solve at most (not converged: an error).
    """

    law: str = "constant"
    mu: float | None = None
    table_file: str | None = None
    table_C: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    mu_glassy: float | None = None
    mu_rubbery: float | None = None
    glass_transition_C: float | None = None
    transition_width_K: float | None = None
    temperature_coefficient_per_K: float = 0.0
    reference_C: float = 25.0
    temperature_range_C: tuple[float, float] = (-50.0, 400.0)
    pressure: str = "none"
    pressure_exponent: float | None = None
    pressure_reference_MPa: float | None = None
    pressure_range_MPa: tuple[float, float] = (1.0, 1000.0)
    pressure_table_MPa: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    sliding_speed: str = "none"
    speed_exponent: float | None = None
    speed_reference_m_s: float | None = None
    speed_range_m_s: tuple[float, float] = (1e-3, 10.0)
    speed_table_m_s: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    contact_temperature: str = "flash"
    flash_width: str = "hertz"
    flash_half_width_um: float | None = None
    pass_balance: str = "cycle"
    cycle_mu: str = "constant"
    cycle_mu_tolerance: float = 0.005
    cycle_mu_max_passes: int = 4

    def __post_init__(self) -> None:
        require_choice("friction.law", self.law, LAWS)
        require_choice("friction.cycle_mu", self.cycle_mu, CYCLE_MUS)
        require_range(
            "friction.cycle_mu_tolerance", self.cycle_mu_tolerance, 0.0, 0.1, lo_open=True
        )
        object.__setattr__(
            self,
            "cycle_mu_max_passes",
            require_int("friction.cycle_mu_max_passes", self.cycle_mu_max_passes, 1, 10),
        )
        require_choice("friction.pressure", self.pressure, FACTOR_FORMS)
        require_choice("friction.sliding_speed", self.sliding_speed, FACTOR_FORMS)
        require_choice(
            "friction.contact_temperature", self.contact_temperature, CONTACT_TEMPERATURES
        )
        _ = self.band_model  # built here: the flash width, its half-width and pass balance checked
        own = {
            "constant": ("mu",),
            "table": ("table_file", "table_C"),
            "glass_transition": (
                "mu_glassy",
                "mu_rubbery",
                "glass_transition_C",
                "transition_width_K",
            ),
        }
        self._only_for("law", self.law, own)
        if self.mu is not None:
            require_range("friction.mu", self.mu, 0.0, MU_MAX)
        if self.law == "table":
            self._resolve_table()
        if self.law == "glass_transition":
            if self.mu_glassy is None:
                raise ParameterError(
                    "friction.mu_glassy", None, f"[0, {MU_MAX:g}] for law 'glass_transition'"
                )
            require_range("friction.mu_glassy", self.mu_glassy, 0.0, MU_MAX)
            if self.mu_rubbery is not None:
                require_range("friction.mu_rubbery", self.mu_rubbery, 0.0, MU_MAX)
            if self.glass_transition_C is not None:
                require_range(
                    "friction.glass_transition_C",
                    self.glass_transition_C,
                    -273.15,
                    1000.0,
                    lo_open=True,
                    unit="C",
                )
            if self.transition_width_K is not None:
                require_range(
                    "friction.transition_width_K",
                    self.transition_width_K,
                    0.0,
                    200.0,
                    lo_open=True,
                    unit="K",
                )
        require_range(
            "friction.temperature_coefficient_per_K",
            self.temperature_coefficient_per_K,
            -0.1,
            0.1,
            unit="1/K",
        )
        require_range(
            "friction.reference_C", self.reference_C, -273.15, 1000.0, lo_open=True, unit="C"
        )
        self._range("friction.temperature_range_C", self.temperature_range_C, -273.15, 2000.0)
        self._factor_keys(
            "pressure",
            self.pressure,
            "pressure_exponent",
            "pressure_reference_MPa",
            "pressure_table_MPa",
        )
        self._range("friction.pressure_range_MPa", self.pressure_range_MPa, 0.0, 1e5, lo_open=True)
        self._factor_keys(
            "sliding_speed",
            self.sliding_speed,
            "speed_exponent",
            "speed_reference_m_s",
            "speed_table_m_s",
        )
        self._range("friction.speed_range_m_s", self.speed_range_m_s, 0.0, 1e3, lo_open=True)

    # -- validation helpers -------------------------------------------------------------------
    def _only_for(self, key: str, choice: str, own: dict[str, tuple[str, ...]]) -> None:
        for other, names in own.items():
            if other == choice:
                continue
            for n in names:
                if getattr(self, n) is not None:
                    raise ParameterError(
                        f"friction.{n}",
                        getattr(self, n),
                        f"unset with friction.{key} = {choice!r}",
                        f"it belongs to friction.{key} = {other!r}",
                    )

    def _range(self, name: str, value, lo: float, hi: float, lo_open: bool = False) -> None:
        if len(value) != 2:
            raise ParameterError(name, value, "[lower, upper]")
        a, b = value
        require_range(name, a, lo, hi, lo_open=lo_open)
        require_range(name, b, lo, hi, lo_open=lo_open)
        if not b > a:
            raise ParameterError(name, value, "lower < upper")

    def _factor_keys(self, key: str, form: str, exp: str, ref: str, table: str) -> None:
        own = {"power": (exp, ref), "table": (table,), "none": ()}
        self._only_for(key, form, own)
        if form == "power":
            for n in (exp, ref):
                if getattr(self, n) is None:
                    raise ParameterError(f"friction.{n}", None, f"a value for {key} = 'power'")
            require_range(f"friction.{exp}", getattr(self, exp), -2.0, 2.0)
            require_positive(f"friction.{ref}", getattr(self, ref))
        elif form == "table":
            if getattr(self, table) is None:
                raise ParameterError(f"friction.{table}", None, f"a table for {key} = 'table'")
            _pair_table(f"friction.{table}", getattr(self, table), key, 0.0, math.inf)

    def _resolve_table(self) -> None:
        if self.table_file is None and self.table_C is None:
            raise ParameterError(
                "friction.table_file", None, "a CSV file (or friction.table_C) for law 'table'"
            )
        if self.table_file is not None:
            from_file = read_mu_table(self.table_file)
            if self.table_C is not None and not np.allclose(
                np.asarray(self.table_C, dtype=float), np.asarray(from_file), rtol=0, atol=0
            ):
                raise ParameterError(
                    "friction.table_C",
                    self.table_C,
                    f"the values of friction.table_file {self.table_file!r}",
                    "both given and they differ: the file changed since the case was written?",
                )
            object.__setattr__(self, "table_C", from_file)
        name = "friction.table_file" if self.table_file is not None else "friction.table_C"
        _, mus = _pair_table(name, self.table_C, "temperature_C", -273.15, 2000.0)
        if np.any(mus > MU_MAX):
            raise ParameterError(name, self.table_C, f"mu within [0, {MU_MAX:g}]")

    # -- the law --------------------------------------------------------------------------------
    def pinned_to(self, cycle_mu: float) -> FrictionOptions:
        """These options with the defaults that follow the cycle's mu (``mu`` of the constant
        law, ``mu_rubbery`` of the glass transition) set to ``cycle_mu``: the same law whatever
        mu a later cycle is solved with."""
        if self.law == "constant" and self.mu is None:
            return dataclasses.replace(self, mu=float(cycle_mu))
        if self.law == "glass_transition" and self.mu_rubbery is None:
            return dataclasses.replace(self, mu_rubbery=float(cycle_mu))
        return self

    def law_for(self, cycle_mu: float) -> FrictionLaw:
        """The law with its defaults resolved against the cycle's friction coefficient
        (validates mu <= 2 everywhere)."""
        require_range("contact.friction_coefficient", cycle_mu, 0.0, MU_MAX)
        return FrictionLaw(self, float(cycle_mu))

    @property
    def cycle_mu_step(self) -> float:
        """The grid the cycle's mu of the ``"law"`` fixed point is rounded to: a fiftieth of
        ``cycle_mu_tolerance`` (1e-4 by default), well inside it."""
        return self.cycle_mu_tolerance / 50.0

    def rounded_cycle_mu(self, mu: float) -> float:
        """``mu`` on the :attr:`cycle_mu_step` grid (the value the cycle is solved and keyed
        with: a run whose effective mu differs in round-off finds the same stored cycle)."""
        step = self.cycle_mu_step
        return float(f"{round(float(mu) / step) * step:.12g}")

    @functools.cached_property
    def band_model(self) -> BandModel:
        """How the contact history's bands are read (width of the flash, scale of the passes);
        built, and so validated, once per options."""
        half = None if self.flash_half_width_um is None else self.flash_half_width_um * 1e-6
        return BandModel(self.flash_width, half, self.pass_balance)

    @property
    def is_default(self) -> bool:
        """True when the law is the cycle's constant mu with no factor (today's model)."""
        return (
            self.law == "constant"
            and self.mu is None
            and self.temperature_coefficient_per_K == 0.0
            and self.pressure == "none"
            and self.sliding_speed == "none"
        )


class FrictionLaw:
    """A resolved friction law (see the module docstring): ``mu(T_K, p_Pa, v_m_s)`` and its
    temperature derivative on numpy arrays. Built by :meth:`FrictionOptions.law_for`."""

    def __init__(self, options: FrictionOptions, cycle_mu: float) -> None:
        o = options
        self.options, self.cycle_mu = o, cycle_mu
        self.law = o.law
        if o.law == "constant":
            self.mu0 = cycle_mu if o.mu is None else float(o.mu)
        elif o.law == "table":
            t, m = (np.asarray(v, dtype=float) for v in o.table_C)
            self._tab_T, self._tab_mu = t + ZERO_CELSIUS_K, m
        else:
            self.mu_glassy = float(o.mu_glassy)
            self.mu_rubbery = cycle_mu if o.mu_rubbery is None else float(o.mu_rubbery)
            tg = dma_glass_transition_C() if o.glass_transition_C is None else o.glass_transition_C
            self.tg_K = float(tg) + ZERO_CELSIUS_K
            self.width_K = (
                DEFAULT_TRANSITION_WIDTH_K
                if o.transition_width_K is None
                else float(o.transition_width_K)
            )
        self.beta = float(o.temperature_coefficient_per_K)
        self.t_ref_K = o.reference_C + ZERO_CELSIUS_K
        self.t_range_K = tuple(t + ZERO_CELSIUS_K for t in o.temperature_range_C)
        self._p = self._factor(
            o.pressure,
            o.pressure_exponent,
            None if o.pressure_reference_MPa is None else o.pressure_reference_MPa * 1e6,
            tuple(p * 1e6 for p in o.pressure_range_MPa),
            None
            if o.pressure_table_MPa is None
            else (np.asarray(o.pressure_table_MPa[0]) * 1e6, np.asarray(o.pressure_table_MPa[1])),
        )
        self._v = self._factor(
            o.sliding_speed,
            o.speed_exponent,
            o.speed_reference_m_s,
            tuple(o.speed_range_m_s),
            None
            if o.speed_table_m_s is None
            else (np.asarray(o.speed_table_m_s[0]), np.asarray(o.speed_table_m_s[1])),
        )
        self._check_bounds()

    # -- parts ------------------------------------------------------------------------------
    @staticmethod
    def _factor(form, exponent, reference, bounds, table):
        return {"form": form, "e": exponent, "ref": reference, "bounds": bounds, "table": table}

    @staticmethod
    def _factor_value(f, x) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if f["form"] == "none":
            return np.ones_like(x)
        if f["form"] == "power":
            lo, hi = f["bounds"]
            return (np.clip(x, lo, hi) / f["ref"]) ** f["e"]
        xs, ys = f["table"]
        return np.interp(x, xs, ys)

    def base(self, T_K) -> np.ndarray:
        """mu_T(T) (the law proper, without the factors)."""
        T = np.asarray(T_K, dtype=float)
        if self.law == "constant":
            return np.full_like(T, self.mu0)
        if self.law == "table":
            return np.interp(T, self._tab_T, self._tab_mu)
        s = 0.5 * (1.0 + np.tanh((T - self.tg_K) / self.width_K))
        return self.mu_glassy + (self.mu_rubbery - self.mu_glassy) * s

    def base_derivative(self, T_K) -> np.ndarray:
        """d mu_T / dT (1/K); for a table the slope of the segment (zero beyond the ends)."""
        T = np.asarray(T_K, dtype=float)
        if self.law == "constant":
            return np.zeros_like(T)
        if self.law == "table":
            t, m = self._tab_T, self._tab_mu
            if len(t) == 1:
                return np.zeros_like(T)
            slopes = np.diff(m) / np.diff(t)
            i = np.clip(np.searchsorted(t, T, side="right") - 1, 0, len(slopes) - 1)
            return np.where((t[0] <= T) & (t[-1] > T), slopes[i], 0.0)
        e = np.exp(-2.0 * np.abs((T - self.tg_K) / self.width_K))
        sech2 = 4.0 * e / (1.0 + e) ** 2  # 1/cosh² without overflow
        return (self.mu_rubbery - self.mu_glassy) * 0.5 * sech2 / self.width_K

    def temperature_factor(self, T_K) -> np.ndarray:
        if self.beta == 0.0:
            return np.ones_like(np.asarray(T_K, dtype=float))
        lo, hi = self.t_range_K
        return np.exp(-self.beta * (np.clip(T_K, lo, hi) - self.t_ref_K))

    def temperature_factor_derivative(self, T_K) -> np.ndarray:
        T = np.asarray(T_K, dtype=float)
        if self.beta == 0.0:
            return np.zeros_like(T)
        lo, hi = self.t_range_K
        inside = (lo < T) & (hi > T)
        return np.where(inside, -self.beta * self.temperature_factor(T), 0.0)

    def pressure_factor(self, p_Pa) -> np.ndarray:
        return self._factor_value(self._p, p_Pa)

    def speed_factor(self, v_m_s) -> np.ndarray:
        return self._factor_value(self._v, v_m_s)

    # -- the law --------------------------------------------------------------------------------
    def mu(self, T_K, p_Pa, v_m_s) -> np.ndarray:
        """mu at contact temperature T (K), pressure p (Pa), sliding speed v_s (m/s)."""
        return (
            self.base(T_K)
            * self.temperature_factor(T_K)
            * self.pressure_factor(p_Pa)
            * self.speed_factor(v_m_s)
        )

    def dmu_dT(self, T_K, p_Pa, v_m_s) -> np.ndarray:
        """d mu / dT at fixed p, v (1/K)."""
        dt = self.base_derivative(T_K) * self.temperature_factor(T_K) + self.base(
            T_K
        ) * self.temperature_factor_derivative(T_K)
        return dt * self.pressure_factor(p_Pa) * self.speed_factor(v_m_s)

    def mu_of_T(self, T_K) -> np.ndarray:
        """mu_T(T) times the temperature factor (the temperature part of the law)."""
        return self.base(T_K) * self.temperature_factor(T_K)

    def dmu_of_T_dT(self, T_K) -> np.ndarray:
        """d/dT of :meth:`mu_of_T` (1/K)."""
        return self.base_derivative(T_K) * self.temperature_factor(T_K) + self.base(
            T_K
        ) * self.temperature_factor_derivative(T_K)

    @property
    def depends_on_temperature(self) -> bool:
        return self.law != "constant" or self.beta != 0.0

    @property
    def is_constant(self) -> bool:
        return (
            not self.depends_on_temperature
            and self._p["form"] == "none"
            and self._v["form"] == "none"
        )

    @property
    def may_rise_with_temperature(self) -> bool:
        """True when d mu/dT > 0 somewhere: friction heat that grows with T can make the thermal
        Jacobian indefinite and allow several steady states."""
        if not self.depends_on_temperature:
            return False
        T = self._temperature_grid()
        return bool(
            np.any(
                self.base_derivative(T) * self.temperature_factor(T)
                + self.base(T) * self.temperature_factor_derivative(T)
                > 0.0
            )
        )

    def _temperature_grid(self) -> np.ndarray:
        lo, hi = self.t_range_K
        pts = [np.linspace(lo - 1.0, hi + 1.0, 4001)]
        if self.law == "table":
            pts.append(self._tab_T)
        if self.law == "glass_transition":
            pts.append(self.tg_K + self.width_K * np.linspace(-8.0, 8.0, 801))
        return np.unique(np.concatenate(pts))

    @staticmethod
    def _factor_extremes(f) -> tuple[float, float]:
        if f["form"] == "none":
            return 1.0, 1.0
        if f["form"] == "power":
            vals = (np.asarray(f["bounds"]) / f["ref"]) ** f["e"]
        else:
            vals = f["table"][1]
        return float(np.min(vals)), float(np.max(vals))

    def _check_bounds(self) -> None:
        T = self._temperature_grid()
        mt = self.mu_of_T(T)
        p_lo, p_hi = self._factor_extremes(self._p)
        v_lo, v_hi = self._factor_extremes(self._v)
        top = float(mt.max()) * p_hi * v_hi
        bottom = float(mt.min()) * p_lo * v_lo
        if top <= MU_MAX and bottom >= 0.0:
            return
        # name the key that takes the law out of range
        if float(mt.max()) > MU_MAX:
            key = "temperature_coefficient_per_K" if self.beta != 0.0 else self.law
            val = self.beta if self.beta != 0.0 else self.options.law
        elif p_hi >= v_hi:
            key, val = "pressure", self.options.pressure
        else:
            key, val = "sliding_speed", self.options.sliding_speed
        raise ParameterError(
            f"friction.{key}",
            val,
            f"a law with mu in [0, {MU_MAX:g}] everywhere",
            f"mu reaches {top:.3g} (max of mu_T(T) times the factors {float(mt.max()):.3g} x "
            f"{p_hi:.3g} x {v_hi:.3g} over their ranges)",
        )

    def describe(self) -> str:
        o = self.options
        if self.law == "constant":
            txt = f"mu = {self.mu0:g}"
        elif self.law == "table":
            txt = f"mu(T) from a table of {len(self._tab_T)} points"
        else:
            txt = (
                f"mu = {self.mu_glassy:g} + ({self.mu_rubbery:g} - {self.mu_glassy:g}) "
                f"s((T - {self.tg_K - ZERO_CELSIUS_K:g} C)/{self.width_K:g} K)"
            )
        if self.beta != 0.0:
            txt += f" x exp(-{self.beta:g} (T - {o.reference_C:g} C))"
        if o.pressure == "power":
            txt += f" x (p/{o.pressure_reference_MPa:g} MPa)^{o.pressure_exponent:g}"
        elif o.pressure == "table":
            txt += " x f(p) (table)"
        if o.sliding_speed == "power":
            txt += f" x (v_s/{o.speed_reference_m_s:g} m/s)^{o.speed_exponent:g}"
        elif o.sliding_speed == "table":
            txt += " x f(v_s) (table)"
        return txt


__all__ = [
    "CONTACT_TEMPERATURES",
    "FACTOR_FORMS",
    "LAWS",
    "FrictionLaw",
    "FrictionOptions",
    "dma_glass_transition_C",
    "read_mu_table",
]
