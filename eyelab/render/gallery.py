"""Gallery images of blur fields, rendered offscreen (used by ``apps/gallery.py``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyvista as pv

from eyelab.blur import compute_blur_field
from eyelab.optics.chain.analysis import analyze_points
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.rays.camera import eye_camera
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.render.fields import blur_field_to_pyvista, ellipse_glyphs, save_vti, sturm_conoid


def _plotter(window_size):
    pv.global_theme.multi_samples = 0
    p = pv.Plotter(off_screen=True, window_size=window_size)
    p.set_background("white")
    return p


def write_gallery(out, window_size=(800, 600)) -> list[Path]:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    # 1. volume: a -2 D myope with 1 D of accommodation left, naked, NDC grid
    eye = Eye.from_rx(Prescription(-2.0), accommodation_max=1.0)
    field = compute_blur_field(eye, None, eye_camera(fov_y_deg=40.0, near=0.1, far=10.0),
                               shape=(64, 24, 24))
    grid = blur_field_to_pyvista(field)
    blur_field_to_pyvista(field, world=True).save(out / "blurfield_world.vts")
    save_vti(field, out / "blurfield.vti")
    vol = grid.cell_data_to_point_data()
    p = _plotter(window_size)
    p.add_volume(vol, scalars="blur_arcmin", cmap="magma", opacity="linear",
                 scalar_bar_args={"title": "blur (arcmin)", "color": "black"})
    p.add_mesh(grid.outline(), color="black")
    p.add_text("naked -2 D myope, amplitude 1 D: blur over NDC (z = dioptric depth)",
               font_size=10, color="black")
    p.camera_position = [(4.0, 3.0, -5.0), (0, 0, 0), (0, 1, 0)]
    written.append(out / "blurfield_volume.png")
    p.screenshot(written[-1])
    p.close()
    # 2. glyphs: astigmatic presbyopic naked eye reading at 6-11 cm (Kakimoto Fig. 12)
    eye2 = Eye(astigmatism=2.0, astigmatism_axis_deg=30.0, accommodation_max=3.0,
               pupil_diameter=4e-3)
    cam2 = eye_camera(fov_y_deg=30.0, near=0.04, far=2.0)
    f2 = compute_blur_field(eye2, None, cam2, shape=(96, 12, 12),
                            scene_bounds=((-0.05, -0.05, -0.11), (0.05, 0.05, -0.06)))
    depths = f2.slice_depths()
    ks = np.flatnonzero((depths > 0.06) & (depths < 0.11))[::4]
    glyphs = ellipse_glyphs(f2, slices=ks, scale=1.0)
    glyphs.save(out / "blurfield_glyphs.vtp")
    p = _plotter(window_size)
    p.add_mesh(glyphs, scalars="blur_arcmin", cmap="viridis", line_width=2,
               scalar_bar_args={"title": "blur (arcmin)", "color": "black"})
    p.add_text("astigmatic naked eye (2 D x 30), 6-11 cm: Sturm-conoid ellipses per voxel",
               font_size=10, color="black")
    p.camera_position = [(0.12, 0.08, 0.05), (0.0, 0.0, -0.085), (0, 1, 0)]
    written.append(out / "blurfield_glyphs.png")
    p.screenshot(written[-1])
    p.close()
    # 3. one point's Sturm conoid inside the eye
    eye3 = Eye(astigmatism=3.0, astigmatism_axis_deg=0.0, accommodation_max=0.0,
               pupil_diameter=6e-3)
    res = analyze_points(eye3, None, ObjectPoints.from_angles(1.0, 0.0, 0.0))
    k = res.wave_eye.in_basis(res.eye_x)
    parts = sturm_conoid(eye3, [v[0] for v in k], float(res.accommodation[0]), start=0.9,
                         beyond=1.12, transverse_scale=15.0, rays=64, rings=1)
    p = _plotter(window_size)
    p.add_mesh(parts["rays"], color="steelblue", opacity=0.35)
    if parts["focal_lines"].n_points:
        p.add_mesh(parts["focal_lines"], color="red", line_width=5)
    p.add_mesh(parts["retina_section"], color="black", line_width=4)
    p.add_text("Sturm conoid near the retina (black): 3 D astigmatic eye, point at 1 m;\n"
               "red: the two focal lines; x, y magnified 15x (mm)", font_size=10,
               color="black")
    p.camera_position = [(30.0, 18.0, 16.0), (0, 0, 23.0), (0, 1, 0)]
    written.append(out / "sturm_conoid.png")
    p.screenshot(written[-1])
    p.close()
    return written
