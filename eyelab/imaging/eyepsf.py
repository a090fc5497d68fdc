"""The eye's higher-order aberrations and diffraction in a rendered image
(:mod:`eyelab.optics.eye.aberrations`), applied by :meth:`eyelab.imaging.contract.Renderer.
render` to every renderer's image when the eye has ``[eye.aberrations]`` — and only then
(without them a render is exactly as before, at no cost). In linear light, each colour
channel at its own wavelength.

* **The naked eye: wave optics throughout** (:func:`wave_scatter`). The renderer draws the
  scene sharp (an eye that focuses every point); each pixel's low-order wave error is
  found from its depth as the renderers find it — the scene point on the pixel's chief
  ray (embree), the accommodation by the renderer's rule (Eq. 13 by default), the eye's
  power at the channel's wavelength: M = P_eye(acc, lambda) + v I - n2/z_r I, v the
  point's vergence — and each pixel's light is spread by the full-wave PSF of that
  defocus and astigmatism plus the higher orders, over the render's pupil. PSFs are
  computed on levels of the mean defocus (the eye's astigmatism is the same everywhere)
  and each pixel's light split between its two neighbouring levels (linear weights): a
  scatter, so light is conserved; exact for a scene at one depth, approximate at depth
  edges (no occlusion between blurred layers). Level spacing: 0.02 um of c20, or 10 % of
  the defocus where it is larger (a blur that large changes smoothly), at most
  :data:`MAX_LEVELS` per channel.
* **Through a lens: product** (:func:`apply_eye_psf`). The lens's low-order blur varies
  across the field and is rendered exactly by the renderer; the raster convolves its
  image with the higher orders' wave PSF (diffraction included, no defocus), the
  reference bends each pupil ray by grad W (geometric) and convolves with the
  diffraction-limited PSF. The true PSF of low + high orders is not the convolution of
  the two (their ray errors add pupil point by pupil point): the error of this product
  against the full-wave PSF is stated in docs/checking/optics-patient-eye.md.

Kernels are sampled at the view's angular pitch at its centre (2 tan(fov_y / 2) / height
rad per pixel; off axis a pixel subtends less, by up to cos^2 of the field angle, so the
kernel is there slightly too small) with reflected edges.
"""

from __future__ import annotations

import math
import time

import numpy as np


def view_pitch_rad(view) -> float:
    """Radians per pixel at the view's centre."""
    return 2 * math.tan(math.radians(view.fov_y_deg) / 2) / view.height


def channel_wavelengths() -> tuple:
    """The wavelengths (nm) of the R, G, B channels."""
    from eyelab.optics.rays.materials import RGB_WAVELENGTHS_NM

    return tuple(RGB_WAVELENGTHS_NM)


def convolve_linear(linear: np.ndarray, kernels) -> np.ndarray:
    """Each channel of ``linear`` (h, w, 3+) convolved with its kernel (odd squares, sums 1),
    edges reflected; returns float32 (h, w, 3)."""
    from scipy.signal import fftconvolve

    h, w = linear.shape[:2]
    out = np.empty((h, w, 3), np.float32)
    for c, k in enumerate(kernels):
        r = k.shape[0] // 2
        src = np.pad(np.asarray(linear[..., c], np.float64), r, mode="reflect")
        out[..., c] = fftconvolve(src, k, mode="same")[r:r + h, r:r + w]
    return np.clip(out, 0.0, None)


def eye_kernels(eye, view, *, waves: bool = True) -> list:
    """The three channels' kernels for ``eye`` (with aberrations) in ``view``: the higher
    orders and diffraction (``waves``) or diffraction alone."""
    ab = eye.aberrations
    pitch = view_pitch_rad(view)
    pupil = eye.pupil_diameter * 1e3
    return [ab.kernel(wl, pupil, pitch, waves=waves) for wl in channel_wavelengths()]


#: The most defocus levels per channel of :func:`wave_scatter`.
MAX_LEVELS = 64
#: Level spacing in c20 (um) near focus.
LEVEL_C20_UM = 0.02


def sharp_eye(eye):
    """An eye with ``eye``'s geometry that focuses every point farther than 4 cm sharply
    (emmetropic, no astigmatism or chromatic aberration, the largest amplitude): the
    renderer's sharp image for :func:`wave_scatter`."""
    import dataclasses

    from eyelab.optics.eye.thin import MAX_ACCOMMODATION_D

    return dataclasses.replace(eye, power_min=eye.emmetropic_power, astigmatism=0.0,
                               accommodation_max=MAX_ACCOMMODATION_D, chromatic=False,
                               aberrations=None)


def pixel_wave_errors(scene, eye, view, quality) -> tuple:
    """Per pixel (row 0 at the top) of a naked-eye view: (mean defocus (3, h, w) D per
    channel — (Mxx + Myy) / 2 of M = P_eye(acc, lambda) + v I - n2/z_r I — and the eye's
    constant (Mxx - Myy) / 2, Mxy (D)), the accommodation by the renderer's rule."""
    from eyelab.scene.focus import pixel_accommodation
    from eyelab.scene.raycast import EmbreeIntersector

    ndc = view.pixel_ndc()
    cam = view.camera(eye.rotation_centre)
    d = cam.ray_directions(ndc[:, 0], ndc[:, 1])
    inter = EmbreeIntersector(scene)
    rule = getattr(quality, "accommodation", "eq13")
    acc, _ = pixel_accommodation(d, scene, inter, eye, None, view, cam, "thin",
                                 rule if rule in ("eq13", "rms") else "eq13")
    pupil = np.asarray(cam.position, float)
    hit = inter.intersect(pupil + 1e-7 * d, d)
    with np.errstate(divide="ignore"):
        v = np.where(hit.hit, -1.0 / (hit.t + 1e-7), 0.0)
    means = []
    for wl in channel_wavelengths():
        pxx, pxy, pyy = eye.power_matrix(acc, wl)
        means.append((0.5 * (pxx + pyy) + v - eye.emmetropic_power).reshape(view.height,
                                                                            view.width))
    pxx, pxy, pyy = eye.power_matrix(0.0)
    return np.stack(means), 0.5 * float(pxx - pyy), float(pxy)


def _levels(m: np.ndarray, pupil_mm: float) -> np.ndarray:
    """Mean-defocus levels (D) covering ``m``: spacing LEVEL_C20_UM of c20 near focus,
    10 % of |m| beyond, at most MAX_LEVELS (then evenly spaced)."""
    r2 = (pupil_mm / 2) ** 2                                   # mm^2
    step0 = LEVEL_C20_UM * 4 * math.sqrt(3) / r2               # D per c20 step
    lo, hi = float(m.min()), float(m.max())
    if hi - lo < 1e-9:
        return np.array([lo])
    out = [lo]
    while out[-1] < hi:
        out.append(out[-1] + max(step0, 0.1 * abs(out[-1])))
    if len(out) > MAX_LEVELS:
        return np.linspace(lo, hi, MAX_LEVELS)
    return np.array(out)


def wave_scatter(sharp: np.ndarray, mean_d: np.ndarray, j0w: float, mxy: float, eye,
                 view) -> np.ndarray:
    """The naked eye's image (module text): ``sharp`` (h, w, 3) linear, each pixel's light
    spread by the full-wave PSF of its low-order error (``mean_d`` (3, h, w) D, the
    eye's (Mxx - Myy) / 2 = ``j0w`` and ``mxy``) plus the higher orders."""
    from scipy.signal import fftconvolve

    from eyelab.optics.eye.aberrations import psf_kernel, second_order

    ab = eye.aberrations
    pupil = eye.pupil_diameter * 1e3
    pitch = view_pitch_rad(view)
    hoa = ab.wearer(pupil)
    h, w = sharp.shape[:2]
    out = np.zeros((h, w, 3), np.float32)
    for c, wl in enumerate(channel_wavelengths()):
        levels = _levels(mean_d[c], pupil)
        kernels = []
        for lev in levels:
            c20, c22, c2m2 = second_order(lev + j0w, mxy, lev - j0w, pupil)
            coef = np.zeros(max(len(hoa), 6))
            coef[:len(hoa)] = hoa
            coef[3:6] += (c2m2, c20, c22)
            kernels.append(psf_kernel(coef, pupil, wl, pitch, ab.stiles_crawford))
        pad = max(k.shape[0] for k in kernels) // 2
        src = np.pad(np.asarray(sharp[..., c], np.float64), pad, mode="reflect")
        m = np.pad(mean_d[c], pad, mode="reflect")
        if len(levels) == 1:
            idx, frac = np.zeros(m.shape, int), np.zeros(m.shape)
        else:
            pos = np.interp(m, levels, np.arange(len(levels)))
            idx = np.minimum(pos.astype(int), len(levels) - 2)
            frac = pos - idx
        acc = np.zeros_like(src)
        for li, k in enumerate(kernels):
            wgt = np.where(idx == li, 1.0 - frac, 0.0) + np.where(idx == li - 1, frac, 0.0)
            rows, cols = np.flatnonzero(wgt.any(axis=1)), np.flatnonzero(wgt.any(axis=0))
            if len(rows) == 0:
                continue
            r = k.shape[0] // 2             # each level's light only where it falls
            y0, y1 = max(rows[0] - r, 0), min(rows[-1] + r + 1, src.shape[0])
            x0, x1 = max(cols[0] - r, 0), min(cols[-1] + r + 1, src.shape[1])
            acc[y0:y1, x0:x1] += fftconvolve(src[y0:y1, x0:x1] * wgt[y0:y1, x0:x1], k,
                                             mode="same")
        out[..., c] = acc[pad:pad + h, pad:pad + w]
    return np.clip(out, 0.0, None)


def apply_eye_psf(result, eye, view, *, waves: bool = True):
    """``result`` (a :class:`~eyelab.imaging.contract.RenderResult`) with the eye's kernels
    applied to its linear image, the sRGB re-encoded and the report noting it."""
    lin = result.linear
    kernels = eye_kernels(eye, view, waves=waves)
    t0 = time.perf_counter()
    out = convolve_linear(lin, kernels)
    ab = eye.aberrations
    pupil = eye.pupil_diameter * 1e3
    result.report["details"]["eye_aberrations"] = {
        "mode": "product: the renderer's low-order blur, then a kernel of the higher orders "
                "and diffraction (wave)" if waves else "product: the renderer's low-order "
                "blur and the higher orders traced per ray (geometric), then the "
                "diffraction kernel (wave)",
        "pupil_mm": pupil, "measured_pupil_mm": ab.pupil_mm,
        "rms_um": ab.rms_um(pupil), "kernel_px": [int(k.shape[0]) for k in kernels],
        "pitch_arcmin": view_pitch_rad(view) * 180 * 60 / math.pi}
    t = result.report["timings_s"]
    t["eye_psf"] = time.perf_counter() - t0
    if "total" in t:
        t["total"] += t["eye_psf"]
    return type(result)(result.report, linear=out, layers=result.layers,
                        progressive=result.progressive)


def render_aberrated(renderer, scene, eye, lens, view, quality, progressive):
    """``renderer``'s image of what ``eye`` (with aberrations) sees (module text): naked,
    its sharp image spread by the full-wave PSFs; through ``lens``, the product."""
    if lens is not None:
        res = renderer._render(scene, eye, lens, view, quality, progressive)
        return apply_eye_psf(res, eye, view, waves=not renderer.traces_eye_aberrations)
    sharp = renderer._render(scene, sharp_eye(eye), None, sharp_view(view), quality,
                             progressive)
    return naked_wave(sharp, scene, eye, view, quality)


def sharp_view(view):
    """``view`` without a fixed focus: the sharp eye focuses each point itself (a fixed
    focus is the real eye's, applied by :func:`pixel_wave_errors`)."""
    import dataclasses

    return view if view.focus_d is None else dataclasses.replace(view, focus_d=None)


def aberrated_frames(renderer, scene, eye, lens, view, quality, *args):
    """A progressive renderer's frames (its ``_run(scene, eye, lens, view, quality,
    *args)`` generator) for an eye with aberrations, as :func:`render_aberrated` treats
    its final image."""
    from eyelab.core.parallel import NO_IMAGE

    run = renderer._run
    if lens is not None:
        waves = not renderer.traces_eye_aberrations
        for res in run(scene, eye, lens, view, quality, *args):
            yield res if res is None or res is NO_IMAGE else apply_eye_psf(res, eye, view,
                                                                           waves=waves)
        return
    for res in run(scene, sharp_eye(eye), None, sharp_view(view), quality, *args):
        yield res if res is None or res is NO_IMAGE else naked_wave(res, scene, eye, view,
                                                                    quality)


#: The report's line for the sharp passes of the naked eye in wave optics (in place of the
#: raster's "blur field all zero", which would read as if the eye's blur were lost).
WAVE_SHARP_NOTE = ("naked view: drawn sharp (the passes antialias only); the eye's blur, "
                   "its defocus and higher orders, is the full-wave PSF's, spread after")


def naked_wave(sharp, scene, eye, view, quality):
    """:func:`wave_scatter` of a sharp :class:`RenderResult`, the report noting it."""
    t0 = time.perf_counter()
    mean_d, j0w, mxy = pixel_wave_errors(scene, eye, view, quality)
    out = wave_scatter(sharp.linear, mean_d, j0w, mxy, eye, view)
    pupil = eye.pupil_diameter * 1e3
    ab = eye.aberrations
    rep = sharp.report
    # the sharp eye's zero field is how the wave mode starts, not a finding: say so
    rep["skipped"] = [WAVE_SHARP_NOTE if "blur field all zero" in line else line
                      for line in rep["skipped"]]
    rep["details"]["eye_aberrations"] = {
        "mode": "wave: the sharp image spread by the full-wave PSF of each pixel's defocus "
                "and astigmatism plus the higher orders",
        "pupil_mm": pupil, "measured_pupil_mm": ab.pupil_mm, "rms_um": ab.rms_um(pupil),
        "defocus_range_d": [float(mean_d.min()), float(mean_d.max())],
        "levels": [len(_levels(m, pupil)) for m in mean_d],
        "pitch_arcmin": view_pitch_rad(view) * 180 * 60 / math.pi}
    t = rep["timings_s"]
    t["eye_psf"] = time.perf_counter() - t0
    if "total" in t:
        t["total"] += t["eye_psf"]
    return type(sharp)(rep, linear=out, layers=sharp.layers, progressive=sharp.progressive)
