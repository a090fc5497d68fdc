"""Independent truths computed the slow, obvious way: real ray bundles.

These helpers use only exact ray intersection and Snell's law (``SpectacleLens.trace``),
never the wavefront code or the path finder, so they check both independently; the tests
and ``eyelab bench stability`` use them.
"""

import numpy as np

from eyelab.core.vecmath import any_tangent
from eyelab.optics.rays.trace import FATAL


def bundle_vergence(lens, start, dir_in, finite, pupil, n_chief, x_axis, *,
                    radius=1e-4, rings=6, spokes=24, wavelength_nm=587.56, strict=True):
    """Curvature matrix (D) of the wave arriving at ``pupil``, measured from real rays.

    Rays leave the object (``start``, one point; or parallel rays around it for an object at
    infinity) in a small cone/tube around the chief ray, pass the lens exactly, and are cut by
    the plane through ``pupil`` perpendicular to ``n_chief``. A least-squares linear fit of the
    rays' transverse direction components against their transverse positions gives
    T = T0 + J rho, and the wave's curvature matrix is K = -J (rays of a wave of curvature K
    head toward its centre of curvature). Centrally symmetric sampling makes the fit blind
    to the quadratic (coma) terms; the residual bias is the cubic term, ~radius^2.

    Returns (kxx, kxy, kyy) in the basis (x_axis, n_chief x x_axis) and the fit's J; None
    when any ray of the bundle fails in the lens (``strict=False``; else AssertionError).
    """
    e_a = any_tangent(dir_in[None])[0]
    e_b = np.cross(dir_in, e_a)
    r = np.concatenate([[0.0], np.repeat(np.linspace(radius / rings, radius, rings), spokes)])
    t = np.concatenate([[0.0], np.tile(np.linspace(0, 2 * np.pi, spokes, endpoint=False),
                                       rings)])
    off = (r * np.cos(t))[:, None] * e_a + (r * np.sin(t))[:, None] * e_b
    if finite:
        # angular cone: the spread at the lens ~ radius * 1 m / distance; keep ~0.1 mm there
        dist = np.linalg.norm(pupil - start)
        dirs = dir_in + off * (1.0 / max(dist, 1e-3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        origins = np.broadcast_to(start, dirs.shape).copy()
    else:
        dirs = np.broadcast_to(dir_in, off.shape).copy()
        origins = start + off
    if lens is not None:
        res = lens.trace(origins, dirs, wavelength_nm)
        if not (res["status"] == 0).all():
            assert not strict, "a bundle ray failed in the lens"
            return None
        origins, dirs = res["out_points"], res["out_dirs"]
    s = ((pupil - origins) @ n_chief) / (dirs @ n_chief)
    q = origins + s[:, None] * dirs
    y_axis = np.cross(n_chief, x_axis)
    rho = np.stack([(q - pupil) @ x_axis, (q - pupil) @ y_axis], 1)
    tr = np.stack([dirs @ x_axis, dirs @ y_axis], 1)
    a = np.column_stack([np.ones(len(rho)), rho])
    coef, *_ = np.linalg.lstsq(a, tr, rcond=None)
    j = coef[1:].T  # j[i, k] = d T_i / d rho_k
    k = -0.5 * (j + j.T)
    return k[0, 0], k[0, 1], k[1, 1], j


def retinal_spot_axes(eye, k_in, acc, n_rim=4096):
    """Semi-axes (m) and major-axis angle of the retinal spot by tracing pupil-rim rays through
    the thin toric eye, in slope form: a ray at pupil point rho with incoming slope s = -K rho
    leaves with n2 s' = n1 s - P rho and meets the retina at rho + z_r s'.

    k_in : (kxx, kxy, kyy) of the arriving wave in the eye (x, y) frame, 1/m
    """
    kxx, kxy, kyy = k_in
    t = np.linspace(0, 2 * np.pi, n_rim, endpoint=False)
    rho = eye.pupil_diameter / 2 * np.stack([np.cos(t), np.sin(t)], 1)
    k = np.array([[kxx, kxy], [kxy, kyy]])
    pxx, pxy, pyy = (float(v) for v in eye.power_matrix(acc))
    p = np.array([[pxx, pxy], [pxy, pyy]])
    s_in = -(rho @ k.T)
    s_out = (s_in - rho @ p.T) / eye.n_vitreous
    spot = rho + eye.retina_distance * s_out
    # support: the ellipse's semi-axes from the farthest/nearest rim images
    rr = np.linalg.norm(spot, axis=1)
    i = np.argmax(rr)
    major = rr[i]
    ang = np.arctan2(spot[i, 1], spot[i, 0]) % np.pi
    minor = rr.min()
    return major, minor, ang


def search_path(lens, target, position, finite, direction, *, grid=41, starts=3,
                wavelength_nm=587.56, tol=1e-7, max_nfev=60):
    """Whether a light path from an object through ``lens`` to ``target`` exists, found by
    exhaustive search rather than by the path finder's Newton iteration.

    Reverse rays leave ``target`` in a ``grid`` x ``grid`` fan of directions that covers the
    whole lens (every direction whose line meets the lens's bounding disc, with margin);
    each is traced back through the lens exactly, and its angular residual measured (between
    the ray leaving the front surface and the direction to the object: ``position`` for a
    finite object, ``direction`` -- unit, from the eye toward the object -- for an infinite
    one). From the ``starts`` best rays that pass, scipy's trust-region least squares
    refines the residual. Independent of :func:`eyelab.optics.rays.paths.find_chief_rays`: an
    angular fan around the line to the lens centre (not points on the front surface, nor
    the straight line to the object) and a different solver (not Newton with halving).

    Returns (found, residual): found when a passing ray's residual is below ``tol`` rad and
    the object lies in front of the lens along it.
    """
    from scipy.optimize import least_squares

    front, _back = lens.placed_surfaces()
    centre = np.asarray(front.translation, float)
    axis0 = centre - target
    dist = np.linalg.norm(axis0)
    axis0 /= dist
    e_a = any_tangent(axis0[None])[0]
    e_b = np.cross(axis0, e_a)
    reach = (lens.diameter / 2 + 0.01) / max(dist - lens.center_thickness, 1e-3)

    def dirs_of(uv):
        d = axis0 + uv[:, :1] * e_a + uv[:, 1:] * e_b
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    def residual(uv):
        uv = np.atleast_2d(uv)
        d = dirs_of(uv)
        res = lens.trace(np.broadcast_to(target, d.shape).copy(), d, wavelength_nm,
                         reverse=True)
        q, dout = res["out_points"], res["out_dirs"]
        want = position - q if finite else np.broadcast_to(direction, q.shape)
        want = want / np.linalg.norm(want, axis=1, keepdims=True)
        r = np.stack([want @ e_a - dout @ e_a, want @ e_b - dout @ e_b,
                      (want - dout) @ axis0], 1)
        passed = (res["status"] & np.uint8(FATAL)) == 0
        front_ok = np.einsum("ij,ij->i", position - q, dout) > 0 if finite \
            else np.ones(len(q), bool)
        return r, passed & front_ok

    u = np.linspace(-reach, reach, grid)
    uv = np.stack(np.meshgrid(u, u), -1).reshape(-1, 2)
    r, ok = residual(uv)
    if not ok.any():
        return False, np.inf
    rn = np.where(ok, np.linalg.norm(r, axis=1), np.inf)
    best = np.inf
    for i in np.argsort(rn)[:starts]:
        if not np.isfinite(rn[i]):
            break

        def fun(p):
            rr, okk = residual(p[None])
            return rr[0] if okk[0] else np.full(3, 1.0)

        sol = least_squares(fun, uv[i], method="trf", xtol=1e-15, ftol=1e-15, gtol=1e-15,
                            max_nfev=max_nfev)
        rr, okk = residual(sol.x[None])
        if okk[0]:
            best = min(best, float(np.linalg.norm(rr[0])))
        if best < tol:
            return True, best
    return False, best


def extrapolated_vergence(lens, start, dir_in, finite, pupil, n_chief, x_axis, *,
                          radii=(2e-5, 1e-5), strict=True):
    """:func:`bundle_vergence` at two bundle radii r and r/2, extrapolated to radius 0
    (Richardson: the fit's bias grows as radius^2): ((kxx, kxy, kyy) (3,), the largest
    change the extrapolation made — an estimate of the error left), or None when a bundle
    ray fails in the lens and ``strict`` is False."""
    fits = [bundle_vergence(lens, start, dir_in, finite, pupil, n_chief, x_axis, radius=r,
                            strict=strict) for r in radii]
    if any(f is None for f in fits):
        return None
    k2, k1 = (np.array(f[:3]) for f in fits)
    return (4.0 * k1 - k2) / 3.0, float(np.abs(k1 - k2).max())
