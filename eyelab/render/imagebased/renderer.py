"""The image-based lens model of Heidrich, Slusallek & Seidel 1997 as a renderer: per lens
sample and quad-tree cell one perspective render of the scene (VTK, offscreen), morphed
onto the film grid with the traced rays' image-plane intersections as texture
coordinates, weighted by W_i (§3.5) and accumulated in linear light.

The plan (rays, centres of projection, quad-tree, vignetting, weights) is
:mod:`eyelab.render.imagebased.plan`. The slices are drawn by GL; the morph — the paper's texture
mapping of each slice onto its film grid with Gouraud-interpolated texture coordinates and
bilinear texture filtering, alpha-blended with the weight grid — runs in numpy on the
read-back slice (:mod:`eyelab.render.imagebased.morph`):
the same arithmetic the texture unit does, in float, so that the accumulation stays in
linear light without one more 8-bit read-back per slice.
"""

from __future__ import annotations

import math
import time

import numpy as np

from eyelab.imaging.contract import Renderer, channel_wavelengths, finish, new_report
from eyelab.imaging.options import ImageBasedQuality
from eyelab.optics.cameralens.film import CameraRays
from eyelab.optics.eye.thin import EYE_REFERENCE_NM, Eye
from eyelab.optics.rays.materials import RGB_WAVELENGTHS_NM
from eyelab.render.accumulate import DECODE16
from eyelab.render.imagebased.layers import keep_layer, plan_layers
from eyelab.render.imagebased.morph import bilinear, morph_pixels
from eyelab.render.imagebased.plan import plan_projections
from eyelab.render.imagebased.rays import EyeRays, SchematicEyeRays


class ImageBasedRenderer(Renderer):
    """``render(scene, observer, lens, view, quality)``: ``observer`` an
    :class:`~eyelab.optics.eye.thin.Eye` (with ``lens`` a spectacle lens or None; a fixed
    ``view.focus_d`` or each film point's own accommodation) or a
    :class:`~eyelab.optics.cameralens.system.LensSystem` camera (``lens`` None; the film height
    follows ``view.fov_y_deg`` through the paraxial focal length; the lens samples are
    fixed points of a disc that holds every film point's vignetted bundle, the
    ``"cover"`` domain of :class:`~eyelab.optics.cameralens.film.CameraRays`, and the film
    irradiance is their mean radiance times the system's exact relative illumination:
    :func:`_normalisation`). A spectacle lens with lenslets is drawn in layers, the
    carrier's and each lenslet's (:mod:`eyelab.render.imagebased.layers`).

    Plans (rays, COPs, quad-trees) are kept per configuration (:attr:`plans`, LRU; a
    camera's relative illumination with them, :attr:`illumination`): the paper's
    preprocessing, done once while the lens, the eye, the view and the focus stay (with
    automatic accommodation the scene is part of the key)."""

    name = "imagebased"
    Quality = ImageBasedQuality

    def __init__(self, quality=None):
        from eyelab.core.cache import LRUCache

        super().__init__(quality)
        self._window = None
        self.plans = LRUCache(8, "plans")
        self.illumination = LRUCache(8, "relative illumination")

    def _win(self):
        if self._window is None:
            from eyelab.render.window import OffscreenWindow

            self._window = OffscreenWindow()
            self._window.use_field(None, "attribute")
            self._window.set_seed((0.0, 0.0))
        return self._window

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None

    # ------------------------------------------------------------------ rendering
    def _render(self, scene, eye, lens, view, q, progressive):
        t0 = time.perf_counter()
        report = new_report(self.name, view, q)
        if isinstance(eye, Eye):
            maker = EyeRays(eye, lens, view, view.focus_d, scene)
        else:           # a schematic eye at fixation: view.focus_d is its accommodation
            maker = SchematicEyeRays(eye, lens, view, view.focus_d)
        wls = channel_wavelengths(eye, lens, q.chromatic, report)
        radiometry = "radiance" if q.radiometry == "auto" else q.radiometry
        return self._project(scene, eye, lens, maker, wls, radiometry, view, q, report, t0)

    def _render_camera(self, scene, camera, view, q, progressive):
        t0 = time.perf_counter()
        report = new_report(self.name, view, q)
        # fixed lens samples shared by the film: one disc holding every film point's bundle
        maker = CameraRays(camera, view.width, view.height, view.fov_y_deg, view.near,
                           domain="cover")
        dispersive = any(s.after.dispersive for s in camera.surfaces)
        wls = RGB_WAVELENGTHS_NM if q.chromatic and dispersive else (EYE_REFERENCE_NM,)
        if len(wls) == 1:
            report["skipped"].append("chromatic: one wavelength")
        radiometry = "irradiance" if q.radiometry == "auto" else q.radiometry
        return self._project(scene, camera, None, maker, wls, radiometry, view, q, report, t0)

    def _project(self, scene, observer, lens, maker, wls, radiometry, view, q, report, t0):
        """Plan, draw and morph the slices of every lens sample and wavelength (§3),
        weighted by Eq. 3 and normalised by ``radiometry``."""
        from eyelab.core.sampling import equal_area_seeds, pass_samples

        # through lenslets each sample stands for an equal share of the pupil's area (the
        # light each lenslet takes is its area's share; both sets have the disc's moments)
        samples = equal_area_seeds(q.samples) if lens is not None and lens.has_lenslets \
            else pass_samples(q.samples)[0]
        h, w = view.height, view.width
        acc = np.zeros((h * w, 3))
        wsum = np.zeros((h * w, len(wls)))
        plans = []
        t_plan = t_draw = t_morph = 0.0
        win = self._win()
        items = [(m.content_key, _factory(m)) for m in scene.meshes]
        win.show(items)
        from eyelab.core.cache import content_key

        base_key = content_key(observer=observer, lens=lens, quality=q,
                               view=view.replace(cvd=None, cvd_severity=1.0),
                               scene=scene.content_key if getattr(maker, "acc", 0) is None
                               else None)
        for ci, wl in enumerate(wls):
            t1 = time.perf_counter()
            plan, hit = self.plans.get_or_create(
                f"{base_key}-{wl}", lambda wl=wl: _plan(maker, lens, samples, wl, q))
            report["cache"]["hits" if hit else "misses"].append(f"plan {wl} nm")
            plans.append(plan)
            t_plan += time.perf_counter() - t1
            channels = [0, 1, 2] if len(wls) == 1 else [ci]
            covered = {}
            for pr in plan.projections:
                t1 = time.perf_counter()
                slice_img = self._draw(win, pr, view, scene.background)
                t2 = time.perf_counter()
                cov = covered.setdefault(pr.sample, np.zeros(h * w, bool))
                keep = None if pr.layer is None else keep_layer(lens.front, pr.layer)
                idx, vals = morph_pixels(pr, w, h, cov, keep)
                if len(idx):
                    col = bilinear(slice_img, vals[:, 0], vals[:, 1])
                    acc[idx[:, None], channels] += vals[:, 2:3] * col[:, channels]
                    wsum[idx, ci] += vals[:, 3]
                t_morph += time.perf_counter() - t2
                t_draw += t2 - t1
        rel = self._relative_illumination(maker, radiometry, base_key, wls, w, h)
        norm = _normalisation(radiometry, wsum, rel)
        if len(wls) == 1:
            out = acc / np.maximum(norm[:, :1], 1e-300)
        else:
            out = acc / np.maximum(norm, 1e-300)
        img = out.reshape(h, w, 3).astype(np.float32)
        stats = plans[0].stats if len(plans) == 1 else {
            "projections": sum(p.stats["projections"] for p in plans),
            "max_angle_deg": max(p.stats["max_angle_deg"] for p in plans),
            "per_channel": [p.stats for p in plans]}
        n_proj = sum(len(p.projections) for p in plans)
        report["samples"].update(target=len(samples), done={"lens samples": len(samples),
                                                             "projections": n_proj})
        report["timings_s"].update(plan=t_plan, render=t_draw, morph=t_morph)
        report["details"].update(
            plan=stats, radiometry=radiometry, channels=len(wls),
            cop=q.cop, angle_threshold_deg=q.angle_threshold_deg,
            image_plane_m=maker.near,
            slice_pixels=int(sum(p.slice_size[0] * p.slice_size[1] for pl in plans
                                 for p in pl.projections)),
            system=None if maker.kind == "eye" else observer.name)
        if plans[0].stats.get("unresolved_cells"):
            report["warnings"].append(
                f"{plans[0].stats['unresolved_cells']} quad-tree cells stopped at max_depth "
                f"{q.max_depth} above the {q.angle_threshold_deg}° threshold (largest "
                f"{stats['max_angle_deg']:.3f}°)")
        return finish(report, view, linear=img, t_start=t0)

    def _relative_illumination(self, maker, radiometry, base_key, wls, w, h):
        """(h*w, channels) a camera's relative illumination at the pixel centres
        (:meth:`~eyelab.optics.cameralens.film.CameraRays.relative_illumination`), kept with the
        plans (:attr:`illumination`, LRU; a second frame does not trace the bundles
        again); None for radiance or an eye."""
        if radiometry != "irradiance" or not hasattr(maker, "relative_illumination"):
            return None
        cx, cy = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
        px = np.column_stack([cx.ravel(), cy.ravel()])
        return np.column_stack([self.illumination.get_or_create(
            f"{base_key}-{wl}", lambda wl=wl: maker.relative_illumination(px, wl))[0]
            for wl in wls])

    def _draw(self, win, pr, view, background):
        """The projection's slice: (sh, sw, 3) float linear light, row 0 at the top."""
        win.set_frustum(pr.cop, pr.forward, pr.up, math.degrees(2 * math.atan(pr.tan_half[1])),
                        view.near, view.far, pr.slice_size, background)
        rgba = win.grab_rgba()
        return DECODE16[rgba[::-1, :, :3]].astype(np.float32) / np.float32(65535.0)


def _plan(maker, lens, samples, wavelength_nm, q):
    """The frame's projections at one wavelength: the quad-trees of
    :func:`~eyelab.render.imagebased.plan.plan_projections`, or through a lenslet lens its
    layers (:func:`~eyelab.render.imagebased.layers.plan_layers`)."""
    options = dict(grid=q.grid, threshold_deg=q.angle_threshold_deg, max_depth=q.max_depth,
                   cop=q.cop, oversample=q.oversample, max_slice=q.max_slice)
    if lens is not None and lens.has_lenslets:
        return plan_layers(maker, lens, samples, wavelength_nm, **options)
    return plan_projections(maker, samples, wavelength_nm, **options)


def _normalisation(radiometry, wsum, rel) -> np.ndarray:
    """(h*w, channels) what the accumulated sum of W_i T L over the lens samples is divided
    by. Radiance: each film point's sum of W_i over the samples that reach it (the losses
    stay in the image). Irradiance of a camera lens system: that sum over the film point's
    relative illumination ``rel`` (``CameraRays.relative_illumination`` of
    :mod:`eyelab.optics.cameralens.film`: int W dA over its vignetted bundle, integrated once over
    the traced bundle, over the film centre's unvignetted value; 0 where no light passes).

    Why not the plain sum of Eq. 3 over the samples (each standing for its share of the
    sample plane): the lens samples are few fixed points shared by the whole film, so a
    film point's irradiance would hang on how many of them fall inside its bundle — a
    step of 1/n at each sample's vignetting cut-off on the film — and a sample set made
    for blur moments (mean 0, covariance I/4) is no area-uniform quadrature (measured:
    the plain sum 15-33 % off a white wall at 10-16 samples). The vignetting and the
    natural falloff do not depend on the scene: they are integrated once, and the samples
    only estimate the W-weighted mean of T L over each film point's bundle (the radiance
    image times the relative illumination; a ratio estimator, consistent as the samples
    grow). A uniform scene is then exact at every film point, and image value 1 stays the
    film centre's unvignetted, lossless irradiance. Irradiance of the eye (``rel`` None):
    1, the sum of W_i T L as it is."""
    if radiometry == "radiance":
        return wsum
    if rel is None:
        return np.ones_like(wsum)
    with np.errstate(divide="ignore"):
        return np.where(rel > 0, wsum / rel, np.inf)


def _factory(mesh):
    from eyelab.render.actors import mesh_actor

    return lambda: mesh_actor(mesh, None, mipmap=True)
