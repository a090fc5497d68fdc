"""Compositing the view through the lens into the naked-eye view (Kakimoto 2007, §3.2).

The lens is drawn from the eye as a grid mesh on its back surface, textured with the
blurred environment image at the per-vertex texture coordinates of the exactly refracted
rays, in one draw: each colour channel at its own wavelength's coordinates (vertex
attributes ``uvR`` / ``uvB`` beside VTK's tcoord for green) and times the lens's Fresnel
transmittance (attribute ``lensT``), in linear light (``shaders/lensview.*.glsl``). Its
outline, the pixels whose rays fail in the lens (drawn in a defined 'invalid' colour) and
the rim come from the polar outline mesh. Actors are built once per compositor and their
data updated.
"""

from __future__ import annotations

import time
from contextlib import contextmanager

import numpy as np

from eyelab.core.cache import LRUCache
from eyelab.render import _vtk
from eyelab.render.actors import (
    add_point_array,
    image_data,
    polydata,
    set_faces,
    set_geometry,
    set_image_rgba_gl,
    set_tcoords,
    unlit_actor,
)
from eyelab.render.window import OffscreenWindow, inject_fragment, inject_vertex

#: The lens grid's own vertex attributes (besides VTK's tcoord, the green channel's
#: coordinates): the red and blue channels' coordinates and the transmittance (R, G, B).
LENS_ATTRIBUTES = ("uvR", "uvB", "lensT")


class LensCompositor:
    """Draws the textured lens and its masks in an :class:`OffscreenWindow` (the eye's);
    the window's own actors are hidden meanwhile. ``masks``: where masks are cached."""

    def __init__(self, window: OffscreenWindow, masks: LRUCache):
        self.window = window
        self.masks_cache = masks
        self._image = image_data(np.zeros((2, 2, 3), np.uint8))
        tex = _vtk.vtkTexture()
        tex.SetInputData(self._image)
        tex.UseSRGBColorSpaceOn()           # sampled and filtered in linear light ...
        tex.InterpolateOn()
        tex.RepeatOff()
        tex.EdgeClampOn()
        tex.SetColorModeToDirectScalars()
        self._pd = polydata(np.zeros((3, 3)), np.array([[0, 1, 2]]))
        self._actor = unlit_actor(self._pd, tex)
        sp = _vtk.vtkOpenGLShaderProperty()
        for name in ("lensview.dec", "lensview.impl"):
            inject_vertex(sp, name)
        for name in ("lensview.frag.dec", "lensview.frag"):   # ... and re-encoded
            inject_fragment(sp, name)
        self._actor.SetShaderProperty(sp)
        mapper = self._actor.GetMapper()
        for name in LENS_ATTRIBUTES:
            mapper.MapDataArrayToVertexAttribute(
                name, name, _vtk.vtkDataObject.FIELD_ASSOCIATION_POINTS, -1)
        self._grid_key = None
        self._mask_pd = polydata(np.zeros((3, 3)), np.array([[0, 1, 2]]))
        self._mask_actor = unlit_actor(self._mask_pd)
        m = self._mask_actor.GetMapper()
        m.SetScalarModeToUsePointFieldData()
        m.SelectColorArray("colors")
        m.SetColorModeToDirectScalars()
        m.ScalarVisibilityOn()

    @contextmanager
    def _lens_stage(self):
        """Hide the window's actors, black background, near clipping range for the lens
        (~12 mm from the eye); restore all of it afterwards."""
        ren = self.window.ren
        saved = list(self.window.actors.values())
        for a in saved:
            a.VisibilityOff()
        bg = ren.GetBackground()
        ren.SetBackground(0, 0, 0)
        cam = ren.GetActiveCamera()
        clip = cam.GetClippingRange()
        cam.SetClippingRange(1e-3, 1.0)
        try:
            yield ren
        finally:
            ren.SetBackground(*bg)
            cam.SetClippingRange(*clip)
            for a in saved:
                a.VisibilityOn()

    def lens_view(self, env_rgba: np.ndarray, grid_v, grid_f, uv_sets, transmittance,
                  grid_key) -> np.ndarray:
        """(h, w, 3) uint8, row 0 at the top: the lens grid (vertices (n, 3), faces) textured
        with ``env_rgba`` (h_e, w_e, 4) uint8 (GL row order, opaque) at ``uv_sets``
        (channels, n, 2) — channel c of the result from set c (R, G, B), or every channel
        from a single set — times ``transmittance`` (channels, n) or None (1), in one
        draw. The grid's attributes are uploaded when ``grid_key`` changes."""
        if grid_key != self._grid_key:
            set_geometry(self._pd, grid_v, grid_f)
            self._set_uv(uv_sets)
            n = len(grid_v)
            t = (np.ones((3, n)) if transmittance is None
                 else np.broadcast_to(np.asarray(transmittance, float), (3, n)))
            add_point_array(self._pd, "lensT", t.T)
            self._grid_key = grid_key
        set_image_rgba_gl(self._image, env_rgba)
        with self._lens_stage() as ren:
            ren.AddActor(self._actor)
            try:
                rgba = self.window.grab_rgba()           # GL order: row 0 at the bottom
            finally:
                ren.RemoveActor(self._actor)
        return rgba[::-1, :, :3].copy()

    def _set_uv(self, uv_sets) -> None:
        uv = [uv_sets[0]] * 3 if len(uv_sets) == 1 else list(uv_sets)
        set_tcoords(self._pd, uv[1])
        add_point_array(self._pd, "uvR", uv[0])
        add_point_array(self._pd, "uvB", uv[2])

    def moved_views(self, env_rgba, uv_sets, transmittance, moves, rect):
        """After :meth:`lens_view` (its grid uploaded), the grid's triangles ``f`` textured
        with ``env_rgba`` (its shape) at ``uv_sets + m`` times ``transmittance`` (as
        :meth:`lens_view`'s) times ``w`` for each (m (channels, n, 2), w (n,), f (k, 3)) of
        ``moves``: yields each view's pixels in ``rect`` = (x0, y0, x1, y1) (GL order, x1,
        y1 exclusive) as (y1 - y0, x1 - x0, 4) uint8 RGBA, GL order (a view of a reused
        buffer: consume it before the next); only the rectangle is rendered and read
        (:meth:`~eyelab.render.window.OffscreenWindow.grab_rect_rgba`), and only the
        triangles given are rasterised (the others' pixels are black)."""
        self._grid_key = None                 # the attributes below are not the grid's own
        set_image_rgba_gl(self._image, env_rgba)
        n = len(uv_sets[0])
        t = (np.ones((3, n)) if transmittance is None
             else np.broadcast_to(np.asarray(transmittance, float), (3, n)))
        with self._lens_stage() as ren:
            ren.AddActor(self._actor)
            try:
                for m, w, f in moves:
                    set_faces(self._pd, f)
                    self._set_uv(uv_sets + m)
                    add_point_array(self._pd, "lensT", (t * w).T)
                    yield self.window.grab_rect_rgba(rect)
            finally:
                ren.RemoveActor(self._actor)

    def masks(self, lens_v, lens_f, valid, key):
        """(invalid, inside, rim) (h, w) bool masks of the lens outline mesh: inside the
        outline; inside and drawn from vertices whose rays fail (``valid`` (n,) False); the
        outline's one-pixel rim. Cached under ``key``."""
        hit = self.masks_cache.get(key)
        if hit is not None:
            return hit
        set_geometry(self._mask_pd, lens_v, lens_f)
        with self._lens_stage() as ren:
            ren.AddActor(self._mask_actor)
            try:
                vimg = self._draw_mask(np.where(valid, 255, 0).astype(np.uint8))
                mimg = self._draw_mask(np.full(len(lens_v), 255, np.uint8))
            finally:
                ren.RemoveActor(self._mask_actor)
        inside = mimg > 127
        out = (inside & (vimg < 128), inside, inside & ~erode(inside))
        self.masks_cache.put(key, out)
        return out

    def _draw_mask(self, grey):
        col = _vtk.numpy_to_vtk(np.repeat(grey[:, None], 3, 1), deep=True)
        col.SetName("colors")
        self._mask_pd.GetPointData().AddArray(col)
        self._mask_pd.Modified()
        return self.window.grab()[..., 0]

    def close(self) -> None:
        for actor in (self._actor, self._mask_actor):
            actor.GetMapper().SetInputData(None)
            actor.SetTexture(None)


def compose(naked, lens_img, masks, rim_color, invalid_color) -> np.ndarray:
    """The lens view inside the outline, the naked view around it, the invalid pixels and
    the rim in their colours. All (h, w, 3) uint8 / (h, w) bool."""
    invalid, inside, rim = masks
    out = np.where(inside[..., None], lens_img, naked)
    out[invalid] = invalid_color
    out[rim] = rim_color
    return out


def erode(mask: np.ndarray) -> np.ndarray:
    """4-neighbour binary erosion of an (h, w) bool mask (edges kept as outside-neutral)."""
    m = mask.copy()
    m[1:] &= mask[:-1]
    m[:-1] &= mask[1:]
    m[:, 1:] &= mask[:, :-1]
    m[:, :-1] &= mask[:, 1:]
    return m


def frame_image(naked_rgba, env_rgba, env, view, q, report, compositor):
    """A generator (pausing as :func:`composite_frame` does) whose value is (uint8 image
    (h, w, 3), layers) of a raster frame: the naked view's averaged RGBA ``naked_rgba``
    (GL order; None where the lens covers the view: the quality's invalid colour) with,
    when there is an environment stage ``env``, the lens's view of ``env_rgba``
    composited by ``compositor()`` (a :class:`LensCompositor`)."""
    if naked_rgba is not None:
        image = naked_rgba[::-1, :, :3]
        layers = {"naked": image}
    else:   # covered by the lens: every pixel is the lens's (a stray one: invalid colour)
        image = np.empty((view.height, view.width, 3), np.uint8)
        image[:] = q.invalid_color
        layers = {}
    if env is None:
        return image, layers
    return (yield from composite_frame(compositor(), image, layers, env, env_rgba, q, report))


def composite_frame(compositor, image, layers, env, env_rgba, q, report):
    """A generator pausing (None) between a lenslet lens's groups of moved views
    (:func:`~eyelab.render.lensletview.lenslet_lens_view`) and before the lens outline's
    masks are drawn anew, whose value is (image, layers)
    with the lens's view composited over the eye's ``image`` (uint8
    (h, w, 3)): the environment stage ``env``'s averaged RGBA ``env_rgba`` mapped through
    the lens by ``compositor`` (:class:`LensCompositor`; a lenslet lens's views by
    :func:`~eyelab.render.lensletview.lenslet_lens_view`), the rim and invalid pixels
    coloured by the quality ``q``; the report's lens pixel counts and its
    ``lens_composite`` time updated."""
    from eyelab.render.lensletview import lenslet_lens_view

    t = time.perf_counter()
    geo = env["geo"]
    if env["lenslets"] is not None:
        lo = env["lenslets"]                 # its spread in environment pixels
        spread = lo.cell_sigma_rad * env_rgba.shape[1] / (2 * env["cam"].tan_half[0])
        lens_img = yield from lenslet_lens_view(compositor, env_rgba, geo, lo,
                                                env["geo_key"], env["eye_cam"], spread, report)
    else:
        lens_img = compositor.lens_view(env_rgba, geo["grid_v"], geo["grid_f"],
                                        geo["tc_grid"].uv, geo["transmittance"],
                                        env["geo_key"])
    mkey = ("masks", env["geo_key"], compositor.window.size)
    if mkey not in compositor.masks_cache:
        yield None                      # the masks' two renders: a tick of their own
    masks = compositor.masks(geo["lens_v"], geo["lens_f"], geo["tc"].lens_ok.all(0), mkey)
    image = compose(image, lens_img, masks, q.rim_color, q.invalid_color)
    invalid, inside, _ = masks
    report["details"]["lens"].update(pixels_inside=int(inside.sum()),
                                     pixels_invalid=int(invalid.sum()))
    layers.update(environment=env_rgba[::-1, :, :3], lens_mask=inside)
    tm = report["timings_s"]
    tm["lens_composite"] = tm.get("lens_composite", 0.0) + time.perf_counter() - t
    return image, layers
