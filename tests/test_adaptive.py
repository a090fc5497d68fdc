"""Cost follows the scene, quality kept: colour channels drawn apart only where they
differ (eyelab/render/channels.py), sub-rectangle renders equal to the whole view's pixels,
and the environment image's density from the lens's magnification."""

import dataclasses

import numpy as np
import pytest

import eyelab.render.channels as channels
from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import SpectacleLens
from eyelab.optics.rays.camera import fit_virtual_camera, lens_view_density
from eyelab.optics.rays.materials import Material
from eyelab.optics.rays.surfaces import Plane
from eyelab.reference import compare_images
from eyelab.render.raster import RasterRenderer
from eyelab.scene.library import room_scene


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
    """A chromatic emmetrope in a 320 x 240 view of the room (its red and blue blurs below
    half a pixel) is drawn once per pass; forcing every channel to be drawn apart
    everywhere (a negative tolerance) gives the same image to within what the tolerance
    allows: the channels' sub-pixel displacements drawn with the first channel's (measured:
    SSIM 0.9988 between the two, mean 0.22 code values; against 256-spp references at
    320 x 240 both score alike, e.g. the 6 m chart seen by an emmetropic presbyope 0.9949
    and 0.9949, the room 0.9961 and 0.9962)."""
    eye = Eye.from_rx(Prescription(0.0), accommodation_max=5.0, pupil_diameter=4e-3)
    view = View(width=320, height=240)
    with RasterRenderer() as r:
        fast = r.render(room, eye, None, view)
    info = fast.report["details"]["channels"]["naked view"]
    assert info["area_fraction"] == 0.0 and info["renders_per_pass"] == 1
    assert any("colour channels" in s for s in fast.report["skipped"])
    monkeypatch.setattr(channels, "CHANNEL_TOL_PX", -1.0)
    with RasterRenderer() as r:
        full = r.render(room, eye, None, view)
    assert full.report["details"]["channels"]["naked view"]["area_fraction"] > 0.9
    d = np.abs(fast.image.astype(int) - full.image.astype(int))
    assert d.mean() < 0.3
    assert compare_images(fast.image, full.image)["ssim"] > 0.998


def test_channel_spread_is_the_blur_covariance_difference():
    """For round blurs of semi-axes a (channel) and a0 (first channel) the spread is
    sqrt|a^2 - a0^2| px, whatever the sign of either matrix (B and -B average alike)."""
    @dataclasses.dataclass
    class F:
        matrix: np.ndarray

        def blur_matrix(self):             # a second-order field: its matrix
            return self.matrix

        def mean_offset(self):
            return np.zeros(self.matrix.shape[:-1])

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
    air = SpectacleLens(Plane(), Plane(), 0.002, Material("vacuum", 1.0))
    vc = fit_virtual_camera(air, cam).camera
    dens = lens_view_density(air, cam, vc, view.width)
    assert dens == pytest.approx(cam.tan_half[0] / (vc.tan_half[0] * view.width), rel=1e-6)
    per = {}
    for p in (-4.0, 4.0):
        lens = SpectacleLens.from_rx(Prescription(p))
        v2 = fit_virtual_camera(lens, cam).camera
        per[p] = lens_view_density(lens, cam, v2, view.width) * v2.tan_half[0] / cam.tan_half[0]
    inv_m = {p: v * view.width for p, v in per.items()}      # the smallest 1 / M
    assert inv_m[-4.0] > 1.0
    assert inv_m[4.0] < 1 / 1.05
