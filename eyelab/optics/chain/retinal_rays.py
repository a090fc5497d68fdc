"""Rays from points of a schematic eye's curved retina out through the eye (and, by the
caller, the spectacle lens) into the scene: what the retinal image at fixation is made of.

A pixel of the retinal image is a line of sight: the direction in which a chief ray enters
the eye (the eye camera's pixel direction, from the entrance pupil's centre). Its retinal
point R is where that chief ray lands (:func:`retina_points`, at the eye's reference
wavelength). The light R gathers is carried by the rays from R through the stop: for each
sample point s of the stop (a disc at the lens's front vertex), the ray from R whose
reverse path through the crystalline lens crosses the stop plane at s is found by Newton's
method on its direction (:func:`rays_from_retina`), then traced on through the aqueous and
the cornea into the air.
"""

from __future__ import annotations

import numpy as np

from eyelab.core.vecmath import any_tangent, cross, dot
from eyelab.optics.chain.retina import _eye_part, aim_at_stop
from eyelab.optics.eye.schematic import SchematicEye
from eyelab.optics.rays.trace import Status, intersect, refract

#: Newton's iterations for a ray from the retina through a stop point (a fixed Jacobian,
#: the chief ray's: linear convergence, the residual shrinks ~10x per step), and the
#: residual (m) past which the ray is dropped.
RETINA_MAX_ITER = 12
RETINA_TOL = 1e-9
#: Step (rad) of the central differences of that Jacobian.
JACOBIAN_STEP = 1e-6


def camera_frame(camera) -> tuple:
    """(rotation (3, 3) eye frame -> world, corneal vertex (3,)) of the eye whose camera is
    ``camera`` (:class:`~eyelab.optics.rays.camera.Camera`: right, up, forward): the eye's
    z runs into it (-forward), its vertex is the camera's position."""
    r, u, f = camera.basis
    return np.stack([r, u, -f], axis=1), np.asarray(camera.position, float)


def _trace(placed, n, pairs, o, d):
    """Rays through ``placed[i]`` for each (i, n_before, n_after) of ``pairs`` in order:
    (points, directions, status)."""
    return _trace_path(placed, n, pairs, o, d)[:3]


def _trace_path(placed, n, pairs, o, d):
    """:func:`_trace` and the optical path (n,) from ``o`` to the last surface (m)."""
    st = np.zeros(len(o), np.uint8)
    path = np.zeros(len(o))
    for i, n1, n2 in pairs:
        h = intersect(placed[i], o, d)
        path = path + n[n1] * np.linalg.norm(h.points - o, axis=1)
        d, _, _, _, s = refract(d, h.normals, n[n1] / n[n2])
        o, st = h.points, st | h.status | s
    return o, d, st, path


def retina_points(eye: SchematicEye, rot, vertex, dirs, accommodation: float,
                  wavelength_nm: float):
    """Where the chief rays entering the eye along ``dirs`` (n, 3, world, into the eye)
    land on the retina: (points (n, 3) world, their directions in the vitreous (n, 3),
    status (n,))."""
    dirs = np.atleast_2d(np.asarray(dirs, float))
    pts, st = aim_at_stop(eye, rot, vertex, dirs, accommodation, wavelength_nm)
    placed, n, _ = eye.placed(rot, vertex, accommodation, wavelength_nm)
    o, d, s2 = _trace(placed, n, ((0, 0, 1), (1, 1, 2), (2, 2, 3), (3, 3, 4)),
                      pts - 0.05 * dirs, dirs)          # from in front of the cornea
    h = intersect(placed[4], o, d)
    return h.points, d, st | s2 | h.status


def rays_from_retina(eye: SchematicEye, rot, vertex, retina, v0, targets, jac_rows,
                     accommodation: float, wavelength_nm: float, *, path: bool = False):
    """Rays from retinal points out of the eye through given points of the stop.

    retina : (m, 3) world points on the retina; v0 : (m, 3) unit directions into the eye
    of their chief rays in the vitreous; targets : (m, 2) the stop points (m, in the eye's
    x, y from the stop's centre); jac_rows : (m,) the row of :func:`stop_jacobians`' result
    each ray takes its Jacobian from (its pixel's), with that result as ``jac_rows[1]``.

    Returns (origins (m, 3) on the cornea's front, directions (m, 3) scene-ward, ok (m,));
    with ``path``, also the optical path (m,) from the retina to the cornea's front (m).
    """
    rows, jac = jac_rows
    placed, n, _ = eye.placed(rot, vertex, accommodation, wavelength_nm)
    stop = vertex + rot @ np.array([0.0, 0.0, eye.stop_z(accommodation)])
    e1 = any_tangent(v0)
    e2 = cross(v0, e1)
    inv = np.linalg.inv(jac)[rows]                              # (m, 2, 2)
    ab = np.einsum("mij,mj->mi", inv, targets)                  # the linear guess
    for _ in range(RETINA_MAX_ITER):
        got, _ = _to_stop(placed, n, rot, stop, retina, v0, e1, e2, ab)
        r = got - targets
        ab = ab - np.einsum("mij,mj->mi", inv, r)
        if np.all(np.abs(r) < RETINA_TOL):
            break
    got, (o, d, st, inner) = _to_stop(placed, n, rot, stop, retina, v0, e1, e2, ab)
    ok = np.all(np.abs(got - targets) < 1e3 * RETINA_TOL, axis=1)
    o, d, s2, outer = _trace_path(placed, n, ((1, 2, 1), (0, 1, 0)), o, d)
    ok &= ((st | s2) & np.uint8(Status.MISSED | Status.TIR)) == 0
    return (o, d, ok, inner + outer) if path else (o, d, ok)


def stop_jacobians(eye: SchematicEye, rot, vertex, retina, v0, accommodation: float,
                   wavelength_nm: float):
    """(m, 2, 2): d(stop crossing x, y) / d(a, b) of the ray from each retinal point with
    direction v0 + a e1 + b e2 (the frame :func:`rays_from_retina` uses), by central
    differences."""
    placed, n, _ = eye.placed(rot, vertex, accommodation, wavelength_nm)
    stop = vertex + rot @ np.array([0.0, 0.0, eye.stop_z(accommodation)])
    e1 = any_tangent(v0)
    e2 = cross(v0, e1)
    h = JACOBIAN_STEP
    cols = []
    for step in ((h, 0.0), (0.0, h)):
        ab = np.broadcast_to(np.array(step), (len(v0), 2))
        plus, _ = _to_stop(placed, n, rot, stop, retina, v0, e1, e2, ab)
        minus, _ = _to_stop(placed, n, rot, stop, retina, v0, e1, e2, -ab)
        cols.append((plus - minus) / (2 * h))
    return np.stack(cols, -1)


def _to_stop(placed, n, rot, stop, retina, v0, e1, e2, ab):
    """The stop-plane crossing (m, 2; eye x, y from the stop's centre) of reverse rays from
    the retina with directions -(v0 + a e1 + b e2), and (points, directions, status) of
    each ray at the crystalline lens's front surface, travelling out, and its optical path
    from the retina)."""
    v = v0 + ab[:, :1] * e1 + ab[:, 1:] * e2
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    o, d, st, path = _trace_path(placed, n, ((3, 4, 3), (2, 3, 2)), retina, -v)
    normal = np.broadcast_to(rot[:, 2], d.shape)
    s = dot(stop - o, normal) / dot(d, normal)
    q = o + s[:, None] * d - stop
    return np.stack([q @ rot[:, 0], q @ rot[:, 1]], -1), (o, d, st, path)


def needed_wave(eye: SchematicEye, rot, vertex, dirs, x_axis, accommodation: float,
                wavelength_nm: float):
    """The wave (kxx, kxy, kyy; 1/m = D in air) each line of sight entering the eye along
    ``dirs`` (n, 3) needs to be focused on the retina, where its chief ray (aimed at the
    stop's centre) crosses the entrance pupil's plane, in the basis (x, N x x) with x =
    ``x_axis`` (n, 3) across each ray: the far point's wave (:func:`~eyelab.optics.chain.
    retina.trace_lines`' refraction with nothing arriving). Also the status (n,)."""
    from eyelab.optics.rays.wavefront import Wavefront

    dirs = np.atleast_2d(np.asarray(dirs, float))
    points, st = aim_at_stop(eye, rot, vertex, dirs, accommodation, wavelength_nm)
    # the chain takes the wave where the ray crosses the corneal vertex plane
    normal = np.broadcast_to(rot[:, 2], dirs.shape)
    back = dot(points - vertex, normal) / dot(dirs, normal)
    ref = points - back[:, None] * dirs
    flat = Wavefront.spherical(dirs, np.inf)              # nothing arriving: E = need
    got = _eye_part(eye, rot, vertex, accommodation, wavelength_nm, ref, dirs, flat)
    euu, euv, evv = got["err"].T
    # from the basis (u, N x u) (u: the eye's x across the ray) to (x, N x x)
    u = rot[:, 0] - dot(np.broadcast_to(rot[:, 0], dirs.shape), dirs)[:, None] * dirs
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    c, s = dot(x_axis, u), dot(x_axis, cross(dirs, u))
    kxx = c * c * euu + 2 * c * s * euv + s * s * evv
    kyy = s * s * euu - 2 * c * s * euv + c * c * evv
    kxy = c * s * (evv - euu) + (c * c - s * s) * euv
    need = Wavefront(dirs.copy(), np.array(x_axis, float), kxx, kxy, kyy,
                     np.zeros(len(dirs), np.uint8)).transfer(back)   # on to the pupil's plane
    return (need.k11, need.k12, need.k22), st | got["status"] | need.status
