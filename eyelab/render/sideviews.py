"""The inspector window's side views: the 3-D scene with each eye (a small sphere at its
camera), its lens, view frustum and line of sight; and the blur field of the last frame as
Sturm-conoid ellipses (Kakimoto et al. 2007, Figs. 12-13) at the depth of the gaze point,
with their legend. Functions of the :class:`~eyelab.render.inspector.InspectorWindow`."""

from __future__ import annotations

import numpy as np
import pyvista as pv

from eyelab.optics.eye.thin import EYE_REFERENCE_NM
from eyelab.render.legend import RAMP_PX


def field_title(side, slice_m: float, gaze_m, wavelength_nm: float) -> str:
    """The blur-field panel's title: the depth of the slice its ellipses are drawn at and,
    where that is not the gaze point's (the field's slices are uniform in NDC z, sparse
    far away), the gaze point's depth beside it."""
    eye = f"{side} eye, " if side else ""
    if gaze_m is None or not np.isfinite(gaze_m):
        where = "farthest slice"
    elif abs(slice_m - gaze_m) <= 0.02 * gaze_m:
        where = "gaze point"
    else:
        where = f"gaze {gaze_m:.2f} m"
    return f"blur field at {slice_m:.2f} m ({eye}{where}; {wavelength_nm:.0f} nm)"


def _draw_eye(win, tag: str, cam, lens, offset) -> None:
    """One eye (a small sphere at its camera), its lens, view frustum and line of
    sight, moved by ``offset`` (3,) m into the head frame."""
    p = win.plotter
    pos = np.asarray(cam.position, float) + offset
    p.add_mesh(pv.Sphere(radius=0.012, center=pos + np.array([0, 0, 0.012])),
               color="white", name=f"eye{tag}")
    if lens is not None:
        v, f, _ = lens.mesh(8, 48)
        p.add_mesh(pv.PolyData(v + offset, np.column_stack([np.full(len(f), 3), f]).ravel()),
                   color="lightblue", opacity=0.5, name=f"lens{tag}")
    else:
        p.remove_actor(f"lens{tag}")
    depth = 1.5
    corners = []
    for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        d = cam.ray_directions(np.array([sx], float), np.array([sy], float))[0]
        corners.append(pos + d * depth / (d @ cam.basis[2]))
    lines = [pv.Line(pos, c) for c in corners]
    lines += [pv.Line(corners[i], corners[(i + 1) % 4]) for i in range(4)]
    p.add_mesh(pv.merge(lines), color="yellow", name=f"frustum{tag}")
    p.add_mesh(pv.Line(pos, pos + np.asarray(cam.basis[2]) * 20.0), color="red",
               line_width=2, name=f"gaze_line{tag}")

def draw_side(win) -> None:
    """Eye, lens, frustum and line of sight; the blur-field glyphs at the gaze depth."""
    from eyelab.render.fields import ellipse_glyphs

    p, m = win.plotter, win.model
    p.subplot(0, 1)
    if m.two_eyes:                       # each eye at its pupil (head frame)
        pose = m.pose
        for side in ("right", "left"):
            _, eye, lens, view = pose.inputs[side]
            offset = -np.asarray(pose.wearer.to_eye(side), float)[:3, 3]
            _draw_eye(win, side, view.camera(eye.rotation_centre), lens, offset)
    else:
        _draw_eye(win, "", m.view.camera(m.spec.eye.rotation_centre), m.lens,
                       np.zeros(3))
    if not getattr(win, "_scene_camera_set", False):
        p.camera_position = [(2.5, 1.5, 2.0), (0.0, 0.0, -1.5), (0.0, 1.0, 0.0)]
        win._scene_camera_set = True
    # the field of the last frame's first stage (the shown eye's), ellipses at the gaze
    # point's slice (the farthest for a gaze to infinity)
    p.subplot(1, 1)
    cache = m.shown_renderer().caches["fields"]
    fields = [cache.get(k) for k in list(cache.keys())]
    # the view's own field (the last stage's), its green channel when per channel
    fields = [f for f in fields if f.camera == fields[-1].camera] if fields else []
    if fields:
        finest = max(f.nz for f in fields)          # the full field, not a change's preview
        field = min((f for f in fields if f.nz == finest),
                    key=lambda f: abs(f.report.get("wavelength_nm", EYE_REFERENCE_NM) - 546.07))
        gaze = getattr(m, "gaze_distance_m", None)
        depth = 1.0 if gaze is None else gaze
        depths = field.slice_depths()
        k = int(np.argmin(np.abs(depths - depth))) if np.isfinite(depth) else len(depths) - 1
        win.set_top_text("field", field_title(m.side if m.two_eyes else None, depths[k], gaze,
                                              field.report.get("wavelength_nm",
                                                               EYE_REFERENCE_NM)))
        # ellipses magnified to fill about half the column spacing (Kakimoto Fig. 12)
        w = depths[k]
        tx, ty = field.camera.tan_half
        spacing = 2 * 2 * w * tx / field.shape[2]
        big = np.abs(field.matrix[k]).max() * w * max(tx, ty)
        glyphs = ellipse_glyphs(field, slices=k, stride=2, segments=24,
                                scale=0.45 * spacing / big if big > 0 else 1.0)
        if glyphs.n_points:
            actor = p.add_mesh(glyphs, scalars="blur_arcmin", cmap="viridis",
                               name="glyphs", show_scalar_bar=False)
            x0 = _show_legend(win, actor)
            p.view_vector(-np.asarray(field.camera.basis[2]), np.asarray(
                field.camera.basis[1]))
            p.reset_camera()
            # the ellipses in the panel's part left of the legend (x0: its left edge, a
            # fraction of the panel; the title has a band of its own): shrunk and moved there
            part = max(0.3, x0 - 0.04)
            p.renderer.camera.Zoom(0.95 * part)
            p.renderer.camera.SetWindowCenter(1.0 - part, 0.0)
        else:
            p.remove_actor("glyphs")
            win._field_legend.hide()
    p.subplot(0, 0)

def _show_legend(win, actor) -> float:
    """The blur legend at the field panel's right edge, its labels' room measured; returns
    its left edge as a fraction of the panel's width."""
    legend = win._field_legend
    vw, _ = legend.renderer.GetSize()
    lo, hi = actor.mapper.scalar_range
    x0 = max(0.5, 1.0 - legend.room_px((lo, hi), "arcmin", win.font) / max(vw, 1))
    legend.show(actor.mapper.lookup_table, (lo, hi), "arcmin",
                box=(x0, 0.1, x0 + RAMP_PX / max(vw, 1), 0.62), size=win.font)
    return x0

