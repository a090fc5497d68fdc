"""The retinal image of a schematic eye at fixation: the raster's blur follows the eye's own
oblique astigmatism (traced, :mod:`eyelab.optics.chain.retina`), the thin eye's "each
point as the eye looks at it" shows none, and the raster agrees with the reference
renderer's rays from the curved retina."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality, ReferenceQuality
from eyelab.optics.chain.retina import trace_field
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.schematic import SchematicEye
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import SpectacleLens
from eyelab.reference.metrics import compare_images
from eyelab.reference.tracer import ReferenceRenderer
from eyelab.render.raster import RasterRenderer
from eyelab.scene.library import grid_quad
from eyelab.scene.scene import Scene

ANGLES = (0.0, 10.0, 20.0, 30.0)
DISTANCE = 10.0
W, H, HALF_X = 1800, 300, math.radians(36.0)
TAN_Y = math.tan(HALF_X) * H / W


def _dots() -> Scene:
    """25 mm white squares (3 px) 10 m away at 0, 10, 20 and 30 deg to the right, facing the eye."""
    quads = []
    for a in ANGLES:
        t = math.radians(a)
        d = np.array([math.sin(t), 0.0, -math.cos(t)])
        right = np.array([math.cos(t), 0.0, math.sin(t)])
        quads.append(grid_quad(f"dot{a:g}", d * DISTANCE, right, (0, 1, 0), 0.025, 0.025,
                               nu=1, nv=1, colors=np.array([255, 255, 255], np.uint8)))
    return Scene(quads, background=(0, 0, 0), name="dots")


def _view(focus) -> View:
    return View(width=W, height=H, fov_y_deg=2 * math.degrees(math.atan(TAN_Y)), near=1.0,
                far=20.0, focus_d=focus)


def _spreads(img) -> list:
    """(sigma_x, sigma_y) px of each dot's image in the green channel (546.07 nm; linear
    light, its window's moments: each channel has its own defocus, the eye's LCA)."""
    lum = img[..., 1]
    out = []
    for a in ANGLES:
        cx = (math.tan(math.radians(a)) / math.tan(HALF_X) + 1) * W / 2
        x0, x1 = int(cx - 60), int(cx + 60)
        win = lum[:, max(x0, 0):x1]
        ys, xs = np.mgrid[0:win.shape[0], 0:win.shape[1]]
        m = win.sum()
        mx, my = (win * xs).sum() / m, (win * ys).sum() / m
        out.append((math.sqrt((win * (xs - mx) ** 2).sum() / m),
                    math.sqrt((win * (ys - my) ** 2).sum() / m)))
    return out


def _render(eye, focus, samples=32):
    with RasterRenderer(RasterQuality(samples=samples, field_shape=(32, 24, 96))) as r:
        return r.render(_dots(), eye, None, _view(focus)).linear


def _truth(eye, lens, focus, wavelength_nm=546.07) -> list:
    """Per dot: ((sigma_x, sigma_y) px, centroid x, y relative to the chief ray's pixel) of
    its image by forward rays (:mod:`eyelab.reference.spots`), the dot's square and the
    pixel's box added to the spot's covariance (convolutions add covariances)."""
    from eyelab.reference.spots import point_spot

    view = _view(focus)
    out = []
    for a in ANGLES:
        t = math.radians(a)
        p = np.array([math.sin(t), 0.0, -math.cos(t)]) * DISTANCE
        sp = point_spot(eye, lens, view, p, focus, wavelength_nm)
        side_x = 0.025 / DISTANCE * W / 2 / math.tan(HALF_X) / math.cos(t)
        side_y = 0.025 / DISTANCE * H / 2 / TAN_Y / math.cos(t)
        sx = math.sqrt(sp["cov"][0, 0] + side_x**2 / 12 + 1 / 12)
        sy = math.sqrt(sp["cov"][1, 1] + side_y**2 / 12 + 1 / 12)
        out.append(((sx, sy), sp["centroid"] - sp["chief"]))
    return out


def _centroids(img) -> list:
    """Each dot's centroid (px) relative to its chief ray's pixel (the green channel)."""
    lum = img[..., 1]
    out = []
    for a in ANGLES:
        cx = (math.tan(math.radians(a)) / math.tan(HALF_X) + 1) * W / 2
        x0 = max(int(cx - 60), 0)
        win = lum[:, x0:int(cx + 60)]
        ys, xs = np.mgrid[0:win.shape[0], 0:win.shape[1]] + 0.5     # pixel centres
        m = win.sum()
        out.append(((win * xs).sum() / m + x0 - cx, (win * ys).sum() / m - H / 2))
    return out


@pytest.mark.parametrize("samples", [8, 32])
def test_the_blur_is_the_eyes_real_rays(samples):
    """A Navarro eye with a 6 mm pupil fixating straight ahead, accommodated 2 D short of
    the dots: oblique astigmatism, coma and spherical aberration shape each dot's blur. At
    0, 10, 20 and 30 deg the raster's widths (second moments, horizontal = tangential)
    are those of forward rays traced from the dot through the pupil
    (:mod:`eyelab.reference.spots`, a truth that does not find rays as the renderers do)
    within 5 % at 32 passes, 10 % at the default 8, and its centroid, which coma moves
    8 px inward at 30 deg, within 0.3 / 0.5 px. Before the ray-aberration fields the
    raster drew 6.7 x 1.8 px with the centroid on the chief ray there (11.1 x 4.2 px,
    -8.3 px)."""
    eye = SchematicEye(pupil_diameter=6e-3)
    acc = eye.accommodation_for(-1.0 / DISTANCE - 2.0)
    img = _render(eye, acc, samples)
    got, cen = _spreads(img), _centroids(img)
    tol, ctol = (0.05, 0.75) if samples >= 32 else (0.10, 0.75)
    for a, (sxy, c), (wx, wy), (cx, cy) in zip(ANGLES, _truth(eye, None, acc), got, cen,
                                               strict=True):
        assert wx == pytest.approx(sxy[0], rel=tol), (a, (wx, wy), sxy)
        assert wy == pytest.approx(sxy[1], rel=tol), (a, (wx, wy), sxy)
        assert abs(cx - c[0]) < ctol and abs(cy - c[1]) < ctol, (a, (cx, cy), c)
    assert got[3][0] / got[3][1] > 2.5     # at 30 deg: the tangential blur ~2.7x


def test_the_blur_follows_the_eyes_oblique_astigmatism():
    """With a 2 mm pupil (the higher orders small: ray aberrations of coma grow as r^2,
    of spherical aberration as r^3) and 4 D of defocus, the spreads at 10-30 deg are the
    eye's own traced tangential and sagittal refraction's, within 8 % (a uniform
    ellipse's sigma is half its semi-axis: r_EP |E| cos(angle) across, r_EP |E| along the
    meridian; the image through a 0.5 mm pupil, added in quadrature, holds the dot's size,
    the pixels and the passes' jitter)."""
    eye = SchematicEye(pupil_diameter=2e-3)
    acc = eye.accommodation_for(-1.0 / DISTANCE - 4.0)
    got = _spreads(_render(eye, acc))
    sharp = _spreads(_render(SchematicEye(pupil_diameter=0.5e-3), acc))
    tr = trace_field(eye, None, list(ANGLES), 0.0, DISTANCE, accommodation=acc,
                     wavelength_nm=546.07)
    r_ep = 1e-3
    for i, a in enumerate(ANGLES):
        t = math.radians(a)
        px_x = W / 2 / math.tan(HALF_X) / math.cos(t) ** 2
        px_y = H / 2 / TAN_Y / math.cos(t)
        pred_x = r_ep * abs(tr.tangential[i]) * math.cos(t) * px_x / 2
        pred_y = r_ep * abs(tr.sagittal[i]) * px_y / 2
        sx = math.hypot(pred_x, sharp[i][0])
        sy = math.hypot(pred_y, sharp[i][1])
        assert got[i][0] == pytest.approx(sx, rel=0.08), (a, got[i], sx, sy)
        assert got[i][1] == pytest.approx(sy, rel=0.08), (a, got[i], sx, sy)
    assert got[3][0] / got[3][1] > 1.5


def test_the_thin_eye_shows_no_oblique_astigmatism():
    """The thin eye images every line of sight as the fovea does: the same 2 D of defocus
    gives round, equal blurs at every angle (the rotating mode's view)."""
    eye = Eye(pupil_diameter=6e-3, chromatic=False)
    got = _spreads(_render(eye, eye.accommodation_for(-1.0 / DISTANCE) + 2.0))
    for sx, sy in got:
        # the pixels' angular size shrinks off axis: compare in angle
        assert sx > 3.0 and sy > 3.0
    angular = [(sx * math.cos(math.radians(a)) ** 2, sy * math.cos(math.radians(a)))
               for (sx, sy), a in zip(got, ANGLES, strict=True)]
    for ax, ay in angular:
        assert ax == pytest.approx(angular[0][0], rel=0.08)
        assert ay == pytest.approx(angular[0][1], rel=0.08)


@pytest.mark.parametrize("lens", [None, "-3.00"], ids=["uncorrected", "corrected"])
def test_raster_agrees_with_rays_from_the_retina(lens):
    """A -3 D schematic myope in the room scene, 60 deg: the raster's retinal image at
    fixation against the reference renderer's rays from the curved retina, SSIM >= 0.97
    (docs/bench/schematic.json: every quick-bench scene)."""
    from eyelab.scene.library import room_scene

    eye = SchematicEye.from_rx("-3.00", accommodation_max=1.0)
    ln = None if lens is None else SpectacleLens.from_rx(Prescription.parse(lens))
    view = View(width=160, height=120, fov_y_deg=60.0, near=0.05, far=20.0)
    scene = room_scene()
    with RasterRenderer(RasterQuality()) as r:
        a = r.render(scene, eye, ln, view)
    with ReferenceRenderer(ReferenceQuality(samples=32)) as r:
        b = r.render(scene, eye, ln, view)
    assert b.report["details"]["schematic_eye"]["accommodation_d"] == pytest.approx(
        a.report["details"]["schematic_eye"]["accommodation_d"], abs=1e-12)
    assert compare_images(a.srgb, b.srgb)["ssim"] >= 0.97


def test_the_guides_numbers_are_the_benchmarks():
    """docs/checking/optics-schematic-eye.md quotes docs/bench/schematic.json as it stands: the
    frame's cost, the quick scenes' SSIM, and the dots' tables (the default raster and the
    raster at eyelab.bench.dots.CONVERGED_SAMPLES passes) and the reference's agreement
    with forward rays (eyelab.bench.dots)."""
    import json
    from pathlib import Path

    from eyelab.bench.dots import dots_table, reference_agreement

    root = Path(__file__).resolve().parents[1]
    guide = " ".join((root / "docs" / "checking" / "optics-schematic-eye.md").read_text()
                     .split())
    bench = json.loads((root / "docs" / "bench" / "schematic.json").read_text())
    assert not bench["quick"]
    f = bench["frames"]
    truth = [r["raster_vs_truth"]["ssim"] for r in bench["errors"]]
    own = [r["reference_vs_truth"]["ssim"] for r in bench["errors"]]
    ref = reference_agreement(bench["dots"])
    for text in (f"{f['ratio_warm']:.2f}× the thin eye's warm ({f['ratio_cold']:.2f}× cold)",
                 f"{bench['truth_spp']}-spp reference is {min(truth):.3f}–{max(truth):.3f}",
                 f"{bench['reference_spp']} spp reach {min(own):.3f}–{max(own):.3f}",
                 f"renderer at {bench['dots_spp']} rays per pixel",
                 f"widths within {ref['width_pct']:.1f} %, centroids within "
                 f"{ref['centroid_px']:.2f} px", *dots_table(bench["dots"]),
                 *dots_table(bench["dots"], converged=True)):
        assert " ".join(text.split()) in guide, text
