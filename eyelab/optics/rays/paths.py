"""Light-path finding: the chief ray from an object point through the lens to a target point.

The ray from the target (the eye's pupil centre, or its centre of rotation) is traced in
reverse (eye -> lens -> scene) with exact Snell refraction; its direction is found by a
vectorised Newton iteration so that the ray leaving the lens points at the object.
Light paths are reversible, so this is the Fermat path from the object to the target
(Kakimoto 2007 §4.2 finds it by image processing; eyelab solves it directly).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eyelab.core.constants import TOL
from eyelab.core.vecmath import any_tangent, cross, dot
from eyelab.optics.rays.trace import FATAL, Status


@dataclass
class ObjectPoints:
    """Object points relative to the world origin (pupil centre).

    direction : (n, 3) unit vectors from the origin toward each object
    distance : (n,) metres, may be ``inf`` (a point at infinity in that direction)
    """

    direction: np.ndarray
    distance: np.ndarray

    @classmethod
    def from_positions(cls, points):
        p = np.atleast_2d(np.asarray(points, float))
        d = np.linalg.norm(p, axis=1)
        return cls(p / np.where(d > 0, d, 1.0)[:, None], d)

    @classmethod
    def from_angles(cls, distance, field_x_deg, field_y_deg):
        """Distance (m, may be inf) and field angles: the direction is
        unit(tan fx, tan fy, -1), so fx > 0 is toward the wearer's right, fy > 0 up."""
        fx, fy, dist = np.broadcast_arrays(np.radians(np.asarray(field_x_deg, float)),
                                           np.radians(np.asarray(field_y_deg, float)),
                                           np.asarray(distance, float))
        d = np.stack([np.tan(fx), np.tan(fy), -np.ones_like(fx)], -1).reshape(-1, 3)
        return cls(d / np.linalg.norm(d, axis=1, keepdims=True), dist.ravel().copy())

    @classmethod
    def along_gazes(cls, directions, distances, rotation_centre: float):
        """Objects seen by an eye that turns about its centre of rotation (rotation_centre m
        behind the pupil, on +z): along each unit gaze ``directions`` (n, 3) from that
        centre, ``distances`` (n,) m from the turned pupil (inf: at infinity, parallel to
        the gaze)."""
        d = np.atleast_2d(np.asarray(directions, float))
        dist = np.broadcast_to(np.asarray(distances, float), (len(d),))
        fin = np.isfinite(dist)
        cor = np.array([0.0, 0.0, rotation_centre])
        pos = cor + d * np.where(fin, dist + rotation_centre, 1.0)[:, None]
        rel = np.where(fin[:, None], pos, d)
        return cls(rel / np.linalg.norm(rel, axis=1, keepdims=True),
                   np.where(fin, np.linalg.norm(pos, axis=1), np.inf))

    def __len__(self):
        return len(self.distance)

    @property
    def finite(self):
        return np.isfinite(self.distance)

    def positions(self):
        """(n, 3) positions; rows at infinity hold direction * 1e12 m (for display only)."""
        dist = np.where(self.finite, self.distance, 1e12)
        return self.direction * dist[:, None]


@dataclass
class ChiefRays:
    """Result of path finding for n object points.

    start : (n, 3) where the forward ray begins: the object (finite) or a point on the
        incoming ray 1 m before the lens (infinite)
    entry, exit : (n, 3) front / back surface hits (= the target when there is no lens)
    dir_in, dir_glass, dir_out : (n, 3) unit forward directions before, inside and after
    hits : (front Hit, back Hit) or None
    residual : (n,) final angular residual, radians
    iterations : (n,) Newton iterations used
    status : (n,) uint8
    """

    start: np.ndarray
    entry: np.ndarray
    exit: np.ndarray
    dir_in: np.ndarray
    dir_glass: np.ndarray
    dir_out: np.ndarray
    hits: tuple | None
    residual: np.ndarray
    iterations: np.ndarray
    status: np.ndarray
    object_distance_to_entry: np.ndarray


def _residual(lens, target, dirs, objects, wavelength_nm, ea, eb):
    res = lens.trace(target, dirs, wavelength_nm, reverse=True)
    q, dout = res["out_points"], res["out_dirs"]
    w = np.where(objects.finite[:, None], objects.positions() - q, objects.direction)
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    diff = w - dout
    return np.stack([dot(ea, diff), dot(eb, diff)], -1), res


def find_chief_rays(lens, target, objects: ObjectPoints, wavelength_nm: float = 587.56, *,
                    search: bool = True):
    """Chief rays from ``objects`` through ``lens`` (or straight, if ``lens`` is None) to
    ``target`` ((3,) or (n, 3), metres).

    Newton's method on the two transverse components of the reverse-traced direction,
    with a central-difference Jacobian (4 extra rays per row and iteration, traced in one
    call) and step halving when the residual grows. Converged rows are frozen. Newton
    starts from the straight line to the object; where that ends without a light path
    through the lens (it diverged at a strong lens's rim, or converged on the line that
    passes outside the lens while a path through it exists — an object seen both around
    and through a minus lens), ``search`` starts it again from the best of a grid of
    reverse rays aimed over the whole lens (:data:`SEARCH_GRID`), so a row is reported
    without a path only when none was found from any of them.
    """
    n = len(objects)
    target = np.broadcast_to(np.asarray(target, float), (n, 3)).copy()
    status = np.zeros(n, np.uint8)
    pos = objects.positions()
    # objects behind the target plane (or behind the eye) have no light path
    to_obj = np.where(objects.finite[:, None], pos - target, objects.direction)
    behind = to_obj[:, 2] >= -1e-9
    status[behind] |= np.uint8(Status.BEHIND)
    e0 = to_obj / np.linalg.norm(to_obj, axis=1, keepdims=True)
    e0[behind] = [0.0, 0.0, -1.0]
    if lens is None:
        dist = np.where(objects.finite, np.linalg.norm(pos - target, axis=1), np.inf)
        start = np.where(objects.finite[:, None], pos, target + e0)
        return ChiefRays(start, target.copy(), target.copy(), -e0, -e0, -e0, None,
                         np.zeros(n), np.zeros(n, int), status, dist)
    ea = any_tangent(e0)
    eb = cross(e0, ea)
    ab = np.zeros((n, 2))
    its = np.zeros(n, int)
    _newton(lens, target, objects, e0, ea, eb, ab, its, ~behind, wavelength_nm)
    r, res = _residual(lens, target, _dirs(e0, ea, eb, ab), objects, wavelength_nm, ea, eb)
    if search:
        lost = ~behind & ~_is_path(res, r, objects, pos)
        if lost.any():
            _search(lens, target, objects, e0, ea, eb, ab, its, np.flatnonzero(lost),
                    wavelength_nm, pos)
            r, res = _residual(lens, target, _dirs(e0, ea, eb, ab), objects, wavelength_nm,
                               ea, eb)
    rn = np.linalg.norm(r, axis=1)
    status |= res["status"]
    notconv = ~(rn <= TOL.path_fail) & ~behind
    status[notconv] |= np.uint8(Status.NOT_CONVERGED)
    q = res["out_points"]
    dist = np.where(objects.finite, np.linalg.norm(pos - q, axis=1), np.inf)
    # the object must lie in front of the lens along the outgoing ray
    in_front = np.where(objects.finite, dot(pos - q, res["out_dirs"]) > 0, True)
    status[~in_front & ~behind] |= np.uint8(Status.BEHIND)
    rev_dir = _dirs(e0, ea, eb, ab)
    start = np.where(objects.finite[:, None], pos, q + res["out_dirs"])
    h_back, h_front = res["hit1"], res["hit2"]
    return ChiefRays(start=start, entry=h_front.points, exit=h_back.points,
                     dir_in=-res["out_dirs"], dir_glass=-res["inside"], dir_out=-rev_dir,
                     hits=(h_front, h_back), residual=np.where(np.isfinite(rn), rn, np.inf),
                     iterations=its, status=status, object_distance_to_entry=dist)


#: Reverse rays per row of the fallback search: a SEARCH_GRID x SEARCH_GRID square over
#: the lens's front surface (the points inside its aperture), and how many of the best
#: Newton restarts from.
SEARCH_GRID = 33
SEARCH_STARTS = 6
#: Newton iterations of a restart (from a grid point it converges in a few; a restart that
#: has not converged by then started in no path's basin).
SEARCH_MAX_ITER = 15
#: Grid rays whose angular residual exceeds this (rad) are no start: the grid spacing
#: (1.9 mm on a 60 mm lens, ~0.2 rad seen from the pupil) bounds the residual of the grid
#: point nearest a path well below it.
SEARCH_MAX_RESIDUAL = 0.5


def _dirs(e0, ea, eb, ab):
    d = e0 + ab[:, :1] * ea + ab[:, 1:] * eb
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def _is_path(res, r, objects, pos):
    """Rows whose reverse ray passes the lens, points at the object (within
    TOL.path_fail) and has the object in front of it."""
    passed = (res["status"] & np.uint8(FATAL)) == 0
    rn = np.linalg.norm(r, axis=1)
    in_front = np.where(objects.finite, dot(pos - res["out_points"], res["out_dirs"]) > 0,
                        True)
    return passed & (rn <= TOL.path_fail) & in_front


def _newton(lens, target, objects, e0, ea, eb, ab, its, active, wavelength_nm,
            max_iter=None):
    """Newton iterations in place on ``ab`` (n, 2) for the rows of ``active`` (only those
    rows are traced)."""
    h = TOL.path_fd_step
    active = active.copy()
    r = np.zeros((len(ab), 2))
    rn = np.full(len(ab), np.inf)
    idx = np.flatnonzero(active)
    if len(idx):
        sub = ObjectPoints(objects.direction[idx], objects.distance[idx])
        r[idx], _ = _residual(lens, target[idx], _dirs(e0[idx], ea[idx], eb[idx], ab[idx]),
                              sub, wavelength_nm, ea[idx], eb[idx])
        rn[idx] = np.linalg.norm(r[idx], axis=1)
        active[idx] = rn[idx] > TOL.path_tol
        rn = np.where(np.isfinite(rn), rn, np.inf)
    for _ in range(max_iter or TOL.path_max_iter):
        if not active.any():
            break
        idx = np.flatnonzero(active)
        sub = ObjectPoints(objects.direction[idx], objects.distance[idx])
        # the central differences' four traces as one (each row is traced on its own, so
        # the rows are the same as four calls'; one call spares three calls' overhead)
        m = len(idx)
        steps = np.array([[h, 0.0], [-h, 0.0], [0.0, h], [0.0, -h]])
        four = (ab[idx][None] + steps[:, None]).reshape(-1, 2)
        t4, e04, ea4, eb4, d4 = (np.tile(v[idx], (4, 1)) for v in (target, e0, ea, eb,
                                                                    objects.direction))
        rf, _ = _residual(lens, t4, _dirs(e04, ea4, eb4, four),
                          ObjectPoints(d4, np.tile(objects.distance[idx], 4)), wavelength_nm,
                          ea4, eb4)
        rf = rf.reshape(4, m, 2)
        cols = [(rf[0] - rf[1]) / (2 * h), (rf[2] - rf[3]) / (2 * h)]
        j00, j10 = cols[0][:, 0], cols[0][:, 1]
        j01, j11 = cols[1][:, 0], cols[1][:, 1]
        det = j00 * j11 - j01 * j10
        ok = np.abs(det) > 1e-300
        det = np.where(ok, det, 1.0)
        ri = r[idx]
        step = -np.stack([(j11 * ri[:, 0] - j01 * ri[:, 1]) / det,
                          (-j10 * ri[:, 0] + j00 * ri[:, 1]) / det], -1)
        step[~ok] = 0.0
        # step halving (up to 4 times) where the residual would grow
        lam = np.ones(len(idx))
        for _half in range(5):
            trial = ab[idx] + lam[:, None] * step
            rt, _ = _residual(lens, target[idx], _dirs(e0[idx], ea[idx], eb[idx], trial), sub,
                              wavelength_nm, ea[idx], eb[idx])
            rtn = np.linalg.norm(rt, axis=1)
            worse = ~(rtn < rn[idx]) & (lam > 1 / 16)
            if not worse.any():
                break
            lam[worse] *= 0.5
        ab[idx] = trial
        r[idx] = rt
        rn[idx] = np.where(np.isfinite(rtn), rtn, np.inf)
        its[idx] += 1
        active[idx] = (rn[idx] > TOL.path_tol) & ok & np.isfinite(rn[idx])


def _search(lens, target, objects, e0, ea, eb, ab, its, rows, wavelength_nm, pos,
            chunk=64):
    """For ``rows`` without a light path: reverse rays from the target through a grid of
    points on the lens's front aperture; Newton again from the SEARCH_STARTS best passing
    ones (smallest angular residual), all restarts of a chunk of rows in one vectorised
    iteration; the first restart of a row that ends on a light path replaces its direction
    (``ab`` and ``its`` in place)."""
    front, _ = lens.placed_surfaces()
    rad = lens.diameter / 2
    u = np.linspace(-rad, rad, SEARCH_GRID)
    gu, gv = (g.ravel() for g in np.meshgrid(u, u))
    keep = gu * gu + gv * gv <= rad * rad
    # on the front surface itself (not its vertex plane: a steep surface's rim lies far
    # behind that plane, and rays through it cross the plane outside the aperture)
    local = np.stack([gu[keep], gv[keep], front.surface.sag(gu[keep], gv[keep])], 1)
    disc = local @ np.asarray(front.rotation, float).T + np.asarray(front.translation, float)
    m = len(disc)
    found = np.zeros(len(ab), bool)
    for a in range(0, len(rows), chunk):
        idx = rows[a:a + chunk]
        k = len(idx)
        d = disc[None, :, :] - target[idx][:, None, :]                 # (k, m, 3)
        d /= np.linalg.norm(d, axis=2, keepdims=True)
        fwd = np.einsum("kmj,kj->km", d, e0[idx])
        rep = np.repeat(idx, m)
        sub = ObjectPoints(objects.direction[rep], objects.distance[rep])
        r, res = _residual(lens, target[rep], d.reshape(-1, 3), sub, wavelength_nm,
                           ea[rep], eb[rep])
        rn = np.linalg.norm(r, axis=1).reshape(k, m)
        ok = ((res["status"] & np.uint8(FATAL)) == 0).reshape(k, m) & (fwd > 1e-3)
        rn = np.where(ok & np.isfinite(rn) & (rn < SEARCH_MAX_RESIDUAL), rn, np.inf)
        order = np.argsort(rn, axis=1)[:, :SEARCH_STARTS]              # (k, S)
        row_of, start_of = np.nonzero(np.isfinite(np.take_along_axis(rn, order, 1)))
        if not len(row_of):
            continue
        cr = idx[row_of]                                                # candidate rows
        dd = d[row_of, order[row_of, start_of]]
        f = fwd[row_of, order[row_of, start_of]]
        c_ab = np.stack([dot(dd, ea[cr]) / f, dot(dd, eb[cr]) / f], -1)
        c_its = its[cr].copy()
        c_obj = ObjectPoints(objects.direction[cr], objects.distance[cr])
        _newton(lens, target[cr], c_obj, e0[cr], ea[cr], eb[cr], c_ab, c_its,
                np.ones(len(cr), bool), wavelength_nm, max_iter=SEARCH_MAX_ITER)
        r2, res2 = _residual(lens, target[cr], _dirs(e0[cr], ea[cr], eb[cr], c_ab), c_obj,
                             wavelength_nm, ea[cr], eb[cr])
        good = _is_path(res2, r2, c_obj, pos[cr])
        # the first good restart of each row (candidates are in row, then start, order)
        g = np.flatnonzero(good)
        rows_g, first = np.unique(cr[g], return_index=True)
        ab[rows_g] = c_ab[g[first]]
        its[rows_g] = c_its[g[first]]
        found[rows_g] = True
    # polish the accepted restarts to the main iteration's tolerance (path_tol)
    _newton(lens, target, objects, e0, ea, eb, ab, its, found, wavelength_nm)
