"""Measured data for the diagnosis: a documented CSV format, its reader and the thesis bench file.

Format (one measurement per row; lines starting with ``#`` are comments; header required)::

    speed_rpm,torque_Nm,time_s,quantity,value,uncertainty,ambient_C
    1000,8,,camera_max,110,3.0,21
    1000,8,300,probe:web,61.5,1.0,21
    1000,8,,torque_loss_Nm,0.052,0.06,21

* ``speed_rpm`` (pinion), ``torque_Nm`` (resisting torque on the wheel): the operating point.
* ``time_s``: time since start (cold gear at ambient); empty = the equilibrium (end) value, i.e.
  the steady state of the model (the thesis bench values are "after about 15 minutes, judged to be
  thermal equilibrium").
* ``quantity``: what was measured, and by which instrument (:mod:`gearfem.instruments`):
  ``camera_max`` (the hottest pixel of the IR camera of ``[instruments.camera]``),
  ``probe:NAME`` (the probe ``[instruments.probes.NAME]``: a thermocouple, a side-face spot...),
  ``torque_loss_Nm`` and ``efficiency`` (the torque meters), or one of the thermal model's
  reported field temperatures :data:`FIELD_QUANTITIES` (``max_surface``: the hottest surface node,
  ``mean_bulk``, ``flank_mean``...: what a perfect probe of that quantity would read).
* ``value``: the measured value in the quantity's unit (C for temperatures, N m for the torque
  loss, 1 for the efficiency). ``uncertainty``: its standard uncertainty (u_D of ASME V&V 20) in
  the same unit (K for temperatures), > 0. ``ambient_C``: the recorded air/surroundings
  temperature of that run, C. The older header names ``value_C`` and ``uncertainty_K`` are read
  as ``value`` and ``uncertainty``.

Rows with the same (speed, torque, ambient, quantity) are samples of one temperature curve: they
are not independent (see :meth:`Dataset.n_effective`).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import re
from collections.abc import Iterable
from pathlib import Path

from gearfem.core.errors import ParameterError
from gearfem.core.params import require_finite, require_positive, require_range
from gearfem.instruments.options import FIELD_QUANTITIES, CameraOptions

#: Quantities read by instruments (``probe:NAME`` for every configured probe besides).
INSTRUMENT_QUANTITIES = ("camera_max", "torque_loss_Nm", "efficiency")
#: Every fixed quantity name of a data file.
QUANTITIES = (*FIELD_QUANTITIES, *INSTRUMENT_QUANTITIES)
UNITS = {"torque_loss_Nm": "N m", "efficiency": "1"}
COLUMNS = ("speed_rpm", "torque_Nm", "time_s", "quantity", "value", "uncertainty", "ambient_C")
_LEGACY = {"value_C": "value", "uncertainty_K": "uncertainty"}
_PROBE = re.compile(r"^probe:[A-Za-z][A-Za-z0-9_-]*$")


def check_quantity(quantity: str, name: str = "data.quantity") -> str:
    """``quantity`` if it is a known quantity name or ``probe:NAME``, else a ParameterError."""
    if quantity in QUANTITIES or _PROBE.match(quantity):
        return quantity
    raise ParameterError(name, quantity, "one of " + ", ".join(QUANTITIES) + " or probe:NAME")


def unit_of(quantity: str) -> str:
    """The unit of a quantity's value ("C" for temperatures)."""
    return UNITS.get(quantity, "C")


@dataclasses.dataclass(frozen=True)
class Measurement:
    """One measured value (see the module docstring for the fields)."""

    speed_rpm: float
    torque_Nm: float
    time_s: float | None
    quantity: str
    value: float
    uncertainty: float
    ambient_C: float

    def __post_init__(self) -> None:
        require_positive("data.speed_rpm", self.speed_rpm)
        require_positive("data.torque_Nm", self.torque_Nm)
        if self.time_s is not None:
            require_positive("data.time_s", self.time_s)
        check_quantity(self.quantity)
        if self.is_temperature:
            require_range("data.value", self.value, -273.15, 1000.0, lo_open=True, unit="C")
        else:
            require_finite("data.value", self.value)
        require_positive("data.uncertainty", self.uncertainty)
        require_range("data.ambient_C", self.ambient_C, -273.15, 1000.0, lo_open=True, unit="C")

    @property
    def unit(self) -> str:
        return unit_of(self.quantity)

    @property
    def is_temperature(self) -> bool:
        return self.unit == "C"

    @property
    def point(self) -> tuple[float, float, float]:
        """The operating point of the run: (speed_rpm, torque_Nm, ambient_C)."""
        return (self.speed_rpm, self.torque_Nm, self.ambient_C)

    @property
    def series(self) -> tuple[float, float, float, str]:
        """The temperature curve this sample belongs to."""
        return (*self.point, self.quantity)

    def label(self) -> str:
        t = "end" if self.time_s is None else f"{self.time_s:g} s"
        return f"{self.speed_rpm:g} rpm {self.torque_Nm:g} N m, {self.quantity} @ {t}"


@dataclasses.dataclass(frozen=True)
class Dataset:
    """Measurements (validated; at least one)."""

    measurements: tuple[Measurement, ...]
    source: str = ""

    def __post_init__(self) -> None:
        if not self.measurements:
            raise ParameterError("data", 0, "at least one measurement row")
        seen = set()
        for m in self.measurements:
            key = (m.series, m.time_s)
            if key in seen:
                raise ParameterError(
                    "data.time_s",
                    m.time_s,
                    "one row per (operating point, quantity, time)",
                    f"duplicate row {m.label()}",
                )
            seen.add(key)

    def __len__(self) -> int:
        return len(self.measurements)

    @property
    def points(self) -> tuple[tuple[float, float, float], ...]:
        """Distinct operating points (speed_rpm, torque_Nm, ambient_C), in file order."""
        return tuple(dict.fromkeys(m.point for m in self.measurements))

    @property
    def torques(self) -> tuple[float, ...]:
        return tuple(sorted({m.torque_Nm for m in self.measurements}))

    @property
    def times(self) -> tuple[float, ...]:
        """Distinct finite sample times (s), sorted (end values excluded)."""
        return tuple(sorted({m.time_s for m in self.measurements if m.time_s is not None}))

    def series_weights(self) -> list[float]:
        """Per-row weight of its squared residual so that each curve counts as at most two data.

        A curve (operating point and quantity) sampled k times carries its level and, with k >= 2,
        its rate (time constant); the samples are strongly correlated, so the curve is worth
        min(k, 2) independent data, and each of its k samples gets the weight min(k, 2)/k.
        """
        counts: dict[tuple, int] = {}
        for m in self.measurements:
            counts[m.series] = counts.get(m.series, 0) + 1
        return [min(counts[m.series], 2) / counts[m.series] for m in self.measurements]

    def n_effective(self) -> int:
        """Honest count of independent data: sum over curves of min(samples, 2)."""
        return round(sum(self.series_weights()))

    def subset(self, keep: Iterable[bool]) -> Dataset:
        return Dataset(tuple(m for m, k in zip(self.measurements, keep) if k), self.source)

    def without_point(self, point: tuple[float, float, float]) -> Dataset:
        return self.subset(m.point != point for m in self.measurements)


def _float(text: str, name: str, row: int, optional: bool = False) -> float | None:
    text = text.strip()
    if text == "" and optional:
        return None
    try:
        value = float(text)
    except ValueError:
        raise ParameterError(
            f"data row {row}: {name}", text, "a number" + (" or empty" if optional else "")
        ) from None
    if not math.isfinite(value):
        raise ParameterError(f"data row {row}: {name}", text, "a finite number")
    return value


def parse_csv(text: str, source: str = "") -> Dataset:
    """Parse the measured-data CSV (see the module docstring)."""
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise ParameterError("data", source or "<text>", "a header line and at least one row")
    reader = csv.reader(io.StringIO("\n".join(lines)))
    header = [_LEGACY.get(h.strip(), h.strip()) for h in next(reader)]
    missing = [c for c in COLUMNS if c not in header]
    unknown = [c for c in header if c not in COLUMNS]
    if missing or unknown:
        raise ParameterError(
            "data header",
            ",".join(header),
            f"the columns {','.join(COLUMNS)}",
            f"missing {missing}, unknown {unknown}",
        )
    out = []
    for i, row in enumerate(reader, start=1):
        if len(row) != len(header):
            raise ParameterError(
                f"data row {i}", ",".join(row), f"{len(header)} comma-separated values"
            )
        r = dict(zip(header, row))
        out.append(
            Measurement(
                speed_rpm=_float(r["speed_rpm"], "speed_rpm", i),
                torque_Nm=_float(r["torque_Nm"], "torque_Nm", i),
                time_s=_float(r["time_s"], "time_s", i, optional=True),
                quantity=check_quantity(r["quantity"].strip(), f"data row {i}: quantity"),
                value=_float(r["value"], "value", i),
                uncertainty=_float(r["uncertainty"], "uncertainty", i),
                ambient_C=_float(r["ambient_C"], "ambient_C", i),
            )
        )
    return Dataset(tuple(out), source)


def read_csv(path: str | Path) -> Dataset:
    """Read a measured-data CSV file; a file in the thesis bench format is converted (see below)."""
    path = Path(path)
    if not path.is_file():
        raise ParameterError("data file", str(path), "an existing CSV file")
    text = path.read_text()
    first = next(
        (ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")), ""
    )
    if "measured_max_surface_C" in first:
        return thesis_bench(text, str(path))
    return parse_csv(text, str(path))


def write_csv(data: Dataset, path: str | Path, comment: str = "") -> Path:
    path = Path(path)
    lines = [f"# {ln}" for ln in comment.splitlines()] + [",".join(COLUMNS)]
    for m in data.measurements:
        t = "" if m.time_s is None else f"{m.time_s:g}"
        lines.append(
            f"{m.speed_rpm:g},{m.torque_Nm:g},{t},{m.quantity},{m.value:.6g},{m.uncertainty:g},"
            f"{m.ambient_C:g}"
        )
    path.write_text("\n".join(lines) + "\n")
    return path


def camera_uncertainty_K(value_C: float, camera: CameraOptions | None = None) -> float:
    """Standard uncertainty of the thesis bench's IR camera maximum (K).

    The camera's stated accuracy (FLIR E40: +-2 C or +-2 % of reading, whichever is larger,
    :meth:`CameraOptions.uncertainty_K`), taken as one standard uncertainty, combined in quadrature
    with 2 K for what the single end value does not tell: "equilibrium" judged by the operators
    after about 15 min, and the maximum read from a video by post-processing. What the camera
    does with emissivity, footprint and rotation is modelled by ``camera_max`` itself
    (:mod:`gearfem.instruments.camera`); the surface emissivity's own uncertainty is an input
    uncertainty of the model (V&V 20 u_input). An assumption, documented in docs/diagnosis.md.
    """
    camera = camera or CameraOptions()
    return math.hypot(camera.uncertainty_K(value_C), 2.0)


def thesis_bench(text: str, source: str = "") -> Dataset:
    """Convert the thesis bench file (``testbench/thesis_testbench.csv``): the IR camera's
    maximum (``camera_max``) as an end (equilibrium) value, ambient = the camera's atmospheric
    temperature, uncertainty :func:`camera_uncertainty_K`."""
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    rows = list(csv.DictReader(io.StringIO("\n".join(lines))))
    out = []
    for i, r in enumerate(rows, start=1):
        value = _float(r["measured_max_surface_C"], "measured_max_surface_C", i)
        out.append(
            Measurement(
                speed_rpm=_float(r["speed_rpm"], "speed_rpm", i),
                torque_Nm=_float(r["torque_Nm"], "torque_Nm", i),
                time_s=None,
                quantity="camera_max",
                value=value,
                uncertainty=camera_uncertainty_K(value),
                ambient_C=_float(r["camera_ambient_C"], "camera_ambient_C", i),
            )
        )
    return Dataset(tuple(out), source)
