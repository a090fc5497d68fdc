"""The real-time renderer (Kakimoto et al. 2007, §3 and §4.5), on VTK, offscreen-first.

Per frame (the orchestration lives here; the parts in their own modules):

1. blur fields (``eyelab.blur``): the naked-eye field in the eye camera's NDC, and, when
   the lens is in view, the through-lens field in the virtual camera fitted behind it;
2. refinement (``eyelab.scene.refine``): meshes subdivided where the field is not linear
   along their edges;
3. naked-eye view: the scene from the eye camera, each vertex displaced in NDC by its
   blur-field matrix times a per-pass seed (vertex shader, ``window.OffscreenWindow``),
   S passes averaged (``accumulate.PassAccumulator``); with per-channel fields a pass draws
   the other channels only where they differ from the first (``channels``);
4. through the lens (only if the lens is in view): the same with the virtual camera and
   the through-lens field -> the environment image, as dense as the lens needs;
   per-vertex ray tracing (``eyelab.scene.pervertex``) gives every lens vertex its
   texture coordinates into it (one set per colour channel when the lens disperses);
5. reconstruction (``eyelab.blur.reconstruct``; on by default, ``RasterQuality.reconstruct``):
   each stage's mean filtered by its pixels' blur-shaped Gaussians, over the box of
   pixels it changes, the passes having displaced by variance-compensated fields;
6. composite (``composite.LensCompositor``): the lens view (one draw, every channel)
   inside the lens's outline, the naked view around it, the rim.

Work a frame does not need is skipped and listed in the report; everything reusable is
cached by content (eye, lens, view, scene geometry) in bounded LRU caches.
"""

from __future__ import annotations

import copy
import functools
import time

import numpy as np

from eyelab.blur.field import VoxelStatus
from eyelab.blur.wavefront import compute_blur_field
from eyelab.core.cache import LRUCache, content_key
from eyelab.core.parallel import NO_IMAGE, on_worker, relabel, run_steps
from eyelab.core.progress import bar as progress_bar
from eyelab.imaging.contract import (
    Renderer,
    RenderResult,
    View,
    channel_wavelengths,
    eye_view_camera,
    finish,
    new_report,
)
from eyelab.imaging.options import RasterQuality
from eyelab.optics.eye.thin import EYE_REFERENCE_NM
from eyelab.optics.lens.lenslets import carrier
from eyelab.optics.rays.camera import fit_virtual_camera, fit_window
from eyelab.render.accumulate import PassAccumulator
from eyelab.render.channels import channel_spread, compensated_stage, note_channels, pass_steps
from eyelab.render.composite import LensCompositor, frame_image
from eyelab.render.stages import (
    env_width,
    field_details,
    image_due,
    lens_coords,
    lens_details,
    passes_for,
    progressive_checkpoints,
    refining,
    scene_items,
    stage_mean,
    stage_route,
    start_passes,
    warm_textures,
)
from eyelab.render.window import OffscreenWindow
from eyelab.scene.lensview import lens_covers_view, lens_in_view_of
from eyelab.scene.prefilter import drawn_texture, with_texture
from eyelab.scene.raycast import scene_warnings

#: LRU sizes of the renderer's caches (entries): blur fields (each ~1-20 MB at the default
#: grid), refined meshes, lens texture coordinates, and small items (lens-in-view answers,
#: virtual cameras, masks, reconstruction sigma maps). Enough for an inspector toggling
#: between a few eyes, lenses and views, and for the demo's three views of a chromatic eye
#: (3 + 4 + 3 fields: with 8, each view recomputed its fields); memory stays bounded.
#: A scene's meshes must fit "refined" (per set of fields: the room's 21 meshes for each
#: of those views) and "prefiltered" (the room 21, the ETDRS chart 15). "texcoords": a
#: lens's grid coordinates and a lenslet lens's per-sample offsets (~4 MB at 640 x 480).
#: "fields": the demo's 10 and a schematic eye's 3 (its maps +17 MB each at the default).
CACHE_SIZES = {"fields": 16, "refined": 96, "prefiltered": 48, "texcoords": 8, "small": 48}


class RasterRenderer(Renderer):
    """Renders what an eye sees, with or without a spectacle lens, on VTK offscreen.

    Reuse one instance for many frames: its windows and caches (blur fields, refined
    meshes, lens texture coordinates, masks) persist while their inputs do not change,
    bounded by :data:`CACHE_SIZES`; :meth:`close` releases them all.
    """

    name = "raster"
    Quality = RasterQuality

    def __init__(self, quality: RasterQuality | None = None):
        super().__init__(quality)
        self._eye_win = None
        self._env_win = None
        self._compositor = None
        self._image_s = None            # the last image's build time (s)
        self.caches = {k: LRUCache(n, k) for k, n in CACHE_SIZES.items()}

    def close(self) -> None:
        if self._compositor is not None:
            self._compositor.close()
        for w in (self._eye_win, self._env_win):
            if w is not None:
                w.close()
        self._eye_win = self._env_win = self._compositor = None
        for c in self.caches.values():
            c.clear()

    # ------------------------------------------------------------------ caches
    def _cached(self, cache: str, key, factory, report, label):
        value, hit = self.caches[cache].get_or_create(key, factory)
        report["cache"]["hits" if hit else "misses"].append(label)
        return value, hit

    # ------------------------------------------------------------------ render
    def _render(self, scene, eye, lens, view: View, q: RasterQuality, progressive: bool
                ) -> RenderResult:
        checkpoints = progressive_checkpoints(q.samples) if progressive else [q.samples]
        results = [r for r in self._run(scene, eye, lens, view, q, checkpoints) if r]
        final = results[-1]
        if progressive:
            final.progressive = [(r.report["samples"]["done_passes"], r.srgb) for r in results]
        return final

    def frames(self, scene, eye, lens=None, view: View | None = None, quality=None, *,
               every: int = 1, images: str = "every", setup_steps: bool = False,
               offload: bool = False, preview: bool = False, after_preview: bool = False):
        """Render progressively: after pass 1, 1 + ``every``, ... and the last (S) yield a
        :class:`RenderResult` — the complete image of the passes so far, its report's
        ``samples.done_passes`` saying how many — or, with ``images = "doubling"``, an
        image only after pass 1, S and those of passes 2, 4, 8, ... whose passes since the
        last image took at least as long as that image took to build (0.15-0.2 s at
        800 x 600), None after the others (one step per checkpoint: two eyes' frames pair
        up); ``after_preview`` (a viewer shows a preview of the same state) treats pass 1
        alike, against this renderer's last image's build time. Set-up (fields,
        refinement, lens coordinates) comes before the first pass — with ``setup_steps``
        and "doubling" in steps, None after each (a mesh refined, a stage set up) — and
        between two yields only ``every`` passes run, so an interactive viewer stays
        responsive; with ``offload`` and "doubling" an image's averaging (numpy) runs on a
        worker thread, None yielded meanwhile. A ``preview`` draws the scene's textures
        prefiltered, never mip-mapped (a chain is one GL call that held the window
        0.1-0.5 s; its report says ``details.preview``). Through a lenslet lens
        "doubling" shows the last image only (each image draws the lens view once per
        pupil sample: 32 at 800 x 600, ~0.9 s). The last image equals :meth:`render`'s.
        Closing the generator early stops the work."""
        view, quality = self._checked(view, quality, scene)
        every = max(1, int(every))
        if images not in ("every", "doubling"):
            raise ValueError(f"images must be 'every' or 'doubling', got {images!r}")
        steps = sorted(set(range(1, quality.samples + 1, every)) | {quality.samples})
        shown = set(steps) if images == "every" else set(progressive_checkpoints(quality.samples))
        if images == "doubling" and not preview and getattr(lens, "has_lenslets", False):
            shown = {quality.samples}   # an image: a lens view per pupil sample (32: ~0.9 s)
        if getattr(eye, "aberrations", None) is None:
            gen = self._run(scene, eye, lens, view, quality, steps, shown, offload, preview,
                            costed=images == "doubling", after_preview=after_preview)
        else:                                           # eyelab/imaging/eyepsf.py
            from eyelab.imaging.eyepsf import aberrated_frames

            gen = aberrated_frames(self, scene, eye, lens, view, quality, steps, shown)
        started = False     # set-up's Nones come before the first pass's step (NO_IMAGE)
        for res in gen:
            started = started or res is not None
            if res is not None and res is not NO_IMAGE:
                yield res
            elif images == "doubling" and (started or setup_steps):
                yield None

    def _run(self, scene, eye, lens, view: View, q: RasterQuality, checkpoints,
             shown=None, offload=False, preview=False, costed=False, after_preview=False):
        t_start = time.perf_counter()
        report = new_report(self.name, view, q)
        if preview:
            report["details"]["preview"] = True
        report["samples"]["target"] = q.samples
        details = report["details"]
        details.update(fields={}, refinement=[])
        timings = report["timings_s"]
        cam, lens_in_view, f_naked, vcam, f_lens = self._geometry(scene, eye, lens, view, q,
                                                                  report)
        t = time.perf_counter()          # a mesh a step: a viewer's window keeps answering
        meshes = yield from refining(self.caches["refined"], scene,
                                     list(f_naked or []) + list(f_lens or []), view, q, report,
                                     offload)
        timings["refine"] = time.perf_counter() - t
        t = time.perf_counter()
        naked = yield from self._naked_stage(scene, meshes, cam, f_naked, view, q, report,
                                             offload)
        timings["setup_naked"] = time.perf_counter() - t
        env = None
        if lens_in_view:
            yield None
            t = time.perf_counter()
            env = yield from self._env_stage(scene, meshes, lens, vcam, f_lens, cam, view, q,
                                             report, eye, offload)
            timings["setup_lens"] = time.perf_counter() - t
        yield None                          # set-up done: the passes from the next step
        for count, image, layers in self._passes(naked, env, view, q, report, checkpoints,
                                                 shown, offload, costed, after_preview):
            if image is None:
                yield NO_IMAGE
                continue
            report["samples"]["done"] = {
                "naked": min(count, naked["passes"]),
                "environment": 0 if env is None else min(count, env["passes"])}
            report["samples"]["done_passes"] = count
            gl = sum(w.render_s for w in (naked["win"], env and env["win"]) if w)
            rb = sum(w.readback_s for w in (naked["win"], env and env["win"]) if w)
            timings.update(gl_render=gl, readback=rb)
            yield finish(copy.deepcopy(report), view, srgb=image, layers=layers,
                         t_start=t_start)

    def prepare(self, scene, eye, lens=None, view: View | None = None, quality=None) -> None:
        """Compute and cache the blur fields and the virtual camera a frame needs — numpy
        and embree only, no GL — so that it may run on a worker thread while the GL thread
        shows something else (the inspector does); the next :meth:`render` or
        :meth:`frames` of the same inputs finds them cached. Refinement is left to the
        frame: pymeshlab used from a worker thread corrupted the heap at exit (measured:
        `eyelab bench inspect` aborted in 2 of 2 runs). Not to be run concurrently with a
        render on this renderer. Returns the report of what it computed."""
        view, quality = self._checked(view, quality, scene)
        report = new_report(self.name, view, quality)
        cam, lens_in_view, f_naked, vcam, f_lens = self._geometry(scene, eye, lens, view,
                                                                  quality, report)
        # the stages' GL-free set-up too: each stage's compensated fields (numpy), and
        # the rays through the lens that give its texture coordinates (embree)
        for fields, size, label in ((f_naked, (view.width, view.height), "naked view"),
                                    (f_lens, vcam and vcam[1], "environment")):
            if fields is not None:
                passes, seeds, _ = passes_for(fields, quality, report, label)
                self._reconstruction(fields, passes, size, quality, report, seeds)
        if lens_in_view:
            lens_coords(self._cached, scene, lens, vcam[0], cam, view, quality, report, eye)
        return report

    def _geometry(self, scene, eye, lens, view, q, report) -> tuple:
        """The GL-free part of a frame: (eye camera, lens in view, naked fields or None,
        virtual camera, lens fields or None)."""
        report["details"].setdefault("fields", {})
        report["details"].setdefault("refinement", [])
        timings = report["timings_s"]
        cam = eye_view_camera(view, eye)
        report["warnings"], _ = self._cached(
            "small", content_key(warnings=scene.content_key, camera=cam),
            lambda: scene_warnings(scene, cam), report, "scene_warnings")
        bounds = scene.bounds()
        lens = carrier(lens)          # a lenslet lens: the carrier's view, then the lenslets'
        lens_in_view = self._lens_in_view(lens, cam, report)
        covered = lens_in_view and q.skip_unneeded and self._lens_covers(lens, cam, report)
        t = time.perf_counter()
        f_naked = None if covered else self._fields(eye, None, cam, bounds, view, q, report,
                                                    "naked")
        f_lens = vcam = None
        if lens_in_view:
            vcam = self._virtual_camera(lens, cam, view, q, report)      # (camera, size)
            f_lens = self._fields(eye, lens, vcam[0], bounds, view, q, report, "through_lens",
                                  pupil=cam.position)
        timings["fields"] = time.perf_counter() - t
        return cam, lens_in_view, f_naked, vcam, f_lens

    def _lens_covers(self, lens, cam, report) -> bool:
        """Whether every pixel sees through the lens (then the naked view is not drawn)."""
        return self._lens_query("covers_view", lens_covers_view, lens, cam, report, True,
                                "naked view: the lens covers the whole view: the naked-eye "
                                "field and passes are not needed")

    def _lens_in_view(self, lens, cam, report) -> bool:
        if lens is None:
            report["skipped"].append("lens passes: no lens")
            return False
        return self._lens_query("in_view", lens_in_view_of, lens, cam, report, False,
                                "lens passes: the lens is outside the view")

    def _lens_query(self, what, fn, lens, cam, report, skip_if: bool, why: str) -> bool:
        """``fn(lens, cam)``, cached; ``why`` goes to the skipped work when it is ``skip_if``."""
        answer, _ = self._cached("small", content_key(what=what, lens=lens, camera=cam),
                                 lambda: fn(lens, cam), report, f"lens_{what}")
        if answer == skip_if:
            report["skipped"].append(why)
        return answer

    def _virtual_camera(self, lens, cam, view, q, report):
        """The virtual camera fitted to the refracted rays (§3.1), in an integer window."""
        def fit():       # the camera and its window's width, from the lens's density
            fitted = fit_virtual_camera(lens, cam).camera
            return fit_window(fitted, env_width(cam, fitted, view, q, lens))

        key = content_key(what="vcam", lens=lens, camera=cam, oversample=q.env_oversample,
                          width=view.width)
        return self._cached("small", key, fit, report, "virtual_camera")[0]  # (cam, size)

    def _fields(self, eye, lens, cam, bounds, view, q, report, label, pupil=None) -> list:
        """The stage's blur fields: one at the eye's reference wavelength, or one per colour
        channel (R, G, B at their design wavelengths) when the eye's own chromatic
        aberration or the lens's dispersion makes them differ. The eye has one
        accommodation state whatever the colour: through a dispersive lens the channels
        take it per voxel from the reference wavelength's field (elsewhere Eq. 13 gives the
        same at every wavelength)."""
        wls = channel_wavelengths(eye, lens, q.chromatic)
        if len(wls) == 1:
            return [self._field(eye, lens, cam, bounds, view, q, report, label, pupil)]
        acc = None
        if lens is not None and lens.material.dispersive and view.focus_d is None:
            ref = self._field(eye, lens, cam, bounds, view, q, report, label, pupil)
            acc = np.where(ref.status == VoxelStatus.OK, ref.accommodation, np.nan)
        return [self._field(eye, lens, cam, bounds, view, q, report,
                            f"{label}_{wl:g}nm", pupil, wavelength_nm=wl, accommodation=acc)
                for wl in wls]

    def _field(self, eye, lens, cam, bounds, view, q, report, label, pupil=None,
               wavelength_nm=EYE_REFERENCE_NM, accommodation=None):
        pupil = np.asarray(cam.position if pupil is None else pupil, float)
        key = content_key(eye=eye, lens=lens, camera=cam, shape=q.field_shape,
                          depth_mode=q.depth_mode, focus=view.focus_d,
                          bounds=np.asarray(bounds, float), pupil=pupil,
                          wavelength=wavelength_nm, accommodation=accommodation)
        f, hit = self._cached("fields", key, lambda: compute_blur_field(
            eye, lens, cam, shape=q.field_shape, depth_mode=q.depth_mode, focus=view.focus_d,
            scene_bounds=bounds, pupil=pupil, wavelength_nm=wavelength_nm,
            accommodation=accommodation), report, f"field_{label}")
        report["details"]["fields"][label] = field_details(f, hit)
        return f

    def _scene_items(self, meshes, fields, route, passes, cam, height, report, offload):
        """A generator (pausing while a worker thread prefilters, with ``offload``) whose
        value is per field (channel) the [(key, factory)] of the meshes' actors
        (:func:`~eyelab.render.stages.scene_items`), prefiltered textures (padded to
        power-of-two sides: :func:`~eyelab.scene.prefilter.drawn_texture`) cached."""
        def prefilter(m, f):            # keyed by the texels: refinement keeps them
            drawn = self._cached("prefiltered", ("prefiltered", m.texture_key, f),
                                 lambda: drawn_texture(m.texture, f), report,
                                 f"prefiltered_{m.name}")[0]
            return with_texture(m, drawn)

        work = functools.partial(scene_items, meshes, fields, route, passes, cam, height,
                                 prefilter, mipmaps=not report["details"].get("preview"))
        return (yield from on_worker(work)) if offload else work()

    def _reconstruction(self, fields, passes, size, q, report, seeds=None) -> tuple:
        """(fields the passes displace by, reconstruction state or None, their
        :func:`~eyelab.render.channels.channel_spread`) of a stage of
        ``size`` = (w, h) px. With the reconstruction filter on and more than one pass,
        each field is variance-compensated for the filter's per-voxel sigma at S passes
        (:func:`eyelab.blur.reconstruct.compensated`: disc + Gaussian keep the blur's
        second moments), cached; otherwise the fields themselves."""
        if not (q.reconstruct and passes > 1):
            spread, _ = self.caches["small"].get_or_create(   # derived from the fields:
                ("spread", tuple(size)) + tuple(f.key for f in fields),   # not a recompute
                lambda: channel_spread(fields, size))
            return fields, None, spread

        key = ("compensated", passes, tuple(size)) + tuple(f.key for f in fields)
        (shrunk, recon, spread), _ = self._cached(
            "small", key, lambda: compensated_stage(fields, passes, size, seeds), report,
            "compensated_fields")
        return shrunk, recon, spread

    def _naked_stage(self, scene, meshes, cam, fields, view, q, report, offload):
        if self._eye_win is None:
            self._eye_win = OffscreenWindow()
        win = self._eye_win
        win.render_s = win.readback_s = 0.0
        win.set_view(cam, (view.width, view.height), scene.background)
        if offload:                     # the shaders' texture variants, once per window
            yield from win.warm_variants(cam)
        if fields is None:                          # the lens covers the view
            win.show([])
            return {"win": win, "passes": 0, "acc": None}
        passes, seeds, jitter = passes_for(fields, q, report, "naked view")
        route = stage_route(fields, q, report, "naked view")
        fields, recon, spread = self._reconstruction(fields, passes,
                                                     (view.width, view.height), q, report,
                                                     seeds)
        items = yield from self._scene_items(meshes, fields, route, passes, cam, view.height,
                                             report, offload)
        if offload:                     # textures uploaded a few a tick
            yield from warm_textures(win, fields, route, items)
        return {"win": win, "cam": cam, "fields": fields, "recon": recon, "spread": spread,
                "route": route, "items": items,
                "key": ("naked", scene.content_key) + tuple(f.key for f in fields),
                "passes": passes, "seeds": seeds, "jitter": jitter,
                "acc": PassAccumulator(view.height, view.width)}

    def _env_stage(self, scene, meshes, lens, vcam, fields, cam, view, q, report, eye,
                   offload):
        if self._env_win is None:
            self._env_win = OffscreenWindow()
        win = self._env_win
        win.render_s = win.readback_s = 0.0
        vcam, (w_env, h_env) = vcam
        win.set_view(vcam, (w_env, h_env), scene.background)
        if offload:
            yield from win.warm_variants(vcam)
        passes, seeds, jitter = passes_for(fields, q, report, "environment")
        route = stage_route(fields, q, report, "environment")
        fields, recon, spread = self._reconstruction(fields, passes, (w_env, h_env), q,
                                                     report, seeds)
        items = yield from self._scene_items(meshes, fields, route, passes, vcam, h_env, report,
                                             offload)
        if offload:
            yield from warm_textures(win, fields, route, items)
        geo, tkey, offsets, n_wls = lens_coords(self._cached, scene, lens, vcam, cam, view,
                                                q, report, eye)
        report["details"]["lens"] = dict(lens_details(geo, n_wls, vcam),
                                         environment_px=[w_env, h_env])
        return {"win": win, "cam": vcam, "fields": fields, "recon": recon, "spread": spread,
                "items": items, "route": route,
                "key": ("env", scene.content_key) + tuple(f.key for f in fields),
                "passes": passes, "seeds": seeds, "jitter": jitter, "geo": geo,
                "geo_key": tkey, "lenslets": offsets, "eye_cam": cam,
                "acc": PassAccumulator(h_env, w_env)}

    # ------------------------------------------------------------------ passes
    def _passes(self, naked, env, view, q, report, checkpoints, shown=None, offload=False,
                costed=False, after_preview=False):
        """Run the passes, yielding (passes done, uint8 image, layers) at each checkpoint
        (ascending, the last S); at checkpoints not in ``shown`` (None: all are) — and,
        ``costed``, at those between the first image and the last whose passes since the
        last image took less time than it took to build (:func:`image_due`; the first too
        ``after_preview``, against the last image this renderer built) — no image is
        built and (passes done, None, None) is yielded; with ``offload`` also while a
        worker thread averages the passes for an image."""
        timings = report["timings_s"]
        stages = [s for s in (naked, env) if s is not None and s["passes"]]
        if offload:     # each stage's undisplaced render a tick of its own
            yield from relabel(start_passes(stages, naked, report),
                               (checkpoints[0], None, None))
        else:
            run_steps(start_passes(stages, naked, report))
        done, since, image_s = 0, time.perf_counter(), self._image_s if after_preview else None
        bar = progress_bar(max((s["passes"] for s in stages), default=0),
                           f"raster {view.width}x{view.height}", "pass")
        try:
            for cp in checkpoints:
                for k in range(done, cp):
                    for st in stages:
                        if k >= st["passes"]:
                            continue
                        t = time.perf_counter()     # (offloaded: the pauses included)
                        steps = pass_steps(st, k, st["route"], offload)   # a channel a step
                        st["acc"].add((yield from relabel(steps, (cp, None, None)))
                                      if offload else run_steps(steps))
                        name = "naked_passes" if st is naked else "env_passes"
                        timings[name] = timings.get(name, 0.0) + time.perf_counter() - t
                        note_channels(st, "naked view" if st is naked else "environment",
                                      report)
                        if offload:
                            yield cp, None, None
                    bar.update(1)
                done = cp
                if (shown is not None and cp not in shown) or (costed and not image_due(
                        cp == checkpoints[-1], image_s, time.perf_counter() - since)):
                    yield cp, None, None
                    continue
                t = time.perf_counter()
                average = functools.partial(self._means, naked, env, q, report)
                if offload:     # averaged on a worker, composited in steps: the GL thread answers
                    means = yield from on_worker(average, idle=(cp, None, None))
                    image, layers = yield from relabel(
                        self._image(naked, env, view, q, report, means), (cp, None, None))
                else:
                    image, layers = run_steps(self._image(naked, env, view, q, report, average()))
                image_s, since = time.perf_counter() - t, time.perf_counter()
                self._image_s = image_s
                yield cp, image.copy(), layers
        finally:
            bar.close()
            for st in stages:
                st["win"].set_seed((0.0, 0.0))

    def _mean(self, st, q, report) -> np.ndarray:
        """The stage's average as GL-ordered RGBA (:func:`~eyelab.render.stages.stage_mean`)."""
        return stage_mean(st, lambda key, fn: self._cached("small", key, fn, report,
                                                           "reconstruction_sigma")[0], report)

    def _means(self, naked, env, q, report) -> tuple:
        """(naked view's, environment's) averaged RGBA (None where a stage has no passes or
        is absent): numpy only, so the inspector builds them on a worker thread."""
        return (self._mean(naked, q, report) if naked["passes"] else None,
                None if env is None else self._mean(env, q, report))

    def _image(self, naked, env, view, q, report, means):
        """:func:`~eyelab.render.composite.frame_image` of :meth:`_means`' ``means``."""
        return frame_image(*means, env, view, q, report, self._lens_compositor)

    def _lens_compositor(self) -> LensCompositor:
        if self._compositor is None:
            self._compositor = LensCompositor(self._eye_win, self.caches["small"])
        return self._compositor
