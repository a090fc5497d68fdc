"""Gaze: the eye turns about its centre of rotation behind the head-fixed lens."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eyelab.blur import compute_blur_field
from eyelab.blur.field import VoxelStatus
from eyelab.core.color import linear_to_srgb
from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality, ReferenceQuality
from eyelab.imaging.registry import make_renderer
from eyelab.optics.chain.analysis import analyze_points
from eyelab.optics.chain.binocular import line_of_sight_prism
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import SpectacleLens
from eyelab.optics.rays.camera import eye_camera, gaze_camera
from eyelab.optics.rays.paths import ObjectPoints, find_chief_rays
from eyelab.optics.rays.trace import intersect
from eyelab.scene.library import grid_quad
from eyelab.scene.scene import Scene


def test_primary_gaze_is_the_eye_camera():
    assert gaze_camera((0.0, 0.0), 0.0135) == eye_camera()
    assert View().camera() == eye_camera(aspect=640 / 480)


@pytest.mark.parametrize("gaze", [(0.0, -30.0), (25.0, 10.0)])
def test_the_gazed_line_of_sight_field_is_analyze_rotating(gaze):
    """The naked eye turned by the gaze: the field's central column (the line of sight)
    holds, voxel by voxel, what ``analyze --fixation rotating`` computes for its wave
    sources (the eye turning about its centre of rotation to look at each of them):
    accommodation to 1e-9 D, ellipse semi-axes to 1e-12 m."""
    eye = Eye.from_rx(Prescription(-1.5, -1.0, 30), accommodation_max=1.0)
    cam = gaze_camera(gaze, eye.rotation_centre, fov_y_deg=20.0, aspect=1.0, near=0.2,
                      far=20.0)
    f = compute_blur_field(eye, None, cam, shape=(16, 3, 3), pupil=cam.position)
    ok = f.status[:, 1, 1] == VoxelStatus.OK
    src = f.sources[:, 1, 1][ok]
    np.testing.assert_allclose(np.cross(src - cam.position, cam.forward), 0.0, atol=1e-12)
    res = analyze_points(eye, None, ObjectPoints.from_positions(src), fixation="rotating")
    np.testing.assert_allclose(res.pupil, np.broadcast_to(cam.position, res.pupil.shape),
                               atol=1e-12)
    np.testing.assert_allclose(f.accommodation[:, 1, 1][ok], res.accommodation, atol=1e-9)
    np.testing.assert_allclose(f.a[:, 1, 1][ok], res.a, atol=1e-12)
    np.testing.assert_allclose(f.b[:, 1, 1][ok], res.b, atol=1e-12)


@pytest.mark.parametrize("renderer, quality", [
    ("raster", RasterQuality(samples=4)),
    ("reference", ReferenceQuality(samples=16)),
])
def test_looking_down_through_a_minus_lens_moves_the_image_by_prentice(renderer, quality):
    """Looking 30 deg down through a -6 D lens: a dot on the line of sight (2 m) is seen
    displaced (measured 8.03 prism dioptres in both renderers) by what the exact trace
    gives for its image — the angle at the turned pupil between the line of sight and the
    dot's chief ray, 8.01 prism dioptres — within 1 % (measured 0.3 %), and by Prentice's
    thin-lens c F for the point where the line of sight crosses the back surface (c = 1.37
    cm below the optical centre: 8.23 prism dioptres) within 5 % (measured 2.4 %). The
    lens's own prism on the line of sight (reverse-traced from the centre of rotation, 9.17
    prism dioptres) is larger than the image's displacement: the dot's chief ray crosses the
    back surface nearer the optical centre (1.26 cm) and less obliquely, where the lens
    deviates it by 8.09 prism dioptres."""
    eye = Eye(accommodation_max=10.0)
    lens = SpectacleLens.from_rx(Prescription(-6.0))
    gaze = (0.0, -30.0)
    cam = gaze_camera(gaze, eye.rotation_centre)
    fwd, pos = np.array(cam.forward), np.array(cam.position)
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    x = np.arange(16) - 7.5
    g = np.exp(-0.5 * (x[:, None] ** 2 + x[None] ** 2) / 4.0)
    tex = np.repeat(np.round(linear_to_srgb(g) * 255).astype(np.uint8)[..., None], 3, 2)
    dot = grid_quad("dot", pos + 2.0 * fwd, right, up, 0.02, 0.02, nu=1, nv=1, texture=tex)
    scene = Scene([dot], background=(0, 0, 0))
    view = View(width=200, height=200, fov_y_deg=20.0, near=0.05, far=10.0, gaze_deg=gaze)

    def centroid_y(img):
        w = img.sum(axis=2)
        return (w * np.arange(w.shape[0])[:, None]).sum() / w.sum()

    with make_renderer(renderer, quality) as r:
        naked = r.render(scene, eye, None, view).linear
        seen = r.render(scene, eye, lens, view).linear
    assert centroid_y(naked) == pytest.approx(99.5, abs=0.05)      # on the line of sight
    shift = abs(centroid_y(seen) - centroid_y(naked)) / (100 / math.tan(math.radians(10)))
    _, back = lens.placed_surfaces()
    c_cm = np.linalg.norm(intersect(back, pos[None], fwd[None]).points[0][:2]
                          - lens.pose.translation[:2]) * 100
    prentice = c_cm * 6.0 / 100                                    # tan of the deviation
    assert shift == pytest.approx(prentice, rel=0.05)
    # the exact image displacement: the dot's chief ray to the turned pupil (path finding)
    dot_centre = ObjectPoints.from_positions((pos + 2.0 * fwd)[None])
    chief = find_chief_rays(lens, pos, dot_centre, 587.56)
    seen_dir = -chief.dir_out[0]
    exact = math.tan(math.acos(float(np.clip(seen_dir @ fwd, -1.0, 1.0))))
    assert shift == pytest.approx(exact, rel=0.01)
    # ... smaller than the lens's prism on the line of sight itself
    los, _, ok = line_of_sight_prism(eye, lens, ObjectPoints(fwd[None], np.array([np.inf])))
    assert ok[0] and los[0] / 100 > 1.1 * shift
