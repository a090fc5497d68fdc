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

from eyelab.constants import TOL
from eyelab.optics.trace import Status
from eyelab.vecmath import any_tangent, cross, dot


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


def find_chief_rays(lens, target, objects: ObjectPoints, wavelength_nm: float = 587.56):
    """Chief rays from ``objects`` through ``lens`` (or straight, if ``lens`` is None) to
    ``target`` ((3,) or (n, 3), metres).

    Newton's method on the two transverse components of the reverse-traced direction,
    with a central-difference Jacobian (4 extra traces per iteration, all vectorised) and
    step halving when the residual grows. Converged rows are frozen.
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
    h = TOL.path_fd_step

    def dirs_of(ab_):
        d = e0 + ab_[:, :1] * ea + ab_[:, 1:] * eb
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    r, res = _residual(lens, target, dirs_of(ab), objects, wavelength_nm, ea, eb)
    rn = np.linalg.norm(r, axis=1)
    its = np.zeros(n, int)
    active = (rn > TOL.path_tol) & ~behind
    for _ in range(TOL.path_max_iter):
        if not active.any():
            break
        idx = np.flatnonzero(active)
        sub = ObjectPoints(objects.direction[idx], objects.distance[idx])
        cols = []
        for k in range(2):
            dab = np.zeros((len(idx), 2))
            dab[:, k] = h
            rp, _ = _residual(lens, target[idx], dirs_of_sub(e0, ea, eb, idx, ab[idx] + dab),
                              sub, wavelength_nm, ea[idx], eb[idx])
            rm, _ = _residual(lens, target[idx], dirs_of_sub(e0, ea, eb, idx, ab[idx] - dab),
                              sub, wavelength_nm, ea[idx], eb[idx])
            cols.append((rp - rm) / (2 * h))
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
            rt, _ = _residual(lens, target[idx], dirs_of_sub(e0, ea, eb, idx, trial), sub,
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
    r, res = _residual(lens, target, dirs_of(ab), objects, wavelength_nm, ea, eb)
    rn = np.linalg.norm(r, axis=1)
    status |= res["status"]
    notconv = ~(rn <= TOL.path_fail) & ~behind
    status[notconv] |= np.uint8(Status.NOT_CONVERGED)
    q = res["out_points"]
    dist = np.where(objects.finite, np.linalg.norm(pos - q, axis=1), np.inf)
    # the object must lie in front of the lens along the outgoing ray
    in_front = np.where(objects.finite, dot(pos - q, res["out_dirs"]) > 0, True)
    status[~in_front & ~behind] |= np.uint8(Status.BEHIND)
    rev_dir = dirs_of(ab)
    start = np.where(objects.finite[:, None], pos, q + res["out_dirs"])
    h_back, h_front = res["hit1"], res["hit2"]
    return ChiefRays(start=start, entry=h_front.points, exit=h_back.points,
                     dir_in=-res["out_dirs"], dir_glass=-res["inside"], dir_out=-rev_dir,
                     hits=(h_front, h_back), residual=np.where(np.isfinite(rn), rn, np.inf),
                     iterations=its, status=status, object_distance_to_entry=dist)


def dirs_of_sub(e0, ea, eb, idx, ab):
    d = e0[idx] + ab[:, :1] * ea[idx] + ab[:, 1:] * eb[idx]
    return d / np.linalg.norm(d, axis=1, keepdims=True)
