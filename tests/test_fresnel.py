"""Fresnel transmission through the lens, in both renderers (docs/SCIENCE.md §9b)."""

from __future__ import annotations

import numpy as np
import pytest

from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality, ReferenceQuality
from eyelab.imaging.registry import make_renderer
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import SpectacleLens
from eyelab.optics.rays.fresnel import AR_REFLECTANCE, reflectance, transmittance
from eyelab.optics.rays.materials import Material
from eyelab.optics.rays.surfaces import Plane
from eyelab.scene.library import grid_quad
from eyelab.scene.scene import Scene


def test_normal_incidence_and_brewster_angle():
    """Textbook values: R = ((n - 1)/(n + 1))^2 at normal incidence; at Brewster's angle
    (tan i = n) the p wave is fully transmitted, so R = r_s^2 / 2."""
    n = 1.5
    assert reflectance(1.0, 1.0, 1.0, n) == pytest.approx(0.04)
    i = np.arctan(n)
    t = np.arcsin(np.sin(i) / n)
    rs = (np.cos(i) - n * np.cos(t)) / (np.cos(i) + n * np.cos(t))
    assert reflectance(np.cos(i), np.cos(t), 1.0, n) == pytest.approx(rs**2 / 2)
    assert i + t == pytest.approx(np.pi / 2)                  # Brewster: i + t = 90 deg
    # reciprocity: glass -> air transmits as air -> glass
    assert transmittance(np.cos(t), np.cos(i), n, 1.0) == pytest.approx(
        transmittance(np.cos(i), np.cos(t), 1.0, n))


def test_lens_trace_reports_the_two_surfaces():
    lens = SpectacleLens(Plane(), Plane(), 0.002, Material("glass", 1.5))
    d = np.array([[0.0, 0.0, -1.0], [0.0, np.sin(0.5), -np.cos(0.5)]])
    res = lens.trace(np.zeros((2, 3)), d, reverse=True)
    assert res["transmittance"][0] == pytest.approx(0.9216)
    assert 0.8 < res["transmittance"][1] < 0.9216             # more reflected obliquely
    coated = SpectacleLens(Plane(), Plane(), 0.002, Material("glass", 1.5), coating="ar")
    t = coated.trace(np.zeros((2, 3)), d, reverse=True)["transmittance"]
    assert t[0] == pytest.approx((1 - AR_REFLECTANCE) ** 2)


@pytest.mark.parametrize("renderer, quality", [
    ("raster", RasterQuality(samples=1)),
    ("reference", ReferenceQuality(samples=4)),
])
@pytest.mark.parametrize("coating, expected", [("none", 0.9216),
                                               ("ar", (1 - AR_REFLECTANCE) ** 2)])
def test_uncoated_plate_transmits_the_fresnel_fraction(renderer, quality, coating, expected):
    """Through an n = 1.5 plane plate at (near) normal incidence the image is (1 - R)^2 =
    0.9216 of the naked level (+- 0.003), in linear light; 0.990 with the AR coating. (A
    grey ramp, so that the 8-bit output's rounding averages out over the image.)"""
    ramp = np.repeat(np.repeat(np.arange(40, 256, dtype=np.uint8)[None, :, None], 8, 0), 3, 2)
    wall = grid_quad("wall", (0.0, 0.0, -2.0), (1, 0, 0), (0, 1, 0), 0.4, 0.4, nu=2, nv=2,
                     texture=ramp)
    scene = Scene([wall], background=(180, 180, 180), name="wall")
    plate = SpectacleLens(Plane(), Plane(), 0.002, Material("glass", 1.5), coating=coating)
    view = View(width=48, height=36, fov_y_deg=10.0, near=0.2, far=10.0)
    eye = Eye(accommodation_max=5.0)
    with make_renderer(renderer, quality) as r:
        naked = r.render(scene, eye, None, view).linear
        seen = r.render(scene, eye, plate, view).linear
    inner = (slice(4, -4), slice(4, -4))
    ratio = seen[inner].mean() / naked[inner].mean()
    print(renderer, coating, ratio)
    assert ratio == pytest.approx(expected, abs=0.003)


def _plate_exact(theta, n):
    """Transmission of unpolarised light through a plane-parallel plate of index ``n`` at
    incidence ``theta`` (rad), written directly from Fresnel's amplitude coefficients: the
    s and p waves each pass both surfaces (the same angles at both, by symmetry), and the
    unpolarised result is the mean of the two polarisations' products."""
    ci = np.cos(theta)
    ct = np.sqrt(1.0 - (np.sin(theta) / n) ** 2)
    ts = 2 * ci / (ci + n * ct)                    # air -> glass amplitude, s
    tp = 2 * ci / (n * ci + ct)                    # air -> glass amplitude, p
    ts2 = 2 * n * ct / (n * ct + ci)               # glass -> air, s
    tp2 = 2 * n * ct / (ct + n * ci)               # glass -> air, p
    # intensity: |t|^2 times the ratio of (n cos) on the two sides; they cancel over a plate
    big_ts = (ts * ts2) ** 2
    big_tp = (tp * tp2) ** 2
    return 0.5 * (big_ts + big_tp)


@pytest.mark.parametrize("deg", [0.0, 30.0, 60.0])
def test_plate_tracks_s_and_p_through_both_surfaces(deg):
    """Through an n = 1.5 plate the two surfaces' s and p parts multiply separately:
    the exact transmission to 1e-6 (multiplying the unpolarised per-surface factors is
    0.00026 low at 30 deg and 0.0076 at 60 deg)."""
    plate = SpectacleLens(Plane(), Plane(), 0.002, Material("glass", 1.5))
    th = np.radians(deg)
    for azimuth in (0.0, 0.7):                 # the plane of incidence turned about z
        d = np.array([[np.sin(th) * np.cos(azimuth), np.sin(th) * np.sin(azimuth),
                       -np.cos(th)]])
        t = plate.trace(np.zeros((1, 3)), d, reverse=True)["transmittance"][0]
        assert t == pytest.approx(_plate_exact(th, 1.5), abs=1e-6)
    # the raster's per-vertex rays (what its transmittance map is made of) and a camera
    # lens system's rays (both camera renderers) carry the same value; the reference
    # tracer weights its rays by the lens trace above
    from eyelab.optics.cameralens.system import LensSystem, SystemSurface
    from eyelab.optics.rays.camera import eye_camera
    from eyelab.scene.pervertex import lens_texcoords
    from eyelab.scene.raycast import EmbreeIntersector

    wall = grid_quad("wall", (0.0, 0.0, -2.0), (1, 0, 0), (0, 1, 0), 9.0, 9.0)
    point = np.array([[0.0, 0.012 * np.tan(th), -0.012]])   # on the plate, seen at theta
    tc = lens_texcoords(SpectacleLens(Plane(), Plane(), 0.002, Material("glass", 1.5)),
                        point, eye_camera(), EmbreeIntersector(Scene([wall])))
    assert tc.transmittance[0, 0] == pytest.approx(_plate_exact(th, 1.5), abs=1e-6)
    glass = Material("glass", 1.5)
    plate_system = LensSystem((SystemSurface(Plane(), 0.0, glass, 0.5),
                               SystemSurface(Plane(), 0.002, Material("air", 1.0), 0.5)),
                              stop_z=-1e-3, stop_radius=0.5, film_z=0.01)
    d = np.array([[0.0, np.sin(th), -np.cos(th)]])
    t = plate_system.trace_reverse(np.array([[0.0, 0.0, 0.01]]), d)["transmittance"][0]
    assert t == pytest.approx(_plate_exact(th, 1.5), abs=1e-6)


def test_crossed_planes_of_incidence_mix_s_and_p():
    """Two tilted surfaces whose planes of incidence are crossed at 90 deg: the first
    surface's s light is the second's p light, so the transmission is (T_s1 T_p2 +
    T_p1 T_s2) / 2, not (T_s1 T_s2 + T_p1 T_p2) / 2 — the frame rotation between surfaces
    is what gets this right."""
    from eyelab.optics.rays.fresnel import PolarisedTransmission, reflectances

    n1, n2, n3 = 1.0, 1.5, 1.0
    d = np.array([[0.0, 0.0, -1.0]])
    th1, th2 = np.radians(50.0), np.radians(40.0)
    # surface 1 tilted about x (plane of incidence y-z), surface 2 about y (x-z), both
    # as seen by the same straight ray (the refraction's bend is irrelevant to the check)
    nrm1 = np.array([[0.0, np.sin(th1), np.cos(th1)]])
    nrm2 = np.array([[np.sin(th2), 0.0, np.cos(th2)]])
    pt = PolarisedTransmission(1)
    ct1 = np.sqrt(1 - (np.sin(th1) * n1 / n2) ** 2)
    pt.surface(d, nrm1, np.cos(th1), ct1, n1, n2)
    ct2 = np.sqrt(1 - (np.sin(th2) * n2 / n3) ** 2)
    pt.surface(d, nrm2, np.cos(th2), ct2, n2, n3)
    rs1, rp1 = reflectances(np.cos(th1), ct1, n1, n2)
    rs2, rp2 = reflectances(np.cos(th2), ct2, n2, n3)
    want = 0.5 * ((1 - rs1) * (1 - rp2) + (1 - rp1) * (1 - rs2))
    assert pt.transmittance[0] == pytest.approx(float(want[()]), abs=1e-12)
