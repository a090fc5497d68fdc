"""The inspector's as-worn maps, without any GL: the lens's mean power error and cylinder
over eye rotations (:func:`eyelab.optics.lens.asworn.as_worn_maps`, the maps ``eyelab maps``
draws) and the point on them where the inspector's line of sight passes.

The maps are drawn over eye rotations about the centre of rotation (Fick angles: azimuth
to the wearer's right, then elevation up, deg), and the inspector's gaze
(``render.gaze_deg``) is such a rotation, so the gaze is directly a point on the maps; the
values there are read off the maps by bilinear interpolation (:func:`values_at`).

Cost: the maps take 0.1-0.4 s on :data:`MAP_POINTS` x :data:`MAP_POINTS` eye rotations
within +-:data:`MAP_HALF_ANGLE_DEG` (a 4 deg step, coarser than ``eyelab maps``'s default
31 x 31 over +-30 deg), several times that at 31 x 31 with a progressive lens. They depend
on the lens (its surfaces, pose and the frame it is cut to), the eye's centre of rotation
(the eye turns about it) and the wavelength, and on nothing the inspector's other controls
change: they are computed once per such change and kept (:class:`GazeMaps`, keyed by
content; the gaze, the eye's Rx, pupil, age and focus reuse them). They are computed on a
worker thread, started only once the first frame after the change has been shown
(:class:`~eyelab.jobs.inspector.InspectorModel` asks for them at the next tick), so they
never delay it.
"""

from __future__ import annotations

import threading
import time

import numpy as np

from eyelab.core.cache import LRUCache, content_key

#: The maps' grid: eye rotations within +-MAP_HALF_ANGLE_DEG (deg), MAP_POINTS^2 points.
MAP_HALF_ANGLE_DEG = 40.0
MAP_POINTS = 21
#: The maps the marker reads (AsWornMaps attributes): mean power error and cylinder (D).
MAP_NAMES = ("mean_error_d", "cylinder_d")
#: Maps kept (a lens toggled off and on, or a spec reloaded, finds its maps again).
MAPS_KEPT = 4


def maps_key(eye, lens, wavelength_nm: float) -> str | None:
    """The content key of the maps of ``lens`` worn by ``eye`` (None without a lens): what
    :func:`~eyelab.optics.lens.asworn.as_worn_maps` reads — the lens, the eye's centre of
    rotation, the wavelength (nm) and the grid."""
    if lens is None:
        return None
    return content_key(what="as_worn_maps", lens=lens, rotation_centre=eye.rotation_centre,
                       wavelength_nm=float(wavelength_nm), half_angle_deg=MAP_HALF_ANGLE_DEG,
                       n=MAP_POINTS)


def values_at(maps, a_deg: float, e_deg: float) -> dict:
    """The maps' values at eye rotation (a_deg right, e_deg up; Fick angles, deg): each of
    :data:`MAP_NAMES` (D) interpolated bilinearly between the four grid points about it;
    NaN outside the grid or where one of them has no light path (outside the lens)."""
    gx, gy = maps.eye_rotation_x_deg, maps.eye_rotation_y_deg
    out = {}
    inside = gx[0] <= a_deg <= gx[-1] and gy[0] <= e_deg <= gy[-1]
    i = min(max(int(np.searchsorted(gx, a_deg) - 1), 0), len(gx) - 2)
    j = min(max(int(np.searchsorted(gy, e_deg) - 1), 0), len(gy) - 2)
    tx = (a_deg - gx[i]) / (gx[i + 1] - gx[i])
    ty = (e_deg - gy[j]) / (gy[j + 1] - gy[j])
    w = np.array([[(1 - tx) * (1 - ty), tx * (1 - ty)], [(1 - tx) * ty, tx * ty]])
    for name in MAP_NAMES:
        z = np.asarray(getattr(maps, name), float)[j:j + 2, i:i + 2]     # (y, x)
        out[name] = float(np.sum(w * z)) if inside else float("nan")
    return out


class GazeMaps:
    """The as-worn maps of the lenses seen so far, by :func:`maps_key`, and at most one
    worker thread computing the maps of the latest key asked for (:meth:`want`).

    ``computed`` counts the maps computed (not found kept); ``compute_s`` is the time the
    last computation took (s); ``errors`` the one-line refusals by key (e.g. a lens given
    by its surfaces has no prescription to compare with)."""

    def __init__(self, kept: int = MAPS_KEPT):
        self._cache = LRUCache(kept, "as-worn maps")
        self._worker = None
        self._wanted = None          # (key, eye, lens, wavelength_nm) of the latest ask
        self.errors = {}
        self.computed = 0
        self.compute_s = 0.0

    def get(self, key):
        """The AsWornMaps of ``key``, or None (not computed yet, or refused)."""
        return None if key is None else self._cache.get(key)

    def state(self, key) -> str:
        """"none" (no lens), "ready", "computing" or the refusal's message."""
        if key is None:
            return "none"
        if key in self._cache:
            return "ready"
        return self.errors.get(key, "computing")

    def want(self, key, eye, lens, wavelength_nm: float) -> None:
        """Ask for the maps of ``key``: started on the worker thread unless kept, refused
        before or under way; a worker busy with another key finishes first (the ask is
        started by a later call, e.g. the next tick's)."""
        if key is None or key in self._cache or key in self.errors:
            return
        self._wanted = (key, eye, lens, float(wavelength_nm))
        if self.busy:
            return
        self._worker = threading.Thread(target=self._compute, args=self._wanted,
                                        name="eyelab-asworn-maps", daemon=True)
        self._worker.start()

    @property
    def busy(self) -> bool:
        return self._worker is not None and self._worker.is_alive()

    def _compute(self, key, eye, lens, wavelength_nm) -> None:
        from eyelab.core.errors import SpecError
        from eyelab.optics.lens.asworn import as_worn_maps

        t0 = time.perf_counter()
        try:
            maps = as_worn_maps(eye, lens, half_angle_deg=MAP_HALF_ANGLE_DEG, n=MAP_POINTS,
                                wavelength_nm=wavelength_nm)
        except SpecError as e:
            self.errors[key] = f"no as-worn maps: {e}"
            return
        except Exception as e:        # the window shows it; the maps must not stop it
            self.errors[key] = f"as-worn maps failed: {type(e).__name__}: {e}"
            return
        self.compute_s = time.perf_counter() - t0
        self.computed += 1
        self._cache.put(key, maps)

    def wait(self, timeout: float | None = None) -> None:
        """Wait for the worker (and start and wait for the latest ask, if it is not done)."""
        for _ in range(2):
            if self._worker is not None:
                self._worker.join(timeout)
            if self._wanted is None or self._wanted[0] in self._cache \
                    or self._wanted[0] in self.errors:
                return
            self.want(*self._wanted)

    def close(self) -> None:
        self._wanted = None
        if self._worker is not None:
            self._worker.join(10.0)
        self._cache.clear()


class GazeMapsMixin:
    """The inspector model's as-worn maps (:class:`~eyelab.jobs.inspector.InspectorModel`
    mixes it in; it provides ``spec``, ``lens``, ``value()``, ``maps_on``, ``gaze_maps``
    (a :class:`GazeMaps`) and ``_maps_key``, reset to None at each restart)."""

    #: The maps' grid: (half angle (deg), points per side).
    maps_grid = (MAP_HALF_ANGLE_DEG, MAP_POINTS)

    @property
    def maps_wanted(self) -> bool:
        """Whether the as-worn map panel is shown: switched on and a lens worn."""
        return self.maps_on and self.lens is not None

    def maps_key(self) -> str | None:
        """The current maps' content key (:func:`~eyelab.jobs.gazemaps.maps_key`; None
        without a lens), found once per state."""
        if self.lens is None:
            return None
        if self._maps_key is None:
            self._maps_key = maps_key(self._wearer(), self.lens, self.spec.wavelength_nm)
        return self._maps_key

    def _want_maps(self) -> None:
        if self.maps_wanted:
            self.gaze_maps.want(self.maps_key(), self._wearer(), self.lens,
                                self.spec.wavelength_nm)

    def _wearer(self):
        """The eye the maps are measured for (a schematic eye's centre of rotation and
        pupil on a thin eye: :func:`eyelab.jobs.maps.lens_wearer`)."""
        from eyelab.jobs.maps import lens_wearer

        return lens_wearer(self.eye)

    def maps(self):
        """The lens's as-worn maps (:class:`~eyelab.optics.lens.asworn.AsWornMaps` on
        :data:`~eyelab.jobs.gazemaps.MAP_POINTS`^2 eye rotations within
        +-:data:`~eyelab.jobs.gazemaps.MAP_HALF_ANGLE_DEG`), or None: no lens, not computed
        yet (:meth:`maps_state`) or refused."""
        return self.gaze_maps.get(self.maps_key())

    def maps_state(self) -> str:
        """"none" (no lens), "ready", "computing", or why there are no maps."""
        return self.gaze_maps.state(self.maps_key())

    def wait_maps(self) -> None:
        """Compute the maps now if they are wanted and not kept (scripted use)."""
        self._want_maps()
        self.gaze_maps.wait()

    def gaze_marker(self) -> dict | None:
        """The line of sight's point on the maps: ``eye_rotation_deg`` (right, up; the
        shown eye's Fick angles, deg: :meth:`eye_gaze`) and each map's value there (D,
        bilinear; NaN outside the maps or the lens); None while there are no maps."""
        maps = self.maps()
        if maps is None:
            return None
        a, e = (float(v) for v in self.eye_gaze())
        return {"eye_rotation_deg": (a, e), **values_at(maps, a, e)}
