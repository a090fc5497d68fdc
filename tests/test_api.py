"""The public API (``import eyelab``): lazy, callable in the forms the README shows, and
giving the same images as the renderers driven by hand."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import eyelab

ROOT = Path(__file__).resolve().parents[1]
GUIDE = (ROOT / "docs" / "guide" / "python-api.md").read_text()
HEAVY = ("vtk", "vtkmodules", "pyvista", "embreex", "trimesh", "pymeshlab")


def test_import_eyelab_loads_no_vtk_and_no_embree():
    code = ("import sys, eyelab; eyelab.Eye; eyelab.load_spec; eyelab.View; "
            f"bad = [m for m in sys.modules if m.split('.')[0] in {HEAVY!r}]; "
            "print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_guide_api_example_runs_with_one_import(tmp_path, monkeypatch):
    section = GUIDE
    start = section.index("```python") + 9
    code = section[start: section.index("```\n", start)]
    assert len(re.findall(r"^(?:import|from) ", code, flags=re.M)) <= 3
    monkeypatch.chdir(tmp_path)
    scope = {}
    exec(compile(code, "python-api.md", "exec"), scope)
    assert scope["result"].srgb.shape == (240, 320, 3)
    assert (tmp_path / "view.png").stat().st_size > 0 and (tmp_path / "view.json").exists()
    assert scope["through_chart"].srgb.shape == (120, 160, 3)
    assert len(scope["points"]) == 3


def test_the_one_liner_of_the_issue_runs_as_a_fresh_process(tmp_path):
    code = ("import eyelab; r = eyelab.render(eyelab.load_spec(None), width=96, height=72, "
            "samples=2); r.save('x.png')")
    env = dict(os.environ, VTK_DEFAULT_OPENGL_WINDOW="vtkOSOpenGLRenderWindow")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                       text=True, env=env)
    assert r.returncode == 0, r.stderr
    from PIL import Image

    with Image.open(tmp_path / "x.png") as im:
        assert im.size == (96, 72) and im.info.get("srgb") == 0


def test_render_stays_callable_after_the_gl_package_is_imported():
    import eyelab.render.raster  # noqa: F401  (binds eyelab.render, which must not win)

    assert callable(eyelab.render)
    from eyelab.render import raster

    assert raster.RasterRenderer.name == "raster"
    import eyelab.render.raster as by_as

    assert by_as is raster
    from unittest import mock

    with mock.patch("eyelab.render.raster.RasterRenderer.name", "patched"):
        assert raster.RasterRenderer.name == "patched"
    import inspect

    from eyelab.jobs.api import render

    assert inspect.signature(eyelab.render) == inspect.signature(render)
    assert eyelab.render.__doc__ == render.__doc__


def test_every_spec_form_gives_the_same_image():
    """A path, a dict, a Spec and None (the built-in default) are one spec here; the
    image equals the renderer driven by hand with the spec's own objects."""
    from eyelab.jobs.render import build_scene

    data_path = Path(eyelab.__file__).parent / "data" / "default.toml"
    kw = dict(width=64, height=48, samples=2)
    by_none = eyelab.render(None, **kw)
    by_path = eyelab.render(str(data_path), **kw)
    spec = eyelab.load_spec(None)
    by_spec = eyelab.render(spec, **kw)
    import tomllib

    by_dict = eyelab.render(tomllib.loads(data_path.read_text()), **kw)
    for r in (by_path, by_spec, by_dict):
        np.testing.assert_array_equal(r.srgb, by_none.srgb)
    rs = spec.render.with_changes(**kw)
    with eyelab.make_renderer(rs.renderer, rs.quality) as r:
        direct = r.render(build_scene(rs.scene), spec.eye, spec.lens, rs.view)
    np.testing.assert_array_equal(direct.srgb, by_none.srgb)


def test_overrides_are_checked_like_the_file():
    with pytest.raises(eyelab.SpecError) as e:
        eyelab.render(None, width=0)
    assert e.value.field == "render.width"
    with pytest.raises(eyelab.SpecError) as e:
        eyelab.render(None, colour="red")
    assert e.value.field == "render.colour"
    with pytest.raises(TypeError):
        eyelab.render(3.0)


def test_render_result_shows_itself_and_saves(tmp_path):
    from PIL import Image

    res = eyelab.render(None, width=40, height=30, samples=1)
    text = repr(res)
    assert text.startswith("<RenderResult 40x30 raster") and "samples" in text
    png = res._repr_png_()
    with Image.open(io.BytesIO(png)) as im:
        np.testing.assert_array_equal(np.asarray(im), res.srgb)
    res.save(tmp_path / "a.png", report=tmp_path / "a.json")
    with Image.open(tmp_path / "a.png") as im:
        np.testing.assert_array_equal(np.asarray(im), res.srgb)
    res.save(tmp_path / "l.png", linear=True)
    with Image.open(tmp_path / "l.png") as im:
        assert im.info["gamma"] == 1.0 and im.size == (40, 30)


def test_constructors_take_the_obvious_forms():
    a = eyelab.Eye.from_rx("-3.00 / -1.00 x 180")
    b = eyelab.Eye.from_rx(eyelab.Prescription.parse("-3.00 / -1.00 x 180"))
    assert a == b
    with eyelab.make_renderer("reference", samples=3) as r:
        assert r.quality.samples == 3
    with pytest.raises(eyelab.SpecError):
        eyelab.make_renderer("nope")
    assert eyelab.builtin_scene("chart", distance_m=2.0).meshes
    assert "render" in dir(eyelab) and "Eye" in eyelab.__all__


def test_a_two_eye_result_saves_like_one_eye(tmp_path):
    """eyelab.render of a two-eye spec returns a BinocularResult; .save writes its spec's
    output (side by side) or any other, sRGB or linear, with both eyes' report."""
    import json

    from PIL import Image

    res = eyelab.render({"binocular": {}}, width=32, height=24, samples=1)
    res.save(tmp_path / "b.png", report=tmp_path / "b.json")
    with Image.open(tmp_path / "b.png") as im:
        np.testing.assert_array_equal(np.asarray(im), res.srgb("side-by-side"))
        assert im.size == (64, 24)
    assert set(json.loads((tmp_path / "b.json").read_text())) >= {"right", "left", "binocular"}
    res.save(tmp_path / "r.png", output="right", linear=True)
    with Image.open(tmp_path / "r.png") as im:
        assert im.info["gamma"] == 1.0 and im.size == (32, 24)
    with pytest.raises(eyelab.SpecError, match="binocular.output"):
        res.save(tmp_path / "x.png", output="wiggle")
    assert not (tmp_path / "x.png").exists()
