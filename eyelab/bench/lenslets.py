"""``eyelab bench lenslets``: myopia-control lenses in the raster renderer — what a frame
through a DIMS-like and a HALT-like lens costs against the single-vision lens of the same
Rx (their carrier), and how close it comes to the reference renderer's pupil rays.

Frames: a -3.00 D myope (4 mm pupil) at the default view size and quality, the built-in
room, looking straight ahead, 20 deg and 30 deg down (the page at 40 cm lies 20 deg
down); per gaze the single-vision lens and each lenslet lens with its own raster renderer,
cold (first frame: fields, refinement, lens coordinates, the lenslet offsets) and warm
(the best of ``repeats``), measured in alternation so that the machine's load falls on all
alike. Error: a page at 40 cm along each gaze, 160 x 120 over 5 deg (the lenslets' halo
a few pixels wide), raster at its default quality and the single-vision lens against the
reference renderer at ``truth_spp`` rays a pixel through the lenslet lens; SSIM / PSNR /
blur-size error (:func:`eyelab.reference.metrics.compare_images`).
"""

from __future__ import annotations

import time

from eyelab.bench.schematic import Steps

#: The gazes (deg down) of the frames and the error rows.
GAZES = (0.0, 20.0, 30.0)
EYE = {"rx": "-3.00", "pupil_diameter_mm": 4}


def designs() -> dict:
    """name -> the ``[lens]`` table of the single-vision lens and the two lenslet lenses."""
    from eyelab.spec.lensletkeys import DIMS_LIKE, HALT_LIKE

    return {"single_vision": {"rx": "-3.00"},
            "dims_like": {"rx": "-3.00", "lenslets": DIMS_LIKE},
            "halt_like": {"rx": "-3.00", "lenslets": HALT_LIKE}}


def _frames(repeats: int, bar, gazes=GAZES) -> dict:
    from eyelab.imaging.registry import make_renderer
    from eyelab.jobs.api import as_spec
    from eyelab.jobs.render import build_scene

    specs = {k: as_spec({"eye": EYE, "lens": lens}) for k, lens in designs().items()}
    rs = as_spec(None).render
    scene = build_scene(rs.scene)
    out = {}
    for gaze in gazes:
        view = rs.view.replace(gaze_deg=(0.0, -gaze))
        renderers = {k: make_renderer("raster", rs.quality) for k in specs}
        try:
            cold, warm, details = {}, {k: [] for k in specs}, {}
            for k, s in specs.items():
                t = time.perf_counter()
                res = renderers[k].render(scene, s.eye, s.lens, view)
                cold[k] = time.perf_counter() - t
                details[k] = res.report["details"].get("lenslets")
                bar.update(1, f"frame {gaze:g} deg down, {k}, cold: {cold[k]:.2f} s")
            for i in range(repeats):
                for k, s in specs.items():
                    t = time.perf_counter()
                    renderers[k].render(scene, s.eye, s.lens, view)
                    warm[k].append(time.perf_counter() - t)
                bar.update(1, f"frames {gaze:g} deg down, repeat {i + 1}: " + ", ".join(
                    f"{k} {w[-1]:.2f} s" for k, w in warm.items()))
        finally:
            for r in renderers.values():
                r.close()
        row = {k: {"cold_s": cold[k], "warm_s": min(warm[k]), "lenslets": details[k]}
               for k in specs}
        for k in ("dims_like", "halt_like"):
            row[k]["ratio_warm"] = row[k]["warm_s"] / row["single_vision"]["warm_s"]
            row[k]["ratio_cold"] = row[k]["cold_s"] / row["single_vision"]["cold_s"]
        out[f"{gaze:g}"] = row
    out["view"] = [rs.view.width, rs.view.height, rs.view.fov_y_deg]
    return out


def _errors(truth_spp: int, bar, gazes=GAZES) -> list:
    from eyelab.imaging.contract import View
    from eyelab.imaging.options import RasterQuality, ReferenceQuality
    from eyelab.jobs.api import as_spec
    from eyelab.reference.metrics import compare_images
    from eyelab.reference.tracer import ReferenceRenderer
    from eyelab.render.raster import RasterRenderer
    from eyelab.scene.library import page_scene

    specs = {k: as_spec({"eye": EYE, "lens": lens}) for k, lens in designs().items()}
    sv = specs.pop("single_vision")
    rows = []
    for gaze in gazes:
        view = View(width=160, height=120, fov_y_deg=5.0, gaze_deg=(0.0, -gaze))
        scene = page_scene(distance_m=0.4, below_deg=gaze)
        with RasterRenderer(RasterQuality()) as r:
            t = time.perf_counter()
            single = r.render(scene, sv.eye, sv.lens, view)
            t_single = time.perf_counter() - t
            for name, s in specs.items():
                t = time.perf_counter()
                raster = r.render(scene, s.eye, s.lens, view)
                t_raster = time.perf_counter() - t
                t = time.perf_counter()
                truth = ReferenceRenderer(ReferenceQuality(samples=truth_spp)).render(
                    scene, s.eye, s.lens, view)
                t_truth = time.perf_counter() - t
                rows.append({"gaze_down_deg": gaze, "design": name, "raster_s": t_raster,
                             "single_vision_s": t_single, "truth_s": t_truth,
                             "lenslets": raster.report["details"]["lenslets"],
                             "raster_vs_truth": compare_images(raster.srgb, truth.srgb),
                             "single_vision_vs_truth": compare_images(single.srgb,
                                                                      truth.srgb)})
                bar.update(1, f"error {gaze:g} deg down, {name}: raster {t_raster:.1f} s, "
                              f"reference at {truth_spp} spp {t_truth:.1f} s")
    return rows


#: The quick preset (``--quick``): one repeat, the gaze through the treatment zone only
#: and the reference at fewer rays a pixel (a check that everything runs and roughly
#: agrees, in under two minutes; the numbers the docs quote come from the default run).
QUICK = {"repeats": 1, "truth_spp": 64, "gazes": (20.0,)}


def run_lenslets_bench(repeats: int = 3, truth_spp: int = 512, *,
                       quick: bool = False) -> dict:
    """The benchmark's JSON (module doc): ``frames``, ``errors`` and ``summary``;
    ``quick``: :data:`QUICK`'s settings instead."""
    gazes = GAZES
    if quick:
        repeats, truth_spp, gazes = (QUICK[k] for k in ("repeats", "truth_spp", "gazes"))
    bar = Steps(len(gazes) * (3 + repeats) + 2 * len(gazes), "lenslets bench")
    try:
        frames = _frames(repeats, bar, gazes)
        errors = _errors(truth_spp, bar, gazes)
    finally:
        bar.close()
    w, h, fov = frames["view"]
    summary = []
    for name in ("dims_like", "halt_like"):
        warm = [frames[f"{g:g}"][name]["ratio_warm"] for g in gazes]
        cold = [frames[f"{g:g}"][name]["ratio_cold"] for g in gazes]
        rows = [r for r in errors if r["design"] == name]
        ssim = [r["raster_vs_truth"]["ssim"] for r in rows]
        ssim_sv = [r["single_vision_vs_truth"]["ssim"] for r in rows]
        psnr = [r["raster_vs_truth"]["psnr_db"] for r in rows]
        psnr_sv = [r["single_vision_vs_truth"]["psnr_db"] for r in rows]
        summary += [
            f"{name} frame {w}x{h} ({fov:g} deg), gazes {'/'.join(f'{g:g}' for g in gazes)} "
            f"deg down: "
            f"{'/'.join(f'{v:.2f}' for v in warm)}x the single-vision frame warm, "
            f"{'/'.join(f'{v:.2f}' for v in cold)}x cold",
            f"{name} page at 40 cm, 160x120 over 5 deg, vs the reference at {truth_spp} spp: "
            f"raster SSIM {min(ssim):.3f}-{max(ssim):.3f}, PSNR {min(psnr):.1f}-"
            f"{max(psnr):.1f} dB; the single-vision lens {min(ssim_sv):.3f}-"
            f"{max(ssim_sv):.3f}, {min(psnr_sv):.1f}-{max(psnr_sv):.1f} dB"]
    return {"benchmark": "lenslets", "frames": frames, "errors": errors,
            "truth_spp": truth_spp, "quick": quick, "summary": summary}
