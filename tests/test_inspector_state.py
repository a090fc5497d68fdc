"""The inspector shows its current state and nothing older: with the lens turned off (by
its check box or the ``l`` key) the as-worn maps' titles and legends go with the maps
(the side panels take their room, so no stale pixels of them stay), one blur legend, and
every check box mirrors the model; sliders say what they hold (an amplitude where the
spec gives no age, "auto" focus); the gaze readout is ``eyelab analyze`` at the gaze
point, through lenslets too (the carrier's image and the lenslets' share)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from eyelab.jobs.inspector import InspectorModel

DIMS = "examples/dims.toml"


def _covered(renderers) -> float:
    """The fraction of the window's area no drawn renderer covers (on a 200 x 200 grid)."""
    g = (np.arange(200) + 0.5) / 200
    x, y = np.meshgrid(g, g)
    hit = np.zeros_like(x, bool)
    for r in renderers:
        if r.GetDraw():
            x0, y0, x1, y1 = r.GetViewport()
            hit |= (x >= x0) & (x < x1) & (y >= y0) & (y < y1)
    return float((~hit).mean())


@pytest.mark.parametrize("by", ["box", "key"])
def test_turning_the_lens_off_and_on_leaves_nothing_stale(by):
    from eyelab.render.inspector import InspectorWindow

    m = InspectorModel(None, size=(96, 72), samples=1)
    win = InspectorWindow(m, off_screen=True, window_size=(1000, 700))
    try:
        win.run_to_target()
        assert win._maps.shown and win._checks["lens"].GetRepresentation().GetState() == 1
        for on in (False, True):
            if by == "box":
                win._request("lens", on)
            else:                        # the key's own handler: a request, as the box's
                win.plotter.iren.interactor.SetKeySym("l")
                win.plotter.iren.interactor.InvokeEvent("KeyPressEvent")
            win.run_to_target()
            assert m.lens_on is on
            assert win._checks["lens"].GetRepresentation().GetState() == int(on)
            assert win._maps.shown is on
            ren_win = win.plotter.ren_win
            rens = [ren_win.GetRenderers().GetItemAsObject(i)
                    for i in range(ren_win.GetRenderers().GetNumberOfItems())]
            assert _covered(rens) < 1e-9, "a part of the window no panel draws keeps old pixels"
            for name in win._maps.renderers:
                drawn = win._maps.renderers[name].GetDraw()
                assert bool(drawn) is on
    finally:
        win.close()


def test_sliders_say_what_they_hold(tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text('[eye]\nrx = "-2.00"\n[render]\nwidth = 32\nheight = 24\n')
    m = InspectorModel(spec, samples=1)
    try:
        assert m.value_text("age") == f"amplitude {m.eye.accommodation_max:.2f} D"
        assert m.value_text("focus_d") == "auto"
        assert m.value("age") == pytest.approx((18.5 - m.eye.accommodation_max) / 0.3)
        m.apply({"age": 40})
        assert m.value_text("age") == "40" and m.value("age") == 40
        m.apply({"focus_d": 1.0})
        assert m.value_text("focus_d") == "1.00"
    finally:
        m.close()


@pytest.mark.parametrize("path", [None, DIMS])
def test_the_gaze_readout_is_analyze_at_the_gaze_point(path):
    """The thin default spec and a lenslet lens (the carrier's image, as analyze reports
    it, and the share of light through lenslets)."""
    import eyelab
    from eyelab.spec import read_spec_data

    m = InspectorModel(path, size=(48, 36), samples=1)
    try:
        m.run_to_target()
        text = m.readout()
        data, _, _ = read_spec_data(path)
        data = copy.deepcopy(data)
        data["points"] = [{"position_m": [float(v) for v in m.gaze_point]}]
        p = eyelab.analyze(data)["points"][0]
        assert f"accommodation {p['accommodation_d']:.2f} D" in text, text
        assert f"blur {p['blur']['major_arcmin']:.2f}' x {p['blur']['minor_arcmin']:.2f}'" \
            in text, text
        if path == DIMS:
            share = p["lenslets"]["fraction"]
            assert f"{100 * share:.1f} % of the light through {p['lenslets']['count']} " \
                   "lenslets" in text, text
            assert p["blur"]["major_arcmin"] < 0.05          # the carrier's image: sharp
    finally:
        m.close()


def test_an_aberrometer_eye_is_moved_by_the_rx_sliders():
    """examples/aberrometer.toml's refraction is its second order: the inspector shows it
    (not plano), draws the same eye, and its sphere slider moves it (it used to write
    eye.rx beside the second order and refuse its own spec)."""
    from eyelab.spec import load_spec

    path = "examples/aberrometer.toml"
    want = load_spec(path).eye
    m = InspectorModel(path, size=(32, 24), samples=1)
    try:
        got = m.spec.eye
        for k in ("power_min_d", "astigmatism_d"):
            assert got.spec_keys()[k] == pytest.approx(want.spec_keys()[k], abs=1e-6)
        assert np.allclose(got.aberrations.coefficients_um, want.aberrations.coefficients_um)
        assert "plano" not in m.status().splitlines()[0]
        assert m.apply({"sphere": -1.5}) is None
        assert m.status().splitlines()[0].startswith("eye -1.50 /")
    finally:
        m.close()


def test_a_camera_spec_is_refused_naming_the_camera(tmp_path):
    """A camera lens has no eye for the sliders to move: one line naming render.camera
    (it used to be replaced by the default eye without a word)."""
    from eyelab.core.errors import SpecError

    spec = tmp_path / "cam.toml"
    spec.write_text('[render]\nrenderer = "reference"\ncamera = "doublet"\n')
    with pytest.raises(SpecError) as e:
        InspectorModel(spec, samples=1)
    assert e.value.field == "render.camera" and "no eye" in e.value.message


def test_a_schematic_eye_is_inspected_at_fixation_as_render_draws_it():
    """examples/myope.toml (a Navarro eye behind its lens): the inspector opens it, its
    frame is eyelab.render's (the eye accommodated for the fixated point, not for the
    view's near plane), and its readout is analyze's at the gaze point."""
    import eyelab
    from eyelab.spec import read_spec_data

    path = "examples/myope.toml"
    m = InspectorModel(path, size=(64, 48), samples=2)
    try:
        m.run_to_target()
        got = m.result.linear
        data, _, _ = read_spec_data(path)
        data = copy.deepcopy(data)
        data["render"] = {"width": 64, "height": 48, "samples": 2}
        want = eyelab.render(data).linear
        assert np.abs(got - want).mean() < 2e-3 * float(want.mean())
        text = m.readout()
        data["points"] = [{"position_m": [float(v) for v in m.gaze_point]}]
        data["analysis"] = {"fixation": "rotating"}
        p = eyelab.analyze(data)["points"][0]
        assert f"accommodation {p['accommodation_d']:.2f} D" in text, text
        assert f"M {p['m_d']:+.2f} D" in text, text
        assert m.apply({"sphere": -2.0}) is None and m.apply({"lens": False}) is None
        m.run_to_target()
        assert "M -" in m.readout()                 # naked, the myope is left myopic
    finally:
        m.close()


def test_a_lenslet_lens_previews_with_fewer_pupil_samples_and_ends_with_all():
    """After a change through lenslets the preview's lens view takes at most
    PREVIEW_LENSLET_SAMPLES pupil samples (equal-area seeds: the disc's moments at any
    count) and the frames end with the quality's own (32)."""
    from eyelab.jobs.controls import PREVIEW_LENSLET_SAMPLES

    m = InspectorModel(DIMS, size=(64, 48), samples=2)
    try:
        m.run_to_target()
        m.apply({"sphere": -2.5})
        while not (m.tick() and m.result is not None):
            pass
        preview = m.eye_report()
        assert preview["samples"]["done_passes"] == 0
        assert preview["details"]["lenslets"]["pupil_samples"] == PREVIEW_LENSLET_SAMPLES
        m.run_to_target()
        assert m.eye_report()["details"]["lenslets"]["pupil_samples"] == 32
    finally:
        m.close()


def test_a_preview_is_drawn_coarser_and_shown_at_the_views_size():
    """The first frame after a change (an S change too) is drawn PREVIEW_SCALE times coarser
    on a side by the previews' own renderer and shown at the view's size, each preview
    pixel a uniform block; the full frames that follow are the view's own size, drawn by
    the model's renderer, whose windows keep the view's size."""
    from eyelab.jobs.controls import PREVIEW_SCALE

    m = InspectorModel(None, size=(64, 48), samples=2)
    try:
        m.run_to_target()
        for change in ({"sphere": -2.5}, {"samples": 4}):
            m.apply(change)
            while not m.tick():
                pass
            r = m.eye_report()
            assert r["samples"]["done_passes"] == 0, change
            assert r["details"]["preview_size"] == [64 // PREVIEW_SCALE, 48 // PREVIEW_SCALE]
            shown = m.display()
            assert shown.shape == (48, 64, 3)
            blocks = shown.reshape(48 // PREVIEW_SCALE, PREVIEW_SCALE,
                                   64 // PREVIEW_SCALE, PREVIEW_SCALE, 3)
            assert (blocks == blocks[:, :1, :, :1]).all()
            m.run_to_target()
            r = m.eye_report()
            assert r["samples"]["done_passes"] == m.samples
            assert "preview_size" not in r["details"] and m.display().shape == (48, 64, 3)
        assert m.renderer._eye_win.size == (64, 48)
    finally:
        m.close()


def test_an_enlarged_preview_keeps_each_pixel_as_the_block_it_covers():
    """An odd-sized view (65 x 49) from its ceil-halved preview (33 x 25; a 40 x 24 view's
    is 20 x 16, no side below a view's smallest): every view pixel
    takes the preview pixel its centre lies in (row i of 49 from row floor((i + 0.5) *
    25 / 49): the same field of view), its lens mask too (no intermediate images); a
    preview already of the view's size is returned as it is."""
    from eyelab.imaging.contract import RenderResult, View
    from eyelab.jobs.frameloop import enlarged, preview_inputs

    (_, _, _, v), = preview_inputs([(None, None, None, View(width=65, height=49))], 2)
    assert (v.width, v.height) == (33, 25)
    (_, _, _, v), = preview_inputs([(None, None, None, View(width=40, height=24))], 2)
    assert (v.width, v.height) == (20, 16)          # a view's smallest side: 16
    rng = np.random.default_rng(1)
    small = rng.integers(0, 256, (25, 33, 3), dtype=np.uint8)
    mask = rng.random((25, 33)) > 0.5
    res = enlarged(RenderResult({"details": {}}, srgb=small,
                                layers={"lens_mask": mask, "environment": small[:7]}),
                   (65, 49))
    assert list(res.layers) == ["lens_mask"]
    rows = np.floor((np.arange(49) + 0.5) * 25 / 49).astype(int)
    cols = np.floor((np.arange(65) + 0.5) * 33 / 65).astype(int)
    assert rows[-1] == 24 and cols[-1] == 32
    assert (res.srgb == small[rows][:, cols]).all()
    assert (res.layers["lens_mask"] == mask[rows][:, cols]).all()
    assert res.report["details"]["preview_size"] == [33, 25]
    same = RenderResult({"details": {}}, srgb=small)
    assert enlarged(same, (33, 25)) is same
