"""The inspector's control strip (the bottom row of :class:`eyelab.render.inspector.
InspectorWindow`): the status line, one slider per model control (four to a row, their
values drawn by eyelab in the window's font, VTK's own 5-px label hidden), the toggles'
check boxes and the help hint. Every size follows the window's font
(:mod:`eyelab.render.textlayout`): ``win.scale`` is the font over the base font,
``win.strip_px`` the strip's height in pixels.
"""

from __future__ import annotations

from eyelab.render.textlayout import elide, style

#: Margin (px) between text and its viewport's edges.
MARGIN_PX = 6
#: Sliders to a row.
SLIDER_COLUMNS = 4


def build_controls(win) -> None:
    """Build ``win``'s control strip in the plotter's subplot (2, 0).

    Sets ``win._status`` (the status text actor), ``win._sliders`` (name -> slider
    widget), ``win._values`` (name -> (text actor, format, right edge as a fraction of
    the width, baseline y in px)) and ``win._checks`` (toggle name -> check box widget).
    Widget events go to ``win._request(name, value)``.
    """
    p, m, font = win.plotter, win.model, win.font
    p.subplot(2, 0)
    p.set_background((0.16, 0.16, 0.18))
    k, strip = win.scale, win.strip_px
    win._status = p.add_text(" ", position=(8, strip - MARGIN_PX), color="yellow",
                             name="status")
    style(win._status, font, (1.0, 1.0, 0.0), top=True)
    win._sliders, win._values = {}, {}
    height = font / strip               # a slider's title height, of the strip's
    for i, c in enumerate(m.controls):
        row, col = divmod(i, SLIDER_COLUMNS)
        y = (112 - 56 * row) * k / strip     # the strip's own normalized coordinates
        x0 = 0.02 + col * 0.245
        w = win._sliders[c.name] = p.add_slider_widget(
            lambda v, name=c.name: win._request(name, v), (c.lo, c.hi),
            value=float(m.value(c.name)), title=c.label, pointa=(x0, y),
            pointb=(x0 + 0.2, y), interaction_event="always", fmt=c.fmt,
            title_height=height, style="modern")
        rep = w.GetRepresentation()
        rep.ShowSliderLabelOff()          # VTK sizes it itself (5 px): ours instead
        rep.GetTitleProperty().ShadowOff()
        rep.GetTitleProperty().SetColor(1.0, 1.0, 1.0)
        vy = int(round(y * strip + 9 * k))
        value = p.add_text(" ", position=(int((x0 + 0.2) * win.window_size[0]), vy))
        style(value, font)
        value.GetTextProperty().SetJustificationToRight()
        win._values[c.name] = (value, c.fmt, x0 + 0.2, vy)
    win._checks = {}
    W = win.window_size[0]
    box, y = int(round(18 * k)), int(round(8 * k))
    for i, name in enumerate(m.toggles):
        x = 12 + i * (W // 4)
        win._checks[name] = p.add_checkbox_button_widget(
            lambda v, name=name: win._request(name, v), value=bool(m.value(name)),
            position=(x, y), size=box, border_size=2)
        style(p.add_text(name, position=(x + box + 6, y)), font)
    hint = "h: help" + (" (e: eye, a: anaglyph)" if m.two_eyes else "")
    x = 12 + 3 * (W // 4)
    style(p.add_text(elide(hint, font, W - x - MARGIN_PX), position=(x, y)), font,
          (0.7, 0.7, 0.7))
