"""``eyelab bench imagebased``: the image-based lens model (Heidrich et al. 1997) per angle
threshold — projections, the largest angle error reached, planning time, steady frame
time (the plan kept, as the paper's preprocessing) and error against the distribution ray
traced reference — for the paper's two lenses (as sourced in :mod:`eyelab.optics.cameralens.system`)
and an eye behind a spectacle lens, with the paper's own figures beside them; and the
least-squares COP against the angle COP on every quad-tree cell.
"""

from __future__ import annotations

import time

import numpy as np

from eyelab.imaging.contract import View
from eyelab.imaging.options import ImageBasedQuality, ReferenceQuality

#: Heidrich et al. 1997, §4 (a 256x256 film; SGI RealityEngine2 for the hardware images).
PAPER = {
    "doublet": {"samples": 10, "projections": 1, "fps": 14.0, "threshold_deg": None,
                "note": "a single perspective projection"},
    "biconvex": {"samples": 10, "projections": 40, "fps": 3.0, "threshold_deg": 0.05,
                 "note": "quad-tree to 0.05 deg"},
    "ray_traced_reference": {"size": [256, 256], "samples": 10, "time_s": 270.0,
                             "machine": "SGI Onyx, R8000"},
}
THRESHOLDS = (0.5, 0.1, 0.05)


def _cases(quick: bool):
    from eyelab.optics.cameralens.system import get_system
    from eyelab.optics.eye.prescription import Prescription
    from eyelab.optics.eye.thin import Eye
    from eyelab.optics.lens.spectacle import SpectacleLens

    rx = Prescription(-3.0, -1.0, 180)
    return {
        "doublet": (get_system("doublet").focused(1.5), None, {}),
        "biconvex": (get_system("biconvex").focused(1.5), None, {}),
        "eye_-3.00/-1.00x180_lens": (Eye.from_rx(rx, accommodation_max=1.0),
                                     SpectacleLens.from_rx(rx), {"focus_d": 0.5}),
    }


def run_imagebased_bench(quick: bool = False, *, repeats: int = 3) -> dict:
    """Every case at every threshold of :data:`THRESHOLDS`; ``quick``: 96x96 instead of
    the paper's 256x256 and a 64-spp reference."""
    from eyelab.core.progress import bar as progress_bar
    from eyelab.reference.metrics import compare_images
    from eyelab.reference.tracer import ReferenceRenderer
    from eyelab.render.imagebased import ImageBasedRenderer
    from eyelab.scene.library import room_scene

    size = 96 if quick else 256
    spp = 64 if quick else 256
    scene = room_scene()
    rows, cop_rows, depth_rows = [], [], []
    cases = _cases(quick)
    bar = progress_bar(len(cases) * (len(THRESHOLDS) + 1), "imagebased", "run")
    for name, (observer, lens, kw) in cases.items():
        view = View(width=size, height=size, fov_y_deg=40.0, near=0.1, far=20.0, **kw)
        t = time.perf_counter()
        truth = ReferenceRenderer(ReferenceQuality(samples=spp, chromatic=False)).render(
            scene, observer, lens, view)
        t_truth = time.perf_counter() - t
        bar.update(1)
        for thr in THRESHOLDS:
            q = ImageBasedQuality(samples=10, grid=10, angle_threshold_deg=thr, max_depth=6,
                                  chromatic=False)
            with ImageBasedRenderer(q) as r:
                t = time.perf_counter()
                first = r.render(scene, observer, lens, view)
                cold = time.perf_counter() - t
                warm = np.inf
                for _ in range(repeats):
                    t = time.perf_counter()
                    res = r.render(scene, observer, lens, view)
                    warm = min(warm, time.perf_counter() - t)
            plan = first.report["details"]["plan"]
            m = compare_images(res.srgb, truth.srgb)
            rows.append({"case": name, "threshold_deg": thr,
                         "projections": plan["projections"],
                         "max_angle_deg": plan["max_angle_deg"],
                         "unresolved_cells": plan.get("unresolved_cells", 0),
                         "plan_s": first.report["timings_s"]["plan"],
                         "first_frame_s": cold, "frame_s": warm, "fps": 1.0 / warm,
                         "render_s": res.report["timings_s"]["render"],
                         "morph_s": res.report["timings_s"]["morph"],
                         "ssim": m["ssim"], "psnr_db": m["psnr_db"],
                         "reference_spp": spp, "reference_time_s": t_truth})
            bar.update(1)
        cop_rows.append(_cop_comparison(name, observer, lens, view))
        depth_rows += _cop_by_depth(name, observer, lens, view)
    bar.close()
    summary = [f"{r['case']:>26} {r['threshold_deg']:>5}°: {r['projections']:>4} projections"
               f", max angle {r['max_angle_deg']:.3f}°, plan {r['plan_s']:.2f} s, frame "
               f"{r['frame_s'] * 1e3:.0f} ms ({r['fps']:.1f} fps), SSIM {r['ssim']:.4f}"
               for r in rows]
    summary += [f"{c['case']:>26}: least-squares / angle COP, largest angle error over "
                f"{c['cells']} cells: median ratio {c['median_ratio']:.3f}, range "
                f"{c['min_ratio']:.3f}-{c['max_ratio']:.3f}" for c in cop_rows]
    summary.append("paper (RealityEngine2, 256x256): doublet 10 samples, 1 projection, "
                   "~14 fps; biconvex 10 samples, 0.05°, 40 projections, ~3 fps; ray "
                   "traced 10 spp in ~4.5 min")
    summary += [f"{r['case']:>26} level {r['depth']} ({r['cells']:>5} cells): largest angle "
                f"error / the angle COP's: least-squares float64 {r['lsq64']['min']:.3f}-"
                f"{r['lsq64']['max']:.3f}, float32 {r['lsq32']['min']:.3f}-"
                f"{r['lsq32']['max']:.2f}; angle COP in float32 {r['angle32']['min']:.3f}-"
                f"{r['angle32']['max']:.3f}" for r in depth_rows]
    return {"benchmark": "imagebased", "size": [size, size], "rows": rows,
            "cop_comparison": cop_rows, "cop_by_depth": depth_rows, "paper": PAPER,
            "summary": summary}


def _ray_maker(observer, lens, view):
    """The image-based model's rays for a camera lens system or an eye (+ lens)."""
    from eyelab.optics.cameralens.film import CameraRays
    from eyelab.optics.cameralens.system import LensSystem
    from eyelab.render.imagebased.rays import EyeRays

    if isinstance(observer, LensSystem):
        return CameraRays(observer, view.width, view.height, view.fov_y_deg, view.near)
    return EyeRays(observer, lens, view, view.focus_d)


#: The COP study's quad-tree levels (uniform: every cell of each level) and pupil/lens
#: samples (indices into the 10-sample set: centre, middle, rim).
COP_DEPTHS = (0, 1, 2, 3, 4, 5, 6)
COP_SAMPLE_INDICES = (0, 3, 9)


def _cop_by_depth(name, observer, lens, view) -> list:
    """The least-squares COP against the angle COP on every cell of each uniform quad-tree
    level, in double and in single precision.

    The paper's claim is about subdivided cells ("as soon as subdivision is performed ...
    the maximum angle ... reduced by a factor of up to 10"). Each cell: an 11x11 film grid
    through one lens sample; the angle COP by Newton from the parent cell's angle COP (the
    sample's lens centre at level 0: Heidrich §3.3), the least-squares COP by its normal
    equations, both in the precision of the row; every angle is then measured exactly
    (float64 rays, the image plane at the view's near distance). Per level: the ratio of
    the least-squares COP's largest angle error to the angle COP's (float64 and float32),
    and the float32 angle COP's to the float64 one's."""
    from eyelab.core.sampling import pass_samples
    from eyelab.core.vecmath import unit
    from eyelab.render.imagebased.cop import (
        angle_errors_deg,
        fit_cop_angle,
        fit_cop_least_squares,
        image_plane_points,
    )

    w, h = view.width, view.height
    samples = pass_samples(10)[0][list(COP_SAMPLE_INDICES)]
    maker = _ray_maker(observer, lens, view)
    g = np.linspace(0.0, 1.0, 11)
    ratios = {d: {"lsq64": [], "lsq32": [], "angle32": []} for d in COP_DEPTHS}
    for s in samples:
        starts = {(0, 0): (None, None)}             # cell -> parent's angle COPs (f64, f32)
        for depth in COP_DEPTHS:
            n = 2 ** depth
            nxt = {}
            for (cx, cy), (s64, s32) in starts.items():
                gx, gy = np.meshgrid((cx + g) * w / n, (cy + g) * h / n)
                rs = maker.rays(np.stack([gx.ravel(), gy.ravel()], -1), s, 587.56)
                if rs.ok.sum() < 20:
                    continue
                q, d = rs.origins[rs.ok], rs.dirs[rs.ok]
                if s64 is None:
                    s64 = s32 = q.mean(axis=0)          # the lens centre for this sample
                p = image_plane_points(q, d, s64, unit(d.mean(axis=0)), view.near)
                e64, _ = fit_cop_angle(p, d, s64)
                e32, _ = fit_cop_angle(p, d, s32, dtype=np.float32)
                e32 = np.asarray(e32, float)
                a64 = angle_errors_deg(p, d, e64).max()
                if a64 > 1e-9:
                    r = ratios[depth]
                    r["lsq64"].append(angle_errors_deg(
                        p, d, fit_cop_least_squares(q, d)).max() / a64)
                    r["lsq32"].append(angle_errors_deg(p, d, np.asarray(
                        fit_cop_least_squares(q, d, np.float32), float)).max() / a64)
                    r["angle32"].append(angle_errors_deg(p, d, e32).max() / a64)
                for k in range(4):
                    nxt[(2 * cx + k % 2, 2 * cy + k // 2)] = (e64, e32)
            starts = nxt
    out = []
    for depth, r in ratios.items():
        if not r["lsq64"]:
            continue
        row = {"case": name, "depth": depth, "cells": len(r["lsq64"])}
        for key, vals in r.items():
            v = np.array(vals)
            row[key] = {"median": float(np.median(v)), "min": float(v.min()),
                        "max": float(v.max())}
        out.append(row)
    return out


def _cop_comparison(name, observer, lens, view) -> dict:
    """Largest angle error of the least-squares COP over the angle COP's, on every cell of
    the 0.05° quad-tree (the same rays and image plane for both)."""
    from eyelab.core.sampling import pass_samples
    from eyelab.core.vecmath import unit
    from eyelab.render.imagebased.cop import (
        angle_errors_deg,
        fit_cop_least_squares,
        image_plane_points,
    )
    from eyelab.render.imagebased.plan import plan_projections

    maker = _ray_maker(observer, lens, view)
    samples = pass_samples(10)[0]
    plan = plan_projections(maker, samples, 587.56, threshold_deg=0.05, max_depth=6,
                            plane_distance=view.near)
    ratios = []
    for pr in plan.projections:
        rs = maker.rays(pr.grid_film.reshape(-1, 2), samples[pr.sample], 587.56)
        q, d = rs.origins[rs.ok], rs.dirs[rs.ok]
        p = image_plane_points(q, d, pr.cop, unit(d.mean(axis=0)), view.near)
        el = fit_cop_least_squares(q, d)
        a_lsq = angle_errors_deg(p, d, el).max()
        a_ang = angle_errors_deg(p, d, pr.cop).max()
        if a_ang > 1e-9:
            ratios.append(a_lsq / a_ang)
    r = np.array(ratios) if ratios else np.ones(1)
    return {"case": name, "cells": len(plan.projections), "median_ratio": float(np.median(r)),
            "min_ratio": float(r.min()), "max_ratio": float(r.max())}
