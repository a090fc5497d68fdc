"""Lambertian shading of meshes (eyelab/scene/shading.py), checked against the cosine law
computed independently: a plain sphere's render against the analytic sphere's normal per
pixel, shaded colours against the radial normals of points on a sphere, a box's faces
against their axis normals."""

import math

import numpy as np
import pytest
import trimesh

from eyelab.core.color import decode_srgb
from eyelab.core.errors import SpecError
from eyelab.jobs.render import render_spec
from eyelab.scene.library import grid_quad
from eyelab.scene.scene import PLAIN_GREY, SceneMesh, load_meshes
from eyelab.scene.shading import AMBIENT, LIGHT_DIRECTION, MAX_NORMAL_STEP_DEG, shade
from eyelab.spec.load import parse_spec

ALBEDO = float(decode_srgb(np.uint8(PLAIN_GREY)))        # linear 0.578
R, CENTRE = 0.1, np.array([0.0, 0.0, -1.0])               # the sphere: 10 cm, 1 m ahead
W = H = 40
FOV_Y_DEG = 16.0


def cosine_law(n, albedo=ALBEDO):
    """The model written out: albedo (ambient + (1 - ambient) max(0, n . l))."""
    return albedo * (AMBIENT + (1 - AMBIENT) * np.maximum(n @ LIGHT_DIRECTION, 0.0))


def _render(stl, shading, renderer="reference", samples=64):
    """Linear (H, W, 3) render of the mesh file placed at CENTRE, an emmetropic eye
    (accommodated per pixel: no blur but at depth edges), one wavelength."""
    spec = parse_spec({"render": {
        "scene": {"path": str(stl), "position_m": CENTRE.tolist(), "shading": shading},
        "renderer": renderer, "width": W, "height": H, "fov_y_deg": FOV_Y_DEG,
        "samples": samples, "chromatic": False}})
    return render_spec(spec).linear.astype(float)


def _sphere_pixels():
    """Per pixel (rows from the top): the analytic sphere's unit normal where the pixel
    centre's ray from the pupil meets it, and the cosine between that ray and the normal
    (0 where it misses). The rays are written out from the field of view here (ray =
    (x tan, y tan, -1), square pixels), not taken from the renderer's camera."""
    t = math.tan(math.radians(FOV_Y_DEG) / 2)
    x = (2 * np.arange(W) + 1) / W - 1
    y = 1 - (2 * np.arange(H) + 1) / H
    gx, gy = np.meshgrid(x * t * W / H, y * t)
    d = np.stack([gx, gy, -np.ones_like(gx)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    b = d @ CENTRE                                    # |o + s d - c| = R, o = 0
    disc = b ** 2 - (CENTRE @ CENTRE - R ** 2)
    s = b - np.sqrt(np.maximum(disc, 0.0))
    n = (s[..., None] * d - CENTRE) / R
    facing = np.where(disc > 0, -(n * d).sum(-1), 0.0)
    return n, facing


@pytest.fixture(scope="module")
def sphere_stl(tmp_path_factory):
    path = tmp_path_factory.mktemp("shading") / "sphere.stl"
    trimesh.creation.icosphere(3, radius=R).export(path)        # no colours
    return path


@pytest.mark.parametrize("renderer,samples", [("reference", 64), ("raster", 16)])
def test_a_plain_sphere_follows_the_cosine_law_per_pixel(sphere_stl, renderer, samples):
    """Every pixel whose ray meets the sphere within 50 deg of its normal (off the
    silhouette) and away from the terminator (|n . l| > 0.1), and every pixel of the unlit
    side (n . l < -0.1) within 72.5 deg, shows the cosine law's linear radiance within 2 %,
    in every channel, in the reference (64 rays a pixel: their jitter over the pixel
    averages out) and in the raster renderer (16 passes; it interpolates the vertex
    colours' sRGB codes across a triangle, the reference their linear values)."""
    img = _render(sphere_stl, "auto", renderer, samples)
    n, facing = _sphere_pixels()
    nl = n @ LIGHT_DIRECTION
    use = ((facing > math.cos(math.radians(50))) & (np.abs(nl) > 0.1)) \
        | ((facing > 0.3) & (nl < -0.1))
    assert use.sum() > 300 and (nl[use] < 0).sum() >= 3 and (nl[use] > 0.5).sum() > 100
    expected = cosine_law(n)[use]
    rel = np.abs(img[use] - expected[:, None]) / expected[:, None]
    assert rel.max() < 0.02, (rel.max(), np.median(rel))
    # the same pixels drawn flat would be off by up to 1 / ambient: the check can see it
    assert (np.abs(ALBEDO - expected) / expected).max() > 1.0


def test_none_draws_the_sphere_flat(sphere_stl):
    img = _render(sphere_stl, "none")
    _, facing = _sphere_pixels()
    np.testing.assert_allclose(img[facing > 0.5], ALBEDO, rtol=1e-3)


def test_a_coloured_mesh_stays_flat_under_auto_and_is_shaded_under_lambert(tmp_path):
    ball = trimesh.creation.icosphere(3)
    ball.visual.vertex_colors = np.tile([180, 120, 60, 255], (len(ball.vertices), 1))
    ball.export(tmp_path / "c.ply")
    (flat,) = load_meshes(tmp_path / "c.ply")
    assert not flat.plain and len(flat.vertices) == len(ball.vertices)
    np.testing.assert_array_equal(flat.colors, np.tile([180, 120, 60], (len(ball.vertices), 1)))
    (lit,) = load_meshes(tmp_path / "c.ply", shading="lambert")
    radial = lit.vertices / np.linalg.norm(lit.vertices, axis=1, keepdims=True)
    albedo = decode_srgb(np.array([180, 120, 60], np.uint8)).astype(float)
    expected = albedo * cosine_law(radial, 1.0)[:, None]
    np.testing.assert_allclose(decode_srgb(lit.colors), expected, rtol=0.02, atol=1e-3)


def test_a_coarse_sphere_is_split_until_gouraud_follows_the_cosine_law():
    """icosphere(1) (normals 36 deg apart along edges): points all over its faces, coloured
    as the renderers interpolate them (linear light), against the cosine law at the normal
    of the sphere through each point's direction (the shape the mesh approximates)."""
    ball = trimesh.creation.icosphere(1)
    rng = np.random.default_rng(1)

    def worst_error(mesh):
        k = 20
        faces = np.repeat(np.arange(mesh.n_triangles), k)
        uv = rng.uniform(0, 1, (len(faces), 2))
        uv = np.where(uv.sum(1, keepdims=True) > 1, 1 - uv, uv)
        w = np.column_stack([1 - uv.sum(1), uv])
        p = np.einsum("ij,ijk->ik", w, mesh.vertices[mesh.faces[faces]])
        n = p / np.linalg.norm(p, axis=1, keepdims=True)
        nl = n @ LIGHT_DIRECTION
        keep = np.abs(nl) > 0.1                          # the terminator's kink aside
        got = mesh.linear_color_at(faces, uv)[keep, 0]
        return np.max(np.abs(got - cosine_law(n[keep])) / cosine_law(n[keep]))

    v, f, c, info = shade(ball.vertices, ball.faces, np.full((len(ball.vertices), 3),
                                                              PLAIN_GREY, np.uint8))
    assert info["rounds"] >= 1 and info["max_step_deg"] <= MAX_NORMAL_STEP_DEG
    assert worst_error(SceneMesh("split", v, f, c)) < 0.015
    # unsplit, Gouraud misses the cosine law by several per cent: the check can see it
    v0, f0, c0, info0 = shade(ball.vertices, ball.faces,
                              np.full((len(ball.vertices), 3), PLAIN_GREY, np.uint8),
                              max_triangles=len(ball.faces))
    assert info0["rounds"] == 0
    assert worst_error(SceneMesh("unsplit", v0, f0, c0)) > 0.03


def test_a_box_keeps_flat_faces_and_an_inside_out_one_is_lit_from_outside(tmp_path):
    box = trimesh.creation.box()
    for name, faces in (("box", box.faces), ("inverted", box.faces[:, ::-1])):
        v, f, c, _ = shade(box.vertices, faces, np.full((len(box.vertices), 3), PLAIN_GREY,
                                                        np.uint8))
        centre_dir = v[f].mean(axis=1)
        axis = np.eye(3)[np.argmax(np.abs(centre_dir), 1)] * np.sign(
            centre_dir[np.arange(len(f)), np.argmax(np.abs(centre_dir), 1)])[:, None]
        expected = np.repeat(cosine_law(axis), 3)
        np.testing.assert_allclose(decode_srgb(c[f.ravel(), 0]), expected, rtol=0.01,
                                   err_msg=name)


def test_textured_parts_stay_flat_and_bad_values_are_named():
    tex = grid_quad("q", (0, 0, -1), (1, 0, 0), (0, 1, 0), 1.0, 1.0,
                    texture=np.zeros((4, 4, 3), np.uint8))
    assert tex.shaded() is tex
    with pytest.raises(SpecError) as e:
        parse_spec({"render": {"scene": {"path": "room", "shading": "phong"}}})
    assert str(e.value).startswith("render.scene.shading")
    assert all(v in str(e.value) for v in ("'auto'", "'lambert'", "'none'"))
