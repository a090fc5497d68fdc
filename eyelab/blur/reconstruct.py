"""Reconstruction filter for images made of S displaced copies (Kakimoto 2007, §4.5).

S passes sample each pixel's blur ellipse at S points, which ghosts when the ellipse spans
many pixels. Each pixel is smoothed by a Gaussian shaped like its own blur ellipse: along
the ellipse's major axis its sigma is :data:`RECON_SIGMA` times the spacing of the S
samples in the ellipse (at most :data:`RECON_MAX_FRACTION` of that axis's variance),
along the minor axis the same but at most what the minor semi-axis allows, found per voxel
from the field and per pixel from the depth buffer; in-focus pixels are untouched. It
runs as an isotropic Gaussian of the minor-axis sigma (:func:`variable_gaussian`) and a
1-D Gaussian along the major axis for the rest (:func:`directional_gaussian`).

A filter adds its covariance to the blur's B (I/4) B^T (averaging copies adds
covariances), so a filtered image would be blurrier than the eye's. The filter is
therefore variance-compensated: the passes displace by a shrunk matrix B' whose
covariance plus the filter's is the blur's (:func:`compensated`), so disc + Gaussian keep
the blur's second moments (tested on a rendered point). Pure numpy / scipy.
"""

from __future__ import annotations

import functools

import numpy as np

#: Reconstruction Gaussian sigma in units of the spacing of the S samples in a blur
#: ellipse. 0.7 (with the variance compensation; 0.5 before it, when a wider filter made
#: the blur too large): swept at 1024x768 against the converged references on the three
#: largest-blur cases (tilted page +3 D lens wearer and presbyope, 6 m chart oblique
#: astigmat; 0.5 / 0.6 / 0.7 / 0.85 / 1.0 at S = 8 and 32): 0.7 is best or within 0.005
#: SSIM of the best on each at S = 32.
RECON_SIGMA = 0.7

#: The largest share of the major axis's blur variance that the Gaussian may carry
#: (sigma <= sqrt(RECON_MAX_FRACTION) x semi-axis / 2): beyond it the blur takes the
#: Gaussian's shape instead of the disc's (at S = 8 without it the tilted page's SSIM fell
#: from 0.977 to 0.936).
RECON_MAX_FRACTION = 0.4

#: Sigmas below this (px) are not filtered (and their voxels not compensated).
MIN_SIGMA = 0.25

#: The 1-D Gaussian along the major axis runs where its sigma is at least this (px);
#: below it the filter stays round and the major axis is compensated only by the round
#: part (:func:`sigma_volume`), so the blur's variance is kept either way.
MIN_LINE_SIGMA = 0.5


def pixel_svd(field, size) -> tuple:
    """(u, s, vt): the SVD of ``field``'s (nz, ny, nx, 2, 2) matrices scaled to pixels of a
    ``size`` = (w, h) window (NDC x, y per unit seed -> px); s (nz, ny, nx, 2) are the blur
    ellipse's semi-axes a >= b, u's first column its major axis (x right, y up). Computed
    once per field and window, shared by :func:`sigma_volume` and :func:`compensated`."""
    from eyelab.core.vecmath import svd2x2

    px = np.array([size[0] / 2, size[1] / 2])
    return svd2x2(field.blur_matrix() * px[:, None])


def map_reach_px(fields, size) -> list | None:
    """Per field, (nz, ny, nx) px: how far a pass can move light in a ``size`` = (w, h)
    window — for a ray-aberration map the sum of its terms' lengths (each monomial of the
    pupil point is at most 1 on the unit disc: a bound on coma's tail, spherical
    aberration's rim and the lateral colour's shift together); None when no field has
    such a map (then the ellipse's semi-axis is the reach)."""
    if not any(f.has_aberration for f in fields):
        return None
    from eyelab.blur.aberration import full_coefficients

    px = np.array([size[0] / 2, size[1] / 2])
    return [f.on_active(lambda m, a: np.linalg.norm(
        full_coefficients(m, a) * px[:, None], axis=-2).sum(-1), f.matrix, f.aberration)
        if f.has_aberration else np.zeros(f.matrix.shape[:3]) for f in fields]


def sigma_volume(svds, passes: int, reaches=None) -> dict:
    """Per voxel, (nz, ny, nx) px arrays from the fields' :func:`pixel_svd` ``svds`` (one per
    field or colour channel, on one voxel grid): "major" / "minor" the reconstruction
    sigmas along the blur ellipse's axes, "u" (nz, ny, nx, 2) the major axis's unit
    direction (x right, y up), "reach" the largest semi-axis + 2 sigma (how far blurred
    light spreads). With spacing max(sqrt(pi a b / S), 2 a / S) of ``passes`` = S samples
    in an ellipse of semi-axes a >= b: major = min(RECON_SIGMA spacing, sqrt(F) a / 2)
    (F = RECON_MAX_FRACTION), minor = min(major, b / 2) (what the minor axis's variance can
    give: the filter is round unless the ellipse is elongated); the smallest over the
    fields (never over-filters a channel). What the filter would skip is not asked of it
    (a skip removes work, not variance): a minor sigma below MIN_SIGMA becomes 0, and a
    major one whose 1-D part sqrt(major^2 - minor^2) falls below MIN_LINE_SIGMA becomes
    the minor one — so the compensation removes exactly what the filter adds.
    ``reaches``: None, or per field (nz, ny, nx) px, the farthest a ray-aberration map
    moves light (:func:`map_reach_px`), the reach where it exceeds the semi-axis."""
    root_f = np.sqrt(RECON_MAX_FRACTION)
    major = minor = reach = None
    for i, (_, sv, _) in enumerate(svds):
        a, b = sv[..., 0], sv[..., 1]
        spacing = np.maximum(np.sqrt(np.pi * a * b / passes), 2 * a / passes)
        ma = np.minimum(RECON_SIGMA * spacing, root_f * a / 2)
        mi = np.minimum(ma, b / 2)
        major = ma if major is None else np.minimum(major, ma)
        minor = mi if minor is None else np.minimum(minor, mi)
        far = a if reaches is None else np.maximum(a, reaches[i])
        reach = far if reach is None else np.maximum(reach, far)
    minor = np.where(minor < MIN_SIGMA, 0.0, minor)
    major = np.where(major**2 - minor**2 < MIN_LINE_SIGMA**2, minor, major)
    return {"major": major, "minor": minor, "u": svds[0][0][..., :, 0],
            "reach": reach + 2 * major}


def compensated(field, svd, vol: dict, size, seeds=None):
    """A copy of ``field`` whose (nz, ny, nx, 2, 2) matrices B (NDC per unit seed) are
    shrunk so that, in pixels of a ``size`` = (w, h) window, B' (I/4) B'^T plus the
    filter's covariance (``vol`` of :func:`sigma_volume`: sigma "major" along the blur's
    major axis, "minor" across it) is B (I/4) B^T: each singular value s of the
    pixel-scaled matrix (``svd``, the field's :func:`pixel_svd`) becomes
    sqrt(max(s^2 - 4 sigma^2, 0)), axes kept (exact, as sigma <= s / 2 by construction;
    for per-channel fields each channel's own axes, the filter's from the first channel).
    The passes then displace by B' and the filter supplies the rest of the blur's
    variance.

    A field with a ray-aberration map (``field.aberration``): B is the map's
    covariance-equivalent matrix (:meth:`~eyelab.blur.field.BlurField.blur_matrix`), and
    the map about its mean is transformed linearly (every coefficient but the mean's) so
    that its covariance over the passes' ``seeds`` (S, 2) (None: over the disc) becomes
    B' (I/4) B'^T — its shape (the comet, the ring) kept, its mean (where the blur's light
    is centred) unchanged; over few seeds a cubic map's spread falls short of the disc's,
    and the transform makes it up."""
    import dataclasses

    from eyelab.core.cache import content_key

    px = np.array([size[0] / 2, size[1] / 2])
    u, s, vt = svd
    sig = np.stack([vol["major"], vol["minor"]], -1)
    s2 = np.sqrt(np.maximum(s**2 - 4 * sig**2, 0.0))
    key = content_key(field=field.key, sigma=np.asarray(sig, np.float32),
                      size=list(size), kind="variance-compensated",
                      seeds=None if seeds is None else np.asarray(seeds, float))
    if field.aberration is None:
        matrix = ((u * s2[..., None, :]) @ vt) / px[:, None]
        return dataclasses.replace(field, matrix=matrix, key=key)
    from eyelab.blur.aberration import HIGHER, full_coefficients, seed_moments, sym_power

    # The passes draw the map at S seeds: T takes the map's covariance over them, A (for
    # a cubic map over 8 seeds short of the disc's), to the target C_t = B' (I/4) B'^T:
    # T = C_t^(1/2) A^(-1/2) (for a linear map and a pass set, U diag(s'/s) U^T); only
    # the voxels whose map is not zero (the field's active ones) are worked on
    mu_phi, gram = seed_moments(seeds)
    pm = np.diag(px)
    c0 = HIGHER.index(0)
    mean_map = field.mean_offset()

    def shrink(m, ab, uu, ss2, mean):
        coef = full_coefficients(m, ab)                               # NDC per term
        cp = pm @ coef                                                # px per term
        a = (cp @ gram) @ np.swapaxes(cp, -1, -2)
        c_t = (uu * (ss2**2 / 4)[:, None, :]) @ np.swapaxes(uu, -1, -2)
        t_px = sym_power(c_t, 0.5) @ sym_power(a, -0.5)
        t = t_px * (px[None, :] / px[:, None])                    # P^-1 T_px P, in NDC
        higher = t @ ab
        # the constant c' keeps the passes' mean on the map's: c' = mean - T (mu_s - c),
        # mu_s the unshrunk map's mean over the seeds (the disc's mean for a pass set)
        mu_s = coef @ mu_phi
        higher[..., c0] = mean - (t @ (mu_s - ab[..., c0])[..., None])[..., 0]
        return np.concatenate([(t @ m).reshape(len(m), -1), higher.reshape(len(m), -1)], 1)

    k = len(HIGHER)
    both = field.on_active(shrink, field.matrix, field.aberration, u, s2, mean_map,
                           tail=(4 + 2 * k,))
    return dataclasses.replace(field, matrix=both[..., :4].reshape(field.matrix.shape),
                               aberration=both[..., 4:].reshape(field.aberration.shape),
                               key=key)


def pixel_voxels(zbuf: np.ndarray, cam, field) -> dict:
    """Where each pixel of a window whose z-buffer is ``zbuf`` (h, w) in [0, 1] (row 0 at
    the bottom, GL order) looks in ``field``'s voxel grid, evaluated on every 2nd pixel
    (row 0 at the top): "voxel" (h2, w2) the nearest voxel of the pixel's scene point
    through the field's camera, as flat index + 1 (0: no surface, or behind the camera);
    "near" the voxel of the nearest surface pixel and "dist" the distance to it (full
    pixels), for background pixels; "shape" (h, w). Found once per frame's depth buffer;
    :func:`sigma_map` maps any sigma volume through it."""
    from scipy.ndimage import distance_transform_edt

    h, w = zbuf.shape
    # each evaluated pixel stands for its 2 x 2 block: the block's nearest surface (a
    # surface smaller than the block, a distant dot, is not skipped)
    top = zbuf[::-1]
    pad = np.ones((h + h % 2, w + w % 2), top.dtype)
    pad[:h, :w] = top
    zb = pad.reshape(pad.shape[0] // 2, 2, pad.shape[1] // 2, 2).min(axis=(1, 3))
    ys, xs = np.mgrid[0:h:2, 0:w:2]
    fg = zb < 1.0
    voxel = np.zeros(zb.shape, np.int64)
    near, dist = voxel, np.zeros(zb.shape)
    if fg.any():
        ndc = np.stack([(2 * xs[fg] + 1.0) / w - 1, 1 - (2 * ys[fg] + 1.0) / h,
                        2 * zb[fg] - 1], -1)
        ids = np.arange(1, int(np.prod(field.shape)) + 1).reshape(field.shape)
        voxel[fg] = field.sample(ids, cam.ndc_to_world(ndc), interpolate=False)
        if not fg.all():
            d, (iy, ix) = distance_transform_edt(~fg, return_indices=True)
            near, dist = voxel[iy, ix], 2.0 * d                # in full pixels
    return {"voxel": voxel, "near": near, "dist": dist, "shape": (h, w)}


def sigma_map(zbuf: np.ndarray, cam, field, vol: dict, voxels: dict | None = None) -> dict:
    """Per pixel of a window whose z-buffer is ``zbuf`` (h, w) (row 0 at the bottom, GL
    order): the voxel values of ``vol`` (:func:`sigma_volume`) at each pixel's scene point
    through ``field``'s camera and grid (nearest voxel, every 2nd pixel, repeated; the
    look-up ``voxels`` of :func:`pixel_voxels`, found here if None), row 0 at the top, over
    the padded box of :func:`filtered_region` ("region"; None, and nothing else, where
    no pixel is filtered): "minor" px, the isotropic Gaussian's sigma; "line" px, the 1-D
    Gaussian's along "u" (..., 2) (column, row) unit vectors — sqrt(major^2 - minor^2).
    All float32; the crop's arrays are all a frame needs (:mod:`eyelab.render.raster`).

    A background pixel (no surface) receives the light that blur spreads beyond the
    silhouettes around it, so it takes the values of its nearest surface pixel if that
    pixel's blur reaches it (distance <= reach), else 0: without it the filter, which
    gathers, would leave the ghost copies in every halo against the background, and a
    compensated blur would lose variance there."""
    v = pixel_voxels(zbuf, cam, field) if voxels is None else voxels
    h, w = v["shape"]
    stack = np.concatenate([np.stack([vol["major"], vol["minor"], vol["reach"]], -1),
                            vol["u"]], -1).reshape(-1, 5)
    table = np.concatenate([np.zeros((1, 5)), stack]).astype(np.float32)   # 0: no voxel
    small = table[v["voxel"]]
    cand = table[v["near"]]
    spread = (v["voxel"] == 0) & (v["dist"] <= cand[..., 2])
    small[spread] = cand[spread]
    major, minor = small[..., 0], small[..., 1]
    line = np.sqrt(np.maximum(major**2 - minor**2, 0.0))
    region = filtered_region(minor, line, scale=2, shape=(h, w))
    if region is None:
        return {"region": None}
    _, (py0, py1, px0, px1) = region
    # each evaluated pixel stands for its 2 x 2 block: repeated over the crop only
    crop = np.stack([minor, line, small[..., 3], -small[..., 4]], -1)[  # NDC y up -> down
        np.arange(py0, py1)[:, None] // 2, np.arange(px0, px1)[None, :] // 2]
    return {"minor": crop[..., 0], "line": crop[..., 1], "u": crop[..., 2:],
            "region": region}


def filtered_region(minor, line, *, scale: int = 1, shape=None) -> tuple | None:
    """((y0, y1, x0, x1), (py0, py1, px0, px1)) of sigma maps ``minor`` / ``line``: the rows
    and columns of every pixel the filters change, and that box padded by how far the
    filters read around a pixel — the largest sigma level's kernel radius (the level is at
    most twice the largest sigma, or the first level) plus the 1-D Gaussian's 4 sigma,
    plus bilinear taps — clipped to the image; None when no pixel is filtered. Filtering
    the padded box alone gives the changed pixels the whole image's values. With
    ``scale`` the maps hold one value per ``scale`` x ``scale`` block of an image of
    ``shape`` (h, w) pixels, and the boxes are in its pixels."""
    sel = (minor >= MIN_SIGMA) | (line >= MIN_LINE_SIGMA)
    rows, cols = np.flatnonzero(sel.any(1)), np.flatnonzero(sel.any(0))
    if not len(rows):
        return None
    h, w = minor.shape if shape is None else shape
    level = max(2.0 * float(minor.max()), 0.35)
    pad = int(4.0 * level + 0.5) + 1 + int(np.ceil(4.0 * float(line.max()))) + 2
    box = (int(rows[0]) * scale, min((int(rows[-1]) + 1) * scale, h),
           int(cols[0]) * scale, min((int(cols[-1]) + 1) * scale, w))
    return box, (max(box[0] - pad, 0), min(box[1] + pad, h), max(box[2] - pad, 0),
                 min(box[3] + pad, w))


def reconstruct(img: np.ndarray, sig: dict) -> np.ndarray:
    """Filter an (h, w, 3) image of linear light (float, row 0 at the top) with the
    per-pixel blur-shaped Gaussian of ``sig`` (:func:`sigma_map`): float32, or the image
    itself where no sigma reaches :data:`MIN_SIGMA`."""
    return directional_gaussian(variable_gaussian(img, sig["minor"]), sig["line"], sig["u"])


def directional_gaussian(img: np.ndarray, sig: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Filter an (h, w, 3) image (float) with a per-pixel 1-D Gaussian of sigma ``sig``
    (h, w) px along ``u`` (h, w, 2) unit (column, row) directions: 17 taps at steps of
    sigma / 2 (to +-4 sigma), bilinear, weights normalised (the taps' variance is sigma^2
    to 0.1 %; bilinear interpolation adds up to 1/4 px^2), in row bands on the thread
    pool; the image itself where every sigma is below :data:`MIN_LINE_SIGMA`."""
    from eyelab.core.parallel import split_rows

    h, w = sig.shape
    if h < 2 or w < 2 or not (sig >= MIN_LINE_SIGMA).any():
        return img
    src = np.asarray(img, np.float32)
    out = src.copy()
    split_rows(lambda a, b: _line_rows(src, sig, u, a, b, out), h)
    return out


def _line_rows(src, sig, u, a, b, out) -> None:
    """:func:`directional_gaussian` for the pixels of rows a:b, written into ``out``."""
    h, w = sig.shape
    sel = sig[a:b] >= MIN_LINE_SIGMA
    if not sel.any():
        return
    flat = src.reshape(h * w, -1)
    ys, xs = np.nonzero(sel)
    ys += a
    half = (sig[ys, xs] / 2).astype(np.float32)              # the step, px
    dx = u[ys, xs, 0].astype(np.float32) * half
    dy = u[ys, xs, 1].astype(np.float32) * half
    fxs, fys = xs.astype(np.float32), ys.astype(np.float32)
    acc = np.zeros((len(half), flat.shape[1]), np.float32)
    wsum = 0.0
    for j in range(-8, 9):
        wt = float(np.exp(-0.5 * (j / 2) ** 2))
        x = np.clip(fxs + j * dx, 0, w - 1.001)
        y = np.clip(fys + j * dy, 0, h - 1.001)
        x0, y0 = x.astype(np.int64), y.astype(np.int64)
        fx, fy = (x - x0)[:, None], (y - y0)[:, None]
        i = y0 * w + x0
        top = flat[i] + fx * (flat[i + 1] - flat[i])
        bottom = flat[i + w] + fx * (flat[i + w + 1] - flat[i + w])
        acc += np.float32(wt) * (top + fy * (bottom - top))
        wsum += wt
    out[ys, xs] = acc / np.float32(wsum)


@functools.lru_cache(maxsize=64)
def _kernel_variance(sigma: float) -> float:
    """Variance (px^2) of scipy's sampled, truncated Gaussian kernel of ``sigma`` px."""
    from scipy.ndimage import gaussian_filter1d

    if sigma == 0:
        return 0.0
    n = 2 * int(4 * sigma + 1) + 1
    delta = np.zeros(n)
    delta[n // 2] = 1.0
    x = np.arange(n) - n // 2
    return float(np.sum(gaussian_filter1d(delta, sigma) * x**2))


def variable_gaussian(img: np.ndarray, sig: np.ndarray) -> np.ndarray:
    """Filter an (h, w, 3) image of linear light (float) with a per-pixel Gaussian of sigma
    ``sig`` (h, w) px, by blending copies filtered at sigma levels 0, 0.35, 0.7, 1.4, ...
    (the two levels around each pixel's, weighted so that the blend's variance is
    sigma^2 — a mixture of two Gaussians, exact in its second moments — where sigma^2 is
    at least the first level's 0.033 px^2). Each level is filtered only over the bounding
    box of the pixels that blend it (padded by its kernel's reach, so the values there are
    those of the whole image filtered), in float32, in row bands on the thread pool
    (scipy's filters release the GIL). Returns float32; the image itself where every
    sigma is below :data:`MIN_SIGMA`."""
    from eyelab.core.parallel import split_rows

    smax = float(sig.max())
    if smax < MIN_SIGMA:
        return img
    levels = [0.0]
    while _kernel_variance(levels[-1]) < smax**2:
        levels.append(0.35 if levels[-1] == 0 else levels[-1] * 2)
    src = np.asarray(img, np.float32)
    out = src.copy()
    split_rows(lambda a, b: _blend_rows(src, sig, levels, a, b, out), sig.shape[0])
    return out


def _blend_rows(src, sig, levels, a, b, out) -> None:
    """:func:`variable_gaussian` for the pixels of rows a:b, written into ``out``."""
    from scipy.ndimage import gaussian_filter

    # each level's true variance: scipy's sampled kernel at 0.35 px has 0.033 px^2, not
    # 0.1225 (from 0.7 px up the two agree to 0.3 %)
    var = np.array([_kernel_variance(lv) for lv in levels])
    ys, xs = np.nonzero(sig[a:b] > 0)         # sigma 0 keeps the pixel (level 0, t = 0)
    if not len(ys):
        return
    ys += a
    s2 = sig[ys, xs].astype(np.float64) ** 2
    idx = np.clip(np.searchsorted(var, s2) - 1, 0, len(levels) - 2)
    lo, hi = var[idx], var[idx + 1]
    # weights that keep the variance: (1 - t) var_lo + t var_hi = sigma^2
    t = np.clip((s2 - lo) / (hi - lo), 0, 1).astype(np.float32)[:, None]
    acc = (1 - t) * src[ys, xs] * (idx == 0)[:, None]
    h, w = sig.shape
    for i in range(1, len(levels)):
        need = (idx == i) | ((idx == i - 1) & ((t[:, 0] > 0) if i == 1 else True))
        if not need.any():
            continue
        ny, nx = ys[need], xs[need]
        pad = int(4.0 * levels[i] + 0.5) + 1          # scipy's kernel radius, plus one
        y0, y1 = max(int(ny.min()) - pad, 0), min(int(ny.max()) + pad + 1, h)
        x0, x1 = max(int(nx.min()) - pad, 0), min(int(nx.max()) + pad + 1, w)
        # the crop's own border mode differs from the whole image's only within the kernel
        # reach of the crop's edges, which the padding keeps away from the pixels used
        # (at the image's edges the crop's edges are the image's: the same mode)
        filt = gaussian_filter(src[y0:y1, x0:x1], (levels[i], levels[i], 0))
        vals = filt[ny - y0, nx - x0]
        wt = np.where(idx[need] == i, 1 - t[need, 0], t[need, 0])[:, None]
        acc[need] += wt * vals
    out[ys, xs] = acc


def filter_has_work(recon) -> bool:
    """Whether a stage's reconstruction state (None: no filter) filters any voxel: a sigma
    at least :data:`MIN_SIGMA` somewhere."""
    return recon is not None and any(
        float(v["major"].max(initial=0.0)) >= MIN_SIGMA for v in recon["sigma"])


#: Colour channels share one reconstruction filter (the smallest of theirs: it never
#: over-filters a channel) where their filters' sigmas differ by at most this (px)
#: everywhere: the filters then differ by less than the smallest sigma the filter applies
#: (:data:`MIN_SIGMA`), and one filter of the three channels costs a third of three.
SHARED_FILTER_PX = 0.25


def channel_volumes(svds, passes: int, reaches=None) -> list:
    """The filter's sigma volumes (:func:`sigma_volume`) of a stage's colour channels
    (their pixel SVDs ``svds``; their maps' reaches, :func:`map_reach_px`, or None): one
    shared volume for second-order fields (the thin eye: its channels differ by its small
    longitudinal colour) and where the channels' own agree within
    :data:`SHARED_FILTER_PX`, else one per channel (a schematic eye's colours). Used for
    the compensation at S passes and for a progressive preview's passes so far alike."""
    shared = sigma_volume(svds, passes, reaches)
    if len(svds) == 1 or reaches is None:
        return [shared]
    own = [sigma_volume([svd], passes, [r]) for svd, r in zip(svds, reaches, strict=True)]
    if all(np.abs(v[k] - shared[k]).max() <= SHARED_FILTER_PX
           for v in own for k in ("major", "minor")):
        return [shared]
    return own
