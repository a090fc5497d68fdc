"""``eyelab bench psf``: the eye's wave-optics PSF (:mod:`eyelab.optics.psf`) — its FFT
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
    from eyelab.optics.aberrations import Aberrations

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




def run_psf_bench(width: int = 1024, height: int = 768, repeats: int = 2) -> dict:
    from eyelab.optics.psf import ARCMIN, psf
    from eyelab.optics.zernike import j_from_nm

    bar = progress_bar(len(CASES) + 1, "psf bench", "step")
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
    bar.close()
    lines = [f"{r['case']:>58}: PSF 129 px at 0.25'/px in {r['time_s'] * 1e3:.0f} ms "
             f"({r['fft']}-point FFT, {r['pupil_samples']} pupil samples, blocks of "
             f"{r['block']}), Strehl {r['strehl']:.3f}, RMS {r['rms_um']:.3f} um" for r in rows]
    lines.append(f"default spec {width}x{height}, warm, {frames['aberrations']}: naked "
                 f"{frames['with']['naked'] * 1e3:.0f} ms (without "
                 f"{frames['without']['naked'] * 1e3:.0f} ms), through the lens "
                 f"{frames['with']['through_lens'] * 1e3:.0f} ms (without "
                 f"{frames['without']['through_lens'] * 1e3:.0f} ms)")
    return {"benchmark": "psf", "rows": rows, "frames": frames,
            "size": [width, height], "summary": lines}
