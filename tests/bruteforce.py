"""Independent truths computed the slow, obvious way: real ray bundles.

These helpers use only exact ray intersection and Snell's law (``SpectacleLens.trace``),
never the wavefront code, so they check the wavefront tracer independently.
"""

import numpy as np

from eyelab.vecmath import any_tangent


def bundle_vergence(lens, start, dir_in, finite, pupil, n_chief, x_axis, *,
                    radius=1e-4, rings=6, spokes=24, wavelength_nm=587.56):
    """Curvature matrix (D) of the wave arriving at ``pupil``, measured from real rays.

    Rays leave the object (``start``, one point; or parallel rays around it for an object at
    infinity) in a small cone/tube around the chief ray, pass the lens exactly, and are cut by
    the plane through ``pupil`` perpendicular to ``n_chief``. A least-squares linear fit of the
    rays' transverse direction components against their transverse positions gives
    T = T0 + J rho, and the wave's curvature matrix is K = -J (rays of a wave of curvature K
    head toward its centre of curvature). Centrally symmetric sampling makes the fit blind
    to the quadratic (coma) terms; the residual bias is the cubic term, ~radius^2.

    Returns (kxx, kxy, kyy) in the basis (x_axis, n_chief x x_axis) and the fit's J.
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
        assert (res["status"] == 0).all()
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
