"""The inspector's progressive frame loop (a mixin of
:class:`eyelab.jobs.inspector.InspectorModel`): after a change, a preview frame (one pass
on a coarse field), the full set-up on a worker thread, then the progressive frames of one
reused raster renderer — both eyes' in step for a two-eye spec — one step per
:meth:`~FrameLoopMixin.tick` so that the window never blocks longer than a step."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from eyelab.core.parallel import on_worker
from eyelab.jobs.controls import (
    PREVIEW_FIELD,
    PREVIEW_FIELD_SCHEMATIC,
    PREVIEW_LENSLET_SAMPLES,
    PREVIEW_SCALE,
)


def fixated(scene, eye, lens, view) -> tuple:
    """A render's inputs as ``eyelab render`` draws them: a schematic eye (its retinal
    image at fixation) takes one accommodation, the view's focus or else the fixation's
    on the line of sight (:func:`~eyelab.imaging.retinal.view_accommodation`, as
    :meth:`~eyelab.imaging.contract.Renderer.render` does before its frames)."""
    from eyelab.optics.eye.thin import Eye

    if isinstance(eye, Eye) or view.focus_d is not None:
        return scene, eye, lens, view
    from eyelab.imaging.retinal import fixation_view

    return scene, eye, lens, fixation_view(scene, eye, lens, view)


def preview_field(eye) -> tuple:
    """The preview's blur-field grid for ``eye``: a thin eye's :data:`PREVIEW_FIELD`, a
    schematic eye's coarser :data:`PREVIEW_FIELD_SCHEMATIC` (its columns are exact-ray
    fits)."""
    from eyelab.optics.eye.thin import Eye

    return PREVIEW_FIELD if isinstance(eye, Eye) else PREVIEW_FIELD_SCHEMATIC


def preview_inputs(inputs, scale: int = PREVIEW_SCALE) -> list:
    """Render ``inputs`` [(scene, eye, lens, view)] with each view ``scale`` times coarser
    on a side (its field of view kept; no side below a view's smallest,
    ``View.LIMITS``): what a preview draws."""
    from eyelab.imaging.contract import View

    def side(n, name):
        return max(-(-n // scale), min(n, View.LIMITS[name][0]))

    return [(scene, eye, lens, view.replace(width=side(view.width, "render.width"),
                                            height=side(view.height, "render.height")))
            for scene, eye, lens, view in inputs]


def enlarged(result, size):
    """A coarser render ``result`` (a preview) enlarged to ``size`` = (w, h) px, each of its
    pixels drawn as the block of view pixels whose centres it covers (nearest pixel: every
    block keeps its pixel's linear light, so regions keep their mean; 3 ms at 800 x 600
    where a bilinear resampling in linear light and its sRGB encoding cost 0.1 s); its
    lens mask likewise (its intermediate images, which no viewer shows, are left out). The
    report says ``details.preview_size`` (the size it was drawn at)."""
    from eyelab.imaging.contract import RenderResult

    w, h = size
    srgb = result.srgb
    if srgb.shape[:2] == (h, w):
        return result
    rows = ((2 * np.arange(h) + 1) * srgb.shape[0]) // (2 * h)   # the one each pixel's
    cols = ((2 * np.arange(w) + 1) * srgb.shape[1]) // (2 * w)   # centre lies in
    layers = {k: np.asarray(v)[rows][:, cols] for k, v in result.layers.items()
              if k == "lens_mask"}          # the intermediate images: not shown
    report = result.report
    report["details"]["preview_size"] = [int(srgb.shape[1]), int(srgb.shape[0])]
    return RenderResult(report, srgb=srgb[rows][:, cols], layers=layers)


class FrameLoopMixin:
    """Needs of its model: ``spec``, ``renderers()``, ``scene()``, ``lens``, ``lens_on``,
    ``view``, ``two_eyes``, ``samples``, ``every``, ``apply``, ``_pending``,
    ``_preview_renderers`` (a list, empty at first) and the
    as-worn maps' ``_want_maps``."""

    def restart(self, why: str, *, preview: bool = True) -> None:
        """Start the progressive frames of the current state (set-up runs at the next
        :meth:`tick`); with ``preview``, one pass on a coarse field comes first."""
        if self._frames is not None:
            self._frames.close()
        self._frames = self._sequence(preview)
        self.last_change = why
        self._t_change = time.perf_counter()
        self.timings = {}
        self._maps_key = None            # the maps' key, found once the first frame is shown
        self._shown = False              # whether this state's first frame has been shown

    def _inputs(self) -> list:
        """Each eye's render inputs (scene, eye, lens, view): one eye's, or both eyes'
        posed as ``eyelab render`` poses them (then kept as ``self.pose``, a
        :class:`~eyelab.imaging.stereo.BinocularPose`)."""
        if not self.two_eyes:
            return [fixated(self.scene(), self.spec.eye, self.lens, self.view)]
        from eyelab.imaging.stereo import pose_binocular

        self.pose = pose_binocular(self.scene(), self.spec.binocular, self.view,
                                    no_lens=not self.lens_on)
        return [fixated(*self.pose.inputs[s]) for s in ("right", "left")]

    def _result(self, results):
        """One step's RenderResults (one per eye) as the model's result."""
        if not self.two_eyes:
            return results[0]
        from eyelab.jobs.twoeyes import binocular_frame

        return binocular_frame(self.pose, *results)

    def _sequence(self, preview: bool):
        """The preview frame (if asked: its coarse field computed on a worker thread,
        then one pass, a lenslet lens's views from at most PREVIEW_LENSLET_SAMPLES pupil
        samples), the full set-up on a worker thread (fields, the filter's compensation,
        the rays through the lens: numpy and embree, no GL — the window stays responsive,
        showing the last frame), then the full progressive frames (the meshes refined one
        a step; after a preview, the first full image only once the passes took as long as
        an image builds), both eyes' in step for two. Yields the model's results, or None
        while waiting or between shown images."""
        self._prepared = None
        q = self.spec.render.quality
        self.scene()           # built here, once (meshes: not from a worker thread)
        # a schematic eye's fixation (its accommodation traced) and two eyes' pose
        inputs = yield from on_worker(self._inputs)
        pairs = list(zip(self.renderers(), inputs, strict=True))
        shape = preview_field(inputs[0][1])
        previewed = preview and (q.samples > 1 or tuple(q.field_shape) != shape)
        if previewed:
            coarse = dataclasses.replace(
                q, samples=1, refine=False, chromatic=False, field_shape=shape,
                lenslet_samples=min(q.lenslet_samples, PREVIEW_LENSLET_SAMPLES),
                lens_grid_px=2 * q.lens_grid_px)
            small = list(zip(self.preview_renderers(), preview_inputs(inputs), strict=True))
            yield from on_worker(lambda: [r.prepare(*args, coarse) for r, args in small])
            shots = yield from self._preview(small, coarse)
            for res in shots:
                res.report["samples"]["done_passes"] = 0      # a preview, not pass 1
            shots = [enlarged(res, (v.width, v.height))
                     for res, (*_, v) in zip(shots, inputs, strict=True)]
            yield self._result(shots)
        reports = yield from on_worker(lambda: [r.prepare(*args, q) for r, args in pairs])
        self._prepared = {"cache": {"misses": [m for r in reports
                                               for m in r["cache"]["misses"]]}}
        # one eye: its set-up in steps, its images averaged on a worker thread too; after
        # a preview the first image weighed by its cost. Two eyes' frames step once per
        # checkpoint and pair up by it: a step is shown when both eyes have an image.
        one = not self.two_eyes
        gens = [r.frames(*args, q, every=self.every, images="doubling", setup_steps=one,
                         offload=one, after_preview=previewed)
                for r, args in zip(self.renderers(), inputs, strict=True)]
        try:
            for step in zip(*gens, strict=True):
                yield None if any(s is None for s in step) else self._result(step)
        finally:
            for g in gens:
                g.close()

    def preview_renderers(self) -> list:
        """A raster renderer per eye for the previews (:data:`PREVIEW_SCALE` times coarser:
        their own windows, kept at that size, and caches)."""
        from eyelab.render.raster import RasterRenderer

        n = 2 if self.two_eyes else 1
        while len(self._preview_renderers) < n:
            self._preview_renderers.append(RasterRenderer())
        return self._preview_renderers[:n]

    def _close_previews(self) -> None:
        for r in self._preview_renderers:
            r.close()
        self._preview_renderers = []

    def _preview(self, pairs, coarse):
        """The preview frames (one pass each, ``coarse`` quality) of the (renderer, inputs)
        ``pairs``: one eye's in steps (None yielded between them: its set-up, its lens
        view), two eyes' at once (their steps would not pair up)."""
        if len(pairs) > 1:
            return [list(r.frames(*args, coarse, preview=True))[-1] for r, args in pairs]
        (r, args), = pairs
        shot = None
        for res in r.frames(*args, coarse, images="doubling", setup_steps=True,
                            offload=True, preview=True):
            if res is None:
                yield None
            else:
                shot = res
        return [shot]

    def eye_report(self) -> dict | None:
        """The (first) eye's report of the current result."""
        if self.result is None:
            return None
        return self.result.report if not self.two_eyes else self.result.right.report

    @property
    def done(self) -> bool:
        return self._frames is None

    def tick(self) -> bool:
        """Apply the queued changes, then advance the frames by one step (the first frame
        after a change, or ``every`` more passes). Returns whether the image changed."""
        if self._pending:
            changes, self._pending = self._pending, {}
            self.apply(changes)
            if self.last_change.endswith("display only"):
                return True
        if self._shown:        # the maps start once the first frame is out, never before
            self._want_maps()
        if self._frames is None:
            return False
        try:
            res = next(self._frames)
        except StopIteration:
            self._frames = None
            return False
        if res is None:            # passes ran; the next image comes at 2, 4, 8, ... S
            return False
        self.result = res
        self._shown = True
        done = self.eye_report()["samples"]["done_passes"]
        elapsed = time.perf_counter() - self._t_change
        self.timings.setdefault("first_frame_s", elapsed)
        self.timings["to_now_s"] = elapsed
        if done:
            self.timings[f"to_S{done}_s"] = elapsed
        if done >= self.samples:
            self._frames.close()
            self._frames = None
        return True

    def run_to_target(self) -> None:
        """Tick until the target S is reached."""
        while not self.done or self._pending:
            self.tick()
