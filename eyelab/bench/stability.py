"""``eyelab bench stability``: throw random configurations at the engine, the blur field and
the reference renderer; count NaN/inf, crashes and wrong statuses (all must be zero) and
report the slowest and worst-conditioned cases.

Engine configurations are (lens, eye, object point) triples: random prescriptions
(sphere +-20 D, cylinder 0-8 D, any axis) made in random materials (CR-39 to 1.74, plus
steep high-index 'TIR-provoking' explicit lenses), random poses, eyes with pupils 1-9 mm,
points from 5 cm to 1 km and fields to 40 deg, plus points exactly at each eye meridian's
far point. A status is 'wrong' when a row reported OK fails an independent check: its chief
ray, traced forward through the lens from just before its entry point, must reach the pupil
centre within 1 nm; the object must lie on its incoming line within the solver's 1e-8 rad;
a point at a meridian's far point must give a zero semi-axis.
"""

from __future__ import annotations

import math
import time
import traceback

import numpy as np

from eyelab.errors import SpecError
from eyelab.optics.analysis import analyze_points
from eyelab.optics.eye import Eye
from eyelab.optics.lens import LensPose, SpectacleLens
from eyelab.optics.materials import CATALOGUE, Material
from eyelab.optics.paths import ObjectPoints
from eyelab.optics.prescription import Prescription
from eyelab.optics.surfaces import Sphere, Toric
from eyelab.optics.trace import FATAL

MATERIALS = [m for k, m in CATALOGUE.items() if k != "air"]


def _random_lens(rng):
    if rng.uniform() < 0.15:   # steep, high-index explicit lens: TIR and misses expected
        n = rng.uniform(1.6, 1.95)
        return SpectacleLens(Sphere(rng.uniform(-30, 45)),
                             Toric(rng.uniform(-30, 70), rng.uniform(-30, 70),
                                   rng.uniform(0, math.pi)),
                             rng.uniform(0.0005, 0.012), Material("hi", n, 30.0),
                             diameter=0.04)
    rx = Prescription(rng.uniform(-20, 20), -rng.uniform(0, 8), rng.uniform(1, 180))
    pose = LensPose(rng.uniform(0.008, 0.02), rng.uniform(-15, 15), rng.uniform(-10, 10),
                    tuple(rng.uniform(-0.005, 0.005, 2)))
    return SpectacleLens.from_rx(rx, material=MATERIALS[rng.integers(len(MATERIALS))],
                                 pose=pose)


def _random_eye(rng):
    return Eye(power_min=rng.uniform(52, 66), astigmatism=rng.uniform(0, 6),
               astigmatism_axis_deg=rng.uniform(0, 180), accommodation_max=rng.uniform(0, 12),
               pupil_diameter=rng.uniform(1e-3, 9e-3))


def _check_engine(eye, lens, objects, fixation):
    """Run one batch; return (n, nan_count, wrong_count, stats)."""
    t = time.perf_counter()
    res = analyze_points(eye, lens, objects, fixation=fixation)
    dt = time.perf_counter() - t
    arrays = [res.retina_matrix, res.accommodation, res.a, res.b, res.omega,
              res.wave_eye.k11, res.wave_eye.k12, res.wave_eye.k22]
    nan = int(sum((~np.isfinite(a)).reshape(len(objects), -1).any(1).sum() for a in arrays))
    ok = (res.status & np.uint8(FATAL)) == 0
    wrong = 0
    if lens is not None and ok.any():
        # (1) the path is a light path: traced forward from just before its entry point it
        # reaches the pupil centre; (2) the object lies on its incoming line, within the
        # solver's angular tolerance (1e-8 rad) times the distance
        din = res.chief.dir_in[ok]
        fwd = lens.trace(res.chief.entry[ok] - 0.01 * din, din)
        o, d = fwd["out_points"], fwd["out_dirs"]
        miss = np.linalg.norm(np.cross(res.pupil[ok] - o, d), axis=1)
        pos = objects.positions()[ok]
        fin = objects.finite[ok]
        rel = pos - res.chief.entry[ok]
        off = np.linalg.norm(np.cross(rel, din), axis=1)
        dist = np.linalg.norm(rel, axis=1)
        bad_obj = fin & (off > 1e-9 + 2e-8 * dist)
        bad_inf = ~fin & (np.linalg.norm(np.cross(-objects.direction[ok], din), axis=1) > 2e-8)
        wrong += int(((miss > 1e-9) | ((fwd["status"] & np.uint8(FATAL)) != 0) | bad_obj
                      | bad_inf).sum())
    curv = np.abs(np.concatenate([res.wave_eye.k11[ok], res.wave_eye.k22[ok]])) \
        if ok.any() else np.zeros(1)
    return len(objects), nan, wrong, {"time_s": dt, "max_iterations": int(
        res.chief.iterations.max(initial=0)), "max_residual": float(
        res.chief.residual[ok].max(initial=0.0)), "max_curvature": float(curv.max()),
        "ok": int(ok.sum())}


def run_stability_bench(cases: int = 100_000, seed: int = 0, points_per_config: int = 100,
                        field_configs: int = 100, reference_configs: int = 20) -> dict:
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    total = nan = wrong = crashes = ok_rows = 0
    slowest = (0.0, None)
    worst_iter = (0, None)
    worst_curv = (0.0, None)
    refused = 0
    crash_examples = []
    n_configs = int(math.ceil(cases / points_per_config))
    for c in range(n_configs):
        try:
            lens = None if rng.uniform() < 0.1 else _random_lens(rng)
        except SpecError:
            refused += 1        # an impossible lens is refused with a clear error: counted
            lens = None
        eye = _random_eye(rng)
        dist = 10 ** rng.uniform(math.log10(0.05), 3, points_per_config)
        dist[::9] = np.inf
        obj = ObjectPoints.from_angles(dist, rng.uniform(-40, 40, points_per_config),
                                       rng.uniform(-40, 40, points_per_config))
        fixation = "rotating" if c % 2 else "fixed"
        try:
            n, bad, wr, st = _check_engine(eye, lens, obj, fixation)
        except Exception:  # a crash is what this benchmark counts
            crashes += 1
            crash_examples.append(traceback.format_exc(limit=3))
            continue
        total += n
        nan += bad
        wrong += wr
        ok_rows += st["ok"]
        desc = {"config": c, "lens": None if lens is None else repr(lens)[:200],
                "eye": repr(eye)}
        if st["time_s"] > slowest[0]:
            slowest = (st["time_s"], desc)
        if st["max_iterations"] > worst_iter[0]:
            worst_iter = (st["max_iterations"], desc)
        if st["max_curvature"] > worst_curv[0]:
            worst_curv = (st["max_curvature"], desc)
    # points exactly at a meridian's far point (naked eye): that semi-axis must vanish
    focal_wrong = 0
    for _ in range(200):
        eye = Eye(power_min=rng.uniform(58.7, 66), astigmatism=rng.uniform(0, 4),
                  astigmatism_axis_deg=rng.uniform(0, 180), accommodation_max=0.0,
                  pupil_diameter=rng.uniform(1e-3, 9e-3))
        k1, k2 = eye.refraction()
        res = analyze_points(eye, None, ObjectPoints.from_angles([-1 / k1, -1 / k2], 0.0, 0.0))
        total += 2
        if not (abs(res.a[0]) < 1e-12 or abs(res.b[0]) < 1e-12):
            focal_wrong += 1
        if not (abs(res.a[1]) < 1e-12 or abs(res.b[1]) < 1e-12):
            focal_wrong += 1
    wrong += focal_wrong
    # blur fields
    from eyelab.blur import compute_blur_field

    field_nan = field_crash = voxels = 0
    for _ in range(field_configs):
        eye = _random_eye(rng)
        try:
            lens = _random_lens(rng) if rng.uniform() < 0.7 else None
            f = compute_blur_field(eye, lens, shape=(8, 4, 4))
        except SpecError:
            refused += 1
            continue
        except Exception:
            field_crash += 1
            crash_examples.append(traceback.format_exc(limit=3))
            continue
        voxels += f.matrix.shape[0] * f.matrix.shape[1] * f.matrix.shape[2]
        field_nan += int((~np.isfinite(f.matrix)).any(axis=(-1, -2)).sum())
    # reference renderer
    from eyelab.imaging import View
    from eyelab.options import ReferenceQuality
    from eyelab.reference.tracer import ReferenceRenderer
    from eyelab.scene.library import room_scene

    scene = room_scene()
    ref_nan = ref_crash = pixels = 0
    for _ in range(reference_configs):
        eye = _random_eye(rng)
        try:
            lens = _random_lens(rng) if rng.uniform() < 0.7 else None
            img = ReferenceRenderer(ReferenceQuality(samples=4, workers=1)).render(
                scene, eye, lens, View(width=16, height=12)).linear
        except SpecError:
            refused += 1
            continue
        except Exception:
            ref_crash += 1
            crash_examples.append(traceback.format_exc(limit=3))
            continue
        pixels += img.shape[0] * img.shape[1]
        ref_nan += int((~np.isfinite(img)).any(axis=2).sum())
    out = {
        "benchmark": "stability", "seed": seed,
        "engine_configurations": total, "engine_ok_rows": ok_rows,
        "engine_nan_or_inf": nan, "engine_crashes": crashes, "wrong_statuses": wrong,
        "focal_point_failures": focal_wrong,
        "lenses_refused_with_clear_error": refused,
        "blur_field_voxels": voxels, "blur_field_nan": field_nan,
        "blur_field_crashes": field_crash,
        "reference_pixels": pixels, "reference_nan": ref_nan, "reference_crashes": ref_crash,
        "slowest_batch": {"time_s": slowest[0], "case": slowest[1]},
        "most_path_iterations": {"iterations": worst_iter[0], "case": worst_iter[1]},
        "largest_curvature_1_per_m": {"value": worst_curv[0], "case": worst_curv[1]},
        "crash_examples": crash_examples[:5],
        "time_s": time.perf_counter() - t0,
    }
    out["all_clear"] = (nan == crashes == wrong == field_nan == field_crash == ref_nan
                        == ref_crash == 0)
    out["summary"] = [
        f"engine: {total} configurations ({ok_rows} with a light path), {nan} NaN/inf, "
        f"{crashes} crashes, {wrong} wrong statuses; {refused} impossible lenses refused "
        f"with a clear error",
        f"blur field: {voxels} voxels, {field_nan} NaN/inf, {field_crash} crashes; reference: "
        f"{pixels} pixels, {ref_nan} NaN/inf, {ref_crash} crashes",
        f"slowest batch {slowest[0] * 1e3:.1f} ms; most path iterations {worst_iter[0]}; "
        f"largest wave curvature {worst_curv[0]:.3g} 1/m; {out['time_s']:.1f} s in all",
        "ALL CLEAR" if out["all_clear"] else "FAILURES FOUND",
    ]
    return out
