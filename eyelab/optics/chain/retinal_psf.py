"""A schematic eye's forward wave as the pupil field of a point-spread function in visual
angle: what ``eyelab psf`` computes for ``eye.model = "navarro"``.

The wave is :mod:`eyelab.optics.chain.forward_wave`'s: exact forward rays from the object
through the lens (lenslets included) and the eye, their optical paths to the exit pupil's
reference sphere about the chief ray's retinal point R (radius rho, in the vitreous of
index n'), each ray's light sqrt(J) — the forward wave, which a defocused pencil through a
lens needs (the reversed one, :mod:`~eyelab.optics.chain.retinal_wave`, differs from it at
second order in the wave's slope: 6 % of the spot's variance for 2 D of defocus behind a
-1 D lens). In the Fraunhofer approximation the field at R + Delta on the retina sums
exp(i k (W + n' xi . Delta / rho)) over the exit pupil's points xi; and a visual angle
theta (the direction of the light entering the eye, across the line of sight) lands at
Delta = L theta, L (2 x 2) the retina's displacement per angle there (the naked eye's
lines of sight 1 mrad apart, traced to the retina). So the field in visual angle is the
pupil field over x = (n' / rho) L^T xi — the entrance pupil as the retina's angles see it,
its obliquity and the eye's distortion included — which :mod:`eyelab.optics.eye.psf` takes
like the thin eye's pupil: W and the light per area of x, interpolated linearly between
the rays (Delaunay triangles; a lenslet's zone edge resolved to one ray spacing).
"""

from __future__ import annotations

import numpy as np

from eyelab.core.vecmath import unit
from eyelab.optics.chain.forward_wave import forward_wave
from eyelab.optics.chain.retina import RetinalTrace, eye_in_world
from eyelab.optics.chain.retinal_rays import retina_points

#: The lines of sight's step (rad) for the retina's displacement per angle.
ANGLE_STEP = 1e-3
#: The percentile of the triangles' |grad W| taken as the wave's largest slope.
SLOPE_PERCENTILE = 99.8


def retinal_pupil_field(eye, lens, trace: RetinalTrace, i: int, *, fixation: str,
                        wavelength_nm: float) -> tuple:
    """(field, slope, wave) of line of sight ``i`` of ``trace`` (the eye placed for
    ``fixation``, at the trace's accommodation; ``lens``: the lens its rays cross, lenslets
    included): field(x, y) -> (W (m, ANSI sign: a myope's defocus positive), light per
    area (relative; 0 outside the pupil)) at pupil points (m, module doc: x toward the
    eye's x, the wearer's right, y up, across the line of sight), the wave's largest
    slope there (rad), and the forward wave (:func:`~eyelab.optics.chain.forward_wave.
    forward_wave`'s dict)."""
    from scipy.spatial import Delaunay

    rot, vertex = eye_in_world(eye, fixation, trace.eye_dir[i])
    acc = float(trace.accommodation[i])
    wave = forward_wave(eye, lens, rot, vertex, trace.object_points, i, acc,
                        wavelength_nm=wavelength_nm)
    # the retina's displacement per visual angle at R, in the exit pupil's basis
    n = np.asarray(trace.eye_dir[i], float)
    x_ax = unit((rot[:, 0] - (rot[:, 0] @ n) * n)[None])[0]
    y_ax = np.cross(n, x_ax)
    h = ANGLE_STEP
    dirs = unit(np.stack([n + h * x_ax, n - h * x_ax, n + h * y_ax, n - h * y_ax]))
    r, _, _ = retina_points(eye, rot, vertex, dirs, acc, wavelength_nm)
    land = np.stack([(r[0] - r[1]) / (2 * h), (r[2] - r[3]) / (2 * h)], -1)   # (3, 2)
    land = wave["basis"] @ land                                             # (2, 2)
    ok = wave["ok"]
    pts = (wave["n_vitreous"] / wave["radius"]) * (wave["xi"][ok] @ land)
    light = 1.0 / wave["amplitude"][ok] ** 2          # per area: 1 / J, J per sample
    light = light / np.median(light)
    w = wave["opd"][ok]
    amp = np.sqrt(light)
    zone = wave["zone"][ok]
    tri = Delaunay(pts)
    simp = tri.simplices
    # a triangle whose corners pass different zones (carrier, lenslets) spans a zone's
    # dark rim, which no ray reaches: no light there
    same = (zone[simp] == zone[simp[:, :1]]).all(1)
    p0, p1, p2 = pts[simp[:, 0]], pts[simp[:, 1]], pts[simp[:, 2]]
    a = np.stack([p1 - p0, p2 - p0], 1)                                   # (t, 2, 2)
    area = np.abs(np.linalg.det(a))
    good = same & (area > 0.0)
    # slivers along the hull (half a spacing wide) would give any slope: not in the bound
    fat = good & (area > 0.25 * np.median(area[good]))
    dw = np.stack([w[simp[fat, 1]] - w[simp[fat, 0]], w[simp[fat, 2]] - w[simp[fat, 0]]], -1)
    g = np.linalg.solve(np.swapaxes(a[fat], 1, 2), dw[..., None])[..., 0]
    # the largest |grad W|, robustly: a few triangles whose corners nearly coincide (the
    # grid's rays folded together at the stop's rim) would give any slope
    slope = float(np.percentile(np.hypot(*g.T), SLOPE_PERCENTILE)) if len(g) else 0.0

    def field(x, y):
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        q = np.stack([x.ravel(), y.ravel()], -1)
        s_ = tri.find_simplex(q)
        inside = (s_ >= 0) & good[np.maximum(s_, 0)]
        t = tri.transform[np.maximum(s_, 0)]                              # (q, 3, 2)
        b = np.einsum("qij,qj->qi", t[:, :2], q - t[:, 2])
        bary = np.concatenate([b, 1 - b.sum(1, keepdims=True)], 1)        # (q, 3)
        corners = simp[np.maximum(s_, 0)]
        wv = (bary * w[corners]).sum(1)
        av = (bary * amp[corners]).sum(1)
        return (np.where(inside, wv, 0.0).reshape(x.shape),
                np.where(inside, av, 0.0).reshape(x.shape))

    return field, slope, wave


def wave_rms(wave: dict) -> dict:
    """{"rms_um", "rms_higher_orders_um"} of a forward wave over the exit pupil's area (each
    ray weighted by its area there, J): about its mean, and less its least-squares fit up
    to second order (piston, tilts, defocus, astigmatism)."""
    ok = wave["ok"]
    x, y = wave["xi"][ok].T
    v = wave["opd"][ok]
    wt = wave["amplitude"][ok] ** 2
    wt = wt / wt.sum()
    mean = float((wt * v).sum())
    basis = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], -1)
    sw = np.sqrt(wt)
    coef, *_ = np.linalg.lstsq(basis * sw[:, None], v * sw, rcond=None)
    return {"rms_um": float(np.sqrt((wt * (v - mean) ** 2).sum())) * 1e6,
            "rms_higher_orders_um": float(np.sqrt((wt * (v - basis @ coef) ** 2).sum())) * 1e6}
