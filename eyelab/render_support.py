"""Small sampling helpers shared by the raster (VTK) and reference (embree) renderers,
kept outside ``eyelab/render`` so the reference renderer needs no VTK."""

from __future__ import annotations

import numpy as np


def pixel_jitter(n: int) -> np.ndarray:
    """(n, 2) sub-pixel offsets in [-0.5, 0.5) px: the R2 low-discrepancy sequence (Roberts
    2018), starting at the pixel centre."""
    g = 1.32471795724474602596          # plastic number
    a = np.array([1 / g, 1 / g**2])
    k = np.arange(n)[:, None]
    return np.mod(0.5 + k * a, 1.0) - 0.5
