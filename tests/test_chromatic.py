"""The eye's own longitudinal chromatic aberration (Thibos et al. 1992, "The chromatic eye",
Appl. Opt. 31:3594) in the eye model, the blur fields and both renderers."""

import math

import numpy as np
import pytest

from eyelab.blur.wavefront import compute_blur_field
from eyelab.core.constants import RAD_TO_ARCMIN
from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality, ReferenceQuality
from eyelab.optics.eye.thin import EYE_REFERENCE_NM, Eye, ocular_lca
from eyelab.optics.rays.camera import eye_camera
from eyelab.optics.rays.materials import RGB_WAVELENGTHS_NM
from eyelab.reference.tracer import ReferenceRenderer
from eyelab.render.raster import RasterRenderer
from eyelab.scene.library import grid_quad
from eyelab.scene.scene import Scene


def test_ocular_lca_has_the_published_size():
    """About 1 D between the F and C lines and about 2 D across 400-700 nm (Thibos et al.
    1992; docs/SCIENCE.md §9b); zero at the reference wavelength; the eye more myopic (more
    powerful) at short wavelengths."""
    assert float(ocular_lca(EYE_REFERENCE_NM)) == 0.0
    f_c = float(ocular_lca(486.13) - ocular_lca(656.27))
    assert -1.0 < f_c < -0.85
    assert float(ocular_lca(400.0) - ocular_lca(700.0)) == pytest.approx(-2.1, abs=0.05)
    assert Eye().power_shift(450.0) > 0 > Eye().power_shift(650.0)
    assert Eye(chromatic=False).power_shift(450.0) == 0.0


def test_per_channel_field_of_an_emmetrope_at_infinity():
    """The relaxed emmetrope's field: at each depth w and wavelength a circle of angular
    radius |power shift - 1/w| x pupil radius (the thin eye's defocus, Eq. 8), the shift
    being the channel's -LCA (zero at the reference wavelength)."""
    eye = Eye(accommodation_max=0.0, pupil_diameter=6e-3)
    cam = eye_camera(fov_y_deg=10.0, aspect=1.0, near=1.0, far=2000.0)
    for wl in (EYE_REFERENCE_NM,) + RGB_WAVELENGTHS_NM:
        f = compute_blur_field(eye, None, cam, shape=(16, 4, 4), wavelength_nm=wl)
        w = np.linalg.norm(f.sources[:, 1, 1], axis=-1)       # distance from the pupil
        want = np.abs(-float(ocular_lca(wl)) - 1.0 / w) * 3e-3 * RAD_TO_ARCMIN
        np.testing.assert_allclose(f.major_arcmin[:, 1, 1], want, rtol=2e-3, atol=1e-9)
        assert np.allclose(np.abs(f.a), np.abs(f.b))


def _point_at_infinity(distance=1000.0, size=1.0, texels=16, sigma=2.0):
    """A small white Gaussian blob (``sigma`` texels, about 0.7 px here) far away on black:
    a white point at infinity (its vergence, 1e-3 D, is 0.4 % of the smallest channel's
    chromatic defocus) whose light does not depend on where a displaced copy falls between
    pixel centres."""
    from eyelab.core.color import linear_to_srgb

    x = np.arange(texels) - (texels - 1) / 2
    g = np.exp(-0.5 * (x[:, None] ** 2 + x[None] ** 2) / sigma**2)
    tex = np.repeat(np.round(linear_to_srgb(g) * 255).astype(np.uint8)[..., None], 3, 2)
    quad = grid_quad("point", (0.0, 0.0, -distance), (1, 0, 0), (0, 1, 0), size, size,
                     nu=1, nv=1, texture=tex)
    return Scene([quad], background=(0, 0, 0), name="point")


def _radius_px(channel):
    """Radius (px) of a uniform disc with the channel's light spread: 2 sqrt of the mean of
    the two principal second moments."""
    w = channel / channel.sum()
    ys, xs = np.mgrid[: w.shape[0], : w.shape[1]]
    mx, my = (w * xs).sum(), (w * ys).sum()
    var = 0.5 * ((w * (xs - mx) ** 2).sum() + (w * (ys - my) ** 2).sum())
    return 2.0 * math.sqrt(var)


@pytest.mark.parametrize("renderer", ["raster", "reference"])
def test_white_point_at_infinity_has_r_and_b_blurs_of_the_chromatic_defocus(renderer):
    """An emmetrope (no accommodation needed) looking at a white point at infinity with a
    6 mm pupil: the R and B channels' blur discs have the radius the Thibos model's defocus
    gives, |R(lambda) - R(587.56 nm)| x pupil radius, within 5 % (the point's own size and
    the pixel subtracted as second moments)."""
    eye = Eye(accommodation_max=0.0, pupil_diameter=6e-3)
    w, fov = 160, 1.6
    # near 5 m: the field's last slice centre (the value it keeps to the far plane) is then
    # 0.003 D from infinity, 1 % of R's defocus
    view = View(width=w, height=w, fov_y_deg=fov, near=5.0, far=2000.0)
    scene = _point_at_infinity()
    if renderer == "raster":
        with RasterRenderer(RasterQuality(samples=64, field_shape=(32, 8, 8))) as r:
            lin = r.render(scene, eye, None, view).linear
            sharp = r.render(scene, Eye(accommodation_max=0.0, chromatic=False), None,
                             view).linear
    else:
        lin = ReferenceRenderer(ReferenceQuality(samples=256)).render(
            scene, eye, None, view).linear
        sharp = ReferenceRenderer(ReferenceQuality(samples=16)).render(
            scene, Eye(accommodation_max=0.0, chromatic=False), None, view).linear
    rad_per_px = 2 * math.tan(math.radians(fov / 2)) / w
    for c, wl in ((0, RGB_WAVELENGTHS_NM[0]), (2, RGB_WAVELENGTHS_NM[2])):
        want = abs(float(ocular_lca(wl))) * 3e-3 / rad_per_px
        own = _radius_px(sharp[..., c])
        got = 2.0 * math.sqrt(max(_radius_px(lin[..., c]) ** 2 - own**2, 0.0) / 4.0)
        assert got == pytest.approx(want, rel=0.05), (renderer, wl, got, want)
    # and the rendered point is white in total: each channel keeps its light
    totals = lin.reshape(-1, 3).sum(axis=0)
    assert totals / totals.mean() == pytest.approx(np.ones(3), rel=0.02)
