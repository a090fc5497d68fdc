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
