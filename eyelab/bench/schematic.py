"""``eyelab bench schematic``: the retinal image of a schematic eye at fixation — what a
raster frame costs against the thin eye's at the same view, and how close the raster comes
to the reference renderer's rays from the curved retina on the quality bench's quick
scenes.

Frames: the built-in spec's view and lens (its spherical equivalent for both eyes, the
schematic eye cannot take a cylinder), the thin eye and the Navarro eye of that Rx, one
raster renderer each, warm (the best of ``repeats`` after a first frame), measured in
alternation so that the machine's load falls on both alike. Error: raster (default
quality) against the reference at ``reference_spp`` and against a converged reference at
``truth_spp``, SSIM / PSNR / blur-size error (:func:`eyelab.reference.metrics.
compare_images`), 160 x 120. Dots: :mod:`eyelab.bench.dots` at ``dots_spp``.
"""

from __future__ import annotations

import sys
import time

from eyelab.core import progress


class Steps:
    """A benchmark's progress, one step at a time: the bar of :mod:`eyelab.core.progress`
    on a terminal and, where stderr is not one (a log, a pipe, CI), a line per step on
    stderr, ``"DESC: N/TOTAL (T s) WHAT"``, flushed as it happens, so a long run is seen
    to advance (``WHAT``: the step's own words, else :attr:`phase`). ``--quiet`` silences
    both."""

    def __init__(self, total: int, desc: str, unit: str = "step"):
        self.total, self.desc, self.n, self.phase = total, desc, 0, ""
        self.t0 = time.perf_counter()
        self.bar = progress.bar(total, desc, unit)
        self.lines = lines_wanted()

    def update(self, n: int = 1, what: str = "") -> None:
        self.bar.update(n)
        self.n += n
        if self.lines:
            line = f"{self.desc}: {self.n}/{self.total} ({time.perf_counter() - self.t0:.0f} s)"
            print(f"{line} {what or self.phase}".rstrip(), file=sys.stderr, flush=True)

    def close(self) -> None:
        self.bar.close()


def lines_wanted() -> bool:
    """Step lines are written where stderr is not a terminal and progress was not turned
    off (``eyelab --quiet`` turns it off for the whole process)."""
    if getattr(progress, "_enabled", None) is False:      # set_enabled(False): --quiet
        return False
    try:
        return not sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


def _frames(repeats: int, bar) -> dict:
    from eyelab.imaging.registry import make_renderer
    from eyelab.jobs.api import as_spec
    from eyelab.jobs.render import build_scene
    from eyelab.optics.eye.prescription import Prescription
    from eyelab.optics.eye.schematic import SchematicEye
    from eyelab.optics.eye.thin import Eye
    from eyelab.optics.lens.spectacle import SpectacleLens

    spec = as_spec(None)
    rs = spec.render
    rx = Prescription(spec.lens.rx.sphere + spec.lens.rx.cylinder / 2)
    lens = SpectacleLens.from_rx(rx, pose=spec.lens.pose)
    eyes = {"thin": Eye.from_rx(rx, accommodation_max=spec.eye.accommodation_max,
                                pupil_diameter=spec.eye.pupil_diameter),
            "schematic": SchematicEye.from_rx(rx, pupil_diameter=spec.eye.pupil_diameter,
                                              accommodation_max=min(
                                                  10.0, spec.eye.accommodation_max))}
    scene = build_scene(rs.scene)
    out = {}
    renderers = {k: make_renderer(rs.renderer, rs.quality) for k in eyes}
    try:
        cold = {}
        for k, eye in eyes.items():
            t = time.perf_counter()
            renderers[k].render(scene, eye, lens, rs.view)
            cold[k] = time.perf_counter() - t
            bar.update(1, f"frame, {k} eye, cold: {cold[k]:.2f} s")
        warm = {k: [] for k in eyes}
        for i in range(repeats):
            for k, eye in eyes.items():
                t = time.perf_counter()
                renderers[k].render(scene, eye, lens, rs.view)
                warm[k].append(time.perf_counter() - t)
            bar.update(1, f"frames, repeat {i + 1}: thin eye {warm['thin'][-1]:.2f} s, "
                          f"schematic eye {warm['schematic'][-1]:.2f} s")
    finally:
        for r in renderers.values():
            r.close()
    for k in eyes:
        out[k] = {"cold_s": cold[k], "warm_s": min(warm[k])}
    out["ratio_warm"] = out["schematic"]["warm_s"] / out["thin"]["warm_s"]
    out["ratio_cold"] = out["schematic"]["cold_s"] / out["thin"]["cold_s"]
    out["view"] = [rs.view.width, rs.view.height]
    out["rx"] = rx.format()
    return out


def _errors(reference_spp: int, truth_spp: int, bar, only=None) -> list:
    from eyelab.bench.quality import scenes
    from eyelab.imaging.contract import View
    from eyelab.imaging.options import RasterQuality, ReferenceQuality
    from eyelab.optics.eye.prescription import Prescription
    from eyelab.optics.eye.schematic import SchematicEye
    from eyelab.optics.lens.spectacle import SpectacleLens
    from eyelab.reference.metrics import compare_images
    from eyelab.reference.tracer import ReferenceRenderer
    from eyelab.render.raster import RasterRenderer

    myope = SchematicEye.from_rx("-3.00", accommodation_max=1.0)
    configs = {"myope_uncorrected": None,
               "myope_corrected_-3D": SpectacleLens.from_rx(Prescription(-3.0))}
    rows = []
    for sname, (scene, fov, near, far) in scenes().items():
        if only is not None and sname not in only:
            continue
        view = View(width=160, height=120, fov_y_deg=fov, near=near, far=far)
        for cname, lens in configs.items():
            t = time.perf_counter()
            with RasterRenderer(RasterQuality()) as r:
                raster = r.render(scene, myope, lens, view)
            t_raster = time.perf_counter() - t
            refs = {}
            for spp in (reference_spp, truth_spp):
                t = time.perf_counter()
                with ReferenceRenderer(ReferenceQuality(samples=spp)) as r:
                    refs[spp] = (r.render(scene, myope, lens, view), time.perf_counter() - t)
            rows.append({
                "scene": sname, "config": cname, "raster_s": t_raster,
                "reference_s": refs[reference_spp][1], "truth_s": refs[truth_spp][1],
                "raster_vs_reference": compare_images(raster.srgb,
                                                      refs[reference_spp][0].srgb),
                "raster_vs_truth": compare_images(raster.srgb, refs[truth_spp][0].srgb),
                "reference_vs_truth": compare_images(refs[reference_spp][0].srgb,
                                                     refs[truth_spp][0].srgb)})
            bar.update(1, f"error, {sname}, {cname}: raster {t_raster:.1f} s, reference "
                          f"{refs[reference_spp][1]:.1f} s, {truth_spp} spp "
                          f"{refs[truth_spp][1]:.1f} s")
    return rows


#: The quick preset (``--quick``): one repeat, the reference's ladder and the dots at
#: fewer rays per pixel, the errors on the chart at 6 m only and the dots of the myope
#: behind the lens only (a check that everything runs and roughly agrees, in under two
#: minutes on two cores; the acceptance numbers come from the default run).
QUICK = {"repeats": 1, "reference_spp": 16, "truth_spp": 64, "dots_spp": 32,
         "scenes": ("chart_6m",), "dots": ("myope_lens",)}


def run_schematic_bench(repeats: int = 3, reference_spp: int = 64,
                        truth_spp: int = 256, dots_spp: int | None = None, *,
                        quick: bool = False) -> dict:
    """The benchmark's JSON (module doc): ``frames``, ``errors``, ``dots``
    (:mod:`eyelab.bench.dots`: raster and reference against each other and forward rays
    on small dots across the field, the reference at ``dots_spp`` rays per pixel, None:
    :data:`eyelab.bench.dots.REFERENCE_SPP`) and ``summary``; ``quick``: :data:`QUICK`'s
    settings instead."""
    from eyelab.bench.dots import REFERENCE_SPP, configs, dots_summary, run_dots, steps
    from eyelab.bench.quality import scenes

    only_scenes, only_dots = list(scenes()), list(configs())
    dots_spp = REFERENCE_SPP if dots_spp is None else dots_spp
    if quick:
        repeats, reference_spp, truth_spp, dots_spp, only_scenes, only_dots = (
            QUICK[k] for k in ("repeats", "reference_spp", "truth_spp", "dots_spp",
                               "scenes", "dots"))
    bar = Steps(2 + repeats + 2 * len(only_scenes) + len(only_dots) * steps(),
                "schematic bench")
    try:
        frames = _frames(repeats, bar)
        errors = _errors(reference_spp, truth_spp, bar, only_scenes)
        bar.phase = f"dots: a dot across the field, raster and reference at {dots_spp} spp"
        dots = run_dots(dots_spp, bar, names=only_dots)
    finally:
        bar.close()
    ssim = [r["raster_vs_reference"]["ssim"] for r in errors]
    ssim_truth = [r["raster_vs_truth"]["ssim"] for r in errors]
    summary = [
        f"default frame {frames['view'][0]}x{frames['view'][1]}, {frames['rx']}: schematic "
        f"eye {frames['schematic']['warm_s']:.2f} s warm, thin eye "
        f"{frames['thin']['warm_s']:.2f} s: {frames['ratio_warm']:.2f}x "
        f"(cold {frames['ratio_cold']:.2f}x)",
        f"raster vs reference ({reference_spp} spp), "
        f"{'quick scenes' if not quick else ', '.join(only_scenes)}: SSIM "
        f"{min(ssim):.3f}-{max(ssim):.3f}; vs a {truth_spp} spp reference "
        f"{min(ssim_truth):.3f}-{max(ssim_truth):.3f}",
    ]
    summary += dots_summary(dots)
    return {"benchmark": "schematic", "frames": frames, "errors": errors, "dots": dots,
            "reference_spp": reference_spp, "truth_spp": truth_spp, "dots_spp": dots_spp,
            "quick": quick, "summary": summary}
