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
from dataclasses import dataclass, field

import numpy as np

from eyelab.core.errors import SpecError
from eyelab.core.progress import bar as progress_bar
from eyelab.optics.chain.analysis import analyze_points
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import LensPose, SpectacleLens
from eyelab.optics.rays.materials import CATALOGUE, Material
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.optics.rays.surfaces import Sphere, Toric
from eyelab.optics.rays.trace import FATAL

MATERIALS = [m for k, m in CATALOGUE.items() if k != "air"]
#: ``eyelab bench stability --quick``: what CI runs (tests/test_bench_quality.py).
QUICK = {"cases": 10_000, "field_configs": 40, "reference_configs": 8}


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
    return res, len(objects), nan, wrong, {"time_s": dt, "max_iterations": int(
        res.chief.iterations.max(initial=0)), "max_residual": float(
        res.chief.residual[ok].max(initial=0.0)), "max_curvature": float(curv.max()),
        "ok": int(ok.sum())}


#: Tolerances of the independent re-derivation (bundle fits of radius 10 um: their own
#: error is ~1e-5 D on ordinary lenses and grows with the third derivatives of strong,
#: tilted lenses at 40 deg; a wrong answer is off by much more -- a sign, a dioptre, 2x).
VERGENCE_TOL_D = 2e-3
VERGENCE_TOL_REL = 1e-3
BLUR_TOL_M = 2e-7
BLUR_TOL_REL = 2e-3
ACCOMMODATION_TOL_D = 2e-3


def _rederived_counts() -> dict:
    """The re-derivation's counters, zero."""
    return {"vergence_checked": 0, "vergence_wrong": 0, "blur_wrong": 0,
            "accommodation_wrong": 0, "missed_checked": 0, "missed_wrong": 0,
            "max_vergence_dev_d": 0.0, "max_blur_dev_m": 0.0, "max_accommodation_dev_d": 0.0,
            "examples": []}


def _rederive(eye, lens, objects, res, fixation, rng, n_ok=2, n_fatal=1):
    """Re-derive a random subset of ``res`` without the engine's wavefront tracer or path
    finder: for OK rows the wave at the eye from a bundle of real rays
    (:func:`~eyelab.reference.bruteforce.bundle_vergence`), Eq. 13's accommodation from that
    wave and the eye's amplitude bounds, and the retinal blur from rim rays through the thin
    eye (:func:`~eyelab.reference.bruteforce.retinal_spot_axes`); for rows without a light path,
    an exhaustive search (:func:`~eyelab.reference.bruteforce.search_path`) must find none.
    Returns counts and the worst deviations."""
    from eyelab.reference.bruteforce import extrapolated_vergence, retinal_spot_axes, search_path

    out = _rederived_counts()
    ok = (res.status & np.uint8(FATAL)) == 0
    k_eng = res.wave_eye.in_basis(res.eye_x)
    maj, mnr, _ = res.blur_axes()
    pos = objects.positions()
    for i in rng.permutation(np.flatnonzero(ok))[:n_ok]:
        finite = bool(objects.finite[i])
        start = res.chief.start[i]
        fit = extrapolated_vergence(lens, start, res.chief.dir_in[i], finite, res.pupil[i],
                                    res.wave_eye.N[i], res.eye_x[i], strict=False)
        if fit is None:                    # a bundle ray grazes the rim: no truth here
            continue
        out["vergence_checked"] += 1
        k_bf, left = fit                   # extrapolated, and an estimate of what is left
        k_en = np.array([k[i] for k in k_eng])
        dev = float(np.abs(k_bf - k_en).max())
        out["max_vergence_dev_d"] = max(out["max_vergence_dev_d"], dev)
        if dev > VERGENCE_TOL_D + VERGENCE_TOL_REL * float(np.abs(k_bf).max()) + left:
            out["vergence_wrong"] += 1
            out["examples"].append(f"row {i}: wave at the eye {k_en} D, real rays {k_bf} D")
        # Eq. 13 on the measured wave, within the eye's amplitude
        want = float(np.clip(eye.emmetropic_power - 0.5 * (k_bf[0] + k_bf[2]) - eye.power_min,
                             0.0, eye.accommodation_max))
        acc = float(res.accommodation[i])
        dev_a = abs(acc - want)
        out["max_accommodation_dev_d"] = max(out["max_accommodation_dev_d"], dev_a)
        if not (0.0 <= acc <= eye.accommodation_max) or dev_a > ACCOMMODATION_TOL_D \
                + VERGENCE_TOL_REL * float(np.abs(k_bf).max()):
            out["accommodation_wrong"] += 1
            out["examples"].append(f"row {i}: accommodation {acc:.4f} D, Eq. 13 on the real "
                                   f"wave {want:.4f} D (amplitude {eye.accommodation_max:g})")
        bmaj, bmin, _ = retinal_spot_axes(eye, k_bf, want)
        dev_b = max(abs(maj[i] - bmaj), abs(mnr[i] - bmin))
        out["max_blur_dev_m"] = max(out["max_blur_dev_m"], dev_b)
        if dev_b > BLUR_TOL_M + BLUR_TOL_REL * bmaj:
            out["blur_wrong"] += 1
            out["examples"].append(f"row {i}: blur {maj[i]:.3e} x {mnr[i]:.3e} m, rim rays "
                                   f"{bmaj:.3e} x {bmin:.3e} m")
    if lens is not None:
        target = np.array([0.0, 0.0, eye.rotation_centre]) if fixation == "rotating" \
            else np.zeros(3)
        for i in rng.permutation(np.flatnonzero(~ok))[:n_fatal]:
            out["missed_checked"] += 1
            found, r = search_path(lens, target, pos[i], bool(objects.finite[i]),
                                   objects.direction[i])
            if found:
                out["missed_wrong"] += 1
                out["examples"].append(f"row {i}: status {int(res.status[i])} but a light "
                                       f"path exists (residual {r:.1e} rad)")
    return out


@dataclass
class _Tally:
    """The stability bench's running counts: engine rows, NaN/inf, crashes, wrong statuses,
    refused lenses, blur-field voxels and reference pixels with their failures, the
    re-derivation's counters, and the worst cases as (value, description)."""

    total: int = 0
    nan: int = 0
    wrong: int = 0
    crashes: int = 0
    ok_rows: int = 0
    refused: int = 0
    focal_wrong: int = 0
    field_nan: int = 0
    field_crash: int = 0
    voxels: int = 0
    ref_nan: int = 0
    ref_crash: int = 0
    pixels: int = 0
    slowest: tuple = (0.0, None)
    worst_iter: tuple = (0, None)
    worst_curv: tuple = (0.0, None)
    crash_examples: list = field(default_factory=list)
    rederived: dict = field(default_factory=_rederived_counts)

    def crash(self):
        """Keep the exception being handled as a crash example."""
        self.crash_examples.append(traceback.format_exc(limit=3))

    def add_rederived(self, c, rd):
        """Fold one configuration's re-derivation counts (:func:`_rederive`) in."""
        for k, v in rd.items():
            if k == "examples":
                self.rederived["examples"].extend(f"config {c}: {e}" for e in v)
            elif k.startswith("max_"):
                self.rederived[k] = max(self.rederived[k], v)
            else:
                self.rederived[k] += v


#: The worst cases kept: tally attribute <- the engine batch statistic it maximises.
_WORST = (("slowest", "time_s"), ("worst_iter", "max_iterations"),
          ("worst_curv", "max_curvature"))


def run_stability_bench(cases: int = 100_000, seed: int = 0, points_per_config: int = 100,
                        field_configs: int = 100, reference_configs: int = 20) -> dict:
    """Run ``cases`` engine rows (``points_per_config`` object points per random lens and
    eye), 200 eyes at their meridians' far points, ``field_configs`` blur fields and
    ``reference_configs`` 16 x 16 reference renders, all drawn from ``seed``; the JSON
    report (counts, worst cases, ``all_clear``, ``summary`` lines)."""
    rng = np.random.default_rng(seed)
    # the rows re-derived are drawn from a stream of their own, so that configuration c is
    # the same whatever the checks drew before it (a failure can be replayed alone)
    check_rng = np.random.default_rng([seed, 1])
    t0 = time.perf_counter()
    tally = _Tally()
    n_configs = int(math.ceil(cases / points_per_config))
    bar = progress_bar(n_configs + field_configs + reference_configs, "stability", "config")
    for c in range(n_configs):
        bar.update(1)
        _engine_config(tally, c, rng, check_rng, points_per_config)
    _focal_points(tally, rng)
    _blur_fields(tally, rng, field_configs, bar)
    _reference_renders(tally, rng, reference_configs, bar)
    bar.close()
    return _stability_report(tally, seed, t0)


def _engine_config(tally, c, rng, check_rng, points_per_config):
    """Engine configuration ``c``: a random lens (none in 10 %; an impossible one refused
    with a clear error is counted and replaced by none), eye and object points (every 9th
    at infinity), run and re-derived; a crash is counted, not raised."""
    try:
        lens = None if rng.uniform() < 0.1 else _random_lens(rng)
    except SpecError:
        tally.refused += 1      # an impossible lens is refused with a clear error: counted
        lens = None
    eye = _random_eye(rng)
    dist = 10 ** rng.uniform(math.log10(0.05), 3, points_per_config)
    dist[::9] = np.inf
    obj = ObjectPoints.from_angles(dist, rng.uniform(-40, 40, points_per_config),
                                   rng.uniform(-40, 40, points_per_config))
    fixation = "rotating" if c % 2 else "fixed"
    try:
        res, n, bad, wr, st = _check_engine(eye, lens, obj, fixation)
        rd = _rederive(eye, lens, obj, res, fixation, check_rng)
    except Exception:  # a crash is what this benchmark counts
        tally.crashes += 1
        tally.crash()
        return
    tally.add_rederived(c, rd)
    tally.total += n
    tally.nan += bad
    tally.wrong += wr
    tally.ok_rows += st["ok"]
    desc = {"config": c, "lens": None if lens is None else repr(lens)[:200],
            "eye": repr(eye)}
    for attr, key in _WORST:
        if st[key] > getattr(tally, attr)[0]:
            setattr(tally, attr, (st[key], desc))


def _focal_points(tally, rng):
    """200 naked eyes with a point exactly at each meridian's far point: that semi-axis
    must vanish (|.| < 1e-12 m), else a wrong status."""
    for _ in range(200):
        eye = Eye(power_min=rng.uniform(58.7, 66), astigmatism=rng.uniform(0, 4),
                  astigmatism_axis_deg=rng.uniform(0, 180), accommodation_max=0.0,
                  pupil_diameter=rng.uniform(1e-3, 9e-3))
        k1, k2 = eye.refraction()
        res = analyze_points(eye, None, ObjectPoints.from_angles([-1 / k1, -1 / k2], 0.0, 0.0))
        tally.total += 2
        for j in (0, 1):
            if not (abs(res.a[j]) < 1e-12 or abs(res.b[j]) < 1e-12):
                tally.focal_wrong += 1
    tally.wrong += tally.focal_wrong


def _eye_and_lens(tally, rng):
    """(eye, lens) of a random configuration (a lens in 70 %), or None when the lens was
    refused (counted)."""
    eye = _random_eye(rng)
    try:
        lens = _random_lens(rng) if rng.uniform() < 0.7 else None
    except SpecError:
        tally.refused += 1
        return None
    return eye, lens


def _blur_fields(tally, rng, field_configs, bar):
    """``field_configs`` random 8 x 4 x 4 blur fields: voxels, NaN/inf and crashes (only
    the lens may be refused; anything the field raises is a crash)."""
    from eyelab.blur import compute_blur_field

    for _ in range(field_configs):
        bar.update(1)
        drawn = _eye_and_lens(tally, rng)
        if drawn is None:
            continue
        eye, lens = drawn
        try:
            f = compute_blur_field(eye, lens, shape=(8, 4, 4))
        except Exception:
            tally.field_crash += 1
            tally.crash()
            continue
        tally.voxels += f.matrix.shape[0] * f.matrix.shape[1] * f.matrix.shape[2]
        tally.field_nan += int((~np.isfinite(f.matrix)).any(axis=(-1, -2)).sum())


def _reference_renders(tally, rng, reference_configs, bar):
    """``reference_configs`` random 16 x 16 renders of the room by the reference renderer
    (4 spp, one worker): pixels, NaN/inf and crashes."""
    from eyelab.imaging.contract import View
    from eyelab.imaging.options import ReferenceQuality
    from eyelab.reference.tracer import ReferenceRenderer
    from eyelab.scene.library import room_scene

    scene = room_scene()
    for _ in range(reference_configs):
        bar.update(1)
        drawn = _eye_and_lens(tally, rng)
        if drawn is None:
            continue
        eye, lens = drawn
        try:
            img = ReferenceRenderer(ReferenceQuality(samples=4, workers=1)).render(
                scene, eye, lens, View(width=16, height=16)).linear
        except Exception:
            tally.ref_crash += 1
            tally.crash()
            continue
        tally.pixels += img.shape[0] * img.shape[1]
        tally.ref_nan += int((~np.isfinite(img)).any(axis=2).sum())


def _stability_report(tally, seed, t0) -> dict:
    """The benchmark's JSON from its ``tally`` (``t0``: its start, perf_counter s)."""
    rederived = tally.rederived
    slowest, worst_iter, worst_curv = tally.slowest, tally.worst_iter, tally.worst_curv
    out = {
        "benchmark": "stability", "seed": seed,
        "engine_configurations": tally.total, "engine_ok_rows": tally.ok_rows,
        "engine_nan_or_inf": tally.nan, "engine_crashes": tally.crashes,
        "wrong_statuses": tally.wrong,
        "focal_point_failures": tally.focal_wrong,
        "lenses_refused_with_clear_error": tally.refused,
        "blur_field_voxels": tally.voxels, "blur_field_nan": tally.field_nan,
        "blur_field_crashes": tally.field_crash,
        "reference_pixels": tally.pixels, "reference_nan": tally.ref_nan,
        "reference_crashes": tally.ref_crash,
        "slowest_batch": {"time_s": slowest[0], "case": slowest[1]},
        "most_path_iterations": {"iterations": worst_iter[0], "case": worst_iter[1]},
        "largest_curvature_1_per_m": {"value": worst_curv[0], "case": worst_curv[1]},
        "crash_examples": tally.crash_examples[:5],
        "rederived": dict(rederived, examples=rederived["examples"][:10]),
        "time_s": time.perf_counter() - t0,
    }
    rd_wrong = sum(rederived[k] for k in ("vergence_wrong", "blur_wrong",
                                          "accommodation_wrong", "missed_wrong"))
    out["all_clear"] = (tally.nan == tally.crashes == tally.wrong == tally.field_nan
                        == tally.field_crash == tally.ref_nan == tally.ref_crash == rd_wrong
                        == 0)
    out["summary"] = [
        f"engine: {tally.total} configurations ({tally.ok_rows} with a light path), "
        f"{tally.nan} NaN/inf, {tally.crashes} crashes, {tally.wrong} wrong statuses; "
        f"{tally.refused} impossible lenses refused with a clear error",
        f"blur field: {tally.voxels} voxels, {tally.field_nan} NaN/inf, {tally.field_crash} "
        f"crashes; reference: {tally.pixels} pixels, {tally.ref_nan} NaN/inf, "
        f"{tally.ref_crash} crashes",
        f"re-derived independently: {rederived['vergence_checked']} rows with a light path "
        f"(real-ray bundles, Eq. 13, rim rays): {rederived['vergence_wrong']} wrong waves, "
        f"{rederived['accommodation_wrong']} wrong accommodations, "
        f"{rederived['blur_wrong']} wrong blurs (largest deviations "
        f"{rederived['max_vergence_dev_d']:.1e} D, {rederived['max_accommodation_dev_d']:.1e} "
        f"D, {rederived['max_blur_dev_m']:.1e} m); {rederived['missed_checked']} rows without "
        f"one searched exhaustively: {rederived['missed_wrong']} had a path",
        f"slowest batch {slowest[0] * 1e3:.1f} ms; most path iterations {worst_iter[0]}; "
        f"largest wave curvature {worst_curv[0]:.3g} 1/m; {out['time_s']:.1f} s in all",
        "ALL CLEAR" if out["all_clear"] else "FAILURES FOUND",
    ]
    return out
