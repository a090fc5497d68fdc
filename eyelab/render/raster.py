"""The real-time renderer (Kakimoto et al. 2007, §3 and §4.5), on VTK, offscreen-first.

Per frame:

1. naked-eye view: the scene from the eye camera, each vertex displaced in NDC by its
   naked-eye blur-field matrix times a per-pass seed (vertex shader), S passes averaged;
2. through the lens (only if the lens is in view): the same with the virtual camera and the
   through-lens blur field -> the environment image; per-vertex ray tracing gives every
   lens vertex its texture coordinates into it (one set per colour channel when the lens
   disperses); the lens is drawn from the eye with them;
3. composite: the lens view inside the lens's outline, the naked view around it, the rim.

Blur-field matrices are looked up per vertex on the CPU (trilinear, as a 3D texture is
sampled; VTK_NOTES route D) and passed as a vertex attribute, so a pass only changes the
``seed`` uniform: no shader rebuild, no data upload. Accumulation: 8-bit read-back summed
in uint16 (S <= 256).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import vtk
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy

from eyelab.blur.bundle import disc_seeds
from eyelab.blur.wavefront import compute_blur_field
from eyelab.errors import SpecError, check_range
from eyelab.optics.camera import Camera, eye_camera, fit_virtual_camera
from eyelab.optics.materials import RGB_WAVELENGTHS_NM
from eyelab.render.shader import inject_vertex
from eyelab.render_support import pixel_jitter
from eyelab.scene.pervertex import lens_texcoords
from eyelab.scene.raycast import EmbreeIntersector
from eyelab.scene.refine import refine_for_fields
from eyelab.scene.scene import Scene, SceneMesh


@dataclass(frozen=True)
class RenderSettings:
    """width, height: pixels (16-4096); samples: S passes (1-256); fov_y_deg; near, far (m);
    field_shape: blur-field grid (nz, ny, nx); chromatic: R/G/B refraction through the lens;
    refine: adaptive tessellation; lens_rings/lens_segments: lens mesh resolution;
    focus: None (best accommodation per voxel) or a fixed accommodation (D)."""

    width: int = 640
    height: int = 480
    samples: int = 10
    fov_y_deg: float = 60.0
    near: float = 0.05
    far: float = 100.0
    field_shape: tuple = (128, 32, 32)
    chromatic: bool = True
    refine: bool = True
    lens_rings: int = 24
    lens_segments: int = 96
    #: the lens mesh that carries the texture coordinates: vertices where eye rays on a grid
    #: of this many pixels meet the back surface (the warp is sampled evenly over the view;
    #: the polar rings x segments mesh gives the lens's outline)
    lens_grid_px: int = 8
    focus: float | None = None
    rim_color: tuple = (30, 30, 30)
    invalid_color: tuple = (128, 128, 128)
    #: skip passes a scene does not need (an all-zero field -> 1 pass); False only to
    #: measure what the skipping saves
    skip_unneeded: bool = True
    #: colour-vision deficiency post-process: None, "protan", "deutan", "tritan", "achromat"
    cvd: str | None = None
    cvd_severity: float = 1.0
    #: "texture": the field as a 3D float texture sampled in the vertex shader (default);
    #: "attribute": matrices looked up per vertex on the CPU (fallback, VTK_NOTES route D)
    field_route: str = "texture"
    #: environment-image pixels per radian relative to the eye view's: the lens view is
    #: resampled from it, so it needs more than the final image's density (1.5 = 2.25x pixels)
    env_oversample: float = 1.5
    #: jitter each pass by a sub-pixel offset (R2 sequence): the S passes antialias too
    antialias: bool = True
    #: reconstruction filter: S displaced copies sample each blur disc at S points, which
    #: ghosts when the disc spans many pixels; each pixel is smoothed by a Gaussian of
    #: RECON_SIGMA x the spacing of the S samples in its own blur disc (from the depth buffer
    #: and the field; in-focus pixels untouched). Off by default: it costs ~0.1-0.25 s per
    #: 1024x768 frame on the CPU (scipy), for accuracy rather than interactivity
    reconstruct: bool = False

    def __post_init__(self):
        check_range("render.width", self.width, 16, 4096)
        check_range("render.height", self.height, 16, 4096)
        check_range("render.samples", self.samples, 1, 256)
        check_range("render.fov_y_deg", self.fov_y_deg, 1, 150)
        check_range("render.near", self.near, 1e-3, 10)
        from eyelab.color import CVD_KINDS

        if self.cvd is not None and self.cvd not in CVD_KINDS:
            raise SpecError("render.cvd", f"must be one of {CVD_KINDS}, got {self.cvd!r}")
        check_range("render.cvd_severity", self.cvd_severity, 0.0, 1.0)
        if self.field_route not in ("texture", "attribute"):
            raise SpecError("render.field_route", f"must be 'texture' or 'attribute', got "
                            f"{self.field_route!r}")
        if not self.far > self.near:
            raise SpecError("render.far", f"must be > near ({self.near}), got {self.far}")

    def eye_camera(self) -> Camera:
        return eye_camera(self.fov_y_deg, self.width / self.height, self.near, self.far)


@dataclass
class RenderResult:
    image: np.ndarray                 # (h, w, 3) uint8, row 0 at the top
    report: dict
    progressive: list = field(default_factory=list)   # [(passes, image)] if asked
    naked: np.ndarray | None = None
    environment: np.ndarray | None = None
    lens_mask: np.ndarray | None = None       # (h, w) bool: pixels seen through the lens


def seeds_for(samples: int) -> np.ndarray:
    """The fixed seed set for S passes: the centre for S = 1, else Vogel's spiral (equal-area
    points of the unit disc), so the same S gives the same image."""
    return np.zeros((1, 2)) if samples == 1 else disc_seeds(samples)


class _Window:
    """One offscreen render window with its renderer."""

    def __init__(self):
        self.win = vtk.vtkRenderWindow()
        self.win.SetOffScreenRendering(1)
        self.win.SetMultiSamples(0)
        self.ren = vtk.vtkRenderer()
        self.win.AddRenderer(self.ren)
        self.size = (0, 0)
        # one shader property for every displaced actor: one GL program per shading
        # variant (textured / coloured), compiled once per window; one uniform per pass
        self.shaders = {}
        for route, names in (("attribute", ("displace.dec", "displace.impl")),
                             ("texture", ("field3d.dec", "field3d.impl"))):
            sp = vtk.vtkOpenGLShaderProperty()
            for name in names:
                inject_vertex(sp, name)
            sp.GetVertexCustomUniforms().SetUniform2f("seed", [0.0, 0.0])
            sp.GetVertexCustomUniforms().SetUniform2f("jitter", [0.0, 0.0])
            self.shaders[route] = sp
        self.shader = self.shaders["attribute"]
        self.actors = {}
        self.field_texture = None
        self.field_texture_key = None
        self.render_s = 0.0      # time spent inside Render() (pure rendering + GPU sync)
        self.readback_s = 0.0
        self._buf = vtk.vtkUnsignedCharArray()

    def set_seed(self, seed, jitter_px=(0.0, 0.0)):
        """Per-pass uniforms: the unit-disc seed and a sub-pixel offset (pixels)."""
        u = self.shader.GetVertexCustomUniforms()
        u.SetUniform2f("seed", [float(seed[0]), float(seed[1])])
        w, h = self.size
        u.SetUniform2f("jitter", [2.0 * float(jitter_px[0]) / max(w, 1),
                                  2.0 * float(jitter_px[1]) / max(h, 1)])

    def use_field(self, field, route: str):
        """Select the route; for "texture", upload the field (once per field) as a 3D
        RGBA32F texture with linear filtering and clamp-to-edge."""
        self.shader = self.shaders[route]
        if route != "texture":
            return
        u = self.shader.GetVertexCustomUniforms()
        cam = field.camera
        u.SetUniformf("depthMode", 0.0 if field.depth_mode == "ndc" else 1.0)
        u.SetUniformf("nearPlane", float(cam.near))
        u.SetUniformf("farPlane", float(cam.far))
        if self.field_texture_key == field.key:
            return
        self.win.Initialize()
        if self.field_texture is not None:
            self.field_texture.ReleaseGraphicsResources(self.win)
        tex = vtk.vtkTextureObject()
        tex.SetContext(self.win)
        nz, ny, nx = field.shape
        self._field_data = field.texture_rgba()          # keep alive while uploaded
        tex.Create3DFromRaw(nx, ny, nz, 4, vtk.VTK_FLOAT, self._field_data)
        for f in (tex.SetWrapS, tex.SetWrapT, tex.SetWrapR):
            f(vtk.vtkTextureObject.ClampToEdge)
        tex.SetMinificationFilter(vtk.vtkTextureObject.Linear)
        tex.SetMagnificationFilter(vtk.vtkTextureObject.Linear)
        self.field_texture = tex
        self.field_texture_key = field.key

    def show(self, items):
        """Show exactly these (key, factory) actors, reusing cached ones."""
        keep = {}
        self.ren.RemoveAllViewProps()
        for key, factory in items:
            actor = self.actors.get(key)
            if actor is None:
                actor = factory()
                actor.SetShaderProperty(self.shader)
                if self.shader is self.shaders["texture"]:
                    _bind_field_texture(actor.GetMapper(), self)
            keep[key] = actor
            self.ren.AddActor(actor)
        self.actors = keep
        return list(keep.values())

    def set_view(self, cam: Camera, size, background):
        if tuple(size) != self.size:
            self.win.SetSize(int(size[0]), int(size[1]))
            self.size = tuple(size)
        c = self.ren.GetActiveCamera()
        pos = np.asarray(cam.position, float)
        c.SetPosition(*pos)
        c.SetFocalPoint(*(pos + cam.basis[2]))
        c.SetViewUp(*cam.basis[1])
        c.SetViewAngle(cam.fov_y_deg)
        c.SetClippingRange(cam.near, cam.far)
        self.ren.SetBackground(*(np.asarray(background, float) / 255.0))

    def depth(self) -> np.ndarray:
        """(h, w) z-buffer of the last render in [0, 1], row 0 at the bottom."""
        w, h = self.size
        arr = vtk.vtkFloatArray()
        self.win.GetZbufferData(0, 0, w - 1, h - 1, arr)
        return vtk_to_numpy(arr).reshape(h, w).copy()

    def grab_rgba(self) -> np.ndarray:
        """Render and read RGBA (h, w, 4) uint8 (a view of a reused buffer: copy or consume
        before the next grab), row 0 at the bottom (GL order)."""
        t0 = time.perf_counter()
        self.win.Render()
        t1 = time.perf_counter()
        w, h = self.size
        self.win.GetRGBACharPixelData(0, 0, w - 1, h - 1, 0, self._buf)
        out = vtk_to_numpy(self._buf).reshape(h, w, 4)
        self.render_s += t1 - t0
        self.readback_s += time.perf_counter() - t1
        return out

    def grab(self) -> np.ndarray:
        """Render and read RGB (h, w, 3) uint8 (a copy), row 0 at the bottom (GL order)."""
        return self.grab_rgba()[..., :3].copy()

    def clear(self):
        self.ren.RemoveAllViewProps()

    def close(self):
        self.clear()
        self.actors.clear()
        if self.field_texture is not None:
            self.field_texture.ReleaseGraphicsResources(self.win)
            self.field_texture = None
        self.win.Finalize()


def _bind_field_texture(mapper, window):
    """Bind the window's field texture to the mapper's shader program before each draw
    (UpdateShaderEvent fires on vtkOpenGLPolyDataMapper; VTK_NOTES Q2 route A)."""

    @vtk.calldata_type(vtk.VTK_OBJECT)
    def bind(caller, event, program):
        tex = window.field_texture
        if tex is not None and program is not None:
            tex.Activate()
            program.SetUniformi("blurField", tex.GetTextureUnit())

    mapper.AddObserver(vtk.vtkCommand.UpdateShaderEvent, bind)
    mapper._eyelab_bind = bind   # keep the callback alive with the mapper


def _polydata(vertices, faces):
    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(np.ascontiguousarray(vertices, dtype=float), deep=True))
    cells = vtk.vtkCellArray()
    conn = np.ascontiguousarray(faces.ravel(), dtype=np.int64)
    offs = np.arange(0, len(conn) + 1, 3, dtype=np.int64)
    cells.SetData(numpy_to_vtk(offs, deep=True), numpy_to_vtk(conn, deep=True))
    pd = vtk.vtkPolyData()
    pd.SetPoints(pts)
    pd.SetPolys(cells)
    return pd


def _texture(img_top_first, mipmap=False):
    """vtkTexture from an (h, w, 3) uint8 image with row 0 at the top (VTK wants bottom).
    ``mipmap``: trilinear mip-mapping, for scene textures seen smaller than their texels
    (each pass then samples the texture pre-filtered to the pixel footprint, as the
    reference's many rays per pixel average it)."""
    h, w = img_top_first.shape[:2]
    data = vtk.vtkImageData()
    data.SetDimensions(w, h, 1)
    arr = numpy_to_vtk(np.ascontiguousarray(img_top_first[::-1].reshape(-1, 3)), deep=True)
    arr.SetName("rgb")
    data.GetPointData().SetScalars(arr)
    tex = vtk.vtkTexture()
    tex.SetInputData(data)
    tex.InterpolateOn()
    tex.RepeatOff()
    tex.EdgeClampOn()
    tex.SetColorModeToDirectScalars()
    if mipmap:
        tex.MipmapOn()
    return tex


def _mesh_actor(mesh: SceneMesh, blur_rows: np.ndarray | None):
    pd = _polydata(mesh.vertices, mesh.faces)
    mapper = vtk.vtkOpenGLPolyDataMapper()
    actor = vtk.vtkActor()
    if mesh.texture is not None:
        tc = numpy_to_vtk(np.ascontiguousarray(mesh.uv, dtype=np.float32), deep=True)
        tc.SetName("uv")
        pd.GetPointData().SetTCoords(tc)
        actor.SetTexture(_texture(mesh.texture))
        mapper.ScalarVisibilityOff()
    else:
        col = numpy_to_vtk(np.ascontiguousarray(mesh.colors), deep=True)
        col.SetName("colors")
        pd.GetPointData().AddArray(col)
        mapper.SetScalarModeToUsePointFieldData()
        mapper.SelectColorArray("colors")
        mapper.SetColorModeToDirectScalars()
        mapper.ScalarVisibilityOn()
    rows = np.zeros((len(mesh.vertices), 4), np.float32) if blur_rows is None else blur_rows
    b = numpy_to_vtk(np.ascontiguousarray(rows, dtype=np.float32), deep=True)
    b.SetName("blurM")
    pd.GetPointData().AddArray(b)
    mapper.SetInputData(pd)
    mapper.MapDataArrayToVertexAttribute("blurM", "blurM",
                                         vtk.vtkDataObject.FIELD_ASSOCIATION_POINTS, -1)
    actor.SetMapper(mapper)
    actor.GetProperty().LightingOff()
    return actor


class RasterRenderer:
    """Renders what an eye sees, with or without a spectacle lens. Reuse one instance for
    many frames: windows and caches (blur fields, lens texture coordinates, refined meshes)
    persist while their inputs do not change."""

    def __init__(self, settings: RenderSettings | None = None):
        self.settings = settings or RenderSettings()
        self._eye_win = None
        self._env_win = None
        self._fields = {}
        self._refined = {}
        self._lens_cache = {}

    def close(self):
        for w in (self._eye_win, self._env_win):
            if w is not None:
                w.close()
        self._eye_win = self._env_win = None
        self._fields.clear()
        self._refined.clear()
        self._lens_cache.clear()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ------------------------------------------------------------------ fields
    def _field(self, eye, lens, cam, bounds, report, label):
        from eyelab.blur.field import cache_key

        s = self.settings
        key = cache_key(eye=eye, lens=lens, camera=cam, shape=s.field_shape, focus=s.focus,
                        bounds=np.asarray(bounds, float))
        if key in self._fields:
            report["fields"][label] = {"cache": "hit"}
            return self._fields[key]
        f = compute_blur_field(eye, lens, cam, shape=s.field_shape, focus=s.focus,
                               scene_bounds=bounds)
        if len(self._fields) > 8:
            self._fields.clear()
        self._fields[key] = f
        report["fields"][label] = {"cache": "miss", "voxels_total": f.report["voxels_total"],
                                   "voxels_computed": f.report["voxels_computed"],
                                   "skipped_why": f.report["skipped_why"],
                                   "all_zero": f.all_zero, "time_s": f.report["timings"]["total_s"]}
        return f

    # ------------------------------------------------------------------ render
    def render(self, scene: Scene, eye, lens=None, *, progressive: bool = False
               ) -> RenderResult:
        s = self.settings
        t_start = time.perf_counter()
        timings = {}
        report = {"settings": {"size": [s.width, s.height], "samples": s.samples,
                               "field_shape": list(s.field_shape)},
                  "fields": {}, "passes": {}, "skipped": [], "refinement": []}
        eye_cam = s.eye_camera()
        bounds = scene.bounds()
        # --- is the lens in view?
        lens_in_view = False
        if lens is None:
            report["skipped"].append("lens passes: no lens")
        else:
            vkey = ("in_view", lens, eye_cam)
            if vkey not in self._lens_cache:
                self._lens_cache[vkey] = lens_in_view_of(lens, eye_cam)
            lens_in_view = self._lens_cache[vkey]
            if not lens_in_view:
                report["skipped"].append("lens passes: the lens is outside the view")
        t = time.perf_counter()
        f_naked = self._field(eye, None, eye_cam, bounds, report, "naked")
        f_lens = vcam = None
        if lens_in_view:
            vkey = ("vcam", lens, eye_cam)
            if vkey not in self._lens_cache:
                fitted = fit_virtual_camera(lens, eye_cam).camera
                self._lens_cache[vkey] = env_view(fitted, self._env_width(eye_cam, fitted))[0]
            vcam = self._lens_cache[vkey]
            f_lens = self._field(eye, lens, vcam, bounds, report, "through_lens")
        timings["fields_s"] = time.perf_counter() - t
        # --- refinement
        t = time.perf_counter()
        meshes = []
        for m in scene.meshes:
            if s.refine:
                key = (id(m), m.n_triangles, f_naked.key, None if f_lens is None else f_lens.key,
                       s.width)
                if key not in self._refined:
                    self._refined[key] = refine_for_fields(m, [f_naked, f_lens],
                                                           px_scale=s.width / 2)
                rm, info = self._refined[key]
                meshes.append(rm)
                report["refinement"].append(info)
            else:
                meshes.append(m)
        if not s.refine:
            report["skipped"].append("refinement: disabled")
        timings["refine_s"] = time.perf_counter() - t
        # --- passes
        seeds_n = seeds_for(s.samples)
        jit = pixel_jitter(s.samples) if s.antialias else np.zeros((s.samples, 2))
        n_naked = 1 if (f_naked.all_zero and s.skip_unneeded) else s.samples
        if n_naked == 1 and s.samples > 1:
            report["skipped"].append(f"naked view: blur field all zero: 1 pass instead of "
                                     f"{s.samples}")
        t = time.perf_counter()
        if self._eye_win is None:
            self._eye_win = _Window()
        ew = self._eye_win
        ew.render_s = ew.readback_s = 0.0
        if self._env_win is not None:
            self._env_win.render_s = self._env_win.readback_s = 0.0
        ew.set_view(eye_cam, (s.width, s.height), scene.background)
        ew.use_field(f_naked, s.field_route)
        ew.show([((id(m), f_naked.key, s.field_route), _factory(m, f_naked, s.field_route))
                 for m in meshes])
        timings["setup_naked_s"] = time.perf_counter() - t
        env_state = None
        if lens_in_view:
            t = time.perf_counter()
            env_state = self._setup_env(scene, meshes, lens, vcam, f_lens, report, eye_cam)
            timings["setup_lens_s"] = time.perf_counter() - t
        checkpoints = _checkpoints(s.samples) if progressive else [s.samples]
        acc_naked = np.zeros((s.height, s.width, 4), np.uint16)
        acc_env = None if env_state is None else np.zeros(env_state["size"][::-1] + (4,),
                                                          np.uint16)
        prog = []
        t_naked = t_env = t_lens = 0.0
        done = 0
        image = naked = env = None
        z_naked = z_env = None
        for cp in checkpoints:
            for k in range(done, cp):
                sd = seeds_n[k] if s.samples > 1 else (0.0, 0.0)
                t = time.perf_counter()
                jk = jit[k] if n_naked > 1 else (0.0, 0.0)
                if k < n_naked:
                    ew.set_seed(sd, jk)
                    np.add(acc_naked, ew.grab_rgba(), out=acc_naked)
                    if k == 0 and n_naked > 1 and s.reconstruct:
                        z_naked = ew.depth()
                t_naked += time.perf_counter() - t
                if env_state is not None and k < env_state["passes"]:
                    t = time.perf_counter()
                    self._env_win.set_seed(sd, jit[k] if env_state["passes"] > 1
                                           else (0.0, 0.0))
                    np.add(acc_env, self._env_win.grab_rgba(), out=acc_env)
                    if k == 0 and env_state["passes"] > 1 and s.reconstruct:
                        z_env = self._env_win.depth()
                    t_env += time.perf_counter() - t
            done = cp
            naked = _mean(acc_naked, min(cp, n_naked))
            if z_naked is not None:
                t = time.perf_counter()
                naked = self._reconstruct(naked, z_naked, eye_cam, f_naked, min(cp, n_naked),
                                          ("naked", id(scene), f_naked.key))
                timings["reconstruct_s"] = timings.get("reconstruct_s", 0.0) \
                    + time.perf_counter() - t
            image = naked
            if env_state is not None:
                t = time.perf_counter()
                env = _mean(acc_env, min(cp, env_state["passes"]))
                if z_env is not None:
                    env = self._reconstruct(env, z_env, env_state["vcam"], f_lens,
                                            min(cp, env_state["passes"]),
                                            ("env", id(scene), f_lens.key))
                image = self._composite(naked, env, env_state, report)
                t_lens += time.perf_counter() - t
            if s.cvd is not None:
                from eyelab.color import simulate_cvd

                image = simulate_cvd(image, s.cvd, s.cvd_severity)
            if progressive:
                prog.append((cp, image.copy()))
        ew.set_seed((0.0, 0.0))
        report["cvd"] = None if s.cvd is None else {"kind": s.cvd, "severity": s.cvd_severity,
                                                    "model": "Machado 2009, linear RGB"}
        report["passes"]["naked"] = n_naked
        report["passes"]["environment"] = 0 if env_state is None else env_state["passes"]
        gl = ew.render_s + (self._env_win.render_s if env_state is not None else 0.0)
        rb = ew.readback_s + (self._env_win.readback_s if env_state is not None else 0.0)
        timings.update(naked_passes_s=t_naked, env_passes_s=t_env, lens_composite_s=t_lens,
                       gl_render_s=gl, readback_s=rb, total_s=time.perf_counter() - t_start)
        report["timings"] = timings
        return RenderResult(image, report, prog, naked,
                            env if env_state is not None else None,
                            None if env_state is None else env_state.get("mask"))

    def _setup_env(self, scene, meshes, lens, vcam, f_lens, report, eye_cam):
        s = self.settings
        if self._env_win is None:
            self._env_win = _Window()
        vcam, (w_env, h_env) = env_view(vcam, self._env_width(eye_cam, vcam))
        env_win = self._env_win
        env_win.set_view(vcam, (w_env, h_env), scene.background)
        env_win.use_field(f_lens, s.field_route)
        actors = env_win.show([((id(m), f_lens.key, s.field_route),
                                _factory(m, f_lens, s.field_route)) for m in meshes])
        passes = 1 if (f_lens.all_zero and s.skip_unneeded) else s.samples
        if passes == 1 and s.samples > 1:
            report["skipped"].append(f"environment: through-lens blur field all zero: 1 pass "
                                     f"instead of {s.samples}")
        # lens mesh as the eye sees it: the back surface, slightly inside the rim
        lv, lf = _lens_back_mesh(lens, s.lens_rings, s.lens_segments)
        gv, gf = _lens_view_mesh(lens, eye_cam, s.width, s.height, s.lens_grid_px)
        disperses = s.chromatic and lens.material.dispersive
        wls = RGB_WAVELENGTHS_NM if disperses else (587.56,)
        if not disperses:
            report["skipped"].append("chromatic: " + ("disabled" if not s.chromatic else
                                                      "the lens material does not disperse")
                                     + ": one texture-coordinate set")
        from eyelab.blur.field import cache_key

        tkey = (id(scene), scene.n_triangles, cache_key(lens=lens, camera=vcam, wls=wls,
                                                        rings=s.lens_rings,
                                                        segments=s.lens_segments,
                                                        grid=s.lens_grid_px, eye=eye_cam))
        if tkey in self._lens_cache:
            tc = self._lens_cache[tkey]
            report["skipped"].append("lens texture coordinates: unchanged inputs, reused")
        else:
            inter = EmbreeIntersector(scene)
            tc = lens_texcoords(lens, lv, vcam, inter, wavelengths=wls)
            # the texture coordinates on the view grid, through the lens extended beyond its
            # rim (the outline mask clips it), so that rim cells are filled
            wide = _widened(lens)
            tc_grid = lens_texcoords(wide, gv, vcam, inter, wavelengths=wls)
            if len(self._lens_cache) > 16:
                self._lens_cache.clear()
            self._lens_cache[tkey] = (tc, tc_grid)
            tc = (tc, tc_grid)
        tc, tc_grid = tc
        report["lens"] = {"vertices": int(len(gv)), "outline_vertices": int(len(lv)),
                          "texcoord_sets": len(wls),
                          "vertices_missing_lens": int((~tc.lens_ok).any(0).sum()),
                          "rays_missing_scene": int((~tc_grid.scene_hit).sum()),
                          "virtual_camera": {"position": list(map(float, vcam.position)),
                                             "fov_y_deg": vcam.fov_y_deg,
                                             "aspect": vcam.aspect}}
        return {"actors": actors, "passes": passes, "size": (w_env, h_env), "vcam": vcam,
                "lens_v": lv,
                "lens_f": lf, "tc": tc, "grid_v": gv, "grid_f": gf, "tc_grid": tc_grid,
                "eye_cam": eye_cam, "mask_key": tkey}

    def _reconstruct(self, img, zbuf, cam, field, passes, key):
        """Spatially varying Gaussian reconstruction (see RenderSettings.reconstruct): sigma
        per pixel = RECON_SIGMA x max(sqrt(pi a b / S), 2 a / S) for the pixel's blur ellipse
        semi-axes a >= b (px); evaluated on every 2nd pixel (nearest voxel), cached per
        geometry and field, applied by blending Gaussian-filtered copies at sigma levels."""
        from scipy.ndimage import gaussian_filter

        h, w = img.shape[:2]
        ckey = ("sigma", key, w, h, passes)
        sig = self._lens_cache.get(ckey)
        if sig is None:
            zb = zbuf[::-1][::2, ::2]
            ys, xs = np.mgrid[0:h:2, 0:w:2]
            ndc = np.stack([(2 * xs + 1.0) / w - 1, 1 - (2 * ys + 1.0) / h, 2 * zb - 1], -1)
            fg = zb < 1.0
            sig_small = np.zeros(zb.shape)
            if fg.any():
                pts = cam.ndc_to_world(ndc[fg])
                b = field.lookup(pts, interpolate=False)
                bpx = b * np.array([w / 2, h / 2])[None, :, None]
                sv = np.linalg.svd(bpx, compute_uv=False)
                spacing = np.maximum(np.sqrt(np.pi * sv[:, 0] * sv[:, 1] / passes),
                                     2 * sv[:, 0] / passes)
                sig_small[fg] = RECON_SIGMA * spacing
            sig = np.repeat(np.repeat(sig_small, 2, 0), 2, 1)[:h, :w]
            self._lens_cache[ckey] = sig
        smax = float(sig.max())
        if smax < 0.25:
            return img
        levels = [0.0]
        while levels[-1] < smax:
            levels.append(0.35 if levels[-1] == 0 else levels[-1] * 2)
        src = img.astype(np.float32)
        filt = [src] + [gaussian_filter(src, (lv, lv, 0)) for lv in levels[1:]]
        idx = np.clip(np.searchsorted(levels, sig) - 1, 0, len(levels) - 2)
        lo = np.asarray(levels)[idx]
        hi = np.asarray(levels)[idx + 1]
        t = np.clip((sig - lo) / (hi - lo), 0, 1)[..., None]
        out = np.zeros_like(src)
        for i in range(len(levels) - 1):
            sel = (idx == i)[..., None]
            out += np.where(sel, (1 - t) * filt[i] + t * filt[i + 1], 0.0)
        return np.clip(out + 0.5, 0, 255).astype(np.uint8)

    def _env_width(self, eye_cam, vcam) -> int:
        s = self.settings
        ratio = vcam.tan_half[0] / eye_cam.tan_half[0]
        return int(min(4096, max(16, round(s.width * ratio * s.env_oversample))))

    def _composite(self, naked, env, st, report):
        s = self.settings
        ew = self._eye_win
        saved = list(_actors(ew.ren))
        for a in saved:
            a.VisibilityOff()
        bg = ew.ren.GetBackground()
        ew.ren.SetBackground(0, 0, 0)
        cam = ew.ren.GetActiveCamera()
        clip = cam.GetClippingRange()
        cam.SetClippingRange(1e-3, 1.0)   # the lens sits ~12 mm from the eye
        tex = _texture(env)
        tc = st["tc"]
        tcg = st["tc_grid"]
        lens_img = np.zeros_like(naked)
        for ch in range(3):
            uv = tcg.uv[min(ch, len(tcg.uv) - 1)]
            mesh = SceneMesh("lens", st["grid_v"], st["grid_f"], texture=env, uv=uv)
            pd = _polydata(mesh.vertices, mesh.faces)
            arr = numpy_to_vtk(np.ascontiguousarray(uv, dtype=np.float32), deep=True)
            pd.GetPointData().SetTCoords(arr)
            mapper = vtk.vtkOpenGLPolyDataMapper()
            mapper.SetInputData(pd)
            mapper.ScalarVisibilityOff()
            actor = vtk.vtkActor()
            actor.SetMapper(mapper)
            actor.SetTexture(tex)
            actor.GetProperty().LightingOff()
            ew.ren.AddActor(actor)
            img = ew.grab_rgba()[::-1]
            ew.ren.RemoveActor(actor)
            if len(tcg.uv) == 1:
                lens_img = img[..., :3].copy()
                break
            lens_img[..., ch] = img[..., ch]
        # outline / validity masks (cached with the texture coordinates): vertex colours
        # white (valid) or black (invalid)
        mkey = ("masks", st["mask_key"], ew.size)
        if mkey not in self._lens_cache:
            valid = tc.lens_ok.all(0)
            cols = np.where(valid[:, None], 255, 0).astype(np.uint8) * np.ones((1, 3),
                                                                                np.uint8)
            mactor = _mesh_actor(SceneMesh("mask", st["lens_v"], st["lens_f"], colors=cols),
                                 None)
            ew.ren.AddActor(mactor)
            vimg = ew.grab()[::-1]
            ew.ren.RemoveActor(mactor)
            full = SceneMesh("mask", st["lens_v"], st["lens_f"],
                             colors=np.full((1, 3), 255, np.uint8))
            mactor = _mesh_actor(full, None)
            ew.ren.AddActor(mactor)
            mimg = ew.grab()[::-1]
            ew.ren.RemoveActor(mactor)
            inside = mimg[..., 0] > 127
            self._lens_cache[mkey] = (inside & (vimg[..., 0] < 128), inside,
                                      inside & ~_erode(inside))
        ew.ren.SetBackground(*bg)
        cam.SetClippingRange(*clip)
        for a in saved:
            a.VisibilityOn()
        invalid, inside, rim = self._lens_cache[mkey]
        out = np.where(inside[..., None], lens_img, naked)
        out[invalid] = s.invalid_color
        out[rim] = s.rim_color
        report["lens"]["pixels_inside"] = int(inside.sum())
        report["lens"]["pixels_invalid"] = int(invalid.sum())
        st["mask"] = inside
        return out


#: reconstruction Gaussian sigma in units of the spacing of the S samples in a blur disc.
#: 0.5: swept over 0-1 at 512x384 against 512-spp references (charts at 0.4 m / 6 m, the
#: tilted page; myope, astigmat, presbyope; S = 8 and 32): the best SSIM lies at 0.4-0.55
#: on every case (6 m astigmat chart, S = 32: 0.965 unfiltered, 0.991 at 0.55, 0.981 at 1.0)
RECON_SIGMA = 0.5


def env_view(vcam: Camera, width: int):
    """The environment window for a virtual camera: (camera, (w, h)) with the camera's
    aspect set to exactly w / h of the integer window, so VTK and eyelab project alike."""
    import dataclasses

    h = max(16, int(round(width / vcam.aspect)))
    return dataclasses.replace(vcam, aspect=width / h), (width, h)


def lens_in_view_of(lens, cam: Camera, samples: int = 17) -> bool:
    """True if any ray of a ``samples`` x ``samples`` grid over the camera's view (edges
    included) passes through the lens."""
    g = np.linspace(-1.0, 1.0, samples)
    gx, gy = np.meshgrid(g, g)
    d = cam.ray_directions(gx.ravel(), gy.ravel())
    o = np.broadcast_to(np.asarray(cam.position, float), d.shape)
    res = lens.trace(o, d, reverse=True)
    from eyelab.optics.trace import FATAL

    return bool(np.any((res["status"] & np.uint8(FATAL)) == 0))


def _factory(mesh, field, route):
    if route == "texture":
        return lambda: _mesh_actor(mesh, None)
    return lambda: _mesh_actor(mesh, field.lookup(mesh.vertices).reshape(-1, 4)
                               .astype(np.float32))


def _actors(ren):
    col = ren.GetActors()
    col.InitTraversal()
    for _ in range(col.GetNumberOfItems()):
        yield col.GetNextActor()


def _erode(mask):
    m = mask.copy()
    m[1:] &= mask[:-1]
    m[:-1] &= mask[1:]
    m[:, 1:] &= mask[:, :-1]
    m[:, :-1] &= mask[:, 1:]
    return m


def _mean(acc, n):
    """RGB average of n summed RGBA passes, rounded, row 0 at the top."""
    rgb = acc[::-1, :, :3]
    if n <= 1:
        return rgb.astype(np.uint8)
    out = rgb.astype(np.float32)
    out *= np.float32(1.0 / n)
    out += np.float32(0.5)                       # round half up (values are >= 0)
    return out.astype(np.uint8)


def _checkpoints(samples):
    cps, k = [], 1
    while k < samples:
        cps.append(k)
        k *= 2
    return cps + [samples]


def _widened(lens):
    """The same lens with a 15 % larger aperture (where its surfaces allow): used only for
    texture coordinates of grid vertices just outside the rim."""
    import dataclasses

    d = min(lens.diameter * 1.15, 0.09)
    r = d / 2
    for surf in (lens.front, lens.back):
        if not bool(np.all(surf.derivatives(np.array([r, 0.0, -r, 0.0]),
                                            np.array([0.0, r, 0.0, -r])).valid)):
            return lens
    return dataclasses.replace(lens, diameter=d)


def _lens_view_mesh(lens, cam, width, height, step_px):
    """Grid mesh on the lens's back surface: where eye rays through every ``step_px``-th pixel
    (one cell of margin around the view) meet it; cells whose corners all meet it."""
    nx = max(2, int(math.ceil(width / step_px)) + 3)
    ny = max(2, int(math.ceil(height / step_px)) + 3)
    gx = np.linspace(-1 - 2 * step_px / width, 1 + 2 * step_px / width, nx)
    gy = np.linspace(-1 - 2 * step_px / height, 1 + 2 * step_px / height, ny)
    mx, my = np.meshgrid(gx, gy)
    d = cam.ray_directions(mx.ravel(), my.ravel())
    from eyelab.optics.trace import intersect

    _, back = _widened(lens).placed_surfaces()
    hit = intersect(back, np.zeros_like(d), d)
    ok = hit.status == 0
    idx = np.arange(nx * ny).reshape(ny, nx)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, e = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, e], 1), np.stack([a, e, c], 1)])
    faces = faces[ok[faces].all(1)]
    pts = np.where(ok[:, None], hit.points, 0.0)
    return pts, faces


def _lens_back_mesh(lens, rings, segments):
    """The lens's back surface as a polar grid (world), out to 99.5 % of the radius."""
    r = np.linspace(0.0, 0.995 * lens.diameter / 2, rings + 1)[1:]
    th = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
    rr, tt = np.meshgrid(r, th, indexing="ij")
    x = np.concatenate([[0.0], (rr * np.cos(tt)).ravel()])
    y = np.concatenate([[0.0], (rr * np.sin(tt)).ravel()])
    _, back = lens.placed_surfaces()
    z = back.surface.sag(x, y)
    v = np.stack([x, y, z], 1) @ back.rotation.T + back.translation
    faces = []
    for i in range(segments):
        faces.append((0, 1 + i, 1 + (i + 1) % segments))
    for ring in range(rings - 1):
        for i in range(segments):
            j = (i + 1) % segments
            a, b = 1 + ring * segments + i, 1 + ring * segments + j
            faces += [(a, a + segments, b + segments), (a, b + segments, b)]
    return v, np.array(faces)
