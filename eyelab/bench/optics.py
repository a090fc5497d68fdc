"""``eyelab bench optics``: throughput of the optics engine.

* wavefront tracing of the full chain (lens front, glass, back, air, accommodation, toric
  eye, conoid section) for chief rays already found, in points per second;
* chief-ray path finding (Newton), in solves per second;
* exact ray tracing through the lens, in rays per second.

Each figure is the best of ``repeats`` runs on one thread and on all cores, reported
with the ratio between them, measured in the same run.
"""

from __future__ import annotations

import platform
import time

import numpy as np

from eyelab.core.parallel import default_workers, map_row_chunks
from eyelab.optics.chain.analysis import trace_chain
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import LensPose, SpectacleLens
from eyelab.optics.rays.paths import ChiefRays, ObjectPoints, find_chief_rays

TARGET_CHAIN_PER_S = 2.0e6


def _subset(ch: ChiefRays, a: int, b: int) -> ChiefRays:
    def cut_hit(h):
        return h.take(slice(a, b))

    return ChiefRays(ch.start[a:b], ch.entry[a:b], ch.exit[a:b], ch.dir_in[a:b],
                     ch.dir_glass[a:b], ch.dir_out[a:b],
                     None if ch.hits is None else tuple(cut_hit(h) for h in ch.hits),
                     ch.residual[a:b], ch.iterations[a:b], ch.status[a:b],
                     ch.object_distance_to_entry[a:b])


def _best(fn, repeats):
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def run_optics_bench(points: int = 1_000_000, repeats: int = 3, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    rx = Prescription.parse("-4.00 -1.00 x 30")
    lens = SpectacleLens.from_rx(rx, pose=LensPose(pantoscopic_tilt_deg=8.0))
    eye = Eye.from_rx(rx, accommodation_max=2.0)
    n_path = min(points, 200_000)
    obj = ObjectPoints.from_angles(rng.uniform(0.25, 20.0, n_path), rng.uniform(-35, 35, n_path),
                                   rng.uniform(-30, 30, n_path))
    workers = default_workers()

    def paths(workers_):
        def run(a, b):
            return find_chief_rays(lens, np.zeros(3),
                                   ObjectPoints(obj.direction[a:b], obj.distance[a:b]))
        return map_row_chunks(run, n_path, workers=workers_)

    t_path_1 = _best(lambda: paths(1), repeats)
    t_path_n = _best(lambda: paths(workers), repeats)
    chief = paths(workers)
    # tile the solved paths up to `points` rows for the chain benchmark
    reps = int(np.ceil(points / n_path))
    parts = [c for c in chief] * reps
    cat = lambda xs: np.concatenate(xs)[:points]  # noqa: E731
    from eyelab.optics.rays.trace import Hit

    hits = tuple(Hit(cat([p.hits[k].points for p in parts]),
                     cat([p.hits[k].normals for p in parts]),
                     tuple(cat([p.hits[k].form[j] for p in parts]) for j in range(3)),
                     parts[0].hits[k].rotation, cat([p.hits[k].status for p in parts]))
                 for k in range(2))
    big = ChiefRays(*(cat([getattr(p, f) for p in parts]) for f in
                      ("start", "entry", "exit", "dir_in", "dir_glass", "dir_out")), hits,
                    cat([p.residual for p in parts]), cat([p.iterations for p in parts]),
                    cat([p.status for p in parts]),
                    cat([p.object_distance_to_entry for p in parts]))
    big_obj = ObjectPoints(np.tile(obj.direction, (reps, 1))[:points],
                           np.tile(obj.distance, reps)[:points])

    def chain(workers_):
        def run(a, b):
            return trace_chain(eye, lens, _subset(big, a, b),
                               ObjectPoints(big_obj.direction[a:b], big_obj.distance[a:b]))
        return map_row_chunks(run, points, workers=workers_)

    t_chain_1 = _best(lambda: chain(1), repeats)
    t_chain_n = _best(lambda: chain(workers), repeats)
    res = chain(workers)
    ok = sum(int((r.ok).sum()) for r in res)
    dirs = big.dir_in
    starts = big.entry - 0.01 * dirs

    def rays(workers_):
        return map_row_chunks(lambda a, b: lens.trace(starts[a:b], dirs[a:b]), points,
                              workers=workers_)

    t_rays_n = _best(lambda: rays(workers), repeats)
    out = {
        "benchmark": "optics",
        "machine": {"python": platform.python_version(), "numpy": np.__version__,
                    "processor": platform.processor() or platform.machine(),
                    "workers": workers},
        "lens": f"{rx.format()} CR-39, 8 deg tilt",
        "points": points,
        "path_points": n_path,
        "repeats": repeats,
        "chain_points_per_s": {"1_thread": points / t_chain_1, f"{workers}_threads":
                               points / t_chain_n, "speedup": t_chain_1 / t_chain_n},
        "chain_ok_fraction": ok / points,
        "path_solves_per_s": {"1_thread": n_path / t_path_1, f"{workers}_threads":
                              n_path / t_path_n, "speedup": t_path_1 / t_path_n},
        "path_iterations_mean": float(np.mean(np.concatenate([c.iterations for c in chief]))),
        "lens_rays_per_s": points / t_rays_n,
        "target_chain_points_per_s": TARGET_CHAIN_PER_S,
        "meets_target": points / t_chain_n >= TARGET_CHAIN_PER_S,
    }
    out["summary"] = [
        f"wavefront chain (lens + eye): {points / t_chain_n / 1e6:.2f} M points/s on {workers} "
        f"threads ({points / t_chain_1 / 1e6:.2f} M/s on 1; x{t_chain_1 / t_chain_n:.2f}); "
        f"target {TARGET_CHAIN_PER_S / 1e6:.1f} M/s: "
        f"{'met' if out['meets_target'] else 'NOT met'}",
        f"path finding: {n_path / t_path_n / 1e3:.1f} k solves/s on {workers} threads "
        f"({n_path / t_path_1 / 1e3:.1f} k/s on 1), mean "
        f"{out['path_iterations_mean']:.2f} Newton iterations",
        f"exact lens ray tracing: {points / t_rays_n / 1e6:.2f} M rays/s",
    ]
    return out
