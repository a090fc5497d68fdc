"""``eyelab bench memory``: resident memory over many renders (leaks and cache bounds).

Two scenarios of the raster renderer, through a lens (64x48, S = 2, the chart at 2 m):

* ``new_renderer_each``: N renders, each with a new renderer created and closed (windows,
  GL contexts, caches built and released every time);
* ``new_eye_each``: M renders with one renderer and a new eye each (every frame computes
  new blur fields; the bounded caches must hold memory flat).

Resident set size (``VmRSS``) is read after a warm-up and after the run, garbage
collected both times; growth is reported in MB with the caches' final sizes.
"""

from __future__ import annotations

import gc
import time

from eyelab.core.progress import bar as progress_bar
from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality
from eyelab.optics.eye import Eye
from eyelab.optics.lens import SpectacleLens
from eyelab.optics.prescription import Prescription
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


def run_memory_bench(new_renderers: int = 200, new_eyes: int = 500) -> dict:
    a = new_renderer_each(new_renderers)
    b = new_eye_each(new_eyes)
    lines = [f"{a['renders']} renders through a lens, a new renderer each: RSS "
             f"{a['rss_growth_mb']:+.1f} MB ({a['time_s']:.0f} s)",
             f"{b['renders']} renders through a lens, one renderer, a new eye each: RSS "
             f"{b['rss_growth_mb']:+.1f} MB ({b['time_s']:.0f} s); cache entries "
             + ", ".join(f"{k} {v['entries']}/{v['maxsize']}"
                         for k, v in b["cache_entries"].items())]
    return {"benchmark": "memory", "new_renderer_each": a, "new_eye_each": b,
            "summary": lines}
