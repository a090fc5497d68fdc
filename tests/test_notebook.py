"""What a notebook shows: reprs in the spec's units (mm, D, degrees), rounded; a two-eye
result's image and a one-line repr; help(eyelab.render) with its signature."""

from __future__ import annotations

import inspect
import io
import pydoc
import re

import numpy as np
from PIL import Image

import eyelab
from eyelab.core.reprs import number, value

LONG_FLOAT = re.compile(r"\d\.\d{4,}")


def test_numbers_are_rounded_for_reading():
    assert [number(x) for x in (61.99134032443915, 0.004e3, -0.0, 2.0, 1e-9, 180.0)] == [
        "61.991", "4", "0", "2", "0", "180"]
    assert value((0.0, 1.23456)) == "(0, 1.235)" and value([1.0]) == "[1]"
    assert number(float("inf")) == "inf" and number(True) == "True"


def test_the_eye_lens_pose_and_rx_speak_mm_and_dioptres():
    from eyelab.jobs.session import as_spec

    eye = eyelab.Eye.from_rx("-3.00 / -1.00 x 180")
    text = repr(eye)
    assert "power_min_d=61.991" in text and "pupil_diameter_mm=4," in text, text
    assert "retina_distance_mm=22.785" in text and not LONG_FLOAT.search(text), text
    spec = as_spec(None)
    for obj in (spec.lens, spec.lens.pose, spec.lens.rx, spec.eye, spec.view
                if hasattr(spec, "view") else spec.lens):
        text = repr(obj)
        assert not LONG_FLOAT.search(text), text
    lens = repr(spec.lens)
    assert "rx='-3.00 / -1.00 x 180'" in lens and "center_thickness_mm=2" in lens, lens
    assert "vertex_distance_mm=12" in lens and "diameter_mm=60" in lens, lens
    assert repr(eyelab.Prescription.parse("L +1.25 / -0.50 x 15 add 2")) == (
        "Prescription(sphere=1.25, cylinder=-0.5, axis=15, add=2, eye='L')")
    # the numbers stay whole in the objects: the repr only reads them
    assert eye.power_min != round(eye.power_min, 3)


def test_a_two_eye_result_shows_its_image_and_one_line():
    r = eyelab.render({"eye": {"rx": "-2.00 DS"}, "lens": {},
                       "binocular": {"pd_mm": 64, "output": "anaglyph"}},
                      width=64, height=48, samples=1)
    text = repr(r)
    assert "\n" not in text and len(text) < 160 and "anaglyph" in text, text
    png = Image.open(io.BytesIO(r._repr_png_()))
    assert np.array_equal(np.asarray(png.convert("RGB")), r.srgb("anaglyph"))


def test_help_shows_the_render_signature_and_the_spec_forms():
    sig = inspect.signature(eyelab.render)
    assert list(sig.parameters)[:3] == ["spec", "no_lens", "session"]
    doc = pydoc.render_doc(eyelab.render, renderer=pydoc.plaintext)
    assert "render(spec=None, *, no_lens" in doc, doc[:300]
    flat = " ".join(doc.split())
    assert "a spec file's path" in flat and "a dict of its tables" in flat
    assert "_RenderEntry" not in doc


def test_the_notebook_inspector_shows_what_eyelab_render_gives(tmp_path):
    """A slider moved from Python: the image shown last is eyelab.render's for the spec
    the inspector holds; a refused value says why and leaves the image as it was."""
    import pytest

    pytest.importorskip("ipywidgets")
    from pathlib import Path

    spec = Path(__file__).resolve().parents[1] / "examples" / "first.toml"
    ins = eyelab.NotebookInspector(spec, size=(96, 72), samples=2)
    try:
        first = ins.image.value
        ins.sliders["sphere"].value = -2.0
        data = ins.spec_data()
        assert data["eye"]["rx"].startswith("-2.00") and data["lens"]["rx"].startswith("-2.50")
        want = eyelab.render(data).srgb
        shown = np.asarray(Image.open(io.BytesIO(ins.image.value)).convert("RGB"))
        assert np.array_equal(shown, want) and ins.image.value != first
        assert "data-state='done'" in ins.status.value
        before = ins.image.value
        assert "pupil_diameter_mm" in ins.set("pupil_mm", 99.0)
        assert ins.image.value == before and "must be in" in ins.status.value
        ins.toggles["lens"].value = False
        assert "lens" not in ins.spec_data()
    finally:
        ins.close()
