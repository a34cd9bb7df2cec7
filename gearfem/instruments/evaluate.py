"""Every configured instrument's reading of a run's snapshot (numpy and matplotlib only, on one
rank): the camera, the probes and the torque meters, at each reported time of the run."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from gearfem.core.errors import ParameterError
from gearfem.core.results import JsonRecord
from gearfem.instruments.camera import Camera, CameraReading
from gearfem.instruments.options import InstrumentOptions
from gearfem.instruments.probes import ProbeReading, read_probe
from gearfem.instruments.scene import gear_surface
from gearfem.instruments.snapshot import FieldSnapshot
from gearfem.instruments.thermogram import write_csv, write_png
from gearfem.instruments.torque import TorqueReading, read_torque

INSTRUMENTS = ("camera", "probes", "torque")
TORQUE_QUANTITIES = ("torque_loss_Nm", "efficiency")


@dataclasses.dataclass(frozen=True)
class InstrumentReadings(JsonRecord):
    """The readings of a run (``summary.json`` "instruments").

    Attributes:
        labels: The reported times (``"900"``, ``"end"``, ``"steady"``); ``times_s`` their times
            (None: steady state).
        camera: The camera's reading at each label.
        probes: Each probe's reading at each label (label -> name -> reading).
        torque: The torque meters' reading at the end value (the steady state when the run has
            one, else the end of the run; None without a cycle).
        torque_at: Their reading at each label (the power of the active friction law and the
            hysteresis at that state, :func:`gearfem.instruments.torque.read_torque`; empty when
            the snapshot does not keep both gears' heat: then ``torque`` is the cycle's reading).
        files: The thermogram files written (relative to the output directory).
    """

    labels: tuple[str, ...]
    times_s: tuple[float | None, ...]
    camera: dict[str, CameraReading]
    probes: dict[str, dict[str, ProbeReading]]
    torque: TorqueReading | None = None
    files: tuple[str, ...] = ()
    torque_at: dict[str, TorqueReading] = dataclasses.field(default_factory=dict)

    def value(self, quantity: str, label: str) -> float:
        """The reading of a measured quantity (``camera_max``, ``probe:NAME``,
        ``torque_loss_Nm``, ``efficiency``) at a label."""
        if quantity in TORQUE_QUANTITIES:
            if self.torque is None:
                raise ParameterError(
                    "quantity", quantity, "a run with torque meters and a contact cycle"
                )
            return float(getattr(self.torque_at.get(label, self.torque), quantity))
        if quantity == "camera_max":
            if label not in self.camera:
                raise ParameterError("quantity", quantity, "a run with the camera enabled")
            return self.camera[label].max_C
        if quantity.startswith("probe:"):
            name = quantity.partition(":")[2]
            got = self.probes.get(label, {})
            if name not in got:
                raise ParameterError(
                    "quantity", quantity, "probe:NAME of a configured probe: " + ", ".join(got)
                )
            return got[name].value_C
        raise ParameterError(
            "quantity", quantity, "camera_max, probe:NAME, torque_loss_Nm or efficiency"
        )


def target_point_m(options, snapshot: FieldSnapshot) -> np.ndarray:
    """The camera's target: ``target_mm``, or half way between the axes at mid face width."""
    if options.target_mm is not None:
        return np.asarray(options.target_mm, dtype=float) * 1e-3
    centers = np.array([b.center_m for b in snapshot.bodies.values()])
    mid = centers.mean(axis=0)
    return np.array([mid[0], mid[1], 0.5 * snapshot.face_width_m])


def camera_of(
    options: InstrumentOptions,
    snapshot: FieldSnapshot,
    rows: list[int],
    views_dir: str | Path | None = None,
) -> Camera:
    """The camera of ``options`` on the snapshot's gears at the snapshot rows ``rows`` (its phase
    views stored in ``views_dir``: :class:`~gearfem.instruments.camera.Camera`)."""
    cam = options.camera
    missing = [b for b in ("pinion", "wheel") if b not in snapshot.bodies]
    if missing:
        raise ParameterError(
            "instruments.camera.enabled",
            True,
            "a run with both gears' temperature fields",
            f"the snapshot has no {', '.join(missing)}",
        )
    surfaces = {}
    for name, bf in snapshot.bodies.items():
        sub = dataclasses.replace(bf, temperature_K=bf.temperature_K[rows])
        surfaces[name] = gear_surface(sub, emissivity=cam.surface_emissivity)
    amb = snapshot.ambient_C
    return Camera(
        cam,
        surfaces,
        snapshot.pinion_speed_rpm,
        snapshot.bodies["pinion"].teeth,
        target_point_m(cam, snapshot),
        amb if cam.surroundings_C is None else cam.surroundings_C,
        amb if cam.background_C is None else cam.background_C,
        tuple(snapshot.labels[i] for i in rows),
        views_dir,
    )


def evaluate(
    options: InstrumentOptions,
    snapshot: FieldSnapshot,
    out_dir: str | Path | None = None,
    labels: tuple[str, ...] | None = None,
    only: tuple[str, ...] | None = None,
    views_dir: str | Path | None = None,
) -> InstrumentReadings:
    """Read every configured instrument (or those named in ``only``: ``camera``, ``probes``,
    ``torque``) at the snapshot's labels (or ``labels``); with ``out_dir`` write the thermogram
    of each label (``thermogram_<label>.png`` and ``.csv``); the camera's phase views stored in
    ``views_dir`` (a later run of the same scene reads them). Not collective: call on one rank."""
    only = INSTRUMENTS if only is None else tuple(only)
    for name in only:
        if name not in INSTRUMENTS:
            raise ParameterError("instrument", name, "one of " + ", ".join(INSTRUMENTS))
    labels = snapshot.labels if labels is None else tuple(labels)
    rows = [snapshot.label_index(lab) for lab in labels]
    camera: dict[str, CameraReading] = {}
    files: list[str] = []
    if "camera" in only and options.camera.enabled:
        cam = camera_of(options, snapshot, rows, views_dir)
        thermograms, _ = cam.render()
        for th in thermograms:
            camera[th.reading.label] = th.reading
            if out_dir is not None:
                out = Path(out_dir)
                out.mkdir(parents=True, exist_ok=True)
                stem = f"thermogram_{th.reading.label}"
                note = f"{snapshot.case}, {snapshot.pinion_speed_rpm:g} rpm"
                write_csv(th, options.camera, out / f"{stem}.csv", note)
                title = (
                    f"{snapshot.case}: {snapshot.pinion_speed_rpm:g} rpm, "
                    f"{_time_text(snapshot, th.reading.label)} — camera_max "
                    f"{th.reading.max_C:.1f} °C (hottest model node "
                    f"{th.reading.hottest_node_C:.1f} °C)"
                )
                write_png(th, options.camera, out / f"{stem}.png", title)
                files += [f"{stem}.png", f"{stem}.csv"]
    probes: dict[str, dict[str, ProbeReading]] = {lab: {} for lab in labels}
    if "probes" in only:
        for name, probe in options.probes.items():
            if probe.body not in snapshot.bodies:
                raise ParameterError(
                    f"instruments.probes.{name}.body",
                    probe.body,
                    "a gear whose field the run kept: " + ", ".join(snapshot.bodies),
                )
            got = read_probe(
                name, probe, snapshot.bodies[probe.body], rows, list(labels), snapshot.face_width_m
            )
            for lab, r in zip(labels, got):
                probes[lab][name] = r
    torque, torque_at = None, {}
    if "torque" in only and options.torque.enabled and snapshot.torques is not None:
        for lab in labels:
            heat = snapshot.mesh_heat_W(lab)
            if heat is not None:
                torque_at[lab] = read_torque(
                    options.torque, snapshot.torques, snapshot.pinion_speed_rpm, heat
                )
        end = snapshot.label_of(None) if snapshot.labels else None
        torque = torque_at.get(end) or read_torque(
            options.torque, snapshot.torques, snapshot.pinion_speed_rpm
        )
    return InstrumentReadings(
        labels=labels,
        times_s=tuple(snapshot.times_s[i] for i in rows),
        camera=camera,
        probes=probes,
        torque=torque,
        files=tuple(files),
        torque_at=torque_at,
    )


def _time_text(snapshot: FieldSnapshot, label: str) -> str:
    t = snapshot.times_s[snapshot.label_index(label)]
    return "steady state" if t is None else f"t = {t:g} s"
