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
:class:`CameraRays` (a :class:`~eyelab.optics.cameralens.system.LensSystem` and its film) and
:class:`EyeRays` (the thin toric eye of the other renderers, with or without a spectacle
lens: the eye's pupil is the image-sided surface, the eye camera's image the film).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from eyelab.core.errors import SpecError
from eyelab.core.vecmath import UP, unit
from eyelab.render.imagebased.cop import (
    angle_errors_deg,
    fit_cop_angle,
    fit_cop_least_squares,
    image_plane_points,
)


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
    layer: int | None = None     # a lenslet lens's layer: -1 the carrier, i lenslet i
    grid_site: np.ndarray | None = None  # (g+1, g+1, 2) front-surface crossings (layers)


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
                     oversample: float = 2.0, max_slice: int = 2048,
                     cell: tuple | None = None, layer: int | None = None) -> Plan:
    """Every projection of a frame (Heidrich §3.1-3.4): per sample, the film as a quad-tree
    of cells, each with a ``grid`` x ``grid`` grid of rays, its COP (``cop`` = "angle":
    the Newton fit of Eq. 1; "lsq": the least-squares-distance point), split while the
    maximum angle error exceeds ``threshold_deg`` and the depth is below ``max_depth``.
    The image plane lies ``plane_distance`` m along the cell's mean ray direction (default:
    the maker's near distance: the angle error at infinity, which the criterion measures,
    then bounds the angular error of every scene point at or beyond the plane, the error
    growing as |1/D - 1/D_plane| with the depth D). Slices get ``oversample`` x the film's pixel
    density, at most ``max_slice`` pixels a side. ``cell`` (x0, y0, x1, y1): the film
    region planned (default the whole film); ``layer``: the lenslet layer the projections
    draw (:mod:`eyelab.render.imagebased.layers`; they keep the rays' front-surface
    crossings)."""
    if cop not in ("angle", "lsq"):
        raise SpecError("render.cop", f"must be 'angle' or 'lsq', got {cop!r}")
    dist = maker.near if plane_distance is None else plane_distance
    projections = []
    stats = {"cells": 0, "vignetted_cells": 0, "newton_steps": 0, "split": 0,
             "unresolved_cells": 0}
    full = (0.0, 0.0, float(maker.width), float(maker.height)) if cell is None else \
        tuple(float(c) for c in cell)
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
            pr = _projection(si, depth, cell, g_film, rs, e, dist, normal, err, grid,
                             oversample, max_slice)
            if layer is not None:
                pr.layer, pr.grid_site = layer, rs.site.reshape(grid + 1, grid + 1, 2)
            projections.append(pr)
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
