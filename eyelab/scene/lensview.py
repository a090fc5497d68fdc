"""The spectacle lens as the eye sees it: is it in view, and the meshes on its back surface
that carry the per-vertex refraction (Kakimoto 2007, §3). Pure numpy."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from eyelab.core.errors import SpecError
from eyelab.optics.rays.camera import Camera
from eyelab.optics.rays.trace import FATAL, intersect


def view_rays_through(lens, cam: Camera, samples: int) -> np.ndarray:
    """(samples^2,) bool: which rays of a ``samples`` x ``samples`` grid over the camera's
    view (its border included) pass through the lens."""
    g = np.linspace(-1.0, 1.0, samples)
    gx, gy = np.meshgrid(g, g)
    d = cam.ray_directions(gx.ravel(), gy.ravel())
    o = np.broadcast_to(np.asarray(cam.position, float), d.shape)
    res = lens.trace(o, d, reverse=True)
    return (res["status"] & np.uint8(FATAL)) == 0


def lens_in_view_of(lens, cam: Camera, samples: int = 17) -> bool:
    """True if any ray of a grid over the camera's view passes through the lens."""
    return bool(np.any(view_rays_through(lens, cam, samples)))


def lens_covers_view(lens, cam: Camera, samples: int = 33, margin: float = 0.99) -> bool:
    """True if every ray of a grid over the camera's view (its border included) passes
    through the lens shrunk to ``margin`` of its diameter (the outline the renderer masks
    with is at 99.5 %): the lens and the view are both convex, so then every pixel sees
    through the lens. A lens cut to a frame is shrunk about its outline's centre (an
    outline need not be convex: a grid's rays all through it is then taken as covering)."""
    if lens.outline is not None:
        small = dataclasses.replace(lens, outline=lens.outline.scaled(margin))
    else:
        small = dataclasses.replace(lens, diameter=lens.diameter * margin)
    return bool(np.all(view_rays_through(small, cam, samples)))


def widened_lens(lens, factor: float = 1.15, max_diameter: float = 0.09):
    """The same lens with a ``factor`` larger aperture where its surfaces allow (else the
    lens itself): used only for texture coordinates of grid vertices just outside the rim,
    so that rim cells are filled (the outline mask clips them). A lens cut to a frame
    widens its whole blank: the cut is dropped."""
    if lens.outline is not None:
        lens = dataclasses.replace(lens, outline=None)
    d = min(lens.diameter * factor, max_diameter)
    r = d / 2
    for surf in (lens.front, lens.back):
        if not bool(np.all(surf.derivatives(np.array([r, 0.0, -r, 0.0]),
                                            np.array([0.0, r, 0.0, -r])).valid)):
            return lens
    try:
        return dataclasses.replace(lens, diameter=d)
    except SpecError:            # a plus lens's surfaces cross beyond its thin edge
        return lens


def lens_view_mesh(lens, cam: Camera, width: int, height: int, step_px: int):
    """Grid mesh on the (widened) lens's back surface: where eye rays through every
    ``step_px``-th pixel (one cell of margin around the view) meet it; cells whose corners
    all meet it. Returns (vertices (ny * nx, 3) m, faces (m, 3)); vertex j * nx + i lies on
    the ray through NDC (gx[i], gy[j]) of the grid's nx x ny points, one cell beyond the
    view on each side."""
    nx = max(2, int(math.ceil(width / step_px)) + 3)
    ny = max(2, int(math.ceil(height / step_px)) + 3)
    gx = np.linspace(-1 - 2 * step_px / width, 1 + 2 * step_px / width, nx)
    gy = np.linspace(-1 - 2 * step_px / height, 1 + 2 * step_px / height, ny)
    mx, my = np.meshgrid(gx, gy)
    d = cam.ray_directions(mx.ravel(), my.ravel())
    _, back = widened_lens(lens).placed_surfaces()
    hit = intersect(back, np.broadcast_to(np.asarray(cam.position, float), d.shape), d)
    ok = hit.status == 0
    idx = np.arange(nx * ny).reshape(ny, nx)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, e = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, e], 1), np.stack([a, e, c], 1)])
    faces = faces[ok[faces].all(1)]
    # a vertex off the (widened) lens belongs to no face: a point on its ray keeps its
    # direction from the pupil defined (a lens smaller than a wide view)
    pts = np.where(ok[:, None], hit.points, np.asarray(cam.position, float)
                   + d * lens.pose.vertex_distance)
    return pts, faces


#: How far out the outline mesh reaches: of the round blank's radius (its rim's rays
#: graze the aperture), and of a frame's outline (its own vertices, just inside).
ROUND_FILL, OUTLINE_FILL = 0.995, 1.0 - 1e-4


def lens_back_mesh(lens, rings: int, segments: int):
    """The lens's back surface as a polar grid (world): the outline of the lens as the eye
    sees it — out to :data:`ROUND_FILL` of the round blank's radius in ``segments``
    directions, or, for a lens cut to a frame, rings about its outline's centre through
    :data:`OUTLINE_FILL` of each of the outline's own vertices (the trace's polygon).
    Returns (vertices (n, 3) m, faces (m, 3))."""
    if lens.outline is None:
        c = np.zeros(2)
        th = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
        rim = np.full(segments, ROUND_FILL * lens.diameter / 2)
    else:
        c = np.asarray(lens.outline.centre, float)
        th = np.asarray(lens.outline.angles, float)
        rim = OUTLINE_FILL * np.asarray(lens.outline.radii, float)
    segments = len(th)
    ss, rr = np.meshgrid(np.linspace(0.0, 1.0, rings + 1)[1:], rim, indexing="ij")
    tt = np.broadcast_to(th, rr.shape)
    x = np.concatenate([[c[0]], (c[0] + ss * rr * np.cos(tt)).ravel()])
    y = np.concatenate([[c[1]], (c[1] + ss * rr * np.sin(tt)).ravel()])
    _, back = lens.placed_surfaces()
    z = back.surface.sag(x, y)
    v = np.stack([x, y, z], 1) @ back.rotation.T + back.translation
    i = np.arange(segments)
    j = (i + 1) % segments
    fan = np.stack([np.zeros(segments, int), 1 + i, 1 + j], 1)
    ring = np.arange(rings - 1)[:, None] * segments
    a, b = 1 + ring + i, 1 + ring + j
    quads = np.stack([np.stack([a, a + segments, b + segments], -1),
                      np.stack([a, b + segments, b], -1)], axis=2).reshape(-1, 3)
    return v, np.concatenate([fan, quads])
