"""The renderer interface: one call shape and one result type for every renderer,
validated options, content-keyed bounded caches, no leaks."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from eyelab.core.color import decode_srgb, encode_srgb
from eyelab.core.errors import SpecError
from eyelab.imaging.contract import REPORT_KEYS, RenderResult, View
from eyelab.imaging.options import ImageBasedQuality, RasterQuality, ReferenceQuality
from eyelab.imaging.registry import QUALITIES, make_renderer
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import SpectacleLens
from eyelab.reference import compare_images
from eyelab.render.raster import CACHE_SIZES, RasterRenderer
from eyelab.scene.library import chart_scene, grid_quad
from eyelab.scene.scene import Scene

QUICK = {"raster": RasterQuality(samples=32, reconstruct=True),
         "reference": ReferenceQuality(samples=256),
         "imagebased": ImageBasedQuality(samples=32, angle_threshold_deg=0.1)}


@pytest.fixture(scope="module")
def chart():
    return chart_scene(1.0)


@pytest.fixture(scope="module")
def both(chart):
    """Every renderer through the same call: the chart at 1 m seen by a -3 D myope (1 D of
    accommodation) uncorrected (2 D of blur, ~3 px) and through a -3 D lens (sharp)."""
    eye = Eye.from_rx(Prescription(-3.0), accommodation_max=1.0)
    lens = SpectacleLens.from_rx(Prescription(-3.0))
    view = View(width=96, height=72, fov_y_deg=6.0, near=0.1, far=20.0)
    out = {}
    for name in ("raster", "reference", "imagebased"):
        with make_renderer(name, QUICK[name]) as r:
            out[name] = {"naked": r.render(chart, eye, None, view),
                         "lens": r.render(chart, eye, lens, view)}
    return out


def test_every_renderer_returns_the_same_type_and_report_schema(both):
    for name, results in both.items():
        for res in results.values():
            assert isinstance(res, RenderResult)
            assert tuple(res.report) == REPORT_KEYS
            assert res.report["renderer"] == name
            assert res.linear.dtype == np.float32 and res.linear.shape == (72, 96, 3)
            assert res.srgb.dtype == np.uint8 and res.srgb.shape == (72, 96, 3)
            np.testing.assert_array_equal(res.srgb, encode_srgb(res.linear))
            assert res.report["samples"]["target"] > 0
            assert res.report["timings_s"]["total"] > 0
            assert set(res.report["cache"]) == {"hits", "misses"}


def test_raster_agrees_with_the_reference_through_the_interface(both):
    """Naked (blurred by 2 D) and corrected by the lens: raster S = 32 vs reference 256.
    Measured on the ETDRS chart (whose smallest rows are 4-px letters here): SSIM 0.945
    blurred (0.952 at S = 128: both images' sampling noise), 0.98 corrected."""
    for name in ("raster", "imagebased"):
        for case, floor in (("naked", 0.94), ("lens", 0.95)):
            m = compare_images(both[name][case].srgb, both["reference"][case].srgb)
            assert m["ssim"] > floor, (name, case, m)
    # the lens corrects: the corrected views are much sharper than the naked ones
    for name in both:
        sharp = compare_images(both[name]["lens"].srgb, both[name]["naked"].srgb)
        assert sharp["blur_size_error"] < -0.3, (name, sharp)


def test_encode_decode_are_exact_inverses_on_every_code():
    codes = np.arange(256, dtype=np.uint8).reshape(1, -1, 1).repeat(3, axis=2)
    np.testing.assert_array_equal(encode_srgb(decode_srgb(codes)), codes)


def test_encode_srgb_rounds_the_standard_curve():
    """encode_srgb (a search among the codes' edges) gives the code of rounding IEC
    61966-2-1's curve, 1.055 c^(1/2.4) - 0.055 (12.92 c below 0.0031308), written out here:
    on a dense sweep and within 2,000 float32 steps of every edge, float32 and float64;
    out-of-range values clip, NaN gives 0."""
    def curve(c):
        c = np.clip(c.astype(np.float64), 0.0, 1.0)
        s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.abs(c) ** (1 / 2.4) - 0.055)
        return np.round(s * 255.0).astype(np.uint8)

    k = (np.arange(1, 256) - 0.5) / 255.0
    edges = np.where(k <= 0.04045, k / 12.92, ((k + 0.055) / 1.055) ** 2.4).astype(np.float32)
    near = (edges.view(np.int32)[:, None] + np.arange(-2000, 2000)).view(np.float32)
    x = np.concatenate([near.ravel(), np.linspace(-0.1, 1.1, 1_000_001, dtype=np.float32)])
    for xs in (x, x.astype(np.float64)):
        np.testing.assert_array_equal(encode_srgb(xs), curve(xs))
    assert encode_srgb(np.array([np.nan, -np.inf, np.inf])).tolist() == [0, 0, 255]


@pytest.mark.parametrize("cls, kwargs, field", [
    (View, {"width": 8}, "render.width"),
    (View, {"width": True}, "render.width"),
    (View, {"far": 0.01, "near": 0.05}, "render.far_m"),
    (View, {"focus_d": -1}, "eye.accommodation_d"),
    (View, {"cvd": "red"}, "render.cvd"),
    (View, {"width": 4096, "height": 16}, "render.width"),
    (RasterQuality, {"samples": 0}, "render.samples"),
    (RasterQuality, {"samples": 2.5}, "render.samples"),
    (RasterQuality, {"field_shape": (1.5, 8, 8)}, "render.field_shape[0]"),
    (RasterQuality, {"depth_mode": "log"}, "render.depth_mode"),
    (RasterQuality, {"reconstruct": 1}, "render.reconstruct"),
    (RasterQuality, {"rim_color": (0, 0, 300)}, "render.rim_color[2]"),
    (ReferenceQuality, {"samples": 70000}, "render.samples"),
    (ReferenceQuality, {"model": "kakimoto"}, "render.model"),
    (ReferenceQuality, {"workers": 0}, "render.workers"),
])
def test_options_name_the_field_in_every_error(cls, kwargs, field):
    with pytest.raises(SpecError) as e:
        cls(**kwargs)
    assert e.value.field == field


def test_a_renderer_refuses_another_renderers_options(chart):
    with pytest.raises(TypeError):
        RasterRenderer(ReferenceQuality())
    with RasterRenderer() as r, pytest.raises(TypeError):
        r.render(chart, Eye(), None, View(width=32, height=24), ReferenceQuality())


def test_every_option_is_reachable_from_a_spec():
    from eyelab.spec import parse_render, renderer_keys

    for name, cls in QUALITIES.items():
        keys = set(renderer_keys(name))
        for f in (x.name for x in dataclasses.fields(cls)):
            assert f in keys or f == "progress", (name, f)
    rs = parse_render({"renderer": "raster", "depth_mode": "linear", "field_shape": [16, 8, 8],
                       "skip_unneeded": False, "reconstruct": True})
    assert rs.quality.depth_mode == "linear" and rs.quality.field_shape == (16, 8, 8)
    assert not rs.quality.skip_unneeded
    with pytest.raises(SpecError) as e:
        parse_render({"renderer": "raster", "model": "fons"})
    assert e.value.field == "render.model" and "reference" in e.value.message
    ref = rs.with_changes(renderer="reference", samples=8)
    assert isinstance(ref.quality, ReferenceQuality) and ref.quality.samples == 8


def test_depth_mode_reaches_the_shader():
    """The linear depth slicing (reachable from the spec) renders a dot's blur like the NDC
    slicing does (the field is sampled at the same voxel centres either way)."""
    from eyelab.scene.library import dot_scene

    eye = Eye.from_rx(Prescription(-4.0), accommodation_max=0.0,    # 3 D: ~5 px radius
                      chromatic=False)
    view = View(width=64, height=64, fov_y_deg=4.0, near=0.2, far=5.0)
    imgs = {}
    for mode in ("ndc", "linear"):
        with RasterRenderer(RasterQuality(samples=16, depth_mode=mode,
                                          field_shape=(64, 8, 8))) as r:
            res = r.render(dot_scene(1.0, 0.002), eye, None, view)
            imgs[mode] = res.linear.sum(axis=2)
            (key,) = r.caches["fields"].keys()
            assert r.caches["fields"].get(key).depth_mode == mode
    spread = {m: (im > 0.01).sum() for m, im in imgs.items()}
    assert spread["ndc"] > 50
    assert abs(spread["linear"] - spread["ndc"]) < 0.2 * spread["ndc"]


def _quad(x):
    img = np.zeros((8, 8, 3), np.uint8)
    img[:, 4:] = 255
    return grid_quad("edge", (x, 0.0, -1.0), (1, 0, 0), (0, 1, 0), 0.4, 0.4, nu=2, nv=2,
                     texture=img)


def test_caches_are_keyed_by_content_not_identity():
    """A mesh moved (new vertices) is re-traced; an equal mesh in a new object hits."""
    lens = SpectacleLens.from_rx(Prescription(-1.0))
    eye = Eye(accommodation_max=5.0)
    view = View(width=48, height=36, fov_y_deg=40.0, near=0.1, far=10.0)
    with RasterRenderer(RasterQuality(samples=1, refine=False)) as r:
        a = r.render(Scene([_quad(0.0)]), eye, lens, view)
        assert "lens_texcoords" in a.report["cache"]["misses"]
        again = r.render(Scene([_quad(0.0)]), eye, lens, view)     # new objects, same content
        assert "lens_texcoords" in again.report["cache"]["hits"]
        np.testing.assert_array_equal(again.srgb, a.srgb)
        moved = Scene([_quad(0.0)])
        moved.meshes[0].vertices = moved.meshes[0].vertices + [0.05, 0.0, 0.0]
        b = r.render(moved, eye, lens, view)
        assert "lens_texcoords" in b.report["cache"]["misses"]
        assert np.abs(b.linear - a.linear).max() > 0.5


def test_mesh_arrays_cannot_change_behind_a_cache():
    m = _quad(0.0)
    with pytest.raises(ValueError):
        m.vertices[0, 0] = 1.0
    key = m.content_key
    m.vertices = m.vertices * 2
    assert m.content_key != key


def test_caches_stay_bounded_with_a_new_eye_each_frame(chart):
    lens = SpectacleLens.from_rx(Prescription(-1.0))
    view = View(width=32, height=24)
    with RasterRenderer(RasterQuality(samples=1, field_shape=(8, 4, 4))) as r:
        for i in range(CACHE_SIZES["fields"] + 6):
            r.render(chart, Eye(accommodation_max=0.1 * i), lens, view)
        sizes = {k: len(c) for k, c in r.caches.items()}
        assert all(sizes[k] <= CACHE_SIZES[k] for k in sizes)
        assert sizes["fields"] == CACHE_SIZES["fields"]
    assert all(len(c) == 0 for c in r.caches.values())        # close() empties them


def test_lru_cache_counters_are_thread_safe():
    from concurrent.futures import ThreadPoolExecutor

    from eyelab.core.cache import LRUCache

    c = LRUCache(4)
    with ThreadPoolExecutor(4) as ex:
        list(ex.map(lambda i: c.get_or_create(i % 8, lambda: i), range(4000)))
    assert c.hits + c.misses == 4000 and len(c) <= 4


@pytest.mark.slow
def test_no_leak_new_renderer_each_render_and_new_eye_each_render():
    """The acceptance figures: 200 renders through a lens with a new renderer each, and 500
    with one renderer and a new eye each, grow RSS by < 50 MB each."""
    from eyelab.bench.memory import new_eye_each, new_renderer_each

    assert new_renderer_each(200)["rss_growth_mb"] < 50
    assert new_eye_each(500)["rss_growth_mb"] < 50


def test_no_leak_new_renderer_each_render_quick():
    from eyelab.bench.memory import new_renderer_each

    assert new_renderer_each(30, warmup=5)["rss_growth_mb"] < 15


@pytest.mark.parametrize("name", ["raster", "reference", "imagebased"])
def test_achromat_observer_sees_grey_in_every_renderer(name, chart):
    """``cvd = "achromat"`` (Rec. 709 luminance, not a Machado table) goes through the same
    observer step as the other deficiencies in every renderer: a grey image."""
    from eyelab.scene.library import room_scene

    q = QUALITIES[name](samples=1)
    with make_renderer(name, q) as r:
        res = r.render(room_scene(), Eye(accommodation_max=5.0), None,
                       View(width=32, height=24, cvd="achromat"))
    lin = res.linear
    np.testing.assert_allclose(lin[..., 0], lin[..., 1], atol=1e-6)
    np.testing.assert_allclose(lin[..., 1], lin[..., 2], atol=1e-6)
    assert res.report["details"]["cvd"]["kind"] == "achromat"
