"""Small vector helpers on struct-of-arrays (rows of 3-vectors), used across eyelab.

Every function takes ``(n, 3)`` float arrays (metres or unitless directions) and works
row by row; they are written out by component because ``np.cross`` / ``np.einsum`` are
several times slower on the short rows of the ray tracer.
"""

from __future__ import annotations

import numpy as np

#: The world's up direction (eyelab's frame: x to the wearer's right, y up, light along +z).
UP = np.array([0.0, 1.0, 0.0])


def dot(a, b):
    """(n,) row-wise dot products of (n, 3) arrays."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def cross(a, b):
    """(n, 3) row-wise cross products of (n, 3) arrays."""
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
                     a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)


def unit(v):
    """``v`` (..., 3) scaled to unit length along the last axis."""
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def any_tangent(n):
    """(n, 3) unit vectors perpendicular to the unit vectors ``n`` (stable for any n).

    >>> any_tangent(np.array([[0.0, 0.0, 1.0]])).round(12).tolist()
    [[0.0, -1.0, 0.0]]
    """
    helper = np.where((np.abs(n[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    t = cross(helper, n)
    return t / np.linalg.norm(t, axis=1, keepdims=True)


def svd2x2(m):
    """The singular value decomposition of (..., 2, 2) matrices in closed form: (u, s, vt)
    with m = u diag(s) vt, u and vt orthogonal, s (..., 2) = (s1 >= s2 >= 0) — what
    ``np.linalg.svd`` returns, ~4x faster on many small matrices. m is split into a
    scaled rotation [[e, -h], [h, e]] and a scaled reflection [[f, g], [g, -f]]: the
    singular values are q + r and |q - r| (q = |(e, h)|, r = |(f, g)|), u a rotation by
    (a2 + a1) / 2 (its second column negated where q < r: a reflection), vt a rotation
    by (a2 - a1) / 2, with a1 = atan2(g, f), a2 = atan2(h, e) (Blinn, "Consider the
    lowly 2x2 matrix", IEEE CG&A 1996)."""
    a, b, c, d = m[..., 0, 0], m[..., 0, 1], m[..., 1, 0], m[..., 1, 1]
    e, f, g, h = (a + d) / 2, (a - d) / 2, (c + b) / 2, (c - b) / 2
    q, r = np.hypot(e, h), np.hypot(f, g)
    a1, a2 = np.arctan2(g, f), np.arctan2(h, e)
    phi, theta = (a2 + a1) / 2, (a2 - a1) / 2
    sign = np.where(q < r, -1.0, 1.0)
    cp, sp, ct, st = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta)
    u = np.stack([np.stack([cp, -sp * sign], -1), np.stack([sp, cp * sign], -1)], -2)
    vt = np.stack([np.stack([ct, -st], -1), np.stack([st, ct], -1)], -2)
    return u, np.stack([q + r, np.abs(q - r)], -1), vt
