"""An infrared camera looking at the running gear pair: what each pixel reads (numpy only).

Physical model (options: :class:`gearfem.instruments.options.CameraOptions`):

* **Optics.** A pinhole camera at ``distance_m`` from the target point, looking along the view
  direction; pixel (r, c) of the ``pixels_v`` x ``pixels_h`` detector collects the rays through
  its square of the image plane (angular pitch = field of view / pixels, the IFOV; footprint at
  1 m for the E40: 2.7 mm), blurred by a Gaussian point-spread function (``blur_fwhm_px``). The
  footprint integral is a midpoint quadrature of ``subsamples``² rays per pixel; the blur is applied
  to the sampled image before the pixel average (the two convolutions commute).
* **Scene.** Each ray meets the first surface of either gear (z-buffer visibility,
  :mod:`gearfem.instruments.raster`, on the gears' whole boundaries built by
  :func:`gearfem.instruments.scene.gear_surface`), or passes between them to the background. A
  gear surface at T sends ε L(T) + (1 − ε) L(T_s) (band radiance, :mod:`radiometry`; T_s the
  surroundings it reflects; ε constant, or the Fresnel ε(θ) of a dielectric at the angle between
  ray and surface normal); the background ε_b L(T_b) + (1 − ε_b) L(T_s). Side faces, tips, flanks
  at grazing angles, gaps and the mating gear behind them are what the rays meet. Reflections of
  one gear in the other and the atmosphere over 1 m are neglected.
* **Rotation and time.** Both gears turn (pinion counter-clockwise at its speed, wheel clockwise)
  with their temperature fields fixed to them (the thermal model's rotation-averaged field); the
  scene repeats after one tooth pass, P = 60 / (n₁ z₁) s (2 ms at 1000 rpm, 30 teeth). The
  instantaneous pixel signals s(t) are computed at ``phases`` equally spaced phases of that period
  (held constant over each phase interval) and the detector's response h (exponential with the time
  constant τ for a microbolometer, boxcar over the integration time for a photon detector) is
  applied exactly to that periodic, piecewise-constant signal: y(tᵢ) = Σₖ wₖ s(tᵢ₋ₖ), with
  wₖ = ∫ over the k-th phase interval of the periodic sum of h. For τ ≫ P this is the average over
  a tooth pass (teeth and gaps are averaged at each radius: the camera reads the fill-fraction
  weighted radiance); for a short response (or a gear at rest) it resolves teeth and gaps. Frames
  sample the phases at the frame rate; with an unknown start every phase is equally likely.
* **Reading.** Each frame's pixel value is the camera's inversion of its signal with the
  emissivity and reflected-temperature settings (:func:`radiometry.camera_temperature`). The
  thermogram is the frame average of the readings; ``camera_max`` (what the thesis reports, "the
  maximum surface temperature" of the IR video) is the hottest pixel of a frame, averaged over the
  frames (its range over the frames is reported too).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import logging
import math
import os
import zipfile
from fractions import Fraction
from pathlib import Path

import numpy as np
from scipy import ndimage

from gearfem.core.errors import ParameterError
from gearfem.core.materials import ZERO_CELSIUS_K
from gearfem.core.provenance import code_hash
from gearfem.core.results import JsonRecord
from gearfem.core.rotation import rotate_xy
from gearfem.instruments.options import CameraOptions
from gearfem.instruments.radiometry import Band, camera_temperature, directional_emissivity
from gearfem.instruments.raster import rasterize
from gearfem.instruments.scene import Surface
from gearfem.instruments.snapshot import KINDS


@dataclasses.dataclass(frozen=True)
class CameraGeometry:
    """Pinhole geometry: position, unit axes (right, up, forward) and the pixel grid."""

    position_m: np.ndarray
    right: np.ndarray
    up: np.ndarray
    forward: np.ndarray
    half_u: float  # tan(fov_h / 2)
    half_w: float
    pixels_h: int
    pixels_v: int

    @classmethod
    def of(cls, options: CameraOptions, target_m: np.ndarray) -> CameraGeometry:
        view = options.view
        if view == "axial":
            d = np.array([0.0, 0.0, -1.0])
        elif view == "radial":
            d = np.array([0.0, -1.0, 0.0])
        else:
            d = np.asarray(view, dtype=float)
        d = d / np.linalg.norm(d)
        hint = np.array([0.0, 1.0, 0.0]) if abs(d[2]) > 0.9 else np.array([0.0, 0.0, 1.0])
        right = np.cross(d, hint)
        right /= np.linalg.norm(right)
        up = np.cross(right, d)
        return cls(
            position_m=np.asarray(target_m, dtype=float) - options.distance_m * d,
            right=right,
            up=up,
            forward=d,
            half_u=math.tan(math.radians(options.fov_h_deg) / 2.0),
            half_w=math.tan(math.radians(options.fov_v_deg) / 2.0),
            pixels_h=options.pixels_h,
            pixels_v=options.pixels_v,
        )

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(column, row, depth) of points: continuous pixel coordinates (pixel (r, c) covers
        [c, c + 1) x [r, r + 1), row 0 at the top) and the depth along the view."""
        p = points - self.position_m
        depth = p @ self.forward
        with np.errstate(divide="ignore", invalid="ignore"):
            u = (p @ self.right) / depth
            w = (p @ self.up) / depth
        col = (u + self.half_u) / (2.0 * self.half_u) * self.pixels_h
        row = (self.half_w - w) / (2.0 * self.half_w) * self.pixels_v
        return col, row, depth

    def ray(self, col, row) -> np.ndarray:
        """Unit ray directions through continuous pixel coordinates."""
        u = (np.asarray(col) / self.pixels_h * 2.0 - 1.0) * self.half_u
        w = (1.0 - np.asarray(row) / self.pixels_v * 2.0) * self.half_w
        r = self.forward + u[..., None] * self.right + w[..., None] * self.up
        return r / np.linalg.norm(r, axis=-1, keepdims=True)


def gear_window(
    options: CameraOptions,
    geometry: CameraGeometry,
    centers_m,
    radii_m,
    z_range_m: tuple[float, float],
) -> tuple[int, int, int, int]:
    """Rows r0:r1 and columns c0:c1 of the pixels that see the gears (the projections of the
    cylinders of the given centres and outer radii over the face width, plus the blur's reach).
    A camera with a gear behind it, or whose frame misses the gears, is an error naming the
    option."""
    ang = np.linspace(0.0, 2.0 * math.pi, 181)
    pts = np.concatenate(
        [
            np.column_stack([c[0] + r * np.cos(ang), c[1] + r * np.sin(ang), np.full_like(ang, z)])
            for c, r in zip(centers_m, radii_m)
            for z in z_range_m
        ]
    )
    col, row, depth = geometry.project(pts)
    o = options
    if np.any(depth <= 0.0):
        raise ParameterError(
            "instruments.camera.distance_m",
            o.distance_m,
            "a distance that puts the whole pair in front of the camera",
            f"view {o.view!r}",
        )
    margin = 0 if o.blur_fwhm_px == 0.0 else math.ceil(4.0 * o.blur_fwhm_px / 2.3548) + 1
    c0 = max(0, math.floor(col.min()) - margin)
    c1 = min(geometry.pixels_h, math.ceil(col.max()) + margin)
    r0 = max(0, math.floor(row.min()) - margin)
    r1 = min(geometry.pixels_v, math.ceil(row.max()) + margin)
    seen = (
        col.max() > 0
        and col.min() < geometry.pixels_h
        and row.max() > 0
        and row.min() < geometry.pixels_v
    )
    if not seen or c1 <= c0 or r1 <= r0:
        raise ParameterError(
            "instruments.camera.view",
            o.view,
            "a view (with target_mm and distance_m) whose field of view contains the gears",
            f"the gears project to columns {col.min():.0f} to {col.max():.0f}, rows "
            f"{row.min():.0f} to {row.max():.0f} of a {geometry.pixels_h} x "
            f"{geometry.pixels_v} frame",
        )
    return r0, r1, c0, c1


def phase_weights(options: CameraOptions, period_s: float, phases: int) -> np.ndarray:
    """Weights w_k of the signal k phase intervals ago in a frame (module docstring); sum 1.

    Exponential response, Δ = P / n: w_k = e^(-kΔ/τ) (1 - e^(-Δ/τ)) / (1 - e^(-P/τ)).
    Boxcar of length t: w_k = Σ_m |[mP + kΔ, mP + (k+1)Δ) ∩ [0, t)| / t.
    """
    n = phases
    if n == 1 or period_s == 0.0:
        return np.ones(1)
    dt = period_s / n
    k = np.arange(n)
    if options.response == "exponential":
        tau = options.time_constant_s
        if tau == 0.0:
            return (k == 0).astype(float)
        a = dt / tau
        return np.exp(-k * a) * (-np.expm1(-a)) / (-np.expm1(-n * a))
    t = options.integration_time_s
    if t == 0.0:
        return (k == 0).astype(float)
    w = np.zeros(n)
    for m in range(math.ceil(t / period_s) + 1):
        lo = m * period_s + k * dt
        w += np.clip(np.minimum(lo + dt, t) - lo, 0.0, None)
    return w / t


@dataclasses.dataclass(frozen=True, eq=False)
class BodyHits:
    """The samples of one phase that meet a body first: their flat indices in the window's
    sample grid, the triangle of the body's surface each meets, its barycentric weights (k, 3)
    and, for the dielectric emissivity, the cosine between the triangle's normal and the ray."""

    samples: np.ndarray
    triangles: np.ndarray
    weights: np.ndarray
    cosine: np.ndarray | None


@dataclasses.dataclass(frozen=True, eq=False)
class PhaseView:
    """What the samples see at one phase, which the surfaces' temperatures and emissivities do
    not change: per body (in the order of the camera's surfaces) its :class:`BodyHits`, and the
    surface id of every sample (H, W; -1: background)."""

    bodies: tuple[BodyHits, ...]
    ids: np.ndarray


#: The phase views of the scenes rendered last, by :meth:`Camera._view_key` (most recent last):
#: a diagnosis renders one scene with many temperature fields, each run a new Camera.
_VIEWS: dict[str, tuple[PhaseView, ...]] = {}
_VIEWS_KEPT = 4

log = logging.getLogger(__name__)


@functools.cache
def _ray_code() -> str:
    """Hash of the code that traces the rays (this module and what it imports: the raster, the
    scene): part of a stored view's key."""
    return code_hash("gearfem.instruments.camera")


def save_views(path: Path, views: tuple[PhaseView, ...]) -> None:
    """Write the phase views to ``path`` (``.npz``), under a temporary name renamed at the end so
    that an interrupted write never leaves a file that looks complete."""
    arrays: dict[str, np.ndarray] = {"shape": np.array([len(views), len(views[0].bodies)])}
    for j, view in enumerate(views):
        arrays[f"ids_{j}"] = view.ids
        for b, hit in enumerate(view.bodies):
            arrays[f"samples_{j}_{b}"] = hit.samples
            arrays[f"triangles_{j}_{b}"] = hit.triangles
            arrays[f"weights_{j}_{b}"] = hit.weights
            if hit.cosine is not None:
                arrays[f"cosine_{j}_{b}"] = hit.cosine
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp{os.getpid()}.npz")
    np.savez(tmp, **arrays)
    os.replace(tmp, path)


def load_views(path: Path) -> tuple[PhaseView, ...]:
    """The phase views :func:`save_views` wrote to ``path``."""
    with np.load(path) as z:
        phases, bodies = (int(n) for n in z["shape"])
        return tuple(
            PhaseView(
                tuple(
                    BodyHits(
                        z[f"samples_{j}_{b}"],
                        z[f"triangles_{j}_{b}"],
                        z[f"weights_{j}_{b}"],
                        z[f"cosine_{j}_{b}"] if f"cosine_{j}_{b}" in z.files else None,
                    )
                    for b in range(bodies)
                ),
                z[f"ids_{j}"],
            )
            for j in range(phases)
        )


@dataclasses.dataclass(frozen=True)
class CameraReading(JsonRecord):
    """What the camera reports at one time of the run.

    Attributes:
        label: The snapshot label (``"end"``, ``"steady"``, ``"900"``...).
        max_C: ``camera_max``: the hottest pixel of a frame, averaged over the frames, and over
            the sub-pixel aims (``CameraOptions.aim_offsets``): the expected reading of a camera
            whose pixel grid falls anywhere within a pixel on the gears.
        frame_max_range_C: Lowest and highest per-frame maximum at the nominal aim (the flicker
            of the maximum).
        aim_std_C: Standard deviation of the frame-averaged hottest pixel over the sub-pixel aims:
            the standard uncertainty the unknown aim gives the reading (0 with one aim).
        aim_range_C: Its lowest and highest value over the aims.
        aims: How many aims were read.
        pixel: (row, column) of the pixel whose frame-averaged reading is highest.
        pixel_C: That pixel's frame-averaged reading.
        body, surface: What that pixel sees most of (``"background"`` when nothing).
        surface_fractions: The parts of that pixel's footprint and frame time each surface
            (``"pinion side_front"``, ...) and the background fill.
        hottest_node_C: The hottest surface temperature of the model in view (for comparison: what
            the model's maximum-node value would claim).
        background_C: What a pixel seeing only the background reads.
        footprint_mm: Pixel footprint across at the target distance.
        tooth_pass_period_s: P (0: gears at rest).
        frame_phases: Distinct tooth-pass phases the frames visit (frame rate vs tooth-pass
            frequency; 0 for gears at rest).
    """

    label: str
    max_C: float
    frame_max_range_C: tuple[float, float]
    pixel: tuple[int, int]
    pixel_C: float
    body: str
    surface: str
    surface_fractions: dict[str, float]
    hottest_node_C: float
    background_C: float
    footprint_mm: float
    tooth_pass_period_s: float
    frame_phases: int
    aim_std_C: float = 0.0
    aim_range_C: tuple[float, float] = (math.nan, math.nan)
    aims: int = 1


@dataclasses.dataclass(frozen=True, eq=False)
class Thermogram:
    """A frame-averaged image (C) with its reading (for the PNG and numbers files)."""

    image_C: np.ndarray  # (pixels_v, pixels_h)
    reading: CameraReading
    window: tuple[int, int, int, int]  # rows r0:r1, columns c0:c1 containing the gears
    title: str


class Camera:
    """The camera of ``options`` looking at ``surfaces`` (the gears) turning at ``speed_rpm``.

    Args:
        options: The camera.
        surfaces: The gears' surfaces by body name (``gear_surface``), each turning about its own
            axis by one tooth pitch per tooth pass (sense from the surface).
        pinion_speed_rpm, pinion_teeth: The tooth-pass period P = 60 / (n₁ z₁) (0 rpm: at rest).
        target_m: The point the camera looks at (pair frame).
        surroundings_C, background_C: What the surfaces reflect and what lies behind them.
        labels: The snapshot labels of the surfaces' temperature rows.
        views_dir: Where the phase views of a scene are stored between runs (``<key>.npz``, the
            key of everything the rays depend on and the code tracing them): a later run of the
            same gears, pose and camera (another operating point) reads them instead of tracing
            (about 7 s on the built-in case). None: kept within the process only.
    """

    def __init__(
        self,
        options: CameraOptions,
        surfaces: dict[str, Surface],
        pinion_speed_rpm: float,
        pinion_teeth: int,
        target_m: np.ndarray,
        surroundings_C: float,
        background_C: float,
        labels: tuple[str, ...],
        views_dir: str | Path | None = None,
    ) -> None:
        self.options = options
        self.surfaces = surfaces
        self.labels = labels
        self.views_dir = None if views_dir is None else Path(views_dir)
        self.band = Band(*options.band_um)
        self.geometry = CameraGeometry.of(options, target_m)
        self.period_s = 0.0 if pinion_speed_rpm == 0.0 else 60.0 / (pinion_speed_rpm * pinion_teeth)
        self.phases = 1 if self.period_s == 0.0 else options.phases
        self.weights = phase_weights(options, self.period_s, self.phases)
        self.T_s = surroundings_C + ZERO_CELSIUS_K
        self.L_s = float(self.band.radiance(self.T_s))
        eb = options.background_emissivity
        self.S_background = (
            eb * float(self.band.radiance(background_C + ZERO_CELSIUS_K)) + (1.0 - eb) * self.L_s
        )
        self.window = self._window()
        self.sigma_px = options.blur_fwhm_px / (2.0 * math.sqrt(2.0 * math.log(2.0)))
        self._prepare_culling()

    # --- where the gears are in the image ---------------------------------------------------------
    def _window(self) -> tuple[int, int, int, int]:
        centers, radii, z = [], [], []
        for s in self.surfaces.values():
            p = s.points_m.reshape(-1, 3)
            centers.append(s.center_m)
            radii.append(float(np.max(np.hypot(p[:, 0] - s.center_m[0], p[:, 1] - s.center_m[1]))))
            z.append((float(p[:, 2].min()), float(p[:, 2].max())))
        zr = (min(a for a, _ in z), max(b for _, b in z))
        return gear_window(self.options, self.geometry, centers, radii, zr)

    # --- rendering --------------------------------------------------------------------------------
    def _phase(self, view: PhaseView):
        """Instantaneous sampled radiance (labels, H, W) and surface ids (H, W) at a phase whose
        samples see what ``view`` says."""
        r0, r1, c0, c1 = self.window
        n = self.options.subsamples
        H, W = (r1 - r0) * n, (c1 - c0) * n
        S = np.full((len(self.labels), H * W), self.S_background)
        for surf, hit in zip(self.surfaces.values(), view.bodies, strict=True):
            if len(hit.samples) == 0:
                continue
            T = np.einsum("lij,ij->li", surf.temperature_K[:, hit.triangles], hit.weights)
            eps = (
                surf.emissivity
                if hit.cosine is None
                else directional_emissivity(surf.emissivity, hit.cosine)
            )
            S[:, hit.samples] = eps * self.band.radiance_fast(T) + (1.0 - eps) * self.L_s
        return S.reshape(len(self.labels), H, W), view.ids

    def _views(self) -> tuple[PhaseView, ...]:
        """What the samples of every phase see: computed once for the scene's geometry and kept
        (:data:`_VIEWS`, keyed by :meth:`_view_key`), so that cameras of the same gears and
        options reading other temperatures (a diagnosis' runs) do not trace the rays again; with
        :attr:`views_dir`, also stored there for later processes."""
        key = self._view_key()
        views = _VIEWS.pop(key, None)
        stored = None if self.views_dir is None else self.views_dir / f"{key[:32]}.npz"
        if views is None and stored is not None and stored.is_file():
            try:
                views = load_views(stored)
            except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile) as e:
                # unreadable: traced and stored again
                log.warning("camera views %s unreadable (%s): traced again", stored, e)
        if views is None:
            views = tuple(self._phase_view(j) for j in range(self.phases))
            if stored is not None:
                save_views(stored, views)
        _VIEWS[key] = views  # the most recently used last
        while len(_VIEWS) > _VIEWS_KEPT:
            del _VIEWS[next(iter(_VIEWS))]
        return views

    def _view_key(self) -> str:
        """A digest of everything the rays of :meth:`_phase_view` depend on: the options, the
        camera's pose, the window, the phases and each surface's triangles, kinds and motion (not
        its temperatures or emissivity), and the code that traces the rays."""
        h = hashlib.sha256(_ray_code().encode())
        g = self.geometry
        h.update(repr((self.options, self.window, self.phases)).encode())
        for arr in (g.position_m, g.right, g.up, g.forward):
            h.update(np.ascontiguousarray(arr, dtype=float).tobytes())
        h.update(repr((g.half_u, g.half_w, g.pixels_h, g.pixels_v)).encode())
        for name, s in self.surfaces.items():
            h.update(repr((name, s.closed, s.rotation_sense, s.pitch_rad)).encode())
            for arr in (s.points_m, s.center_m):
                h.update(np.ascontiguousarray(arr, dtype=float).tobytes())
            h.update(np.ascontiguousarray(s.kind, dtype=np.int64).tobytes())
        return h.hexdigest()

    def _phase_view(self, j: int) -> PhaseView:
        """The first surface each sample meets at phase j (z-buffer), the triangle and its
        barycentric weights, the cosine between its normal and the ray (for the dielectric
        emissivity) and the surface ids (H, W)."""
        o, g = self.options, self.geometry
        r0, r1, c0, c1 = self.window
        n = o.subsamples
        H, W = (r1 - r0) * n, (c1 - c0) * n
        screens, owners = [], []
        names = list(self.surfaces)
        frac = j / self.phases
        for b, name in enumerate(names):
            s = self.surfaces[name]
            idx = self._candidates(b, s.rotation_sense * s.pitch_rad * frac)
            P = rotate_xy(s.points_m[idx], s.center_m, s.rotation_sense * s.pitch_rad * frac)
            col, row, depth = g.project(P.reshape(-1, 3))
            sc = np.stack([(col - c0) * n - 0.5, (row - r0) * n - 0.5, depth], axis=1).reshape(
                -1, 3, 3
            )
            screens.append(sc)
            owners.append((b, idx, P))
        sizes = [len(sc) for sc in screens]
        hits = rasterize(np.concatenate(screens), W, H)
        ids = np.full(H * W, -1, dtype=np.int16)
        starts = np.cumsum([0, *sizes])
        bodies = []
        for (b, idx, P), lo, hi in zip(owners, starts[:-1], starts[1:]):
            sel = np.flatnonzero((hits.triangle >= lo) & (hits.triangle < hi))
            surf = self.surfaces[names[b]]
            local = hits.triangle[sel] - lo
            tri = idx[local]
            w = hits.weights[sel]
            cosine = None
            if o.directional_emissivity == "dielectric":
                pts = P[local]
                nrm = np.cross(pts[:, 1] - pts[:, 0], pts[:, 2] - pts[:, 0])
                nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
                hit = np.einsum("ij,ijk->ik", w, pts)
                ray = hit - g.position_m
                ray /= np.linalg.norm(ray, axis=1, keepdims=True)
                cosine = np.einsum("ij,ij->i", nrm, ray)
            ids[sel] = b * len(KINDS) + surf.kind[tri]
            bodies.append(BodyHits(sel, tri, w, cosine))
        return PhaseView(tuple(bodies), ids.reshape(H, W))

    def _prepare_culling(self) -> None:
        """Per surface: triangle centroids relative to the axis, normals (unnormalised) and the
        largest centroid-vertex distance, for :meth:`_candidates`."""
        g = self.geometry
        self._cull = []
        for s in self.surfaces.values():
            P = s.points_m
            cen = P.mean(axis=1)
            reach = np.max(np.linalg.norm(P - cen[:, None, :], axis=2), axis=1)
            nrm = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
            self._cull.append((cen - s.center_m, nrm, reach, s.closed))
        # pixels per unit tangent of the view angle
        self._px_per_tan = g.pixels_h / (2.0 * g.half_u), g.pixels_v / (2.0 * g.half_w)

    def _candidates(self, b: int, angle: float) -> np.ndarray:
        """Triangles of surface ``b`` turned by ``angle`` that may cover a sample of the window:
        facing the camera (closed surfaces) and with the bounding sphere (centroid, reach) of
        their projection overlapping the window."""
        rel, nrm, reach, closed = self._cull[b]
        s = list(self.surfaces.values())[b]
        c, sn = math.cos(angle), math.sin(angle)
        cen = np.empty_like(rel)
        cen[:, 0] = c * rel[:, 0] - sn * rel[:, 1]
        cen[:, 1] = sn * rel[:, 0] + c * rel[:, 1]
        cen[:, 2] = rel[:, 2]
        cen += s.center_m
        g = self.geometry
        keep = np.ones(len(rel), dtype=bool)
        if closed:  # cull faces turned away from the camera
            n = np.empty_like(nrm)
            n[:, 0] = c * nrm[:, 0] - sn * nrm[:, 1]
            n[:, 1] = sn * nrm[:, 0] + c * nrm[:, 1]
            n[:, 2] = nrm[:, 2]
            keep = np.einsum("ij,ij->i", n, cen - g.position_m) < 0.0
        col, row, depth = g.project(cen)
        r0, r1, c0, c1 = self.window
        # a sphere of radius `reach` at depth d spans at most reach / (d - reach) in tangent
        span = reach / np.maximum(depth - reach, 1e-12)
        rc, rr = span * self._px_per_tan[0] + 1.0, span * self._px_per_tan[1] + 1.0
        keep &= (col + rc >= c0) & (col - rc <= c1) & (row + rr >= r0) & (row - rr <= r1)
        keep |= depth - reach <= 0.0  # too close to judge: keep
        return np.flatnonzero(keep)

    def _pixels(self, S: np.ndarray) -> np.ndarray:
        """Pixel signals (aims, labels, rows, cols) of the window from the sampled radiance: the
        footprint means with the pixel grid shifted by k / aim_offsets pixel in each direction
        (aim a · aim_offsets + b: a down, b across; aim 0 is the nominal one)."""
        n, m = self.options.subsamples, self.options.aim_offsets
        if self.sigma_px > 0.0:
            S = np.stack(
                [
                    ndimage.gaussian_filter(
                        s, self.sigma_px * n, mode="constant", cval=self.S_background, truncate=4.0
                    )
                    for s in S
                ]
            )
        nl, H, W = S.shape
        padded = np.full((nl, H + n, W + n), self.S_background)
        padded[:, :H, :W] = S
        step = n // m
        out = np.empty((m * m, nl, H // n, W // n))
        for a in range(m):
            for b in range(m):
                block = padded[:, a * step : a * step + H, b * step : b * step + W]
                out[a * m + b] = block.reshape(nl, H // n, n, W // n, n).mean(axis=(2, 4))
        return out

    def render(self) -> tuple[list[Thermogram], np.ndarray]:
        """Readings at every label: the thermograms and the nominal aim's per-frame readings
        (labels, phases, rows, cols of the window) in C."""
        o = self.options
        r0, r1, c0, c1 = self.window
        signals, ids = [], []
        for view in self._views():
            S, sid = self._phase(view)
            signals.append(self._pixels(S))
            ids.append(sid)
        sig = np.stack(signals, axis=2)  # (aims, labels, phases, rows, cols)
        N = self.phases
        circ = np.array([[self.weights[(i - k) % N] for k in range(N)] for i in range(N)])
        frames = np.einsum("ik,alkrc->alirc", circ, sig)
        readings = (
            camera_temperature(
                self.band, frames, o.emissivity_setting, o.reflected_C + ZERO_CELSIUS_K, fast=True
            )
            - ZERO_CELSIUS_K
        )
        bg = float(
            camera_temperature(
                self.band, self.S_background, o.emissivity_setting, o.reflected_C + ZERO_CELSIUS_K
            )
            - ZERO_CELSIUS_K
        )
        outside = (r1 - r0) * (c1 - c0) < o.pixels_h * o.pixels_v
        ids = np.stack(ids)  # (phases, H, W)
        out = []
        aims = readings.shape[0]
        for li, label in enumerate(self.labels):
            mean = readings[0, li].mean(axis=0)  # the nominal aim's thermogram
            image = np.full((o.pixels_v, o.pixels_h), bg)
            image[r0:r1, c0:c1] = mean
            per_frame = readings[:, li].reshape(aims, N, -1).max(axis=2)  # (aims, frames)
            if outside:
                per_frame = np.maximum(per_frame, bg)
            per_aim = per_frame.mean(axis=1)
            r, c = np.unravel_index(int(np.argmax(image)), image.shape)
            fr = (
                self._fractions(ids, int(r) - r0, int(c) - c0)
                if r0 <= r < r1 and c0 <= c < c1
                else {"background": 1.0}
            )
            top = max(fr, key=fr.get)
            body, _, surface = top.partition(" ")
            hottest = max(float(s.temperature_K[li].max()) for s in self.surfaces.values())
            reading = CameraReading(
                label=label,
                max_C=float(per_aim.mean()),
                frame_max_range_C=(float(per_frame[0].min()), float(per_frame[0].max())),
                pixel=(int(r), int(c)),
                pixel_C=float(image[r, c]),
                body=body if surface else "",
                surface=surface or "background",
                surface_fractions=fr,
                hottest_node_C=hottest - ZERO_CELSIUS_K,
                background_C=bg,
                footprint_mm=o.footprint_mm,
                tooth_pass_period_s=self.period_s,
                frame_phases=self.frame_phases(),
                aim_std_C=float(per_aim.std()),
                aim_range_C=(float(per_aim.min()), float(per_aim.max())),
                aims=aims,
            )
            out.append(Thermogram(image, reading, self.window, ""))
        return out, readings[0]

    def _fractions(self, ids: np.ndarray, r: int, c: int) -> dict[str, float]:
        n = self.options.subsamples
        block = ids[:, r * n : (r + 1) * n, c * n : (c + 1) * n].ravel()
        names = list(self.surfaces)
        vals, counts = np.unique(block, return_counts=True)
        out = {}
        for v, k in zip(vals, counts):
            if v < 0:
                key = "background"
            else:
                key = f"{names[v // len(KINDS)]} {KINDS[v % len(KINDS)]}"
            out[key] = float(k) / block.size
        return dict(sorted(out.items(), key=lambda kv: -kv[1]))

    def frame_phases(self) -> int:
        """How many distinct tooth-pass phases the frames visit (0 at rest)."""
        if self.period_s == 0.0:
            return 0
        ratio = Fraction(1.0 / (self.period_s * self.options.frame_rate_Hz)).limit_denominator(1000)
        return ratio.denominator
