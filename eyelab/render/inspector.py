"""The inspector's window: one PyVista ``Plotter`` (no Qt) around an inspector model
(:class:`eyelab.jobs.inspector.InspectorModel`, passed in: this module never imports it).

Layout (a 3 x 3 grid): the simulated view on the left, pixel for pixel (a textured plane
under a parallel camera whose scale matches the viewport's height, nearest-texel
sampling); beside it the 3-D scene with the eye, the lens, the view frustum and the
line of sight, and below it the blur field as Sturm-conoid ellipses (Kakimoto Figs.
12-13) at the depth of the gaze point; on the right the lens's as-worn maps, mean power
error above cylinder, with the line of sight's point on them
(:mod:`eyelab.render.mappanel`; computed once per lens, after the change's first frame,
and kept: a gaze change only moves the point; no panel without a lens, the side views
then take its room); along the bottom the sliders, toggles and the status line. A
repeating timer drives the model: each tick applies the queued changes (slider events
are coalesced) and runs one step of the progressive frames, so the window never blocks
longer than the set-up of a change or one step of passes.

Keys: arrows turn the gaze by 2 deg; a left click in the simulated view looks there, on a
map it turns the eye to that eye rotation; ``l`` lens on/off; ``m`` shows or hides the
as-worn maps; ``v`` cycles the colour-vision deficiency; ``c`` designs the lens for the
eye's current Rx; ``s`` saves the view and the spec that reproduces it; ``r`` resets;
``o`` re-reads the spec file; ``h`` shows or hides the help; ``q`` quits.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyvista as pv

from eyelab.optics.eye import EYE_REFERENCE_NM
from eyelab.render.mappanel import MapPanel

#: Timer period (ms) between ticks.
TICK_MS = 15
#: Height (px) of the controls strip and width of the side column relative to the view.
CONTROLS_PX = 230
SIDE_FRACTION = 0.5
#: Width of the as-worn map column relative to the view's height (each map is half of it).
MAPS_FRACTION = 0.55
#: Degrees per arrow-key press.
GAZE_STEP_DEG = 2.0

HELP = ("arrows: gaze +-2 deg   click: look there (view or map)   l: lens on/off\n"
        "m: as-worn maps on/off   v: colour vision   c: lens for the eye's Rx\n"
        "s: save view + spec   r: reset   o: reload spec   h: this help   q: quit")


class InspectorWindow:
    """The window around ``model``; ``off_screen`` for tests and screenshots."""

    def __init__(self, model, *, off_screen: bool = False, save_dir="."):
        self.model = model
        self.save_dir = Path(save_dir)
        w, h = model.size
        side = max(240, int(round(w * SIDE_FRACTION)))
        maps_w = max(220, int(round(h * MAPS_FRACTION)))
        self.window_size = (w + side + maps_w, h + CONTROLS_PX)
        self._columns = (w / self.window_size[0], (w + side) / self.window_size[0])
        p = pv.Plotter(off_screen=off_screen, shape=(3, 3),
                       groups=[(np.s_[0:2], 0), (2, np.s_[0:3])],
                       row_weights=[h / 2, h / 2, CONTROLS_PX], col_weights=[w, side, maps_w],
                       window_size=self.window_size, border=False,
                       title="eyelab inspector")
        self.plotter = p
        self._ready = False
        self._opened = False
        self._saved = 0
        self._help_on = False
        self._build_view()
        self._build_scene_view()
        self._build_controls()
        self._maps = MapPanel(p, ((0, 2), (1, 2)), relayout=self._layout,
                              grid=model.maps_grid)
        self._maps.sync(model)
        self._field_actor = None
        self._update_side = True
        self._ready = True
        self.refresh()
        p.iren.add_observer("TimerEvent", self._on_timer)
        p.iren.add_observer("LeftButtonPressEvent", self._on_click)
        for key, fn in (("Left", lambda: self._turn(-GAZE_STEP_DEG, 0)),
                        ("Right", lambda: self._turn(GAZE_STEP_DEG, 0)),
                        ("Up", lambda: self._turn(0, GAZE_STEP_DEG)),
                        ("Down", lambda: self._turn(0, -GAZE_STEP_DEG)),
                        ("l", lambda: self._request("lens", not model.value("lens"))),
                        ("m", self._toggle_maps),
                        ("v", self._cycle_cvd), ("c", self._full_correction),
                        ("s", self.save), ("r", self._reset), ("o", self._reload),
                        ("h", self._toggle_help)):
            p.add_key_event(key, fn)

    # ------------------------------------------------------------- building
    def _build_view(self):
        p, (w, h) = self.plotter, self.model.size
        p.subplot(0, 0)
        p.set_background("black")
        self._image = pv.ImageData(dimensions=(w, h, 1))
        self._image.point_data["rgb"] = np.zeros((w * h, 3), np.uint8)
        self._texture = pv.Texture(self._image)
        self._texture.interpolate = False
        plane = pv.Plane(center=(w / 2, h / 2, 0), direction=(0, 0, 1), i_size=w, j_size=h,
                         i_resolution=1, j_resolution=1)
        p.add_mesh(plane, texture=self._texture, lighting=False, name="view",
                   reset_camera=False)
        cam = p.renderer.camera
        cam.parallel_projection = True
        cam.position = (w / 2, h / 2, 10.0)
        cam.focal_point = (w / 2, h / 2, 0.0)
        cam.up = (0.0, 1.0, 0.0)
        p.renderer.ResetCameraClippingRange()
        self._fit_view_camera()
        self._help = p.add_text("", position=(8, 8), font_size=9, color="white", name="help")
        self._view_renderer = p.renderer

    def _layout(self, maps_shown: bool) -> None:
        """The side column's right edge: before the map column, or at the window's edge
        when the maps are hidden (their renderers are not drawn)."""
        right = self._columns[1] if maps_shown else 1.0
        for cell in ((0, 1), (1, 1)):
            ren = self.plotter.renderers[self.plotter.renderers.loc_to_index(cell)]
            x0, y0, _, y1 = ren.GetViewport()
            ren.SetViewport(x0, y0, right, y1)

    def _fit_view_camera(self):
        """Parallel scale for one texel per pixel when the viewport is the view's size."""
        vp_h = self._view_renderer.GetSize()[1] if hasattr(self, "_view_renderer") else None
        h = self.model.size[1]
        self.plotter.renderers[0].camera.parallel_scale = (vp_h or h) / 2.0

    def _build_scene_view(self):
        p = self.plotter
        p.subplot(0, 1)
        p.set_background((0.12, 0.12, 0.14))
        scene = self.model.scene()
        for m in scene.meshes:
            mesh = pv.PolyData(m.vertices, np.column_stack(
                [np.full(len(m.faces), 3), m.faces]).ravel())
            if m.colors is not None:
                mesh.point_data["rgb"] = np.asarray(m.colors, np.uint8)
                p.add_mesh(mesh, scalars="rgb", rgb=True, lighting=False,
                           name=f"scene_{m.name}")
            elif m.texture is not None:
                mesh.active_texture_coordinates = np.asarray(m.uv, np.float32)
                p.add_mesh(mesh, texture=pv.Texture(np.ascontiguousarray(m.texture[::-1])),
                           lighting=False, name=f"scene_{m.name}")
            else:
                p.add_mesh(mesh, color="grey", name=f"scene_{m.name}")
        p.add_text("scene, eye, lens, line of sight", font_size=8, color="white")
        p.subplot(1, 1)
        p.set_background((0.08, 0.08, 0.1))
        self._field_title = p.add_text("blur field at the gaze depth (arcmin)",
                                       position=(6, self.model.size[1] // 2 - 18),
                                       font_size=7, color="white")

    def _build_controls(self):
        p, m = self.plotter, self.model
        p.subplot(2, 0)
        p.set_background((0.16, 0.16, 0.18))
        self._status = p.add_text("", position=(8, CONTROLS_PX - 52), font_size=6,
                                  color="yellow", name="status")
        self._sliders = {}
        cols = 4
        for i, c in enumerate(m.controls):
            row, col = divmod(i, cols)
            y = (125 - 58 * row) / CONTROLS_PX     # the strip's own normalized coordinates
            x0 = 0.02 + col * 0.245
            self._sliders[c.name] = p.add_slider_widget(
                lambda v, name=c.name: self._request(name, v), (c.lo, c.hi),
                value=float(m.value(c.name)), title=c.label, pointa=(x0, y),
                pointb=(x0 + 0.2, y), interaction_event="always", fmt=c.fmt,
                title_height=0.07, style="modern")
        self._checks = {}
        w = self.window_size[0]
        for i, name in enumerate(m.toggles):
            x = 12 + i * (w // 4)
            self._checks[name] = p.add_checkbox_button_widget(
                lambda v, name=name: self._request(name, v), value=bool(m.value(name)),
                position=(x, 8), size=18, border_size=2)
            p.add_text(name, position=(x + 24, 8), font_size=7, color="white")
        p.add_text("h: help", position=(12 + 3 * (w // 4), 8), font_size=7, color="grey")

    # ---------------------------------------------------------------- events
    def _request(self, name, value):
        if self._ready:              # widgets report their initial values while built
            self.model.request(name, value)

    def _turn(self, d_right, d_up):
        g = self.model.value("gaze")
        self._request("gaze", (max(-60.0, min(60.0, g[0] + d_right)),
                               max(-60.0, min(60.0, g[1] + d_up))))

    def _cycle_cvd(self):
        cyc = list(self.model.cvd_cycle)
        self._request("cvd", cyc[(cyc.index(self.model.value("cvd")) + 1) % len(cyc)])

    def _full_correction(self):
        self.model.copy_eye_rx_to_lens()
        self._update_side = True

    def _reset(self):
        self.model.reset()
        self._sync_widgets()
        self._update_side = True

    def _reload(self):
        try:
            self.model.load()
        except Exception as e:      # a broken file on disk: say so, keep the state
            self.model.message = f"could not re-read the spec: {e}"
        self._sync_widgets()
        self._update_side = True

    def _toggle_maps(self):
        self._request("maps", not self.model.value("maps"))

    def _toggle_help(self):
        self._help_on = not self._help_on
        self._help.SetInput(HELP if self._help_on else "")

    def _on_click(self, obj, event):
        x, y = self.plotter.iren.get_event_position()
        on_map = self._maps.eye_rotation_at(x, y)
        if on_map is not None:            # a map's point is an eye rotation: look there
            self._request("gaze", tuple(round(v, 1) for v in on_map))
            return
        ren = self._view_renderer
        vx, vy = ren.GetOrigin()
        vw, vh = ren.GetSize()
        if not (vx <= x < vx + vw and vy <= y < vy + vh):
            return
        # the view's pixel under the click (the camera shows one texel per pixel, centred)
        w, h = self.model.size
        scale = self.plotter.renderers[0].camera.parallel_scale * 2.0 / vh
        px = w / 2 + (x - vx - vw / 2) * scale
        py = h / 2 + (y - vy - vh / 2) * scale
        if not (0 <= px < w and 0 <= py < h):
            return
        view = self.model.view
        g = self.model.value("gaze")
        ty = math.tan(math.radians(view.fov_y_deg / 2))
        tx = ty * w / h
        dx = math.degrees(math.atan((2 * px / w - 1) * tx))
        dy = math.degrees(math.atan((2 * py / h - 1) * ty))
        self._request("gaze", (max(-60.0, min(60.0, g[0] + dx)),
                               max(-60.0, min(60.0, g[1] + dy))))

    def _on_timer(self, obj, event):
        if self.step():
            self.plotter.render()

    # --------------------------------------------------------------- drawing
    def step(self) -> bool:
        """One tick of the model; the display refreshed when its image changed, the map
        panel brought up to the model. Returns whether the window needs a render."""
        before = self.model.last_change
        changed = self.model.tick()
        if self.model.last_change != before:
            self._update_side = True
        if changed:
            self.refresh()
        return self._maps.sync(self.model) or changed

    def refresh(self) -> None:
        """Show the model's current image, status and (after a change) side views."""
        img = self.model.display()
        h, w = img.shape[:2]
        self._image.point_data["rgb"][:] = img[::-1].reshape(-1, 3)
        self._image.Modified()
        self._texture.Modified()
        text = self.model.status()
        if self._update_side and self.model.result is not None:
            self._update_side = False
            try:
                text_r = self.model.readout()
            except Exception as e:         # the readout must never stop the window
                text_r = f"gaze point: {e}"
            self._readout = text_r
            self._draw_side()
        self._status.SetInput(text + "\n" + getattr(self, "_readout", ""))

    def _draw_side(self):
        """Eye, lens, frustum and line of sight; the blur-field glyphs at the gaze depth."""
        from eyelab.render.fields import ellipse_glyphs

        p, m = self.plotter, self.model
        view, eye = m.view, m.spec.eye
        cam = view.camera(eye.rotation_centre)
        p.subplot(0, 1)
        pos = np.asarray(cam.position, float)
        p.add_mesh(pv.Sphere(radius=0.012, center=pos + np.array([0, 0, 0.012])),
                   color="white", name="eye")
        if m.lens is not None:
            v, f, _ = m.lens.mesh(8, 48)
            p.add_mesh(pv.PolyData(v, np.column_stack([np.full(len(f), 3), f]).ravel()),
                       color="lightblue", opacity=0.5, name="lens")
        else:
            p.remove_actor("lens")
        depth = 1.5
        corners = []
        for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            d = cam.ray_directions(np.array([sx], float), np.array([sy], float))[0]
            corners.append(pos + d * depth / (d @ cam.basis[2]))
        lines = [pv.Line(pos, c) for c in corners]
        lines += [pv.Line(corners[i], corners[(i + 1) % 4]) for i in range(4)]
        p.add_mesh(pv.merge(lines), color="yellow", name="frustum")
        p.add_mesh(pv.Line(pos, pos + np.asarray(cam.basis[2]) * 20.0), color="red",
                   line_width=2, name="gaze_line")
        if not getattr(self, "_scene_camera_set", False):
            p.camera_position = [(2.5, 1.5, 2.0), (0.0, 0.0, -1.5), (0.0, 1.0, 0.0)]
            self._scene_camera_set = True
        # the field of the last frame's first stage, ellipses at the gaze point's slice
        p.subplot(1, 1)
        cache = m.renderer.caches["fields"]
        fields = [cache.get(k) for k in list(cache.keys())]
        # the view's own field (the last stage's), its green channel when per channel
        fields = [f for f in fields if f.camera == fields[-1].camera] if fields else []
        if fields:
            field = min(fields, key=lambda f: abs(f.report.get("wavelength_nm", EYE_REFERENCE_NM)
                                                  - 546.07))
            depth = getattr(m, "gaze_distance_m", None) or 1.0
            k = int(np.argmin(np.abs(field.slice_depths() - depth)))
            self._field_title.SetInput(
                f"blur field at {field.slice_depths()[k]:.2f} m depth, "
                f"{field.report.get('wavelength_nm', EYE_REFERENCE_NM):g} nm (arcmin)")
            # ellipses magnified to fill about half the column spacing (Kakimoto Fig. 12)
            w = field.slice_depths()[k]
            tx, ty = field.camera.tan_half
            spacing = 2 * 2 * w * tx / field.shape[2]
            big = np.abs(field.matrix[k]).max() * w * max(tx, ty)
            glyphs = ellipse_glyphs(field, slices=k, stride=2, segments=24,
                                    scale=0.45 * spacing / big if big > 0 else 1.0)
            if glyphs.n_points:
                p.add_mesh(glyphs, scalars="blur_arcmin", cmap="viridis", name="glyphs",
                           scalar_bar_args={"title": "blur (arcmin)", "n_labels": 3,
                                            "label_font_size": 10, "title_font_size": 10})
                p.view_vector(-np.asarray(field.camera.basis[2]), np.asarray(
                    field.camera.basis[1]))
                p.reset_camera()
            else:
                p.remove_actor("glyphs")
        p.subplot(0, 0)

    # ----------------------------------------------------------------- output
    def _sync_widgets(self):
        for name, w in self._sliders.items():
            w.GetRepresentation().SetValue(float(self.model.value(name)))
        for name, w in self._checks.items():
            w.GetRepresentation().SetState(int(bool(self.model.value(name))))

    def grab_view(self) -> np.ndarray:
        """(h, w, 3) uint8: the simulated view as the window shows it, read back from the
        window's framebuffer (the main viewport's pixels)."""
        self.plotter.render()
        shot = self.plotter.screenshot(return_img=True)
        ren = self._view_renderer
        vx, vy = ren.GetOrigin()
        vw, vh = ren.GetSize()
        H = shot.shape[0]
        return np.ascontiguousarray(shot[H - (vy + vh):H - vy, vx:vx + vw, :3])

    def save(self, path=None) -> tuple:
        """Write the displayed view (as the window shows it) and the spec that reproduces
        it (``s``): ``eyelab-view-<n>.png`` / ``.toml`` in ``save_dir`` unless ``path``."""
        if path is None:
            self._saved += 1
            path = self.save_dir / f"eyelab-view-{self._saved}.png"
        out = self.model.save(path, image=self.grab_view())
        self.model.message = f"saved {out[0]} and {out[1]}"
        return out

    def run_to_target(self) -> None:
        """Open the window (without handing control to the user) and tick until the
        model reaches its target S (scripted use: screenshots, tests)."""
        if not self.plotter.off_screen and not self._opened:
            self.plotter.show(interactive=False, auto_close=False)
            self._opened = True
        while not self.model.done or self.model._pending:
            self.step()
        if self.model.maps_wanted:
            self.model.wait_maps()
            self._maps.sync(self.model)
        self.refresh()

    def show(self) -> None:
        """Open the window and run until it is closed."""
        self.plotter.iren.initialize()
        self.plotter.iren.create_timer(TICK_MS, repeating=True)
        self.plotter.show()

    def close(self) -> None:
        self.plotter.close()
        self.model.close()
