"""The retinal image of a schematic eye at fixation, by distribution ray tracing from its
curved retina (the reference for the raster's schematic-eye fields).

The eye fixates along the view's line of sight (its gaze) with one accommodation: the
view's ``focus_d`` (the model's accommodation, D) or, by default, the one that focuses the
scene point it fixates (the first hit along its axis, through the lens). Each pixel is a
line of sight (the eye camera's pixel direction entering the eye); its retinal point is
where that chief ray lands (:func:`~eyelab.optics.chain.retinal_rays.retina_points`, at the
eye's reference wavelength, on a grid of pixel corners interpolated at each sample's
sub-pixel position: the box filter). From it, ``samples`` rays leave through points of the
stop (Vogel's equal-area spiral, turned per pixel by a seeded angle), each found by
Newton's method through the crystalline lens and traced exactly through the cornea, the
spectacle lens (a ray missing it goes on straight) and into the scene; a pixel's colour is
the mean radiance of its rays (linear light, times the lens's Fresnel transmission), each
colour channel at its own wavelength (the eye's media disperse). The image shows radiance
as the eye's lines of sight see it: the retinal illuminance's fall-off with the pupil's
obliquity is not applied.
"""

from __future__ import annotations

import math
import time

import numpy as np

from eyelab.core.parallel import map_row_chunks
from eyelab.core.sampling import disc_seeds, pixel_jitter
from eyelab.imaging.contract import channel_wavelengths, finish, new_report
from eyelab.imaging.retinal import view_accommodation
from eyelab.optics.chain.retinal_rays import (
    camera_frame,
    rays_from_retina,
    retina_points,
    stop_jacobians,
)
from eyelab.optics.eye.thin import EYE_REFERENCE_NM
from eyelab.optics.rays.trace import FATAL
from eyelab.scene.raycast import EmbreeIntersector, scene_warnings


def render_retinal(name, scene, eye, lens, view, q):
    """The retinal image (a :class:`~eyelab.imaging.contract.RenderResult`) of the schematic
    ``eye`` behind ``lens`` (or none) for ``view``, ``q.samples`` rays per pixel and
    channel (module doc)."""
    t0 = time.perf_counter()
    report = new_report(name, view, q)
    cam = view.camera(eye.rotation_centre)       # its pixels are the lines of sight
    inter = EmbreeIntersector(scene)
    report["warnings"] = scene_warnings(scene, cam, inter)
    acc = view_accommodation(scene, eye, lens, view, inter)
    wls = channel_wavelengths(eye, lens, q.chromatic, report)
    w, h = view.width, view.height
    out, info = _window(scene, eye, lens, view, q, (0, 0, w, h), inter, acc, wls)
    dt = time.perf_counter() - t0
    k = q.samples
    report["samples"].update(target=k, done={"pixel": k})
    report["timings_s"]["trace"] = dt
    report["details"].update(channels_traced=len(wls), rays=info["rays"],
                             rays_per_s=info["rays"] / dt,
                             lines_of_sight_off_retina=info["off_retina"])
    report["details"]["schematic_eye"] = {"model": eye.model, "accommodation_d": acc,
                                          "fixation": "fixed (the view's line of sight)"}
    return finish(report, view, linear=out, t_start=t0)


def retinal_window(scene, eye, lens, view, q, box) -> np.ndarray:
    """The pixels ``box`` = (x0, y0, x1, y1) (from the top-left corner, x1 and y1
    exclusive) of :func:`render_retinal`'s image, (y1 - y0, x1 - x0, 3) linear light, at
    ``q.samples`` rays per pixel: what a measurement of a few small objects in a large view
    needs (the same rays as the whole image's, without tracing the rest)."""
    inter = EmbreeIntersector(scene)
    acc = view_accommodation(scene, eye, lens, view, inter)
    wls = channel_wavelengths(eye, lens, q.chromatic)
    return _window(scene, eye, lens, view, q, box, inter, acc, wls)[0]


def _window(scene, eye, lens, view, q, box, inter, acc, wls) -> tuple:
    """(linear image of ``box`` (h, w, 3), {"rays", "off_retina"})."""
    cam = view.camera(eye.rotation_centre)
    rot, vertex = camera_frame(cam)
    x0, y0, x1, y1 = (int(v) for v in box)
    w, h = x1 - x0, y1 - y0
    # retinal points at the pixel corners (the reference wavelength's chief rays)
    cx = -1.0 + 2.0 * np.arange(x0, x1 + 1) / view.width
    cy = 1.0 - 2.0 * np.arange(y0, y1 + 1) / view.height
    gx, gy = np.meshgrid(cx, cy)
    corner_dirs = -cam.ray_directions(gx.ravel(), gy.ravel())
    r_corner, v_corner, st_corner = retina_points(eye, rot, vertex, corner_dirs, acc,
                                                  EYE_REFERENCE_NM)
    r_corner = r_corner.reshape(h + 1, w + 1, 3)
    v_corner = v_corner.reshape(h + 1, w + 1, 3)
    k = q.samples
    seeds = disc_seeds(k)
    jit0 = pixel_jitter(k)
    r_stop = eye.stop_radius(acc, EYE_REFERENCE_NM)    # the iris: one size for every colour
    n = w * h
    out = np.zeros((n, 3))
    block = max(1, 16384 // k)
    streams = np.random.SeedSequence(q.seed).spawn(int(math.ceil(n / block)))

    def run(a, b) -> int:
        rng = np.random.default_rng(streams[a // block])
        m = b - a
        pix = np.arange(a, b)
        px, py = pix % w, pix // w
        ang = rng.uniform(0, 2 * math.pi, (m, 1))
        sx = seeds[None, :, 0] * np.cos(ang) - seeds[None, :, 1] * np.sin(ang)
        sy = seeds[None, :, 0] * np.sin(ang) + seeds[None, :, 1] * np.cos(ang)
        targets = r_stop * np.stack([sx.ravel(), sy.ravel()], -1)
        jit = np.mod(jit0[None] + 0.5 + rng.uniform(0, 1, (m, 1, 2)), 1.0)   # [0, 1)
        fx = (px[:, None] + jit[..., 0]).ravel()
        fy = (py[:, None] + jit[..., 1]).ravel()
        retina, v0 = _bilinear(r_corner, fx, fy), _bilinear(v_corner, fx, fy)
        v0 /= np.linalg.norm(v0, axis=1, keepdims=True)
        centre_r = _bilinear(r_corner, px + 0.5, py + 0.5)
        centre_v = _bilinear(v_corner, px + 0.5, py + 0.5)
        centre_v /= np.linalg.norm(centre_v, axis=1, keepdims=True)
        rows = np.repeat(np.arange(m), k)
        col = np.zeros((m, 3))
        for ci, wl in enumerate(wls):
            jac = stop_jacobians(eye, rot, vertex, centre_r, centre_v, acc, wl)
            o, d, ok = rays_from_retina(eye, rot, vertex, retina, v0, targets, (rows, jac),
                                        acc, wl)
            weight = ok.astype(float)
            if lens is not None:
                r2 = lens.trace(o, d, wl, reverse=True)
                through = (r2["status"] & np.uint8(FATAL)) == 0
                o = np.where(through[:, None], r2["out_points"], o)
                d = np.where(through[:, None], r2["out_dirs"], d)
                weight = weight * np.where(through, r2["transmittance"], 1.0)
            hit = inter.intersect(o + 1e-7 * d, d)
            lin = hit.linear_colors(scene) * weight[:, None]
            good = ok.reshape(m, k).sum(axis=1)
            c = lin.reshape(m, k, 3).sum(axis=1) / np.maximum(good, 1)[:, None]
            if len(wls) == 1:
                col = c
            else:
                col[:, ci] = c[:, ci]
        out[a:b] = col
        return m * k * len(wls)

    from eyelab.core.progress import bar as progress_bar

    with progress_bar(n, f"retinal image {w}x{h}, {k} spp", "px", force=q.progress) as bar:
        def shown(a, b):
            r = run(a, b)
            bar.update(b - a)
            return r

        rays = sum(map_row_chunks(shown, n, workers=q.workers, block=block))
    return out.reshape(h, w, 3), {
        "rays": rays,
        "off_retina": int((st_corner & np.uint8(FATAL)).astype(bool).sum())}


def _bilinear(grid, fx, fy):
    """``grid`` (h + 1, w + 1, 3) at continuous pixel positions (fx, fy) (px from the top
    left corner)."""
    h1, w1 = grid.shape[:2]
    x0 = np.clip(np.floor(fx).astype(int), 0, w1 - 2)
    y0 = np.clip(np.floor(fy).astype(int), 0, h1 - 2)
    tx, ty = (fx - x0)[:, None], (fy - y0)[:, None]
    return ((1 - tx) * (1 - ty) * grid[y0, x0] + tx * (1 - ty) * grid[y0, x0 + 1]
            + (1 - tx) * ty * grid[y0 + 1, x0] + tx * ty * grid[y0 + 1, x0 + 1])
