"""Accumulation of S rendered passes in linear light (Kakimoto 2007, §4.5: the passes are
averaged; light adds in linear radiance).

Each pass is an 8-bit read-back of sRGB-encoded colours (what the rasteriser draws). Every
code value is decoded to linear light as a 16-bit integer, ``round(65535 * decode(c))``,
and those are summed exactly in integers; the mean is re-encoded once. Decoding two
channels at a time through one 65536-entry table (the RGBA bytes read as uint16 pairs)
halves the table look-ups, which are the cost of a pass here.

Exactness: the only rounding is the 16-bit quantisation of each decoded code (at most
0.5/65535 in linear light, 0.025 of a code value next to black, where the sRGB curve is
steepest) and the final re-encoding to the nearest code; a mean therefore re-encodes to
within 0.5 code value of the exactly averaged radiance everywhere, dark regions included
(``tests/test_linear_light.py`` measures it).
"""

from __future__ import annotations

import sys

import numpy as np

from eyelab.core.color import linear_to_srgb, srgb_to_linear
from eyelab.core.parallel import split_rows
from eyelab.imaging.options import MAX_PASSES

if sys.byteorder != "little":          # the pair look-ups read RGBA bytes as uint16 / uint32
    raise ImportError("eyelab's pass accumulation assumes a little-endian host")

#: Linear light of each sRGB code value, as 16-bit integers (65535 = white).
DECODE16 = np.round(srgb_to_linear(np.arange(256) / 255.0) * 65535.0).astype(np.uint64)
#: Two channels at once: entry ``lo | hi << 8`` holds DECODE16[lo] | DECODE16[hi] << 32,
#: so a uint64 sum keeps each channel in its own 32-bit field (no carry for <= 65536
#: passes).
_PAIR = DECODE16[np.arange(65536) & 255] | (DECODE16[np.arange(65536) >> 8] << np.uint64(32))
#: The nearest sRGB code of each 16-bit linear value (the midpoints between the codes'
#: linear values decide: the encoding that round-trips every code exactly).
_MIDPOINTS = 0.5 * (DECODE16[1:] + DECODE16[:-1]).astype(np.float64)
ENCODE16 = np.searchsorted(_MIDPOINTS, np.arange(65536), side="right").astype(np.uint8)


def encode_linear(linear: np.ndarray) -> np.ndarray:
    """float linear values (any shape, clipped to [0, 1]) -> uint8 sRGB codes, through the
    16-bit table (nearest code; a table look-up instead of a power per value)."""
    q = np.clip(linear, 0.0, 1.0) * np.float32(65535.0)
    q += np.float32(0.5)
    return ENCODE16[q.astype(np.uint16)]


class PassAccumulator:
    """Sum of RGBA uint8 passes of one (h, w) window, in linear light, GL row order (row 0 at
    the bottom)."""

    def __init__(self, height: int, width: int):
        self.shape = (height, width)
        self.sum = np.zeros((height, width, 2), np.uint64)
        self._buf = np.empty((height, width, 2), np.uint64)
        self._first = None
        self.count = 0

    def add(self, rgba: np.ndarray) -> None:
        """Add one (h, w, 4) uint8 read-back (it may be a view of a reused buffer)."""
        if self.count >= MAX_PASSES:
            raise ValueError(f"at most {MAX_PASSES} passes per frame")
        if self.count == 0:
            self._first = rgba.copy()            # one pass needs no decoding at all
        else:
            if self.count == 1:
                self._add_pairs(self._first)
            self._add_pairs(rgba)
        self.count += 1

    def _add_pairs(self, rgba):
        pairs = np.ascontiguousarray(rgba).view(np.uint16)          # (h, w, 2): RG, BA

        def rows(a, b):
            np.take(_PAIR, pairs[a:b], out=self._buf[a:b], mode="clip")
            np.add(self.sum[a:b], self._buf[a:b], out=self.sum[a:b])

        split_rows(rows, self.shape[0])

    def _mean16_rows(self, a, b) -> np.ndarray:
        """(b - a, w, 4) float32 mean 16-bit linear light of rows a:b (R, G, B, alpha): the
        uint64 pairs read as uint32 (little-endian) are the four channels' sums, below
        2^24 and so exact in float32."""
        f = self.sum[a:b].view(np.uint32).astype(np.float32)
        f *= np.float32(1.0 / self.count)
        return f

    def mean_linear(self, rows=None) -> np.ndarray:
        """(h, w, 3) float32 linear light in [0, 1], row 0 at the top; ``rows`` = (a, b):
        only the rows a:b (counted from the top)."""
        if self.count == 0:
            raise ValueError("no pass accumulated")
        h = self.shape[0]
        a, b = (0, h) if rows is None else rows
        lo, hi = h - b, h - a                          # the same rows in GL order
        if self.count == 1:
            return (DECODE16[self._first[lo:hi][::-1, :, :3]] / 65535.0).astype(np.float32)
        return self._mean16_rows(lo, hi)[::-1, :, :3] * np.float32(1 / 65535.0)

    def mean_rgba(self) -> np.ndarray:
        """(h, w, 4) uint8 sRGB RGBA of the linear average, contiguous, GL row order, alpha
        255: what a texture takes without a copy."""
        if self.count == 1:
            out = self._first.copy()
        else:
            out = np.empty(self.shape + (4,), np.uint8)

            def rows(a, b):
                f = self._mean16_rows(a, b)
                f += np.float32(0.5)
                out[a:b] = ENCODE16[f.astype(np.uint16)]

            split_rows(rows, self.shape[0])
        out[..., 3] = 255
        return out

    def mean(self) -> np.ndarray:
        """(h, w, 3) uint8 sRGB of the linear average, row 0 at the top (a view of
        :meth:`mean_rgba`)."""
        return self.mean_rgba()[::-1, :, :3]


def check_tables() -> float:
    """Largest error (in code values) of re-encoding the 16-bit decoded codes: 0 when every
    code round-trips."""
    back = ENCODE16[DECODE16.astype(np.uint16)]
    exact = linear_to_srgb(DECODE16 / 65535.0) * 255.0
    return float(max(np.abs(back.astype(float) - np.arange(256)).max(),
                     np.abs(exact - np.arange(256)).max()))
