import math

import numpy as np
import pytest

from eyelab.core.color import linear_to_srgb, srgb_to_linear
from eyelab.imaging.contract import View
from eyelab.imaging.options import ReferenceQuality
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import SpectacleLens
from eyelab.optics.rays.materials import Material
from eyelab.optics.rays.surfaces import Plane
from eyelab.reference import ReferenceRenderer, compare_images
from eyelab.reference.metrics import to_linear
from eyelab.scene.library import chart_scene, room_scene


def _ref(scene, eye, lens=None, **kw):
    """(uint8 image, the same in float sRGB values 0-255, the report's details)."""
    v = dict(width=48, height=36, fov_y_deg=20.0, near=0.1, far=20.0)
    q = dict(samples=16)
    for k, val in kw.items():
        (v if k in View.__dataclass_fields__ else q)[k] = val
    res = ReferenceRenderer(ReferenceQuality(**q)).render(scene, eye, lens, View(**v))
    return res.srgb, linear_to_srgb(res.linear.astype(float)) * 255.0, res.report["details"]


def test_converges_at_least_like_one_over_sqrt_spp():
    scene = chart_scene(1.0)
    eye = Eye.from_rx(Prescription(-2.0), accommodation_max=0.0)
    _, truth, _ = _ref(scene, eye, samples=4096)
    errs = []
    spps = (16, 64, 256)
    for spp in spps:
        e = [np.sqrt(np.mean((_ref(scene, eye, samples=spp, seed=k)[1] - truth) ** 2))
             for k in range(2)]
        errs.append(np.mean(e))
    slope = np.polyfit(np.log(spps), np.log(errs), 1)[0]
    assert slope < -0.45          # 1/sqrt(spp) is -0.5; stratified samples do better
    assert errs[-1] < errs[0]


def test_one_depth_no_lens_equals_convolution_with_the_blur_disc():
    """A chart at 0.5 m seen by a 4 D myope without accommodation: each point spreads into a
    uniform disc of angular radius r_p * dV (Eq. 8 with a circular pupil), dV in each colour
    channel shifted by the eye's own chromatic aberration (Thibos et al. 1992: the eye is
    0.26 D less powerful at 656 nm, 0.21 and 0.63 D more at 546 and 486 nm than at 587.56
    nm); the reference image must equal the sharp image convolved with each channel's
    disc, in linear light (compared in sRGB grey levels)."""
    from scipy.ndimage import convolve

    from eyelab.optics.eye.thin import ocular_lca
    from eyelab.optics.rays.materials import RGB_WAVELENGTHS_NM

    scene = chart_scene(0.5)
    w, h, fov = 96, 96, 8.0
    # the sharp image point-samples the texture: take it 3x finer and convolve there, so
    # that the comparison integrates the texture as the blurred rays do
    f = 3
    sharp = srgb_to_linear(_ref(scene, Eye(accommodation_max=10.0, chromatic=False),
                                width=f * w, height=f * h, fov_y_deg=fov, samples=3)[1]
                           / 255.0)
    eye = Eye.from_rx(Prescription(-4.0), vertex_distance=0.0, accommodation_max=0.0,
                      pupil_diameter=6e-3)
    blurred = _ref(scene, eye, width=w, height=h, fov_y_deg=fov, samples=1024)[1]
    conv = np.zeros((h, w, 3))
    radii = []
    for c, wl in enumerate(RGB_WAVELENGTHS_NM):
        # far point 0.25 m, object 0.5 m: 2 D, plus the channel's extra power -LCA
        dv = 4.0 - 2.0 - float(ocular_lca(wl))
        r_px = 3e-3 * dv * (h / 2) / math.tan(math.radians(fov / 2))
        radii.append(r_px)
        r_hi = f * r_px
        k = int(math.ceil(r_hi)) + 1
        yy, xx = np.mgrid[-k:k + 1, -k:k + 1]
        # area-weighted disc kernel (8x supersampled pixels)
        sub = (np.arange(8) + 0.5) / 8 - 0.5
        ker = np.zeros_like(xx, float)
        for dy in sub:
            for dx in sub:
                ker += (xx + dx) ** 2 + (yy + dy) ** 2 <= r_hi**2
        ker /= ker.sum()
        # fine pixel 3i+1 is coarse pixel i's
        conv[..., c] = convolve(sharp[..., c], ker, mode="nearest")[1::f, 1::f]
    conv = linear_to_srgb(conv) * 255.0
    m = int(math.ceil(max(radii))) + 1
    inner = (slice(m, -m), slice(m, -m))
    diff = np.abs(conv[inner] - blurred[inner])
    assert radii[0] > 3 and radii[2] > 1.4 * radii[0]     # R's disc is the smallest
    assert diff.mean() < 2.0           # grey levels, of 255
    assert np.percentile(diff, 99) < 12.0


def test_index_one_lens_changes_nothing_and_rays_are_counted():
    scene = room_scene()
    eye = Eye.from_rx(Prescription(-1.0), accommodation_max=0.5)
    nothing = SpectacleLens(Plane(), Plane(), 0.002, Material("vacuum", 1.0))
    a, fa, rep = _ref(scene, eye, None, samples=32, fov_y_deg=60.0)
    b, fb, rep2 = _ref(scene, eye, nothing, samples=32, fov_y_deg=60.0)
    # identical up to embree's float32 arithmetic: a ray that grazes an edge may pick the
    # other side when its origin moves to the lens (one pixel of 1728 here)
    d = np.abs(fa - fb)
    assert d.mean() < 0.05
    assert (d.max(axis=2) > 1.0).mean() <= 0.002
    # one chief ray per pixel, then 32 rays per pixel in each of R, G, B (the eye's own
    # chromatic aberration gives each channel its rays)
    assert rep["rays"] == 48 * 36 * (3 * 32 + 1)
    assert rep2["rays_per_s"] > 0


def test_fons_model_matches_the_thin_eye_for_spherical_errors():
    scene = chart_scene(1.0)
    eye = Eye.from_rx(Prescription(-2.0), accommodation_max=0.0)
    a = _ref(scene, eye, samples=256)[0]
    b = _ref(scene, eye, model="fons", fons_n=8, fons_m=16)[0]
    assert compare_images(b, a)["ssim"] > 0.97


def test_metrics_identity_and_ordering():
    rng = np.random.default_rng(0)
    img = rng.integers(0, 255, (40, 50, 3)).astype(np.uint8)
    m = compare_images(img, img)
    assert m["psnr_db"] == float("inf") and m["ssim"] == pytest.approx(1.0)
    assert m["blur_size_error"] == pytest.approx(0.0)
    from scipy.ndimage import uniform_filter

    soft = uniform_filter(img.astype(float), size=(3, 3, 1)).astype(np.uint8)
    assert compare_images(soft, img)["blur_size_error"] > 0.2
    assert to_linear(np.array([[[255, 0, 0]]], np.uint8))[0, 0, 0] == pytest.approx(1.0)


def test_fons_pattern_is_n_m_plus_one_points_on_m_diameters():
    """Fons et al. §3, Fig. 4: n radius subdivisions, m diameters at phase pi/m, n m + 1
    rays; every radius k/n once on every diameter (halves alternating), the centre once."""
    from eyelab.reference.tracer import fons_pattern

    n, m = 4, 8
    p = fons_pattern(n, m)
    assert p.shape == (n * m + 1, 2)
    np.testing.assert_array_equal(p[0], [0.0, 0.0])
    r = np.linalg.norm(p[1:], axis=1)
    np.testing.assert_allclose(np.sort(r), np.repeat(np.arange(1, n + 1) / n, m), atol=1e-12)
    ang = np.mod(np.arctan2(p[1:, 1], p[1:, 0]), math.pi)          # the diameter's direction
    steps = ang / (math.pi / m)
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    for j in range(m):                                            # each radius on each one
        on = np.isclose(np.round(steps) % m, j)
        np.testing.assert_allclose(np.sort(r[on]), np.arange(1, n + 1) / n)
    assert np.linalg.norm(p.mean(axis=0)) < 0.1                   # the halves alternate


def test_fons_focuses_the_lowest_error_meridian_not_the_mean():
    """An astigmatic hyperope (meridians +1 and +3 D) looking at 1 m: Fons et al.'s focus
    plane is the lower-error meridian's (accommodation 2 D: that meridian sharp, the other
    2 D off: a line), Kakimoto's Eq. 13 the mean's (3 D: both 1 D off: a circle). The
    rendered blob's spread shows it: elongated with "fons", round with "thin"."""
    from eyelab.reference.tracer import fons_accommodation

    eye = Eye.from_rx(Prescription(1.0, 2.0, 90), accommodation_max=5.0, vertex_distance=0.0,
                      pupil_diameter=4e-3, chromatic=False)     # one wavelength: the shapes
    assert float(fons_accommodation(eye, -1.0)) == pytest.approx(2.0, abs=1e-9)
    assert float(eye.accommodation_for(-1.0)) == pytest.approx(3.0, abs=1e-9)
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from test_raster import _moments, blob_scene

    from eyelab.scene.library import grid_quad
    from eyelab.scene.scene import Scene

    # a black backdrop just behind the blob: every pixel's chief ray meets the scene at
    # 1 m, so the per-pixel accommodation is the blob's everywhere
    backdrop = grid_quad("backdrop", (0.0, 0.0, -1.0005), (1, 0, 0), (0, 1, 0), 0.2, 0.2,
                         nu=1, nv=1, colors=np.array([0, 0, 0], np.uint8))
    scene = Scene(blob_scene(size=0.005).meshes + [backdrop], background=(0, 0, 0))
    ratios = {}
    for model in ("thin", "fons"):
        res = ReferenceRenderer(ReferenceQuality(samples=256, model=model, fons_n=8,
                                                 fons_m=16)).render(
            scene, eye, None, View(width=96, height=96, fov_y_deg=2.0, near=0.2, far=5.0))
        ev = np.linalg.eigvalsh(_moments(res.linear))
        ratios[model] = math.sqrt(ev[1] / ev[0])
    assert ratios["thin"] == pytest.approx(1.0, abs=0.05)
    assert ratios["fons"] > 2.0, ratios


def test_real_ray_accommodation_equals_eq13_where_the_thin_eye_is_exact():
    """Naked spherical eye: the accommodation from real rays' retinal spot (no blur-field
    machinery) is Eq. 13's, so the images agree (SSIM >= 0.999; measured identical)."""
    scene = room_scene()
    eye = Eye.from_rx(Prescription(-2.0), accommodation_max=3.0)
    view = dict(width=64, height=48, fov_y_deg=40.0, near=0.05, far=20.0)
    a = _ref(scene, eye, None, samples=16, **view)
    b = _ref(scene, eye, None, samples=16, accommodation="rms", **view)
    assert compare_images(a[0], b[0])["ssim"] >= 0.999
    assert b[2]["accommodation_rms_vs_eq13_d"]["max_abs"] < 1e-6


def test_real_ray_accommodation_through_a_strong_toric_lens_is_reported():
    """Through -6.00 / -4.00 x 30 at up to 20 deg off axis the two rules differ by hundredths
    of a dioptre (measured mean 0.012 D, max 0.052 D at 96x72): reported, and small."""
    scene = room_scene()
    rx = Prescription(-6.0, -4.0, 30)
    eye = Eye.from_rx(rx, accommodation_max=2.0)
    lens = SpectacleLens.from_rx(rx)
    b = _ref(scene, eye, lens, samples=4, accommodation="rms", width=32, height=24,
             fov_y_deg=40.0, near=0.05, far=20.0)
    d = b[2]["accommodation_rms_vs_eq13_d"]
    assert d["pixels"] > 100
    assert 0.0 < d["mean_abs"] < 0.05 and d["max_abs"] < 0.2


def test_the_fons_pattern_reading_changes_the_mean_not_the_spread():
    """The paper's pattern is ambiguous (n subdivisions of the radius on m diameters, but
    n m + 1 rays). eyelab's reading puts each radius on one half of each diameter; the other
    reading (both halves, 2 n m + 1 rays) has the same second moments — the blur's size
    and shape — and differs only in a small mean offset of the bundle."""
    from eyelab.reference.tracer import fons_pattern

    n, m = 4, 8
    ours = fons_pattern(n, m)
    both = np.vstack([ours, -ours[1:]])              # every point on both halves
    assert len(both) == 2 * n * m + 1
    cov = lambda p: p.T @ p / len(p)                 # noqa: E731 (about the centre)
    np.testing.assert_allclose(cov(ours[1:]), cov(both[1:]), atol=1e-12)
    np.testing.assert_allclose(both.mean(axis=0), 0.0, atol=1e-12)
    assert 0.0 < np.linalg.norm(ours.mean(axis=0)) < 0.1


def _dot_light(dist, renderer, n=65, fov=1.0):
    """The light (linear, green, summed over the image) of a white square exactly one pixel
    wide at ``dist`` m, centred, against a black background at infinity, seen by a
    relaxed emmetrope with a 4 mm pupil: 1.0 where light is conserved."""
    from eyelab.scene.library import grid_quad
    from eyelab.scene.scene import Scene

    side = 2 * math.tan(math.radians(fov / 2)) / n * dist
    dot = grid_quad("dot", (0.0, 0.0, -dist), (1, 0, 0), (0, 1, 0), side, side, nu=1, nv=1,
                    colors=np.array([255, 255, 255], np.uint8))
    eye = Eye(pupil_diameter=4e-3, chromatic=False)
    res = renderer.render(Scene([dot], background=(0, 0, 0)), eye, None,
                          View(width=n, height=n, fov_y_deg=fov, near=0.1, far=2 * dist))
    return float(res.linear[..., 1].sum())


def test_the_reference_gathers_each_pixel_in_its_own_focus_and_so_adds_light_at_depth_edges():
    """The documented rule: each reference pixel focuses on its own surface (Eq. 13 per
    pixel), so at a depth edge light is not conserved. A one-pixel dot at 50 m before a
    background at infinity (0.92' pixels) comes out 1.13x as bright: the dot's pixel
    gathers all its light, and its neighbours, focused at infinity, gather some of it
    again through their 0.28' blur (0.02 D over 4 mm); at 1000 m the excess is gone. The
    raster renderer scatters each point's light with its own blur, and conserves it."""
    from eyelab.imaging.options import RasterQuality
    from eyelab.render.raster import RasterRenderer

    ref = ReferenceRenderer(ReferenceQuality(samples=256))
    near, far = _dot_light(50.0, ref), _dot_light(1000.0, ref)
    assert 1.08 < near < 1.2, near
    assert far == pytest.approx(1.0, abs=0.01)
    with RasterRenderer(RasterQuality(samples=16)) as r:
        assert _dot_light(50.0, r) == pytest.approx(1.0, abs=0.005)
