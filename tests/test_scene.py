import numpy as np
import pytest
import trimesh

from eyelab.blur import compute_blur_field
from eyelab.errors import SpecError
from eyelab.optics.camera import eye_camera
from eyelab.optics.eye import Eye
from eyelab.optics.prescription import Prescription
from eyelab.scene.library import SCENES, chart_texture, room_scene
from eyelab.scene.raycast import EmbreeIntersector, NumpyIntersector
from eyelab.scene.refine import refine_for_fields
from eyelab.scene.scene import Scene, SceneMesh, load_mesh, sample_texture


def test_embree_matches_numpy_twin():
    s = trimesh.creation.icosphere(3)
    rng = np.random.default_rng(0)
    mesh = SceneMesh("s", s.vertices - [0, 0, 3], s.faces,
                     colors=rng.integers(0, 255, (len(s.vertices), 3)))
    scene = Scene([mesh])
    d = rng.normal(size=(400, 3))
    d[:, 2] = -np.abs(d[:, 2]) * 5
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.zeros((400, 3))
    a = EmbreeIntersector(scene).intersect(o, d)
    b = NumpyIntersector(scene).intersect(o, d)
    np.testing.assert_array_equal(a.hit, b.hit)
    assert a.hit.sum() > 50 and (~a.hit).sum() > 50
    # embree is float32: 1e-6 relative on ~3 m
    np.testing.assert_allclose(a.t[a.hit], b.t[b.hit], atol=1e-5)
    np.testing.assert_array_equal(a.tri, b.tri)
    np.testing.assert_allclose(a.colors(scene), b.colors(scene), atol=0.05)


def test_sample_texture_conventions():
    tex = np.zeros((2, 2, 3), np.uint8)
    tex[0, 0] = 255                    # top-left texel
    assert sample_texture(tex, np.array([[0.25, 0.75]]))[0, 0] == 255   # v up: top row
    assert sample_texture(tex, np.array([[0.25, 0.25]]))[0, 0] == 0


def test_chart_letters_have_the_right_angular_size():
    img, (w, h) = chart_texture(6.0, rows=(1.0,), px_per_mm=1.0)
    ink = np.argwhere(img[..., 0] == 0)
    height_mm = ink[:, 0].max() - ink[:, 0].min() + 1
    want_mm = 6000 * np.tan(np.radians(50 / 60))      # 20/200: 50 arcmin at 6 m
    assert height_mm == pytest.approx(want_mm, abs=5)


@pytest.mark.parametrize("name", SCENES)
def test_scenes_build(name):
    s = SCENES[name]()
    assert s.n_triangles > 0
    lo, hi = s.bounds()
    assert (hi >= lo).all()


def test_refinement_only_where_needed():
    """The floor's displacement is far from linear along its edges (it recedes from 0.05 to
    6 m through the myope's blur range): it is subdivided until linear interpolation is within
    the tolerance, checked here independently at the midpoints of the final edges (faces
    clipped by the near plane excepted); the boxes, nearly linear already, are untouched; an
    in-focus view refines nothing."""
    scene = room_scene()
    eye = Eye.from_rx(Prescription(-2.0), accommodation_max=0.5)
    f = compute_blur_field(eye, None, eye_camera(near=0.05, far=100.0), shape=(64, 32, 32))
    floor, box = scene.meshes[0], scene.meshes[3]
    out, info = refine_for_fields(floor, [f], px_scale=320.0, tol_px=0.5)
    assert info["refined"] and out.n_triangles > floor.n_triangles
    assert info["max_error_px_before"] > 0.5
    v, fc = out.vertices, out.faces
    keep = ~(f.camera.depth(v) < f.camera.near)[fc].any(axis=1)
    worst = 0.0
    for a, b in ((0, 1), (1, 2), (2, 0)):
        ia, ib = fc[keep, a], fc[keep, b]
        mid = 0.5 * (v[ia] + v[ib])
        lin = 0.5 * (f.lookup(v[ia]) + f.lookup(v[ib]))
        worst = max(worst, float(np.abs(f.lookup(mid) - lin).max() * 320.0))
    assert worst <= 0.5 + 1e-9
    assert info["max_error_px_after"] == pytest.approx(worst)
    _, binfo = refine_for_fields(box, [f], px_scale=320.0, tol_px=0.5)
    assert not binfo["refined"] and "linear" in binfo["why"]
    sharp = Eye(accommodation_max=10.0)
    g = compute_blur_field(sharp, None, eye_camera(near=0.3, far=100.0), shape=(16, 8, 8))
    _, info = refine_for_fields(box, [g])
    assert not info["refined"] and "no blur" in info["why"]


def test_load_mesh_round_trip(tmp_path):
    box = trimesh.creation.box(extents=(1, 2, 3))
    box.visual.vertex_colors = np.tile([10, 20, 30, 255], (len(box.vertices), 1))
    p = tmp_path / "b.ply"
    box.export(p)
    m = load_mesh(p)
    assert m.n_triangles == 12
    assert (m.colors == [10, 20, 30]).all()
    with pytest.raises(SpecError, match="render.scene"):
        load_mesh(tmp_path / "missing.obj")


def test_prefiltered_texture_keeps_the_mean_light():
    """Reducing a texture by f x f blocks keeps each block's mean linear light (a fine
    black/white checker becomes code 188, linear 0.5, not the codes' mean 128)."""
    import numpy as np

    from eyelab.scene.prefilter import reduce_texture

    tex = np.zeros((8, 8, 3), np.uint8)
    tex[(np.arange(8)[:, None] + np.arange(8)[None]) % 2 == 1] = 255
    out = reduce_texture(tex, 4)
    assert out.shape == (2, 2, 3)
    assert np.all(out == 188)
    np.testing.assert_array_equal(reduce_texture(tex, 1), tex)


def test_bad_meshes_are_named_errors(tmp_path):
    """Unreadable, empty, point-cloud, non-finite, absurdly large and all-degenerate
    meshes name render.scene; zero-area triangles among good ones are dropped."""
    import trimesh

    from eyelab.errors import SpecError
    from eyelab.scene.scene import load_mesh

    (tmp_path / "junk.ply").write_bytes(b"\x00\x01 not a mesh")
    (tmp_path / "empty.ply").write_text(
        "ply\nformat ascii 1.0\nelement vertex 0\nelement face 0\n"
        "property list uchar int vertex_indices\nend_header\n")
    trimesh.PointCloud(np.random.default_rng(0).random((10, 3))).export(tmp_path / "pc.ply")
    (tmp_path / "nan.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nf 1 2 3\nf 1 2 4\n")
    (tmp_path / "huge.obj").write_text("v 0 0 0\nv 1e300 0 0\nv 0 1 0\nf 1 2 3\n")
    trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [2, 0, 0]], faces=[[0, 1, 2]],
                    process=False).export(tmp_path / "line.ply")
    for name in ("junk.ply", "empty.ply", "pc.ply", "nan.obj", "huge.obj", "line.ply"):
        with pytest.raises(SpecError) as e:
            load_mesh(tmp_path / name)
        assert e.value.field == "render.scene", name
    trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]],
                    faces=[[0, 1, 2], [0, 1, 3]], process=False).export(tmp_path / "one.ply")
    assert load_mesh(tmp_path / "one.ply").n_triangles == 1
