"""How umbilic a progressive lens's corridor is, as worn: the unwanted cylinder along the
eye's path and Minkwitz's ratio at the path.

Minkwitz's theorem (G. Minkwitz, *Optica Acta* 10:223 (1963); docs/SCIENCE.md §8): beside
an umbilic line along which the mean power P changes, the cylinder C rises across it as
dC/dx = 2 dP/dy at the line. The ratio there is 2 for any umbilic corridor; the figures'
contour-based :func:`eyelab.optics.lens.figures.minkwitz` measures the gradient between the
0.50 and 0.75 D contours instead, 1-2 mm out, where a designer's blend may already bend it.
Here the gradient is taken at the path, free of the small cylinder floor a real corridor
keeps: on each section, C(x)^2 = C0^2 + (k x)^2 fitted to the map 0.1-1 mm either side of
the path (least squares in C^2), k the gradient.
"""

from __future__ import annotations

import numpy as np

#: The sections' offsets from the path (mm) the gradient is fitted on.
OFFSETS_MM = np.concatenate([np.arange(-1.0, -0.05, 0.1), np.arange(0.1, 1.05, 0.1)])
#: Path sampling (mm).
STEP_MM = 0.1


def corridor_umbilic(lm, corridor_path, y25: float, y75: float) -> dict:
    """From a lens map ``lm`` (:class:`~eyelab.optics.lens.figures.LensMap`), its path
    (``corridor_path``: y (mm) -> x (mm)) and the heights of its 25 % and 75 % add points
    (mm): the largest unwanted cylinder along the path from the fitting cross to the near
    reference point (D, and its height, mm), and Minkwitz's ratio dC/dx / dP/dy at the
    path (module text) averaged over sections every 0.5 mm between the two add points
    (2 for an umbilic corridor)."""
    yn = lm.near_point_mm[1]
    ys = np.arange(0.0, yn - STEP_MM / 2, -STEP_MM)
    c = lm.at("cylinder_d", corridor_path(ys), ys)
    k = int(np.nanargmax(c))
    out = {"path_cylinder_max_d": float(c[k]), "at_y_mm": float(ys[k])}
    if not (np.isfinite(y25) and np.isfinite(y75) and y25 > y75):
        return out
    ratios = []
    for y in np.arange(y25, y75 - 1e-9, -0.5):
        x = float(corridor_path(y)[0])
        cc = lm.at("cylinder_d", x + OFFSETS_MM, np.full_like(OFFSETS_MM, y))
        a = np.stack([np.ones_like(OFFSETS_MM), OFFSETS_MM ** 2], -1)
        sol = np.linalg.lstsq(a, cc ** 2, rcond=None)[0]
        yy = np.array([y - 0.5, y + 0.5])
        p = lm.at("mean_power_d", corridor_path(yy), yy)
        dp = abs(p[0] - p[1])
        if sol[1] > 0 and dp > 0:
            ratios.append(float(np.sqrt(sol[1]) / dp))
    if ratios:
        out["minkwitz_at_path"] = {"ratio": float(np.mean(ratios)), "min": float(min(ratios)),
                                   "max": float(max(ratios)), "from_y_mm": float(y25),
                                   "to_y_mm": float(y75), "sections": len(ratios)}
    return out
