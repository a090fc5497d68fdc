"""What a render of a schematic eye's retinal image shares between the renderers: the
eye's one accommodation for the view (the fixation's)."""

from __future__ import annotations

import math

import numpy as np

from eyelab.core.cache import LRUCache, content_key
from eyelab.optics.chain.retina import fixation_accommodation
from eyelab.optics.chain.retinal_rays import camera_frame
from eyelab.optics.eye.thin import EYE_REFERENCE_NM
from eyelab.optics.rays.trace import FATAL

#: The accommodations found (a render's warm frames ask again), by the content of what
#: decides them.
_FOUND = LRUCache(64, "fixation accommodation")


def fixation_view(scene, eye, lens, view):
    """``view`` with the schematic eye's one accommodation as its focus
    (:func:`view_accommodation`): how every renderer's frames draw a schematic eye's
    retinal image at fixation (:meth:`~eyelab.imaging.contract.Renderer.render`, the
    inspector's frames)."""
    return view.replace(focus_d=view_accommodation(scene, eye, lens, view))


def view_accommodation(scene, eye, lens, view, inter=None) -> float:
    """The schematic eye's accommodation (D, the model's) for ``view``: ``view.focus_d``
    clipped to the eye's range, else the one that focuses the scene point it fixates (the
    first hit along its axis, through the lens; at infinity where the axis hits nothing).
    ``inter``: the scene's intersector, if the caller has one."""
    if view.focus_d is not None:
        return float(min(max(view.focus_d, 0.0), eye.accommodation_max))
    key = content_key(scene=scene.content_key, eye=eye, lens=lens,
                      camera=view.camera(eye.rotation_centre))
    return _FOUND.get_or_create(key, lambda: _fixation(scene, eye, lens, view, inter))[0]


def _fixation(scene, eye, lens, view, inter) -> float:
    from eyelab.optics.lens.lenslets import carrier

    lens = carrier(lens)            # a lenslet lens: the eye focuses its carrier's image
    if inter is None:
        from eyelab.scene.raycast import scene_intersector

        inter = scene_intersector(scene)
    rot, vertex = camera_frame(view.camera(eye.rotation_centre))
    o, d = vertex[None], -rot[:, 2][None]
    if lens is not None:
        r = lens.trace(o, d, EYE_REFERENCE_NM, reverse=True)
        if (r["status"][0] & np.uint8(FATAL)) == 0:
            o, d = r["out_points"], r["out_dirs"]
    t = float(inter.intersect(o + 1e-7 * d, d).t[0])
    dist = float(np.linalg.norm(o[0] + t * d[0])) if math.isfinite(t) else math.inf
    return float(fixation_accommodation(eye, lens, dist, EYE_REFERENCE_NM, rot=rot,
                                        vertex=vertex)[0])
