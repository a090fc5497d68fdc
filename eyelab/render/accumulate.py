"""Accumulation of S rendered passes (Kakimoto 2007, §4.5: the passes are averaged).

8-bit read-backs are summed in uint16 (exact for S <= 256, VTK_NOTES Q3: the cheapest
route on llvmpipe); the mean is rounded to uint8 with row 0 at the top.
"""

from __future__ import annotations

import numpy as np

from eyelab.options import MAX_PASSES


class PassAccumulator:
    """Sum of RGBA uint8 passes of one (h, w) window, GL row order (row 0 at the bottom)."""

    def __init__(self, height: int, width: int):
        self.sum = np.zeros((height, width, 4), np.uint16)
        self.count = 0

    def add(self, rgba: np.ndarray) -> None:
        """Add one (h, w, 4) uint8 read-back (it may be a view of a reused buffer)."""
        if self.count >= MAX_PASSES:
            raise ValueError(f"at most {MAX_PASSES} passes fit a uint16 sum")
        np.add(self.sum, rgba, out=self.sum)
        self.count += 1

    def mean_rgba(self) -> np.ndarray:
        """(h, w, 4) uint8 RGBA average of the passes so far, rounded, contiguous, in GL row
        order (row 0 at the bottom), alpha 255: what a texture takes without a copy."""
        if self.count <= 1:
            out = self.sum.astype(np.uint8)
        else:
            f = self.sum.astype(np.float32)
            f *= np.float32(1.0 / self.count)
            f += np.float32(0.5)                     # round half up (values are >= 0)
            out = f.astype(np.uint8)
        out[..., 3] = 255
        return out

    def mean(self) -> np.ndarray:
        """(h, w, 3) uint8 RGB average of the passes so far, rounded, row 0 at the top (a
        view of :meth:`mean_rgba`: converting whole and viewing is the fast way)."""
        return self.mean_rgba()[::-1, :, :3]
