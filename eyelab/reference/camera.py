"""Distribution ray tracing through a general lens system (Kolb, Mitchell & Hanrahan 1995,
as Heidrich et al. 1997 use it for their reference images): for every pixel, rays from
points of the pixel's film area through points of the image-sided sample plane, traced
exactly through every surface and the stop (a vignetted ray carries nothing), then into
the scene; the film irradiance E(x') = A(x')/n sum L W T (Heidrich Eq. 3 with many random
samples; W = cos th' cos th'' / |x'' - x'|^2, T the surfaces' Fresnel transmission),
normalised by the exact unvignetted, lossless value at the film centre
(:meth:`eyelab.optics.cameralens.film.CameraRays.white_level`). Each film point's samples are drawn
from the bounding disc of its own vignetted bundle, of area A(x') (the ``"bundle"``
domain of :class:`~eyelab.optics.cameralens.film.CameraRays`): off the axis the bundle moves away
from the film centre's disc, and a disc that follows it holds all of its light with the
fewest vignetted samples. The truth the image-based renderer's camera images are measured
against; its approximations (perspective slices, morph, few lens samples) are absent here.
"""

from __future__ import annotations

import math
import time

import numpy as np

from eyelab.core.parallel import map_row_chunks
from eyelab.core.sampling import GOLDEN_ANGLE, pixel_jitter
from eyelab.imaging.contract import finish, new_report
from eyelab.optics.cameralens.film import CameraRays
from eyelab.optics.rays.materials import RGB_WAVELENGTHS_NM
from eyelab.scene.raycast import EmbreeIntersector


def render_camera(scene, system, view, quality, name: str = "reference"):
    """The film image of ``system`` (a :class:`~eyelab.optics.cameralens.system.LensSystem`) for
    ``view`` (pixels, field of view through the paraxial focal length, clipping) with
    ``quality.samples`` rays per pixel and channel (a :class:`ReferenceQuality`); returns
    a :class:`~eyelab.imaging.contract.RenderResult` in the common schema, whose report's
    ``details.rays`` counts the rays traced: width x height x samples x channels traced.

    Pixels are traced in blocks of ~16k rays on ``quality.workers`` threads; each block
    has its own random stream, so the image does not depend on the thread count."""
    t0 = time.perf_counter()
    report = new_report(name, view, quality)
    # random samples per film point: each from its own vignetted bundle's bounding disc
    maker = CameraRays(system, view.width, view.height, view.fov_y_deg, view.near,
                       domain="bundle")
    dispersive = any(s.after.dispersive for s in system.surfaces)
    wls = RGB_WAVELENGTHS_NM if quality.chromatic and dispersive else (587.56,)
    for wl in wls:
        maker.footprints(wl)            # the bundles, tabulated before the threads start
    if len(wls) == 1:
        report["skipped"].append("chromatic: one wavelength")
    inter = EmbreeIntersector(scene)
    h, w = view.height, view.width
    n = h * w
    k = quality.samples
    golden = np.arange(k) * GOLDEN_ANGLE          # Vogel's spiral, made random per pixel
    jit0 = pixel_jitter(k)
    out = np.zeros((n, 3))
    seeds = np.random.SeedSequence(quality.seed)
    block = max(1, 16384 // k)
    streams = seeds.spawn(int(math.ceil(n / block)))

    def run(a, b) -> int:
        """Trace pixels ``a:b`` (row-major indices) into ``out``; returns the rays traced.

        Runs on a worker thread: it writes only its own rows of ``out`` and returns its
        count rather than adding to a shared one, so the total needs no lock.
        """
        rng = np.random.default_rng(streams[a // block])
        m = b - a
        pix = np.arange(a, b)
        # sample i at area fraction (i + u)/k and angle i x golden + phi, u and phi uniform
        # per pixel: each sample is uniform over the disc (an unbiased estimate of the
        # bundle's integral, edges included), the set still stratified in area
        u = rng.uniform(0, 1, (m, 1))
        phi = rng.uniform(0, 2 * math.pi, (m, 1))
        rad = np.sqrt((np.arange(k)[None] + u) / k)
        sx, sy = rad * np.cos(golden[None] + phi), rad * np.sin(golden[None] + phi)
        jit = np.mod(jit0[None] + 0.5 + rng.uniform(0, 1, (m, 1, 2)), 1.0)
        fx = (pix % w)[:, None] + jit[..., 0]
        fy = (pix // w)[:, None] + jit[..., 1]
        film = np.column_stack([fx.ravel(), fy.ravel()])
        smp = np.column_stack([sx.ravel(), sy.ravel()])
        col = np.zeros((m, 3))
        for ci, wl in enumerate(wls):
            rs = maker.ray_pairs(film, smp, wl)
            hit = inter.intersect(rs.origins + 1e-7 * rs.dirs, rs.dirs)
            lin = hit.linear_colors(scene) * (rs.weight * rs.transmittance)[:, None]
            c = lin.reshape(m, k, 3).mean(axis=1)
            if len(wls) == 1:
                col = c
            else:
                col[:, ci] = c[:, ci]
        out[a:b] = col / maker.white_level()
        return m * k * len(wls)

    rays = sum(map_row_chunks(run, n, workers=quality.workers, block=block))
    report["samples"].update(target=k, done={"pixel": k})
    report["details"].update(system=system.name, radiometry="irradiance", channels=len(wls),
                             rays=rays)
    report["timings_s"]["trace"] = time.perf_counter() - t0
    return finish(report, view, linear=out.reshape(h, w, 3).astype(np.float32), t_start=t0)
