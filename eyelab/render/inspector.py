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
``o`` re-reads the spec file; ``h`` shows or hides the help (with the whole status); ``q``
quits. Two eyes (a two-eye spec): both eyes' views as the spec's ``binocular.output``
shows them; ``e`` cycles the eye the sliders edit (both, right, left); ``a`` toggles a
red/cyan anaglyph; the status shows the pupillary and frame PDs and the prism at the
fixated point; the scene view draws both eyes, the blur field and the maps are the edited
eye's (the right when both).

Text: one font size from the window's height (:mod:`eyelab.render.textlayout`); every
line fitted to its viewport (the status elided, its whole text in the help); the window
may be any size (``window_size``): the simulated view is then shown scaled to fit its
cell (and read back from the model, not the screen, when saved).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyvista as pv

from eyelab.render._vtk import vtkRenderer
from eyelab.render.controlstrip import MARGIN_PX, build_controls
from eyelab.render.legend import Legend
from eyelab.render.mappanel import MapPanel
from eyelab.render.sideviews import draw_side
from eyelab.render.textlayout import BASE_FONT, elide, font_size, style, wrap
from eyelab.render.titles import TitleBand

#: Timer period (ms) between ticks.
TICK_MS = 15
#: Height (px) of the controls strip at the base font (it grows with the font) and width
#: of the side column relative to the view.
CONTROLS_PX = 230
SIDE_FRACTION = 0.5
#: Width of the as-worn map column relative to the view's height (each map is half of it).
MAPS_FRACTION = 0.55
#: The smallest window (px) by default: a small view gets this much room around it.
DEFAULT_WINDOW = (960, 710)
#: The largest window (px) by default, a laptop's screen: a view that would need more is
#: shown scaled to fit (two eyes side by side at 640 x 480 each wanted 1864 px).
MAX_DEFAULT_WINDOW = (1440, 900)
#: The smallest window (px) the layout keeps legible (``window_size``).
MIN_WINDOW = (800, 560)
#: Degrees per arrow-key press.
GAZE_STEP_DEG = 2.0

HELP = ("arrows: gaze +-2 deg   click: look there (view or map)   l: lens on/off\n"
        "m: as-worn maps on/off   v: colour vision   c: lens for the eye's Rx\n"
        "s: save view + spec   r: reset   o: reload spec   h: this help   q: quit")
HELP_TWO_EYES = "e: sliders edit both eyes / right / left   a: anaglyph on/off"
#: Lines of status the strip shows (the rest: in the ``h`` help).
STATUS_LINES = 4


class InspectorWindow:
    """The window around ``model``; ``off_screen`` for tests and screenshots."""

    def __init__(self, model, *, off_screen: bool = False, save_dir=".",
                 window_size=None):
        self.model = model
        self.save_dir = Path(save_dir)
        w, h = model.display_size
        side = max(240, int(round(model.size[0] * SIDE_FRACTION)))
        maps_w = max(220, int(round(h * MAPS_FRACTION)))
        natural = (min(max(w + side + maps_w, DEFAULT_WINDOW[0]), MAX_DEFAULT_WINDOW[0]),
                   min(max(h + CONTROLS_PX, DEFAULT_WINDOW[1]), MAX_DEFAULT_WINDOW[1]))
        self.window_size = tuple(int(v) for v in (window_size or natural))
        W, H = self.window_size
        self.font = font_size(H)
        self.scale = self.font / BASE_FONT          # the controls strip's layout grows with it
        self.strip_px = int(round(CONTROLS_PX * self.scale))
        total = w + side + maps_w
        self._columns = (w / total, (w + side) / total)
        top = max(H - self.strip_px, 2)
        p = pv.Plotter(off_screen=off_screen, shape=(3, 3),
                       groups=[(np.s_[0:2], 0), (2, np.s_[0:3])],
                       row_weights=[top / 2, top / 2, self.strip_px],
                       col_weights=[w, side, maps_w],
                       window_size=self.window_size, border=False,
                       title="eyelab inspector")
        self.plotter = p
        self._overlay = self._add_overlay()
        self._ready = False
        self._opened = False
        self._saved = 0
        self._help_on = False
        self._build_view()
        self._build_scene_view()
        self._build_controls()
        self._maps = MapPanel(p, ((0, 2), (1, 2)), relayout=self._layout,
                              grid=model.maps_grid, font=self.font)
        self._maps.sync(model)
        self._field_actor = None
        self._update_side = True
        self._ready = True
        self.refresh()
        p.ren_win.AddObserver("WindowResizeEvent", self._on_resize)
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
                        ("h", self._toggle_help), ("e", self._cycle_edit),
                        ("a", self._toggle_anaglyph)):
            p.add_key_event(key, fn)

    # ------------------------------------------------------------- building
    def _build_view(self):
        p = self.plotter
        p.subplot(0, 0)
        p.set_background("black")
        self._view_renderer = p.renderer
        self._make_view_plane(*self.model.display_size)

    def _make_view_plane(self, w: int, h: int) -> None:
        """The textured plane of a (w, h) px image under a parallel camera."""
        p = self.plotter
        p.subplot(0, 0)
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
        cam.up = (0.0, 1.0, 0.0)
        self._view_px = (w, h)
        self._fit_view_camera()
        cam.clipping_range = (1.0, 20.0)

    def _add_overlay(self):
        """A renderer over the whole window (layer 1) for the help text."""
        win = self.plotter.ren_win
        win.SetNumberOfLayers(2)
        ren = vtkRenderer()
        ren.SetLayer(1)
        ren.SetViewport(0.0, 0.0, 1.0, 1.0)
        ren.InteractiveOff()
        win.AddRenderer(ren)
        from eyelab.render._vtk import vtkTextActor

        self._help = vtkTextActor()
        style(self._help, self.font, top=True)
        prop = self._help.GetTextProperty()
        prop.SetBackgroundColor(0.0, 0.0, 0.0)
        prop.SetBackgroundOpacity(0.85)
        self._help.SetPosition(MARGIN_PX, self.window_size[1] - MARGIN_PX)
        ren.AddViewProp(self._help)
        return ren

    def _layout(self, maps_shown: bool) -> None:
        """The side column's right edge: before the map column, or at the window's edge
        when the maps are hidden (their renderers are not drawn)."""
        right = self._columns[1] if maps_shown else 1.0
        for band in self._top_texts.values():      # each side panel with its title band
            band.set_right(right)

    def _fit_view_camera(self):
        """Parallel scale that shows the image whole: one texel per pixel when the viewport
        holds it, else scaled down to fit (:attr:`one_to_one` says which)."""
        vw, vh = self._view_renderer.GetSize()
        w, h = self._view_px
        vw, vh = vw or w, vh or h
        cam = self.plotter.renderers[0].camera
        cam.parallel_scale = max(vh, h, w * vh / vw) / 2.0
        if vw >= w and vh >= h:     # texel j on pixel i0 + j exactly (no half-pixel shift)
            i0, j0 = self._image_origin()
            fx, fy = vw / 2 - i0, vh / 2 - j0
        else:
            fx, fy = w / 2, h / 2
        cam.position = (fx, fy, 10.0)
        cam.focal_point = (fx, fy, 0.0)

    def _image_origin(self) -> tuple:
        """(i0, j0) px of the image's lower-left corner in the view's viewport (1:1)."""
        vw, vh = self._view_renderer.GetSize()
        return (vw - self._view_px[0]) // 2, (vh - self._view_px[1]) // 2

    @property
    def one_to_one(self) -> bool:
        """Whether the view shows the image one texel per screen pixel."""
        vw, vh = self._view_renderer.GetSize()
        return vw >= self._view_px[0] and vh >= self._view_px[1]

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
        self._top_texts = {}
        self._top_text(p.renderer, "scene", "scene, eyes, lenses, lines of sight"
                       if self.model.two_eyes else "scene, eye, lens, line of sight")
        p.subplot(1, 1)
        p.set_background((0.08, 0.08, 0.1))
        self._top_text(p.renderer, "field", "blur field at the gaze depth")
        self._field_legend = Legend(p.renderer)

    def _top_text(self, ren, key: str, text: str) -> None:
        """The title of renderer ``ren``'s panel, in a band above it
        (:class:`~eyelab.render.titles.TitleBand`; placed again when the window's size
        changes: :meth:`_place_texts`)."""
        self._top_texts[key] = TitleBand(self.plotter.ren_win, ren, text, self.font,
                                         MARGIN_PX)

    def set_top_text(self, key: str, text: str) -> None:
        """Set the title ``key`` ("scene", "field"), wrapped to its panel's width."""
        self._top_texts[key].set(text)

    def _place_texts(self) -> None:
        """Every text whose place or width follows the window's size."""
        self._help.SetPosition(MARGIN_PX, self.window_size[1] - MARGIN_PX)
        for band in self._top_texts.values():
            band.place()
        W = self.window_size[0]
        for actor, _, x1, y in self._values.values():
            actor.SetPosition(int(x1 * W), y)
        self._maps.place_titles()

    def _on_resize(self, obj, event) -> None:
        """The window was resized: the view's scale, the texts' places and widths."""
        self.window_size = tuple(int(v) for v in self.plotter.ren_win.GetSize())
        self._fit_view_camera()
        self._place_texts()
        self.refresh()

    def _build_controls(self):
        build_controls(self)

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
        self._show_help()

    def _show_help(self):
        """The keys and the whole status (which the strip may elide), wrapped to the
        window, over everything."""
        if not self._help_on:
            self._help.SetInput("")
            return
        keys = HELP + ("\n" + HELP_TWO_EYES if self.model.two_eyes else "")
        text = keys + "\n\n" + self._status_text()
        self._help.SetInput(wrap(text, self.font, self.window_size[0] - 2 * MARGIN_PX))

    def _cycle_edit(self):
        self.model.cycle_edit()
        self._sync_widgets()
        self._update_side = True
        self.refresh()

    def _toggle_anaglyph(self):
        self.model.toggle_anaglyph()
        self.refresh()

    def _on_click(self, obj, event):
        x, y = self.plotter.iren.get_event_position()
        on_map = self._maps.eye_rotation_at(x, y)
        if on_map is not None:            # a map's point is an eye rotation: look there
            gaze = self.model.gaze_for_eye_rotation(on_map)
            self._request("gaze", tuple(round(v, 1) for v in gaze))
            return
        ren = self._view_renderer
        vx, vy = ren.GetOrigin()
        vw, vh = ren.GetSize()
        if not (vx <= x < vx + vw and vy <= y < vy + vh):
            return
        # the view's pixel under the click (the image centred; texels per pixel: scale)
        iw, h = self._view_px
        scale = self.plotter.renderers[0].camera.parallel_scale * 2.0 / vh
        px = iw / 2 + (x - vx - vw / 2) * scale
        py = h / 2 + (y - vy - vh / 2) * scale
        if not (0 <= px < iw and 0 <= py < h):
            return
        w = self.model.size[0]
        px = px % w                 # two eyes side by side: the pixel in its eye's view
        view = self.model.view
        g = self.model.value("gaze")
        ty = math.tan(math.radians(view.fov_y_deg / 2))
        tx = ty * w / h
        dx = math.degrees(math.atan((2 * px / w - 1) * tx))
        dy = math.degrees(math.atan((2 * py / h - 1) * ty))
        self._request("gaze", (max(-60.0, min(60.0, g[0] + dx)),
                               max(-60.0, min(60.0, g[1] + dy))))

    def _on_timer(self, obj, event):
        from eyelab.core import interrupt

        if interrupt.requested() is not None:     # Ctrl-C / SIGTERM: end the event loop
            self.plotter.iren.terminate_app()
            return
        if self.step():
            self.plotter.render()

    # --------------------------------------------------------------- drawing
    def step(self) -> bool:
        """One tick of the model; the display refreshed when its image changed, the map
        panel brought up to the model. Returns whether the window needs a render."""
        before, was_done = self.model.last_change, self.model.done
        changed = self.model.tick()
        if self.model.last_change != before or (self.model.done and not was_done):
            self._update_side = True            # and once more with the finished frame's
        if changed:
            self.refresh()
        return self._maps.sync(self.model) or changed

    def refresh(self) -> None:
        """Show the model's current image, status and (after a change) side views."""
        img = self.model.display()
        h, w = img.shape[:2]
        if (w, h) != self._view_px:        # two eyes: side by side <-> anaglyph
            self._make_view_plane(w, h)
        self._image.point_data["rgb"][:] = img[::-1].reshape(-1, 3)
        self._image.Modified()
        self._texture.Modified()
        if self._update_side and self.model.result is not None:
            self._update_side = False
            try:
                text_r = self.model.readout()
            except Exception as e:         # the readout must never stop the window
                text_r = f"gaze point: {e}"
            self._readout = text_r
            self._draw_side()
        for name, (actor, _, _, _) in self._values.items():
            actor.SetInput(self.model.value_text(name))
        self._sync_widgets(sliders=False)
        room = self.window_size[0] - 16
        lines = self._status_text().split("\n")
        if len(lines) > STATUS_LINES:           # the rest in the help
            more = len(lines) - STATUS_LINES + 1
            lines = lines[:STATUS_LINES - 1] + [f"(+{more} lines: press h)"]
        self._status.SetInput("\n".join(elide(line, self.font, room) for line in lines))
        self._show_help()

    def _status_text(self) -> str:
        return self.model.status() + "\n" + getattr(self, "_readout", "")

    def _draw_side(self):
        """Eye(s), lens(es), frustum and line of sight; the blur-field glyphs."""
        draw_side(self)

    # ----------------------------------------------------------------- output
    def _sync_widgets(self, sliders: bool = True):
        """Every widget mirrors the model, whichever way its value changed (mouse, key,
        reset): the check boxes always, the sliders unless ``sliders`` is false (a slider
        being dragged is ahead of the model by a tick)."""
        for name, w in (self._sliders.items() if sliders else ()):
            w.GetRepresentation().SetValue(float(self.model.value(name)))
        for name, w in self._checks.items():
            state = int(bool(self.model.value(name)))
            if w.GetRepresentation().GetState() != state:
                w.GetRepresentation().SetState(state)

    def grab_view(self) -> np.ndarray:
        """(h, w, 3) uint8: the simulated view as the window shows it, read back from the
        window's framebuffer (the image's pixels in the main viewport) when it is shown one
        texel per pixel; else (scaled to fit a small window) the model's image."""
        self._fit_view_camera()             # the viewport's size now (after a resize)
        if not self.one_to_one:
            return self.model.display()
        self.plotter.render()
        shot = self.plotter.screenshot(return_img=True)
        vx, vy = self._view_renderer.GetOrigin()
        i0, j0 = self._image_origin()
        w, h = self._view_px
        H = shot.shape[0]
        y1 = H - (vy + j0)
        return np.ascontiguousarray(shot[y1 - h:y1, vx + i0:vx + i0 + w, :3])

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
        self.plotter.render()       # the window shows the finished state (a shot reads it)

    def show(self) -> None:
        """Open the window and run until it is closed. Ctrl-C or SIGTERM ends the event
        loop at the next timer tick (never inside VTK's callbacks) and is raised here
        after it (:func:`eyelab.core.interrupt.recorded`): the command then says
        ``eyelab: interrupted`` / ``terminated`` and exits 130 / 143 as every other."""
        from eyelab.core import interrupt
        from eyelab.core.errors import SpecError
        from eyelab.render import NO_WINDOW_WAYS, window_error

        self.plotter.iren.initialize()
        why = window_error(self.plotter.ren_win)
        if why is not None:
            raise SpecError("inspect", f"{why}; {NO_WINDOW_WAYS}")
        self.plotter.iren.create_timer(TICK_MS, repeating=True)
        with interrupt.recorded():
            self.plotter.show()
        interrupt.check()

    def close(self) -> None:
        self.plotter.close()
        self.model.close()
