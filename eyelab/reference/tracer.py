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
   scene; their colours are averaged.

Shading is the raster renderer's: unlit vertex colours or bilinear texture look-ups,
averaged in the same (sRGB-encoded) values. With a dispersive lens each colour channel
is traced at its own wavelength (C, e, F lines). Pupil samples: Vogel's equal-area spiral,
rotated per pixel by a seeded random angle (deterministic for a seed, decorrelated between
pixels). Rows of pixels run on a thread pool.

``model="fons"`` replaces the eye by Fons et al. 2023's reduced-eye sampling: n x m + 1
polar pupil points (n radii, m diameters) aimed at the focus plane P at the accommodated
distance, and for astigmatism their two-axis construction (samples projected on the axis
of larger error are aimed at the focus plane P' of that meridian; the ray keeps its pupil
origin and goes to where that line meets P).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from eyelab.blur.bundle import disc_seeds
from eyelab.errors import SpecError, check_range
from eyelab.optics.analysis import UP
from eyelab.optics.camera import Camera, eye_camera
from eyelab.optics.materials import RGB_WAVELENGTHS_NM
from eyelab.optics.paths import ChiefRays
from eyelab.optics.raymatrix import apply_isotropic, lens_path_matrix
from eyelab.optics.trace import FATAL
from eyelab.optics.wavefront import _cross
from eyelab.parallel import map_row_chunks
from eyelab.render_support import pixel_jitter
from eyelab.scene.raycast import EmbreeIntersector
from eyelab.scene.scene import Scene


@dataclass(frozen=True)
class ReferenceSettings:
    """width, height (px), fov_y_deg, near/far (m, as the raster camera), spp (rays per pixel
    and channel, 1-65536), seed, chromatic, focus (None = Eq. 13 per pixel, else D),
    model ("kakimoto" thin toric eye, or "fons"), fons_n / fons_m (radii, diameters)."""

    width: int = 160
    height: int = 120
    fov_y_deg: float = 60.0
    near: float = 0.05
    far: float = 100.0
    spp: int = 64
    seed: int = 0
    chromatic: bool = True
    focus: float | None = None
    model: str = "kakimoto"
    fons_n: int = 4
    fons_m: int = 8
    progress: bool = False

    def __post_init__(self):
        check_range("reference.width", self.width, 4, 4096)
        check_range("reference.height", self.height, 4, 4096)
        check_range("reference.spp", self.spp, 1, 65536)
        check_range("reference.fov_y_deg", self.fov_y_deg, 1, 150)
        check_range("reference.near", self.near, 1e-3, 10)
        if not self.far > self.near:
            raise SpecError("reference.far", f"must be > near ({self.near}), got {self.far}")
        if self.model not in ("kakimoto", "fons"):
            raise SpecError("reference.model", f"must be 'kakimoto' or 'fons', got "
                                               f"{self.model!r}")

    def eye_camera(self) -> Camera:
        return eye_camera(self.fov_y_deg, self.width / self.height, self.near, self.far)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


class ReferenceRenderer:
    def __init__(self, settings: ReferenceSettings | None = None):
        self.settings = settings or ReferenceSettings()

    def pixel_ndc(self):
        """(n, 2) NDC of the pixel centres, row 0 at the top."""
        s = self.settings
        x = -1.0 + (2 * np.arange(s.width) + 1.0) / s.width
        y = 1.0 - (2 * np.arange(s.height) + 1.0) / s.height
        gx, gy = np.meshgrid(x, y)
        return np.column_stack([gx.ravel(), gy.ravel()])

    def pixel_directions(self):
        ndc = self.pixel_ndc()
        return self.settings.eye_camera().ray_directions(ndc[:, 0], ndc[:, 1])

    def pupil_samples(self):
        s = self.settings
        if s.model == "fons":
            r = np.arange(1, s.fons_n + 1) / s.fons_n
            t = np.arange(2 * s.fons_m) * math.pi / s.fons_m
            rr, tt = np.meshgrid(r, t, indexing="ij")
            pts = np.column_stack([(rr * np.cos(tt)).ravel(), (rr * np.sin(tt)).ravel()])
            return np.vstack([[0.0, 0.0], pts])
        return disc_seeds(s.spp)

    def render(self, scene: Scene, eye, lens=None, *, workers=None):
        """Returns (image uint8 (h, w, 3), float image (h, w, 3) in [0, 255], report)."""
        s = self.settings
        t0 = time.perf_counter()
        ndc = self.pixel_ndc()
        dirs = self.pixel_directions()
        n = len(dirs)
        inter = EmbreeIntersector(scene)
        samples = self.pupil_samples()
        disperses = s.chromatic and lens is not None and lens.material.dispersive
        wls = RGB_WAVELENGTHS_NM if disperses else (587.56,)
        out = np.zeros((n, 3))
        counts = {"rays": 0}
        rng_root = np.random.SeedSequence(s.seed)
        block = max(1, 16384 // len(samples))   # ~16k rays per task: numpy-friendly
        seeds = rng_root.spawn(int(math.ceil(n / block)))

        def run(a, b):
            rng = np.random.default_rng(seeds[a // block])
            col, nrays = self._pixels(dirs[a:b], ndc[a:b], scene, inter, eye, lens, samples,
                                      wls, rng)
            out[a:b] = col
            counts["rays"] += nrays

        it = None
        if s.progress:
            from tqdm import tqdm

            it = tqdm(total=n, desc="reference", unit="px")
        map_row_chunks(run if it is None else _progress(run, it), n, workers=workers,
                       block=block)
        if it is not None:
            it.close()
        img = out.reshape(s.height, s.width, 3)
        dt = time.perf_counter() - t0
        report = {"spp": len(samples), "channels_traced": len(wls), "rays": counts["rays"],
                  "time_s": dt, "rays_per_s": counts["rays"] / dt, "model": s.model,
                  "size": [s.width, s.height]}
        return np.clip(np.round(img), 0, 255).astype(np.uint8), img, report

    def _pixels(self, d, ndc, scene, inter, eye, lens, samples, wls, rng):
        s = self.settings
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
            x_e = _unit(_cross(np.broadcast_to(UP, n_in.shape), n_in))
            t, _ = lens_path_matrix(chief, lens, 587.56, np.zeros((len(idx), 3)), x_e)
            kxx, _, kyy, _ = apply_isotropic(t, v[idx])
            kbar[idx] = 0.5 * (kxx + kyy)
        acc = eye.accommodation_for(kbar) if s.focus is None else np.full(
            m, min(max(float(s.focus), 0.0), eye.accommodation_max))
        # 3. ray bundles from the retina point through the pupil samples
        n_in = -d
        x_e = _unit(_cross(np.broadcast_to(UP, n_in.shape), n_in))
        y_e = _cross(n_in, x_e)
        ang = rng.uniform(0, 2 * math.pi, m)
        ca, sa = np.cos(ang), np.sin(ang)
        sx = samples[None, :, 0] * ca[:, None] - samples[None, :, 1] * sa[:, None]
        sy = samples[None, :, 0] * sa[:, None] + samples[None, :, 1] * ca[:, None]
        rho_x, rho_y = rp * sx, rp * sy                                  # (m, k)
        pxx, pxy, pyy = eye.power_matrix(acc)
        e = eye.emmetropic_power
        if s.model == "fons":
            gx, gy = self._fons_slopes(eye, acc, rho_x, rho_y, kbar)
        else:
            gx = (pxx - e)[:, None] * rho_x + pxy[:, None] * rho_y       # incoming slope G rho
            gy = pxy[:, None] * rho_x + (pyy - e)[:, None] * rho_y
        origins = pupil + rho_x[..., None] * x_e[:, None] + rho_y[..., None] * y_e[:, None]
        # each sample's ray leaves a point of the pixel (box filter, as the raster's jittered
        # passes): R2 offsets, shifted per pixel (Cranley-Patterson rotation)
        k = samples.shape[0]
        jit = np.mod(pixel_jitter(k)[None] + 0.5 + rng.uniform(0, 1, (m, 1, 2)), 1.0) - 0.5
        cam = s.eye_camera()
        tx, ty = cam.tan_half
        b = cam.basis
        jx = ndc[:, None, 0] + 2 * jit[..., 0] / s.width
        jy = ndc[:, None, 1] + 2 * jit[..., 1] / s.height
        d_s = _unit((jx * tx)[..., None] * b[0] + (jy * ty)[..., None] * b[1] + b[2])
        dirs = _unit(d_s - gx[..., None] * x_e[:, None] - gy[..., None] * y_e[:, None])
        o = origins.reshape(-1, 3)
        dd = dirs.reshape(-1, 3)
        col = np.zeros((m, 3))
        traced = lens.trace_wavelengths(o, dd, wls, reverse=True) if lens is not None \
            else [None] * len(wls)
        for ci, r2 in enumerate(traced):
            if r2 is not None:
                ok = ((r2["status"] & np.uint8(FATAL)) == 0)
                oo = np.where(ok[:, None], r2["out_points"], o)
                od = np.where(ok[:, None], r2["out_dirs"], dd)
            else:
                oo, od = o, dd
            h = inter.intersect(oo + 1e-7 * od, od)
            c = h.colors(scene).reshape(m, -1, 3).mean(axis=1)
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
