"""How an eye focuses on what each pixel shows: the accommodation rules shared by the
renderers that trace the eye's rays (the reference renderer, the image-based renderer).

:func:`pixel_accommodation` finds, for each pixel's chief ray (through the spectacle lens
where it passes it), the first scene point (embree) and the accommodation for it: Kakimoto's
Eq. 13 on the point's wave carried along the chief ray (the blur field's rule), Fons et
al. 2023's lowest-error-meridian rule (:func:`fons_accommodation`), or the accommodation
minimising the real rays' retinal spot (:func:`rms_accommodation`).
"""

from __future__ import annotations

import numpy as np

from eyelab.core.sampling import disc_seeds
from eyelab.core.vecmath import UP, cross, unit
from eyelab.optics.eye.thin import EYE_REFERENCE_NM
from eyelab.optics.rays.paths import ChiefRays
from eyelab.optics.rays.raymatrix import apply_isotropic, lens_path_matrix
from eyelab.optics.rays.trace import FATAL


def pixel_accommodation(d, scene, inter, eye, lens, view, cam, model: str = "thin",
                        rule: str = "eq13"):
    """The accommodation (D) of each pixel (chief directions ``d`` (m, 3) from the pupil
    centre): the view's fixed focus, or for the first scene point along the chief ray
    (through the lens where it passes it; embree) the accommodation by ``rule`` — Eq. 13 on
    the wave of that point carried along the chief ray (the blur field's rule), Fons et
    al.'s for ``model`` "fons", or the real-ray RMS rule ("rms"). Through a lenslet lens
    the eye focuses the carrier's image. Returns (acc (m,), the RMS rule's differences from
    Eq. 13 where it was used (k,))."""
    from eyelab.optics.lens.lenslets import carrier

    lens = carrier(lens)            # a lenslet lens: the eye focuses its carrier's image
    m = len(d)
    pupil = np.asarray(cam.position, float)
    if view.focus_d is not None:
        return np.full(m, min(max(float(view.focus_d), 0.0), eye.accommodation_max)), \
            np.zeros(0)
    # 1. chief rays: through the lens where they pass it
    through = np.zeros(m, bool)
    q = np.broadcast_to(pupil, (m, 3)).copy()
    dq = d.copy()
    if lens is not None:
        res = lens.trace(q, d, EYE_REFERENCE_NM, reverse=True)
        through = (res["status"] & np.uint8(FATAL)) == 0
        q = np.where(through[:, None], res["out_points"], pupil)
        dq = np.where(through[:, None], res["out_dirs"], d)
    hit = inter.intersect(q + 1e-7 * dq, dq)
    dist = np.where(hit.hit, hit.t + 1e-7, np.inf)
    # 2. accommodation (Eq. 13) from the wave of the hit point along the chief ray
    with np.errstate(divide="ignore"):
        v = np.where(np.isfinite(dist), -1.0 / dist, 0.0)
    kbar = v.copy()
    if lens is not None and through.any():
        idx = np.flatnonzero(through)
        h_back, h_front = res["hit1"], res["hit2"]
        chief = ChiefRays(None, h_front.points[idx], h_back.points[idx], -dq[idx],
                          -res["inside"][idx], -d[idx],
                          (h_front.take(idx), h_back.take(idx)),
                          None, None, np.zeros(len(idx), np.uint8), dist[idx])
        n_in = -d[idx]
        x_e = unit(cross(np.broadcast_to(UP, n_in.shape), n_in))
        t, _ = lens_path_matrix(chief, lens, EYE_REFERENCE_NM,
                                np.broadcast_to(pupil, (len(idx), 3)), x_e)
        kxx, _, kyy, _ = apply_isotropic(t, v[idx])
        kbar[idx] = 0.5 * (kxx + kyy)
    acc_diff = np.zeros(0)
    if model == "fons":
        acc = fons_accommodation(eye, kbar)
    else:
        acc = eye.accommodation_for(kbar)                            # Kakimoto Eq. 13
        if rule == "rms":
            found = np.isfinite(dist)
            pts = q + np.where(found, dist, 1.0)[:, None] * dq
            a_rms = rms_accommodation(eye, lens, pts, through, d, pupil)
            use = found & np.isfinite(a_rms)
            acc_diff = (a_rms - acc)[use]
            acc = np.where(use, a_rms, acc)
    return acc, acc_diff


#: Pupil points (Vogel's spiral, stratified in area) of the real-ray RMS accommodation.
RMS_PUPIL_POINTS = 12


def rms_accommodation(eye, lens, points, through, pixel_dirs, pupil=(0.0, 0.0, 0.0)):
    """(m,) accommodation (D) that minimises the RMS of the retinal spot of scene points
    ``points`` (m, 3), found without the blur field's machinery: for pupil points rho_k
    the real light path from the point through the lens (exact path finding, per row where
    ``through``; straight otherwise) gives the arriving slope u_k relative to the pixel's
    axis; the thin eye of power P0 + A I maps it to the retinal point r_k(A) = rho_k +
    z_r (u_k - P0 rho_k - A rho_k) / n2 (paraxial refraction at the eye, n' u' = n u -
    P y), and the A minimising sum |r_k - mean r|^2 is solved in closed form (the spot is
    linear in A), then clamped to [0, amplitude]. NaN where a path fails."""
    from eyelab.optics.rays.paths import ObjectPoints, find_chief_rays

    m = len(points)
    n_in = -pixel_dirs                                     # the pixel's axis, toward the eye
    x_e = unit(cross(np.broadcast_to(UP, n_in.shape), n_in))
    y_e = cross(n_in, x_e)
    rp = eye.pupil_diameter / 2
    rho = rp * disc_seeds(RMS_PUPIL_POINTS)                # (k, 2)
    pxx, pxy, pyy = eye.power_matrix(np.zeros(m))
    n2, zr = eye.n_vitreous, eye.retina_distance
    c = np.zeros((m, len(rho), 2))
    ok = np.ones(m, bool)
    objects = ObjectPoints.from_positions(points)
    for k, (rx, ry) in enumerate(rho):
        target = np.asarray(pupil, float) + rx * x_e + ry * y_e
        if lens is not None and through.any():
            idx = np.flatnonzero(through)
            sub = ObjectPoints(objects.direction[idx], objects.distance[idx])
            ch = find_chief_rays(lens, target[idx], sub)
            arrive = -pixel_dirs.copy()
            arrive[idx] = ch.dir_out
            ok[idx] &= (ch.status & np.uint8(FATAL)) == 0
        else:
            arrive = np.zeros((m, 3))
        straight = ~through if lens is not None else np.ones(m, bool)
        arrive[straight] = unit(target[straight] - points[straight])
        along = np.einsum("ij,ij->i", arrive, n_in)
        ux = np.einsum("ij,ij->i", arrive, x_e) / along
        uy = np.einsum("ij,ij->i", arrive, y_e) / along
        c[:, k, 0] = rx + zr * (ux - (pxx * rx + pxy * ry)) / n2
        c[:, k, 1] = ry + zr * (uy - (pxy * rx + pyy * ry)) / n2
    b = c - c.mean(axis=1, keepdims=True)
    qv = rho - rho.mean(axis=0)
    s = zr / n2
    a = np.einsum("mkj,kj->m", b, qv) / (s * np.sum(qv**2))
    a = np.clip(a, 0.0, eye.accommodation_max)
    return np.where(ok, a, np.nan)


def fons_accommodation(eye, mean_vergence):
    """Fons et al. 2023, §4: the focus plane P lies where the principal meridian with the
    *lowest* refractive error focuses (Delta P = P_min - P'_min + P_axis_min), within the
    far and near points: the accommodation (D) that focuses that meridian on the object's
    wave (mean vergence, 1/m), clamped to [0, amplitude]. Kakimoto's Eq. 13 instead focuses
    the mean meridian (the circle of least confusion)."""
    r1, r2 = eye.refraction()                      # far-point vergence of each meridian
    p_low = eye.principal_powers()[0 if abs(r1) <= abs(r2) else 1]
    want = eye.emmetropic_power - np.asarray(mean_vergence, float) - p_low
    return np.clip(want, 0.0, eye.accommodation_max)
