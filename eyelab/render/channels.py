"""Colour channels rendered apart only where they differ.

Where the eye's chromatic aberration or a lens's dispersion gives each colour channel its
own blur field, a pass displaces every vertex by each channel's own matrix, and so draws
the view once per channel (Kakimoto et al. 2007, §4.5, per wavelength). But where every
channel's pass displacement is the same — in focus, or where the channels' blurs differ by
less than a pixel's footprint — the channels' renders are the same image. A pass therefore
draws the whole view once, with the first channel's field, and draws the other channels
again only inside the rectangles where some channel's displacement differs from the first's
by more than :data:`CHANNEL_TOL_PX`, widened by how far any displaced copy can reach. The
rectangles are found once per frame, from the first pass's depth buffer. A rectangle's
render costs what the geometry inside it costs (the background is all but free): where the
rectangles would hold most of the view's surfaces, each channel draws the whole view
instead (:data:`RECTS_MAX_SHARE`).

Pure numpy and scipy (the rectangles); the renders are :class:`~eyelab.render.window.
OffscreenWindow`'s.
"""

from __future__ import annotations

import numpy as np

#: Channels agree where the blurs their passes make differ by at most this (px): drawn with
#: the first channel's displacement B0 instead of its own B, a channel's blur covariance
#: B0 B0^T / 4 differs from its own by at most (CHANNEL_TOL_PX / 2)^2 = 0.0625 px^2 (the
#: spectral norm), less than the pixel's own footprint (1/12 px^2). The passes' seeds
#: average to the disc's covariance whatever the matrix's sign (eyelab.core.sampling), so
#: the two sides of focus, B and -B, agree.
CHANNEL_TOL_PX = 0.5

#: Side (px) of the tiles the disagreement is mapped on.
TILE_PX = 32

#: A render's fixed cost as pixels of fill: two rectangles are drawn as one (their
#: bounding box) when that fills fewer extra pixels than this. Measured with llvmpipe on the
#: built-in room at 1024 x 768 (`OffscreenWindow.grab_rect_rgba`): 1.1 ms for a 32 x 32
#: rectangle, 4.95 ms for the 1024 x 192 band of floor, page and boxes (~20 ns per pixel of
#: dense geometry), 7.6 ms for the whole view: a render's overhead is worth ~55k pixels.
RENDER_COST_PX = 60_000

#: The largest share of the view's surface pixels the rectangles may hold: beyond it each
#: channel draws the whole view (measured as above: a rectangle holding 90 % of the room's
#: surfaces, 1024 x 544 of 1024 x 768, took 6.7 ms against the whole view's 6.0 ms).
RECTS_MAX_SHARE = 0.6


def compensated_stage(fields, passes: int, size, seeds) -> tuple:
    """(fields the passes displace by, reconstruction state, their channel spread) of a
    stage's ``fields`` (one per colour channel) at ``passes`` = S with ``seeds`` (S, 2), in
    a window of ``size`` = (w, h) px: each channel its own filter (the eye's longitudinal
    colour leaves one channel sharp and another blurred), sized by its map's covariance and
    reach, and its field variance-compensated for it
    (:func:`~eyelab.blur.reconstruct.compensated`) — one filter for all where they agree
    (:func:`~eyelab.blur.reconstruct.channel_volumes`). The state: the fields' pixel
    SVDs, their reaches (None for second-order fields) and sigma volumes (one, or one
    per channel)."""
    from eyelab.blur.reconstruct import (
        channel_volumes,
        compensated,
        map_reach_px,
        pixel_svd,
    )

    svds = [pixel_svd(f, size) for f in fields]
    reaches = map_reach_px(fields, size)
    vols = channel_volumes(svds, passes, reaches)
    per_field = vols * len(fields) if len(vols) == 1 else vols      # shared, or each own
    shrunk = [compensated(f, svd, vol, size, seeds)
              for f, svd, vol in zip(fields, svds, per_field, strict=True)]
    for f in shrunk:                   # the passes' displacements multiply these rows
        if f.has_aberration:
            f.active_rows()
    return shrunk, {"svds": svds, "sigma": vols, "reaches": reaches}, channel_spread(
        shrunk, size)


def channel_spread(fields, size) -> dict | None:
    """Per voxel of per-channel ``fields`` (those the passes displace by) in a window of
    ``size`` = (w, h) px: "diff" (nz, ny, nx) px, the largest difference of a channel's
    blur from the first's, sqrt(||B B^T - B0 B0^T||) of the pixel-scaled matrices
    (spectral norm: for round blurs of semi-axes a and a0, sqrt|a^2 - a0^2|), and "reach"
    (nz, ny, nx) px, the largest displacement of any channel. None for one field."""
    if len(fields) < 2:
        return None
    from eyelab.core.vecmath import svd2x2

    px = np.array([size[0] / 2, size[1] / 2])[:, None]
    def cov(m):
        return m @ np.swapaxes(m, -1, -2)

    m0 = fields[0].blur_matrix() * px
    c0 = cov(m0)
    mu0 = fields[0].mean_offset() * px[:, 0]
    diff = np.zeros(fields[0].matrix.shape[:3])
    reach = svd2x2(m0)[1][..., 0] + np.linalg.norm(mu0, axis=-1)
    for f in fields[1:]:
        m = f.blur_matrix() * px
        mu = f.mean_offset() * px[:, 0]
        # a map's centre moves too (the eye's lateral colour): that counts in full
        diff = np.maximum(diff, np.linalg.norm(mu - mu0, axis=-1))
        reach = np.maximum(reach, np.linalg.norm(mu, axis=-1) + svd2x2(m)[1][..., 0])
        # the symmetric difference's spectral norm is its largest |eigenvalue|
        d = cov(m) - c0
        mean, half = (d[..., 0, 0] + d[..., 1, 1]) / 2, np.hypot(
            (d[..., 0, 0] - d[..., 1, 1]) / 2, d[..., 0, 1])
        diff = np.maximum(diff, np.sqrt(np.abs(mean) + half))
        reach = np.maximum(reach, svd2x2(m)[1][..., 0])
    return {"diff": diff, "reach": reach}


def disagreeing_rects(spread: dict, voxels: dict) -> list:
    """The rectangles (x0, y0, x1, y1) (GL order: row 0 at the bottom; x1, y1 exclusive)
    that the other channels must be drawn in: tiles of :data:`TILE_PX` holding a surface
    pixel whose channels disagree (``spread`` of :func:`channel_spread` looked up through
    ``voxels``, :func:`eyelab.blur.reconstruct.pixel_voxels` of the first pass's depth
    buffer), widened by the largest reach of those pixels (+ 2 px: jitter and rounding),
    each connected group of tiles one rectangle (its bounding box), rectangles merged where
    :data:`RENDER_COST_PX` says one render is cheaper (:func:`merge_boxes`; a pixel in two
    rectangles is drawn twice, the same both times); the whole view alone where they would
    hold more than :data:`RECTS_MAX_SHARE` of its surface pixels. Empty where the channels
    agree."""
    from scipy.ndimage import find_objects, label, maximum_filter

    h, w = voxels["shape"]
    vox = voxels["voxel"]                                  # every 2nd pixel, top row first
    diff = np.concatenate([[0.0], spread["diff"].ravel()])[vox]
    dyn = diff > CHANNEL_TOL_PX
    if not dyn.any():
        return []
    reach = float(np.concatenate([[0.0], spread["reach"].ravel()])[vox][dyn].max()) + 2.0
    t = TILE_PX // 2                                       # tile side in evaluated pixels
    ty, tx = -(-dyn.shape[0] // t), -(-dyn.shape[1] // t)
    pad = np.zeros((ty * t, tx * t), bool)
    pad[:dyn.shape[0], :dyn.shape[1]] = dyn
    tiles = pad.reshape(ty, t, tx, t).any((1, 3))
    k = min(int(np.ceil(reach / TILE_PX)), max(ty, tx))   # past the window: all of it
    tiles = maximum_filter(tiles, size=2 * k + 1, mode="constant")
    labels, n = label(tiles)
    boxes = [[s[0].start, s[0].stop, s[1].start, s[1].stop] for s in find_objects(labels)]
    boxes = merge_boxes(boxes, RENDER_COST_PX / TILE_PX**2)
    t = TILE_PX
    rects = [(c0 * t, max(h - r1 * t, 0), min(c1 * t, w), h - r0 * t)
             for r0, r1, c0, c1 in boxes]
    fg = vox > 0                                           # surface pixels, top row first
    inside = np.zeros_like(fg)
    for x0, y0, x1, y1 in rects:                           # GL order -> top-first rows
        inside[(h - y1) // 2:-(-(h - y0) // 2), x0 // 2:-(-x1 // 2)] = True
    if (fg & inside).sum() > RECTS_MAX_SHARE * max(int(fg.sum()), 1):
        return [(0, 0, w, h)]
    return rects


def merge_boxes(boxes: list, cost: float) -> list:
    """Boxes [r0, r1, c0, c1] (half-open) merged pairwise, cheapest first, while drawing
    two as their bounding box fills fewer extra cells than ``cost`` (a render's fixed cost
    in cells) — which also merges overlapping boxes."""
    boxes = [list(b) for b in boxes]

    def area(b):
        return (b[1] - b[0]) * (b[3] - b[2])

    while len(boxes) > 1:
        best = None
        for i in range(len(boxes)):
            for j in range(i + 1, len(boxes)):
                a, b = boxes[i], boxes[j]
                u = [min(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), max(a[3], b[3])]
                extra = area(u) - area(a) - area(b)
                if extra < cost and (best is None or extra < best[0]):
                    best = (extra, i, j, u)
        if best is None:
            break
        _, i, j, u = best
        boxes = [b for k, b in enumerate(boxes) if k not in (i, j)] + [u]
    return boxes


def rects_area(rects) -> int:
    """Pixels covered by non-overlapping ``rects`` (x0, y0, x1, y1)."""
    return int(sum((x1 - x0) * (y1 - y0) for x0, y0, x1, y1 in rects))


def pass_steps(st: dict, k: int, route: str, offload: bool = False):
    """A generator pausing (None) after each colour channel's render (an interactive
    window's tick) whose value is pass ``k`` of a raster stage ``st``
    (:mod:`eyelab.render.raster`) as GL-ordered RGBA uint8: one render, or with
    per-channel fields the whole view with the first channel's field and, inside the
    rectangles of :func:`disagreeing_rects` (found on pass 0 from its depth buffer, kept
    in ``st["rects"]``), each other channel with its own (the same seed and jitter), of
    which each gives its own colour channel. With ``offload`` the rectangles are found on
    a worker thread (numpy and scipy: the window's ticks go on meanwhile)."""
    from eyelab.blur.reconstruct import pixel_voxels
    from eyelab.core.parallel import on_worker
    from eyelab.render.stages import select_channel

    win = st["win"]
    fields = st["fields"]
    baked = any(f.has_aberration for f in fields)
    if baked or len(fields) > 1:        # the first channel (its pass's own texture)
        select_channel(st, 0, route, k)
    win.set_seed((1.0, 0.0) if baked else st["seeds"][k], st["jitter"][k])
    whole = win.grab_rgba()
    if len(fields) == 1:
        return whole
    out = st["rgba"]
    if "rects" not in st:       # the undisplaced depth (raster._passes), else this pass's
        if "zbuf" not in st:
            st["zbuf"] = win.depth()
        whole = whole.copy()    # the window's buffer is reused by the next grab

        def find():
            st["voxels"] = pixel_voxels(st["zbuf"], st["cam"], fields[0])
            return disagreeing_rects(st["spread"], st["voxels"])

        st["rects"] = (yield from on_worker(find)) if offload else find()
        st["whole_view"] = st["rects"] == [(0, 0, out.shape[1], out.shape[0])]
    if not st["rects"]:                 # every channel is the first's: one render
        return whole
    if st["whole_view"]:                # the others are drawn whole: only the first kept
        out[..., 0] = whole[..., 0]
    else:
        np.copyto(out, whole)
    for c in range(1, len(fields)):     # the seed uniforms stay set across channels
        yield None
        select_channel(st, c, route, k)
        if st["whole_view"]:
            out[..., c] = win.grab_rgba()[..., c]
            continue
        for x0, y0, x1, y1 in st["rects"]:
            out[y0:y1, x0:x1, c] = win.grab_rect_rgba((x0, y0, x1, y1))[..., c]
    out[..., 3] = 255
    return out


def note_channels(st: dict, label: str, report: dict) -> None:
    """Once per frame and stage: the report's ``details.channels[label]`` (rectangles drawn
    per channel, their share of the view, renders per pass) and, where that saves renders,
    the skipped work."""
    if "rects" not in st or st.get("noted"):
        return
    st["noted"] = True
    n = len(st["fields"])
    h, w = st["acc"].shape
    share = rects_area(st["rects"]) / float(w * h)
    report["details"].setdefault("channels", {})[label] = {
        "channels": n, "rects": [list(map(int, r)) for r in st["rects"]],
        "area_fraction": share, "renders_per_pass": 1 + (n - 1) * len(st["rects"])}
    if share < 1.0:
        report["skipped"].append(
            f"{label}: the {n} colour channels' displacements agree outside "
            f"{len(st['rects'])} rectangle(s) ({100 * share:.0f} % of the view): one render "
            f"per pass there instead of {n}")
