"""The morph of the image-based lens model (Heidrich et al. 1997, §3.1): a slice image
mapped back onto the film grid through the rays' image-plane intersections — texture
coordinates, scan conversion of the grid's triangles, and the direct per-pixel morph of an
undeformed grid."""

from __future__ import annotations

import math

import numpy as np

from eyelab.render.imagebased.plan import Projection, _grid


def texcoords(pr: Projection) -> np.ndarray:
    """(g+1, g+1, 2) slice-image positions (pixels: x right, y down from the top-left
    corner) of the grid's projection rays."""
    right = np.cross(pr.forward, pr.up)
    d = pr.grid_dirs
    w = d @ pr.forward
    tx = (d @ right) / w / pr.tan_half[0]
    ty = (d @ pr.up) / w / pr.tan_half[1]
    sw, sh = pr.slice_size
    return np.stack([(tx + 1) * sw / 2, (1 - ty) * sh / 2], -1)


# ----------------------------------------------------------------------- morph
def rasterize(film_tri, attrs, width, height, covered, keep=None):
    """Scan-convert triangles onto the film (pixel centres at k + 0.5): film_tri (k, 3, 2)
    film pixels, attrs (k, 3, c) per-vertex attributes; ``covered`` (h*w,) bool marks
    pixels already given to an earlier triangle of the same sample (updated; each pixel
    belongs to one triangle). Returns (pixel indices (m,), attributes (m, c)) interpolated
    linearly (Gouraud: as the texture unit interpolates texture coordinates); ``keep``
    (attributes -> (m,) bool, or None) leaves pixels out before they are covered (a
    lenslet layer's, :func:`eyelab.render.imagebased.layers.keep_layer`)."""
    if len(film_tri) == 0:
        return np.zeros(0, int), np.zeros((0, attrs.shape[2]))
    lo = np.floor(film_tri.min(axis=1) - 0.5).astype(int) + 1
    hi = np.ceil(film_tri.max(axis=1) - 0.5).astype(int)
    lo = np.maximum(lo, 0)
    hi[:, 0] = np.minimum(hi[:, 0], width - 1)
    hi[:, 1] = np.minimum(hi[:, 1], height - 1)
    nx = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0)
    ny = np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    counts = nx * ny
    some = counts > 0
    if not some.any():
        return np.zeros(0, int), np.zeros((0, attrs.shape[2]))
    tri_id = np.repeat(np.flatnonzero(some), counts[some])
    start = np.repeat(np.cumsum(counts[some]) - counts[some], counts[some])
    local = np.arange(len(tri_id)) - start
    px = lo[tri_id, 0] + local % nx[tri_id]
    py = lo[tri_id, 1] + local // nx[tri_id]
    cx, cy = px + 0.5, py + 0.5
    a, b, c = film_tri[tri_id, 0], film_tri[tri_id, 1], film_tri[tri_id, 2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = ((cx - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (cy - a[:, 1])) / det
        l2 = ((b[:, 0] - a[:, 0]) * (cy - a[:, 1]) - (cx - a[:, 0]) * (b[:, 1] - a[:, 1])) / det
        l0 = 1 - l1 - l2                    # nan for a degenerate triangle: left out below
    eps = -1e-9
    inside = (l0 >= eps) & (l1 >= eps) & (l2 >= eps) & np.isfinite(l1) & np.isfinite(l2)
    idx = py * width + px
    inside &= ~covered[idx]
    tri_id, idx = tri_id[inside], idx[inside]
    l0, l1, l2 = l0[inside], l1[inside], l2[inside]
    idx, first = np.unique(idx, return_index=True)          # one triangle per pixel
    tri_id, l0, l1, l2 = tri_id[first], l0[first], l1[first], l2[first]
    at = attrs[tri_id]
    vals = l0[:, None] * at[:, 0] + l1[:, None] * at[:, 1] + l2[:, None] * at[:, 2]
    if keep is not None:
        mine = keep(vals)
        idx, vals = idx[mine], vals[mine]
    covered[idx] = True
    return idx, vals


def morph_pixels(pr: Projection, width, height, covered, keep=None):
    """The film pixels the projection's grid gives colour to and their interpolated
    attributes (slice x, slice y, W x transmittance, W; a layer's sites x, y after them)
    — what :func:`rasterize` returns for :func:`grid_triangles` — with ``covered`` updated
    the same way; ``keep`` as :func:`rasterize`'s.

    A grid that vignetting left undeformed (every point where :func:`_grid` put it, every
    ray passed) is a regular lattice: each pixel centre's quad and its triangle (the
    quad split along the c00-c11 diagonal, as :func:`grid_triangles` splits it) follow
    from two floors, without scan conversion (3-5x faster); a deformed grid is scan
    converted. Pixel centres on the cell's right or bottom edge belong to the neighbour."""
    g = pr.grid_film.shape[0] - 1
    if not (pr.grid_ok.all() and np.array_equal(pr.grid_film, _grid(pr.cell, g))):
        tri_f, tri_a = grid_triangles(pr)
        return rasterize(tri_f, tri_a, width, height, covered, keep)
    x0, y0, x1, y1 = pr.cell
    ix = np.arange(max(math.ceil(x0 - 0.5), 0), min(math.ceil(x1 - 0.5), width))
    iy = np.arange(max(math.ceil(y0 - 0.5), 0), min(math.ceil(y1 - 0.5), height))
    att = grid_attributes(pr).astype(np.float64 if pr.grid_site is not None else np.float32)
    if not (len(ix) and len(iy)):
        return np.zeros(0, int), np.zeros((0, att.shape[-1]))
    u = (ix + 0.5 - x0) * (g / (x1 - x0))
    v = (iy + 0.5 - y0) * (g / (y1 - y0))
    i = np.minimum(u.astype(int), g - 1)
    j = np.minimum(v.astype(int), g - 1)
    fu = (u - i).astype(att.dtype)[None, :]
    fv = (v - j).astype(att.dtype)[:, None]
    # each triangle's attributes are affine: value at c00 + fu * x-step + fv * y-step;
    # table (g, g, 2 triangles, 3 coefficients, c attributes), one gather per pixel
    c00, c10, c01, c11 = att[:-1, :-1], att[:-1, 1:], att[1:, :-1], att[1:, 1:]
    table = np.stack([np.stack([c00, c10 - c00, c11 - c10], -2),     # (c00, c10, c11)
                      np.stack([c00, c11 - c01, c01 - c00], -2)], -3)  # (c00, c11, c01)
    k = ((j[:, None] * g + i[None, :]) * 2 + (fu < fv)).ravel()
    coef = table.reshape(-1, 3, att.shape[-1])[k]
    shape = (len(iy), len(ix))
    vals = (coef[:, 0] + np.broadcast_to(fu, shape).reshape(-1, 1) * coef[:, 1]
            + np.broadcast_to(fv, shape).reshape(-1, 1) * coef[:, 2])
    idx = (iy[:, None] * width + ix[None, :]).ravel()
    free = ~covered[idx]
    idx, vals = idx[free], vals[free]
    if keep is not None:
        mine = keep(vals)
        idx, vals = idx[mine], vals[mine]
    covered[idx] = True
    return idx, vals


def grid_attributes(pr: Projection) -> np.ndarray:
    """(g+1, g+1, 4) per grid point: slice x, slice y, W x transmittance, W; (g+1, g+1,
    6) for a lenslet layer's projection, its sites (m) after them."""
    cols = [texcoords(pr), (pr.grid_weight * pr.grid_transmittance)[..., None],
            pr.grid_weight[..., None]]
    if pr.grid_site is not None:
        cols.append(pr.grid_site)
    return np.concatenate(cols, -1)


def grid_triangles(pr: Projection):
    """(film triangles (k, 3, 2), attributes (k, 3, c): :func:`grid_attributes`) of the
    projection's grid quads whose four corners' rays passed."""
    f = pr.grid_film
    ok = pr.grid_ok
    quad_ok = ok[:-1, :-1] & ok[1:, :-1] & ok[:-1, 1:] & ok[1:, 1:]
    j, i = np.nonzero(quad_ok)
    att = grid_attributes(pr)
    c00, c10 = (j, i), (j, i + 1)
    c01, c11 = (j + 1, i), (j + 1, i + 1)
    tri_f = np.concatenate([np.stack([f[c00], f[c10], f[c11]], 1),
                            np.stack([f[c00], f[c11], f[c01]], 1)])
    tri_a = np.concatenate([np.stack([att[c00], att[c10], att[c11]], 1),
                            np.stack([att[c00], att[c11], att[c01]], 1)])
    return tri_f, tri_a


def bilinear(img, x, y):
    """(m, c) samples of img (h, w, c) at continuous pixel positions (x right, y down,
    pixel centres at k + 0.5), clamped at the border: the texture unit's bilinear filter."""
    h, w = img.shape[:2]
    fx = np.clip(x - 0.5, 0, w - 1)
    fy = np.clip(y - 0.5, 0, h - 1)
    x0 = np.minimum(np.floor(fx).astype(int), w - 2 if w > 1 else 0)
    y0 = np.minimum(np.floor(fy).astype(int), h - 2 if h > 1 else 0)
    tx, ty = fx - x0, fy - y0
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    a = img[y0, x0] * ((1 - tx) * (1 - ty))[:, None] + img[y0, x1] * (tx * (1 - ty))[:, None]
    return a + img[y1, x0] * ((1 - tx) * ty)[:, None] + img[y1, x1] * (tx * ty)[:, None]
