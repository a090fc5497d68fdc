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


def seeds_for(samples: int) -> np.ndarray:
    """The fixed seed set for S passes: the centre for S = 1, else :func:`disc_seeds`."""
    return np.zeros((1, 2)) if samples == 1 else disc_seeds(samples)


def pixel_jitter(n: int) -> np.ndarray:
    """(n, 2) sub-pixel offsets in [-0.5, 0.5) px: the R2 low-discrepancy sequence (Roberts
    2018), starting at the pixel centre."""
    g = 1.32471795724474602596          # plastic number
    a = np.array([1 / g, 1 / g**2])
    k = np.arange(n)[:, None]
    return np.mod(0.5 + k * a, 1.0) - 0.5
