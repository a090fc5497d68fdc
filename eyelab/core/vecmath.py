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
