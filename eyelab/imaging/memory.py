"""Memory a render will need, estimated up front, and the limit it is checked against.

The estimate is linear in what a spec controls (image pixels, blur-field voxels and colour
channels, reference rays in flight), with constants measured on this code (peak resident
memory, ``ru_maxrss``, of ``eyelab render`` with the built-in scene; tracemalloc for the
blur field) and rounded up:

- raster: 0.5 GiB of libraries and scene + 400 B per image pixel (measured 364 B between
  1024x768 and 2048x1536, environment image at ``env_oversample`` 1.5 included; scaled by
  (env_oversample / 1.5)^2 above that) + per blur-field voxel 100 B for each colour
  channel's field kept (measured 97 B) and 200 B of working arrays while one is computed
  (measured 160-185 B at 64^3; more per voxel for small grids, where it does not matter);
- reference: 0.3 GiB + 150 B per pixel + 1 KiB per ray in flight (each worker traces
  max(16384, samples) rays at a time);
- image-based: 0.4 GiB + 1000 B per image pixel at ``oversample`` 2 (slices, morph and
  accumulation; measured 390 MB at 256x192 and 1050 MB at 1024x768 through a lens: 890 B
  per pixel), scaled by (oversample / 2)^2 above that.

The limit is half the machine's physical memory unless ``--max-memory GIB`` (or the
environment variable ``EYELAB_MAX_MEMORY_GB``) sets it. A spec over the limit is refused
before any work, naming the key that dominates the estimate.
"""

from __future__ import annotations

import contextlib
import os

from eyelab.core.checks import check_range
from eyelab.core.errors import SpecError

GIB = 1024.0**3
RASTER_BASE_BYTES = 0.5 * GIB
RASTER_BYTES_PER_PIXEL = 400.0
FIELD_BYTES_PER_VOXEL_CHANNEL = 100.0
FIELD_WORK_BYTES_PER_VOXEL = 200.0
REFERENCE_BASE_BYTES = 0.3 * GIB
REFERENCE_BYTES_PER_PIXEL = 150.0
REFERENCE_BYTES_PER_RAY = 1024.0
#: Rays per reference task (tracer.py: max(1, 16384 // samples) pixels per task).
REFERENCE_RAYS_PER_TASK = 16384
IMAGEBASED_BASE_BYTES = 0.4 * GIB
IMAGEBASED_BYTES_PER_PIXEL = 1000.0
ENV_MAX_MEMORY = "EYELAB_MAX_MEMORY_GB"


def physical_memory() -> float:
    """Bytes of physical memory of this machine (0 when the OS does not say)."""
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 0.0


def memory_limit(max_memory_gb: float | None = None) -> float:
    """The limit in bytes: ``max_memory_gb`` if given, else ``$EYELAB_MAX_MEMORY_GB``, else
    half the physical memory (16 GiB when it is unknown)."""
    if max_memory_gb is not None:
        return check_range("--max-memory", max_memory_gb, 0.01, 1e6) * GIB
    env = os.environ.get(ENV_MAX_MEMORY)
    if env is not None:
        try:
            value = float(env)
        except ValueError:
            raise SpecError(ENV_MAX_MEMORY, f"must be a number of GiB, got {env!r}") from None
        return check_range(ENV_MAX_MEMORY, value, 0.01, 1e6) * GIB
    phys = physical_memory()
    return phys / 2 if phys > 0 else 16 * GIB


def estimate_memory(renderer: str, view, quality) -> dict:
    """Estimated peak bytes of one render, by part: {"total", "image", "field", "base"}
    (raster) or {"total", "image", "rays", "base"} (reference). ``view``: a
    :class:`~eyelab.imaging.contract.View`; ``quality``: the renderer's options."""
    pixels = float(view.width) * float(view.height)
    if renderer == "raster":
        nz, ny, nx = quality.field_shape
        voxels = float(nz) * ny * nx
        channels = 3 if quality.chromatic else 1
        env = max(1.0, (quality.env_oversample / 1.5) ** 2)
        parts = {"base": RASTER_BASE_BYTES,
                 "image": pixels * RASTER_BYTES_PER_PIXEL * env,
                 "field": voxels * (channels * FIELD_BYTES_PER_VOXEL_CHANNEL
                                    + FIELD_WORK_BYTES_PER_VOXEL)}
    elif renderer == "imagebased":
        slices = max(1.0, (quality.oversample / 2.0) ** 2)
        parts = {"base": IMAGEBASED_BASE_BYTES,
                 "image": pixels * IMAGEBASED_BYTES_PER_PIXEL * slices}
    else:
        workers = quality.workers or os.cpu_count() or 1
        rays = workers * max(REFERENCE_RAYS_PER_TASK, quality.samples)
        parts = {"base": REFERENCE_BASE_BYTES, "image": pixels * REFERENCE_BYTES_PER_PIXEL,
                 "rays": rays * REFERENCE_BYTES_PER_RAY}
    parts["total"] = sum(parts.values())
    return parts


def check_memory(render_spec, limit: float | None = None) -> dict:
    """Refuse (:class:`SpecError`) a render whose estimate exceeds ``limit`` bytes (None:
    :func:`memory_limit`), naming the ``[render]`` key of its largest part; returns the
    estimate. ``render_spec``: anything with ``renderer``, ``view`` and ``quality``."""
    return check_render_memory(render_spec.renderer, render_spec.view, render_spec.quality,
                               limit)


def set_memory_limit(max_memory_gb: float | None) -> None:
    """Make ``max_memory_gb`` (validated; None: leave as it is) this process's limit, as
    ``$EYELAB_MAX_MEMORY_GB``: every render checks against it, and so do worker processes
    started after this call."""
    if max_memory_gb is not None:
        memory_limit(max_memory_gb)
        os.environ[ENV_MAX_MEMORY] = repr(float(max_memory_gb))


@contextlib.contextmanager
def memory_limit_scope():
    """Restore ``$EYELAB_MAX_MEMORY_GB`` on exit: a limit set by :func:`set_memory_limit`
    inside the block (a command's ``--max-memory``) does not outlive it."""
    before = os.environ.get(ENV_MAX_MEMORY)
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(ENV_MAX_MEMORY, None)
        else:
            os.environ[ENV_MAX_MEMORY] = before


def check_render_memory(renderer: str, view, quality, limit: float | None = None) -> dict:
    """:func:`check_memory` for a renderer's name, view and quality options; every
    :meth:`Renderer.render <eyelab.imaging.contract.Renderer.render>` calls it."""
    limit = memory_limit() if limit is None else limit
    est = estimate_memory(renderer, view, quality)
    if est["total"] > limit:
        key = {"image": "render.width", "field": "render.field_shape",
               "rays": "render.samples", "base": "render"}[
            max(("image", "field", "rays", "base"), key=lambda k: est.get(k, 0.0))]
        raise SpecError(key, f"this render needs an estimated {est['total'] / GIB:.1f} GiB of "
                             f"memory; the limit is {limit / GIB:.1f} GiB (set by "
                             f"--max-memory GIB or {ENV_MAX_MEMORY}; default half this "
                             f"machine's memory)")
    return est
