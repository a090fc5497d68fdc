import numpy as np
import pytest
import trimesh

from eyelab.blur import compute_blur_field
from eyelab.core.errors import SpecError
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.rays.camera import eye_camera
from eyelab.scene.library import SCENES, room_scene
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


def test_a_scenes_shared_intersector_answers_threads_as_its_numpy_twin():
    """scene_intersector: one embree scene per scene content (the same object asked twice,
    another for another scene), and eight threads casting through it at once get the
    numpy twin's hits."""
    from concurrent.futures import ThreadPoolExecutor

    from eyelab.scene.raycast import scene_intersector

    s = trimesh.creation.icosphere(3)
    scene = Scene([SceneMesh("s", s.vertices - [0, 0, 3], s.faces)])
    other = Scene([SceneMesh("s", s.vertices - [0, 0, 4], s.faces)])
    shared = scene_intersector(scene)
    assert scene_intersector(scene) is shared and scene_intersector(other) is not shared
    rng = np.random.default_rng(1)
    rays = []
    for _ in range(8):
        d = rng.normal(size=(5000, 3))
        d[:, 2] = -np.abs(d[:, 2]) * 5
        rays.append(d / np.linalg.norm(d, axis=1, keepdims=True))
    with ThreadPoolExecutor(8) as pool:
        got = list(pool.map(lambda d: shared.intersect(np.zeros_like(d), d), rays))
    twin = NumpyIntersector(scene)
    for d, a in zip(rays, got, strict=True):
        b = twin.intersect(np.zeros_like(d), d)
        np.testing.assert_array_equal(a.hit, b.hit)
        np.testing.assert_allclose(a.t[a.hit], b.t[b.hit], atol=1e-5)
        np.testing.assert_array_equal(a.tri, b.tri)


def test_sample_texture_conventions():
    tex = np.zeros((2, 2, 3), np.uint8)
    tex[0, 0] = 255                    # top-left texel
    assert sample_texture(tex, np.array([[0.25, 0.75]]))[0, 0] == 255   # v up: top row
    assert sample_texture(tex, np.array([[0.25, 0.25]]))[0, 0] == 0


@pytest.mark.parametrize("distance", [6.0, 0.4])
def test_every_etdrs_row_has_its_exact_size_in_the_scene(distance):
    """Rays from the eye over each row's first letter (embree, in the rendered scene): the
    ink's vertical extent, as an angle, is 5 MAR (MAR = 10^logMAR arcmin) to 1 % on every
    row, -0.3 to 1.0 logMAR."""
    from eyelab.scene.library import ETDRS_ROWS, chart_scene, etdrs_layout
    from eyelab.scene.raycast import EmbreeIntersector

    scene = chart_scene(distance)
    inter = EmbreeIntersector(scene)
    layout = etdrs_layout(distance)
    firsts = [row for row in layout[::5]]
    assert [lm for _, lm, *_ in firsts] == list(ETDRS_ROWS)
    for _letter, lm, x, y, size in firsts:
        ys = y + np.linspace(-0.6, 0.6, 1201) * size        # 0.1 % of the letter per ray
        xs = x + np.linspace(-0.45, 0.45, 31) * size
        gx, gy = np.meshgrid(xs, ys)
        d = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, -distance)], 1)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        hits = inter.intersect(np.zeros_like(d), d)
        lum = hits.linear_colors(scene).mean(axis=1).reshape(gy.shape)
        ink_rows = np.flatnonzero((lum < 0.5).any(axis=1))
        top, bottom = gy[ink_rows.max(), 0], gy[ink_rows.min(), 0]
        angle = np.degrees(np.arctan2(top, distance) - np.arctan2(bottom, distance)) * 60
        want = 5 * 10 ** lm
        assert angle == pytest.approx(want, rel=0.01), (lm, angle, want)


def test_chart_contrast_and_letters():
    from eyelab.core.color import decode_srgb
    from eyelab.scene.library import SLOAN, chart_scene, sloan_letter

    for c in SLOAN:      # every Sloan letter fills its box's height and width (C: open right)
        g = sloan_letter(c, 100)
        assert g[0].any() and g[-1].any() and g[:, 0].any(), c
        assert g[:, -1].any() or (c == "C" and g[:, -15:].any()), c
    low = chart_scene(6.0, contrast=0.1)
    tex = low.meshes[1].texture                             # row 1.0 logMAR
    ink = decode_srgb(tex.min(axis=(0, 1)).astype(np.uint8)[None])[0]
    assert ink == pytest.approx(0.9, abs=0.005)            # Weber 10 % in linear light


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


def test_refinement_in_steps_measured_on_a_worker_is_the_same_mesh():
    """refine_steps with its error measured on a worker thread (the inspector's) pauses
    between its measurements and subdivisions and gives the mesh refine_for_fields
    gives."""
    from eyelab.core.parallel import run_steps
    from eyelab.scene.refine import refine_steps

    scene = room_scene()
    eye = Eye.from_rx(Prescription(-2.0), accommodation_max=0.5)
    f = compute_blur_field(eye, None, eye_camera(near=0.05, far=100.0), shape=(64, 32, 32))
    floor = scene.meshes[0]
    want, info = refine_for_fields(floor, [f], px_scale=320.0, tol_px=0.5)
    steps = refine_steps(floor, [f], px_scale=320.0, tol_px=0.5, offload=True)
    pauses = 0
    while True:
        try:
            next(steps)
            pauses += 1
        except StopIteration as done:
            got, got_info = done.value
            break
    assert pauses > info["iterations"]
    np.testing.assert_array_equal(got.vertices, want.vertices)
    np.testing.assert_array_equal(got.faces, want.faces)
    assert got_info == info
    assert run_steps(refine_steps(floor, [f]))[1] == refine_for_fields(floor, [f])[1]


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
    # an odd-sized random texture against block means written out (edges repeated)
    rng = np.random.default_rng(3)
    tex = rng.integers(0, 256, (23, 17, 3), dtype=np.uint8)
    lin = ((tex / 255.0 + 0.055) / 1.055) ** 2.4
    lin = np.where(tex / 255.0 <= 0.04045, tex / 255.0 / 12.92, lin)
    padded = np.pad(lin, ((0, 1), (0, 1), (0, 0)), mode="edge")
    want = np.array([[padded[i:i + 3, j:j + 3].mean(axis=(0, 1)) for j in range(0, 18, 3)]
                     for i in range(0, 24, 3)])
    got = ((reduce_texture(tex, 3) / 255.0 + 0.055) / 1.055) ** 2.4
    np.testing.assert_allclose(got, want, atol=0.01)      # within a code of the mean


def test_a_prefiltered_mesh_keeps_its_texture_in_place():
    """A texture whose size f does not divide (23 x 17, f = 4: 6 x 5 blocks, padded to
    8 x 8 texels) keeps every uv on the reduced texel whose block holds the original
    texel (u right, v up from the image's bottom), so the image is not stretched."""
    import numpy as np

    from eyelab.scene.prefilter import prefiltered
    from eyelab.scene.scene import SceneMesh

    rng = np.random.default_rng(5)
    uv = rng.uniform(0.0, 1.0, (200, 2))
    mesh = SceneMesh("t", rng.normal(size=(200, 3)), np.arange(198).reshape(66, 3), None,
                     rng.integers(0, 256, (23, 17, 3), dtype=np.uint8), uv)
    small = prefiltered(mesh, 4)
    assert small.texture.shape == (8, 8, 3)
    col, row = np.floor(uv[:, 0] * 17), np.floor((1 - uv[:, 1]) * 23)     # original texel
    col2, row2 = np.floor(small.uv[:, 0] * 8), np.floor((1 - small.uv[:, 1]) * 8)
    np.testing.assert_array_equal(col2, col // 4)
    np.testing.assert_array_equal(row2, row // 4)


def test_bad_meshes_are_named_errors(tmp_path):
    """Unreadable, empty, point-cloud, non-finite, absurdly large and all-degenerate
    meshes name render.scene; zero-area triangles among good ones are dropped."""
    import trimesh

    from eyelab.core.errors import SpecError
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
