"""Fresnel transmission through the lens, in both renderers (SCIENCE.md §9b)."""

from __future__ import annotations

import numpy as np
import pytest

from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality, ReferenceQuality
from eyelab.imaging.registry import make_renderer
from eyelab.optics.eye import Eye
from eyelab.optics.fresnel import AR_REFLECTANCE, reflectance, transmittance
from eyelab.optics.lens import SpectacleLens
from eyelab.optics.materials import Material
from eyelab.optics.surfaces import Plane
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
