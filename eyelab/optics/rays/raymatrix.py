"""Wavefront transport along a fixed chief ray as a 4x4 (astigmatic ABCD) matrix.

Along one chief ray, every operation of Kakimoto's Table 1 maps the curvature matrix K of
the wave to K' = (C + D K)(A + B K)^-1 for 2x2 blocks A, B, C, D (the symplectic ray
transfer matrix of the bundle around the chief ray: position x' = A x + B p, 'slope'
p' = C x + D p with p = K x):

* transfer by d (Eq. 1):            A = I, B = -d I, C = 0, D = I
* refraction (Eq. 4), K' = S K S + G: A = S^-1, B = 0, C = G S^-1, D = S,
  S = diag(sqrt(mu), sqrt(mu) cos(phi)/cos(phi')) in the (u, v) frame
* change of tangent basis by R:      A = D = R, B = C = 0.

Composing them once per chief ray lets a blur field evaluate the whole lens for every
source distance along that ray with a few 2x2 operations per voxel (the wave from a
point source at distance L is K = -I/L, isotropic, so no starting basis is needed).
The result is the same physics as :class:`~eyelab.optics.rays.wavefront.Wavefront` (tested).
"""

from __future__ import annotations

import numpy as np

from eyelab.core.vecmath import any_tangent, cross, dot
from eyelab.optics.rays.wavefront import refraction_frame


def _blocks(a, b, c, d):
    n = a.shape[0]
    t = np.empty((n, 4, 4))
    t[:, :2, :2], t[:, :2, 2:], t[:, 2:, :2], t[:, 2:, 2:] = a, b, c, d
    return t


def _eye2(n, s=1.0):
    return np.broadcast_to(np.eye(2) * s, (n, 2, 2)) if np.isscalar(s) else \
        np.eye(2)[None] * np.asarray(s)[:, None, None]


def transfer_matrix(d):
    d = np.asarray(d, float)
    n = d.shape[0]
    z = np.zeros((n, 2, 2))
    return _blocks(_eye2(n), _eye2(n, -d), z, _eye2(n))


def basis_change(u_old, v_old, u_new, v_new):
    r = np.stack([np.stack([dot(u_new, u_old), dot(u_new, v_old)], -1),
                  np.stack([dot(v_new, u_old), dot(v_new, v_old)], -1)], -2)
    z = np.zeros_like(r)
    return _blocks(r, z, z, r)


def refraction_matrix(N, hit, mu, basis_u, basis_v):
    """Refraction of a wave travelling along N (n, 3) at ``hit``; the incoming K is expressed
    in (basis_u, basis_v). Returns (T including the basis change, new N, u, v')."""
    fr = refraction_frame(N, hit, mu, basis_u)
    new_dir, u, cos_i, cos_t, gamma = fr.new_dir, fr.u, fr.cos_i, fr.cos_t, fr.gamma
    ksu, ksv, ksuv = fr.ks
    rot = basis_change(basis_u, basis_v, u, cross(N, u))
    n = N.shape[0]
    s = np.zeros((n, 2, 2))
    s[:, 0, 0] = np.sqrt(mu)
    s[:, 1, 1] = np.sqrt(mu) * cos_i / cos_t
    sinv = np.zeros((n, 2, 2))
    sinv[:, 0, 0] = 1.0 / s[:, 0, 0]
    sinv[:, 1, 1] = 1.0 / s[:, 1, 1]
    g = np.empty((n, 2, 2))
    g[:, 0, 0] = gamma * ksu
    g[:, 0, 1] = g[:, 1, 0] = gamma * ksuv / cos_t
    g[:, 1, 1] = gamma * ksv / cos_t**2
    t = _blocks(sinv, np.zeros((n, 2, 2)), g @ sinv, s) @ rot
    return t, new_dir, u, cross(new_dir, u)


def lens_path_matrix(chief, lens, wavelength_nm, target_points, x_axis):
    """4x4 transport of the wave from the lens front hit, along the chief ray, through the
    lens and on to ``target_points`` (n, 3) (the pupil), ending in the basis
    (x_axis, N x x_axis). Returns (T (n, 4, 4), N at the target (n, 3))."""
    nl = lens.material.n(wavelength_nm)
    h_front, h_back = chief.hits
    N0 = chief.dir_in
    u0 = any_tangent(N0)
    v0 = cross(N0, u0)
    t1, N1, u1, v1 = refraction_matrix(N0, h_front, 1.0 / nl, u0, v0)
    t2 = transfer_matrix(np.linalg.norm(h_back.points - h_front.points, axis=1))
    t3, N2, u2, v2 = refraction_matrix(N1, h_back, nl, u1, v1)
    t4 = transfer_matrix(dot(target_points - h_back.points, N2))
    y_axis = cross(N2, x_axis)
    t5 = basis_change(u2, v2, x_axis, y_axis)
    return t5 @ t4 @ t3 @ t2 @ t1, N2


def apply_isotropic(t, v):
    """K_out for incoming K = v I through transport t: (C + v D)(A + v B)^-1.

    t : (..., 4, 4); v : (...) -> (kxx, kxy, kyy, det(A + v B)) each (...), K in the
    transport's final basis.
    """
    v = np.asarray(v, float)
    x00 = t[..., 0, 0] + v * t[..., 0, 2]
    x01 = t[..., 0, 1] + v * t[..., 0, 3]
    x10 = t[..., 1, 0] + v * t[..., 1, 2]
    x11 = t[..., 1, 1] + v * t[..., 1, 3]
    y00 = t[..., 2, 0] + v * t[..., 2, 2]
    y01 = t[..., 2, 1] + v * t[..., 2, 3]
    y10 = t[..., 3, 0] + v * t[..., 3, 2]
    y11 = t[..., 3, 1] + v * t[..., 3, 3]
    det = x00 * x11 - x01 * x10
    # A + v B singular: the wave is focused on the target itself; clamp (finite, huge K)
    inv = 1.0 / np.where(np.abs(det) < 1e-300, 1e-300, det)
    kxx = (y00 * x11 - y01 * x10) * inv
    kyy = (-y10 * x01 + y11 * x00) * inv
    # K is symmetric up to round-off: average the two off-diagonal entries
    kxy = 0.5 * ((-y00 * x01 + y01 * x00) + (y10 * x11 - y11 * x10)) * inv
    return kxx, kxy, kyy, det
