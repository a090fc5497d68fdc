"""Light adds in linear radiance: both renderers average linear light and encode once."""

from __future__ import annotations

import numpy as np
import pytest

from eyelab.core.color import linear_to_srgb, srgb_to_linear
from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality, ReferenceQuality
from eyelab.imaging.registry import make_renderer
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.render.accumulate import ENCODE16, PassAccumulator, check_tables, encode_linear
from eyelab.scene.library import grid_quad
from eyelab.scene.scene import Scene


def edge_scene(distance=1.0):
    """A black (left) / white (right) geometric edge through the view's centre: two
    uniformly coloured quads meeting at x = 0."""
    quads = [grid_quad(name, (x, 0.0, -distance), (1, 0, 0), (0, 1, 0), 0.2, 0.2, nu=4,
                       nv=4, colors=np.array([c, c, c], np.uint8))
             for name, x, c in (("black", -0.1, 0), ("white", 0.1, 255))]
    return Scene(quads, background=(0, 0, 0), name="edge")


@pytest.mark.parametrize("renderer, quality", [
    ("raster", RasterQuality(samples=64, refine=False)),
    ("reference", ReferenceQuality(samples=1024)),
])
def test_blurred_edge_is_half_way_in_linear_light(renderer, quality):
    """A sharp black/white edge blurred by a disc (a -4 D myope without accommodation at
    1 m: 3 D of defocus, ~6 px of blur radius): the pixel on the edge holds half the light,
    linear 0.5 = sRGB code 188 (averaging encoded values would give 128)."""
    eye = Eye.from_rx(Prescription(-4.0), accommodation_max=0.0, pupil_diameter=4e-3)
    view = View(width=65, height=41, fov_y_deg=2.5, near=0.2, far=5.0)
    with make_renderer(renderer, quality) as r:
        res = r.render(edge_scene(), eye, None, view)
    column = res.linear[:, 32].mean(axis=0)                 # the edge runs down column 32
    code = linear_to_srgb(column) * 255
    np.testing.assert_allclose(code, 188.0, atol=1.0)
    # and it is really blurred: the edge spans several pixels
    row = res.linear[20, :, 1]
    assert 0.05 < row[28] < 0.45 and 0.55 < row[36] < 0.95


def test_tables_round_trip_every_code():
    assert check_tables() < 0.03            # the 16-bit decode of each code, re-encoded
    np.testing.assert_array_equal(ENCODE16[np.round(srgb_to_linear(np.arange(256) / 255)
                                                    * 65535).astype(int)], np.arange(256))
    np.testing.assert_array_equal(encode_linear(srgb_to_linear(np.arange(256) / 255.0)),
                                  np.arange(256))


@pytest.mark.parametrize("samples", [2, 3, 7, 16, 64, 256])
def test_accumulated_mean_is_the_linear_average_to_half_a_code(samples):
    """Against the float64 average of the decoded passes, re-encoded: the accumulator's
    result is within 0.5 code value plus the 16-bit quantisation (0.05 code next to black),
    everywhere including the darkest codes; and it rounds the same way except within that
    margin of a rounding midpoint."""
    rng = np.random.default_rng(samples)
    passes = np.concatenate([rng.integers(0, 24, (samples, 16, 16, 4)),        # dark
                             rng.integers(0, 256, (samples, 16, 16, 4))], axis=1
                            ).astype(np.uint8)
    acc = PassAccumulator(32, 16)
    for p in passes:
        acc.add(p)
    exact = linear_to_srgb(srgb_to_linear(passes[..., :3] / 255.0).mean(axis=0)) * 255.0
    got = acc.mean()[::-1].astype(float)
    err = np.abs(got - exact)
    assert err.max() <= 0.5 + 0.05
    near_tie = np.abs(exact - np.floor(exact) - 0.5) < 0.05
    np.testing.assert_array_equal(got[~near_tie], np.round(exact[~near_tie]))
    lin = srgb_to_linear(passes[..., :3] / 255.0).mean(axis=0)
    np.testing.assert_allclose(acc.mean_linear()[::-1], lin, atol=1.0 / 65535)
    # rows a:b counted from the top: the passes are GL-ordered (row 0 at the bottom)
    top_first = lin[::-1]
    for a, b in ((0, 32), (3, 17), (31, 32), (0, 1)):
        np.testing.assert_allclose(acc.mean_linear(rows=(a, b)), top_first[a:b],
                                   atol=1.0 / 65535)


def test_one_pass_is_passed_through_exactly():
    rgba = np.random.default_rng(0).integers(0, 256, (8, 8, 4)).astype(np.uint8)
    acc = PassAccumulator(8, 8)
    acc.add(rgba)
    np.testing.assert_array_equal(acc.mean(), rgba[::-1, :, :3])
    lin = srgb_to_linear(rgba[::-1, :, :3] / 255.0)
    np.testing.assert_allclose(acc.mean_linear(rows=(2, 5)), lin[2:5], atol=1.0 / 65535)


def test_a_minified_texture_is_its_mean_light_without_aliasing():
    """A fine black/white checker texture seen far smaller than its texels (64 texels per
    pixel) renders, in one pass, at the texture's mean linear light (0.5, code 188) with
    little pixel-to-pixel variation: mip-maps built in linear light (point sampling would
    alias to a random black/white pattern; averaging codes would give 0.21)."""
    tex = np.zeros((512, 512, 3), np.uint8)
    tex[(np.arange(512)[:, None] + np.arange(512)[None]) % 2 == 1] = 255
    quad = grid_quad("fine", (0.0, 0.0, -1.0), (1, 0, 0), (0, 1, 0), 0.2, 0.2, nu=2, nv=2,
                     texture=tex)
    view = View(width=64, height=64, fov_y_deg=8.0, near=0.2, far=5.0)
    with make_renderer("raster", RasterQuality(samples=1)) as r:
        res = r.render(Scene([quad], background=(0, 0, 0)), Eye(accommodation_max=5.0),
                       None, view)
    inner = res.linear[16:-16, 16:-16, 1]
    assert inner.mean() == pytest.approx(0.5, abs=0.03)
    assert inner.std() < 0.05
