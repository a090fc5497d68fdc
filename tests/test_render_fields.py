import numpy as np
import pytest

pv = pytest.importorskip("pyvista")

from eyelab.blur import compute_blur_field  # noqa: E402
from eyelab.optics.chain.analysis import analyze_points  # noqa: E402
from eyelab.optics.eye.prescription import Prescription  # noqa: E402
from eyelab.optics.eye.thin import Eye  # noqa: E402
from eyelab.optics.rays.camera import eye_camera  # noqa: E402
from eyelab.optics.rays.paths import ObjectPoints  # noqa: E402
from eyelab.render import fields as sf  # noqa: E402
from eyelab.render.fields import ellipse_glyphs, sturm_conoid  # noqa: E402


@pytest.fixture(scope="module")
def field():
    eye = Eye.from_rx(Prescription(-2.0, -1.5, 30), accommodation_max=1.0)
    return compute_blur_field(eye, None, eye_camera(fov_y_deg=40, near=0.1, far=10.0),
                              shape=(12, 5, 7))


def test_image_data_cells_follow_voxel_indices(field):
    g = sf.blur_field_to_pyvista(field)
    nz, ny, nx = field.shape
    assert g.n_cells == nz * ny * nx
    centres = g.cell_centers().points
    k, j, i = 7, 3, 5
    c = (k * ny + j) * nx + i
    np.testing.assert_allclose(centres[c], [-1 + (2 * i + 1) / nx, -1 + (2 * j + 1) / ny,
                                            -1 + (2 * k + 1) / nz], atol=1e-12)
    assert g.cell_data["blur_arcmin"][c] == field.major_arcmin[k, j, i]
    np.testing.assert_array_equal(g.cell_data["matrix"][c], field.matrix[k, j, i].ravel())


def test_world_grid_cells_contain_their_wave_sources(field):
    g = sf.blur_field_to_pyvista(field, world=True)
    src = field.sources.reshape(-1, 3)
    found = g.find_containing_cell(src)
    np.testing.assert_array_equal(found, np.arange(len(src)))


def test_vti_round_trip_is_exact(field, tmp_path):
    p = tmp_path / "f.vti"
    sf.save_vti(field, p)
    g = pv.read(p)
    np.testing.assert_allclose(g.cell_data["blur_arcmin"], field.major_arcmin.ravel())
    back = sf.load_vti(p)
    for name in ("matrix", "a", "b", "omega", "major_arcmin", "accommodation", "status",
                 "sources"):
        np.testing.assert_array_equal(getattr(back, name), getattr(field, name))
    assert back.key == field.key and back.camera == field.camera


def test_glyphs_are_the_ndc_ellipses_of_each_voxel(field):
    k = 3
    gl = ellipse_glyphs(field, slices=k, segments=64)
    ok = field.status[k] == 0
    assert gl.n_cells == ok.sum()
    cam = field.camera
    ndc = cam.world_to_ndc(gl.points)[:, :2].reshape(-1, 64, 2)
    centre_ndc = cam.world_to_ndc(field.sources[k][ok])[:, :2]
    m = field.matrix[k][ok]
    # every glyph point is B s for a unit s: |B^-1 (p - c)| = 1
    s = np.einsum("nij,nkj->nki", np.linalg.inv(m), ndc - centre_ndc[:, None])
    np.testing.assert_allclose(np.linalg.norm(s, axis=-1), 1.0, rtol=1e-9)


def test_sturm_conoid_section_and_focal_lines():
    eye = Eye(astigmatism=3.0, accommodation_max=0.0, pupil_diameter=6e-3)
    res = analyze_points(eye, None, ObjectPoints.from_angles(1.0, 0.0, 0.0))
    k = [v[0] for v in res.wave_eye.in_basis(res.eye_x)]
    parts = sturm_conoid(eye, k, 0.0)
    maj, mnr, _ = res.blur_axes()
    r = np.linalg.norm(parts["retina_section"].points[:, :2], axis=1)     # mm
    assert r.max() == pytest.approx(maj[0] * 1e3, rel=1e-3)
    assert r.min() == pytest.approx(mnr[0] * 1e3, rel=1e-3)
    # focal lines at z = n2 / (vergence + power) per meridian (thin-lens vergence, calc)
    z = sorted(set(np.round(parts["focal_lines"].points[:, 2], 9)))
    p1, p2 = eye.principal_powers()
    want = sorted(1e3 * eye.n_vitreous / (p - 1.0) for p in (p1, p2))
    # (pv.Line stores float32 points: 1e-6 relative)
    np.testing.assert_allclose(z, [w for w in want if w < 1.3 * 22.785], rtol=1e-6)


def test_gallery_writes_images(tmp_path):
    from eyelab.render.gallery import write_gallery

    paths = write_gallery(tmp_path, window_size=(200, 150))
    import matplotlib.image as mpimg

    for p in paths:
        img = mpimg.imread(p)
        assert img.shape[:2] == (150, 200)
        assert (img[..., :3] < 0.9).any()   # something drawn on the white background


def test_voxel_conoid_and_plot_helpers(field):
    eye = Eye.from_rx(Prescription(-2.0, -1.5, 30), accommodation_max=1.0)
    k, j, i = 2, 2, 3
    parts = sf.voxel_conoid(field, eye, None, (k, j, i))
    r = np.linalg.norm(parts["retina_section"].points[:, :2], axis=1)
    big = max(abs(field.a[k, j, i]), abs(field.b[k, j, i])) * 1e3
    assert r.max() == pytest.approx(big, rel=1e-3)
    p = sf.plot_volume(field)
    p2 = sf.plot_glyphs(field, depth=float(field.slice_depths()[5]))
    # (pyvista counts the scalar bar as an actor too)
    assert len(p.renderer.actors) >= 2 and len(p2.renderer.actors) >= 1
    p.close()
    p2.close()
