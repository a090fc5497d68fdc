"""As-worn maps and figures of merit kept on disk (:mod:`eyelab.core.diskcache`).

The maps of a lens worn by an eye (:func:`eyelab.optics.lens.asworn.as_worn_maps`: a tenth of a
second to a second) and the figures of merit read off them
(:func:`eyelab.optics.lens.figures.as_worn_figures` on a 41 x 41 grid: a second or more for a
progressive lens) depend only on the eye, the lens, the wavelength and the grid, and on
the code that computes them; like an optimised design, each is computed once per machine
and read back by later processes — but only for an eye and a lens with a *complete*
content key (:func:`eyelab.core.cache.complete_key`: every surface, the material, pose,
prescription, design and outline by their whole content). An input that only a text
could stand for is never keyed by it: such maps and figures are computed every time,
their :class:`~eyelab.core.diskcache.Status` saying why.

Keys: the eye's and lens's complete key, every other input the result reads (wavelength,
grid, the object-distance model), numpy's and scipy's versions, and the digest of this
package's and the core's code (an edited tracer misses rather than reads a stale result).
Entries: the maps' arrays bit for bit (npz); the figures as JSON (numbers written as
Python's ``repr``, which reads back to the same double; NaN kept).
"""

from __future__ import annotations

import inspect
import json
from pathlib import Path

import numpy as np

from eyelab.core import diskcache
from eyelab.core.cache import complete_key
from eyelab.core.fileio import json_default
from eyelab.optics.lens import asworn
from eyelab.optics.lens.asworn import AsWornMaps, as_worn_maps
from eyelab.optics.rays.paths import ObjectPoints

#: The disk cache's namespaces (:mod:`eyelab.core.diskcache`).
MAPS_NAMESPACE = "asworn-maps"
FIGURES_NAMESPACE = "asworn-figures"
#: The maps' arrays (AsWornMaps attributes) an entry holds, beside the surfaces' maps and
#: the objects.
MAP_ARRAYS = ("eye_rotation_x_deg", "eye_rotation_y_deg", "mean_error_d", "cylinder_d",
              "axis_tabo_deg", "sphere_error_d", "prism_d", "object_vergence_d", "ok",
              "object_x_deg", "object_y_deg")
#: Why a result was not looked for on disk (the Status's note).
INCOMPLETE = "not cached: the eye or the lens has no complete content key"


def _parts(eye, lens, what: str, inputs: dict) -> dict | None:
    """The disk cache's inputs for ``what`` of ``lens`` worn by ``eye``, or None when they
    have no complete key."""
    import scipy

    key = complete_key(eye=eye, lens=lens)
    if key is None:
        return None
    return dict(what=what, eye_and_lens=key, inputs=inputs, numpy=np.__version__,
                scipy=scipy.__version__)


def _code() -> tuple:
    """The code the results are computed by: this package and the core."""
    return (Path(__file__).parent, Path(diskcache.__file__).parent)


def _maps_entry(maps: AsWornMaps) -> tuple:
    """(arrays, meta) of ``maps`` for the disk cache."""
    arrays = {k: getattr(maps, k) for k in MAP_ARRAYS if getattr(maps, k) is not None}
    arrays.update({f"surface__{k}": v for k, v in maps.surface.items()})
    if maps.objects is not None:
        arrays.update(objects_direction=maps.objects.direction,
                      objects_distance=maps.objects.distance)
    meta = {"surface": list(maps.surface), "model": maps.model,
            "marks": [[k, *v] for k, v in maps.marks.items()]}
    return arrays, meta


def _maps_from(arrays: dict, meta: dict) -> AsWornMaps:
    """The :class:`AsWornMaps` of a disk cache entry (:func:`_maps_entry`)."""
    objects = None
    if "objects_direction" in arrays:
        objects = ObjectPoints(arrays["objects_direction"], arrays["objects_distance"])
    kw = {k: arrays.get(k) for k in MAP_ARRAYS}
    return AsWornMaps(**kw, surface={k: arrays[f"surface__{k}"] for k in meta["surface"]},
                      model=dict(meta["model"]),
                      marks={m[0]: (float(m[1]), float(m[2])) for m in meta["marks"]},
                      objects=objects)


def maps(eye, lens, **kw) -> tuple:
    """(maps, status): :func:`~eyelab.optics.lens.asworn.as_worn_maps` of ``lens`` worn by
    ``eye`` (``kw``: its keywords), read from the disk cache when this eye, lens and
    keywords were mapped before (the arrays bit for bit), else computed and stored.
    ``status``: where they came from (:class:`~eyelab.core.diskcache.Status`)."""
    bound = inspect.signature(as_worn_maps).bind(eye, lens, **kw)   # TypeError: unknown
    bound.apply_defaults()
    inputs = {k: v for k, v in bound.arguments.items() if k not in ("eye", "lens")}
    parts = _parts(eye, lens, "maps", inputs)
    if parts is None:
        return as_worn_maps(eye, lens, **kw), diskcache.Status("computed", note=INCOMPLETE)
    arrays, meta, status = diskcache.fetch(
        MAPS_NAMESPACE, parts, lambda: _maps_entry(as_worn_maps(eye, lens, **kw)),
        code=_code())
    return _maps_from(arrays, meta), status


def _plain(obj):
    """``obj`` as JSON reads it back (numpy numbers Python's, tuples lists, NaN kept):
    what a disk cache entry's meta gives."""
    return json.loads(json.dumps(obj, default=json_default))


def figures(eye, lens, *, half_angle_deg: float, n: int, wavelength_nm: float = 587.56,
            maps_on_grid: AsWornMaps | None = None) -> tuple:
    """(figures, status): :func:`~eyelab.optics.lens.figures.as_worn_figures` of ``lens`` worn
    by ``eye`` read off its as-worn maps on the ``n`` x ``n`` grid within
    +-``half_angle_deg`` (deg) at ``wavelength_nm`` (nm), as JSON gives them back (numpy
    numbers Python's, tuples lists, NaN kept) whether read from the disk cache or computed
    (and stored). ``maps_on_grid``: those maps, when the caller has them (their
    object-distance model is part of the key); else they are computed on a miss.
    ``status``: where the figures came from (:class:`~eyelab.core.diskcache.Status`)."""
    from eyelab.optics.lens.figures import as_worn_figures

    model = maps_on_grid.model if maps_on_grid is not None else {}
    inputs = dict(half_angle_deg=half_angle_deg, n=n, wavelength_nm=wavelength_nm,
                  near_vergence_d=model.get("near_vergence_d", asworn.NEAR_VERGENCE_D),
                  near_rotation_deg=model.get("near_rotation_deg", asworn.NEAR_ROTATION_DEG))

    def compute() -> tuple:
        m = maps_on_grid
        if m is None:
            m = as_worn_maps(eye, lens, half_angle_deg=half_angle_deg, n=n,
                             wavelength_nm=wavelength_nm)
        return {}, _plain(as_worn_figures(m, eye, lens, wavelength_nm))

    parts = _parts(eye, lens, "figures", inputs)
    if parts is None:
        return compute()[1], diskcache.Status("computed", note=INCOMPLETE)
    _, out, status = diskcache.fetch(FIGURES_NAMESPACE, parts, compute, code=_code())
    return out, status
