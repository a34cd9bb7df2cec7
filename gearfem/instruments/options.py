"""The ``[instruments]`` table of a case: what is measured and with what (DOLFINx-free).

::

    [instruments.camera]          # CameraOptions: the IR camera (default: the thesis's FLIR E40)
    view = "axial"
    [instruments.probes.web]      # ProbeOptions: a thermocouple, a side-face spot, a field value
    kind = "thermocouple"
    radius_mm = 22.0
    [instruments.torque]          # TorqueMeterOptions: input and output torque transducers

Every value carries its unit in its name; a bad value raises
:class:`~gearfem.core.errors.ParameterError` naming the key (``instruments.camera.pixels_h``), the
value and the allowed range. The physical models are in :mod:`gearfem.instruments.camera`,
:mod:`gearfem.instruments.probes` and :mod:`gearfem.instruments.torque`.
"""

from __future__ import annotations

import dataclasses
import math
import re

from gearfem.core.errors import ParameterError
from gearfem.core.params import (
    require_choice,
    require_finite,
    require_int,
    require_nonnegative,
    require_positive,
    require_range,
)

#: The thermal model's reported temperatures of one gear (``StepRecord.temperatures_K``): the
#: hottest surface node, the volume mean and the mean/maximum of each monitored surface set.
FIELD_QUANTITIES = (
    "max_surface",
    "mean_bulk",
    "flank_mean",
    "flank_max",
    "coast_flank_mean",
    "coast_flank_max",
    "tip_mean",
    "tip_max",
    "root_mean",
    "root_max",
)
VIEWS = ("axial", "radial")
RESPONSES = ("exponential", "boxcar")
DIRECTIONAL_EMISSIVITY = ("diffuse", "dielectric")
PROBE_KINDS = ("thermocouple", "side_face", "field")
SIDES = ("front", "back")
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]*$")


@dataclasses.dataclass(frozen=True)
class CameraOptions:
    """``[instruments.camera]``: an infrared camera looking at the running pair.

    Defaults: the FLIR E40 as the thesis bench used it (thesis 6.1.2: emissivity set to 0.90,
    atmospheric temperature 21 C, reference distance 1 m); detector and optics from the E40 data
    sheet (160 x 120 uncooled microbolometer, 25 x 19 deg lens, 7.5-13 um, 60 Hz, thermal
    sensitivity < 0.07 K, accuracy +-2 C or +-2 % of reading).

    Attributes:
        enabled: Evaluate the camera (false: no camera reading, no second thermal model).
        pixels_h, pixels_v: Detector pixels across and up.
        fov_h_deg, fov_v_deg: Field of view across and up, in (0, 180) deg.
        band_um: Spectral band (lower, upper wavelength) in micrometres; the detector's response
            is taken as flat inside the band and zero outside.
        frame_rate_Hz: Frames per second (only which rotation phases frames sample depends on it).
        response: ``"exponential"`` (a microbolometer: first-order thermal response with
            ``time_constant_s``) or ``"boxcar"`` (a photon detector integrating over
            ``integration_time_s``, e.g. a high-speed camera).
        time_constant_s: Detector time constant of the exponential response (E40: about 10 ms;
            uncooled microbolometers are 8-12 ms).
        integration_time_s: Integration time of the boxcar response.
        distance_m: Distance from the camera to the target point.
        view: Viewing direction (from the camera towards the pair): ``"axial"`` (along -z: the
            side faces z = b of both gears), ``"radial"`` (along -y, perpendicular to the line of
            centres: the tips and flanks of both gears where the teeth leave the mesh), or a
            vector ``[x, y, z]`` in the pair frame (pinion axis = z, wheel centre on +x).
        target_mm: The point looked at (image centre), pair frame, mm (None: the middle of the
            pair, half way between the axes at mid face width).
        emissivity_setting: The emissivity the camera is told (thesis: 0.90).
        reflected_C: The camera's reflected-temperature setting, C (thesis: atmospheric
            temperature 21 C; its reflected temperature is not stated and taken equal).
        surroundings_C: The true temperature of what the gear surfaces reflect, C (None: the
            thermal model's ambient).
        background_C: Temperature of what the camera sees behind the gears, C (None: ambient).
        background_emissivity: Emissivity of that background (1: a black lab wall).
        surface_emissivity: Emissivity of the gear surfaces (None: the thermal model's radiation
            emissivity, ``[thermal] emissivity`` or the material's).
        directional_emissivity: ``"diffuse"`` (the same emissivity in every direction, the
            thermal model's assumption) or ``"dielectric"`` (Fresnel emissivity of a smooth
            dielectric whose normal emissivity is the surface's: lower at grazing angles).
        blur_fwhm_px: Full width at half maximum of the optics' Gaussian blur, pixels (0: none).
        subsamples: Sample rays per pixel and direction (the footprint quadrature).
        phases: Rotation phases per tooth-pass period (the time quadrature).
        aim_offsets: Sub-pixel aims per direction (must divide ``subsamples``): where the pixel
            grid falls on the gears is not known to a fraction of a pixel (0.1 mrad of aim; the
            thesis states none), and the hottest pixel's reading depends on it by kelvins in the
            mesh zone. The camera is read at ``aim_offsets``² aims shifted by k / aim_offsets
            pixel (k = 0 … aim_offsets − 1) in each direction: ``camera_max`` is their mean (the
            expected reading of a uniformly unknown aim) and their standard deviation the aim's
            standard uncertainty. 1: the nominal aim only.
        accuracy_C, accuracy_percent: Stated accuracy, the larger of the two (E40: 2 C, 2 %),
            used as one standard uncertainty of a reading.
    """

    enabled: bool = True
    pixels_h: int = 160
    pixels_v: int = 120
    fov_h_deg: float = 25.0
    fov_v_deg: float = 19.0
    band_um: tuple[float, float] = (7.5, 13.0)
    frame_rate_Hz: float = 60.0
    response: str = "exponential"
    time_constant_s: float = 0.010
    integration_time_s: float = 1.0e-4
    distance_m: float = 1.0
    view: str | tuple[float, float, float] = "axial"
    target_mm: tuple[float, float, float] | None = None
    emissivity_setting: float = 0.90
    reflected_C: float = 21.0
    surroundings_C: float | None = None
    background_C: float | None = None
    background_emissivity: float = 1.0
    surface_emissivity: float | None = None
    directional_emissivity: str = "diffuse"
    blur_fwhm_px: float = 1.0
    subsamples: int = 8
    phases: int = 24
    aim_offsets: int = 4
    accuracy_C: float = 2.0
    accuracy_percent: float = 2.0

    def __post_init__(self) -> None:
        p = "camera."
        set_ = lambda k, v: object.__setattr__(self, k, v)
        if not isinstance(self.enabled, bool):
            raise ParameterError(p + "enabled", self.enabled, "true or false")
        set_("pixels_h", require_int(p + "pixels_h", self.pixels_h, 1, 100_000))
        set_("pixels_v", require_int(p + "pixels_v", self.pixels_v, 1, 100_000))
        for key in ("fov_h_deg", "fov_v_deg"):
            set_(
                key,
                require_range(
                    p + key, getattr(self, key), 0.0, 180.0, lo_open=True, hi_open=True, unit="deg"
                ),
            )
        band = tuple(self.band_um)
        if len(band) != 2:
            raise ParameterError(p + "band_um", self.band_um, "[lower, upper] in micrometres")
        lo = require_range(p + "band_um[0]", band[0], 0.0, 1000.0, lo_open=True, unit="um")
        hi = require_range(
            p + "band_um[1]",
            band[1],
            lo,
            1000.0,
            lo_open=True,
            unit="um",
            reason="above band_um[0]",
        )
        set_("band_um", (lo, hi))
        set_("frame_rate_Hz", require_positive(p + "frame_rate_Hz", self.frame_rate_Hz))
        require_choice(p + "response", self.response, RESPONSES)
        set_("time_constant_s", require_nonnegative(p + "time_constant_s", self.time_constant_s))
        set_(
            "integration_time_s",
            require_nonnegative(p + "integration_time_s", self.integration_time_s),
        )
        set_("distance_m", require_positive(p + "distance_m", self.distance_m))
        set_("view", view_direction_spec(self.view))
        if self.target_mm is not None:
            t = tuple(self.target_mm)
            if len(t) != 3:
                raise ParameterError(p + "target_mm", self.target_mm, "[x, y, z] in mm")
            set_("target_mm", tuple(require_finite(p + "target_mm", v) for v in t))
        set_(
            "emissivity_setting",
            require_range(
                p + "emissivity_setting", self.emissivity_setting, 0.0, 1.0, lo_open=True
            ),
        )
        for key in ("reflected_C", "surroundings_C", "background_C"):
            v = getattr(self, key)
            if v is not None:
                set_(key, require_range(p + key, v, -273.15, 2000.0, lo_open=True, unit="C"))
        set_(
            "background_emissivity",
            require_range(p + "background_emissivity", self.background_emissivity, 0.0, 1.0),
        )
        if self.surface_emissivity is not None:
            set_(
                "surface_emissivity",
                require_range(p + "surface_emissivity", self.surface_emissivity, 0.0, 1.0),
            )
        require_choice(p + "directional_emissivity", self.directional_emissivity,
                       DIRECTIONAL_EMISSIVITY)  # fmt: skip
        set_("blur_fwhm_px", require_range(p + "blur_fwhm_px", self.blur_fwhm_px, 0.0, 20.0))
        set_("subsamples", require_int(p + "subsamples", self.subsamples, 1, 64))
        set_("phases", require_int(p + "phases", self.phases, 1, 100_000))
        set_("aim_offsets", require_int(p + "aim_offsets", self.aim_offsets, 1, self.subsamples))
        if self.subsamples % self.aim_offsets:
            raise ParameterError(
                p + "aim_offsets",
                self.aim_offsets,
                f"a divisor of camera.subsamples = {self.subsamples}",
            )
        set_("accuracy_C", require_nonnegative(p + "accuracy_C", self.accuracy_C))
        set_("accuracy_percent", require_nonnegative(p + "accuracy_percent", self.accuracy_percent))

    @property
    def pixel_pitch_rad(self) -> tuple[float, float]:
        """Angular pixel pitch (across, up) at the image centre (the IFOV), rad."""
        return (
            2.0 * math.tan(math.radians(self.fov_h_deg) / 2.0) / self.pixels_h,
            2.0 * math.tan(math.radians(self.fov_v_deg) / 2.0) / self.pixels_v,
        )

    @property
    def footprint_mm(self) -> float:
        """Pixel footprint across at the target distance, mm (E40 at 1 m: 2.7 mm)."""
        return self.pixel_pitch_rad[0] * self.distance_m * 1e3

    def uncertainty_K(self, reading_C: float) -> float:
        """Stated accuracy of a reading as one standard uncertainty, K: the larger of
        ``accuracy_C`` and ``accuracy_percent`` of the reading in C."""
        return max(self.accuracy_C, 0.01 * self.accuracy_percent * abs(reading_C))


def view_direction_spec(view) -> str | tuple[float, float, float]:
    """A validated ``view``: ``"axial"``, ``"radial"`` or a non-zero vector of 3 numbers."""
    if isinstance(view, str):
        return require_choice("camera.view", view, VIEWS)
    try:
        v = tuple(float(x) for x in view)
    except (TypeError, ValueError):
        raise ParameterError(
            "camera.view", view, "'axial', 'radial' or a vector [x, y, z]"
        ) from None
    if len(v) != 3 or not all(math.isfinite(x) for x in v) or math.hypot(*v) == 0.0:
        raise ParameterError(
            "camera.view", view, "'axial', 'radial' or a non-zero vector [x, y, z]"
        )
    return v


@dataclasses.dataclass(frozen=True)
class ProbeOptions:
    """``[instruments.probes.NAME]``: a temperature probe on one gear, reading ``probe:NAME``.

    Kinds:
        ``"thermocouple"``: the temperature at a point of the body (e.g. embedded in the web),
            at ``radius_mm`` from the axis, ``angle_deg`` from the centre line of a tooth
            (counter-clockwise; 180/z is the middle of a gap) and ``z_mm`` across the face width
            (None: mid-face). Read as the temperature field at that point (a junction small
            against the element size; no lag: the gears warm up over minutes, a thermocouple
            responds in about a second).
        ``"side_face"``: the mean temperature of a side face on the circle of ``radius_mm``
            (over the body's material on that circle: in the tooth ring, over the teeth only),
            as a contact probe or a spot pyrometer sees a rotating side face.
        ``"field"``: one of the thermal model's reported temperatures (``quantity``:
            max_surface, mean_bulk, flank_mean, tip_max, ...).

    Attributes:
        kind: ``"thermocouple"``, ``"side_face"`` or ``"field"`` (above).
        body: The gear it reads: ``"pinion"`` or ``"wheel"``.
        radius_mm: Distance from the gear's axis (mm): a thermocouple's junction, a side_face
            probe's circle.
        angle_deg: Angle of a thermocouple from the centre line of a tooth (degrees,
            counter-clockwise; 180/z is the middle of a gap).
        z_mm: Position across the face width (mm; None: mid-face).
        side: The side face a side_face probe reads: ``"front"`` (the mesh's side_front, z = 0)
            or ``"back"`` (side_back, z = b).
        quantity: The reported temperature a field probe reads (max_surface, mean_bulk,
            flank_mean, tip_max, ...).
    """

    kind: str = "thermocouple"
    body: str = "pinion"
    radius_mm: float | None = None
    angle_deg: float = 0.0
    z_mm: float | None = None
    side: str = "front"
    quantity: str | None = None

    def __post_init__(self) -> None:
        p = "probe."
        require_choice(p + "kind", self.kind, PROBE_KINDS)
        require_choice(p + "body", self.body, ("pinion", "wheel"))
        require_choice(p + "side", self.side, SIDES)
        if self.kind in ("thermocouple", "side_face"):
            if self.radius_mm is None:
                raise ParameterError(
                    p + "radius_mm", None, f"a radius > 0 mm for a {self.kind} probe"
                )
            object.__setattr__(self, "radius_mm", require_positive(p + "radius_mm", self.radius_mm))
        object.__setattr__(
            self, "angle_deg", require_range(p + "angle_deg", self.angle_deg, -360.0, 360.0)
        )
        if self.z_mm is not None:
            object.__setattr__(self, "z_mm", require_finite(p + "z_mm", self.z_mm))
        if self.kind == "field":
            if self.quantity is None:
                raise ParameterError(p + "quantity", None, "one of " + ", ".join(FIELD_QUANTITIES))
            require_choice(p + "quantity", self.quantity, FIELD_QUANTITIES)
        elif self.quantity is not None:
            raise ParameterError(
                p + "quantity", self.quantity, "unset", "only a 'field' probe reads a quantity"
            )


@dataclasses.dataclass(frozen=True)
class TorqueMeterOptions:
    """``[instruments.torque]``: torque transducers on the input (pinion) and output (wheel)
    shafts (thesis 6.1.1: one on each shaft of the Kleiss bench; their accuracy is not stated).

    Attributes:
        enabled: Report the torque readings.
        uncertainty_Nm: Standard uncertainty of each transducer's mean torque, N m (assumed
            0.04 N m: 0.2 % of a 20 N m full scale).
    """

    enabled: bool = True
    uncertainty_Nm: float = 0.04

    def __post_init__(self) -> None:
        if not isinstance(self.enabled, bool):
            raise ParameterError("torque.enabled", self.enabled, "true or false")
        require_nonnegative("torque.uncertainty_Nm", self.uncertainty_Nm)


@dataclasses.dataclass(frozen=True)
class InstrumentOptions:
    """``[instruments]``: the camera, named probes and torque meters of a case (see the module
    docstring). Probe names are identifiers (letters, digits, ``_``, ``-``)."""

    camera: CameraOptions = dataclasses.field(default_factory=CameraOptions)
    probes: dict[str, ProbeOptions] = dataclasses.field(default_factory=dict)
    torque: TorqueMeterOptions = dataclasses.field(default_factory=TorqueMeterOptions)

    def __post_init__(self) -> None:
        for name, probe in self.probes.items():
            if not _NAME.match(name):
                raise ParameterError(
                    f"instruments.probes.{name}",
                    name,
                    "a name of letters, digits, '_' and '-', starting with a letter",
                )
            if not isinstance(probe, ProbeOptions):
                raise ParameterError(
                    f"instruments.probes.{name}", probe, "a table of probe options"
                )

    def __hash__(self) -> int:  # the probes dict is not hashable; options compare by value
        return hash((self.camera, tuple(sorted(self.probes.items())), self.torque))

    @property
    def quantities(self) -> tuple[str, ...]:
        """The quantities these instruments read (names in measured-data files)."""
        out: list[str] = []
        if self.camera.enabled:
            out.append("camera_max")
        out += [f"probe:{n}" for n in self.probes]
        if self.torque.enabled:
            out += ["torque_loss_Nm", "efficiency"]
        return tuple(out)
