"""Memory a render will need, estimated up front, and the limit it is checked against.

The estimate is linear in what a spec controls (image pixels, blur-field voxels and colour
channels, reference rays in flight) and in what the scene holds (triangles, vertices,
texture texels), with constants measured on this code (peak resident memory, ``VmHWM``, of
a render in its own process; tracemalloc for the blur field) and rounded up:

- raster: 0.4 GiB of libraries and GL contexts (measured 0.45 GiB with both views drawn
  at 512x384, 0.10 GiB of it image and fields) + 400 B per image pixel (measured 364 B
  between 1024x768 and 2048x1536, environment image at ``env_oversample`` 1.5 included;
  scaled by (env_oversample / 1.5)^2 above that) + per blur-field voxel 100 B for each
  colour channel's field kept (measured 97 B) and 200 B of working arrays while one is
  computed (measured 160-185 B at 64^3; more per voxel for small grids, where it does not
  matter);
- reference: 0.17 GiB (measured 0.11 GiB at 16x16) + 150 B per pixel + 1 KiB per ray in
  flight (each worker traces max(16384, samples) rays at a time);
- image-based: 0.3 GiB (measured 0.26 GiB at 64x48) + 1000 B per image pixel at
  ``oversample`` 2 (slices, morph and accumulation; measured 390 MB at 256x192 and
  1050 MB at 1024x768 through a lens, the room's textures included: 890 B per pixel),
  scaled by (oversample / 2)^2 above that;

plus the scene, per triangle, vertex and texel (:data:`SCENE_BYTES`): the loaded mesh, the
embree BVHs and the VTK polydata and GL buffers of its actors. Measured on tilted planes of
10 k to 8 M triangles (binary PLY, vertex colours; a vertex per two triangles), the same as
triangle soups (three vertices per triangle: the per-vertex part) and a textured quad (4 M
and 16.8 M texels), with both of the raster's views drawn (the lens in part of the view):

- raster: 145 B per triangle + 215 B per vertex (measured: 228 B per triangle of a plane,
  a vertex per two triangles, between 1 M and 8 M triangles; 209 B per further vertex of
  a soup) + 24 B per texel (measured 23.5 B) + 140 B per triangle for the first 1 M
  triangles (the allocator keeps what is freed of arrays under its 32 MiB mmap threshold:
  measured 379 B per plane triangle between 10 k and 1 M); on the ``attribute`` route 65 B
  per triangle and 100 B per vertex more for each further colour channel's actors
  (measured 111 MB per channel at 1 M triangles); with refinement on, one mesh refined to
  the cap (:data:`REFINED_MESH`);
- reference: 110 B per triangle + 80 B per vertex + 28 B per texel (measured 146 B per
  plane triangle, 76 B per further soup vertex, 27 B per texel: the texture decoded to
  linear light);
- image-based: 180 B per triangle + 135 B per vertex + 14 B per texel (measured 234 B per
  plane triangle between 1 M and 4 M, 134 B per further soup vertex, 13.4 B per texel).

The scene's counts: a built scene's own (:func:`~eyelab.scene.filestats.scene_stats`);
before loading, a mesh file's from its header or lines
(:func:`~eyelab.scene.filestats.file_stats`), so that a file too big for the limit is
refused before it is read; a built-in scene's, built; unknown (a format not read
there, or no scene given): the largest built-in scene's (:data:`BUILTIN_SCENE`).

The limit is half the machine's physical memory unless ``--max-memory GIB`` (or the
environment variable ``EYELAB_MAX_MEMORY_GB``) sets it. A spec over the limit is refused
before any work, naming the key that dominates the estimate.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass

from eyelab.core.checks import check_range
from eyelab.core.errors import SpecError
from eyelab.scene.filestats import SceneStats, file_stats, scene_stats

GIB = 1024.0**3
RASTER_BASE_BYTES = 0.4 * GIB
RASTER_BYTES_PER_PIXEL = 400.0
FIELD_BYTES_PER_VOXEL_CHANNEL = 100.0
FIELD_WORK_BYTES_PER_VOXEL = 200.0
REFERENCE_BASE_BYTES = 0.17 * GIB
REFERENCE_BYTES_PER_PIXEL = 150.0
REFERENCE_BYTES_PER_RAY = 1024.0
#: Rays per reference task (tracer.py: max(1, 16384 // samples) pixels per task).
REFERENCE_RAYS_PER_TASK = 16384
IMAGEBASED_BASE_BYTES = 0.3 * GIB
IMAGEBASED_BYTES_PER_PIXEL = 1000.0
ENV_MAX_MEMORY = "EYELAB_MAX_MEMORY_GB"


@dataclass(frozen=True)
class SceneCost:
    """Bytes a renderer needs per scene ``triangle``, ``vertex`` and texture ``texel``, and
    ``heap`` bytes more per triangle for the first :data:`HEAP_TRIANGLES` triangles."""

    triangle: float
    vertex: float
    texel: float
    heap: float = 0.0


#: Scene bytes per renderer (measured: see the module's notes).
SCENE_BYTES = {"raster": SceneCost(145.0, 215.0, 24.0, heap=140.0),
               "reference": SceneCost(110.0, 80.0, 28.0),
               "imagebased": SceneCost(180.0, 135.0, 14.0)}
#: Triangles the raster's ``heap`` bytes are counted for (beyond them, the arrays of a mesh
#: pass the allocator's 32 MiB mmap threshold and are returned when freed).
HEAP_TRIANGLES = 1_000_000
#: Raster ``attribute`` route: bytes per triangle and per vertex of each colour channel's
#: actors beyond the first.
ATTRIBUTE_CHANNEL_BYTES = (65.0, 100.0)
#: One mesh refined to the cap (:data:`eyelab.scene.refine.MAX_VERTICES`: a mesh under half
#: of it may be subdivided once more, to about four times its vertices).
REFINED_MESH = SceneStats(triangles=400_000, vertices=200_000, source="refinement")
#: What a built-in scene holds at most (the room: 2736 triangles, 1728 vertices, 6.9 M
#: texels): the scene counted when nothing more is known.
BUILTIN_SCENE = SceneStats(triangles=3000, vertices=2000, texels=7_000_000,
                           source="a built-in scene's, at most")


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


def estimate_memory(renderer: str, view, quality, scene=None) -> dict:
    """Estimated peak bytes of one render, by part: {"total", "base", "image", "field",
    "scene"} (raster), {"total", "base", "image", "rays", "scene"} (reference) or {"total",
    "base", "image", "scene"} (image-based). ``view``: a
    :class:`~eyelab.imaging.contract.View`; ``quality``: the renderer's options;
    ``scene``: what the scene holds — a :class:`~eyelab.scene.filestats.SceneStats`, a
    built :class:`~eyelab.scene.scene.Scene`, or None (unknown: :data:`BUILTIN_SCENE`)."""
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
    parts["scene"] = scene_bytes(renderer, quality, _stats(scene))
    parts["total"] = sum(parts.values())
    return parts


def scene_bytes(renderer: str, quality, stats: SceneStats) -> float:
    """Bytes the scene ``stats`` (:class:`~eyelab.scene.filestats.SceneStats`) costs a
    ``renderer`` with options ``quality`` (:data:`SCENE_BYTES`; the raster's refinement and
    per-channel actors included)."""
    c = SCENE_BYTES.get(renderer, SCENE_BYTES["reference"])
    tris, verts = float(stats.triangles), float(stats.vertices)
    total = (tris * c.triangle + verts * c.vertex + float(stats.texels) * c.texel
             + min(tris, HEAP_TRIANGLES) * c.heap)
    if renderer == "raster":
        if quality.refine:
            r = REFINED_MESH
            total += r.triangles * c.triangle + r.vertices * c.vertex
        if quality.field_route == "attribute" and quality.chromatic:
            per_tri, per_vert = ATTRIBUTE_CHANNEL_BYTES
            total += 2 * (tris * per_tri + verts * per_vert)
    return total


def _stats(scene) -> SceneStats:
    if isinstance(scene, SceneStats):
        return scene
    if getattr(scene, "meshes", None) is None:     # None, or not a built scene: assume
        return BUILTIN_SCENE                       # the largest built-in one
    return scene_stats(scene)


def source_stats(source) -> SceneStats:
    """The :class:`~eyelab.scene.filestats.SceneStats` of what ``[render] scene`` names (a
    :class:`~eyelab.scene.scene.SceneSource`, a name or a path), before it is built: a
    built-in scene's own (built: milliseconds), a mesh file's read from its header or
    lines (:func:`~eyelab.scene.filestats.file_stats`), else :data:`BUILTIN_SCENE`."""
    from eyelab.scene.library import SCENE_NAMES

    name = getattr(source, "name", source)
    if name is None:
        return BUILTIN_SCENE
    if name in SCENE_NAMES:
        return _builtin_stats(name, getattr(source, "chart_distance_m", None),
                              getattr(source, "chart_contrast", None))
    return file_stats(name) or BUILTIN_SCENE


@functools.lru_cache(maxsize=16)
def _builtin_stats(name: str, distance_m, contrast) -> SceneStats:
    from eyelab.scene.library import SCENES

    params = {k: v for k, v in (("distance_m", distance_m), ("contrast", contrast))
              if v is not None}
    return scene_stats(SCENES[name](**params))


def check_memory(render_spec, limit: float | None = None) -> dict:
    """Refuse (:class:`SpecError`) a render whose estimate exceeds ``limit`` bytes (None:
    :func:`memory_limit`), naming the ``[render]`` key of its largest part; returns the
    estimate. ``render_spec``: anything with ``renderer``, ``view`` and ``quality`` (and
    ``scene``, a :class:`~eyelab.scene.scene.SceneSource`: its size is read before it is
    loaded, :func:`source_stats`)."""
    source = getattr(render_spec, "scene", None)
    table = getattr(render_spec, "table", None) or {}
    key = "render.scene.path" if isinstance(table.get("scene"), dict) else "render.scene"
    return check_render_memory(render_spec.renderer, render_spec.view, render_spec.quality,
                               limit, scene=source_stats(source), scene_key=key)


def set_memory_limit(max_memory_gb: float | None) -> None:
    """Make ``max_memory_gb`` (validated; None: leave as it is) this process's limit, as
    ``$EYELAB_MAX_MEMORY_GB``: every render checks against it, and so do worker processes
    started after this call."""
    if max_memory_gb is not None:
        memory_limit(max_memory_gb)
        os.environ[ENV_MAX_MEMORY] = repr(float(max_memory_gb))


def memory_limit_scope():
    """A block after which ``$EYELAB_MAX_MEMORY_GB`` is as before: a limit set by
    :func:`set_memory_limit` inside it (a command's ``--max-memory``) does not outlive
    it."""
    from eyelab.core.parallel import scoped_environ

    return scoped_environ(ENV_MAX_MEMORY)


def check_render_memory(renderer: str, view, quality, limit: float | None = None, *,
                        scene=None, scene_key: str = "render.scene") -> dict:
    """:func:`check_memory` for a renderer's name, view and quality options and the scene
    (as :func:`estimate_memory` takes it; ``scene_key``: the spec key named when the scene
    dominates); every :meth:`Renderer.render <eyelab.imaging.contract.Renderer.render>`
    calls it."""
    limit = memory_limit() if limit is None else limit
    est = estimate_memory(renderer, view, quality, scene)
    if est["total"] > limit:
        keys = {"image": "render.width", "field": "render.field_shape",
                "rays": "render.samples", "base": "render", "scene": scene_key}
        part = max(keys, key=lambda k: est.get(k, 0.0))
        what = ""
        if part == "scene":
            st = _stats(scene)
            what = (f" ({st.triangles:,} triangles, {st.vertices:,} vertices, "
                    f"{st.texels:,} texels, {st.source})")
        raise SpecError(keys[part], f"this render needs an estimated {est['total'] / GIB:.1f} "
                                    f"GiB of memory{what}; the limit is {limit / GIB:.1f} GiB "
                                    f"(set by --max-memory GIB or {ENV_MAX_MEMORY}; default "
                                    f"half this machine's memory)")
    return est
