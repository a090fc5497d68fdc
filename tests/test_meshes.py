"""Mesh scenes: placed by [render] scene = {path, position_m, scale, rotation_deg, units},
their looks kept (textures of glTF/OBJ, flat face colours, several parts), a background
option, and warnings when the eye is inside a mesh or nothing is in view."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from PIL import Image

from eyelab.apps.cli import main
from eyelab.jobs.render import build_scene
from eyelab.scene.raycast import EmbreeIntersector, scene_warnings
from eyelab.scene.scene import SceneSource, load_meshes
from eyelab.spec import parse_spec


def _quad(path, image):
    """A 1 x 1 square in the file's z = 0 plane, textured with ``image`` (uv = corners)."""
    q = trimesh.Trimesh(vertices=[[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0],
                                  [-0.5, 0.5, 0]], faces=[[0, 1, 2], [0, 2, 3]], process=False)
    q.visual = trimesh.visual.TextureVisuals(uv=[[0, 0], [1, 0], [1, 1], [0, 1]],
                                             image=Image.fromarray(image))
    q.export(path)


def test_placement_matrix_units_scale_rotation():
    src = SceneSource("x.ply", position_m=(1.0, 2.0, -3.0), scale=2.0,
                      rotation_deg=(0.0, 90.0, 0.0), units="mm")
    m = src.matrix()
    p = m @ np.array([1000.0, 0.0, 0.0, 1.0])     # 1 m along x, turned 90 deg about y
    np.testing.assert_allclose(p[:3], [1.0, 2.0, -3.0 - 2.0], atol=1e-12)
    assert not SceneSource("room").placed and src.placed


@pytest.mark.parametrize("ext", ["glb", "obj"])
def test_a_textured_file_keeps_its_texture(tmp_path, ext):
    """A 2x2 checker texture on a quad placed 1 m in front, filling the view: the four
    quadrants of the (reference, naked-eye, pinhole) image are the texels' colours."""
    tex = np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 0]]], np.uint8)
    _quad(tmp_path / f"q.{ext}", np.kron(tex, np.ones((32, 32, 1), np.uint8)))
    parts = load_meshes(tmp_path / f"q.{ext}")
    assert len(parts) == 1 and parts[0].texture is not None
    spec = parse_spec({"eye": {"pupil_diameter_mm": 0.5, "power_min_d": 58.635},
                       "render": {"renderer": "reference", "samples": 1, "width": 32,
                                  "height": 32, "fov_y_deg": 20.0, "scene": {
                                      "path": str(tmp_path / f"q.{ext}"),
                                      "position_m": [0, 0, -1.0], "scale": 0.5}}})
    from eyelab.jobs.render import render_spec

    img = render_spec(spec).srgb.astype(int)
    quads = {"top-left": img[4, 4], "top-right": img[4, -5], "bottom-left": img[-5, 4],
             "bottom-right": img[-5, -5]}
    want = {"top-left": tex[0, 0], "top-right": tex[0, 1], "bottom-left": tex[1, 0],
            "bottom-right": tex[1, 1]}
    for k in quads:
        assert np.abs(quads[k] - want[k]).max() <= 2, (k, quads[k], want[k])


def test_face_colours_stay_flat_and_parts_stay_apart(tmp_path):
    b = trimesh.creation.box()
    b.visual.face_colors = np.tile([[255, 0, 0, 255], [0, 0, 255, 255]], (6, 1))
    b.export(tmp_path / "fc.ply")
    (m,) = load_meshes(tmp_path / "fc.ply")
    # every triangle's three vertices carry its own colour: nothing to interpolate
    c = m.colors[m.faces]
    assert (c == c[:, :1]).all() and {tuple(x) for x in c[:, 0]} == {(255, 0, 0), (0, 0, 255)}
    q = trimesh.creation.box()
    scene = trimesh.Scene([q, b.copy().apply_translation([3, 0, 0])])
    scene.export(tmp_path / "two.glb")
    parts = load_meshes(tmp_path / "two.glb")
    assert len(parts) == 2
    lo = min(p.vertices[:, 0].min() for p in parts)
    hi = max(p.vertices[:, 0].max() for p in parts)
    assert (lo, hi) == pytest.approx((-0.5, 3.5))


def test_background_and_built_in_placement(tmp_path):
    spec = parse_spec({"render": {"scene": "chart", "background": [10, 20, 30]}})
    scene = build_scene(spec.render.scene)
    assert scene.background == (10, 20, 30)
    moved = build_scene(SceneSource("chart", position_m=(0.0, 1.0, 0.0)))
    assert moved.bounds()[0][1] == pytest.approx(scene.bounds()[0][1] + 1.0)


def test_warnings_eye_inside_and_nothing_in_view(tmp_path):
    from eyelab.imaging.contract import View

    trimesh.creation.box(extents=[4, 4, 4]).export(tmp_path / "room.ply")
    cam = View().camera(0.0135)
    inside = build_scene(str(tmp_path / "room.ply"))
    w = scene_warnings(inside, cam)
    assert len(w) == 1 and "inside mesh" in w[0]
    ahead = build_scene(SceneSource(str(tmp_path / "room.ply"), position_m=(0, 0, -10.0)))
    assert scene_warnings(ahead, cam, EmbreeIntersector(ahead)) == []
    behind = build_scene(SceneSource(str(tmp_path / "room.ply"), position_m=(0, 0, 10.0)))
    w = scene_warnings(behind, cam)
    assert len(w) == 1 and "nothing in view" in w[0]


def test_render_reports_warnings_and_takes_scene_from_the_command_line(tmp_path, capsys):
    trimesh.creation.box(extents=[4, 4, 4]).export(tmp_path / "room.ply")
    out, rep = tmp_path / "o.png", tmp_path / "o.json"
    assert main(["render", "--scene", str(tmp_path / "room.ply"), "-o", str(out), "--report",
                 str(rep), "--width", "32", "--height", "24", "--samples", "1"]) == 0
    err = capsys.readouterr().err
    assert "eyelab: warning: the eye is inside mesh" in err
    import json

    assert "inside mesh" in json.loads(rep.read_text())["warnings"][0]


@pytest.mark.parametrize("scene, field", [
    ({"path": "room"}, None),
    ({"path": "room", "units": "furlong"}, "render.scene.units"),
    ({"path": "room", "scale": 0}, "render.scene.scale"),
    ({"path": "room", "rotation_deg": [0, 0]}, "render.scene.rotation_deg"),
    ({"path": "room", "position_m": [0, "1", 0]}, "render.scene.position_m[1]"),
    ({"position_m": [0, 0, 0]}, "render.scene.path"),
    ({"path": "room", "colour": 1}, "render.scene.colour"),
    ({"path": "/no/such.glb"}, "render.scene.path"),
])
def test_scene_table_is_validated(scene, field):
    from eyelab.core.errors import SpecError

    if field is None:
        parse_spec({"render": {"scene": scene}})
        return
    with pytest.raises(SpecError) as e:
        parse_spec({"render": {"scene": scene}})
    assert e.value.field == field
