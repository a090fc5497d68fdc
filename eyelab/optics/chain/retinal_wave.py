"""The wave at the retina: the wave aberration of a line of sight through a spectacle lens
and a schematic eye, by exact optical paths, its RMS and its Strehl ratio.

It is the wave an aberrometer measures: a point source at the chief ray's retinal point R
sends light out through the stop, the eye and the lens; the optical path of each ray from R
to the reference surface of the object (a sphere about the object point through the chief
ray's exit point, or for an object at infinity the plane across its direction), taken from
the chief ray's, is the wave aberration W at that ray's point of the stop; its sign is
ANSI Z80.28's (positive where the wave leads the reference: a myope's defocus is
positive). Reversibility makes it the forward wave's error at R to first order in W; the
two differ at second order (about (W slope)^2 times the pupil's distance, a few per cent of
W for dioptres of error: ``tests/test_retinal_wave.py`` measures it against optiland).
Rays are found through a square grid of stop points (:data:`GRID` across its diameter) by
Newton's method through the crystalline lens
(:func:`~eyelab.optics.chain.retinal_rays.rays_from_retina`); the grid is the pupil's area
measure, so means over it are the pupil's means.

- ``rms``: the root mean square of W about its mean (m);
- ``rms_higher``: the same after the least-squares fit of the terms up to second order
  (piston, tilts, defocus, astigmatism — Zernike orders 0-2, which the Cartesian
  polynomials up to degree 2 span) is removed;
- ``strehl``: the peak of the point-spread function over the diffraction-limited peak of
  the same pupil, |sum exp(i k W + i (a x + b y))|^2 / N^2 maximised over the tilt (a, b)
  — at the PSF's peak wherever the aberrations move it, found on the FFT of the pupil
  (zero-padded :data:`PAD` times) and refined on the exact sum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from eyelab.core.vecmath import dot
from eyelab.optics.chain.retina import RetinalTrace, eye_in_world
from eyelab.optics.chain.retinal_rays import rays_from_retina, retina_points, stop_jacobians
from eyelab.optics.eye.schematic import SchematicEye
from eyelab.optics.rays.trace import FATAL

#: Stop samples across the stop's diameter.
GRID = 64
#: Zero-padding of the pupil for the PSF's coarse peak.
PAD = 4


@dataclass
class RetinalWave:
    """One line of sight's wave (SI units).

    stop_xy : (m, 2) the stop points (eye x, y from the stop's centre, m)
    opd : (m,) the wave aberration there (m; nan where the ray is lost)
    ok : (m,) bool, the rays that reach the object's side
    rms, rms_higher : m; strehl : dimensionless; wavelength_nm : nm
    """

    stop_xy: np.ndarray
    opd: np.ndarray
    ok: np.ndarray
    rms: float
    rms_higher: float
    strehl: float
    wavelength_nm: float


def stop_grid(radius: float, grid: int = GRID) -> np.ndarray:
    """(m, 2) the centres of a ``grid`` x ``grid`` square lattice over the stop's diameter
    that lie inside the stop of ``radius`` (m)."""
    c = (np.arange(grid) + 0.5) / grid * 2.0 - 1.0
    x, y = np.meshgrid(c, c)
    inside = x * x + y * y <= 1.0
    return radius * np.stack([x[inside], y[inside]], -1)


def retinal_waves(eye: SchematicEye, lens, trace: RetinalTrace, *, fixation: str = "fixed",
                  wavelength_nm: float, grid: int = GRID) -> list:
    """The :class:`RetinalWave` of each row of ``trace`` (None where its chief ray failed),
    the eye placed as :func:`~eyelab.optics.chain.retina.trace_objects` placed it for
    ``fixation``."""
    out = []
    for i in range(len(trace.status)):
        if trace.status[i] & np.uint8(FATAL):
            out.append(None)
            continue
        rot, vertex = eye_in_world(eye, fixation, trace.eye_dir[i])
        obj = trace.object_points
        target = obj.positions()[i] if obj.finite[i] else None
        out.append(line_wave(eye, lens, rot, vertex, trace.eye_dir[i],
                             float(trace.accommodation[i]), target, obj.direction[i],
                             wavelength_nm=wavelength_nm, grid=grid))
    return out


def line_wave(eye: SchematicEye, lens, rot, vertex, eye_dir, accommodation: float,
              object_point, object_dir, *, wavelength_nm: float, grid: int = GRID
              ) -> RetinalWave:
    """The wave of the line of sight entering the eye along ``eye_dir`` (3,) (world), the
    eye placed by ``rot``, ``vertex`` at ``accommodation`` (D); the object at world
    ``object_point`` (3,) m, or at infinity (None) in the direction ``object_dir``."""
    xy = stop_grid(eye.stop_radius(accommodation, wavelength_nm), grid)
    w, ok = stop_opd(eye, lens, rot, vertex, eye_dir, accommodation, object_point,
                     object_dir, xy, wavelength_nm=wavelength_nm)
    return wave_measures(xy, w, ok, wavelength_nm)


def stop_opd(eye: SchematicEye, lens, rot, vertex, eye_dir, accommodation: float,
             object_point, object_dir, xy, *, wavelength_nm: float, eye_exits: bool = False):
    """The wave aberration (m,) (m; nan where lost) at stop points ``xy`` (m, 2; eye x, y
    from the stop's centre, m) of :func:`line_wave`'s line of sight, and which rays got
    through (m,); with ``eye_exits`` also each ray as it leaves the cornea (points (m, 3),
    directions (m, 3), world), before any lens."""
    d_in = np.asarray(eye_dir, float)[None]
    retina, v0, st = retina_points(eye, rot, vertex, d_in, accommodation, wavelength_nm)
    xy = np.concatenate([[[0.0, 0.0]], np.asarray(xy, float)])
    m = len(xy)
    jac = stop_jacobians(eye, rot, vertex, retina, v0, accommodation, wavelength_nm)
    rep = lambda a: np.repeat(a, m, axis=0)  # noqa: E731
    o, d, ok, path = rays_from_retina(eye, rot, vertex, rep(retina), rep(v0), xy,
                                      (np.zeros(m, int), jac), accommodation, wavelength_nm,
                                      path=True)
    ok &= (st[0] & np.uint8(FATAL)) == 0
    exits = (o[1:].copy(), d[1:].copy())
    if lens is not None:
        res = lens.trace(o, d, wavelength_nm, reverse=True)
        nl = lens.material.n(wavelength_nm)
        p1, p2 = res["hit1"].points, res["out_points"]
        path = path + np.linalg.norm(p1 - o, axis=1) + nl * np.linalg.norm(p2 - p1, axis=1)
        o, d = p2, res["out_dirs"]
        ok &= (res["status"] & np.uint8(FATAL)) == 0
    if not ok[0]:
        raise ValueError("the chief ray of this line of sight does not reach the object")
    path = path + _to_reference(o, d, object_point, object_dir)
    w = path[0] - path[1:]
    good = ok[1:] & np.isfinite(w)
    return (np.where(good, w, np.nan), good) + (exits if eye_exits else ())


def _to_reference(o, d, object_point, object_dir):
    """The path (m, in air) from each ray's last point ``o`` along ``d`` to the object's
    reference surface through the first (the chief) ray's point: the sphere about
    ``object_point``, or the plane across ``object_dir`` when that is None."""
    if object_point is None:
        w = np.asarray(object_dir, float)
        return dot(o[:1] - o, np.broadcast_to(w, o.shape)) / dot(d, np.broadcast_to(w, o.shape))
    c = np.asarray(object_point, float)
    rho2 = float(((o[0] - c) ** 2).sum())
    b = dot(d, o - c)
    disc = np.maximum(b * b - (((o - c) ** 2).sum(1) - rho2), 0.0)
    t1, t2 = -b - np.sqrt(disc), -b + np.sqrt(disc)
    return np.where(np.abs(t1) < np.abs(t2), t1, t2)


def wave_measures(xy, w, ok, wavelength_nm) -> RetinalWave:
    """The :class:`RetinalWave` of the wave ``w`` (m,) at stop points ``xy`` (m, 2; a
    square lattice), ``ok`` (m,) its rays that got through: RMS, RMS beyond second order,
    Strehl ratio (module doc)."""
    x, y, v = xy[ok, 0], xy[ok, 1], w[ok]
    rms = float(np.sqrt(np.mean((v - v.mean()) ** 2)))
    basis = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], -1)
    coef, *_ = np.linalg.lstsq(basis, v, rcond=None)
    resid = v - basis @ coef
    rms_higher = float(np.sqrt(np.mean(resid ** 2)))
    return RetinalWave(stop_xy=xy, opd=w, ok=ok, rms=rms, rms_higher=rms_higher,
                       strehl=strehl_ratio(xy[ok], v, wavelength_nm),
                       wavelength_nm=wavelength_nm)


def strehl_ratio(xy, w, wavelength_nm: float) -> float:
    """The PSF's peak over the diffraction-limited peak of the pupil sampled at ``xy``
    (m, 2; a square lattice) with wave aberration ``w`` (m,) (module doc)."""
    k = 2.0 * np.pi / (wavelength_nm * 1e-9)
    field = np.exp(1j * k * (w - w.mean()))
    n = len(w)
    # the coarse peak: the lattice's FFT, zero-padded
    step = np.min(np.diff(np.unique(np.round(xy[:, 0], 12))))
    ix = np.round((xy - xy.min(0)) / step).astype(int)
    size = PAD * (ix.max() + 1)
    pupil = np.zeros((size, size), complex)
    pupil[ix[:, 1], ix[:, 0]] = field
    spec = np.abs(np.fft.fft2(pupil)) ** 2
    jy, jx = np.unravel_index(np.argmax(spec), spec.shape)
    freq = np.fft.fftfreq(size, d=step) * 2.0 * np.pi        # rad/m of tilt
    ab0 = np.array([-freq[jx], -freq[jy]])
    scale = 2.0 * np.pi / (size * step)

    def neg(ab):
        phase = xy @ (ab * scale)
        return -np.abs(np.sum(field * np.exp(1j * phase))) ** 2 / (n * n)

    best = minimize(neg, ab0 / scale, method="Nelder-Mead",
                    options={"xatol": 1e-4, "fatol": 1e-12, "maxiter": 400})
    return float(min(1.0, max(-best.fun, -neg(ab0 / scale))))
