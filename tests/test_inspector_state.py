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
