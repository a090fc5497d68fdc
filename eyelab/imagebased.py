"""Heidrich, Slusallek & Seidel 1997, "An image-based model for realistic lens systems in
interactive computer graphics": the planning half (pure numpy; the drawing is
:mod:`eyelab.render.imagebased`).

A lens is a transformation of the scene light field into the camera light field. For each
sample point p_i on the image-sided surface of the system (§2.3), the rays from a regular
grid on the film through p_i, traced exactly through the system, leave it on the object
side; a perspective projection with a virtual centre of projection (COP) approximates
them (§3.1): the scene rendered with it is a slice of the scene light field, texture-
mapped back onto the film grid with the rays' image-plane intersections as texture
coordinates (the morph that reproduces the lens's distortion). Where one projection is
not good enough, the film grid is subdivided as a quad-tree and each cell gets its own
projection (§3.2). The COP maximises sum cos^2 of the angles between the traced rays and
the projection's rays (§3.3, Eq. 1, by Newton iteration started from the lens centre or
the parent cell's COP); the least-squares-distance COP of Gremban et al. is kept for
comparison. Grid points whose rays are vignetted are moved toward the grid centre by
bisection and the interior re-spaced (§3.4). The film irradiance is the sum over the
samples of the slices weighted by W_i(x') = cos th' cos th'' / |x'' - x'|^2 (§3.5, Eq. 3),
in linear light.

Two kinds of system make the rays (a ``rays(film_px, sample, wavelength)`` method):
:class:`CameraRays` (a :class:`~eyelab.optics.system.LensSystem` and its film) and
:class:`EyeRays` (the thin toric eye of the other renderers, with or without a spectacle
lens: the eye's pupil is the image-sided surface, the eye camera's image the film).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from eyelab.errors import SpecError
from eyelab.optics.trace import FATAL
from eyelab.vecmath import UP, unit


# ----------------------------------------------------------------------- ray makers
@dataclass
class RaySet:
    """Rays of one grid through one lens sample.

    film : (m, 2) film positions in pixels (x right, y down, pixel edges at integers);
    origins, dirs : (m, 3) the rays leaving the system on the object side (dirs unit,
    into the scene); ok : (m,) the ray passed the system; weight : (m,) W_i(x') (0 where
    not ok); transmittance : (m,) the fraction of the light the system passes (Fresnel).
    """

    film: np.ndarray
    origins: np.ndarray
    dirs: np.ndarray
    ok: np.ndarray
    weight: np.ndarray
    transmittance: np.ndarray


class CameraRays:
    """Rays of a :class:`~eyelab.optics.system.LensSystem` camera.

    The film is ``height`` pixels high over 2 f tan(fov_y / 2) (f the effective focal
    length: the field of view of the paraxial image; the lens's distortion changes it),
    centred on the axis, and seen upright (the image on the film is turned 180°).
    Samples are points of the image-sided sample plane (the last surface's vertex plane)
    in the disc that the film centre's passing rays cross it in (its radius found by
    bisection: every sample carries light at the film centre; off the axis the system's
    own vignetting is traced)."""

    kind = "camera"

    def __init__(self, system, width: int, height: int, fov_y_deg: float,
                 near: float = 0.05):
        self.system = system
        self.width, self.height = width, height
        f = system.cardinal()["efl_m"]
        self.pitch = 2 * f * math.tan(math.radians(fov_y_deg) / 2) / height
        self.dz = system.film_z - system.exit_z
        self.radius = self._pupil_radius()
        self.near = near

    def _pupil_radius(self, steps: int = 48) -> float:
        """Radius (m) in the sample plane within which rays from the film centre pass the
        whole system (bisection along x; the system is rotationally symmetric)."""
        sys_ = self.system
        x = np.array([[0.0, 0.0, sys_.film_z]])
        lo, hi = 0.0, 2.0 * sys_.exit_radius

        def passes(r):
            v = np.array([r, 0.0, sys_.exit_z]) - x[0]
            res = sys_.trace_reverse(x, (v / np.linalg.norm(v))[None])
            return (res["status"][0] & np.uint8(FATAL)) == 0

        if not passes(0.0):
            raise SpecError("camera", f"{sys_.name}: the axial ray does not pass the system")
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if passes(mid) else (lo, mid)
        return lo

    def film_points(self, film_px) -> np.ndarray:
        """(m, 3) film-plane points of film pixel positions (upright image)."""
        px = np.asarray(film_px, float)
        u = px[:, 0] - self.width / 2
        v = px[:, 1] - self.height / 2
        return np.column_stack([-u * self.pitch, v * self.pitch,
                                np.full(len(px), self.system.film_z)])

    def rays(self, film_px, sample, wavelength_nm) -> RaySet:
        """Rays from the film positions through the sample point (unit-disc coordinates
        times the exit radius), traced back into the scene."""
        px = np.asarray(film_px, float)
        return self.ray_pairs(px, np.broadcast_to(np.asarray(sample, float), px.shape),
                              wavelength_nm)

    def ray_pairs(self, film_px, samples, wavelength_nm) -> RaySet:
        """Rays from film positions (n, 2) through their own sample points (n, 2), unit
        disc."""
        x = self.film_points(film_px)
        smp = np.asarray(samples, float)
        p = np.column_stack([smp[:, 0] * self.radius, smp[:, 1] * self.radius,
                             np.full(len(smp), self.system.exit_z)])
        v = p - x
        dist2 = np.sum(v * v, axis=1)
        # start just behind the last surface's apex region: on the film (rays travel -z)
        r = self.system.trace_reverse(x, v / np.sqrt(dist2)[:, None], wavelength_nm)
        ok = (r["status"] & np.uint8(FATAL)) == 0
        w = self.dz ** 2 / dist2 ** 2                   # cos th' cos th'' / |x'' - x'|^2
        return RaySet(np.asarray(film_px, float), r["points"], r["dirs"], ok,
                      np.where(ok, w, 0.0), r["transmittance"])

    def white_level(self) -> float:
        """Mean of W over the sample disc at the film centre: 1 / (dz^2 + R^2) exactly
        (int_0^R 2 pi rho dz^2 / (dz^2 + rho^2)^2 d rho / (pi R^2)); the irradiance of a
        uniform white scene there, without vignetting or reflection losses, per unit
        radiance and sample-disc area."""
        return 1.0 / (self.dz ** 2 + self.radius ** 2)

    def focus_distance(self) -> float:
        """Object distance in focus (m from the first vertex; inf at the back focal
        point): a near-axis real ray from the film centre, traced back."""
        sys_ = self.system
        h = 1e-5 * self.radius
        x = np.array([[0.0, 0.0, sys_.film_z]])
        v = np.array([h, 0.0, sys_.exit_z]) - x[0]
        r = sys_.trace_reverse(x, (v / np.linalg.norm(v))[None])
        p, d = r["points"][0], r["dirs"][0]
        if abs(d[0]) < 1e-15 or d[0] * p[0] >= 0:
            return math.inf
        return float(sys_.surfaces[0].z - (p[2] - p[0] * d[2] / d[0]))


class EyeRays:
    """Rays of the thin toric eye (and a spectacle lens): the film is the eye camera's
    image (a pixel is the chief direction d_s from the pupil centre, tangents t = (tx, ty)
    in the camera's frame); a sample is a pupil point rho (unit disc times the pupil
    radius) in the pupil plane, which is perpendicular to the line of sight. The eye is the
    ideal thin lens of the other renderers' model in tangent form — a ray from the pixel's
    retinal point through rho leaves with the tangents t - G rho, G = P(accommodation) -
    n2 / z_r (+ the eye's chromatic power shift at the wavelength) — then passes the
    spectacle lens exactly (a ray that misses the lens goes on straight). Without a lens
    every ray of a sample passes through its pupil point: one exact perspective per
    sample (Heidrich Fig. 3a). W_i: the retina (a plane z_r behind the pupil) and the
    pupil plane, |x'' - x'|^2 = z_r^2 + |r - rho|^2 with r = -z_r t / n2 the pixel's
    retinal point.

    ``accommodation`` a fixed value (D), or None: each film point's own, for the first
    scene point along its chief ray (``scene`` needed), by the reference renderer's rule
    (:func:`eyelab.scene.focus.pixel_accommodation`, Kakimoto Eq. 13); the rays of a
    sample then change across depth edges, which the quad-tree refines."""

    kind = "eye"

    def __init__(self, eye, lens, view, accommodation: float | None, scene=None):
        self.eye, self.lens, self.view = eye, lens, view
        self.cam = view.camera(eye.rotation_centre)
        self.acc = None if accommodation is None else \
            float(min(max(accommodation, 0.0), eye.accommodation_max))
        if self.acc is None:
            if scene is None:
                raise ValueError("EyeRays: automatic accommodation needs the scene")
            from eyelab.cache import LRUCache
            from eyelab.scene.raycast import EmbreeIntersector

            self.scene, self.inter = scene, EmbreeIntersector(scene)
            # a film point's accommodation does not depend on the lens sample: one chief
            # ray per grid, whatever the sample (planning asks for the same grid per sample)
            self._acc = LRUCache(256, "accommodation")
        self.radius = eye.pupil_diameter / 2
        self.width, self.height = view.width, view.height
        self.near = view.near

    def rays(self, film_px, sample, wavelength_nm) -> RaySet:
        px = np.asarray(film_px, float)
        tx_half, ty_half = self.cam.tan_half
        t = np.column_stack([(2 * px[:, 0] / self.width - 1) * tx_half,
                             (1 - 2 * px[:, 1] / self.height) * ty_half])
        eye = self.eye
        rho = np.array([sample[0], sample[1]]) * self.radius
        b = self.cam.basis
        if self.acc is None:
            from eyelab.cache import array_digest
            from eyelab.scene.focus import pixel_accommodation

            d_s = unit(t[:, :1] * b[0] + t[:, 1:2] * b[1] + b[2])
            acc, _ = self._acc.get_or_create(array_digest(px), lambda: pixel_accommodation(
                d_s, self.scene, self.inter, eye, self.lens, self.view, self.cam)[0])
        else:
            acc = np.full(len(px), self.acc)
        pxx, pxy, pyy = (np.broadcast_to(v, acc.shape) for v in eye.power_matrix(acc))
        # the eye's own chromatic aberration: every meridian's power shifted at this
        # wavelength (the reference renderer's channel slopes)
        e = eye.emmetropic_power - eye.power_shift(wavelength_nm)
        g = np.column_stack([(pxx - e) * rho[0] + pxy * rho[1],
                             pxy * rho[0] + (pyy - e) * rho[1]])
        to = t - g
        d = unit(to[:, :1] * b[0] + to[:, 1:2] * b[1] + b[2])
        o = np.broadcast_to(np.asarray(self.cam.position, float) + rho[0] * b[0]
                            + rho[1] * b[1], d.shape).copy()
        ok = np.ones(len(px), bool)
        trans = np.ones(len(px))
        if self.lens is not None:
            r = self.lens.trace(o, d, wavelength_nm, reverse=True)
            through = (r["status"] & np.uint8(FATAL)) == 0
            o = np.where(through[:, None], r["out_points"], o)
            d = np.where(through[:, None], r["out_dirs"], d)
            trans = np.where(through, r["transmittance"], 1.0)
        zr, n2 = eye.retina_distance, eye.n_vitreous
        r_ret = -zr * t / n2
        dist2 = zr ** 2 + (r_ret[:, 0] - rho[0]) ** 2 + (r_ret[:, 1] - rho[1]) ** 2
        w = zr ** 2 / dist2 ** 2
        return RaySet(px, o, d, ok, w, trans)



# ----------------------------------------------------------------------- COP fitting
def cos2_objective(e, p, d):
    """sum cos^2 (Eq. 1) of the angles between the rays' directions d (n, 3) and p - e."""
    f = p - e
    a = np.sum(f * f, axis=1)
    b = np.sum(d * f, axis=1)
    return float(np.sum(b * b / a))


def cos2_gradient_hessian(e, p, d):
    """Gradient (3,) and Hessian (3, 3) of :func:`cos2_objective` with respect to e.

    With f = p - e, a = |f|^2, b = d.f and c^2 = b^2 / a (Heidrich Eq. 1; our own
    derivation of the derivatives the paper's Newton step needs):
    grad c^2 = 2 b / a^2 (b f - a d);
    Hess c^2 = (b f - a d) (-2 d / a^2 + 8 b f / a^3)^T + 2 b / a^2 (2 d f^T - f d^T - b I).
    """
    f = p - e
    a = np.sum(f * f, axis=1)
    b = np.sum(d * f, axis=1)
    u = b[:, None] * f - a[:, None] * d
    k = 2 * b / a ** 2
    grad = np.sum(k[:, None] * u, axis=0)
    v = -2 * d / a[:, None] ** 2 + 8 * (b / a ** 3)[:, None] * f
    h = np.einsum("ni,nj->ij", u, v)
    h += np.einsum("n,ni,nj->ij", k, 2 * d, f) - np.einsum("n,ni,nj->ij", k, f, d)
    h -= np.sum(k * b) * np.eye(3)
    return grad, h


def fit_cop_angle(p, d, e0, *, iterations: int = 8, dtype=np.float64):
    """The COP maximising sum cos^2 (Heidrich §3.3): Newton from ``e0``, a step kept only
    when it raises the objective (else halved, then a gradient step): returns (e (3,),
    Newton steps taken). ``dtype``: the arithmetic (float32 only to study its
    conditioning against the least-squares COP's)."""
    p, d = np.asarray(p, dtype), np.asarray(d, dtype)
    e = np.asarray(e0, dtype).copy()
    best = cos2_objective(e, p, d)
    steps = 0
    for _ in range(iterations):
        g, h = cos2_gradient_hessian(e, p, d)
        try:
            step = -np.linalg.solve(h, g)
        except np.linalg.LinAlgError:
            step = g * 1e-6
        if np.dot(step, g) <= 0:          # not an ascent direction: a scaled gradient step
            step = g * (np.linalg.norm(step) / max(np.linalg.norm(g), 1e-300))
        improved = False
        for _ in range(30):
            cand = e + step
            val = cos2_objective(cand, p, d)
            if val >= best:
                e, best, improved = cand, val, True
                break
            step *= 0.5
        steps += 1
        if not improved or np.linalg.norm(step) < 1e-15 * max(1.0, np.linalg.norm(e)):
            break
    return e, steps


def fit_cop_least_squares(origins, dirs, dtype=np.float64):
    """The COP closest to all rays in the least-squares sense (Gremban et al. 1988, the
    method Heidrich et al. compare with): solves sum (I - d d^T) e = sum (I - d d^T) q
    (in ``dtype``)."""
    from eyelab.optics.camera import least_squares_point

    return least_squares_point(origins, dirs, dtype)[0]


def image_plane_points(origins, dirs, e, normal, distance):
    """Where the rays (lines q + t d) meet the image plane n.(x - e) = distance."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (distance - (origins - e) @ normal) / (dirs @ normal)
    return origins + t[:, None] * dirs


def angle_errors_deg(p, d, e):
    """(n,) angles (deg) between each ray's direction and the projection's ray p - e."""
    f = unit(p - e)
    return np.degrees(np.arccos(np.clip(np.sum(f * d, axis=1), -1.0, 1.0)))


# ----------------------------------------------------------------------- quad-tree
@dataclass
class Projection:
    """One perspective render of the plan: a film cell, its COP and camera, the grid
    (film positions, texture directions p - e, weights, valid points)."""

    sample: int
    depth: int
    cell: tuple                  # (x0, y0, x1, y1) film pixels
    cop: np.ndarray              # (3,)
    forward: np.ndarray          # (3,) camera axis (unit)
    up: np.ndarray               # (3,)
    tan_half: tuple              # (tx, ty) of the frustum
    grid_film: np.ndarray        # (g+1, g+1, 2) film pixels
    grid_dirs: np.ndarray        # (g+1, g+1, 3) unit p - e (where the texture is read)
    grid_weight: np.ndarray      # (g+1, g+1) W_i (Eq. 3)
    grid_transmittance: np.ndarray  # (g+1, g+1) the fraction of light the system passes
    grid_ok: np.ndarray          # (g+1, g+1) bool
    max_angle_deg: float
    rms_angle_deg: float
    slice_size: tuple = (0, 0)   # (w, h) pixels of the render


@dataclass
class Plan:
    """All projections of one frame and the figures of the planning."""

    projections: list
    samples: np.ndarray          # (n, 2) unit-disc sample points
    wavelength_nm: float
    stats: dict = field(default_factory=dict)


def _grid(cell, g):
    x0, y0, x1, y1 = cell
    xs = np.linspace(x0, x1, g + 1)
    ys = np.linspace(y0, y1, g + 1)
    gx, gy = np.meshgrid(xs, ys)
    return np.stack([gx, gy], -1)


def _coons(border_fn, g):
    """Transfinite (Coons) interpolation of a grid from its moved border: grid (g+1, g+1,
    2) whose outer ring is ``border_fn``'s and whose inside is spaced evenly between."""
    b = border_fn
    s = np.linspace(0, 1, g + 1)
    u, v = s[None, :, None], s[:, None, None]          # (1, g+1, 1) across, (g+1, 1, 1) down
    return ((1 - v) * b[0][None] + v * b[-1][None] + (1 - u) * b[:, 0][:, None]
            + u * b[:, -1][:, None]
            - ((1 - u) * (1 - v) * b[0, 0] + u * (1 - v) * b[0, -1]
               + (1 - u) * v * b[-1, 0] + u * v * b[-1, -1]))


def vignetting_grid(maker, cell, g, sample, wl, *, steps: int = 12):
    """The cell's grid with border points whose rays are vignetted moved toward the grid
    centre by bisection until they pass (Heidrich §3.4), the inside re-spaced evenly
    (Coons patch); returns (grid (g+1, g+1, 2), RaySet of its points) or None when no grid
    point's ray passes. Points inside whose rays still fail (a vignetted region that is
    not star-shaped about the centre) leave their quads out."""
    grid = _grid(cell, g)
    rs = maker.rays(grid.reshape(-1, 2), sample, wl)
    ok = rs.ok.reshape(g + 1, g + 1)
    if ok.all():
        return grid, rs
    centre = np.array([(cell[0] + cell[2]) / 2, (cell[1] + cell[3]) / 2])
    if not maker.rays(centre[None], sample, wl).ok[0]:
        # a sub-cell whose centre is vignetted: bisect toward its passing grid point
        # nearest the centre instead (the paper's grid centre passes on the top level)
        if not ok.any():
            return None
        passing = grid[ok]
        centre = passing[np.argmin(np.sum((passing - centre) ** 2, axis=1))]
    ring = np.zeros((g + 1, g + 1), bool)
    ring[0, :] = ring[-1, :] = ring[:, 0] = ring[:, -1] = True
    bad = ring & ~ok
    if bad.any():
        pts = grid[bad]
        # the fraction of the way to the centre known to pass (1) and to fail (0)
        frac_ok, frac_bad = np.ones(len(pts)), np.zeros(len(pts))
        for _ in range(steps):
            mid = 0.5 * (frac_ok + frac_bad)
            q = pts + mid[:, None] * (centre - pts)
            passes = maker.rays(q, sample, wl).ok
            frac_ok = np.where(passes, mid, frac_ok)
            frac_bad = np.where(passes, frac_bad, mid)
        grid = grid.copy()
        grid[bad] = pts + frac_ok[:, None] * (centre - pts)
    grid = _coons(grid, g)
    rs = maker.rays(grid.reshape(-1, 2), sample, wl)
    return grid, rs


def plan_projections(maker, samples, wavelength_nm, *, grid: int = 10,
                     threshold_deg: float = 0.05, max_depth: int = 3,
                     plane_distance: float | None = None, cop: str = "angle",
                     oversample: float = 2.0, max_slice: int = 2048) -> Plan:
    """Every projection of a frame (Heidrich §3.1-3.4): per sample, the film as a quad-tree
    of cells, each with a ``grid`` x ``grid`` grid of rays, its COP (``cop`` = "angle":
    the Newton fit of Eq. 1; "lsq": the least-squares-distance point), split while the
    maximum angle error exceeds ``threshold_deg`` and the depth is below ``max_depth``.
    The image plane lies ``plane_distance`` m along the cell's mean ray direction (default:
    the maker's near distance: the angle error at infinity, which the criterion measures,
    then bounds the angular error of every scene point at or beyond the plane, the error
    growing as |1/D - 1/D_plane| with the depth D). Slices get ``oversample`` x the film's pixel
    density, at most ``max_slice`` pixels a side."""
    if cop not in ("angle", "lsq"):
        raise SpecError("render.cop", f"must be 'angle' or 'lsq', got {cop!r}")
    dist = maker.near if plane_distance is None else plane_distance
    projections = []
    stats = {"cells": 0, "vignetted_cells": 0, "newton_steps": 0, "split": 0,
             "unresolved_cells": 0}
    full = (0.0, 0.0, float(maker.width), float(maker.height))
    for si, s in enumerate(samples):
        start = None                        # the lens centre: the first cell's guess
        stack = [(full, 0, start)]
        while stack:
            cell, depth, guess = stack.pop()
            got = vignetting_grid(maker, cell, grid, s, wavelength_nm)
            stats["cells"] += 1
            if got is None:
                stats["vignetted_cells"] += 1
                continue
            g_film, rs = got
            ok = rs.ok
            if ok.sum() < 4:
                stats["vignetted_cells"] += 1
                continue
            q, d = rs.origins[ok], rs.dirs[ok]
            if guess is None:
                guess = q.mean(axis=0)      # the lens centre for this sample
            normal = unit(d.mean(axis=0))
            p = image_plane_points(q, d, guess, normal, dist)
            if cop == "angle":
                e, steps = fit_cop_angle(p, d, guess)
                stats["newton_steps"] += steps
            else:
                e = fit_cop_least_squares(q, d)
            err = angle_errors_deg(p, d, e)
            emax = float(err.max())
            if emax > threshold_deg and depth < max_depth:
                stats["split"] += 1
                x0, y0, x1, y1 = cell
                xm, ym = (x0 + x1) / 2, (y0 + y1) / 2
                for c in ((x0, y0, xm, ym), (xm, y0, x1, ym), (x0, ym, xm, y1),
                          (xm, ym, x1, y1)):
                    stack.append((c, depth + 1, e))
                continue
            if emax > threshold_deg:
                stats["unresolved_cells"] += 1
            projections.append(_projection(si, depth, cell, g_film, rs, e, dist, normal, err,
                                           grid, oversample, max_slice))
    errs = [pr.max_angle_deg for pr in projections]
    stats.update(projections=len(projections),
                 max_angle_deg=float(max(errs)) if errs else 0.0,
                 max_depth=max((pr.depth for pr in projections), default=0))
    return Plan(projections, np.asarray(samples, float), wavelength_nm, stats)


def _projection(si, depth, cell, g_film, rs, e, dist, normal, err, g, oversample,
                max_slice) -> Projection:
    ok = rs.ok
    p = np.full_like(rs.origins, np.nan)
    p[ok] = image_plane_points(rs.origins[ok], rs.dirs[ok], e, normal, dist)
    dirs = np.full_like(p, np.nan)
    dirs[ok] = unit(p[ok] - e)
    # the camera: axis through the middle of the directions' tangent-plane bounding box
    def tangents(fwd):
        right = unit(np.cross(fwd, UP if abs(fwd @ UP) < 0.99 else np.array([1.0, 0, 0])))
        up = np.cross(right, fwd)
        t = dirs[ok]
        return up, (t @ right) / (t @ fwd), (t @ up) / (t @ fwd), right

    fwd = unit(dirs[ok].mean(axis=0))
    for _ in range(2):
        up, tx, ty, right = tangents(fwd)
        fwd = unit(fwd + 0.5 * (tx.max() + tx.min()) * right
                   + 0.5 * (ty.max() + ty.min()) * up)
    up, tx, ty, _ = tangents(fwd)
    half = (max(float(np.abs(tx).max()), 1e-6) * 1.02, max(float(np.abs(ty).max()), 1e-6) * 1.02)
    # slice size: the film's pixel density (film pixels per tangent unit, the largest over
    # the grid's edges) times ``oversample``
    gf = g_film.reshape(-1, 2)
    tt = np.full((len(gf), 2), np.nan)
    tt[ok, 0], tt[ok, 1] = tx, ty
    tt = tt.reshape(g + 1, g + 1, 2)
    gf = gf.reshape(g + 1, g + 1, 2)
    dens = []
    for a, b in (((slice(None), slice(1, None)), (slice(None), slice(None, -1))),
                 ((slice(1, None), slice(None)), (slice(None, -1), slice(None)))):
        dp = np.linalg.norm(gf[a] - gf[b], axis=-1)
        dt = np.linalg.norm(tt[a] - tt[b], axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            r = dp / dt
        dens.append(r[np.isfinite(r)])
    dens = np.concatenate(dens)
    density = float(dens.max()) if len(dens) else 1.0
    # the window's aspect sets the horizontal extent (as GL projects it): the vertical
    # half-tangent is kept and the horizontal one becomes ty sw / sh >= tx
    k = density * oversample
    scale = min(1.0, max_slice / max(2 * half[0] * k, 2 * half[1] * k))
    sh = max(8, math.ceil(2 * half[1] * k * scale))
    sw = max(8, math.ceil(sh * half[0] / half[1]))
    if sw > max_slice:
        sw = max_slice
        sh = max(1, math.floor(sw * half[1] / half[0]))
    half = (half[1] * sw / sh, half[1])
    return Projection(si, depth, cell, e, fwd, up, half, g_film,
                      dirs.reshape(g + 1, g + 1, 3), rs.weight.reshape(g + 1, g + 1),
                      rs.transmittance.reshape(g + 1, g + 1),
                      ok.reshape(g + 1, g + 1), float(err.max()),
                      float(np.sqrt(np.mean(err ** 2))), (sw, sh))


def texcoords(pr: Projection) -> np.ndarray:
    """(g+1, g+1, 2) slice-image positions (pixels: x right, y down from the top-left
    corner) of the grid's projection rays."""
    right = np.cross(pr.forward, pr.up)
    d = pr.grid_dirs
    w = d @ pr.forward
    tx = (d @ right) / w / pr.tan_half[0]
    ty = (d @ pr.up) / w / pr.tan_half[1]
    sw, sh = pr.slice_size
    return np.stack([(tx + 1) * sw / 2, (1 - ty) * sh / 2], -1)


# ----------------------------------------------------------------------- morph
def rasterize(film_tri, attrs, width, height, covered):
    """Scan-convert triangles onto the film (pixel centres at k + 0.5): film_tri (k, 3, 2)
    film pixels, attrs (k, 3, c) per-vertex attributes; ``covered`` (h*w,) bool marks
    pixels already given to an earlier triangle of the same sample (updated; each pixel
    belongs to one triangle). Returns (pixel indices (m,), attributes (m, c)) interpolated
    linearly (Gouraud: as the texture unit interpolates texture coordinates)."""
    if len(film_tri) == 0:
        return np.zeros(0, int), np.zeros((0, attrs.shape[2]))
    lo = np.floor(film_tri.min(axis=1) - 0.5).astype(int) + 1
    hi = np.ceil(film_tri.max(axis=1) - 0.5).astype(int)
    lo = np.maximum(lo, 0)
    hi[:, 0] = np.minimum(hi[:, 0], width - 1)
    hi[:, 1] = np.minimum(hi[:, 1], height - 1)
    nx = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0)
    ny = np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    counts = nx * ny
    keep = counts > 0
    if not keep.any():
        return np.zeros(0, int), np.zeros((0, attrs.shape[2]))
    tri_id = np.repeat(np.flatnonzero(keep), counts[keep])
    start = np.repeat(np.cumsum(counts[keep]) - counts[keep], counts[keep])
    local = np.arange(len(tri_id)) - start
    px = lo[tri_id, 0] + local % nx[tri_id]
    py = lo[tri_id, 1] + local // nx[tri_id]
    cx, cy = px + 0.5, py + 0.5
    a, b, c = film_tri[tri_id, 0], film_tri[tri_id, 1], film_tri[tri_id, 2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = ((cx - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (cy - a[:, 1])) / det
        l2 = ((b[:, 0] - a[:, 0]) * (cy - a[:, 1]) - (cx - a[:, 0]) * (b[:, 1] - a[:, 1])) / det
    l0 = 1 - l1 - l2
    eps = -1e-9
    inside = (l0 >= eps) & (l1 >= eps) & (l2 >= eps) & np.isfinite(l1) & np.isfinite(l2)
    idx = py * width + px
    inside &= ~covered[idx]
    tri_id, idx = tri_id[inside], idx[inside]
    l0, l1, l2 = l0[inside], l1[inside], l2[inside]
    idx, first = np.unique(idx, return_index=True)          # one triangle per pixel
    tri_id, l0, l1, l2 = tri_id[first], l0[first], l1[first], l2[first]
    covered[idx] = True
    at = attrs[tri_id]
    vals = l0[:, None] * at[:, 0] + l1[:, None] * at[:, 1] + l2[:, None] * at[:, 2]
    return idx, vals


def morph_pixels(pr: Projection, width, height, covered):
    """The film pixels the projection's grid gives colour to and their interpolated
    attributes (slice x, slice y, W x transmittance, W) — what :func:`rasterize` returns
    for :func:`grid_triangles` — with ``covered`` updated the same way.

    A grid that vignetting left undeformed (every point where :func:`_grid` put it, every
    ray passed) is a regular lattice: each pixel centre's quad and its triangle (the
    quad split along the c00-c11 diagonal, as :func:`grid_triangles` splits it) follow
    from two floors, without scan conversion (3-5x faster); a deformed grid is scan
    converted. Pixel centres on the cell's right or bottom edge belong to the neighbour."""
    g = pr.grid_film.shape[0] - 1
    if not (pr.grid_ok.all() and np.array_equal(pr.grid_film, _grid(pr.cell, g))):
        tri_f, tri_a = grid_triangles(pr)
        return rasterize(tri_f, tri_a, width, height, covered)
    x0, y0, x1, y1 = pr.cell
    ix = np.arange(max(math.ceil(x0 - 0.5), 0), min(math.ceil(x1 - 0.5), width))
    iy = np.arange(max(math.ceil(y0 - 0.5), 0), min(math.ceil(y1 - 0.5), height))
    if not (len(ix) and len(iy)):
        return np.zeros(0, int), np.zeros((0, 4))
    u = (ix + 0.5 - x0) * (g / (x1 - x0))
    v = (iy + 0.5 - y0) * (g / (y1 - y0))
    i = np.minimum(u.astype(int), g - 1)
    j = np.minimum(v.astype(int), g - 1)
    fu = (u - i).astype(np.float32)[None, :]
    fv = (v - j).astype(np.float32)[:, None]
    att = grid_attributes(pr).astype(np.float32)
    # each triangle's attributes are affine: value at c00 + fu * x-step + fv * y-step;
    # table (g, g, 2 triangles, 3 coefficients, 4 attributes), one gather per pixel
    c00, c10, c01, c11 = att[:-1, :-1], att[:-1, 1:], att[1:, :-1], att[1:, 1:]
    table = np.stack([np.stack([c00, c10 - c00, c11 - c10], -2),     # (c00, c10, c11)
                      np.stack([c00, c11 - c01, c01 - c00], -2)], -3)  # (c00, c11, c01)
    k = ((j[:, None] * g + i[None, :]) * 2 + (fu < fv)).ravel()
    coef = table.reshape(-1, 3, 4)[k]
    shape = (len(iy), len(ix))
    vals = (coef[:, 0] + np.broadcast_to(fu, shape).reshape(-1, 1) * coef[:, 1]
            + np.broadcast_to(fv, shape).reshape(-1, 1) * coef[:, 2])
    idx = (iy[:, None] * width + ix[None, :]).ravel()
    free = ~covered[idx]
    idx, vals = idx[free], vals[free]
    covered[idx] = True
    return idx, vals


def grid_attributes(pr: Projection) -> np.ndarray:
    """(g+1, g+1, 4) per grid point: slice x, slice y, W x transmittance, W."""
    return np.concatenate([texcoords(pr), (pr.grid_weight * pr.grid_transmittance)[..., None],
                           pr.grid_weight[..., None]], -1)


def grid_triangles(pr: Projection):
    """(film triangles (k, 3, 2), attributes (k, 3, 4): slice x, slice y, W x
    transmittance, W) of the projection's grid quads whose four corners' rays passed."""
    f = pr.grid_film
    ok = pr.grid_ok
    quad_ok = ok[:-1, :-1] & ok[1:, :-1] & ok[:-1, 1:] & ok[1:, 1:]
    j, i = np.nonzero(quad_ok)
    att = grid_attributes(pr)
    c00, c10 = (j, i), (j, i + 1)
    c01, c11 = (j + 1, i), (j + 1, i + 1)
    tri_f = np.concatenate([np.stack([f[c00], f[c10], f[c11]], 1),
                            np.stack([f[c00], f[c11], f[c01]], 1)])
    tri_a = np.concatenate([np.stack([att[c00], att[c10], att[c11]], 1),
                            np.stack([att[c00], att[c11], att[c01]], 1)])
    return tri_f, tri_a


def bilinear(img, x, y):
    """(m, c) samples of img (h, w, c) at continuous pixel positions (x right, y down,
    pixel centres at k + 0.5), clamped at the border: the texture unit's bilinear filter."""
    h, w = img.shape[:2]
    fx = np.clip(x - 0.5, 0, w - 1)
    fy = np.clip(y - 0.5, 0, h - 1)
    x0 = np.minimum(np.floor(fx).astype(int), w - 2 if w > 1 else 0)
    y0 = np.minimum(np.floor(fy).astype(int), h - 2 if h > 1 else 0)
    tx, ty = fx - x0, fy - y0
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    a = img[y0, x0] * ((1 - tx) * (1 - ty))[:, None] + img[y0, x1] * (tx * (1 - ty))[:, None]
    return a + img[y1, x0] * ((1 - tx) * ty)[:, None] + img[y1, x1] * (tx * ty)[:, None]
