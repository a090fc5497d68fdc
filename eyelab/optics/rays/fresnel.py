"""Fresnel transmission at lens surfaces: unpolarised light, per ray and wavelength, with
its s and p parts tracked through every surface.

Uncoated surface (Hecht, *Optics*, 5th ed., §4.6.2, Eqs. 4.42-4.43; docs/SCIENCE.md §9b):

    r_s = (n1 cos i - n2 cos t) / (n1 cos i + n2 cos t),
    r_p = (n2 cos i - n1 cos t) / (n2 cos i + n1 cos t),
    T_s = 1 - r_s^2,  T_p = 1 - r_p^2   (no absorption)

At normal incidence R = ((n2 - n1)/(n2 + n1))^2: n = 1.5 gives 0.04 per surface and
(1 - 0.04)^2 = 0.9216 through a lens (multiple reflections inside the lens, ~0.16 %
of the light, are not followed: they form faint ghost images, not part of the direct
image).

Through several surfaces the light is no longer unpolarised after the first: the p part
passes an oblique surface better than the s part, so multiplying each surface's
unpolarised factor (T_s + T_p)/2 is wrong (through an n = 1.5 plate at 60 deg it
overstates the loss by 0.0076). :class:`PolarisedTransmission` carries the Stokes vector
(S0, S1, S2) of light that starts unpolarised: each surface acts as a diattenuator in its
own s/p frame (Mueller matrix with (T_s + T_p)/2 on the diagonal, (T_s - T_p)/2 coupling
S0 and S1, sqrt(T_s T_p) on S2; Chipman, Lam & Young, *Polarized Light and Optical
Systems*, 2018, §5.9 and §12), and the frame is rotated between surfaces whose planes of
incidence differ (skew rays, toric or tilted surfaces). The transmitted fraction is S0.
Refraction has no phase change below total internal reflection, so no retardance enters
and S3 stays 0.

Anti-reflection coating ("ar"): a residual reflectance of :data:`AR_REFLECTANCE` per
surface at normal incidence, each of the s and p reflectances growing with the angle as
the uncoated surface's does (R_ar x R_s,p(i) / R(0)). 0.5 % is the low end of the 0.5-1 %
that multilayer AR coatings on spectacle lenses leave per surface (manufacturers' data,
docs/SCIENCE.md §9b); a coating's own spectral and polarisation curves are not modelled.
"""

from __future__ import annotations

import numpy as np

#: Residual reflectance per AR-coated surface at normal incidence (see the module text).
AR_REFLECTANCE = 0.005
#: Lens coatings eyelab models.
COATINGS = ("none", "ar")


def reflectances(cos_i, cos_t, n1, n2, coating: str = "none"):
    """(R_s, R_p), each (n,): the s and p intensity reflectances for incidence/refraction
    cosines (n,) from index n1 into n2 (floats or (n,)), coated as ``coating``."""
    cos_i = np.asarray(cos_i, float)
    cos_t = np.asarray(cos_t, float)
    rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t)
    rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t)
    r_s, r_p = rs * rs, rp * rp
    if coating == "ar":
        r0 = ((np.asarray(n2, float) - n1) / (np.asarray(n2, float) + n1)) ** 2
        scale = np.divide(AR_REFLECTANCE, r0, out=np.zeros_like(r0 * 1.0), where=r0 > 0)
        r_s, r_p = r_s * scale, r_p * scale
    elif coating != "none":
        raise ValueError(f"coating must be one of {COATINGS}, got {coating!r}")
    return r_s, r_p


def reflectance(cos_i, cos_t, n1, n2):
    """Unpolarised Fresnel reflectance (n,) of one uncoated surface, (R_s + R_p) / 2."""
    r_s, r_p = reflectances(cos_i, cos_t, n1, n2)
    return 0.5 * (r_s + r_p)


def transmittance(cos_i, cos_t, n1, n2, coating: str = "none"):
    """(n,) fraction of unpolarised light transmitted by ONE surface (see the module text);
    0 where ``cos_t`` is 0 (total internal reflection is flagged by the tracer). Through
    several surfaces use :class:`PolarisedTransmission`."""
    r_s, r_p = reflectances(cos_i, cos_t, n1, n2, coating)
    return np.clip(1.0 - 0.5 * (r_s + r_p), 0.0, 1.0)


class PolarisedTransmission:
    """The fraction of initially unpolarised light that rays pass through a sequence of
    surfaces, s and p tracked (module text).

    ``n`` rays. Call :meth:`surface` at each surface in the order the light meets it;
    :attr:`transmittance` (n,) is the fraction passed so far (NaN-free; rays whose
    geometry is undefined, e.g. missed surfaces, must be masked by the caller's status).
    """

    def __init__(self, n: int):
        self.stokes = np.zeros((n, 3))
        self.stokes[:, 0] = 1.0
        #: (n, 3) unit s direction of the last surface (across the ray), None before any
        self.frame = None

    def surface(self, directions, normals, cos_i, cos_t, n1, n2, coating: str = "none"):
        """Pass the light through one surface: ``directions`` (n, 3) unit incident rays,
        ``normals`` (n, 3) unit surface normals (either orientation), cosines (n,) and the
        indices before/after (floats or (n,)) as :func:`eyelab.optics.rays.trace.refract`
        returns them."""
        d = np.asarray(directions, float)
        s_dir = np.cross(d, np.asarray(normals, float))
        norm = np.linalg.norm(s_dir, axis=1)
        # at normal incidence s and p are the same: any direction across the ray will do,
        # the last frame (or, at the first surface, one made from the ray) keeps the chain
        if self.frame is None:
            helper = np.where(np.abs(d[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
            fallback = np.cross(d, helper)
            fallback /= np.linalg.norm(fallback, axis=1, keepdims=True)
        else:
            fallback = self.frame
        with np.errstate(invalid="ignore", divide="ignore"):
            s_dir = np.where((norm > 1e-12)[:, None], s_dir / norm[:, None], fallback)
        s_dir = np.nan_to_num(s_dir)
        st = self.stokes
        if self.frame is not None:          # rotate the Stokes frame onto this surface's s
            c = np.einsum("ij,ij->i", self.frame, s_dir)
            sn = np.einsum("ij,ij->i", np.cross(self.frame, s_dir), d)
            c2, s2 = c * c - sn * sn, 2.0 * c * sn
            st[:, 1], st[:, 2] = c2 * st[:, 1] + s2 * st[:, 2], -s2 * st[:, 1] + c2 * st[:, 2]
        with np.errstate(invalid="ignore", divide="ignore"):
            r_s, r_p = reflectances(cos_i, cos_t, n1, n2, coating)
        t_s = np.clip(np.nan_to_num(1.0 - r_s), 0.0, 1.0)
        t_p = np.clip(np.nan_to_num(1.0 - r_p), 0.0, 1.0)
        a, b = 0.5 * (t_s + t_p), 0.5 * (t_s - t_p)
        st[:, 0], st[:, 1] = a * st[:, 0] + b * st[:, 1], b * st[:, 0] + a * st[:, 1]
        st[:, 2] *= np.sqrt(t_s * t_p)
        self.frame = s_dir

    @property
    def transmittance(self) -> np.ndarray:
        """(n,) the fraction of the light passed, in [0, 1]."""
        return np.clip(self.stokes[:, 0], 0.0, 1.0)
