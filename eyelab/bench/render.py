"""``eyelab bench render``: frame times of the raster renderer, per stage, and what each
skip saves; the default-quality frame (the built-in spec at 1024 x 768, naked and through
its lens), old against new with ``against`` (:mod:`eyelab.bench.frames`); and, from a
quality benchmark's JSON, its equal-error speed-ups over the reference renderer.

Scenes of ~10k and ~100k triangles (boxes spread from 0.3 to 6 m, one mesh) at the given
size, S = 1, 10, 32, through a lens and without. Steady-state frames (caches warm) are
timed; 'gl_render_s' is the time inside VTK's Render() (rasterisation, llvmpipe on this
CPU), 'overhead' everything else in the frame (seed updates, read-back, accumulation,
lens texture-coordinate set-up, compositing).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from eyelab.core.progress import bar as progress_bar
from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import SpectacleLens
from eyelab.render.raster import RasterRenderer
from eyelab.scene.scene import Scene, SceneMesh


def boxes_scene(n_triangles: int, seed: int = 0) -> Scene:
    """~n_triangles in boxes (12 triangles each) from 0.3 to 6 m, in one mesh."""
    import trimesh

    rng = np.random.default_rng(seed)
    n = max(1, n_triangles // 12)
    b = trimesh.creation.box(extents=(1, 1, 1))
    dist = 1.0 / rng.uniform(1 / 6.0, 1 / 0.3, n)
    ang = rng.uniform(-0.45, 0.45, (n, 2))
    centres = np.column_stack([np.tan(ang[:, 0]) * dist, np.tan(ang[:, 1]) * dist * 0.75,
                               -dist])
    size = (0.02 * dist)[:, None, None]
    verts = (b.vertices[None] * size + centres[:, None]).reshape(-1, 3)
    faces = (b.faces[None] + 8 * np.arange(n)[:, None, None]).reshape(-1, 3)
    cols = np.repeat(rng.integers(30, 230, (n, 3)), 8, axis=0).astype(np.uint8)
    return Scene([SceneMesh(f"boxes{n_triangles}", verts, faces, colors=cols)],
                 background=(250, 250, 250), name=f"boxes_{n_triangles}")


def _frame(r, scene, eye, lens, view, repeats):
    r.render(scene, eye, lens, view)                # warm caches and shaders
    best = None
    for _ in range(repeats):
        t = time.perf_counter()
        res = r.render(scene, eye, lens, view)
        dt = time.perf_counter() - t
        if best is None or dt < best[0]:
            best = (dt, res.report)
    return best


def equal_error_table(quality: dict) -> dict:
    """From a quality benchmark's result: per case the default-quality raster row's SSIM,
    time and equal-error speed-up over the reference (recomputed from the rows), their
    median and minimum."""
    from eyelab.bench.quality import _default_row
    from eyelab.bench.qualitymerge import merge_results
    from eyelab.core.errors import SpecError

    if not isinstance(quality, dict) or quality.get("benchmark") != "quality" or not \
            quality.get("cases"):
        raise SpecError("--quality", "not a quality benchmark's JSON with cases")
    try:
        q = merge_results([quality])
        rows = [{"scene": c["scene"], "config": c["config"], **{k: _default_row(c)[k] for k in (
            "samples", "ssim", "time_s", "speedup_at_equal_error")}} for c in q["cases"]]
    except (KeyError, IndexError, TypeError, ValueError, StopIteration,
            ZeroDivisionError) as e:
        raise SpecError("--quality", f"a quality result without the rows it needs (raster "
                        f"rows at the default S and 32, reference rows with rmse and "
                        f"time_s): {type(e).__name__} {e}") from None
    sp = [r["speedup_at_equal_error"] for r in rows]
    return {"preset": q["preset"], "size": q["size"], "rows": rows,
            "median": float(np.median(sp)), "min": float(np.min(sp))}


def run_render_bench(width=1024, height=768, triangles=(10_000, 100_000), samples=(1, 10, 32),
                     repeats=2, *, against: str | None = None, quality: dict | None = None,
                     frames_only: bool = False) -> dict:
    rx = Prescription(-3.0, -1.0, 180)
    eye = Eye.from_rx(rx, accommodation_max=1.0)
    lens = SpectacleLens.from_rx(rx)
    rows = []
    table = None if quality is None else equal_error_table(quality)   # refused before the run
    rounds = 2
    if frames_only:          # the default frames alone, three rounds of processes
        rounds, triangles, samples = 3, (), ()
    bar = progress_bar(len(triangles) * len(samples) + rounds * (2 if against else 1)
                       + (0 if frames_only else 2), "render bench", "row")
    from eyelab.bench.frames import default_frames

    default = default_frames(against, size=(width, height), repeats=repeats, rounds=rounds,
                             progress=bar)
    if frames_only:
        bar.close()
        return {"benchmark": "render", "size": [width, height], "default_frame": default,
                "summary": _default_lines(default)}
    for n in triangles:
        scene = boxes_scene(n)
        for s in samples:
            view = View(width=width, height=height, near=0.1, far=20.0)
            with RasterRenderer(RasterQuality(samples=s, refine=False)) as r:
                for label, ln in (("naked", None), ("through_lens", lens)):
                    dt, rep = _frame(r, scene, eye, ln, view, repeats)
                    t = rep["timings_s"]
                    gl = t["gl_render"]
                    rows.append({"triangles": scene.n_triangles, "samples": s, "view": label,
                                 "frame_s": dt, "fps": 1.0 / dt, "gl_render_s": gl,
                                 "overhead_s": dt - gl, "overhead_fraction": (dt - gl) / gl,
                                 "passes": rep["samples"]["done"], "stages_s": t})
                bar.update(1)
    # what the skips save (10k triangles, S = 10)
    scene = boxes_scene(triangles[0])
    skips = {}
    sharp = Eye(accommodation_max=10.0)
    sharp_view = View(width=width, height=height, near=0.25, far=20.0)
    for skip in (True, False):
        bar.update(1)
        with RasterRenderer(RasterQuality(samples=10, refine=False, skip_unneeded=skip)) as r:
            skips[f"all_zero_field_skip_{skip}"] = _frame(r, scene, sharp, None, sharp_view,
                                                          repeats)[0]
    bar.close()
    view = View(width=width, height=height, near=0.1, far=20.0)
    with RasterRenderer(RasterQuality(samples=10, refine=False)) as r:
        skips["lens_in_view"] = _frame(r, scene, eye, lens, view, repeats)[0]
        skips["no_lens"] = _frame(r, scene, eye, None, view, repeats)[0]
        flat = SpectacleLens.from_rx(rx, material={"n_d": 1.498})
        skips["lens_dispersive"] = skips["lens_in_view"]
        skips["lens_no_dispersion"] = _frame(r, scene, eye, flat, view, repeats)[0]
        skips["lens_dispersive_eye_achromatic"] = _frame(
            r, scene, dataclasses.replace(eye, chromatic=False), lens, view, repeats)[0]
    with RasterRenderer(RasterQuality(samples=10, refine=False, chromatic=False)) as r:
        skips["one_wavelength"] = _frame(r, scene, eye, lens, view, repeats)[0]
        skips["one_wavelength_no_lens"] = _frame(r, scene, eye, None, view, repeats)[0]
        t = time.perf_counter()
        r.render(scene, Eye.from_rx(rx, accommodation_max=0.9), lens, view)   # new eye
        skips["cold_frame_new_eye"] = time.perf_counter() - t
        skips["warm_frame"] = skips["lens_in_view"]
    speedups = {
        "one_pass_for_zero_field": skips["all_zero_field_skip_False"]
        / skips["all_zero_field_skip_True"],
        "no_lens_passes": skips["lens_in_view"] / skips["no_lens"],
        "one_texcoord_set": skips["lens_dispersive"] / skips["lens_no_dispersion"],
        "one_wavelength": skips["lens_in_view"] / skips["one_wavelength"],
        "one_wavelength_no_lens": skips["no_lens"] / skips["one_wavelength_no_lens"],
        "caches_reused": skips["cold_frame_new_eye"] / skips["warm_frame"]}
    from eyelab.bench.psf import aberration_frames

    aberr = aberration_frames(width, height, repeats)
    out = {"benchmark": "render", "size": [width, height], "default_frame": default,
           "rows": rows, "skip_times_s": skips, "skip_speedups": speedups,
           "eye_aberrations": aberr}
    lines = _default_lines(default)
    lines.append(f"eye with higher-order aberrations ({aberr['aberrations']}), default spec "
                 f"{width}x{height}, warm: naked {aberr['with']['naked'] * 1e3:.0f} ms (without "
                 f"{aberr['without']['naked'] * 1e3:.0f} ms), through the lens "
                 f"{aberr['with']['through_lens'] * 1e3:.0f} ms (without "
                 f"{aberr['without']['through_lens'] * 1e3:.0f} ms)")
    if table is not None:
        out["equal_error"] = table
        lines.append(f"equal-error speed-up over the reference ({table['preset']} quality "
                     f"bench, {table['size'][0]}x{table['size'][1]}, default quality, warm "
                     f"frames): median x{_times(table['median'])}, min "
                     f"x{_times(table['min'])}")
    for r_ in rows:
        lines.append(f"{r_['triangles']:>7} tris S={r_['samples']:<3} {r_['view']:>12}: "
                     f"{r_['frame_s'] * 1e3:7.1f} ms ({r_['fps']:.1f} fps), GL "
                     f"{r_['gl_render_s'] * 1e3:7.1f} ms, overhead "
                     f"{r_['overhead_fraction'] * 100:5.1f} %")
    lines.append("skip speed-ups: " + ", ".join(f"{k} x{v:.2f}" for k, v in speedups.items()))
    out["summary"] = lines
    return out


def _times(x: float) -> str:
    """A ratio: one decimal below 10, none above."""
    return f"{x:.1f}" if x < 10 else f"{x:.0f}"


def _default_lines(d: dict) -> list:
    """Summary lines of :func:`eyelab.bench.frames.default_frames`' result."""
    w, h = d["size"]
    lines = []
    for label in ("old", "new"):
        if label in d:
            q, b, r = d[label]["quality"], d[label], d[label]["ratios"]
            lines.append(
                f"default frames {w}x{h} ({label}: S={q.get('samples')}, filter "
                f"{q.get('reconstruct')}, env x{q.get('env_oversample')}): uncorrected "
                f"{b['uncorrected'] * 1e3:.0f} ms, through the lens "
                f"{b['corrected_through_lens'] * 1e3:.0f} ms, emmetrope "
                f"{b['emmetrope'] * 1e3:.0f} ms ({r['emmetrope_over_uncorrected']:.2f} of "
                f"the uncorrected); eyelab.render first call {b['api_first_call']:.2f} s, "
                f"second {b['api_second_call'] * 1e3:.0f} ms "
                f"({r['api_second_over_warm']:.2f} x the warm frame)")
    if "new_over_old" in d:
        lines.append(f"new / old ({d['against']['ref']} = {d['against']['commit'][:10]}): "
                     + ", ".join(f"{k} {v:.2f}" for k, v in d["new_over_old"].items()))
    return lines
