"""Blur fields of a schematic eye fixating along the view's line of sight: Kakimoto's voxel
grid, the wave through the lens to each voxel's column as for the thin eye, the thin eye's
Eq. 7-8 replaced by the schematic eye's own optics (:mod:`eyelab.optics.chain.retina`).

Per column (a line of sight entering the eye along the direction d, its chief ray aimed at
the stop's centre): the wave the eye needs there to focus it on the retina, K_need (the far
point's wave, traced back out from the retina through every surface). Per voxel: the wave
that arrives from the voxel's source, K (through the lens). A ray of the bundle through
the entrance pupil at h (m, from the chief ray) then reaches the eye turned by E h from
the rays the eye focuses on the chief ray's retinal point, E = K_need - K (the refraction
error, D = rad/m): it lands where a line of sight turned by theta = -E h would. The pupil
seen along the chief ray is the entrance pupil foreshortened by cos(angle to the eye's
axis) across the meridian (its first-order obliquity), so a unit-disc seed s maps to
theta = -r_EP E F s, F = I - (1 - cos) t t^T with t the tangential direction. The thin eye
is the case K_need = n2/z_r - P, which gives its Eq. 8-9 exactly (r_p (I - z_r K') times
-n2/z_r).
"""

from __future__ import annotations

import math
import time

import numpy as np

from eyelab.core.constants import RAD_TO_ARCMIN
from eyelab.core.vecmath import UP, cross, dot, unit
from eyelab.optics.chain.retina import fixation_accommodation
from eyelab.optics.chain.retinal_rays import needed_wave
from eyelab.optics.rays.camera import gaze_camera


def eye_frame(eye, pupil) -> tuple:
    """(rotation eye -> world, corneal vertex) of a schematic eye whose entrance pupil's
    centre is at ``pupil`` (the centre of projection of its camera): turned about its
    centre of rotation as :func:`~eyelab.optics.rays.camera.gaze_camera` turns the eye
    camera (Fick angles, no torsion); the origin means the eye looking straight ahead."""
    z_ep, _ = eye.entrance_pupil(0.0)
    pupil = np.asarray(pupil, float)
    centre = np.array([0.0, 0.0, eye.rotation_centre])
    if np.allclose(pupil, 0.0):
        pupil = np.array([0.0, 0.0, z_ep])
    f = unit((pupil - centre)[None])[0]
    a = math.degrees(math.atan2(f[0], -f[2]))
    e = math.degrees(math.asin(max(-1.0, min(1.0, f[1]))))
    r, u, fwd = gaze_camera((a, e), eye.rotation_centre).basis
    rot = np.stack([r, u, -fwd], axis=1)
    return rot, centre + eye.rotation_centre * fwd


def schematic_columns(eye, lens, d_in, pupil, focus, wavelength_nm: float,
                      reference_depth: float) -> dict:
    """Per column with eye-side chief-ray directions ``d_in`` (n, 3, into the eye): the
    needed wave in the basis (x = up x d, d x x), the tangential direction in that basis,
    the cosine of the angle to the eye's axis; and the eye's accommodation (``focus``, D,
    clipped to its range, else the fixation's at ``reference_depth``)."""
    rot, vertex = eye_frame(eye, pupil)
    if focus is None:
        acc = float(fixation_accommodation(eye, lens, reference_depth, wavelength_nm,
                                           rot=rot, vertex=vertex)[0])
    else:
        acc = float(min(max(float(focus), 0.0), eye.accommodation_max))
    x = unit(cross(np.broadcast_to(UP, d_in.shape), d_in))
    need, status = needed_wave(eye, rot, vertex, d_in, x, acc, wavelength_nm)
    axis = np.broadcast_to(rot[:, 2], d_in.shape)
    cos = np.clip(dot(axis, d_in), -1.0, 1.0)
    t = axis - cos[:, None] * d_in
    tn = np.linalg.norm(t, axis=1)
    t = np.where(tn[:, None] > 1e-12, t / np.where(tn > 1e-12, tn, 1.0)[:, None], x)
    t2 = np.stack([dot(t, x), dot(t, cross(d_in, x))], -1)
    return {"need": np.stack(need, -1), "t": t2, "cos": cos, "accommodation": acc,
            "r_ep": eye.pupil_diameter / 2, "status": status,
            "retina_scale": eye.indices(wavelength_nm, acc)[-1] / eye.power(acc,
                                                                              wavelength_nm)}


def schematic_blur(sc: dict, cols, kxx, kxy, kyy) -> dict:
    """The angular blur matrices (c, m, 2, 2; rad per unit seed, in the columns' (x, y)
    bases) of voxels whose arriving waves are (kxx, kxy, kyy) (c, m), and their ellipses:
    semi-axes a, b as retinal lengths (m; the paraxial eye's scale), omega (rad), the major
    semi-axis in arcmin."""
    need = sc["need"][cols][:, None]                                   # (c, 1, 3)
    e11, e12, e22 = need[..., 0] - kxx, need[..., 1] - kxy, need[..., 2] - kyy
    t = sc["t"][cols][:, None]
    k = (1.0 - sc["cos"][cols])[:, None]
    f11, f12, f22 = 1.0 - k * t[..., 0] ** 2, -k * t[..., 0] * t[..., 1], \
        1.0 - k * t[..., 1] ** 2
    r = -sc["r_ep"]
    g = np.empty((*e11.shape, 2, 2))
    g[..., 0, 0] = r * (e11 * f11 + e12 * f12)
    g[..., 0, 1] = r * (e11 * f12 + e12 * f22)
    g[..., 1, 0] = r * (e12 * f11 + e22 * f12)
    g[..., 1, 1] = r * (e12 * f12 + e22 * f22)
    u, sv, _ = np.linalg.svd(g)
    major = sv[..., 0]
    omega = np.mod(np.arctan2(u[..., 1, 0], u[..., 0, 0]), math.pi)
    return {"g": g, "a": sv[..., 1] * sc["retina_scale"], "b": major * sc["retina_scale"],
            "omega": omega, "major": major * RAD_TO_ARCMIN}


def schematic_aberrations(eye, lens, camera, pupil, d_in, accommodation: float,
                          wavelength_nm: float, reference_nm: float, depths, ks, iy, ix,
                          sources, status, matrix, workers=None) -> dict:
    """The ray-aberration map of every computed voxel (:mod:`eyelab.blur.aberration`):
    per column (eye-side chief directions ``d_in`` (c, 3); voxel indices ``iy``, ``ix``
    (c,), computed slices ``ks`` at depths ``depths`` (nz,)), rays from its retinal point
    through the stop, fitted at each slice. ``matrix`` (nz, ny, nx, 2, 2) takes the fitted
    linear part where the status is OK and the fit had its rays; returns the non-linear
    part (nz, ny, nx, 2, len(HIGHER)) and the fit's report (residual shares, columns
    kept on the second-order matrix)."""
    from eyelab.blur.aberration import (
        HIGHER,
        LINEAR,
        fit_columns,
        schematic_ray_samples,
    )
    from eyelab.core.parallel import map_row_chunks

    rot, vertex = eye_frame(eye, pupil)
    nz, ny, nx = status.shape
    higher = np.zeros((nz, ny, nx, 2, len(HIGHER)))
    if len(d_in) == 0 or len(ks) == 0:
        return {"higher": higher, "report": {"residual_share_median": 0.0,
                                             "residual_share_max": 0.0,
                                             "columns_second_order": 0}}
    w = depths[ks]

    def run(a, b):
        o, d, ok = schematic_ray_samples(eye, lens, rot, vertex, d_in[a:b], accommodation,
                                         wavelength_nm, reference_nm)
        jj, ii = iy[a:b], ix[a:b]
        src = sources[ks[None, :], jj[:, None], ii[:, None]]            # (c, m, 3)
        ref = camera.world_to_ndc(src.reshape(-1, 3))[:, :2].reshape(src.shape[:2] + (2,))
        coef, good, share = fit_columns(camera, o, d, ok, w, ref)
        vox_ok = (status[ks[None, :], jj[:, None], ii[:, None]] == 0) & good[:, None]
        kk = np.broadcast_to(ks[None, :], vox_ok.shape)[vox_ok]
        yy = np.broadcast_to(jj[:, None], vox_ok.shape)[vox_ok]
        xx = np.broadcast_to(ii[:, None], vox_ok.shape)[vox_ok]
        matrix[kk, yy, xx] = coef[vox_ok][..., list(LINEAR)]
        higher[kk, yy, xx] = coef[vox_ok][..., list(HIGHER)]
        return share[good].ravel(), int((~good).sum())

    parts = map_row_chunks(run, len(d_in), workers=workers, block=64)
    s = np.concatenate([p[0] for p in parts]) if parts else np.zeros(0)
    return {"higher": higher,
            "report": {"residual_share_median": float(np.median(s)) if s.size else 0.0,
                       "residual_share_max": float(s.max()) if s.size else 0.0,
                       "columns_second_order": sum(p[1] for p in parts)}}


def schematic_map(eye, lens, camera, pupil, d_in, accommodation, wavelength_nm, depths,
                   ks, iy, ix, sources, status, matrix, workers, timings) -> tuple:
    """(non-linear coefficients, fit report) of a schematic eye's ray-aberration map
    (:func:`schematic_aberrations`; ``matrix`` takes the fitted linear part), continued
    past a lens's rim as the matrix is; its time in ``timings["aberration_s"]``."""
    from eyelab.blur.field import extend_into_invisible
    from eyelab.optics.eye.thin import EYE_REFERENCE_NM

    t = time.perf_counter()
    got = schematic_aberrations(eye, lens, camera, pupil, d_in, accommodation,
                                wavelength_nm, EYE_REFERENCE_NM, depths, ks, iy, ix,
                                sources, status, matrix, workers)
    if lens is not None:       # continued past the lens's rim as the matrix is
        extend_into_invisible(got["higher"], status)
    timings["aberration_s"] = time.perf_counter() - t
    return got["higher"], got["report"]
