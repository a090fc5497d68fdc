"""The inspector window's as-worn map panel: the lens's mean power error and cylinder over
eye rotations (the model's :meth:`~eyelab.jobs.inspector.InspectorModel.maps`), one map
per viewport of the window's right-hand column, with the current line of sight's point on
both (a green ring and cross: the gaze's Fick angles are a point of the maps' axes).

Each map is the image of its grid (x: eye rotation to the right, y: up, deg; colours
interpolated between grid points, cells touching a point without a light path dropped),
with iso-lines every :func:`~eyelab.render.maps.contour_step` (D, as ``eyelab maps`` draws
them) and, where some lines of sight on the grid miss the lens, its edge (white): the
frame's outline as the turning eye sees it when the lens is cut to a frame. The maps are
drawn once per maps computed; a gaze change only moves the marker (one actor's position)
and rewrites the value under it.
"""

from __future__ import annotations

import math

import numpy as np
import pyvista as pv

from eyelab.render.legend import RAMP_PX, Legend
from eyelab.render.maps import contour_step, finite_cells, map_edge
from eyelab.render.textlayout import BASE_FONT, elide, style, text_width, wrap

#: The marker's colour (sRGB; unlit, so exactly these pixels) and the panel's background.
MARKER_RGB = (0, 255, 0)
BACKGROUND = (0.1, 0.1, 0.12)
#: The maps shown (AsWornMaps attributes), their titles, colour maps and scalar-bar titles.
MAP_LABELS = {"mean_error_d": "mean power error (D)", "cylinder_d": "cylinder (D)"}
CMAPS = {"mean_error_d": "RdBu_r", "cylinder_d": "magma"}
BAR_TITLES = {"mean_error_d": "D", "cylinder_d": "D"}


def marker_mesh(radius: float = 2.5) -> pv.PolyData:
    """A ring (``radius`` deg) with a cross's four arms outside it, about the origin, 1
    unit above the maps (z up, toward the panel's camera)."""
    ring = pv.Disc(center=(0.0, 0.0, 1.0), inner=0.75 * radius, outer=radius,
                   normal=(0.0, 0.0, 1.0), r_res=1, c_res=32)
    arms = [pv.Line((sx * radius, sy * radius, 1.0), (sx * 2 * radius, sy * 2 * radius, 1.0))
            for sx, sy in ((1, 0), (-1, 0), (0, 1), (0, -1))]
    return pv.merge([ring.extract_surface(algorithm=None), *arms])


def map_colouring(values: np.ndarray, name: str) -> tuple:
    """(clim (D), iso-levels (D), cmap name) of a map's ``values`` (ny, nx) D: symmetric
    about 0 for the mean power error, from the most negative cylinder to 0 for the
    cylinder; the levels every contour step."""
    finite = values[np.isfinite(values)]
    span = float(np.abs(finite).max()) if finite.size else 0.0
    step = contour_step(max(span, 0.05))
    top = step * max(1, math.ceil(span / step - 1e-9))
    if name == "cylinder_d":
        levels = np.arange(-top, -step / 2, step)
        return (-top, 0.0), levels, CMAPS[name]
    return (-top, top), np.arange(-top, top + step / 2, step), CMAPS.get(name, "viridis")


class MapPanel:
    """The maps in the plotter's ``cells`` (one per :data:`MAP_LABELS` entry), shown and
    hidden by ``relayout(shown)`` (the window gives or takes back their room) as the model
    wants them (:attr:`~eyelab.jobs.inspector.InspectorModel.maps_wanted`); ``grid``:
    the maps' (half angle (deg), points per side), the model's ``maps_grid``.

    ``draws`` counts the maps drawn, ``marker_moves`` the marker's moves."""

    def __init__(self, plotter, cells=((0, 2), (1, 2)), relayout=None, grid=(40.0, 21),
                 font: int = BASE_FONT):
        self.plotter = plotter
        self.font = int(font)
        self.half, self.points = float(grid[0]), int(grid[1])
        self.cells = dict(zip(MAP_LABELS, cells, strict=True))
        self.relayout = relayout
        self.renderers, self._texts, self._markers, self._legends = {}, {}, {}, {}
        self._titles = {}
        for name, cell in self.cells.items():
            plotter.subplot(*cell)
            plotter.set_background(BACKGROUND)
            self.renderers[name] = plotter.renderer
            self._titles[name] = plotter.add_text(" ", position=(6, 6),
                                                  name=f"map_title_{name}")
            style(self._titles[name], self.font, top=True)
            self._texts[name] = plotter.add_text(" ", position=(6, 4),
                                                 name=f"map_value_{name}")
            style(self._texts[name], self.font)
            self._legends[name] = Legend(plotter.renderer)
            actor = plotter.add_mesh(marker_mesh(), color=MARKER_RGB, lighting=False,
                                     line_width=2, name=f"map_marker_{name}",
                                     reset_camera=False)
            actor.VisibilityOff()
            self._markers[name] = actor
            self._fit_camera(plotter.renderer)
        self.place_titles()
        plotter.subplot(0, 0)
        self.shown = None
        self.drawn = None          # (key, state) the panel shows
        self.marker_at = None
        self.draws = 0
        self.marker_moves = 0

    # ----------------------------------------------------------------- update
    def sync(self, model) -> bool:
        """Bring the panel up to the model: shown or hidden, the maps (re)drawn when new
        ones are ready, the marker moved when the gaze has. Returns whether anything
        changed (the window then renders)."""
        changed = self._set_shown(bool(model.maps_wanted))
        if not self.shown:
            return changed
        drawn = (model.maps_key(), model.maps_state())
        if drawn != self.drawn:
            self._draw(model.maps(), drawn[1])
            self.drawn = drawn
            changed = True
        gaze = tuple(float(v) for v in model.value("gaze"))
        if changed or gaze != self.marker_at:
            self._move_marker(model.gaze_marker(), gaze)
            changed = True
        return changed

    def _set_shown(self, shown: bool) -> bool:
        if shown == self.shown:
            return False
        self.shown = shown
        for ren in self.renderers.values():
            ren.SetDraw(int(shown))
            ren.SetInteractive(int(shown))
        if self.relayout is not None:
            self.relayout(shown)
        if shown:
            for ren in self.renderers.values():
                self._fit_camera(ren)
        return True

    def _draw(self, maps, state: str) -> None:
        """The maps, or the state's message (computing, refused) in their place."""
        p = self.plotter
        for name, cell in self.cells.items():
            p.subplot(*cell)
            for part in ("map", "iso", "edge"):
                p.remove_actor(f"map_{part}_{name}", render=False)
            self._legends[name].hide()
            if maps is not None:
                self._draw_map(maps, name)
            self._fit_camera(p.renderer)
        p.subplot(0, 0)
        if maps is not None:
            self.draws += 1
        elif state == "computing":
            self._say(f"computing the as-worn maps ({self.points} x {self.points} eye "
                      f"rotations, +-{self.half:g} deg)...")
        else:
            self._say(state)

    def _draw_map(self, maps, name: str) -> None:
        p = self.plotter
        cells = finite_cells(maps, name)
        if cells.n_cells == 0:
            return
        clim, levels, cmap = map_colouring(np.asarray(getattr(maps, name), float), name)
        actor = p.add_mesh(cells, scalars=name, cmap=cmap, clim=clim, lighting=False,
                           interpolate_before_map=True, name=f"map_map_{name}",
                           reset_camera=False, show_scalar_bar=False, render=False)
        bar_x = _frame(p.renderer, self.half, self._legend_px())[2]
        vw = max(p.renderer.GetSize()[0], 1)
        self._legends[name].show(actor.mapper.lookup_table, clim, BAR_TITLES[name],
                                 box=(bar_x, 0.16, bar_x + RAMP_PX / vw, 0.62), size=self.font,
                                 fmt="{:+.2f}")
        iso = cells.contour(isosurfaces=list(levels), scalars=name) if len(levels) else None
        if iso is not None and iso.n_points:
            p.add_mesh(iso.translate((0.0, 0.0, 0.2)), color="black", line_width=1,
                       lighting=False, name=f"map_iso_{name}", reset_camera=False,
                       render=False)
        edge = map_edge(maps)
        if edge.n_points:
            p.add_mesh(edge.translate((0.0, 0.0, 0.5)), color="white", line_width=2,
                       lighting=False, name=f"map_edge_{name}", reset_camera=False,
                       render=False)

    def _legend_px(self) -> int:
        """Room (px) right of a map for its legend: the ramp, its widest label, its title."""
        return Legend.room_px((-10.0, 10.0), "D", self.font, "{:+.2f}")

    def place_titles(self) -> None:
        """Each map's title at its viewport's top left, fitted to its width."""
        for name, ren in self.renderers.items():
            vw, vh = ren.GetSize()
            self._titles[name].SetPosition(6, max(vh - 6, 0))
            self._titles[name].SetInput(wrap(MAP_LABELS[name] + ", as worn", self.font,
                                             max(vw - 12, 20)))

    def _say(self, text: str) -> None:
        for name in self.cells:
            vw = self.renderers[name].GetSize()[0]
            self._texts[name].SetInput(wrap(text, self.font, max(vw - 12, 20))
                                       if name == "mean_error_d" else "")
            self._markers[name].VisibilityOff()

    def _move_marker(self, marker: dict | None, gaze: tuple) -> None:
        """The marker at the gaze's eye rotation and the maps' values there."""
        self.marker_at = gaze
        if marker is None:
            return
        a, e = marker["eye_rotation_deg"]
        on_map = abs(a) <= self.half and abs(e) <= self.half
        for name in self.cells:
            actor = self._markers[name]
            actor.SetPosition(a, e, 0.0)
            actor.SetVisibility(on_map)
            v = marker[name]
            value = (f"{round(v, 2) + 0.0:+.2f} D" if math.isfinite(v) else
                     "no path through the lens" if on_map else "beyond the maps")
            room = max(self.renderers[name].GetSize()[0] - 12, 20)
            # the value first: where the gaze is, said shorter or not at all when narrow
            gaze = f"({round(a) + 0:+d}, {round(e) + 0:+d})"
            text = next((t for t in (f"gaze {gaze} deg: {value}", f"{gaze}: {value}", value)
                         if text_width(t, self.font) <= room), value)
            self._texts[name].SetInput(elide(text, self.font, room))
        self.marker_moves += 1

    # ---------------------------------------------------------------- geometry
    def _fit_camera(self, ren) -> None:
        """A parallel camera down -z: the map's square on the left with room above and
        below for the title and the value, the scalar bar right of it."""
        scale, fx, _ = _frame(ren, self.half, self._legend_px())
        if scale is None:
            return
        cam = ren.GetActiveCamera()
        cam.ParallelProjectionOn()
        cam.SetParallelScale(scale)
        cam.SetFocalPoint(fx, 0.0, 0.0)
        cam.SetPosition(fx, 0.0, 100.0)
        cam.SetViewUp(0.0, 1.0, 0.0)
        cam.SetClippingRange(1.0, 200.0)
        ren.camera_set = True            # PyVista must not reset it at the first render

    def eye_rotation_at(self, x: float, y: float) -> tuple | None:
        """(right, up) eye rotation (deg) under display point (x, y) px (origin at the
        window's lower left) when it falls on a shown map, else None."""
        if not self.shown:
            return None
        for ren in self.renderers.values():
            vx, vy = ren.GetOrigin()
            vw, vh = ren.GetSize()
            if vx <= x < vx + vw and vy <= y < vy + vh:
                ren.SetDisplayPoint(float(x), float(y), 0.0)
                ren.DisplayToWorld()
                wx, wy, _, w = ren.GetWorldPoint()
                a, e = (wx / w, wy / w) if w else (wx, wy)
                if abs(a) <= self.half and abs(e) <= self.half:
                    return float(a), float(e)
        return None

    def display_point(self, a_deg: float, e_deg: float, name: str = "mean_error_d") -> tuple:
        """Display position (x, y) px (origin at the window's lower left) of eye rotation
        (a_deg right, e_deg up) on map ``name``."""
        ren = self.renderers[name]
        ren.SetWorldPoint(float(a_deg), float(e_deg), 1.0, 1.0)
        ren.WorldToDisplay()
        dx, dy, _ = ren.GetDisplayPoint()
        return dx, dy

    def marker_display(self, name: str = "mean_error_d") -> tuple:
        """Display position (x, y) px of the marker's centre on map ``name``."""
        x, y, _ = self._markers[name].GetPosition()
        return self.display_point(x, y, name)


def _frame(ren, half: float, legend_px: int = 60) -> tuple:
    """(parallel scale, focal x, the legend's x in the viewport (0-1)) that show a map's
    +-``half`` deg square in renderer ``ren``: at most 64 % of the viewport's height (room
    above for the title, below for the value) and as wide as the viewport leaves beside
    the legend's ``legend_px``, its left edge 6 px from the viewport's; (None, None, 0.78)
    before the viewport has a size."""
    vw, vh = ren.GetSize()
    if vw <= 0 or vh <= 0:
        return None, None, 0.78
    side = max(8.0, min(0.64 * vh, vw - legend_px - 12.0))      # the map's side, px
    scale = half * vh / side                 # parallel scale: half the viewport's height
    deg_per_px = 2.0 * scale / vh
    fx = -half - 6.0 * deg_per_px + 0.5 * vw * deg_per_px
    return scale, fx, (6.0 + side + 6.0) / vw
