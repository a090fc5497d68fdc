"""Reconstruction filter for images made of S displaced copies (Kakimoto 2007, §4.5).

S passes sample each pixel's blur disc at S points, which ghosts when the disc spans many
pixels. Each pixel is smoothed by a Gaussian whose sigma is :data:`RECON_SIGMA` times the
spacing of the S samples in its own blur disc (from the depth buffer and the field);
in-focus pixels are untouched.

The Gaussian adds its variance sigma^2 I to the blur's B (I/4) B^T (averaging copies adds
covariances), so a filtered image would be blurrier than the eye's. The filter is
therefore variance-compensated: the passes displace by a shrunk matrix B' with
B' (I/4) B'^T = B (I/4) B^T - sigma^2 I (:func:`compensated`), and disc + Gaussian keep
the blur's second moments exactly wherever the blur's minor semi-axis is at least 2 sigma
(elsewhere the minor axis is left sigma^2 - b^2/4 too wide, b its semi-axis). Pure
numpy / scipy.
"""

from __future__ import annotations

import numpy as np

#: Reconstruction Gaussian sigma in units of the spacing of the S samples in a blur disc.
#: 0.5: swept over 0-1 at 512x384 against 512-spp references (charts at 0.4 m / 6 m, the
#: tilted page; myope, astigmat, presbyope; S = 8 and 32): the best SSIM lies at 0.4-0.55
#: on every case (6 m astigmat chart, S = 32: 0.965 unfiltered, 0.991 at 0.55, 0.981 at 1.0)
RECON_SIGMA = 0.7

#: The largest share of the blur's variance along its major axis that the Gaussian may
#: carry (sigma <= sqrt(RECON_MAX_FRACTION) a / 2): beyond it the blur takes the
#: Gaussian's shape instead of the disc's.
RECON_MAX_FRACTION = 0.4

#: Sigmas below this (px) are not filtered (and their voxels not compensated).
MIN_SIGMA = 0.25


def sigma_volume(fields, passes: int, size) -> tuple[np.ndarray, np.ndarray]:
    """(sigma, major): (nz, ny, nx) px each, per voxel. sigma: RECON_SIGMA x the spacing
    of ``passes`` samples in the voxel's blur ellipse, max(sqrt(pi a b / S), 2 a / S) for
    semi-axes a >= b (px) in a window of ``size`` = (w, h) px, the smallest over
    ``fields`` (per-channel fields on one voxel grid: never over-filters a channel);
    major: the largest semi-axis a over ``fields``."""
    px = np.array([size[0] / 2, size[1] / 2])
    sigma = major = None
    for f in fields:
        sv = np.linalg.svd(f.matrix * px[:, None], compute_uv=False)
        spacing = np.maximum(np.sqrt(np.pi * sv[..., 0] * sv[..., 1] / passes),
                             2 * sv[..., 0] / passes)
        sig = np.minimum(RECON_SIGMA * spacing,
                         np.sqrt(RECON_MAX_FRACTION) * sv[..., 0] / 2)
        sigma = sig if sigma is None else np.minimum(sigma, sig)
        major = sv[..., 0] if major is None else np.maximum(major, sv[..., 0])
    return np.where(sigma < MIN_SIGMA, 0.0, sigma), major


def compensated(field, sigma: np.ndarray, size):
    """A copy of ``field`` whose (nz, ny, nx, 2, 2) matrices B (NDC per unit seed) are
    shrunk to B' with B' (I/4) B'^T = B (I/4) B^T - sigma^2 I in pixels of a ``size`` =
    (w, h) window, ``sigma`` (nz, ny, nx) px: each singular value s of the pixel-scaled
    matrix becomes sqrt(max(s^2 - 4 sigma^2, 0)), axes kept. The passes then displace by
    B' and the reconstruction Gaussian supplies the rest of the blur's variance."""
    import dataclasses

    from eyelab.cache import content_key

    px = np.array([size[0] / 2, size[1] / 2])
    u, s, vt = np.linalg.svd(field.matrix * px[:, None])
    s2 = np.sqrt(np.maximum(s**2 - 4 * sigma[..., None] ** 2, 0.0))
    matrix = ((u * s2[..., None, :]) @ vt) / px[:, None]
    key = content_key(field=field.key, sigma=np.asarray(sigma, np.float32),
                      size=list(size), kind="variance-compensated")
    return dataclasses.replace(field, matrix=matrix, key=key)


def sigma_map(zbuf: np.ndarray, cam, field, sigma: np.ndarray, major: np.ndarray
              ) -> np.ndarray:
    """(h, w) Gaussian sigma (px) per pixel: the voxel ``sigma`` (nz, ny, nx) px of
    :func:`sigma_volume` at each pixel's scene point, from the z-buffer ``zbuf`` (h, w) in
    [0, 1] (row 0 at the bottom, GL order) through ``field``'s camera and grid; evaluated
    on every 2nd pixel (nearest voxel) and repeated.

    A background pixel (no surface) receives the light that blur spreads beyond the
    silhouettes around it, so it takes the sigma of its nearest surface pixel if that
    pixel's blur reaches it (distance <= major semi-axis + 2 sigma), else 0: without it
    the filter, which gathers, would leave the ghost copies in every halo against the
    background, and a compensated blur would lose variance there."""
    from scipy.ndimage import distance_transform_edt

    h, w = zbuf.shape
    zb = zbuf[::-1][::2, ::2]
    ys, xs = np.mgrid[0:h:2, 0:w:2]
    ndc = np.stack([(2 * xs + 1.0) / w - 1, 1 - (2 * ys + 1.0) / h, 2 * zb - 1], -1)
    fg = zb < 1.0
    sig_small = np.zeros(zb.shape)
    if fg.any():
        pts = cam.ndc_to_world(ndc[fg])
        both = field.sample(np.stack([sigma, major], -1), pts, interpolate=False)
        sig_small[fg] = both[:, 0]
        if not fg.all():
            reach = np.zeros(zb.shape)
            reach[fg] = both[:, 1] + 2 * both[:, 0]
            dist, (iy, ix) = distance_transform_edt(~fg, return_indices=True)
            near = sig_small[iy, ix]
            ok = ~fg & (2 * dist <= reach[iy, ix])        # dist in half-resolution pixels
            sig_small[ok] = near[ok]
    return np.repeat(np.repeat(sig_small, 2, 0), 2, 1)[:h, :w]


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
    at least the first level's 0.033 px^2). Returns float32; the
    image itself where every sigma is below :data:`MIN_SIGMA`."""
    from scipy.ndimage import gaussian_filter

    smax = float(sig.max())
    if smax < MIN_SIGMA:
        return img
    levels = [0.0]
    while _kernel_variance(levels[-1]) < smax**2:
        levels.append(0.35 if levels[-1] == 0 else levels[-1] * 2)
    src = np.asarray(img, np.float32)
    filt = [src] + [gaussian_filter(src, (lv, lv, 0)) for lv in levels[1:]]
    # each level's true variance: scipy's sampled kernel at 0.35 px has 0.033 px^2, not
    # 0.1225 (from 0.7 px up the two agree to 0.3 %)
    var = np.array([_kernel_variance(lv) for lv in levels])
    idx = np.clip(np.searchsorted(var, sig**2) - 1, 0, len(levels) - 2)
    lo, hi = var[idx], var[idx + 1]
    # weights that keep the variance: (1 - t) var_lo + t var_hi = sigma^2
    t = np.clip((sig**2 - lo) / (hi - lo), 0, 1)[..., None].astype(np.float32)
    out = np.zeros_like(src)
    for i in range(len(levels) - 1):
        sel = (idx == i)[..., None]
        out += np.where(sel, (1 - t) * filt[i] + t * filt[i + 1], np.float32(0.0))
    return out
