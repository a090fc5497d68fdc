"""A colour legend eyelab lays out itself: a vertical ramp of a mapper's lookup table, its
title above and three value labels (low, middle, high) beside it, every text at the
window's font size (:mod:`eyelab.render.textlayout`) and wrapped to the room the viewport
has. VTK's ``vtkScalarBarActor`` places and sizes its text on its own, which at small
viewports overlaps the title with the labels; here every box is known."""

from __future__ import annotations

import numpy as np

from eyelab.render._vtk import (
    numpy_to_vtk,
    vtkActor2D,
    vtkCellArray,
    vtkCoordinate,
    vtkPoints,
    vtkPolyData,
    vtkPolyDataMapper2D,
    vtkTextActor,
)
from eyelab.render.textlayout import style, text_width, wrap

#: Steps of the colour ramp, and its width (px).
RAMP_STEPS = 64
RAMP_PX = 10
#: Gaps (px): between the ramp and its labels, and around the legend.
GAP_PX = 4


def _normalized(actor) -> None:
    actor.GetPositionCoordinate().SetCoordinateSystemToNormalizedViewport()


class Legend:
    """A legend in ``renderer`` (hidden until :meth:`show`)."""

    def __init__(self, renderer):
        self.renderer = renderer
        n = RAMP_STEPS + 1
        self._poly = vtkPolyData()
        cells = vtkCellArray()
        for i in range(RAMP_STEPS):
            cells.InsertNextCell(4, (2 * i, 2 * i + 1, 2 * i + 3, 2 * i + 2))
        self._poly.SetPolys(cells)
        self._poly.SetPoints(vtkPoints())
        self._poly.GetPoints().SetNumberOfPoints(2 * n)
        coord = vtkCoordinate()
        coord.SetCoordinateSystemToNormalizedViewport()
        self._mapper = vtkPolyDataMapper2D()
        self._mapper.SetInputData(self._poly)
        self._mapper.SetTransformCoordinate(coord)
        self._mapper.ScalarVisibilityOn()
        self._mapper.SetScalarModeToUsePointData()
        self.ramp = vtkActor2D()
        self.ramp.SetMapper(self._mapper)
        self.title = vtkTextActor()
        self.labels = [vtkTextActor() for _ in range(3)]
        for a in (self.title, *self.labels):
            _normalized(a)
        for a in (self.ramp, self.title, *self.labels):
            renderer.AddViewProp(a)
        self.hide()

    @staticmethod
    def room_px(clim, title: str, size: int, fmt: str = "{:.2f}") -> int:
        """Width (px) a legend of ``clim`` and ``title`` needs at font ``size``: the ramp
        and its widest label, or its title if that is wider, with the gaps."""
        labels = max(text_width(fmt.format(float(v) + 0.0), size)
                     for v in (clim[0], 0.5 * (clim[0] + clim[1]), clim[1]))
        return max(RAMP_PX + GAP_PX + labels, text_width(title, size)) + 3 * GAP_PX

    def hide(self) -> None:
        for a in (self.ramp, self.title, *self.labels):
            a.VisibilityOff()

    def show(self, lut, clim, title: str, *, box=(0.80, 0.12, 0.86, 0.70), size: int = 14,
             fmt: str = "{:.2f}", color=(1.0, 1.0, 1.0)) -> None:
        """The ramp of ``lut`` over ``clim`` (lo, hi) in ``box`` (x0, y0, x1, y1) of the
        viewport (0-1), ``title`` above it (wrapped to the room from x0 to the viewport's
        right edge), the values ``fmt``-formatted to its right, at font ``size`` px."""
        lo, hi = (float(v) for v in clim)
        x0, y0, x1, y1 = box
        ys = np.linspace(y0, y1, RAMP_STEPS + 1)
        pts = np.empty((2 * len(ys), 3))
        pts[0::2, 0], pts[1::2, 0] = x0, x1
        pts[0::2, 1] = pts[1::2, 1] = ys
        pts[:, 2] = 0.0
        self._poly.GetPoints().SetData(numpy_to_vtk(pts, deep=True))
        vals = np.repeat(np.linspace(lo, hi, len(ys)), 2)
        self._poly.GetPointData().SetScalars(numpy_to_vtk(vals, deep=True))
        self._poly.Modified()
        self._mapper.SetLookupTable(lut)
        self._mapper.SetScalarRange(lo, hi if hi > lo else lo + 1e-9)
        w, h = self.renderer.GetSize()
        room = max(20, int((1.0 - x0) * w) - 4)
        self.title.SetInput(wrap(title, size, room))
        style(self.title, size, color)
        # above the high label, which is centred on the ramp's top
        self.title.SetPosition(x0, y1 + (0.6 * size + GAP_PX) / max(h, 1))
        for a, v, y in zip(self.labels, (lo, 0.5 * (lo + hi), hi), (y0, 0.5 * (y0 + y1), y1),
                           strict=True):
            a.SetInput(fmt.format(v + 0.0))
            style(a, size, color)
            a.GetTextProperty().SetVerticalJustificationToCentered()
            a.SetPosition(x1 + GAP_PX / max(w, 1), y)
        for a in (self.ramp, self.title, *self.labels):
            a.VisibilityOn()
