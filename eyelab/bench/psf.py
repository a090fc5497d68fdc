"""``eyelab bench psf``: the eye's wave-optics PSF (:mod:`eyelab.optics.eye.psf`) — its FFT
sizes and times for pupils and aberrations a clinic meets — and the default frame's cost
with higher-order aberrations against without (:func:`aberration_frames`)."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from eyelab.core.progress import bar as progress_bar

#: The PSF cases: (label, OSA coefficients by (n, m) at the pupil, pupil mm).
CASES = (("diffraction, 3 mm", {}, 3.0), ("0.15 um SA + 0.10 um coma, 6 mm",
                                          {(4, 0): 0.15, (3, -1): 0.10}, 6.0),
         ("1 D defocus + 0.3 um SA, 6 mm", {(2, 0): 1.299, (4, 0): 0.3}, 6.0),
         ("keratoconus-like (coma -1.2, trefoil 0.4, SA -0.3 um), 6 mm",
          {(3, -1): -1.2, (3, -3): 0.4, (4, 0): -0.3}, 6.0))


def aberration_frames(width: int, height: int, repeats: int) -> dict:
    """The built-in spec's default frame with and without an example of higher-order
    aberrations (0.15 um of spherical aberration and 0.10 um of vertical coma over 6 mm),
    naked and through its lens, warm (best of ``repeats`` after a first frame), one
    renderer."""
    from eyelab.imaging.registry import make_renderer
    from eyelab.jobs.api import as_spec, with_render
    from eyelab.jobs.render import build_scene
    from eyelab.optics.eye.aberrations import Aberrations

    spec = with_render(as_spec(None), dict(width=width, height=height))
    rs = spec.render
    c = np.zeros(13)
    c[7], c[12] = 0.10, 0.15
    eyes = {"without": spec.eye, "with": dataclasses.replace(
        spec.eye, aberrations=Aberrations(tuple(c), 6.0))}
    scene = build_scene(rs.scene)
    times = {k: {"naked": [], "through_lens": []} for k in eyes}
    with make_renderer(rs.renderer, rs.quality) as r:
        for k, eye in eyes.items():          # one eye at a time: its caches stay warm
            for label, lens in (("naked", None), ("through_lens", spec.lens)):
                for rep in range(repeats + 1):      # the first frame warms the caches
                    t = time.perf_counter()
                    r.render(scene, eye, lens, rs.view, rs.quality)
                    if rep:
                        times[k][label].append(time.perf_counter() - t)
    return {"aberrations": "Z4_0 0.15 um, Z3_-1 0.10 um at 6 mm",
            **{k: {lab: min(v) for lab, v in d.items()} for k, d in times.items()}}




def chart_against_full_wave(width: int, height: int, spp: int = 64) -> dict:
    """The naked-eye figure at full size: an ETDRS chart at 4 m, a -1.25 D eye (0.98 D of
    defocus for it, no accommodation, achromatic) with 0.08 um of vertical coma and 0.12 um
    of spherical aberration over 6 mm at a 5 mm pupil, the view inside the chart (a scene
    at one depth: 0.4'/px at 1024 x 768, a 6.8 x 5.1 deg field); the raster (default
    quality) and the reference (``spp``) against the FFT convolution of the sharp chart
    (the reference, an eye focusing every point) by the full-wave PSF: SSIM."""
    from eyelab.core.color import encode_srgb
    from eyelab.imaging.contract import View
    from eyelab.imaging.eyepsf import (
        channel_wavelengths,
        convolve_linear,
        sharp_eye,
        view_pitch_rad,
    )
    from eyelab.imaging.options import RasterQuality, ReferenceQuality
    from eyelab.optics.eye.aberrations import Aberrations, second_order
    from eyelab.optics.eye.psf import psf
    from eyelab.optics.eye.thin import Eye
    from eyelab.reference.metrics import ssim
    from eyelab.reference.tracer import ReferenceRenderer
    from eyelab.render.raster import RasterRenderer
    from eyelab.scene.library import chart_scene

    dist, pupil = 4.0, 5.0
    fov = 2 * np.degrees(np.arctan(height / 2 * (0.4 * 1024 / width) / 60 * np.pi / 180))
    view = View(width=width, height=height, fov_y_deg=float(fov), near=0.1, far=20.0)
    c = np.zeros(13)
    c[7], c[12] = 0.08, 0.12
    eye = Eye.from_rx("-1.25 DS", accommodation_max=0.0, pupil_diameter=pupil * 1e-3,
                      chromatic=False, aberrations=Aberrations(tuple(c), 6.0))
    scene = chart_scene(dist)
    t = time.perf_counter()
    with ReferenceRenderer(ReferenceQuality(samples=spp)) as r:
        sharp = r.render(scene, sharp_eye(eye), None, view).linear
    m = (eye.power_min - eye.emmetropic_power) - 1.0 / dist
    coef = np.zeros(28)
    hoa = eye.aberrations.wearer(pupil)
    coef[:len(hoa)] = hoa
    coef[4] += second_order(m, 0.0, m, pupil)[0]
    pitch = view_pitch_rad(view)
    ks = [psf(coef, pupil, wl, pitch, 81, strehl=False)["psf"]
          for wl in channel_wavelengths()]
    truth = encode_srgb(convolve_linear(sharp, [k / k.sum() for k in ks]))
    out = {"size": [width, height], "pitch_arcmin": pitch * 180 * 60 / np.pi,
           "defocus_d": m, "truth_s": time.perf_counter() - t}
    for name, cls, q in (("raster", RasterRenderer, RasterQuality()),
                         ("reference", ReferenceRenderer, ReferenceQuality(samples=spp))):
        t = time.perf_counter()
        with cls(q) as r:
            res = r.render(scene, eye, None, view)
        out[name] = {"ssim": ssim(res.srgb, truth), "time_s": time.perf_counter() - t}
    return out


def run_psf_bench(width: int = 1024, height: int = 768, repeats: int = 2) -> dict:
    from eyelab.optics.eye.psf import ARCMIN, psf
    from eyelab.optics.eye.zernike import j_from_nm

    bar = progress_bar(len(CASES) + 2, "psf bench", "step")
    rows = []
    for label, terms, pupil in CASES:
        c = np.zeros(28)
        for (n, m), v in terms.items():
            c[j_from_nm(n, m)] = v
        best = None
        for _ in range(repeats + 1):
            t = time.perf_counter()
            out = psf(c, pupil, 555.0, 0.25 * ARCMIN, 129)
            dt = time.perf_counter() - t
            best = dt if best is None else min(best, dt)
        rows.append({"case": label, "pupil_mm": pupil, "time_s": best, "fft": out["fft"],
                     "block": out["block"], "pupil_samples": out["pupil_samples"],
                     "strehl": out["strehl"], "rms_um": out["rms_um"]})
        bar.update(1)
    frames = aberration_frames(width, height, repeats)
    bar.update(1)
    chart = chart_against_full_wave(width, height)
    bar.close()
    lines = [f"{r['case']:>58}: PSF 129 px at 0.25'/px in {r['time_s'] * 1e3:.0f} ms "
             f"({r['fft']}-point FFT, {r['pupil_samples']} pupil samples, blocks of "
             f"{r['block']}), Strehl {r['strehl']:.3f}, RMS {r['rms_um']:.3f} um" for r in rows]
    lines.append(f"default spec {width}x{height}, warm, {frames['aberrations']}: naked "
                 f"{frames['with']['naked'] * 1e3:.0f} ms (without "
                 f"{frames['without']['naked'] * 1e3:.0f} ms), through the lens "
                 f"{frames['with']['through_lens'] * 1e3:.0f} ms (without "
                 f"{frames['without']['through_lens'] * 1e3:.0f} ms)")
    lines.append(f"naked chart at {width}x{height} ({chart['pitch_arcmin']:.2f}'/px, "
                 f"{chart['defocus_d']:.2f} D of defocus, coma and spherical aberration) "
                 f"against the full-wave image: raster SSIM {chart['raster']['ssim']:.4f} "
                 f"({chart['raster']['time_s']:.1f} s cold), reference "
                 f"{chart['reference']['ssim']:.4f} ({chart['reference']['time_s']:.1f} s)")
    return {"benchmark": "psf", "rows": rows, "frames": frames, "chart_full_size": chart,
            "size": [width, height], "summary": lines}
