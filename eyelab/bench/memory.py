"""``eyelab bench memory``: resident memory over many renders (leaks and cache bounds), and
the memory estimate against the measured peak of mesh files.

Two scenarios of the raster renderer, through a lens (64x48, S = 2, the chart at 2 m):

* ``new_renderer_each``: N renders, each with a new renderer created and closed (windows,
  GL contexts, caches built and released every time);
* ``new_eye_each``: M renders with one renderer and a new eye each (every frame computes
  new blur fields; the bounded caches must hold memory flat).

Resident set size (``VmRSS``) is read after a warm-up and after the run, garbage
collected both times; growth is reported in MB with the caches' final sizes.

* ``mesh_files``: a raster render (:data:`MESH_RENDER`: 512x384, S = 2, a 64x32x32 field,
  both the naked eye's and the lens's views drawn) of a tilted plane of N triangles
  (binary PLY, :func:`plane_ply`), each in its own process: peak resident memory
  (``VmHWM``) against :func:`eyelab.imaging.memory.check_memory`'s estimate, whose scene
  part counts the triangles and vertices read from the file's header.
"""

from __future__ import annotations

import gc
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from eyelab.core.progress import bar as progress_bar
from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import SpectacleLens
from eyelab.render.raster import RasterRenderer
from eyelab.scene.library import chart_scene


def rss_mb(trim: bool = True) -> float:
    """Resident set size of this process, MB (Linux /proc); ``trim``: first garbage-collect
    and hand the allocator's free memory back to the system (glibc ``malloc_trim``), so
    that what is measured is what is still held, not the arenas' free lists."""
    if trim:
        gc.collect()
        _malloc_trim()
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS"):
                return int(line.split()[1]) / 1024
    raise OSError("VmRSS not found in /proc/self/status")


def _malloc_trim() -> None:
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    if name:
        try:
            ctypes.CDLL(name).malloc_trim(0)
        except (OSError, AttributeError):       # not glibc: nothing to trim
            pass


def _eye(i: int) -> Eye:
    return Eye.from_rx(Prescription(-1.0), accommodation_max=0.5 + 1e-3 * i)


def new_renderer_each(n: int, warmup: int = 10) -> dict:
    scene, lens, view = chart_scene(2.0), SpectacleLens.from_rx(Prescription(-1.0)), \
        View(width=64, height=48)
    q = RasterQuality(samples=2)
    for _ in range(warmup):
        with RasterRenderer(q) as r:
            r.render(scene, _eye(0), lens, view)
    bar = progress_bar(n, "memory: a new renderer each", "render")
    gc.collect()
    before, t = rss_mb(), time.perf_counter()
    for _ in range(n):
        with RasterRenderer(q) as r:
            r.render(scene, _eye(0), lens, view)
        bar.update(1)
    bar.close()
    gc.collect()
    return {"renders": n, "rss_growth_mb": rss_mb() - before, "rss_before_mb": before,
            "time_s": time.perf_counter() - t}


def new_eye_each(n: int, warmup: int = 20) -> dict:
    scene, lens, view = chart_scene(2.0), SpectacleLens.from_rx(Prescription(-1.0)), \
        View(width=64, height=48)
    with RasterRenderer(RasterQuality(samples=2)) as r:
        for i in range(warmup):
            r.render(scene, _eye(i), lens, view)
        bar = progress_bar(n, "memory: a new eye each", "render")
        gc.collect()
        before, t = rss_mb(), time.perf_counter()
        for i in range(n):
            r.render(scene, _eye(warmup + i), lens, view)
            bar.update(1)
        bar.close()
        gc.collect()
        out = {"renders": n, "rss_growth_mb": rss_mb() - before, "rss_before_mb": before,
               "time_s": time.perf_counter() - t,
               "cache_entries": {k: c.stats() for k, c in r.caches.items()}}
    return out


#: Renders a spec (JSON, argv[1]) in a process of its own and prints its peak resident
#: memory in bytes (VmHWM: this program's own peak; ru_maxrss keeps the forking parent's
#: across exec).
PEAK_SCRIPT = """
import json, os, sys
os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkOSOpenGLRenderWindow"
from eyelab.jobs.render import render_spec
from eyelab.spec import parse_spec
spec = parse_spec(json.loads(sys.argv[1]))
render_spec(spec)
hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM:")][0]
print(int(hwm.split()[1]) * 1024)
"""

#: The raster's heaviest case for a scene: the lens in part of the view (gaze 35 degrees,
#: 90 degrees field of view), so that both views, the naked eye's and the lens's, draw
#: every triangle.
MESH_RENDER = {"width": 512, "height": 384, "samples": 2, "field_shape": [64, 32, 32],
               "fov_y_deg": 90, "gaze_deg": [35, 0]}


def measured_peak(data: dict, timeout: float = 900.0) -> float:
    """Peak resident bytes of rendering the spec ``data`` (a dict) in a new process."""
    out = subprocess.run([sys.executable, "-P", "-c", PEAK_SCRIPT, json.dumps(data)],
                         capture_output=True, text=True, timeout=timeout, check=True)
    return float(out.stdout.split()[-1])


def plane_ply(path, triangles: int, *, claim: int | None = None) -> None:
    """Write a binary PLY of a grid of ``triangles`` triangles (a vertex per two) with
    vertex colours: a plane 2 m wide and 1.5 m high, tilted from 0.25 m to 4.75 m in front
    of the eye (its blur changes across it). ``claim``: a header claiming that many faces
    and no body (a file that cannot be loaded)."""
    n = int(round(np.sqrt(triangles / 2.0))) + 1                 # vertices per row
    m = -(-triangles // (2 * (n - 1))) + 1                      # rows
    gx, gy = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-0.75, 0.75, m))
    v = np.zeros(n * m, [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("red", "u1"),
                         ("green", "u1"), ("blue", "u1")])
    v["x"], v["y"], v["z"] = gx.ravel(), gy.ravel(), -2.5 - 3.0 * gy.ravel()
    v["red"] = 40 + 180 * ((np.arange(n * m) // 7) % 2)
    v["green"], v["blue"] = 120, 90
    i = np.arange(n * m, dtype=np.int32).reshape(m, n)
    a, b, c, d = (x.ravel() for x in (i[:-1, :-1], i[:-1, 1:], i[1:, 1:], i[1:, :-1]))
    f = np.zeros(triangles, [("n", "u1"), ("v", "<i4", (3,))])
    f["n"] = 3
    f["v"] = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])[:triangles]
    header = ("ply\nformat binary_little_endian 1.0\n"
              f"element vertex {len(v)}\nproperty float x\nproperty float y\n"
              "property float z\nproperty uchar red\nproperty uchar green\n"
              f"property uchar blue\nelement face {claim or triangles}\n"
              "property list uchar int vertex_indices\nend_header\n")
    with open(path, "wb") as fh:
        fh.write(header.encode())
        if claim is None:
            fh.write(v.tobytes())
            fh.write(f.tobytes())


def mesh_file_peaks(triangles=(10_000, 1_000_000, 8_000_000)) -> list:
    """Per triangle count: {"triangles", "vertices", "estimate_gib", "peak_gib", "ratio"
    (estimate / peak), "time_s"} of a raster render (:data:`MESH_RENDER`) of
    :func:`plane_ply`'s plane, through a lens."""
    from eyelab.imaging.memory import GIB, check_memory
    from eyelab.scene.filestats import file_stats
    from eyelab.spec import parse_spec

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in triangles:
            path = Path(tmp) / f"plane{n}.ply"
            plane_ply(path, int(n))
            data = {"eye": {"rx": "-3.00 -1.00 x 30"}, "lens": {},
                    "render": dict(MESH_RENDER, scene=str(path))}
            est = check_memory(parse_spec(data).render, limit=float("inf"))
            t = time.perf_counter()
            peak = measured_peak(data)
            rows.append({"triangles": int(n), "vertices": file_stats(path).vertices,
                         "estimate_gib": est["total"] / GIB,
                         "scene_part_gib": est["scene"] / GIB, "peak_gib": peak / GIB,
                         "ratio": est["total"] / peak, "time_s": time.perf_counter() - t})
            path.unlink()
    return rows


def run_memory_bench(new_renderers: int = 200, new_eyes: int = 500,
                     mesh_triangles=(10_000, 1_000_000, 8_000_000)) -> dict:
    """The three scenarios (0 renders or no triangle counts: that one left out)."""
    out, lines = {"benchmark": "memory"}, []
    if new_renderers:
        a = out["new_renderer_each"] = new_renderer_each(new_renderers)
        lines.append(f"{a['renders']} renders through a lens, a new renderer each: RSS "
                     f"{a['rss_growth_mb']:+.1f} MB ({a['time_s']:.0f} s)")
    if new_eyes:
        b = out["new_eye_each"] = new_eye_each(new_eyes)
        lines.append(f"{b['renders']} renders through a lens, one renderer, a new eye each: "
                     f"RSS {b['rss_growth_mb']:+.1f} MB ({b['time_s']:.0f} s); cache entries "
                     + ", ".join(f"{k} {v['entries']}/{v['maxsize']}"
                                 for k, v in b["cache_entries"].items()))
    if mesh_triangles:
        rows = mesh_file_peaks(mesh_triangles)
        out["mesh_files"] = {"render": MESH_RENDER, "cases": rows}
        lines.append("mesh files, raster 512x384 through a lens (both views drawn): "
                     + "; ".join(f"{r['triangles']:,} triangles: peak {r['peak_gib']:.2f} GiB, "
                                 f"estimate {r['estimate_gib']:.2f} GiB ({r['ratio']:.2f}x, "
                                 f"{r['time_s']:.0f} s)" for r in rows))
    out["summary"] = lines
    return out
