"""Text in eyelab's windows: one font size from the window's height, lines fitted to a
width by measuring them (FreeType, through VTK's text renderer: the same glyphs the window
draws), and the boxes of every piece of text a window shows (for tests: no glyph smaller
than :data:`MIN_GLYPH_PX`, nothing outside its viewport).

Sizes are VTK font sizes, which VTK draws at 72 dpi: a line's box is about N pixels tall
for a size of N, its capitals and digits (the glyph height the window is checked on,
:func:`cap_height_px`, measured on the ink) about 0.75 N: 11 px at 14.
"""

from __future__ import annotations

import functools
import textwrap

import numpy as np

from eyelab.render._vtk import (
    vtkActor2D,
    vtkPropCollection,
    vtkTextActor,
    vtkTextMapper,
    vtkTextProperty,
    vtkTextRenderer,
)

#: The smallest glyph height (px: a capital's or a digit's ink) any text may have.
MIN_GLYPH_PX = 10
#: Font size at the smallest window; it grows with the window's height beyond that.
BASE_FONT = 14
#: Window height (px) per font size point beyond :data:`BASE_FONT` (800 px -> 16).
HEIGHT_PER_POINT = 50.0
#: VTK's text resolution (dpi) for a font size in pixels.
DPI = 72


def font_size(window_height: int) -> int:
    """The window's font size (px at 72 dpi): :data:`BASE_FONT` up to 700 px of height,
    then one per :data:`HEIGHT_PER_POINT` px."""
    return max(BASE_FONT, int(round(window_height / HEIGHT_PER_POINT)))


@functools.lru_cache(maxsize=64)
def cap_height_px(size: int) -> int:
    """Height (px) of a capital H's ink at font ``size``: the glyph height of the text."""
    from eyelab.render._vtk import vtk_to_numpy, vtkImageData

    prop = vtkTextProperty()
    prop.SetFontSize(int(size))
    img = vtkImageData()
    vtkTextRenderer.GetInstance().RenderString(prop, "H", img, [0, 0], DPI)
    w, h, _ = img.GetDimensions()
    alpha = vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, -1)[..., -1]
    rows = np.flatnonzero(alpha.max(axis=1) > 127)
    return int(rows[-1] - rows[0] + 1) if len(rows) else 0


def text_width(text: str, size: int) -> int:
    """Width (px) of the widest line of ``text`` at font ``size``."""
    prop = vtkTextProperty()
    prop.SetFontSize(int(size))
    widest = 0
    for line in text.split("\n") or [""]:
        if not line:
            continue
        bb = [0, 0, 0, 0]
        vtkTextRenderer.GetInstance().GetBoundingBox(prop, line, bb, DPI)
        widest = max(widest, bb[1] - bb[0] + 1)
    return widest


def text_height(text: str, size: int) -> int:
    """Height (px) of ``text``'s lines at font ``size``, as VTK lays them out."""
    prop = vtkTextProperty()
    prop.SetFontSize(int(size))
    bb = [0, 0, 0, 0]
    vtkTextRenderer.GetInstance().GetBoundingBox(prop, text or " ", bb, DPI)
    return bb[3] - bb[2] + 1


def elide(line: str, size: int, width_px: int) -> str:
    """``line`` cut to fit ``width_px`` at font ``size``, ending in an ellipsis when cut."""
    if text_width(line, size) <= width_px:
        return line
    lo, hi = 0, len(line)
    while lo < hi:                       # the longest prefix that fits with the ellipsis
        mid = (lo + hi + 1) // 2
        if text_width(line[:mid].rstrip() + "…", size) <= width_px:
            lo = mid
        else:
            hi = mid - 1
    return line[:lo].rstrip() + "…"


def wrap(text: str, size: int, width_px: int) -> str:
    """``text`` re-wrapped line by line (at word boundaries) to fit ``width_px`` at font
    ``size``; a single word wider than that is elided."""
    out = []
    for line in text.split("\n"):
        if text_width(line, size) <= width_px:
            out.append(line)
            continue
        chars = max(8, len(line))
        while chars > 8:
            parts = textwrap.wrap(line, chars, subsequent_indent="  ")
            if all(text_width(p, size) <= width_px for p in parts):
                break
            chars -= max(1, chars // 12)
        out.extend(elide(p, size, width_px)
                   for p in textwrap.wrap(line, chars, subsequent_indent="  "))
    return "\n".join(out)


def style(actor, size: int, color=(1.0, 1.0, 1.0), *, top: bool = False) -> None:
    """Set a text actor's font size (px) and colour; ``top``: anchored at its top edge
    (multi-line text grows down from its position)."""
    prop = actor.GetTextProperty()
    prop.SetFontSize(int(size))
    prop.SetColor(*color)
    prop.SetVerticalJustificationToTop() if top else prop.SetVerticalJustificationToBottom()


def text_boxes(render_window) -> list:
    """Every non-empty piece of text the window draws: a list of dicts with ``text``,
    ``box`` (x0, x1, y0, y1) in window pixels (origin lower left), ``line_px`` (the box's
    height over its number of lines), ``font_size`` and ``viewport`` (x0, x1, y0, y1) px of
    the renderer it is drawn in. Text actors (PyVista's ``add_text``) and the text of slider widgets
    (their title and value) are read; renderers that are not drawn are skipped."""
    out = []
    rens = render_window.GetRenderers()
    rens.InitTraversal()
    for _ in range(rens.GetNumberOfItems()):
        ren = rens.GetNextItem()
        if not ren.GetDraw():
            continue
        ox, oy = ren.GetOrigin()
        w, h = ren.GetSize()
        port = (ox, ox + w, oy, oy + h)
        props = ren.GetViewProps()
        props.InitTraversal()
        for _ in range(props.GetNumberOfItems()):
            prop = props.GetNextProp()
            if prop.GetVisibility():
                out.extend(_boxes(prop, ren, port))
    return out


def _boxes(prop, ren, port) -> list:
    if isinstance(prop, vtkTextActor):
        text = prop.GetInput() or ""
        if not text.strip():
            return []
        bb = [0.0] * 4
        prop.GetBoundingBox(ren, bb)          # about the actor's anchor
        x0, y0 = prop.GetActualPositionCoordinate().GetComputedDisplayValue(ren)
        return [_entry(text, (bb[0] + x0, bb[1] + x0, bb[2] + y0, bb[3] + y0), port,
                       prop.GetTextProperty().GetFontSize())]
    if isinstance(prop, vtkActor2D) and isinstance(prop.GetMapper(), vtkTextMapper):
        mapper = prop.GetMapper()
        text = mapper.GetInput() or ""
        if not text.strip():
            return []
        size = [0, 0]
        mapper.GetSize(ren, size)
        x, y = prop.GetActualPositionCoordinate().GetComputedDisplayValue(ren)
        just = mapper.GetTextProperty()
        x0 = x - (size[0] / 2 if just.GetJustification() == 1 else
                  size[0] if just.GetJustification() == 2 else 0)
        y0 = y - (size[1] / 2 if just.GetVerticalJustification() == 1 else
                  size[1] if just.GetVerticalJustification() == 2 else 0)
        return [_entry(text, (x0, x0 + size[0], y0, y0 + size[1]), port,
                       just.GetFontSize())]
    if hasattr(prop, "GetActors2D") and not isinstance(prop, vtkActor2D):
        parts = vtkPropCollection()       # a widget representation's own actors
        prop.GetActors2D(parts)
        parts.InitTraversal()
        hidden = None                      # a slider's value label it does not draw
        if hasattr(prop, "GetShowSliderLabel") and not prop.GetShowSliderLabel():
            hidden = prop.GetLabelProperty()
        out = []
        for _ in range(parts.GetNumberOfItems()):
            part = parts.GetNextProp()
            mapper = part.GetMapper() if isinstance(part, vtkActor2D) else None
            if hidden is not None and isinstance(mapper, vtkTextMapper) \
                    and mapper.GetTextProperty() == hidden:
                continue
            out.extend(_boxes(part, ren, port))
        return out
    return []


def _entry(text, box, port, size) -> dict:
    lines = max(1, len(text.rstrip("\n").split("\n")))
    return {"text": text, "box": tuple(float(v) for v in box),
            "line_px": (box[3] - box[2]) / lines, "font_size": int(size), "viewport": port}


def overlaps(boxes: list, slack: float = 1.0) -> list:
    """Pairs of :func:`text_boxes` entries of one viewport whose boxes overlap by more than
    ``slack`` px both ways: [(text a, text b)]."""
    out = []
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            if a["viewport"] != b["viewport"]:
                continue
            dx = min(a["box"][1], b["box"][1]) - max(a["box"][0], b["box"][0])
            dy = min(a["box"][3], b["box"][3]) - max(a["box"][2], b["box"][2])
            if dx > slack and dy > slack:
                out.append((a["text"], b["text"]))
    return out
