"""The wave a spectacle lens puts on the eye's pupil, by real rays: what ``eyelab psf`` adds
to the second-order wave of the chief ray's generalised-Coddington trace.

For a pupil point h (m, in the eye's frame across the chief ray), forward rays from the
object (a plane wave from a distant one) are landed on it by fixed-point steps on where
they are aimed, through the carrier and, for a lenslet lens, through the lens itself. Their
optical paths give the exact wave on the pupil's plane (the eikonal: exact through both
surfaces); the caller's Zernike terms already hold its second order at the chief ray
(K, the Coddington wave), so the field returns what is left:

    W(h) = -(L_carrier(h) - L_carrier(0)) - h^T K h / 2       the lens's higher orders
         + (L_carrier(h) - L_lens(h))                        inside a lenslet's zone

(W as :mod:`eyelab.optics.eye.psf`'s: a converging wave's is positive, the optical path
L's negative). A pupil point's light goes through a lenslet when its lens ray crosses the
front surface inside one (the membership is tested there, not on the plane the rays are
aimed from: 16 mm before the lens, off by 16 mm x tan(gaze) for a line of sight through
the lens's periphery). Its amplitude is the square root of the lens area per pupil area of
its ray over the carrier's (a lenslet's converging pencil fills a zone smaller than the
lenslet by its convergence over the distance to the pupil); a rim that no ray reaches is
dark (:data:`LAND_TOL`).
"""

from __future__ import annotations

import numpy as np

from eyelab.core.vecmath import cross, unit
from eyelab.optics.lens.lenslets import carrier
from eyelab.optics.rays.trace import FATAL

#: Fixed-point steps landing a forward ray on a pupil point, and the miss (m) beyond which
#: no ray reaches it (the dark rim a converging lenslet leaves about its zone). Each step
#: shrinks the miss by about d F (the distance to the pupil times the power: 0.04 for a
#: +3 D lenslet 12 mm before it): four take a 0.1 mm miss below a nanometre.
LAND_STEPS, LAND_TOL = 4, 1e-8
#: Pupil offset (m) of the finite differences of the landing map (the zones' Jacobian).
LAND_STEP = 2e-6
#: Distance (m) before the pupil of the plane the first forward rays are aimed at.
AIM_BEFORE_M = 0.03


def pupil_wave(lens, res, i: int, wavelength_nm: float):
    """The field over the eye's pupil that ``lens`` adds to the second-order wave of point
    ``i`` of a :class:`~eyelab.optics.chain.analysis.PointAnalysis` traced through the lens
    (its carrier for a lenslet lens) at ``wavelength_nm``: a function (x, y) -> (W (m),
    amplitude) of pupil coordinates (m from the pupil centre, x along the eye's x, y up
    across the chief ray: the wearer frame of :mod:`eyelab.optics.eye.psf`; arrays of one
    shape), and the largest slope (rad) the lenslets add (0 without)."""
    base = carrier(lens)
    nl = lens.material.n(wavelength_nm)
    centre = np.asarray(res.pupil[i], float)
    d_in = np.asarray(res.chief.dir_out[i], float)
    x_e = np.asarray(res.eye_x[i], float)
    y_e = cross(d_in[None], x_e[None])[0]
    k11, k12, k22 = (float(k[i]) for k in res.wave_eye.in_basis(res.eye_x))
    start = np.asarray(res.chief.start[i], float)
    finite = bool(np.isfinite(res.chief.object_distance_to_entry[i]))
    d_obj = np.asarray(res.chief.dir_in[i], float)

    def forward(lz, aim):
        """Rays from the object toward the points ``aim`` (m, 3): (pupil-plane points,
        optical paths from the object (or a plane across a distant one's wave), front
        surface crossings, ok)."""
        if finite:
            o, d = np.broadcast_to(start, aim.shape), unit(aim - start)
        else:
            d = np.broadcast_to(d_obj, aim.shape)
            o = aim - ((aim - start) @ d_obj)[:, None] * d
        r = lz.trace(o, np.ascontiguousarray(d), wavelength_nm)
        h1, h2 = r["hit1"].points, r["out_points"]
        u = r["out_dirs"]
        t = ((centre - h2) @ d_in) / (u @ d_in)
        p = h2 + t[:, None] * u
        opl = (np.linalg.norm(h1 - o, axis=1) + nl * np.linalg.norm(h2 - h1, axis=1)
               + np.linalg.norm(p - h2, axis=1))
        return p, opl, h1, (r["status"] & np.uint8(FATAL)) == 0

    def land(lz, target, aim):
        """(aim points, optical paths, front-surface crossings, landed) of the rays
        through ``lz`` that reach the pupil points ``target``."""
        for _ in range(LAND_STEPS):
            p, *_ = forward(lz, aim)
            miss = target - p
            aim = aim + miss - (miss @ d_in)[:, None] * d_in
        p, opl, h1, ok = forward(lz, aim)
        return aim, opl, h1, ok & (np.linalg.norm(p - target, axis=1) < LAND_TOL)

    def which(h1):
        loc = lens.placed_surfaces()[0].to_local(h1)
        return lens.front.which(loc[:, 0], loc[:, 1])

    def area(lz, target, aim, zone=None):
        """|d aim / d pupil| (lens area per pupil area) by finite differences; with
        ``zone`` (each point's lenslet index) one-sided toward the side whose ray lands
        through the same lenslet (a step across a zone's edge would take the jump to the
        carrier beyond the dark rim for a derivative)."""
        sides = []
        for e in (x_e, y_e):
            fwd, _, h1, ok = land(lz, target + LAND_STEP * e, aim)
            if zone is not None:
                back, _, h1b, okb = land(lz, target - LAND_STEP * e, aim)
                use_back = ~(ok & (which(h1) == zone)) & okb & (which(h1b) == zone)
                fwd = np.where(use_back[:, None], 2 * aim - back, fwd)
            sides.append(fwd - aim)
        return np.linalg.norm(cross(*sides), axis=1) / LAND_STEP ** 2

    def field(x, y, through: bool = False):
        """(W, amplitude) at pupil points (x, y); with ``through`` also whether each
        point's light comes through a lenslet (its dark rim included)."""
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        xs, ys = np.append(x.ravel(), 0.0), np.append(y.ravel(), 0.0)     # + the centre
        target = centre + xs[:, None] * x_e + ys[:, None] * y_e
        a_c, opl_c, _, ok_c = land(base, target, target - AIM_BEFORE_M * d_in)
        quad = 0.5 * (k11 * xs * xs + 2 * k12 * xs * ys + k22 * ys * ys)
        w = np.where(ok_c, -(opl_c - opl_c[-1]) - quad, 0.0)
        amp = np.where(ok_c, 1.0, 0.0)
        near = np.zeros(len(w), bool)
        if lens.has_lenslets:
            a_l, opl_l, h1_l, ok_l = land(lens, target, a_c)
            zone = which(h1_l)
            near = ok_c & ((zone >= 0) | ~ok_l)
            if near.any():          # the lenslets' pupil points: their path and light
                k = np.flatnonzero(near)
                w[k] += np.where(ok_l[k], opl_c[k] - opl_l[k], 0.0)
                ratio = (area(lens, target[k], a_l[k], zone[k])
                         / area(base, target[k], a_c[k]))
                amp[k] = np.where(ok_l[k], np.sqrt(ratio), 0.0)
        out = w[:-1].reshape(x.shape), amp[:-1].reshape(x.shape)
        return (*out, near[:-1].reshape(x.shape)) if through else out

    slope = (nl - 1.0) * lens.front.max_added_slope() if lens.has_lenslets else 0.0
    return field, slope


def lenslet_share(field, pupil_radius: float, n: int = 128) -> float:
    """The share of the pupil's light that comes through lenslets, from a
    :func:`pupil_wave` ``field``: over an n x n grid of the pupil (radius m), the lens area
    of the lenslet points' rays (amplitude^2 per pupil area) over all the light's — the
    share of the beam's footprint on the lens, as ``analyze`` counts it."""
    c = ((np.arange(n) + 0.5) / n * 2 - 1) * pupil_radius
    gx, gy = np.meshgrid(c, c)
    inside = gx * gx + gy * gy < pupil_radius ** 2
    _, amp, through = field(gx[inside], gy[inside], through=True)
    light = amp * amp
    return float(light[through].sum() / max(light.sum(), 1e-300))
