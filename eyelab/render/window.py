"""The VTK layer of the raster renderer: one offscreen render window with its renderer,
the displacement shaders (GLSL in ``shaders/*.glsl``, injected through one tag-checking
helper), the blur field as a 3D texture, per-pass uniforms, colour and depth read-back.
"""

from __future__ import annotations

import time
import weakref
from collections import OrderedDict
from importlib import resources

import numpy as np

from eyelab.blur.field import PassField
from eyelab.core.interrupt import deferred
from eyelab.render import _vtk

#: The ``tile`` uniform (NDC scale x, y and centre x, y of the rendered rectangle in the
#: whole view) of a whole-view render.
WHOLE_VIEW = (1.0, 1.0, 0.0, 0.0)

#: Vertex shader tags measured to exist in VTK 9.7 (docs/VTK_NOTES.md Q5).
VERTEX_TAGS = ("//VTK::PositionVC::Dec", "//VTK::PositionVC::Impl",
               "//VTK::CustomBegin::Impl", "//VTK::CustomEnd::Impl")

#: Actors a window keeps built while not shown (a scene's meshes for another field, or
#: another colour channel's on the attribute route).
SPARE_ACTORS = 48

#: Field textures a window keeps uploaded (one per colour channel, plus one spare).
FIELD_TEXTURES = 4

#: Passes' displacement textures of ray-aberration maps a window keeps uploaded: the
#: default frame's 8 passes x 3 colour channels, with room; each is the field's grid of
#: RGBA32F (2 MB at the default 128 x 32 x 32), so at most 64 MB a window.
PASS_TEXTURES = 32

#: Fragment shader tags used: the late hook after VTK has set ``fragOutput0``, and the
#: texture-coordinate declarations (where inputs of a vertex shader's outputs go).
FRAGMENT_TAGS = ("//VTK::DepthPeeling::Impl", "//VTK::TCoord::Dec")

#: The shader files of each blur-field route (see :class:`OffscreenWindow.use_field`).
ROUTE_SHADERS = {"attribute": ("displace.dec", "displace.impl"),
                 "texture": ("field3d.dec", "field3d.impl")}


def glsl(name: str) -> str:
    """Text of ``eyelab/render/shaders/<name>.glsl``."""
    return resources.files("eyelab.render").joinpath(f"shaders/{name}.glsl").read_text()


def inject_vertex(shader_property, name: str) -> None:
    """Apply ``shaders/<name>.glsl`` as a vertex-shader replacement. The file's first line
    must be the VTK tag it replaces (kept in the replacement, so VTK's own code stays)."""
    tag, text = _tagged(name, VERTEX_TAGS)
    shader_property.AddVertexShaderReplacement(tag, True, text, False)


def inject_fragment(shader_property, name: str) -> None:
    """Apply ``shaders/<name>.glsl`` as a fragment-shader replacement (as
    :func:`inject_vertex`)."""
    tag, text = _tagged(name, FRAGMENT_TAGS)
    shader_property.AddFragmentShaderReplacement(tag, True, text, False)


def _tagged(name, known):
    text = glsl(name)
    tag = text.splitlines()[0].strip()
    if tag not in known:
        raise ValueError(f"shader {name!r} starts with unknown tag {tag!r}; known: {known}")
    return tag, text


class OffscreenWindow:
    """One offscreen render window and renderer, MSAA off.

    Every displaced actor shares one shader property per route, so there is one GL program
    per shading variant (textured / coloured), compiled once per window, and a pass only
    changes the ``seed`` / ``jitter`` uniforms (docs/VTK_NOTES.md Q1). ``render_s`` /
    ``readback_s`` accumulate the time spent inside ``Render()`` and in read-back.
    """

    def __init__(self):
        self.win = _vtk.vtkRenderWindow()
        self.win.SetOffScreenRendering(1)
        self.win.SetMultiSamples(0)
        self.ren = _vtk.vtkRenderer()
        self.win.AddRenderer(self.ren)
        self.size = (0, 0)
        # one property per (route, textured): textured actors sample sRGB textures in
        # linear light and re-encode their output (encode_srgb.frag)
        self.shaders = {}
        for route, names in ROUTE_SHADERS.items():
            for textured in (False, True):
                sp = _vtk.vtkOpenGLShaderProperty()
                for name in names:
                    inject_vertex(sp, name)
                if textured:
                    inject_fragment(sp, "encode_srgb.frag")
                sp.GetVertexCustomUniforms().SetUniform2f("seed", [0.0, 0.0])
                sp.GetVertexCustomUniforms().SetUniform2f("jitter", [0.0, 0.0])
                sp.GetVertexCustomUniforms().SetUniform4f("tile", list(WHOLE_VIEW))
                self.shaders[route, textured] = sp
        self.route = "attribute"
        self.actors = {}
        self._spare = OrderedDict()
        self._variant_warmed = False       # warm_variants(): both mip-map states drawn
        self.field_texture = None          # the current one, bound before each draw
        self.field_texture_key = None
        self._textures = OrderedDict()       # key -> (texture object, its data), LRU
        self._pass_textures = OrderedDict()  # the same for passes' displacements
        self.render_s = 0.0
        self.readback_s = 0.0
        self._buf = _vtk.vtkUnsignedCharArray()
        self._rect_buf = _vtk.vtkUnsignedCharArray()
        self._jitter_px = (0.0, 0.0)
        self._fov_y_deg = 30.0

    def _route_shaders(self):
        return [self.shaders[self.route, t] for t in (False, True)]

    def set_seed(self, seed, jitter_px=(0.0, 0.0)) -> None:
        """Per-pass uniforms: the unit-disc seed and a sub-pixel offset (pixels)."""
        self._jitter_px = (float(jitter_px[0]), float(jitter_px[1]))
        for sp in self._route_shaders():
            sp.GetVertexCustomUniforms().SetUniform2f("seed", [float(seed[0]),
                                                               float(seed[1])])
        self._set_jitter(self.size)

    def _set_jitter(self, size) -> None:
        """The pass's sub-pixel offset as NDC of a viewport of ``size`` = (w, h) px."""
        w, h = size
        for sp in self._route_shaders():
            sp.GetVertexCustomUniforms().SetUniform2f(
                "jitter", [2.0 * self._jitter_px[0] / max(w, 1),
                           2.0 * self._jitter_px[1] / max(h, 1)])

    def use_field(self, field, route: str) -> None:
        """Select the route. "texture": the field as a 3D RGBA32F texture (linear filtering,
        clamp-to-edge) sampled in the vertex shader, uploaded once per field and kept (up to
        :data:`FIELD_TEXTURES`, so that per-channel fields switch without uploads)
        (docs/VTK_NOTES.md Q2, route A); "attribute": matrices looked up per vertex on the
        CPU (route D)."""
        self.route = route
        if route != "texture":
            return
        cam = field.camera
        for sp in self._route_shaders():
            u = sp.GetVertexCustomUniforms()
            u.SetUniformf("depthMode", 0.0 if field.depth_mode == "ndc" else 1.0)
            u.SetUniformf("nearPlane", float(cam.near))
            u.SetUniformf("farPlane", float(cam.far))
        if self.field_texture_key == field.key:
            return
        # a pass's own displacement (a ray-aberration map) is kept apart, for the next
        # frame's same pass: a frame of S passes and C channels uses S x C of them
        store, limit = ((self._pass_textures, PASS_TEXTURES)
                        if isinstance(field, PassField) else (self._textures, FIELD_TEXTURES))
        kept = store.pop(field.key, None)
        if kept is None:
            self.win.Initialize()
            tex = _vtk.vtkTextureObject()
            tex.SetContext(self.win)
            nz, ny, nx = field.shape
            data = field.texture_rgba()                  # kept alive while uploaded
            tex.Create3DFromRaw(nx, ny, nz, 4, _vtk.VTK_FLOAT, data)
            for f in (tex.SetWrapS, tex.SetWrapT, tex.SetWrapR):
                f(_vtk.vtkTextureObject.ClampToEdge)
            tex.SetMinificationFilter(_vtk.vtkTextureObject.Linear)
            tex.SetMagnificationFilter(_vtk.vtkTextureObject.Linear)
            kept = (tex, data)
        store[field.key] = kept
        while len(store) > limit:
            _, (old, _) = store.popitem(last=False)
            old.ReleaseGraphicsResources(self.win)
        if self.field_texture is not None and self.field_texture is not kept[0]:
            # one field is bound per draw: give its texture unit back (a kept texture
            # that stays active holds a unit, and a GL has only so many: 32 here)
            self.field_texture.Deactivate()
        self.field_texture = kept[0]
        self.field_texture_key = field.key

    def show(self, items) -> list:
        """Show exactly the actors of ``items`` [(key, factory)], reusing the ones already
        built under the same key; returns them. Actors not shown stay built (up to
        :data:`SPARE_ACTORS`, least recently shown released first, GL resources included),
        so that views alternating between two sets rebuild nothing."""
        keep = {}
        self.ren.RemoveAllViewProps()
        for key, factory in items:
            actor = self.actors.get(key)
            if actor is None:
                actor = self._spare.pop(key, None)
            if actor is None:
                actor = self._build(factory)
            keep[key] = actor
            self.ren.AddActor(actor)
        for key, actor in self.actors.items():
            if key not in keep:
                self._spare[key] = actor
        while len(self._spare) > SPARE_ACTORS:
            release_actor(self._spare.popitem(last=False)[1], self.win)
        self.actors = keep
        return list(keep.values())

    def _build(self, factory):
        """A new actor from ``factory()`` with the route's shader (and field texture)."""
        actor = factory()
        actor.SetShaderProperty(self.shaders[self.route, actor.GetTexture() is not None])
        if self.route == "texture":
            bind_field_texture(actor.GetMapper(), self)
        return actor

    def warm(self, items, textured_per_step: int = 1):
        """A generator pausing (None) after each render: the actors of ``items`` [(key,
        factory)] not built yet are built and drawn, :data:`textured_per_step` textured
        ones a render (their textures' upload and mip-map chains are built there) and the
        others together, then kept for :meth:`show` — so that an interactive window's
        first pass does not upload every texture in one GL call (16 mip-mapped textures of
        the built-in room: 0.5 s). The image drawn is thrown away; the next :meth:`show`
        sets the actors shown."""
        new = [(k, f) for k, f in items if k not in self.actors and k not in self._spare]
        if not new:
            return
        built = []
        for key, factory in new:
            actor = self._build(factory)
            self._spare[key] = actor
            built.append(actor)
        plain = [a for a in built if a.GetTexture() is None]
        textured = [a for a in built if a.GetTexture() is not None]
        groups = ([plain] if plain else []) + [
            textured[i:i + textured_per_step] for i in range(0, len(textured),
                                                            textured_per_step)]
        self._clear_shown()
        for group in groups:
            for actor in group:
                self.ren.AddActor(actor)
            with deferred():
                self.win.Render()
            self.ren.RemoveAllViewProps()
            yield None

    def _clear_shown(self) -> None:
        """Nothing drawn; the actors shown so far kept as spares (still reusable by
        :meth:`show`)."""
        self.ren.RemoveAllViewProps()
        for key, actor in self.actors.items():
            self._spare[key] = actor
        self.actors = {}

    def warm_variants(self, cam):
        """Once per window, a generator pausing after each of two renders: a tiny texture
        drawn through the texture route (a zero one-voxel field, ``cam``'s depth range) in
        each mip-map state. The software GL compiles a fragment-shader variant per sampler
        state at its first draw (measured: 0.13-0.2 s for the mip-mapped one), which the
        first change to S < :data:`~eyelab.render.stages.MIPMAP_BELOW_SAMPLES`, or the
        first naked view after the lens covered it, would otherwise pay inside one of an
        interactive window's ticks; an interactive renderer pays it while it sets up its
        first frame."""
        if self._variant_warmed:
            return
        self._variant_warmed = True
        from eyelab.render.actors import mesh_actor
        from eyelab.scene.scene import SceneMesh

        self.use_field(PassField(cam, (1, 1, 1), "ndc", ("variant",),
                                 lambda: np.zeros((1, 1, 1, 4), np.float32)), "texture")
        quad = SceneMesh("variant", np.array([[-1, -1, -2], [1, -1, -2], [1, 1, -2],
                                              [-1, 1, -2]], float),
                         np.array([[0, 1, 2], [0, 2, 3]]), None, np.zeros((4, 4, 3), np.uint8),
                         np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float))
        self._clear_shown()
        for mipmap in (False, True):
            actor = self._build(lambda m=mipmap: mesh_actor(quad, mipmap=m))
            self.ren.AddActor(actor)
            with deferred():
                self.win.Render()
            self.ren.RemoveAllViewProps()
            release_actor(actor, self.win)
            yield None

    def set_view(self, cam, size, background) -> None:
        """Camera (eyelab :class:`~eyelab.optics.rays.camera.Camera`), window size (w, h) and
        background (sRGB uint8 triple)."""
        self.set_frustum(cam.position, cam.basis[2], cam.basis[1], cam.fov_y_deg, cam.near,
                         cam.far, size, background)

    def set_frustum(self, position, forward, up, fov_y_deg, near, far, size,
                    background) -> None:
        """A symmetric perspective frustum without :class:`~eyelab.optics.rays.camera.Camera`'s
        limits (the image-based renderer's slices can be narrower than 1°): position,
        unit forward and up (3,), vertical field of view (deg), clipping (m), window size
        (w, h) and background (sRGB uint8 triple)."""
        if tuple(size) != self.size:
            self.win.SetSize(int(size[0]), int(size[1]))
            self.size = tuple(size)
        c = self.ren.GetActiveCamera()
        pos = np.asarray(position, float)
        c.SetPosition(*pos)
        c.SetFocalPoint(*(pos + np.asarray(forward, float)))
        c.SetViewUp(*np.asarray(up, float))
        c.SetViewAngle(fov_y_deg)
        self._fov_y_deg = float(fov_y_deg)
        c.SetClippingRange(near, far)
        self.ren.SetBackground(*(np.asarray(background, float) / 255.0))

    def undisplaced_depth(self) -> np.ndarray:
        """Render the view with no displacement and no jitter (seed and jitter zero) and
        return its z-buffer (h, w) in [0, 1], row 0 at the bottom: where each pixel's
        surface is, seen along its own line of sight (what the reconstruction filter and
        the colour channels' rectangles look the field up by; a displaced pass's depth
        would move every edge by that pass's seed). The next pass sets its own seed."""
        self.set_seed((0.0, 0.0), (0.0, 0.0))
        t0 = time.perf_counter()
        with deferred():
            self.win.Render()
        self.render_s += time.perf_counter() - t0
        return self.depth()

    def depth(self) -> np.ndarray:
        """(h, w) z-buffer of the last render in [0, 1], row 0 at the bottom."""
        w, h = self.size
        arr = _vtk.vtkFloatArray()
        self.win.GetZbufferData(0, 0, w - 1, h - 1, arr)
        return _vtk.vtk_to_numpy(arr).reshape(h, w).copy()

    def grab_rgba(self) -> np.ndarray:
        """Render and read RGBA (h, w, 4) uint8 (a view of a reused buffer: copy or consume
        before the next grab), row 0 at the bottom (GL order)."""
        t0 = time.perf_counter()
        with deferred():     # VTK calls back into Python while it renders; a Ctrl-C in a
            self.win.Render()   # callback would make VTK exit(1): delivered after instead
        t1 = time.perf_counter()
        w, h = self.size
        self.win.GetRGBACharPixelData(0, 0, w - 1, h - 1, 0, self._buf)
        out = _vtk.vtk_to_numpy(self._buf).reshape(h, w, 4)
        self.render_s += t1 - t0
        self.readback_s += time.perf_counter() - t1
        return out

    def grab_rect_rgba(self, rect) -> np.ndarray:
        """Render only the pixels of ``rect`` = (x0, y0, x1, y1) (GL order: row 0 at the
        bottom; x1, y1 exclusive) as they are in the whole view, and read them as RGBA
        (y1 - y0, x1 - x0, 4) uint8 (a view of a reused buffer). The renderer's viewport is
        the rectangle and the camera's frustum its part of the whole one (the view angle
        scaled, the window centre moved); the shaders' ``tile`` uniform maps the
        rectangle's NDC back to the whole view's, so the field is looked up, and displaces,
        as in a whole-view render, and the jitter stays the same in pixels. The rasteriser
        fills only the rectangle (its cost follows its area: docs/VTK_NOTES.md)."""
        import math

        x0, y0, x1, y1 = (int(v) for v in rect)
        w, h = self.size
        sx, sy = (x1 - x0) / w, (y1 - y0) / h
        cx, cy = (x0 + x1) / w - 1.0, (y0 + y1) / h - 1.0
        cam = self.ren.GetActiveCamera()
        tan_y = math.tan(math.radians(self._fov_y_deg) / 2)
        cam.SetViewAngle(2 * math.degrees(math.atan(tan_y * sy)))
        cam.SetWindowCenter(cx / sx, cy / sy)
        self.ren.SetViewport(x0 / w, y0 / h, x1 / w, y1 / h)
        self._set_tile((sx, sy, cx, cy), (x1 - x0, y1 - y0))
        try:
            t0 = time.perf_counter()
            with deferred():
                self.win.Render()
            t1 = time.perf_counter()
            self.win.GetRGBACharPixelData(x0, y0, x1 - 1, y1 - 1, 0, self._rect_buf)
            out = _vtk.vtk_to_numpy(self._rect_buf).reshape(y1 - y0, x1 - x0, 4)
            self.render_s += t1 - t0
            self.readback_s += time.perf_counter() - t1
        finally:
            cam.SetViewAngle(self._fov_y_deg)
            cam.SetWindowCenter(0.0, 0.0)
            self.ren.SetViewport(0.0, 0.0, 1.0, 1.0)
            self._set_tile(WHOLE_VIEW, self.size)
        return out

    def _set_tile(self, tile, size) -> None:
        for sp in self._route_shaders():
            sp.GetVertexCustomUniforms().SetUniform4f("tile", [float(v) for v in tile])
        self._set_jitter(size)

    def grab(self) -> np.ndarray:
        """Render and read RGB (h, w, 3) uint8 (a copy), row 0 at the top."""
        return self.grab_rgba()[::-1, :, :3].copy()

    def _release_field_texture(self):
        for store in (self._textures, self._pass_textures):
            for tex, _ in store.values():
                tex.ReleaseGraphicsResources(self.win)
            store.clear()
        self.field_texture = None
        self.field_texture_key = None

    def close(self) -> None:
        """Release every actor, the field texture and the GL context."""
        self.ren.RemoveAllViewProps()
        for actor in list(self.actors.values()) + list(self._spare.values()):
            release_actor(actor, self.win)
        self.actors.clear()
        self._spare.clear()
        self._release_field_texture()
        self.win.Finalize()


def bind_field_texture(mapper, window: OffscreenWindow) -> None:
    """Bind the window's field texture to the mapper's shader program before each draw
    (UpdateShaderEvent fires on vtkOpenGLPolyDataMapper; docs/VTK_NOTES.md Q2, route
    A). The callback holds the window weakly, so the window and its actors never keep each
    other alive."""
    ref = weakref.ref(window)

    @_vtk.calldata_type(_vtk.VTK_OBJECT)
    def bind(caller, event, program):   # runs inside Render(), signals deferred there
        w = ref()
        tex = None if w is None else w.field_texture
        if tex is not None and program is not None:
            tex.Activate()
            program.SetUniformi("blurField", tex.GetTextureUnit())

    mapper._eyelab_observer = mapper.AddObserver(_vtk.vtkCommand.UpdateShaderEvent, bind)


def release_actor(actor, win=None) -> None:
    """Free an actor's GL resources (buffers, textures) in ``win`` and drop its observers
    and inputs so that its polydata and textures can be freed."""
    if win is not None:
        actor.ReleaseGraphicsResources(win)
        tex = actor.GetTexture()
        if tex is not None:
            tex.ReleaseGraphicsResources(win)
    mapper = actor.GetMapper()
    if mapper is not None:
        mapper.RemoveAllObservers()
        mapper.SetInputData(None)
    actor.SetTexture(None)
