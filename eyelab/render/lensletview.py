"""The lens view through a lenslet lens (the multi-image method,
:mod:`eyelab.scene.lensletrays`), in linear light:

    view = carrier view x (1 - share) + (1/K) sum_k lenslet view_k,

the carrier's view (:meth:`~eyelab.render.composite.LensCompositor.lens_view`: the
blurred environment image at the grid's texture coordinates) weighted per vertex by the
share of its pupil samples that miss the lenslets, and per pupil sample k the light of the
rays that meet them: the grid's coordinates moved by that sample's offsets, weighted by
whether the vertex's ray meets a lenslet, from the environment image spread by the
sample's share of the pupil (:func:`~eyelab.scene.lensletrays.cell_sigma`). Work follows
the lenslets: a sample whose rays meet none is not drawn, a moved view rasterises only the
triangles with a vertex whose ray meets a lenslet, and is read only in the rectangle they
can reach; the moved views are summed in 16-bit linear light
(:class:`~eyelab.render.accumulate.PassAccumulator`).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter

from eyelab.core.color import decode_srgb
from eyelab.core.parallel import on_worker
from eyelab.render.accumulate import PassAccumulator, encode_linear

#: Below this spread (environment pixels) the lenslet views sample the environment image
#: as it is.
MIN_SPREAD_PX = 0.3


#: Moved views drawn between two pauses of :func:`lenslet_lens_view` (an interactive
#: window's tick: 21-29 ms a view at 800 x 600 on the CPU's GL, llvmpipe on 2 cores, so
#: that a tick stays under 0.1 s).
VIEWS_PER_STEP = 2


def lenslet_lens_view(compositor, env_rgba, geo, offsets, grid_key, cam, spread_px,
                      report):
    """A generator pausing (None) after the carrier's view and every
    :data:`VIEWS_PER_STEP` moved views, and while a worker thread spreads the environment
    image (numpy and scipy), whose value is (h, w, 3) uint8, row 0 at the top: the view
    (module doc) of ``offsets``
    (:class:`~eyelab.scene.lensletrays.LensletOffsets`) on the lens grid of ``geo``
    (:func:`~eyelab.render.stages.lens_geometry`'s) seen from the eye camera ``cam``;
    ``env_rgba`` the environment image (GL order), ``spread_px`` the sample's spread in
    its pixels."""
    uv, trans = geo["tc_grid"].uv, geo["transmittance"]
    n = len(geo["grid_v"])
    t = np.ones((3, n)) if trans is None else np.broadcast_to(np.asarray(trans), (3, n))
    share = offsets.share
    key = (grid_key, "carrier share", hash(share.tobytes()))
    base = compositor.lens_view(env_rgba, geo["grid_v"], geo["grid_f"], uv,
                                t * (1.0 - share), key)
    total = decode_srgb(base)
    k_all = len(offsets.active)
    active = np.flatnonzero(offsets.active)
    rect = moved_rect(geo["grid_v"], geo["grid_f"], offsets.through.any(0), cam,
                      base.shape[:2])
    if rect is not None and len(active):
        x0, y0, x1, y1 = rect
        h = base.shape[0]
        yield None
        spread = yield from on_worker(lambda: spread_env(env_rgba, spread_px))
        faces = geo["grid_f"]
        moves = ((offsets.offsets[k], offsets.through[k].astype(float),
                  faces[offsets.through[k][faces].any(1)]) for k in active)
        acc = PassAccumulator(y1 - y0, x1 - x0)
        for i, rgba in enumerate(compositor.moved_views(spread, uv, t, moves, rect)):
            acc.add(rgba)
            if i % VIEWS_PER_STEP == VIEWS_PER_STEP - 1:
                yield None
        # the moved views' mean, as a share of all K samples
        total[h - y1:h - y0, x0:x1] += acc.mean_linear() * np.float32(len(active) / k_all)
    report["details"]["lenslets"] = {
        "pupil_samples": k_all, "moved_views": int(len(active)),
        "moved_rect_px": None if rect is None else [int(v) for v in rect],
        "sample_spread_env_px": float(spread_px),
        "vertex_share_max": float(share.max(initial=0.0)),
        "rays_failed": int(offsets.failed)}
    return encode_linear(total)


def spread_env(env_rgba, sigma_px: float) -> np.ndarray:
    """The environment image (h, w, 4) uint8 blurred by a Gaussian of ``sigma_px`` in
    linear light (itself below :data:`MIN_SPREAD_PX`)."""
    if sigma_px < MIN_SPREAD_PX:
        return env_rgba
    lin = decode_srgb(env_rgba[..., :3])
    out = env_rgba.copy()
    out[..., :3] = encode_linear(gaussian_filter(lin, (sigma_px, sigma_px, 0),
                                                 mode="nearest"))
    return out


def moved_rect(grid_v, grid_f, moved, cam, shape) -> tuple | None:
    """(x0, y0, x1, y1) (GL order: row 0 at the bottom; x1, y1 exclusive) the pixels of the
    triangles of ``grid_f`` with a moved vertex (``moved`` (n,) bool) — the grid's vertices
    ``grid_v`` seen from ``cam`` in a view of ``shape`` (h, w) — with a pixel of margin;
    None if none moves."""
    tri = grid_f[moved[grid_f].any(1)]
    if not len(tri):
        return None
    h, w = shape
    ndc = cam.world_to_ndc(grid_v[np.unique(tri)])
    px = (ndc[:, 0] + 1) * 0.5 * w
    py = (ndc[:, 1] + 1) * 0.5 * h
    x0 = int(np.clip(np.floor(px.min()) - 1, 0, w - 1))
    x1 = int(np.clip(np.ceil(px.max()) + 1, x0 + 1, w))
    y0 = int(np.clip(np.floor(py.min()) - 1, 0, h - 1))
    y1 = int(np.clip(np.ceil(py.max()) + 1, y0 + 1, h))
    return x0, y0, x1, y1
