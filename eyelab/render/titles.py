"""Panel titles in a band of their own: a 3-D panel's title drawn above its viewport, not
over what it shows (a room fills its panel to the edges, so no camera framing frees the
top). The band is a renderer of its own at the top of the panel's cell, as tall as the
wrapped title; the panel's renderer keeps the rest of the cell. Placed again whenever the
window's size or the title changes (:meth:`TitleBand.place`)."""

from __future__ import annotations

from eyelab.render._vtk import vtkRenderer, vtkTextActor
from eyelab.render.textlayout import style, text_height, wrap


class TitleBand:
    """The title ``text`` of ``ren`` (a panel's renderer in ``ren_win``) at font ``font``
    px, ``margin`` px from the band's edges, on the panel's background."""

    def __init__(self, ren_win, ren, text: str, font: int, margin: int):
        self.ren_win, self.ren, self.text, self.font, self.margin = (ren_win, ren, text, font,
                                                                     margin)
        self.cell = tuple(ren.GetViewport())            # the panel's whole cell (fractions)
        self.band = vtkRenderer()
        self.band.InteractiveOff()
        ren_win.AddRenderer(self.band)
        self.actor = vtkTextActor()
        style(self.actor, font, top=True)
        self.band.AddViewProp(self.actor)
        self.place()

    def set(self, text: str) -> None:
        """A new title, wrapped and placed."""
        self.text = text
        self.place()

    def set_right(self, x1: float) -> None:
        """The cell's right edge moved to ``x1`` (a fraction of the window: the panel
        widened or narrowed), band and panel placed again."""
        x0, y0, _, y1 = self.cell
        self.cell = (x0, y0, float(x1), y1)
        self.place()

    def place(self) -> None:
        """The title wrapped to the cell's width; the band as tall as it (at most half the
        cell), the panel below it."""
        width, height = self.ren_win.GetSize()
        x0, y0, x1, y1 = self.cell
        room = max(20, int((x1 - x0) * width) - 2 * self.margin)
        wrapped = wrap(self.text, self.font, room)
        band_px = text_height(wrapped, self.font) + 2 * self.margin
        frac = min(band_px / max(height, 1), (y1 - y0) / 2)
        self.ren.SetViewport(x0, y0, x1, y1 - frac)
        self.band.SetViewport(x0, y1 - frac, x1, y1)
        self.band.SetBackground(*self.ren.GetBackground())
        self.actor.SetInput(wrapped)
        self.actor.SetPosition(self.margin, max(int(frac * height) - self.margin, 0))
