"""Cost follows the scene, quality kept: colour channels drawn apart only where they
differ (eyelab/render/channels.py), sub-rectangle renders equal to the whole view's pixels,
small blurs carried whole by the reconstruction filter (its 3-tap kernel checked against
an independent convolution), and the environment image's density from the lens's
magnification."""

import dataclasses

import numpy as np
import pytest
from scipy.ndimage import correlate

import eyelab.render.channels as channels
from eyelab.blur.reconstruct import TAP3_MAX_SIGMA, variable_gaussian
from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality
from eyelab.optics.camera import fit_virtual_camera, lens_view_density
from eyelab.optics.eye import Eye
from eyelab.optics.lens import SpectacleLens
from eyelab.optics.materials import Material
from eyelab.optics.prescription import Prescription
from eyelab.reference import compare_images
from eyelab.render.raster import RasterRenderer
from eyelab.scene.library import room_scene


@pytest.mark.parametrize("sigma", [0.26, 0.5, TAP3_MAX_SIGMA])
def test_three_tap_filter_is_the_separable_kernel_of_its_variance(sigma):
    """Where every sigma is at most TAP3_MAX_SIGMA, the filter is [w, 1-2w, w] per axis
    with w = sigma^2 / 2: equal to scipy's correlation with that 3 x 3 kernel (edges
    mirrored), and a point's spread has variance sigma^2 per axis and sums to 1."""
    rng = np.random.default_rng(4)
    img = rng.random((40, 50, 3)).astype(np.float32)
    w = sigma**2 / 2
    k1 = np.array([w, 1 - 2 * w, w])
    truth = correlate(img.astype(float), np.outer(k1, k1)[..., None], mode="nearest")
    out = variable_gaussian(img, np.full((40, 50), sigma, np.float32))
    np.testing.assert_allclose(out, truth, atol=2e-6)
    dot = np.zeros((21, 21, 1), np.float32)
    dot[10, 10] = 1.0
    spread = variable_gaussian(dot, np.full((21, 21), sigma, np.float32))[..., 0]
    x = np.arange(21) - 10
    assert spread.sum() == pytest.approx(1.0, abs=1e-6)
    assert (spread.sum(0) * x**2).sum() == pytest.approx(sigma**2, rel=1e-5)
    assert (spread.sum(1) * x**2).sum() == pytest.approx(sigma**2, rel=1e-5)


def test_per_channel_sigmas_filter_each_channel_by_its_own():
    """An (h, w, 3) sigma map filters each channel as that channel alone with its own map
    would be filtered, pixel by pixel: by the 3-tap kernel where every channel's sigma
    allows it, by blended levels where the channel's own sigma needs them (a small sigma
    beside a large one is blended too: another kernel of the same variance)."""
    rng = np.random.default_rng(5)
    img = rng.random((30, 36, 3)).astype(np.float32)
    sig = rng.uniform(0.0, 2.0, (30, 36, 3)).astype(np.float32)
    sig[:, :18] = np.minimum(sig[:, :18], TAP3_MAX_SIGMA)    # half of it the 3-tap's
    sig[5:9, 5:9] = 0.0
    out = variable_gaussian(img, sig)
    big = sig.max(-1) > TAP3_MAX_SIGMA
    for c in range(3):
        own = variable_gaussian(img[..., c:c + 1], sig[..., c])
        both = big & (sig[..., c] > TAP3_MAX_SIGMA)
        np.testing.assert_allclose(out[~big, c], own[~big, 0], atol=2e-6)
        np.testing.assert_allclose(out[both, c], own[both, 0], atol=2e-6)
    np.testing.assert_array_equal(out[5:9, 5:9], img[5:9, 5:9])


def test_a_rectangle_renders_what_the_whole_view_has_there():
    """OffscreenWindow.grab_rect_rgba draws only a rectangle, with the frustum's part and
    the tile uniform: its pixels equal the whole view's at the same seed and jitter
    (blur-field displacement and jitter included), on both field routes."""
    eye = Eye.from_rx(Prescription(-2.0), accommodation_max=1.0)
    view = View(width=160, height=120)
    for route in ("texture", "attribute"):
        with RasterRenderer(RasterQuality(samples=2, field_route=route)) as r:
            r.render(room_scene(), eye, None, view)
            win = r._eye_win
            win.set_seed((0.6, -0.3), (0.25, -0.4))
            whole = win.grab_rgba().copy()
            for rect in ((0, 0, 64, 32), (32, 40, 160, 96), (96, 64, 160, 120)):
                x0, y0, x1, y1 = rect
                part = win.grab_rect_rgba(rect)
                diff = np.abs(part.astype(int) - whole[y0:y1, x0:x1].astype(int))
                assert diff.max() <= 2, (route, rect, diff.max())
                assert (diff > 0).mean() < 0.01
            again = win.grab_rgba()
            np.testing.assert_array_equal(again, whole)       # the view was restored


@pytest.fixture(scope="module")
def room():
    return room_scene()


def test_channels_drawn_apart_only_where_they_differ(room, monkeypatch):
    """The default eye's emmetrope (chromatic: red and blue sub-pixel blurs carried by the
    filter) is drawn once per pass over most of the view; forcing every channel to be
    drawn apart everywhere (a negative tolerance) gives the same image to within what the
    tolerance allows: a residual sub-pixel displacement (<= CHANNEL_TOL_PX) drawn with
    the first channel's instead of a channel's own (measured at 320 x 240: SSIM 0.99976,
    PSNR 47.6 dB, mean 0.05 code values, 99.9 % of pixels within 13)."""
    eye = Eye.from_rx(Prescription(0.0), accommodation_max=5.0, pupil_diameter=4e-3)
    view = View(width=320, height=240)
    with RasterRenderer() as r:
        fast = r.render(room, eye, None, view)
    info = fast.report["details"]["channels"]["naked view"]
    assert info["area_fraction"] < 0.5
    assert any("colour channels" in s for s in fast.report["skipped"])
    monkeypatch.setattr(channels, "CHANNEL_TOL_PX", -1.0)
    with RasterRenderer() as r:
        full = r.render(room, eye, None, view)
    assert full.report["details"]["channels"]["naked view"]["area_fraction"] > 0.9
    d = np.abs(fast.image.astype(int) - full.image.astype(int))
    assert d.mean() < 0.1 and np.mean(d <= 13) > 0.998
    assert compare_images(fast.image, full.image)["ssim"] > 0.999


def test_channel_spread_is_the_blur_covariance_difference():
    """For round blurs of semi-axes a (channel) and a0 (first channel) the spread is
    sqrt|a^2 - a0^2| px, whatever the sign of either matrix (B and -B average alike)."""
    @dataclasses.dataclass
    class F:
        matrix: np.ndarray

    size = (200, 100)
    px = np.array([100.0, 50.0])
    a0, a1, a2 = 1.0, -2.0, 0.5                    # semi-axes in px, signs differing
    mats = [np.broadcast_to(np.diag(a / px), (1, 1, 1, 2, 2)).copy() for a in (a0, a1, a2)]
    spread = channels.channel_spread([F(m) for m in mats], size)
    assert spread["diff"][0, 0, 0] == pytest.approx(np.sqrt(4.0 - 1.0))
    assert spread["reach"][0, 0, 0] == pytest.approx(2.0)
    assert channels.channel_spread([F(mats[0])], size) is None


def test_environment_density_follows_the_lens():
    """Through an index-1 lens the virtual camera shares the eye's centre of projection:
    the density is exactly the pinhole ratio tan(eye) / (tan(virtual) W). A plus lens
    magnifies: its environment must be denser than a minus lens's."""
    from eyelab.imaging.contract import View as V

    view = V(width=400, height=300)
    cam = view.camera(np.zeros(3))
    air = SpectacleLens.from_rx(Prescription(-2.0), material=Material("air", 1.0, None))
    vc = fit_virtual_camera(air, cam).camera
    dens = lens_view_density(air, cam, vc, view.width)
    assert dens == pytest.approx(cam.tan_half[0] / (vc.tan_half[0] * view.width), rel=1e-6)
    per = {}
    for p in (-4.0, 4.0):
        lens = SpectacleLens.from_rx(Prescription(p))
        v2 = fit_virtual_camera(lens, cam).camera
        per[p] = lens_view_density(lens, cam, v2, view.width) * v2.tan_half[0] / cam.tan_half[0]
    assert per[4.0] > 1.1 * per[-4.0]
