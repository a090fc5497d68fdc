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
   scene; their radiances are averaged in linear light. An eye with higher-order
   aberrations (``Eye.aberrations``) bends each ray further by grad W at its pupil point
   (geometric optics); the pupil's diffraction is then a kernel on the image
   (:mod:`eyelab.imaging.eyepsf`).

Shading is the raster renderer's: unlit vertex colours or textures, in linear light:
texels are decoded from sRGB and then filtered bilinearly (the raster renderer's sRGB
textures are filtered and mip-mapped in linear light by the GL), vertex colours decoded
and then interpolated. Light adds in linear radiance, so the rays of a pixel are averaged
as they are, times the lens's Fresnel transmission, and the average is encoded once, at
output. Each colour channel is traced at its own wavelength (C, e, F lines) when the lens
disperses or the eye has its own chromatic aberration (``Eye.chromatic``, Thibos et al.
1992): then a channel's rays leave the eye with the slopes of the eye's power at that
wavelength, while the accommodation (one per pixel) is found at the eye's reference
wavelength. Pupil samples: Vogel's equal-area spiral, rotated per pixel by a seeded random
angle (deterministic for a seed, decorrelated between pixels: stratified in area, uniform
in angle, an unbiased estimate of the disc). Rows of pixels run on a thread pool.

``model = "fons"`` replaces the eye by Fons et al. 2023's reduced-eye model: the pupil
pattern of n x m + 1 points (:func:`fons_pattern`), the focus plane set by the meridian
of lowest refractive error (:func:`fons_accommodation`, §4) and the two-axis astigmatism
construction (:func:`fons_slopes`, §4, Fig. 7).
"""

from __future__ import annotations

import math
import threading
import time

import numpy as np

from eyelab.core.parallel import map_row_chunks
from eyelab.core.sampling import disc_seeds, pixel_jitter
from eyelab.core.vecmath import UP, cross, unit
from eyelab.imaging.contract import Renderer, channel_wavelengths, finish, new_report
from eyelab.imaging.options import ReferenceQuality
from eyelab.optics.rays.trace import FATAL
from eyelab.scene.focus import (  # noqa: F401 (fons_accommodation: part of this API)
    fons_accommodation,
    pixel_accommodation,
    rms_accommodation,
)
from eyelab.scene.raycast import EmbreeIntersector, scene_warnings


class ReferenceRenderer(Renderer):
    """Per-pixel distribution ray tracing through the exact lens and the eye (no VTK)."""

    name = "reference"
    Quality = ReferenceQuality
    traces_eye_aberrations = True       # grad W per pupil ray; diffraction as a kernel

    @staticmethod
    def pupil_samples(q: ReferenceQuality):
        """(k, 2) pupil points in the unit disc: Vogel's spiral of ``samples`` points, or
        the Fons pattern (:func:`fons_pattern`)."""
        if q.model == "fons":
            return fons_pattern(q.fons_n, q.fons_m)
        return disc_seeds(q.samples)

    def _render_schematic(self, scene, eye, lens, view, q, progressive):
        from eyelab.reference.retinal import render_retinal

        return render_retinal(self.name, scene, eye, lens, view, q)

    def _render_camera(self, scene, camera, view, q, progressive):
        from eyelab.reference.camera import render_camera

        return render_camera(scene, camera, view, q, self.name)

    def _render(self, scene, eye, lens, view, q, progressive):
        t0 = time.perf_counter()
        report = new_report(self.name, view, q)
        ndc = view.pixel_ndc()
        cam = view.camera(eye.rotation_centre)
        dirs = cam.ray_directions(ndc[:, 0], ndc[:, 1])
        n = len(dirs)
        inter = EmbreeIntersector(scene)
        report["warnings"] = scene_warnings(scene, cam, inter)
        samples = self.pupil_samples(q)
        wls = channel_wavelengths(eye, lens, q.chromatic, report)
        out = np.zeros((n, 3))
        counts = {"rays": 0, "acc_diff_sum": 0.0, "acc_diff_max": 0.0, "acc_n": 0}
        lock = threading.Lock()
        rng_root = np.random.SeedSequence(q.seed)
        block = max(1, 16384 // len(samples))   # ~16k rays per task: numpy-friendly
        seeds = rng_root.spawn(int(math.ceil(n / block)))

        def run(a, b):
            rng = np.random.default_rng(seeds[a // block])
            col, nrays, diff = self._pixels(dirs[a:b], ndc[a:b], scene, inter, eye, lens,
                                            samples, wls, rng, view, q, cam)
            out[a:b] = col
            with lock:
                counts["rays"] += nrays
                if len(diff):
                    counts["acc_diff_sum"] += float(np.abs(diff).sum())
                    counts["acc_diff_max"] = max(counts["acc_diff_max"], float(np.abs(diff).max()))
                    counts["acc_n"] += len(diff)

        from eyelab.core.progress import bar as progress_bar

        with progress_bar(n, f"reference {view.width}x{view.height}, {len(samples)} spp",
                          "px", force=q.progress) as bar:
            map_row_chunks(_progress(run, bar), n, workers=q.workers, block=block)
        img = out.reshape(view.height, view.width, 3)
        dt = time.perf_counter() - t0
        report["samples"].update(target=len(samples), done={"pixel": len(samples)})
        report["timings_s"]["trace"] = dt
        report["details"].update(channels_traced=len(wls), rays=counts["rays"],
                                 rays_per_s=counts["rays"] / dt, model=q.model,
                                 accommodation=q.accommodation)
        if counts["acc_n"]:
            report["details"]["accommodation_rms_vs_eq13_d"] = {
                "mean_abs": counts["acc_diff_sum"] / counts["acc_n"],
                "max_abs": counts["acc_diff_max"], "pixels": counts["acc_n"]}
        return finish(report, view, linear=img, t_start=t0)

    def _pixels(self, d, ndc, scene, inter, eye, lens, samples, wls, rng, view, quality,
                cam):
        m = len(d)
        pupil = np.asarray(cam.position, float)
        rp = eye.pupil_diameter / 2
        nrays = m
        acc, acc_diff = pixel_accommodation(d, scene, inter, eye, lens, view, cam,
                                            quality.model, quality.accommodation)
        # 3. ray bundles from the retina point through the pupil samples
        n_in = -d
        x_e = unit(cross(np.broadcast_to(UP, n_in.shape), n_in))
        y_e = cross(n_in, x_e)
        # the pattern turned per pixel (decorrelates pixels; Vogel's spiral is stratified in
        # area); Fons et al.'s pattern keeps its fixed diameters (§3, Fig. 4)
        ang = rng.uniform(0, 2 * math.pi, m) if quality.model != "fons" else np.zeros(m)
        ca, sa = np.cos(ang), np.sin(ang)
        sx = samples[None, :, 0] * ca[:, None] - samples[None, :, 1] * sa[:, None]
        sy = samples[None, :, 0] * sa[:, None] + samples[None, :, 1] * ca[:, None]
        rho_x, rho_y = rp * sx, rp * sy                                  # (m, k)
        pxx, pxy, pyy = eye.power_matrix(acc)
        e = eye.emmetropic_power
        if quality.model == "fons":
            gx, gy = fons_slopes(eye, acc, rho_x, rho_y)
        else:
            gx = (pxx - e)[:, None] * rho_x + pxy[:, None] * rho_y       # incoming slope G rho
            gy = pxy[:, None] * rho_x + (pyy - e)[:, None] * rho_y
        if eye.aberrations is not None:   # the higher orders bend each pupil ray by grad W
            hx, hy = eye.aberrations.slopes(rho_x, rho_y, eye.pupil_diameter * 1e3)
            gx, gy = gx + hx, gy + hy
        origins = pupil + rho_x[..., None] * x_e[:, None] + rho_y[..., None] * y_e[:, None]
        # each sample's ray leaves a point of the pixel (box filter, as the raster's jittered
        # passes): R2 offsets, shifted per pixel (Cranley-Patterson rotation)
        k = samples.shape[0]
        jit = np.mod(pixel_jitter(k)[None] + 0.5 + rng.uniform(0, 1, (m, 1, 2)), 1.0) - 0.5
        tx, ty = cam.tan_half
        b = cam.basis
        jx = ndc[:, None, 0] + 2 * jit[..., 0] / view.width
        jy = ndc[:, None, 1] + 2 * jit[..., 1] / view.height
        d_s = unit((jx * tx)[..., None] * b[0] + (jy * ty)[..., None] * b[1] + b[2])
        dirs = unit(d_s - gx[..., None] * x_e[:, None] - gy[..., None] * y_e[:, None])
        o = origins.reshape(-1, 3)
        dd = dirs.reshape(-1, 3)
        col = np.zeros((m, 3))
        shifts = [eye.power_shift(wl) for wl in wls]
        if any(shifts):
            # the eye's own chromatic aberration: each channel's rays leave the eye with the
            # slopes of its power at that wavelength (every meridian + shift), then its own
            # trace through the lens
            traced, channel_dirs = [], []
            for wl, dp in zip(wls, shifts, strict=True):
                dc = unit(d_s - (gx + dp * rho_x)[..., None] * x_e[:, None]
                          - (gy + dp * rho_y)[..., None] * y_e[:, None]).reshape(-1, 3)
                channel_dirs.append(dc)
                traced.append(None if lens is None else lens.trace(o, dc, wl, reverse=True))
        else:
            channel_dirs = [dd] * len(wls)
            traced = lens.trace_wavelengths(o, dd, wls, reverse=True) if lens is not None \
                else [None] * len(wls)
        for ci, r2 in enumerate(traced):
            dd = channel_dirs[ci]
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
        return col, nrays, acc_diff


def fons_pattern(n: int, m: int) -> np.ndarray:
    """(n m + 1, 2) pupil points of Fons et al. 2023, §3 and Fig. 4, in the unit disc.

    The paper divides the pupil radius into ``n`` subdivisions and lays ``m`` diameters
    separated by the phase alpha = pi / m, and counts n m + 1 rays (the +1 is the main
    ray through the centre O). n subdivisions on each of the 2m half-diameters would be
    2 n m + 1 rays, so the count fixes one point per (subdivision, diameter): point (k, j)
    lies on diameter j at radius k / n, on that diameter's positive half for even k and on
    its negative half for odd k — every radius on every diameter once, the two halves of
    each diameter alternating (with pi/m phases, the m diameters' positive halves alone
    would cover half the pupil). This reading is eyelab's; the paper's figure does not
    resolve it (``tests/test_reference.py`` pins it and its mean)."""
    pts = [(0.0, 0.0)]
    for j in range(m):
        t = j * math.pi / m
        for k in range(1, n + 1):
            r = k / n * (1.0 if k % 2 == 0 else -1.0)
            pts.append((r * math.cos(t), r * math.sin(t)))
    return np.array(pts)


def fons_slopes(eye, acc, rho_x, rho_y):
    """Fons et al.'s two-axis construction (§4, Fig. 7) in paraxial slope form, (m, k)
    each. A sample's projection on the higher-error axis is aimed at that meridian's focus
    plane P'; the ray from the sample's own origin goes to where that line meets P, the
    lower-error meridian's plane. Along each principal axis a ray therefore converges to
    that meridian's own focus: the incoming slope is f_i (rho . a_i) along axis a_i, with
    f_i = P_i(acc) - n2 / z_r — which is the thin toric eye's G rho, whichever axis is the
    lower-error one."""
    e = eye.emmetropic_power
    p1, p2 = eye.principal_powers(acc)
    f1, f2 = (p1 - e)[:, None], (p2 - e)[:, None]
    w = math.radians(eye.astigmatism_axis_deg)
    a1 = np.array([math.cos(w), math.sin(w)])                       # meridian of P1
    a2 = np.array([-a1[1], a1[0]])
    along1 = rho_x * a1[0] + rho_y * a1[1]
    along2 = rho_x * a2[0] + rho_y * a2[1]
    gx = f1 * along1 * a1[0] + f2 * along2 * a2[0]
    gy = f1 * along1 * a1[1] + f2 * along2 * a2[1]
    return gx, gy


def _progress(fn, bar):
    def run(a, b):
        fn(a, b)
        bar.update(b - a)
    return run
