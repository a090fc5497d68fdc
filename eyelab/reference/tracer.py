"""Per-pixel distribution ray tracing through the spectacle lens and the thin toric eye.

For each pixel (a direction from the pupil centre, the eye camera of the raster renderer):

1. the chief ray through the real lens (exact Snell at both surfaces) to the first scene
   hit (embree); a pixel whose chief ray misses the lens looks past it (naked);
2. the accommodation for that point by the blur field's rule (Eq. 13, from the wave of the
   hit point carried along the chief ray), or a fixed focus;
3. ``spp`` rays leave the retina point through pupil samples: through the thin toric eye
   with that accommodation (slope form: a ray through pupil point rho leaves with the slope
   -(P - n2/z_r) rho relative to the chief ray, as every ray of the pixel's retinal point
   does), through the lens exactly (a ray that misses the lens goes on straight), into the
   scene; their radiances are averaged in linear light.

Shading is the raster renderer's: unlit vertex colours or textures, in linear light:
texels are decoded from sRGB and then filtered bilinearly (the raster renderer's sRGB
textures are filtered and mip-mapped in linear light by the GL), vertex colours decoded
and then interpolated. Light adds in linear radiance, so the rays of a pixel are averaged
as they are, times the lens's Fresnel transmission, and the average is encoded once, at
output. With a dispersive lens each colour channel is traced at its own wavelength (C, e,
F lines). Pupil samples: Vogel's equal-area spiral, rotated per pixel by a seeded random
angle (deterministic for a seed, decorrelated between pixels: stratified in area, uniform
in angle, an unbiased estimate of the disc). Rows of pixels run on a thread pool.

``model = "fons"`` replaces the eye by Fons et al. 2023's reduced-eye sampling: n x m + 1
polar pupil points (n radii, m diameters) aimed at the focus plane P at the accommodated
distance, and for astigmatism their two-axis construction (samples projected on the axis
of larger error are aimed at the focus plane P' of that meridian; the ray keeps its pupil
origin and goes to where that line meets P).
"""

from __future__ import annotations

import math
import threading
import time

import numpy as np

from eyelab.imaging import Renderer, View, finish, new_report
from eyelab.optics.materials import RGB_WAVELENGTHS_NM
from eyelab.optics.paths import ChiefRays
from eyelab.optics.raymatrix import apply_isotropic, lens_path_matrix
from eyelab.optics.trace import FATAL
from eyelab.options import ReferenceQuality
from eyelab.parallel import map_row_chunks
from eyelab.sampling import disc_seeds, pixel_jitter
from eyelab.scene.raycast import EmbreeIntersector
from eyelab.vecmath import UP, cross, unit


class ReferenceRenderer(Renderer):
    """Per-pixel distribution ray tracing through the exact lens and the eye (no VTK)."""

    name = "reference"
    Quality = ReferenceQuality

    @staticmethod
    def pixel_ndc(view: View):
        """(n, 2) NDC of the pixel centres, row 0 at the top."""
        x = -1.0 + (2 * np.arange(view.width) + 1.0) / view.width
        y = 1.0 - (2 * np.arange(view.height) + 1.0) / view.height
        gx, gy = np.meshgrid(x, y)
        return np.column_stack([gx.ravel(), gy.ravel()])

    @staticmethod
    def pupil_samples(q: ReferenceQuality):
        """(k, 2) pupil points in the unit disc: Vogel's spiral of ``samples`` points, or
        the Fons pattern (the centre plus fons_n radii x 2 fons_m angles)."""
        if q.model == "fons":
            r = np.arange(1, q.fons_n + 1) / q.fons_n
            t = np.arange(2 * q.fons_m) * math.pi / q.fons_m
            rr, tt = np.meshgrid(r, t, indexing="ij")
            pts = np.column_stack([(rr * np.cos(tt)).ravel(), (rr * np.sin(tt)).ravel()])
            return np.vstack([[0.0, 0.0], pts])
        return disc_seeds(q.samples)

    def _render(self, scene, eye, lens, view, q, progressive):
        t0 = time.perf_counter()
        report = new_report(self.name, view, q)
        ndc = self.pixel_ndc(view)
        cam = view.camera()
        dirs = cam.ray_directions(ndc[:, 0], ndc[:, 1])
        n = len(dirs)
        inter = EmbreeIntersector(scene)
        samples = self.pupil_samples(q)
        disperses = q.chromatic and lens is not None and lens.material.dispersive
        wls = RGB_WAVELENGTHS_NM if disperses else (587.56,)
        if lens is not None and not disperses:
            report["skipped"].append("chromatic: " + ("disabled" if not q.chromatic else
                                                      "the lens material does not disperse")
                                     + ": one wavelength traced")
        out = np.zeros((n, 3))
        counts = {"rays": 0}
        lock = threading.Lock()
        rng_root = np.random.SeedSequence(q.seed)
        block = max(1, 16384 // len(samples))   # ~16k rays per task: numpy-friendly
        seeds = rng_root.spawn(int(math.ceil(n / block)))

        def run(a, b):
            rng = np.random.default_rng(seeds[a // block])
            col, nrays = self._pixels(dirs[a:b], ndc[a:b], scene, inter, eye, lens, samples,
                                      wls, rng, view, q)
            out[a:b] = col
            with lock:
                counts["rays"] += nrays

        bar = None
        if q.progress:
            from tqdm import tqdm

            bar = tqdm(total=n, desc="reference", unit="px")
        map_row_chunks(run if bar is None else _progress(run, bar), n, workers=q.workers,
                       block=block)
        if bar is not None:
            bar.close()
        img = out.reshape(view.height, view.width, 3)
        dt = time.perf_counter() - t0
        report["samples"].update(target=len(samples), done={"pixel": len(samples)})
        report["timings_s"]["trace"] = dt
        report["details"].update(channels_traced=len(wls), rays=counts["rays"],
                                 rays_per_s=counts["rays"] / dt, model=q.model)
        return finish(report, view, linear=img, t_start=t0)

    def _pixels(self, d, ndc, scene, inter, eye, lens, samples, wls, rng, view, quality):
        m = len(d)
        pupil = np.zeros(3)
        rp = eye.pupil_diameter / 2
        nrays = m
        # 1. chief rays: through the lens where they pass it
        through = np.zeros(m, bool)
        q = np.zeros((m, 3))
        dq = d.copy()
        if lens is not None:
            res = lens.trace(np.zeros_like(d), d, 587.56, reverse=True)
            through = (res["status"] & np.uint8(FATAL)) == 0
            q = np.where(through[:, None], res["out_points"], 0.0)
            dq = np.where(through[:, None], res["out_dirs"], d)
        hit = inter.intersect(q + 1e-7 * dq, dq)
        dist = np.where(hit.hit, hit.t + 1e-7, np.inf)
        # 2. accommodation (Eq. 13) from the wave of the hit point along the chief ray
        with np.errstate(divide="ignore"):
            v = np.where(np.isfinite(dist), -1.0 / dist, 0.0)
        kbar = v.copy()
        if lens is not None and through.any():
            idx = np.flatnonzero(through)
            h_back, h_front = res["hit1"], res["hit2"]
            chief = ChiefRays(None, h_front.points[idx], h_back.points[idx], -dq[idx],
                              -res["inside"][idx], -d[idx],
                              (h_front.take(idx), h_back.take(idx)),
                              None, None, np.zeros(len(idx), np.uint8), dist[idx])
            n_in = -d[idx]
            x_e = unit(cross(np.broadcast_to(UP, n_in.shape), n_in))
            t, _ = lens_path_matrix(chief, lens, 587.56, np.zeros((len(idx), 3)), x_e)
            kxx, _, kyy, _ = apply_isotropic(t, v[idx])
            kbar[idx] = 0.5 * (kxx + kyy)
        acc = eye.accommodation_for(kbar) if view.focus_d is None else np.full(
            m, min(max(float(view.focus_d), 0.0), eye.accommodation_max))
        # 3. ray bundles from the retina point through the pupil samples
        n_in = -d
        x_e = unit(cross(np.broadcast_to(UP, n_in.shape), n_in))
        y_e = cross(n_in, x_e)
        ang = rng.uniform(0, 2 * math.pi, m)
        ca, sa = np.cos(ang), np.sin(ang)
        sx = samples[None, :, 0] * ca[:, None] - samples[None, :, 1] * sa[:, None]
        sy = samples[None, :, 0] * sa[:, None] + samples[None, :, 1] * ca[:, None]
        rho_x, rho_y = rp * sx, rp * sy                                  # (m, k)
        pxx, pxy, pyy = eye.power_matrix(acc)
        e = eye.emmetropic_power
        if quality.model == "fons":
            gx, gy = self._fons_slopes(eye, acc, rho_x, rho_y, kbar)
        else:
            gx = (pxx - e)[:, None] * rho_x + pxy[:, None] * rho_y       # incoming slope G rho
            gy = pxy[:, None] * rho_x + (pyy - e)[:, None] * rho_y
        origins = pupil + rho_x[..., None] * x_e[:, None] + rho_y[..., None] * y_e[:, None]
        # each sample's ray leaves a point of the pixel (box filter, as the raster's jittered
        # passes): R2 offsets, shifted per pixel (Cranley-Patterson rotation)
        k = samples.shape[0]
        jit = np.mod(pixel_jitter(k)[None] + 0.5 + rng.uniform(0, 1, (m, 1, 2)), 1.0) - 0.5
        cam = view.camera()
        tx, ty = cam.tan_half
        b = cam.basis
        jx = ndc[:, None, 0] + 2 * jit[..., 0] / view.width
        jy = ndc[:, None, 1] + 2 * jit[..., 1] / view.height
        d_s = unit((jx * tx)[..., None] * b[0] + (jy * ty)[..., None] * b[1] + b[2])
        dirs = unit(d_s - gx[..., None] * x_e[:, None] - gy[..., None] * y_e[:, None])
        o = origins.reshape(-1, 3)
        dd = dirs.reshape(-1, 3)
        col = np.zeros((m, 3))
        traced = lens.trace_wavelengths(o, dd, wls, reverse=True) if lens is not None \
            else [None] * len(wls)
        for ci, r2 in enumerate(traced):
            weight = 1.0
            if r2 is not None:
                ok = ((r2["status"] & np.uint8(FATAL)) == 0)
                oo = np.where(ok[:, None], r2["out_points"], o)
                od = np.where(ok[:, None], r2["out_dirs"], dd)
                # Fresnel transmission of both surfaces; rays past the lens go on unweakened
                weight = np.where(ok, r2["transmittance"], 1.0)[:, None]
            else:
                oo, od = o, dd
            h = inter.intersect(oo + 1e-7 * od, od)
            c = (h.linear_colors(scene) * weight).reshape(m, -1, 3).mean(axis=1)
            nrays += len(o)
            if len(wls) == 1:
                col = c
            else:
                col[:, ci] = c[:, ci]
        return col, nrays

    @staticmethod
    def _fons_slopes(eye, acc, rho_x, rho_y, kbar):
        """Fons et al.'s construction in slope form. The focus plane P is where the mean
        meridian focuses (vergence F = kbar-independent: the eye's accommodated mean far
        vergence), P' the plane of the meridian with the larger error; a sample is aimed
        from its projection on that axis toward P', and the ray from the sample's own origin
        goes to where that line meets P."""
        e = eye.emmetropic_power
        p1, p2 = eye.principal_powers(acc)
        f_mean = (0.5 * (p1 + p2) - e)[:, None]   # vergence of the bundle (mean meridian)
        w = math.radians(eye.astigmatism_axis_deg)
        ax = np.array([math.cos(w), math.sin(w)])                     # meridian of P1
        f_axis = (p1 - e)[:, None]
        # slope of a ray from pupil point rho toward the focus of vergence f: f * rho
        # (rays converge toward the axis point at distance 1/f): spherical part
        gx = f_mean * rho_x
        gy = f_mean * rho_y
        # two-axis construction: the component along the P1 meridian converges with f_axis
        along = rho_x * ax[0] + rho_y * ax[1]
        extra = ((f_axis - f_mean) * along)
        gx = gx + extra * ax[0]
        gy = gy + extra * ax[1]
        return gx, gy


def _progress(fn, bar):
    def run(a, b):
        fn(a, b)
        bar.update(b - a)
    return run
