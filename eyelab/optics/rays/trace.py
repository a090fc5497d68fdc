"""Exact ray tracing: ray/surface intersection and Snell refraction, vectorised.

Rays are struct-of-arrays: ``origins (n, 3)``, ``directions (n, 3)`` unit, metres, and a
``status (n,) uint8`` bit mask. Rows are never dropped; a failed ray keeps its row with
its status set and finite (but meaningless) coordinates.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from eyelab.core.constants import TOL
from eyelab.optics.rays.surfaces import Surface


class Status(enum.IntFlag):
    """Per-ray status bits. ``OK`` (0) means every step succeeded exactly."""

    OK = 0
    #: The ray misses a surface, or hits it outside its aperture.
    MISSED = 1
    #: Total internal reflection at a surface.
    TIR = 2
    #: Within TOL.grazing_cos of grazing refraction: curvatures clamped.
    GRAZING = 4
    #: The wavefront passed (within TOL.focal_eps) through a focal line: curvature clamped.
    FOCAL = 8
    #: Path finding did not converge to TOL.path_fail.
    NOT_CONVERGED = 16
    #: The object point is behind the eye (or the lens), so no light path exists.
    BEHIND = 32

    @staticmethod
    def describe(code: int) -> str:
        if code == 0:
            return "ok"
        return "|".join(s.name.lower() for s in Status if s and code & s)


#: Bits after which a ray carries no light.
FATAL = Status.MISSED | Status.TIR | Status.NOT_CONVERGED | Status.BEHIND


@dataclass
class PlacedSurface:
    """A surface placed in the world: p_world = R @ p_local + t; plus a circular aperture.

    ``aperture_frame`` (R_a, t_a) is the frame in which the aperture radius is measured
    (the lens frame), so that both lens surfaces share one edge cylinder.
    """

    surface: Surface
    rotation: np.ndarray  # (3, 3)
    translation: np.ndarray  # (3,)
    aperture_radius: float = np.inf
    aperture_translation: np.ndarray | None = None

    def to_local(self, points, directions=None):
        p = (points - self.translation) @ self.rotation
        return p if directions is None else (p, directions @ self.rotation)


@dataclass
class Hit:
    """Intersection of rays with a placed surface.

    points : (n, 3) world, metres
    normals : (n, 3) world unit normals (the surface's local +z side)
    form : tuple of 3 (n,) arrays, the curvature form (hxx, hxy, hyy) in the local frame (1/m)
    rotation : (3, 3) local->world rotation, to evaluate the form on world vectors
    status : (n,) uint8
    """

    points: np.ndarray
    normals: np.ndarray
    form: tuple
    rotation: np.ndarray
    status: np.ndarray

    def take(self, rows) -> Hit:
        """The hits of the given rows (index array or slice)."""
        return Hit(self.points[rows], self.normals[rows], tuple(f[rows] for f in self.form),
                   self.rotation, self.status[rows])

    def curvature(self, a, b):
        """Normal curvature form II(a, b) for world tangent vectors a, b (n, 3), +z normal."""
        al = a @ self.rotation
        bl = b @ self.rotation
        hxx, hxy, hyy = self.form
        return hxx * al[:, 0] * bl[:, 0] + hxy * (al[:, 0] * bl[:, 1] + al[:, 1] * bl[:, 0]) \
            + hyy * al[:, 1] * bl[:, 1]


def intersect(ps: PlacedSurface, origins, directions) -> Hit:
    """Intersect rays with a placed surface (the branch through the vertex, ahead of the
    ray's origin: t >= 0, else MISSED).

    Each ray is first transferred to the vertex tangent plane; from there the osculating
    sphere (or conic) at the vertex gives the first guess by the cancellation-free quadratic
    root (Spencer & Murty 1962: t = C / (-B - sign(B) sqrt(B^2 - AC))), then Newton on
    F(t) = z(t) - f(x(t), y(t)) refines it for non-spherical surfaces.
    """
    p, d = ps.to_local(origins, directions)
    n = p.shape[0]
    status = np.zeros(n, np.uint8)
    surf = ps.surface
    # transfer each ray to the vertex tangent plane first (Spencer & Murty 1962): there the
    # root choice below is the vertex branch's for any ray; from far away a steep surface
    # would otherwise give the root of the sphere's other side
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = np.where(np.abs(d[:, 2]) > 1e-12, -p[:, 2] / d[:, 2], 0.0)
    p = p + t0[:, None] * d
    c = surf.seed_curvature
    k = getattr(surf, "conic", 0.0)
    a = c * (d[:, 0] ** 2 + d[:, 1] ** 2 + (1 + k) * d[:, 2] ** 2)
    b = c * (p[:, 0] * d[:, 0] + p[:, 1] * d[:, 1] + (1 + k) * p[:, 2] * d[:, 2]) - d[:, 2]
    cc = c * (p[:, 0] ** 2 + p[:, 1] ** 2 + (1 + k) * p[:, 2] ** 2) - 2 * p[:, 2]
    disc = b * b - a * cc
    bad = disc < 0
    sq = np.sqrt(np.where(bad, 0.0, disc))
    den = -b - np.where(b >= 0, 1.0, -1.0) * sq
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(den != 0, cc / np.where(den != 0, den, 1.0), np.inf)
    bad |= ~np.isfinite(t)
    t = np.where(bad, 0.0, t)
    exact = isinstance(surf, _exact_types()) and not getattr(surf, "coefficients", ())
    if not exact:
        active = ~bad
        for _ in range(TOL.intersect_max_iter):
            if not active.any():
                break
            q = p[active] + t[active, None] * d[active]
            dv = surf.derivatives(q[:, 0], q[:, 1])
            f = q[:, 2] - dv.z
            fp = d[active, 2] - dv.zx * d[active, 0] - dv.zy * d[active, 1]
            ok = dv.valid & (np.abs(fp) > 1e-12)
            step = np.where(ok, f / np.where(ok, fp, 1.0), 0.0)
            idx = np.flatnonzero(active)
            t[idx] -= step
            bad[idx[~ok]] = True
            done = ~ok | (np.abs(f) < TOL.intersect_tol)
            active[idx[done]] = False
        bad |= active  # not converged
    q = p + t[:, None] * d
    # the hit must lie ahead of the ray's origin (propagation direction, t >= 0)
    bad |= (t0 + t) < -TOL.intersect_tol
    dv = surf.derivatives(q[:, 0], q[:, 1])
    bad |= ~dv.valid
    pw = q @ ps.rotation.T + ps.translation
    if ps.aperture_translation is None:
        qa = q
    else:
        qa = (pw - ps.aperture_translation) @ ps.rotation
    bad |= (qa[:, 0] ** 2 + qa[:, 1] ** 2) > ps.aperture_radius**2
    status[bad] |= np.uint8(Status.MISSED)
    nrm = dv.normal()
    form = dv.curvature_form()
    clean = lambda v: np.where(bad, 0.0, v)  # noqa: E731 - keep failed rows finite
    nrm = np.where(bad[:, None], np.array([0.0, 0.0, 1.0]), nrm)
    return Hit(
        points=pw,
        normals=nrm @ ps.rotation.T,
        form=tuple(clean(v) for v in form),
        rotation=ps.rotation,
        status=status,
    )


def _exact_types():
    from eyelab.optics.rays.surfaces import Asphere

    return (Asphere,)


def refract(directions, normals, mu):
    """Snell's law in vector form (Kakimoto 2007 §4.3: N' = mu N + gamma N_s).

    Parameters
    ----------
    directions : (n, 3) unit incident directions N
    normals : (n, 3) unit surface normals (either orientation)
    mu : float or (n,) ratio n_before / n_after

    Returns
    -------
    new_dirs : (n, 3) unit refracted directions
    ns : (n, 3) the normal oriented along the light (N . N_s >= 0)
    cos_i, cos_t : (n,) cosines of the incidence and refraction angles
    status : (n,) uint8 (TIR, GRAZING)
    """
    cos_i = np.einsum("ij,ij->i", directions, normals)
    sgn = np.where(cos_i < 0, -1.0, 1.0)
    ns = normals * sgn[:, None]
    cos_i = np.abs(cos_i)
    mu = np.asarray(mu, float)
    rad = 1.0 - mu**2 * (1.0 - cos_i**2)
    status = np.zeros(len(cos_i), np.uint8)
    tir = rad < 0
    status[tir] |= np.uint8(Status.TIR)
    cos_t = np.sqrt(np.where(tir, 0.0, rad))
    graz = cos_t < TOL.grazing_cos
    status[graz & ~tir] |= np.uint8(Status.GRAZING)
    cos_t = np.maximum(cos_t, TOL.grazing_cos)
    gamma = cos_t - mu * cos_i
    new = mu[..., None] * directions + gamma[:, None] * ns if mu.ndim else \
        mu * directions + gamma[:, None] * ns
    new /= np.linalg.norm(new, axis=1, keepdims=True)
    return new, ns, cos_i, cos_t, status
