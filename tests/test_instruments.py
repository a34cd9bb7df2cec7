"""Instrument models (issue 13): IR camera, probes, torque meters, against analytic readings.

The expected readings are computed here independently of the code under test: band radiance by
adaptive quadrature of Planck's law (scipy.integrate.quad) and its inverse by root finding, the
tooth fill fraction from the involute (gearfem.geometry.involute tooth thickness), footprints from
the pinhole geometry.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from body_fields import body_field
from mpi4py import MPI
from scipy.integrate import quad
from scipy.optimize import brentq

from gearfem import pipeline
from gearfem.config import Case, case_from_dict
from gearfem.core.errors import ParameterError
from gearfem.core.materials import ZERO_CELSIUS_K
from gearfem.coupling.options import SourceOptions
from gearfem.geometry.involute import GearPair
from gearfem.geometry.options import MeshOptions
from gearfem.instruments.camera import Camera, phase_weights
from gearfem.instruments.evaluate import evaluate
from gearfem.instruments.options import (
    CameraOptions,
    InstrumentOptions,
    ProbeOptions,
    TorqueMeterOptions,
)
from gearfem.instruments.probes import read_probe
from gearfem.instruments.radiometry import Band, directional_emissivity, refractive_index
from gearfem.instruments.scene import Surface, gear_surface, linear_triangles
from gearfem.instruments.snapshot import KINDS, BodyField, CycleTorques, FieldSnapshot
from gearfem.instruments.torque import read_torque
from gearfem.thermal.options import ThermalOptions

H, C, K = 6.62607015e-34, 299792458.0, 1.380649e-23
SMALL = MeshOptions(
    teeth_in_model=3,
    refined_teeth=1,
    layers=1,
    size_flank_mm=0.6,
    size_tip_mm=0.6,
    size_root_mm=0.6,
    size_tooth_mm=1.5,
    size_body_mm=5.0,
)


def L_ref(T_K: float, band=(7.5, 13.0)) -> float:
    """Band radiance by adaptive quadrature of Planck's law (independent of Band)."""
    f = lambda lam: 2 * H * C**2 / lam**5 / math.expm1(H * C / (lam * K * T_K))
    return quad(f, band[0] * 1e-6, band[1] * 1e-6, epsabs=0.0, epsrel=1e-13, limit=200)[0]


def T_ref(L: float, band=(7.5, 13.0)) -> float:
    return brentq(lambda T: L_ref(T, band) - L, 50.0, 3000.0, xtol=1e-12, rtol=1e-14)


def reading_ref(signal: float, eps_set: float, refl_C: float) -> float:
    """What a camera reports for a signal (C): the radiometric formula, independently."""
    return T_ref((signal - (1 - eps_set) * L_ref(refl_C + ZERO_CELSIUS_K)) / eps_set) - 273.15


def S_gray(T_C: float, eps: float, surr_C: float) -> float:
    return eps * L_ref(T_C + ZERO_CELSIUS_K) + (1 - eps) * L_ref(surr_C + ZERO_CELSIUS_K)


# ------------------------------------------------------------------------------ radiometry (fast)


def test_band_radiance_is_planck_integral_and_inverts():
    band = Band(7.5, 13.0)
    for T in (200.0, 294.15, 383.15, 600.0, 1200.0):
        assert band.radiance(T) == pytest.approx(L_ref(T), rel=1e-12)
        h = 1e-4 * T
        fd = (band.radiance(T + h) - band.radiance(T - h)) / (2 * h)
        assert band.derivative(T) == pytest.approx(fd, rel=1e-6)
        assert band.radiance_fast(T) == pytest.approx(L_ref(T), rel=1e-7)
    T = np.linspace(150.0, 2500.0, 1000)
    assert np.max(np.abs(band.temperature(band.radiance(T)) - T)) < 1e-9
    with pytest.raises(ParameterError, match="band radiance"):
        band.temperature(-1.0)


def test_dielectric_emissivity():
    n = refractive_index(0.9)
    assert 1.0 - ((n - 1) / (n + 1)) ** 2 == pytest.approx(0.9, rel=1e-14)
    e = directional_emissivity(0.9, np.array([1.0, 0.5, 0.0]))
    assert e[0] == pytest.approx(0.9, rel=1e-12) and 0.0 < e[1] < 0.9 and e[2] == 0.0
    # Brewster's angle: R_p = 0, so emissivity = 1 - R_s / 2
    c = math.cos(math.atan(n))
    ct = math.sqrt(1 - (1 - c * c) / n**2)
    rs = ((c - n * ct) / (c + n * ct)) ** 2
    assert directional_emissivity(0.9, c) == pytest.approx(1 - rs / 2, rel=1e-12)


def test_phase_weights_of_the_detector_response():
    o = CameraOptions()
    P, n = 0.002, 40
    w = phase_weights(o, P, n)
    # exponential: w_k = integral over [k dt, (k+1) dt) of the periodic sum of exp(-s/tau)/tau
    tau, dt = o.time_constant_s, P / n
    ref = [
        sum(
            math.exp(-(m * P + k * dt) / tau) - math.exp(-(m * P + (k + 1) * dt) / tau)
            for m in range(200)
        )
        for k in range(n)
    ]
    assert np.allclose(w, ref, rtol=1e-12) and w.sum() == pytest.approx(1.0, rel=1e-14)
    # boxcar over exactly three periods: every phase alike; over one phase interval: that one
    box = dataclasses.replace(o, response="boxcar", integration_time_s=3 * P)
    assert np.allclose(phase_weights(box, P, n), 1.0 / n, rtol=1e-12)
    one = dataclasses.replace(o, response="boxcar", integration_time_s=dt)
    assert np.allclose(phase_weights(one, P, n), np.eye(n)[0])
    # a very slow detector averages, an instantaneous one does not
    assert np.allclose(phase_weights(dataclasses.replace(o, time_constant_s=1e3), P, n), 1 / n)
    assert np.allclose(
        phase_weights(dataclasses.replace(o, time_constant_s=0.0), P, n), np.eye(n)[0]
    )


# ------------------------------------------------------------------------- options (fast)


@pytest.mark.parametrize(
    ("table", "key", "allowed"),
    [
        ({"camera": {"pixels_h": 0}}, "instruments.camera.pixels_h", "integer in [1,"),
        ({"camera": {"pixels_v": -3}}, "instruments.camera.pixels_v", "integer in [1,"),
        ({"camera": {"fov_h_deg": 180.0}}, "instruments.camera.fov_h_deg", "(0, 180) deg"),
        ({"camera": {"fov_v_deg": 0.0}}, "instruments.camera.fov_v_deg", "(0, 180) deg"),
        ({"camera": {"view": "sideways"}}, "instruments.camera.view", "'axial', 'radial'"),
        ({"camera": {"view": [0, 0, 0]}}, "instruments.camera.view", "non-zero vector"),
        ({"camera": {"band_um": [13.0, 7.5]}}, "instruments.camera.band_um[1]", "um"),
        (
            {"camera": {"emissivity_setting": 0.0}},
            "instruments.camera.emissivity_setting",
            "(0, 1]",
        ),
        ({"probes": {"web": {"kind": "thermocouple"}}}, "instruments.probes.web.radius_mm", "> 0"),
        (
            {"probes": {"web": {"kind": "field", "quantity": "hot"}}},
            "instruments.probes.web.quantity",
            "max_surface",
        ),
        (
            {"probes": {"1x": {"kind": "field", "quantity": "mean_bulk"}}},
            "instruments.probes.1x",
            "letters",
        ),
        ({"torque": {"uncertainty_Nm": -1.0}}, "instruments.torque.uncertainty_Nm", ">= 0"),
        ({"camera": {"pixel_count": 3}}, "instruments.camera.pixel_count", "known key"),
    ],
)
def test_bad_instrument_options_name_the_key_and_range(table, key, allowed):
    with pytest.raises(ParameterError) as err:
        case_from_dict({"instruments": table})
    assert err.value.name == key and allowed in err.value.allowed, str(err.value)


def test_a_view_that_sees_no_gear_is_an_error():
    case = Case()
    pipeline.check_instruments(case)  # the default camera sees the pair
    away = dataclasses.replace(case.instruments.camera, target_mm=(0.0, 500.0, 6.5))
    with pytest.raises(ParameterError) as err:
        pipeline.check_instruments(
            dataclasses.replace(case, instruments=InstrumentOptions(camera=away))
        )
    assert err.value.name == "instruments.camera.view" and "contains the gears" in err.value.allowed
    behind = dataclasses.replace(case.instruments.camera, distance_m=0.005)  # inside the slab
    with pytest.raises(ParameterError, match="instruments.camera.distance_m"):
        pipeline.check_instruments(
            dataclasses.replace(case, instruments=InstrumentOptions(camera=behind))
        )


def test_instruments_round_trip_through_the_case_file(tmp_path):
    from gearfem.config import load_case, write_case

    ins = InstrumentOptions(
        camera=CameraOptions(view=(1.0, -1.0, -2.0), pixels_h=80, pixels_v=60),
        probes={"web": ProbeOptions(kind="thermocouple", radius_mm=20.0, body="wheel")},
        torque=TorqueMeterOptions(uncertainty_Nm=0.02),
    )
    case = dataclasses.replace(Case(), instruments=ins)
    again = load_case(write_case(case, tmp_path / "c.toml"))
    assert again.instruments == ins
    assert ins.quantities == ("camera_max", "probe:web", "torque_loss_Nm", "efficiency")


# ------------------------------------------------------------------ torque meters (fast, analytic)


def test_torque_meters_read_loss_and_efficiency():
    t1 = np.array([8.5, 8.7, 8.6, 8.4])  # pinion torque over the positions
    torques = CycleTorques(t1, 16.0, 0.5, np.full(4, 0.3), 0.5)  # z1/z2 = 1/2
    r = read_torque(TorqueMeterOptions(uncertainty_Nm=0.05), torques, 1500.0)
    assert r.input_torque_Nm == pytest.approx(8.55, rel=1e-14)
    assert r.torque_loss_Nm == pytest.approx(8.55 - 16.0 * 0.5, rel=1e-14)
    assert r.efficiency == pytest.approx(16.0 * 0.5 / 8.55, rel=1e-14)
    omega = 2 * math.pi * 1500.0 / 60.0
    assert r.friction_power_W == pytest.approx(0.55 * omega, rel=1e-12)
    assert r.cycle_friction_power_W == pytest.approx(0.3 * omega, rel=1e-14)
    assert r.u_torque_loss_Nm == pytest.approx(0.05 * math.sqrt(1.25), rel=1e-14)
    assert r.u_efficiency == pytest.approx(
        r.efficiency * 0.05 * math.hypot(1 / 8.55, 1 / 16), rel=1e-12
    )


# ------------------------------------------------------- the camera on synthetic scenes (fast)


def _plate(T_cold_C, T_hot_C, band_x_m, half=0.02, z=0.0) -> Surface:
    """A flat plate in the plane z facing +z at T_cold with a hot band x in band_x_m (in front)."""
    x0, x1 = band_x_m
    quads = [
        ((-half, -half), (half, half), T_cold_C, z),
        ((x0, -half), (x1, half), T_hot_C, z + 1e-6),
    ]
    pts, vals = [], []
    for (a, b), (c, d), T, zz in quads:
        pts += [[(a, b, zz), (c, b, zz), (c, d, zz)], [(a, b, zz), (c, d, zz), (a, d, zz)]]
        vals += [[T + ZERO_CELSIUS_K] * 3] * 2
    return Surface(
        points_m=np.array(pts),
        temperature_K=np.array(vals)[None],
        kind=np.zeros(len(pts), dtype=np.int8),
        closed=False,
        emissivity=0.9,
        center_m=np.zeros(3),
        rotation_sense=1,
        pitch_rad=2 * math.pi,
    )


def test_hot_band_narrower_than_a_pixel_reads_the_area_weighted_radiance():
    o = CameraOptions(
        subsamples=16, blur_fwhm_px=0.0, surroundings_C=21.0, background_C=21.0, reflected_C=21.0
    )
    delta = 2 * math.tan(math.radians(12.5)) / 160  # footprint at 1 m, m
    # a band of 3/16 of pixel column 80 (x in [0, delta)): its edges on sample boundaries
    band = (5 * delta / 16, 8 * delta / 16)
    cam = Camera(
        o, {"p": _plate(40.0, 200.0, band, half=0.05)}, 0.0, 30, np.zeros(3), 21.0, 21.0, ("t",)
    )
    (th,), _ = cam.render()
    a = 3 / 16
    S = a * S_gray(200.0, 0.9, 21.0) + (1 - a) * S_gray(40.0, 0.9, 21.0)
    expected = reading_ref(S, 0.9, 21.0)
    assert th.image_C[60, 80] == pytest.approx(expected, abs=1e-3)
    assert th.image_C[60, 78] == pytest.approx(40.0, abs=1e-4)
    # radiance, not temperature, is averaged: the band reads far above the temperature average
    assert expected - (a * 200.0 + (1 - a) * 40.0) > 10.0
    assert th.reading.max_C == pytest.approx(expected, abs=1e-3) and th.reading.pixel[1] == 80
    # the optics' blur moves radiance to the neighbours and conserves it along the row
    blur = Camera(
        dataclasses.replace(o, blur_fwhm_px=1.5),
        {"p": _plate(40.0, 200.0, band, half=0.05)},
        0.0,
        30,
        np.zeros(3),
        21.0,
        21.0,
        ("t",),
    )
    (tb,), _ = blur.render()
    b = Band(7.5, 13.0)
    excess = b.radiance(tb.image_C[60, 75:86] + ZERO_CELSIUS_K) - b.radiance(40.0 + ZERO_CELSIUS_K)
    # (to the sample radiance table's 1e-7 of L in each of the 11 pixels)
    assert excess.sum() == pytest.approx(a * (L_ref(473.15) - L_ref(313.15)), rel=5e-6)
    assert tb.image_C[60, 80] < expected - 5.0 and tb.image_C[60, 79] > 40.5


def test_the_unknown_sub_pixel_aim_is_averaged_over_a_pixel():
    """A hot band half a pixel wide, read with the pixel grid at 16 aims k/16 pixel apart: the
    hottest pixel holds the part of the band that the shifted grid leaves in one pixel, max(x,
    w − x) when the band straddles an edge and all of it otherwise, so camera_max is the mean of
    the readings of those area-weighted radiances (1D: the band runs across the image), and the
    spread over the aims is their standard deviation; the nominal aim alone reads the whole
    band."""
    n = 16
    o = CameraOptions(
        subsamples=n,
        aim_offsets=n,
        blur_fwhm_px=0.0,
        surroundings_C=21.0,
        background_C=21.0,
        reflected_C=21.0,
    )
    delta = 2 * math.tan(math.radians(12.5)) / 160  # footprint at 1 m, m
    band = (5 * delta / n, 13 * delta / n)  # samples 5-12 of pixel column 80
    plate = {"p": _plate(40.0, 200.0, band, half=0.05)}
    (th,), _ = Camera(o, plate, 0.0, 30, np.zeros(3), 21.0, 21.0, ("t",)).render()
    hot, cold = S_gray(200.0, 0.9, 21.0), S_gray(40.0, 0.9, 21.0)
    held = []  # samples of the band in the fullest pixel, grid shifted by k samples
    for k in range(n):
        lo, hi = 5 - k, 13 - k  # the band in the shifted grid's sample coordinates
        held.append(max(max(0, min(hi, e + n) - max(lo, e)) for e in range(-n, 2 * n, n)))
    assert sorted(set(held)) == [4, 5, 6, 7, 8]  # straddling for 7 of 16 aims
    readings = np.array([reading_ref(a / n * hot + (1 - a / n) * cold, 0.9, 21.0) for a in held])
    r = th.reading
    assert r.aims == n * n
    assert r.max_C == pytest.approx(readings.mean(), abs=1e-3)
    assert r.aim_std_C == pytest.approx(readings.std(), abs=1e-3)
    assert r.aim_range_C == pytest.approx((readings.min(), readings.max()), abs=1e-3)
    nominal = reading_ref(0.5 * hot + 0.5 * cold, 0.9, 21.0)
    assert th.image_C[60, 80] == pytest.approx(nominal, abs=1e-3)  # the nominal aim's image
    assert r.max_C < nominal - 1.0 and r.aim_std_C > 1.0
    # one aim: the nominal reading, no spread
    (one,), _ = Camera(
        dataclasses.replace(o, aim_offsets=1), plate, 0.0, 30, np.zeros(3), 21.0, 21.0, ("t",)
    ).render()
    assert one.reading.max_C == pytest.approx(nominal, abs=1e-3)
    assert one.reading.aim_std_C == 0.0 and one.reading.aims == 1


def test_aim_offsets_must_divide_the_subsamples():
    with pytest.raises(ParameterError) as err:
        CameraOptions(subsamples=8, aim_offsets=3)
    assert err.value.name == "camera.aim_offsets" and "divisor" in err.value.allowed
    with pytest.raises(ParameterError):
        CameraOptions(subsamples=8, aim_offsets=16)


# ------------------------------------------------------------------ on gear fields (DOLFINx)


def _uniform_case(T_C: float, mesh: MeshOptions = SMALL, **camera) -> Case:
    return Case(
        name="uniform",
        mesh=mesh,
        sources=SourceOptions(mode="prescribed", flank_heat_per_gear_W=0.0, u_max_J_m3=0.0),
        thermal=ThermalOptions(mode="steady", degree=1, ambient_C=T_C),
        instruments=InstrumentOptions(camera=CameraOptions(**camera)),
    )


@pytest.fixture(scope="module")
def uniform_snapshot(tmp_path_factory):
    """Both gears at 80 C exactly: steady state without sources at an ambient of 80 C."""
    comm = MPI.COMM_WORLD
    path = Path(comm.bcast(str(tmp_path_factory.mktemp("uniform")) if comm.rank == 0 else None))
    case = _uniform_case(80.0)
    _, _, snap = pipeline.observed_thermal(case, path, comm)
    return comm.bcast(snap, root=0)


@pytest.mark.parametrize(
    ("view", "speed", "pixels", "fov", "blur"),
    [
        ("axial", 1000.0, (160, 120), (25.0, 19.0), 1.0),
        ("radial", 0.0, (320, 240), (12.0, 9.0), 1.0),
        ((1.0, -1.0, -2.0), 2000.0, (64, 48), (25.0, 19.0), 0.0),
    ],
)
def test_uniform_gear_reads_its_temperature(uniform_snapshot, view, speed, pixels, fov, blur):
    """A uniform gear at T in front of a cold background: with the emissivity setting equal to
    the surface's and the reflected setting equal to the surroundings, the hottest pixel reads T
    (every view, speed, pixel size); the background reads its own temperature; with another
    setting the reading follows the radiometric formula."""
    snap = dataclasses.replace(uniform_snapshot, pinion_speed_rpm=speed)
    assert np.all(
        np.abs(np.concatenate([b.temperature_K.ravel() for b in snap.bodies.values()]) - 353.15)
        < 1e-9
    )
    o = CameraOptions(
        view=view,
        pixels_h=pixels[0],
        pixels_v=pixels[1],
        fov_h_deg=fov[0],
        fov_v_deg=fov[1],
        blur_fwhm_px=blur,
        surroundings_C=21.0,
        background_C=21.0,
        reflected_C=21.0,
        phases=6,
    )
    r = evaluate(InstrumentOptions(camera=o), snap).camera["end"]
    assert r.max_C == pytest.approx(80.0, abs=0.1)
    assert r.frame_max_range_C[1] - r.frame_max_range_C[0] < 0.1
    assert r.background_C == pytest.approx(21.0, abs=1e-6)
    assert r.body in ("pinion", "wheel") and r.surface_fractions.get("background", 0.0) == 0.0
    other = dataclasses.replace(o, emissivity_setting=0.95)
    r2 = evaluate(InstrumentOptions(camera=other), snap).camera["end"]
    expected = reading_ref(S_gray(80.0, 0.9, 21.0), 0.95, 21.0)
    assert r2.max_C == pytest.approx(expected, abs=0.1) and abs(expected - 80.0) > 2.0


RING = MeshOptions(
    teeth_in_model=3,
    refined_teeth=3,
    layers=1,
    order=1,
    size_flank_mm=0.3,
    size_tip_mm=0.3,
    size_root_mm=0.4,
    size_tooth_mm=1.0,
    size_body_mm=5.0,
)


@pytest.fixture(scope="module")
def ring(tmp_path_factory):
    """The pinion alone as a toothed ring at 100 C (linear mesh: flat faces on the involute)."""
    comm = MPI.COMM_WORLD
    path = Path(comm.bcast(str(tmp_path_factory.mktemp("ring")) if comm.rank == 0 else None))
    case = dataclasses.replace(
        _uniform_case(100.0, RING),
        instruments=InstrumentOptions(
            camera=CameraOptions(enabled=False),
            probes={"t": ProbeOptions(kind="field", quantity="mean_bulk")},
        ),
    )
    _, _, snap = pipeline.observed_thermal(case, path, comm)
    snap = comm.bcast(snap, root=0)
    return case, gear_surface(snap.bodies["pinion"])


def _ring_camera(ring, speed, n_phases, **kw):
    """A camera 20 m away looking axially at the bottom of the pinion (x = 0, y = -29.5 mm) with
    8 x 64 pixels of 0.1 mm: nearly parallel rays, so a ray in a gap sees the background."""
    case, surf = ring
    D, fp, n, m = 20.0, 1.0e-4, 64, 8
    o = CameraOptions(
        distance_m=D,
        pixels_h=m,
        pixels_v=n,
        fov_h_deg=math.degrees(2 * math.atan(m * fp / 2 / D)),
        fov_v_deg=math.degrees(2 * math.atan(n * fp / 2 / D)),
        blur_fwhm_px=0.0,
        subsamples=4,
        phases=n_phases,
        surroundings_C=21.0,
        background_C=21.0,
        reflected_C=21.0,
        **kw,
    )
    b = case.geometry.face_width_mm * 1e-3
    target = np.array([0.0, -0.0295, b / 2])
    return Camera(o, {"pinion": surf}, speed, 30, target, 21.0, 21.0, ("end",)), target


def test_the_rays_are_traced_once_per_scene(ring):
    """A camera of the same gears and options reading other temperatures and another emissivity
    (a diagnosis's runs) reuses the rays the first traced (``camera._VIEWS``) and reads what a
    camera tracing them again reads, to the bit; a camera moved traces its own."""
    from gearfem.instruments import camera as camera_module

    camera_module._VIEWS.clear()
    cam, target = _ring_camera(ring, 1000.0, 6, directional_emissivity="dielectric")
    (first,), _ = cam.render()
    assert len(camera_module._VIEWS) == 1
    surf = ring[1]
    x = surf.points_m[None, :, :, 0]
    other = dataclasses.replace(
        surf, temperature_K=surf.temperature_K + 60.0 * (x - x.min()) / np.ptp(x), emissivity=0.7
    )

    def reading():
        c = Camera(cam.options, {"pinion": other}, 1000.0, 30, target, 21.0, 21.0, ("end",))
        (th,), frames = c.render()
        return th, frames

    reused, frames_reused = reading()
    assert len(camera_module._VIEWS) == 1  # the same scene: no rays traced
    camera_module._VIEWS.clear()
    traced, frames_traced = reading()
    assert np.array_equal(frames_reused, frames_traced)
    assert np.array_equal(reused.image_C, traced.image_C) and reused.reading == traced.reading
    assert reused.reading.max_C > first.reading.max_C + 5.0  # it read the other temperatures
    moved = dataclasses.replace(cam.options, distance_m=cam.options.distance_m * 1.01)
    Camera(moved, {"pinion": other}, 1000.0, 30, target, 21.0, 21.0, ("end",)).render()
    assert len(camera_module._VIEWS) == 2


def test_stored_views_are_read_by_a_later_process(ring, tmp_path, monkeypatch, caplog):
    """With a views directory the first camera of a scene stores its phase views (one file); a
    camera of the same scene in a later process (the in-process views cleared) reads them instead
    of tracing and reads the same thermogram to the bit; an unreadable file is traced and stored
    again, with a warning; another pose gets a file of its own."""
    from gearfem.instruments import camera as camera_module

    def camera(distance_factor=1.0):
        cam, target = _ring_camera(ring, 1000.0, 6, directional_emissivity="dielectric")
        o = dataclasses.replace(cam.options, distance_m=cam.options.distance_m * distance_factor)
        return Camera(o, {"pinion": ring[1]}, 1000.0, 30, target, 21.0, 21.0, ("end",), tmp_path)

    camera_module._VIEWS.clear()
    (traced,), frames_traced = camera().render()
    (stored,) = tmp_path.glob("*.npz")
    camera_module._VIEWS.clear()
    with monkeypatch.context() as m:
        m.setattr(Camera, "_phase_view", lambda self, j: pytest.fail("rays traced again"))
        (read,), frames_read = camera().render()
    assert np.array_equal(frames_read, frames_traced)
    assert np.array_equal(read.image_C, traced.image_C) and read.reading == traced.reading
    stored.write_bytes(stored.read_bytes()[:100])
    camera_module._VIEWS.clear()
    with caplog.at_level("WARNING", logger="gearfem.instruments.camera"):
        (again,), _ = camera().render()
    assert "unreadable" in caplog.text and again.reading == traced.reading
    assert len(camera_module.load_views(stored)) == 6  # stored again, whole
    camera(1.01).render()
    assert len(list(tmp_path.glob("*.npz"))) == 2


def _fill_fraction(prof, r: np.ndarray) -> np.ndarray:
    """Time fraction a point at radius r of the turning pinion's side face is on a tooth: the
    tooth's angular thickness over the pitch (involute part of the flank)."""
    return prof.thickness(r) / (r * prof.pitch_angle_rad)


def _footprint_radii(cam: Camera, case: Case, row: int, col: int, n: int = 8) -> np.ndarray:
    """Radii of n x n points of a pixel's footprint on the side face z = b (the pinhole rays
    through the pixel, intersected with that plane)."""
    g = cam.geometry
    q = (np.arange(n) + 0.5) / n
    cc, rr = np.meshgrid(col + q, row + q)
    rays = g.ray(cc.ravel(), rr.ravel())
    t = (case.geometry.face_width_mm * 1e-3 - g.position_m[2]) / rays[:, 2]
    pts = g.position_m + t[:, None] * rays
    return np.hypot(pts[:, 0], pts[:, 1])


def _involute_band(case: Case):
    prof = GearPair(case.geometry).pinion
    return prof, prof.form_radius_m + 3e-4, prof.tip_form_radius_m - 3e-4


@pytest.mark.slow
def test_turning_toothed_ring_reads_the_fill_fraction_weighted_radiance(ring):
    case, _ = ring
    speed, N = 1000.0, 720
    P = 60.0 / (speed * 30)
    cam, _ = _ring_camera(ring, speed, N, response="boxcar", integration_time_s=P)
    (th,), frames = cam.render()
    prof, lo, hi = _involute_band(case)
    S_T, S_b = S_gray(100.0, 0.9, 21.0), S_gray(21.0, 0.9, 21.0)
    # Error bound of the fill fraction: the time quadrature (each ray's time fraction is off by
    # less than 1/N with N phases) and the flat faces of the linear mesh (a chord of length h on
    # the involute, radius of curvature rho >= sqrt(r_lo² - r_b²), lies h²/(8 rho) inside the
    # flank, on both flanks of the tooth).
    snap_faces = ring[1]
    flank = snap_faces.points_m[snap_faces.kind == KINDS.index("drive_flank")][..., :2]
    h = np.max(np.linalg.norm(flank - np.roll(flank, 1, axis=1), axis=2))
    rho = math.sqrt(lo**2 - prof.base_radius_m**2)
    df_geom = 2 * h**2 / (8 * rho) / (lo * prof.pitch_angle_rad)
    assert df_geom < 0.5 / N
    checked, resolved = 0, 0.0
    for row in range(64):
        for col in (1, 4, 6):
            r = _footprint_radii(cam, case, row, col)
            if r.min() < lo or r.max() > hi:
                continue
            f = float(np.mean(_fill_fraction(prof, r)))
            expected = reading_ref(f * S_T + (1 - f) * S_b, 0.9, 21.0)
            tol = (S_T - S_b) / (0.9 * L_derivative(expected)) * (1 / N + df_geom)
            assert th.image_C[row, col] == pytest.approx(expected, abs=tol), (row, col, f)
            resolved = max(resolved, abs(f * 100.0 + (1 - f) * 21.0 - expected) / tol)
            checked += 1
    assert checked > 20
    # averaging temperature instead of radiance would have failed by many tolerances
    assert resolved > 20.0
    # a boxcar over one period: every frame the same reading
    assert np.ptp(frames[0], axis=0).max() < 1e-9


def L_derivative(T_C: float) -> float:
    T = T_C + ZERO_CELSIUS_K
    return (L_ref(T + 0.01) - L_ref(T - 0.01)) / 0.02


def test_ring_at_rest_or_short_integration_resolves_teeth_and_gaps(ring):
    case, _ = ring
    _, lo, hi = _involute_band(case)
    cam, _ = _ring_camera(ring, 0.0, 1)
    band = [
        (row, col)
        for row in range(64)
        for col in range(8)
        if lo <= _footprint_radii(cam, case, row, col, 2).min()
        and _footprint_radii(cam, case, row, col, 2).max() <= hi
    ]
    assert len(band) > 100
    # at rest, in the flank band: pixels on a tooth read 100 C, pixels in a gap 21 C
    (th,), _ = cam.render()
    vals = np.array([th.image_C[p] for p in band])
    assert vals.max() == pytest.approx(100.0, abs=1e-3) and vals.min() == pytest.approx(
        21.0, abs=1e-3
    )
    # turning, with an integration time of one phase: the frames resolve teeth and gaps
    speed, N = 1000.0, 48
    P = 60.0 / (speed * 30)
    fast, _ = _ring_camera(ring, speed, N, response="boxcar", integration_time_s=P / N)
    _, frames = fast.render()
    row, col = band[len(band) // 2]
    seq = frames[0, :, row, col]
    assert seq.max() == pytest.approx(100.0, abs=1e-3) and seq.min() == pytest.approx(
        21.0, abs=1e-3
    )
    # ... while the microbolometer (10 ms against a 2 ms tooth pass) nearly averages them
    slow, _ = _ring_camera(ring, speed, N)
    _, fs = slow.render()
    seq = fs[0, :, row, col]
    assert np.ptp(seq) < 0.1 * (100.0 - 21.0) and 21.0 + 5.0 < seq.mean() < 100.0 - 5.0


# ---------------------------------------------------------- snapshots and probes (DOLFINx)


def _quadratic(x):
    """A quadratic field (K): P2 represents it exactly."""
    return 300.0 + 2000.0 * x[0] + 5.0e4 * x[1] ** 2 + 800.0 * x[2]


def _recorded(comm, body: str, cache: Path, field=_quadratic, degree: int = 2):
    """The snapshot of ``field`` on the SMALL mesh of ``body`` (collective; rank 0 gets it)."""
    from dolfinx import fem

    from gearfem.geometry.mesh import build_gear_mesh
    from gearfem.geometry.placement import placement
    from gearfem.instruments.gather import FieldRecorder, dof_coordinates
    from gearfem.thermal.domain import ThermalDomain

    case = Case(mesh=SMALL)
    gm = build_gear_mesh(case.geometry, SMALL, comm, cache_dir=cache, bodies=(body,))
    dom = ThermalDomain.from_gear_mesh(gm, body)
    T = fem.Function(fem.functionspace(dom.mesh, ("Lagrange", degree)))
    # at the mesh's own node coordinates: the same values whatever the partition
    T.x.array[:] = field(dof_coordinates(T.function_space).T)
    rec = FieldRecorder(T, dom)
    rec.record("end", None, {"mean_bulk": 42.0})
    pl = placement(gm.pair, SMALL, body)
    sense = 1 if body == "pinion" else -1
    teeth = case.geometry.teeth(body)
    return rec.body_field(body, pl.center_m, pl.tooth_angles_rad, teeth, sense, 1000.0, 0.9)


@pytest.fixture(scope="module")
def mesh_cache(tmp_path_factory):
    comm = MPI.COMM_WORLD
    return Path(comm.bcast(str(tmp_path_factory.mktemp("meshes")) if comm.rank == 0 else None))


def test_probes_read_the_field_at_their_points(mesh_cache):
    comm = MPI.COMM_WORLD
    field = comm.bcast(_recorded(comm, "pinion", mesh_cache), root=0)
    b = Case().geometry.face_width_mm * 1e-3
    theta = float(field.tooth_angles_rad[field.central_tooth])
    # thermocouple in the web, 5 deg off the central tooth's centre line, 4 mm deep
    tc = ProbeOptions(kind="thermocouple", radius_mm=22.0, angle_deg=5.0, z_mm=4.0)
    (r,) = read_probe("tc", tc, field, [0], ["end"], b)
    a = theta + math.radians(5.0)
    x = np.array([0.022 * math.cos(a), 0.022 * math.sin(a), 0.004])
    assert r.value_C + ZERO_CELSIUS_K == pytest.approx(_quadratic(x), abs=1e-9)
    assert r.point_mm == pytest.approx(tuple(x * 1e3), abs=1e-12)
    # side face z = 0 at 22 mm: the mean over one pitch of the field on that circle
    sf = ProbeOptions(kind="side_face", radius_mm=22.0, side="front")
    (s,) = read_probe("sf", sf, field, [0], ["end"], b)
    p = field.pitch_rad
    t1, t2 = theta - p / 2, theta + p / 2
    mean_x = 0.022 * (math.sin(t2) - math.sin(t1)) / p
    mean_y2 = 0.022**2 * (0.5 - (math.sin(2 * t2) - math.sin(2 * t1)) / (4 * p))
    exact = 300.0 + 2000.0 * mean_x + 5.0e4 * mean_y2
    assert s.value_C + ZERO_CELSIUS_K == pytest.approx(exact, abs=1e-7)
    # field values as the thermal model reported them
    fp = ProbeOptions(kind="field", quantity="mean_bulk")
    assert read_probe("f", fp, field, [0], ["end"], b)[0].value_C == 42.0
    # a thermocouple outside the gear is an error naming the probe's key
    with pytest.raises(ParameterError, match=r"instruments\.probes\.tc\.radius_mm"):
        read_probe("tc", dataclasses.replace(tc, radius_mm=40.0), field, [0], ["end"], b)
    with pytest.raises(ParameterError, match=r"instruments\.probes\.sf\.radius_mm"):
        read_probe("sf", dataclasses.replace(sf, radius_mm=10.0), field, [0], ["end"], b)


def test_snapshot_file_round_trip(mesh_cache, tmp_path):
    comm = MPI.COMM_WORLD
    fields = {b: _recorded(comm, b, mesh_cache) for b in ("pinion", "wheel")}
    if comm.rank != 0:
        return
    snap = FieldSnapshot(("end",), (None,), fields, 1000.0, 0.012934, 23.0, None, "test")
    again = FieldSnapshot.load(snap.save(tmp_path / "s.npz"))
    assert again.labels == ("end",) and again.times_s == (None,) and again.case == "test"
    for b, f in fields.items():
        g = again.bodies[b]
        for key in ("nodes_m", "cells", "faces", "face_kind", "temperature_K", "tooth_angles_rad"):
            assert np.array_equal(getattr(f, key), getattr(g, key)), key
        assert (g.teeth, g.rotation_sense, g.temperatures_C) == (
            30,
            f.rotation_sense,
            f.temperatures_C,
        )
    # the whole gear from the sector: by the divergence theorem the triangles enclose the whole
    # gear's volume only if they close the surface and face outwards. The linear sub-triangles
    # replace curved arcs by chords; on the bore (5 mm elements, half-chords of 2.5 mm on a 15 mm
    # radius: sagitta 0.05 mm) that adds about 1.4e-3 of the volume, the outline takes a little.
    s = gear_surface(fields["pinion"])
    assert s.count % 30 == 0
    p = s.points_m
    vol = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0
    prof = GearPair(Case().geometry).pinion
    exact = 30 * prof.tooth_sector_area_m2(prof.bore_radius_m) * 0.012934
    assert vol == pytest.approx(exact, rel=2e-3)


@pytest.mark.mpi
def test_snapshot_and_readings_are_the_same_on_one_and_two_ranks(comms, mesh_cache):
    serial, world = comms
    w = {b: _recorded(world, b, mesh_cache) for b in ("pinion", "wheel")}
    s = {b: _recorded(serial, b, mesh_cache) for b in ("pinion", "wheel")}
    if world.rank != 0:
        return
    for b in w:
        for key in ("nodes_m", "cells", "faces", "face_kind", "temperature_K"):
            assert np.array_equal(getattr(w[b], key), getattr(s[b], key)), (b, key)
    ins = InstrumentOptions(
        camera=CameraOptions(phases=4),
        probes={"tc": ProbeOptions(kind="thermocouple", radius_mm=22.0, body="wheel")},
    )
    rw = evaluate(ins, FieldSnapshot(("end",), (None,), w, 1000.0, 0.012934, 23.0))
    rs = evaluate(ins, FieldSnapshot(("end",), (None,), s, 1000.0, 0.012934, 23.0))
    assert rw.to_json() == rs.to_json()


# ------------------------------------------------------------------------ gearfem run / observe


def _prescribed_run_case() -> Case:
    return Case(
        name="prescribed pair",
        mesh=SMALL,
        sources=SourceOptions(mode="prescribed", flank_heat_per_gear_W=15.0, u_max_J_m3=0.0),
        thermal=ThermalOptions(duration_s=120.0, output_times_s=(60.0,), degree=1),
        instruments=InstrumentOptions(
            camera=CameraOptions(phases=4),
            probes={
                "web": ProbeOptions(kind="thermocouple", radius_mm=22.0, body="wheel"),
                "side": ProbeOptions(kind="side_face", radius_mm=30.0),
                "bulk": ProbeOptions(kind="field", quantity="mean_bulk"),
            },
        ),
    )


@pytest.mark.mpi
@pytest.mark.slow
def test_run_writes_every_reading_and_observe_reads_them_again(comms, tmp_path_factory):
    serial, world = comms
    base = Path(world.bcast(str(tmp_path_factory.mktemp("runs")) if world.rank == 0 else None))
    case = _prescribed_run_case()
    out = base / "world"
    summ = pipeline.run(case, out, world, progress=False)
    ins = summ.instruments
    assert ins is not None and ins.labels == ("60", "end", "steady")
    assert ins.torque is None  # prescribed sources: no cycle, no torques
    # the camera sees both gears; its hottest pixel reads below the hottest surface node and
    # above the ambient; the probes read at every label
    for lab in ins.labels:
        cam = ins.camera[lab]
        assert 23.0 < cam.max_C < cam.hottest_node_C
        assert set(ins.probes[lab]) == {"web", "side", "bulk"}
    assert ins.probes["end"]["bulk"].value_C == pytest.approx(
        summ.thermal["final_temperatures_C"]["mean_bulk"], abs=1e-12
    )
    assert summ.thermal_other is not None and summ.thermal_other["body"] == "wheel"
    assert summ.headline.camera_max_C == ins.camera["end"].max_C
    assert summ.headline.camera_max_at_times_C == {"60": ins.camera["60"].max_C}
    # the field's surface maximum: on linear (P1) faces the hottest node itself
    assert summ.headline.max_surface_field_C == pytest.approx(
        summ.headline.max_surface_temperature_C, abs=1e-9
    )
    again = pipeline.RunSummary.read(out / "summary.json")
    assert again.instruments == ins
    for name in ins.files:
        assert (out / "instruments" / name).is_file()
    img = np.loadtxt(out / "instruments" / "thermogram_end.csv", delimiter=",")
    assert img.shape == (120, 160) and img.max() == pytest.approx(
        ins.camera["end"].pixel_C, abs=1e-3
    )
    # observe: the same readings without solving; another view reads differently
    obs = pipeline.observe(out, world, out_dir=base / "obs")
    assert obs == ins
    radial = InstrumentOptions(camera=CameraOptions(view="radial", phases=4))
    other = pipeline.observe(out, world, instruments=radial, only=("camera",), out_dir=base / "r")
    assert other.camera["end"].max_C != ins.camera["end"].max_C and not other.probes["end"]
    if world.rank == 0:
        assert (base / "r" / "readings.json").is_file()
    # 1 rank against all ranks: the same readings to the thermal solver's tolerance
    if world.size > 1:
        alone = pipeline.run(case, base / f"serial{world.rank}", serial, progress=False)
        for lab in ins.labels:
            assert alone.instruments.camera[lab].max_C == pytest.approx(
                ins.camera[lab].max_C, abs=1e-6
            )
            assert alone.instruments.camera[lab].pixel == ins.camera[lab].pixel
            for name, p in ins.probes[lab].items():
                assert alone.instruments.probes[lab][name].value_C == pytest.approx(
                    p.value_C, abs=1e-6
                )


def test_observe_needs_a_finished_run(tmp_path):
    with pytest.raises(ParameterError, match="result directory"):
        pipeline.observe(tmp_path)
    with pytest.raises(ParameterError, match="--instrument"):
        (tmp_path / "summary.json").write_text("{}")
        pipeline.observe(tmp_path, only=("sonar",))


# ------------------------------------------------- torque meters and the forward model (cycles)


def test_torque_meters_read_the_power_the_pair_dissipates():
    """With the pair's friction and hysteresis heat at a thermal state, the meters read that
    power: loss x omega = friction + hysteresis exactly, the input torque the output's referred
    torque plus the loss; the cycle's constant-mu reading stays beside it."""
    t1 = np.array([8.5, 8.7, 8.6, 8.4])
    torques = CycleTorques(t1, 16.0, 0.5, np.full(4, 0.3), 0.5)
    omega = 2.0 * math.pi * 1500.0 / 60.0
    r = read_torque(TorqueMeterOptions(uncertainty_Nm=0.05), torques, 1500.0, heat=(30.0, 2.5))
    assert r.source == "law"
    assert r.torque_loss_Nm * omega == pytest.approx(32.5, rel=1e-14)
    assert r.input_torque_Nm == pytest.approx(16.0 * 0.5 + r.torque_loss_Nm, rel=1e-14)
    assert r.efficiency == pytest.approx(8.0 / r.input_torque_Nm, rel=1e-14)
    assert r.friction_power_W == 30.0 and r.hysteresis_power_W == 2.5
    assert r.cycle_torque_loss_Nm == pytest.approx(8.55 - 8.0, rel=1e-14)
    assert read_torque(TorqueMeterOptions(), torques, 1500.0).source == "cycle"


@pytest.mark.slow
def test_torque_meters_follow_the_friction_law(tmp_path_factory):
    """Both gears' thermal models on the coarse case: the torque meters read the friction law's
    power at the steady state plus the hysteresis (energy balance to round-off); with the cycle's
    constant mu the law's friction power is the cycle's own (each gear's flux carries its share of
    it; the transfer to the thermal mesh conserves it to 1.3e-8 here); a glassy mu of 0.1 below
    T_g reads a smaller loss, by more than the meters' uncertainty."""
    from gearfem.config import load_case
    from gearfem.contact.friction import FrictionOptions
    from gearfem.instruments.evaluate import evaluate

    root = Path(__file__).resolve().parent.parent
    case = load_case(root / "tests" / "cases" / "coarse.toml")
    case = dataclasses.replace(
        case,
        thermal=dataclasses.replace(case.thermal, mode="steady", output_times_s=()),
        instruments=dataclasses.replace(
            case.instruments, camera=dataclasses.replace(case.instruments.camera, enabled=False)
        ),
    )
    comm = MPI.COMM_WORLD
    cyc, _, _ = pipeline.cycle(case, comm)
    omega = 2.0 * math.pi * case.operating.speed_rpm / 60.0
    got = {}
    for name, friction in (
        ("constant", FrictionOptions()),
        ("glass", FrictionOptions(law="glass_transition", mu_glassy=0.1)),
    ):
        c = dataclasses.replace(case, friction=friction)
        out = Path(comm.bcast(str(tmp_path_factory.mktemp(name)) if comm.rank == 0 else None))
        _, _, snap = pipeline.observed_thermal(c, out, comm, cyc, write_fields=False)
        if comm.rank == 0:
            r = evaluate(c.instruments, snap, only=("torque",)).torque
            assert r.source == "law"
            p_f, p_h = snap.mesh_heat_W(snap.label_of(None))
            assert r.torque_loss_Nm * omega == pytest.approx(p_f + p_h, rel=1e-12)
            assert r.friction_power_W == p_f and r.hysteresis_power_W == p_h
            got[name] = r
    if comm.rank == 0:
        const, glass = got["constant"], got["glass"]
        assert const.friction_power_W == pytest.approx(const.cycle_friction_power_W, rel=1e-7)
        # glassy mu 0.1: the gear that stays below T_g makes a fifth of its share; the reading
        # drops by many times the meters' uncertainty (a torque meter sees the law)
        assert glass.friction_power_W < 0.9 * const.friction_power_W
        assert const.torque_loss_Nm - glass.torque_loss_Nm > 3 * glass.u_torque_loss_Nm


@pytest.mark.slow
def test_forward_model_predicts_instrument_readings():
    """The diagnosis' full model returns what the instruments read: camera_max between the
    ambient and the hottest node, the torque meters' loss of the cycle, probes by name; an
    instrument the case does not have is an error naming the quantity."""
    from gearfem.config import load_case
    from gearfem.diagnose.data import Dataset, Measurement
    from gearfem.diagnose.forward import FullModel

    root = Path(__file__).resolve().parent.parent
    case = load_case(root / "tests" / "cases" / "coarse.toml")
    case = dataclasses.replace(
        case,
        instruments=dataclasses.replace(
            case.instruments,
            camera=dataclasses.replace(case.instruments.camera, phases=6),
            probes={"web": ProbeOptions(kind="thermocouple", radius_mm=22.0)},
        ),
    )
    with pytest.raises(ParameterError, match="probe:rim"):
        FullModel(case, MPI.COMM_WORLD, quantities=("probe:rim",))
    q = ("camera_max", "probe:web", "torque_loss_Nm", "max_surface")
    full = FullModel(case, MPI.COMM_WORLD, quantities=q)
    res = full.evaluate(1000.0, 8.0, 21.0)
    assert 21.0 < res[("camera_max", None)] < res[("max_surface", None)]
    assert res[("mean_bulk", None)] - 5.0 < res[("probe:web", None)] < res[("max_surface", None)]
    # the meters read the friction law's power (here the cycle's constant mu: the cycle's
    # friction power) and the hysteresis at the steady state (a few per cent of it)
    cyc = full.cycle(8.0)
    omega = 2.0 * math.pi * 1000.0 / 60.0
    friction = float(np.mean(cyc.friction_power_W_per_rad_s)) * omega
    assert friction / omega <= res[("torque_loss_Nm", None)] <= 1.1 * friction / omega
    # the camera's prediction with the spread over its sub-pixel aims (the others have none)
    data = Dataset(
        tuple(
            Measurement(1000.0, 8.0, None, quantity, 100.0, 1.0, 21.0)
            for quantity in ("camera_max", "torque_loss_Nm")
        )
    )
    S, aim = full.predict_with_aim(data)
    assert S[0] == pytest.approx(res[("camera_max", None)], rel=1e-12)
    assert aim[0] > 0.0 and aim[1] == 0.0


@pytest.mark.mpi
def test_run_without_instruments_reads_nothing(tmp_path_factory):
    comm = MPI.COMM_WORLD
    base = Path(comm.bcast(str(tmp_path_factory.mktemp("bare")) if comm.rank == 0 else None))
    case = dataclasses.replace(
        _prescribed_run_case(),
        thermal=ThermalOptions(mode="steady", degree=1),
        instruments=InstrumentOptions(
            camera=CameraOptions(enabled=False), torque=TorqueMeterOptions(enabled=False)
        ),
    )
    summ = pipeline.run(case, base / "run", comm, progress=False)
    assert summ.instruments is None and summ.thermal_other is None
    assert summ.headline.camera_max_C is None
    assert summ.headline.max_surface_field_C is None  # no field recorded
    if comm.rank == 0:
        assert not (base / "run" / "instruments").exists()


def _one_face_body(T_of_xy, quadratic=True) -> BodyField:
    """A BodyField of one tetrahedron whose face z = 0 (vertices (1,0,0), (0,1,0), (0,0,0)) is a
    drive flank, with nodal temperatures T_of_xy(x, y) (K)."""
    v = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 0], [0, 0, 1.0]])
    edges = [(2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1)]  # basix order of the cell's edges
    nodes = np.vstack([v, [0.5 * (v[a] + v[b]) for a, b in edges]]) if quadratic else v
    face = [0, 1, 2, 6, 8, 9] if quadratic else [0, 1, 2]  # then the edges (1,2), (0,2), (0,1)
    return body_field(
        nodes,
        np.arange(len(nodes))[None, :],
        T_of_xy(nodes[:, 0], nodes[:, 1]),
        faces=np.array([face]),
        face_kind=np.array([KINDS.index("drive_flank")]),
    )


def test_hottest_point_is_the_fields_maximum_between_the_nodes():
    """A quadratic field is exact on a quadratic face: its maximum inside the face (at a lattice
    point) is found to round-off, where it is, and above the hottest node; on a linear face the
    field's maximum is the hottest node's."""

    def peak(x, y):
        return 400.0 - 50.0 * ((x - 4 / 12) ** 2 + (y - 3 / 12) ** 2)

    body = _one_face_body(peak)
    hottest, x = body.hottest_point(0)
    assert hottest == pytest.approx(400.0, abs=1e-12)
    np.testing.assert_allclose(x, [4 / 12, 3 / 12, 0.0], atol=1e-14)
    assert np.max(body.temperature_K) < 400.0 - 0.5  # the hottest node is 0.9 K below
    # off the lattice: within 50 K/m^2 x (half a lattice step)^2 x 2 of the peak
    off = _one_face_body(lambda x, y: 400.0 - 50.0 * ((x - 0.3) ** 2 + (y - 0.27) ** 2))
    assert off.hottest_point(0)[0] == pytest.approx(400.0, abs=2 * 50.0 * (0.5 / 12) ** 2)
    linear = _one_face_body(lambda x, y: 300.0 + x + 2 * y, quadratic=False)
    assert linear.hottest_point(0)[0] == pytest.approx(302.0, abs=1e-12)
    with pytest.raises(ParameterError, match="kinds"):
        body.hottest_point(0, kinds=("tip",))


@pytest.mark.slow
def test_one_tooth_periodic_sector_reads_like_the_whole_gear(tmp_path_factory):
    """The camera completes a sector model by copying its central pitch to every tooth; a
    one-tooth sector with periodic cut faces is its own central pitch (the clipping planes are
    its cut faces). With drive-flank heating (a field not mirror-symmetric about the cuts), its
    completed gear has the whole gear's area and the camera reads from it what it reads from the
    whole gear meshed alike."""
    comm = MPI.COMM_WORLD
    path = Path(comm.bcast(str(tmp_path_factory.mktemp("sector1")) if comm.rank == 0 else None))
    whole = dataclasses.replace(RING, teeth_in_model=30, refined_teeth=30, layers=2)
    one = dataclasses.replace(whole, teeth_in_model=1, refined_teeth=1, periodic_cuts=True)
    out = {}
    for name, mesh in (("whole", whole), ("one", one)):
        case = Case(
            name=name,
            mesh=mesh,
            sources=SourceOptions(
                mode="prescribed", flank_heat_per_gear_W=20.0, u_max_J_m3=0.0, flanks="drive"
            ),
            thermal=ThermalOptions(mode="steady", degree=1, ambient_C=23.0),
            instruments=InstrumentOptions(camera=CameraOptions()),
        )
        _, _, snap = pipeline.observed_thermal(case, path / name, comm, write_plot=False)
        if comm.rank == 0:
            field = snap.bodies["pinion"]
            reading = evaluate(case.instruments, snap).camera["end"]
            # the sector's own visible faces (cut faces excluded), times the copies
            cuts = np.isin(field.face_kind, [KINDS.index("cut_start"), KINDS.index("cut_end")])
            p = field.nodes_m[linear_triangles(field.faces[~cuts])]
            own = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
            copies = field.teeth / mesh.teeth_in_model
            out[name] = (
                reading.max_C,
                gear_surface(field).area_m2(),
                own.sum() * copies,
                field.temperature_K.max(),
            )
    if comm.rank == 0:
        (cam_w, area_w, own_w, tmax_w), (cam_1, area_1, own_1, tmax_1) = out["whole"], out["one"]
        assert tmax_w - 273.15 > 60.0  # a hot flank band was read
        # clipping at the cut faces neither loses nor doubles any of the tooth's surface
        assert area_1 == pytest.approx(own_1, rel=1e-12) and area_w == own_w
        # the two linear meshes' chords of the bore and outline differ by 0.1 %
        assert area_1 == pytest.approx(area_w, rel=2e-3)
        # measured: camera 85.08 against 84.99 C, hottest node 148.17 against 148.36 C (the two
        # coarse linear meshes; on this mesh adiabatic cuts differ as little, the thermal tests
        # tell the tie from them)
        assert abs(tmax_1 - tmax_w) < 0.5, (tmax_1, tmax_w)
        assert abs(cam_1 - cam_w) < 0.2, (cam_1, cam_w)
