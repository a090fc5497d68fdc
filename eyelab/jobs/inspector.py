"""The inspector's model, without any GL: the spec being inspected as an editable TOML
table, the controls that change it, and the progressive frame loop over one reused raster
renderer. The window (PyVista widgets, viewports, timer) is :mod:`eyelab.render.inspector`.

Every change edits the table and is validated by the spec parser (a refused value leaves
the state as it was and returns the parser's one-line message), so the window's state is
always a spec that :func:`dump` writes and ``eyelab render`` reproduces. Changes arriving
between two timer ticks are coalesced (:meth:`InspectorModel.request`): a slider dragged
continuously costs one restart per tick, not one per event. What a restart recomputes is
decided by the renderer's content-keyed caches: a change of S re-runs passes only, a lens
change keeps the naked-eye field, and so on (the report's cache misses say what was
recomputed). The colour-vision deficiency is applied here, to the finished linear image,
so changing it re-runs nothing. The lens's as-worn maps and the line of sight's point on
them (:class:`~eyelab.jobs.gazemaps.GazeMapsMixin`) are computed on a worker thread once
the first frame after a lens change has been shown, and kept per lens.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

from eyelab.core.color import CVD_KINDS, cvd_linear, encode_srgb
from eyelab.core.errors import SpecError
from eyelab.jobs.controls import (
    CONTROL,
    CONTROLS,
    CVD_CYCLE,
    PREVIEW_AFTER,
    STEP,
    TOGGLES,
    rx_beside_aberrations,
    snap,
)
from eyelab.jobs.frameloop import FrameLoopMixin
from eyelab.jobs.gazemaps import GazeMaps, GazeMapsMixin
from eyelab.jobs.readout import ReadoutMixin
from eyelab.jobs.twoeyes import TwoEyesMixin, sided_data
from eyelab.spec import dump_spec, parse_spec, read_spec_data


class InspectorModel(TwoEyesMixin, FrameLoopMixin, GazeMapsMixin, ReadoutMixin):
    """The inspected spec and its frames.

    Parameters
    ----------
    path : a spec file, or None for the built-in default
    size : (width, height) px of the simulated view, overriding the spec's
    samples : the target S, overriding the spec's
    scene : a built-in scene name or mesh file, or a ``[render] scene`` table (a mesh
        file's ``path`` and placement), overriding the spec's
    every : passes run per :meth:`tick` once the first frame is shown
    """

    controls = CONTROLS
    toggles = TOGGLES
    cvd_cycle = CVD_CYCLE

    def __init__(self, path=None, *, size=None, samples=None, scene=None, every: int = 1):
        from eyelab.render.raster import RasterRenderer

        self.path = None if path is None else str(path)
        self.every = max(1, int(every))
        self._overrides = {"size": size, "samples": samples, "scene": scene}
        self.renderer = RasterRenderer()
        self._left_renderer = None     # two eyes: the left eye's own (its GL state, caches)
        self._preview_renderers = []   # the previews' own, per eye (FrameLoopMixin)
        self.pose = None               # two eyes: the last frame's BinocularPose
        self._scenes = {}
        self._pending = {}
        self._frames = None
        self.result = None          # the last RenderResult (no CVD: applied in display())
        self.last_change = "loaded"
        self.message = ""
        self.timings = {}
        self.gaze_distance_m = None
        self.maps_on = True          # the as-worn map panel (display only, not in the spec)
        self.gaze_maps = GazeMaps()
        self.load()

    # ------------------------------------------------------------------ state
    def load(self) -> None:
        """(Re)read the spec file (or the built-in default) and restart."""
        data, source, base = read_spec_data(self.path)
        data = copy.deepcopy(data)
        r = data.setdefault("render", {})
        if r.get("camera") is not None:    # a camera has no eye for the controls to move
            from eyelab.spec import no_camera

            no_camera(parse_spec(data, source, base), "the inspector")
        if r.get("renderer", "raster") != "raster":
            # the inspector is the raster renderer's; the reference's own keys are dropped
            from eyelab.spec import renderer_keys

            keep = set(renderer_keys("raster"))
            data["render"] = {k: v for k, v in r.items() if k in keep}
            data["render"]["renderer"] = "raster"
            self.message = "the inspector renders with the raster renderer"
        size, samples = self._overrides["size"], self._overrides["samples"]
        if size is not None:
            data["render"]["width"], data["render"]["height"] = (int(v) for v in size)
        if samples is not None:
            data["render"]["samples"] = int(samples)
        scene = self._overrides["scene"]
        if isinstance(scene, dict):          # a mesh file and its placement
            data["render"]["scene"] = {**scene, "path": str(Path(scene["path"]).resolve())}
        elif scene is not None:
            data["render"]["scene"] = str(Path(scene).resolve())
        spec = parse_spec(data, source, base)
        if hasattr(self, "spec") and (spec.binocular is not None) != self.two_eyes:
            now = "two eyes" if spec.binocular is not None else "one eye"
            raise SpecError("binocular", f"the spec now has {now}: open the inspector on it "
                                         "again to show that")
        self.source, self.base = source, base
        if spec.binocular is not None:      # each eye's keys in its own table
            data = sided_data(data)
        eye = data.get("eye", {})
        for side in (("right", "left") if spec.binocular is not None else (None,)):
            t = eye if side is None else eye.get(side, {})
            t.update(rx_beside_aberrations(t, base, eye if side is not None else None))
        lens = data.get("lens", {})
        if spec.binocular is None and "lens" in data and "rx" not in lens \
                and "front" not in lens and "rx" in data.get("eye", {}):
            # the lens keeps its own prescription while the eye's controls move
            data["lens"]["rx"] = data["eye"]["rx"]
        self.spec = parse_spec(data, self.source, self.base)
        self.reset_eyes()
        self.loaded = copy.deepcopy(data)
        self.data = data
        self.lens_on = "lens" in data
        self.cvd = self.spec.render.view.cvd
        self.cvd_severity = self.spec.render.view.cvd_severity
        self.restart("loaded")

    def reset(self) -> None:
        """Back to the spec as loaded."""
        self.data = copy.deepcopy(self.loaded)
        self.spec = parse_spec(self.data, self.source, self.base)
        self.reset_eyes()
        self.lens_on = "lens" in self.data
        self.cvd = self.spec.render.view.cvd
        self.cvd_severity = self.spec.render.view.cvd_severity
        self.restart("reset")

    @property
    def view(self):
        """The simulated view (no CVD: the model applies it)."""
        return self.spec.render.view.replace(cvd=None)

    @property
    def size(self) -> tuple:
        return self.view.width, self.view.height

    @property
    def samples(self) -> int:
        return self.spec.render.quality.samples

    def value(self, name: str):
        """The current value of a control or toggle."""
        eye, render = self._eye_table(), self.data.get("render", {})
        if name in ("sphere", "cylinder", "axis"):
            rx = self.eye_rx()
            return {"sphere": rx.sphere, "cylinder": rx.cylinder, "axis": rx.axis}[name]
        if name == "pupil_mm":
            return self.eye.pupil_diameter * 1e3
        if name == "age":      # without an age: the age whose mean amplitude is the eye's
            return float(eye["age"]) if "age" in eye else min(max(
                (18.5 - self.eye.accommodation_max) / 0.3, CONTROL["age"].lo), CONTROL["age"].hi)
        if name == "focus_d":
            f = self.spec.render.view.focus_d
            return -0.5 if f is None else f
        if name == "samples":
            return self.samples
        if name == "cvd_severity":
            return self.cvd_severity
        if name == "lens":
            return self.lens_on
        if name in ("chromatic", "reconstruct"):
            return bool(getattr(self.spec.render.quality, name))
        if name == "gaze":
            return tuple(render.get("gaze_deg", (0.0, 0.0)))
        if name == "cvd":
            return self.cvd
        if name == "maps":
            return self.maps_on
        raise KeyError(name)

    def value_text(self, name: str) -> str:
        """A slider's value as the window writes it: its number, except an age the spec
        does not give (its amplitude instead: what the eye accommodates) and a focus left
        to the eye ("auto": each point's own, Kakimoto Eq. 13)."""
        if name == "age" and "age" not in self._eye_table():
            return f"amplitude {self.eye.accommodation_max:.2f} D"
        if name == "focus_d" and self.spec.render.view.focus_d is None:
            return "auto"
        return CONTROL[name].fmt % float(self.value(name))

    def request(self, name: str, value) -> None:
        """Queue a change; :meth:`tick` applies every queued change at once (the last value
        of each control wins)."""
        self._pending[name] = value

    def apply(self, changes: dict) -> str | None:
        """Apply changes {control: value} now; returns None, or the one-line error of the
        first refused value (then nothing changes)."""
        display_only = {"cvd", "cvd_severity"}
        changes = {k: v for k, v in changes.items() if not self._same(k, v)}
        if "maps" in changes:             # the panel: cannot be refused, re-runs nothing
            self.maps_on = bool(changes.pop("maps"))
            self.last_change = "maps: display only"
        if not changes:
            return None
        data = copy.deepcopy(self.data)
        lens_on, cvd, sev = self.lens_on, self.cvd, self.cvd_severity
        try:
            for name, v in changes.items():
                if name == "lens":
                    lens_on = bool(v)
                elif name == "cvd":
                    cvd = v
                    if cvd is not None and cvd not in CVD_KINDS:
                        raise SpecError("render.cvd", f"must be one of {CVD_KINDS}")
                elif name == "cvd_severity":
                    sev = min(max(float(v), 0.0), 1.0)
                else:
                    self.edit_eyes(data, name, v)
            spec = parse_spec(data, self.source, self.base)
        except SpecError as e:
            self.message = str(e)
            return self.message
        self.lens_on, self.cvd, self.cvd_severity = lens_on, cvd, sev
        changed = set(changes)
        self.message = ""
        if changed <= display_only:
            self.last_change = ", ".join(sorted(changed)) + ": display only"
            return None
        self.data, self.spec = data, spec
        self.restart(", ".join(sorted(changed)), preview=bool(changed & PREVIEW_AFTER))
        return None

    def _same(self, name, v) -> bool:
        """Whether ``v`` leaves control ``name`` as it is (after the control's snapping)."""
        if name == "lens_rx":
            return False
        try:
            cur = self.value(name)
        except KeyError:
            return False
        if name in ("sphere", "cylinder", "axis", "focus_d"):
            if name == "focus_d" and float(v) < 0:
                return cur < 0
            return snap(v, STEP[name]) == cur
        if name in ("samples", "age"):
            return int(round(float(v))) == int(cur)
        if name in ("pupil_mm", "cvd_severity"):
            return abs(float(v) - float(cur)) < 1e-9 or round(float(v), 2) == round(cur, 2)
        if name == "gaze":
            return tuple(map(float, v)) == tuple(map(float, cur))
        return v == cur

    def dump(self) -> str:
        """The spec that reproduces the current state (TOML)."""
        data = copy.deepcopy(self.data)
        if not self.lens_on:
            data.pop("lens", None)
        r = data.setdefault("render", {})
        r.pop("cvd", None)
        r.pop("cvd_severity", None)
        if self.cvd is not None:
            r["cvd"], r["cvd_severity"] = self.cvd, float(self.cvd_severity)
        if self.two_eyes and self.output != self.spec.binocular.output:
            data.setdefault("binocular", {})["output"] = self.output     # as displayed
        return dump_spec(data)

    # ----------------------------------------------------------------- frames
    def scene(self):
        from eyelab.jobs.render import build_scene

        name = self.spec.render.scene
        if name not in self._scenes:
            self._scenes[name] = build_scene(name)
        return self._scenes[name]

    @property
    def lens(self):
        """The shown eye's lens (None when off)."""
        if not self.lens_on:
            return None
        return self.spec.lens if not self.two_eyes else self.spec.binocular.lens(self.side)

    def display(self) -> np.ndarray:
        """(h, w, 3) uint8 sRGB of the current frame as the observer sees it (CVD)."""
        if self.result is None:
            w, h = self.display_size
            return np.zeros((h, w, 3), np.uint8)
        if self.two_eyes:
            if self.cvd is None:
                return self.result.srgb(self.output)
            from eyelab.jobs.twoeyes import display_linear

            linear = display_linear(self.result, self.output)
        elif self.cvd is None:
            return self.result.srgb
        else:
            linear = self.result.linear
        return encode_srgb(cvd_linear(linear, self.cvd, self.cvd_severity))

    @property
    def display_size(self) -> tuple:
        """(width, height) px of :meth:`display`'s image: two eyes side by side are twice
        the view's width."""
        w, h = self.size
        return (2 * w if self.output in ("side-by-side", "crossed") else w), h

    def recomputed(self) -> str:
        """What the last change recomputed, in words (the report's cache misses grouped by
        :data:`RECOMPUTED_WORDS`, with their counts), or 'passes only'."""
        if self.result is None:
            return ""
        prepared = getattr(self, "_prepared", None)
        reports = [self.result.report] if not self.two_eyes else [
            self.result.right.report, self.result.left.report]
        names = [m for r in reports for m in r["cache"]["misses"]] + (
            prepared["cache"]["misses"] if prepared else [])
        return recomputed_words(names)

    def warnings(self) -> list:
        """The current frame's warnings (each eye's), as ``eyelab render`` reports them."""
        if self.result is None:
            return []
        reports = [self.result.report] if not self.two_eyes else [
            self.result.right.report, self.result.left.report]
        return list(dict.fromkeys(w for r in reports for w in r.get("warnings", [])))

    def status(self) -> str:
        """The status line: Rx, lens, passes, the last change and what it recomputed."""
        sides = ("right", "left") if self.two_eyes else (None,)
        lenses = [self.spec.lens if s is None else self.spec.binocular.lens(s) for s in sides]
        lens_s = "; ".join((s[0].upper() + " " if s else "") + _lens_text(lens, self.lens_on)
                           for s, lens in zip(sides, lenses, strict=True))
        eye_s = self.eye_text()
        out = "" if not self.two_eyes else f"  {self.output}"
        done = 0 if self.result is None else self.eye_report()["samples"]["done_passes"]
        first = self.timings.get("first_frame_s")
        t = "" if first is None else f"  first frame {first:.2f} s"
        cvd = "" if self.cvd is None else f"  CVD {self.cvd} {self.cvd_severity:.2f}"
        gz = self.value("gaze")
        return (f"{eye_s};  {lens_s};  S {done}/{self.samples}"
                f"  gaze [{gz[0]:+.0f}, {gz[1]:+.0f}]{cvd}{out}\nchanged: {self.last_change}"
                f" -> recomputed: {self.recomputed()}{t}"
                + (f"\n{self.message}" if self.message else "")
                + "".join(f"\nwarning: {w}" for w in self.warnings()))

    def save(self, image_path, *, image=None) -> tuple:
        """Write the displayed view and the spec that reproduces it (:func:`write_state`)."""
        return write_state(self, image_path, image=image)

    def close(self) -> None:
        if self._frames is not None:
            self._frames.close()
            self._frames = None
        self.gaze_maps.close()
        self.renderer.close()
        if self._left_renderer is not None:
            self._left_renderer.close()
        self._close_previews()


#: The renderer's cache entries in a user's words: (name prefix, words, what it counts),
#: in the order the status line gives them; an entry none of them names is written with
#: its underscores as spaces.
RECOMPUTED_WORDS = (
    ("field_through_lens", "blur field through the lens", "fields"),
    ("field_naked", "naked-eye blur field", "fields"),
    ("field", "blur field", "fields"),
    ("lens_texcoords", "rays through the lens", ""),
    ("compensated_fields", "reconstruction filter", ""),
    ("reconstruction_sigma", "reconstruction filter", ""),
    ("refined_", "mesh refinement", "meshes"),
    ("prefiltered_", "texture prefiltering", "textures"),
)


def recomputed_words(names) -> str:
    """Cache-miss names (``field_naked_546.07nm``, ``refined_floor``, ...) as one line of
    words with counts ("blur field through the lens (4 fields), mesh refinement (21
    meshes)"), or 'passes only' for none."""
    from collections import Counter

    groups = Counter()
    for name in names:
        hit = next(((w, unit) for prefix, w, unit in RECOMPUTED_WORDS
                    if name.startswith(prefix)), (name.replace("_", " "), ""))
        groups[hit] += 1
    if not groups:
        return "passes only"
    order = [(w, u) for _, w, u in RECOMPUTED_WORDS]
    parts = []
    for (words, unit), n in sorted(groups.items(), key=lambda kv: (
            order.index(kv[0]) if kv[0] in order else len(order), kv[0][0])):
        parts.append(words if n == 1 or not unit else f"{words} ({n} {unit})")
    return ", ".join(dict.fromkeys(parts))


def _lens_text(lens, on: bool) -> str:
    if lens is None:
        return "no lens"
    if not on:
        return "lens off"
    return ("lens " + (lens.rx.format() if lens.rx is not None else "(surfaces)")
            + f" {lens.material.name}")


def write_state(model: InspectorModel, image_path, *, image=None) -> tuple:
    """Write the displayed view (PNG) and, beside it, the spec that reproduces it
    (``<stem>.toml``), as one set (:func:`~eyelab.core.fileio.atomic_group`). Returns the
    two paths."""
    from eyelab.core.fileio import atomic_group, png_writer

    image_path = Path(image_path)
    spec_path = image_path.with_suffix(".toml")
    text = model.dump()
    atomic_group({image_path: png_writer(model.display() if image is None else image),
                  spec_path: lambda p: Path(p).write_text(text)})
    return image_path, spec_path
