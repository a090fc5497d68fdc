"""Sample sets shared by every renderer: unit-disc seeds (pupil / blur-disc samples) and
sub-pixel jitter. Pure numpy; the same S always gives the same set, so the same inputs
give the same image.
"""

from __future__ import annotations

import math

import numpy as np

GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))


def disc_seeds(n: int) -> np.ndarray:
    """(n, 2) deterministic, evenly spread points in the unit disc (Vogel's spiral: r =
    sqrt((i + 1/2)/n), theta = i * golden angle); each covers an equal area."""
    i = np.arange(n)
    r = np.sqrt((i + 0.5) / n)
    t = i * GOLDEN_ANGLE
    return np.column_stack([r * np.cos(t), r * np.sin(t)])


def equal_area_seeds(n: int) -> np.ndarray:
    """(n, 2) points of the unit disc that each stand for an equal share of its area
    (:func:`disc_seeds`, Vogel's spiral: the most even spread), moved to the disc's exact
    mean (0) and covariance (I/4) (n >= 3; 1: the centre; 2: an antithetic pair)."""
    if n < 3:
        return pass_samples(n)[0]
    s = disc_seeds(n)
    s = s - s.mean(axis=0)
    return s @ _whitening(s).T


def seeds_for(samples: int) -> np.ndarray:
    """The blur-disc seeds of S passes, (S, 2) in (about) the unit disc: see
    :func:`pass_samples`."""
    return pass_samples(samples)[0]


def pass_samples(samples: int):
    """(seeds, jitter) for S passes: seeds (S, 2), points of the unit disc that each pass
    displaces every vertex by (through the blur-field matrix); jitter (S, 2), sub-pixel
    offsets in pixels (antialiasing). Deterministic: the same S gives the same sets.

    A sample set is part of the physics: S displaced copies of a point render the blur
    disc only if the seeds have the disc's mean (0) and covariance (I/4); otherwise a
    circular blur renders off-centre or elongated. Construction:

    * seeds come in *quads* (s, -s, R s, -R s) with R a quarter turn: every quad has mean 0
      and covariance |s|^2/2 I (isotropic);
    * the quads fill blocks that end at S = 4, 8, 16, 32, ...; inside a block of n quads
      the radii are stratified in area, |s_j|^2 = (j + 1/2) / n, whose mean is exactly 1/2,
      and the angles follow the van der Corput sequence: every power-of-two prefix >= 4
      (each image of progressive refinement) has mean 0 and covariance I/4 exactly, and the
      disc is covered evenly;
    * S not a multiple of 4 ends with the centre (S mod 4 = 1), an antithetic pair (2) or
      both (3), and the whole set is whitened (s -> W s, W = C^(-1/2) / 2, linear: every
      even prefix keeps mean 0) to covariance I/4;
    * the set is centrally symmetric (with each (seed, jitter) pass there is the pass
      (-seed, -jitter)), so every odd moment vanishes: a blurred step edge is exactly
      half-way at the edge, not only on average.

    Exact (to round-off) for every S >= 3: mean 0, covariance I/4. S = 1 is the centre;
    S = 2 is an antithetic pair (mean 0 and the right mean |s|^2 = 1/2, but two points
    span one direction only: no 2-point set is isotropic); S = 3 an equilateral triangle
    (exact moments; three points cannot also be centrally symmetric). Even prefixes have
    mean 0; a one-pass preview is a single (biased) sample.

    Jitter: each antithetic pair of seeds gets (j, -j), j from the R2 sequence (Roberts
    2018), then every j is corrected by a small linear term so that the jitter is
    uncorrelated with the seeds (sum of s j^T = 0: the antialiasing does not skew the blur
    ellipse); its mean is 0. The centre pass gets none.
    """
    if samples < 1:
        raise ValueError(f"samples must be >= 1, got {samples}")
    if samples == 1:
        return np.zeros((1, 2)), np.zeros((1, 2))
    if samples == 2:
        s = np.array([[math.sqrt(0.5), 0.0], [-math.sqrt(0.5), 0.0]])
        return s, np.zeros((2, 2))
    if samples == 3:
        t = np.arange(3) * 2 * math.pi / 3
        return math.sqrt(0.5) * np.column_stack([np.cos(t), np.sin(t)]), np.zeros((3, 2))
    n_quads, rem = divmod(samples, 4)
    parts = [_quads(n_quads)]
    if rem >= 2:
        t = 0.5 * math.pi * (math.sqrt(5.0) - 1.0) / 2      # off the quads' directions
        p = math.sqrt(0.5) * np.array([math.cos(t), math.sin(t)])
        parts.append(np.stack([p, -p]))
    if rem % 2:
        parts.append(np.zeros((1, 2)))
    s = np.concatenate(parts)
    if rem:
        s = s @ _whitening(s).T
    n_pairs = (samples - rem % 2) // 2
    pairs = s[0:2 * n_pairs:2]                                # s of each (s, -s) pair
    j = _r2(n_pairs + 1)[1:]      # from R2's second point: its first is the pixel centre
    x = pairs.T @ j                                           # sum over pairs of s j^T
    j = j - pairs @ np.linalg.solve(pairs.T @ pairs, x)       # now sum of s j^T = 0
    jit = np.zeros((samples, 2))
    jit[0:2 * n_pairs:2] = j
    jit[1:2 * n_pairs:2] = -j
    return s, jit


def _quads(n: int) -> np.ndarray:
    """(4n, 2) seeds: n quads in blocks ending at 1, 2, 4, 8, ... quads (the last block
    possibly partial), radii stratified in area within each block, in order; quad k is
    turned by the van der Corput angle vdc(k) x 90 deg (0, 45, 22.5, 67.5, ... : each
    power-of-two prefix spreads its quads evenly over the quarter turn that a quad
    repeats). A block of 2^m quads starts at k = 2^m, where vdc(k + j) = vdc(j) + 2^-(m+1):
    with the area strata j in order, (|s|^2, angle) of the block is a Hammersley set — the
    disc covered evenly. (Strata in bit-reversed order, as vdc(j), put r^2 and the angle
    on one line: each block on four spiral arms, whose copies ghosted in streaks through
    a large blur — measured: the tilted page at 1024x768, S = 64, SSIM 0.972 -> 0.988.)"""
    out = []
    start = 0
    while start < n:
        size = 1 if start < 2 else start           # blocks of 1, 1, 2, 4, 8, ... quads
        size = min(size, n - start)
        r = np.sqrt((np.arange(size) + 0.5) / size)    # area strata (j + 1/2) / size
        t = 0.5 * math.pi * _van_der_corput(np.arange(start, start + size))
        c, s = r * np.cos(t), r * np.sin(t)
        out.append(np.stack([np.column_stack([c, s]), np.column_stack([-c, -s]),
                             np.column_stack([-s, c]), np.column_stack([s, -c])], axis=1))
        start += size
    return np.concatenate(out).reshape(-1, 2)


def _van_der_corput(k: np.ndarray) -> np.ndarray:
    """Base-2 radical inverse of the integers ``k``: values in [0, 1)."""
    out = np.zeros(len(k))
    f = 0.5
    k = np.array(k)
    while np.any(k):
        out += f * (k & 1)
        k >>= 1
        f *= 0.5
    return out


def _r2(n: int) -> np.ndarray:
    """(n, 2) R2 low-discrepancy offsets in [-0.5, 0.5) px (Roberts 2018)."""
    g = 1.32471795724474602596          # plastic number
    a = np.array([1 / g, 1 / g**2])
    k = np.arange(n)[:, None]
    return np.mod(0.5 + k * a, 1.0) - 0.5


def _whitening(s: np.ndarray) -> np.ndarray:
    """The symmetric 2x2 W with W C W^T = I/4 for the zero-mean set ``s``'s covariance C."""
    c = s.T @ s / len(s)
    w, v = np.linalg.eigh(c)
    return v @ np.diag(0.5 / np.sqrt(w)) @ v.T


def antialias_jitter(n: int) -> np.ndarray:
    """(n, 2) sub-pixel offsets (px) for passes that only antialias: the R2 sequence, less
    its mean (exactly zero-mean: the image is not shifted)."""
    j = _r2(n + 1)[1:]
    return j - j.mean(axis=0)


def pixel_jitter(n: int) -> np.ndarray:
    """(n, 2) sub-pixel offsets in [-0.5, 0.5) px: the R2 low-discrepancy sequence (Roberts
    2018), starting at the pixel centre (the reference renderer shifts it per pixel:
    Cranley-Patterson rotation, so its mean does not matter there)."""
    return _r2(n)
