"""The inspector in a notebook: the wearer's live view with sliders, in Jupyter.

``eyelab.NotebookInspector(spec)`` shows what the spec's eye sees as an ipywidgets
``Image``, with a slider for each of the inspector's controls
(:data:`eyelab.jobs.controls.CONTROLS`: the eye's sphere, cylinder and axis, pupil, age,
focus, samples, CVD severity), the gaze (right, up; within the view's limit), and toggles
for the lens, the eye's chromatic aberration and the reconstruction filter. A change
edits the spec through :class:`~eyelab.jobs.inspector.InspectorModel` (validated by the
spec parser: a refused value shows its one-line message and leaves the view as it was),
then shows the frames as they come — a preview first after a change that needs new blur
fields, then every frame up to the target S — so the image you see last is the one
``eyelab render`` gives for the same spec (:meth:`spec_data`). The desktop window is
``eyelab inspect``; this is the same model without VTK windows (renders are offscreen).

Needs ipywidgets (the ``notebook`` extra); in JupyterLab, Notebook 7 or Voilà.
"""

from __future__ import annotations

import copy

#: The gaze sliders' step (degrees).
GAZE_STEP_DEG = 1.0


class NotebookInspector:
    """The live view and its controls, as one ipywidgets ``VBox`` (:attr:`widget`;
    displaying the inspector displays it).

    A slider or toggle moved, or :meth:`set` called, edits the spec; :meth:`spec_data` is
    the spec the view shows. :meth:`close` releases its renderer. Needs ipywidgets (the
    ``notebook`` extra).

    Parameters
    ----------
    spec : str, Path or None
        A spec file's path, or None for the built-in default.
    size : (width, height) or None
        Pixels of the simulated view (default the spec's).
    samples : int or None
        The target number of samples S (default the spec's).

    Examples
    --------
    >>> import eyelab
    >>> inspector = eyelab.NotebookInspector("examples/first.toml", size=(64, 48), samples=2)
    >>> type(inspector.widget).__name__, inspector.spec_data()["eye"]["rx"]
    ('VBox', '-2.50 -0.75 x 90')
    >>> inspector.set("pupil_mm", 30.0)           # refused: the view stays as it was
    'eye.pupil_diameter_mm: must be in [0.5, 10], got 30.0'
    >>> inspector.close()
    """

    def __init__(self, spec=None, *, size=None, samples=None):
        import ipywidgets as w

        from eyelab.imaging.contract import MAX_GAZE_DEG
        from eyelab.jobs.inspector import InspectorModel
        from eyelab.render import use_offscreen

        use_offscreen()
        self.model = m = InspectorModel(spec, size=size, samples=samples)
        self.image = w.Image(format="png", layout=w.Layout(width=f"{m.display_size[0]}px"))
        self.status = w.HTML()
        self.sliders = {}
        for c in m.controls:
            box = w.IntSlider if c.step >= 1 and float(c.step).is_integer() else w.FloatSlider
            kw = {} if box is w.IntSlider else {"readout_format": ".2f"}
            s = box(value=self._clip(m.value(c.name), c), min=c.lo, max=c.hi, step=c.step,
                    description=c.label, continuous_update=False,
                    style={"description_width": "initial"}, **kw)
            s.observe(self._on_slider(c.name), names="value")
            self.sliders[c.name] = s
        gaze = m.value("gaze")
        for i, label in enumerate(("gaze right (deg)", "gaze up (deg)")):
            s = w.FloatSlider(value=gaze[i], min=-MAX_GAZE_DEG, max=MAX_GAZE_DEG,
                              step=GAZE_STEP_DEG, description=label,
                              continuous_update=False, style={"description_width": "initial"})
            s.observe(self._on_gaze, names="value")
            self.sliders[("gaze", i)] = s
        self.toggles = {}
        for name in m.toggles:
            t = w.Checkbox(value=bool(m.value(name)), description=name, indent=False)
            t.observe(self._on_slider(name), names="value")
            self.toggles[name] = t
        controls = w.VBox([*self.sliders.values(), w.HBox(list(self.toggles.values()))])
        self.widget = w.VBox([self.image, self.status, controls])
        self._show_frames()

    @staticmethod
    def _clip(v, c):
        return min(max(v, c.lo), c.hi)

    def _on_slider(self, name):
        def handler(change):
            self.set(name, change["new"])
        return handler

    def _on_gaze(self, _change):
        self.set("gaze", (self.sliders[("gaze", 0)].value, self.sliders[("gaze", 1)].value))

    def set(self, name: str, value) -> str | None:
        """Change control ``name`` (a slider's or toggle's name, or "gaze" with (right, up))
        and show the new frames; returns None, or the one-line message of a refused value
        (shown under the image; the view stays as it was)."""
        error = self.model.apply({name: value})
        if error:
            self.status.value = f"<span style='color:#b00'>{_escape(error)}</span>"
            return error
        self._show_frames()
        return None

    def _show_frames(self) -> None:
        from eyelab.core.fileio import png_bytes

        m = self.model
        while not m.done:
            if m.tick():
                self.image.value = png_bytes(m.display())
                self._status()
        self._status()

    def _status(self) -> None:
        m = self.model
        rep = m.eye_report() or {}
        done = rep.get("samples", {}).get("done_passes", 0)
        state = "done" if m.done else "rendering"
        self.status.value = (f"<code data-passes='{done}' data-target='{m.samples}' "
                             f"data-state='{state}'>{_escape(m.status())}</code>")
        for c in m.controls:         # a value that is not the slider's number says so
            text = m.value_text(c.name)
            plain = text == c.fmt % float(m.value(c.name))
            self.sliders[c.name].description = c.label if plain else f"{c.label}: {text}"
        for name, t in self.toggles.items():       # the model's state, however it changed
            if t.value != bool(m.value(name)):
                t.value = bool(m.value(name))

    def spec_data(self) -> dict:
        """The spec the view shows, as the tables a spec file holds (``eyelab.render`` of
        it gives the same image)."""
        data = copy.deepcopy(self.model.data)
        if not self.model.lens_on:
            data.pop("lens", None)
        return data

    def close(self) -> None:
        """Release the renderer (its GL context) and the maps' worker."""
        self.model.close()

    def _ipython_display_(self):
        from IPython.display import display

        display(self.widget)


def _escape(text: str) -> str:
    import html

    return html.escape(str(text)).replace("\n", "<br>")
