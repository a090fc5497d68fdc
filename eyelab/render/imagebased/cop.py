"""The virtual centre of projection of a bundle of rays (Heidrich et al. 1997, §3.3): the
point maximising sum cos^2 of the angles between the rays and the projection's rays
(Eq. 1, Newton iteration), the least-squares-distance point of Gremban et al. for
comparison, and the angle errors of a projection."""

from __future__ import annotations

import numpy as np

from eyelab.core.vecmath import unit


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
    from eyelab.optics.rays.camera import least_squares_point

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
