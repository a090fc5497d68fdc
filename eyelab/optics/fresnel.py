"""Fresnel transmission at lens surfaces: unpolarised light, per ray and wavelength.

Uncoated surface (Hecht, *Optics*, 5th ed., §4.6.2, Eqs. 4.42-4.43; SCIENCE.md §9b):

    r_s = (n1 cos i - n2 cos t) / (n1 cos i + n2 cos t),
    r_p = (n2 cos i - n1 cos t) / (n2 cos i + n1 cos t),
    R = (r_s^2 + r_p^2) / 2,   T = 1 - R   (no absorption)

At normal incidence R = ((n2 - n1)/(n2 + n1))^2: n = 1.5 gives 0.04 per surface and
(1 - 0.04)^2 = 0.9216 through a lens (multiple reflections inside the lens, ~0.16 %
of the light, are not followed: they form faint ghost images, not part of the direct
image).

Anti-reflection coating ("ar"): a residual reflectance of :data:`AR_REFLECTANCE` per
surface at normal incidence, growing with the angle as the uncoated surface's does (R_ar
x R(i) / R(0)). 0.5 % is the low end of the 0.5-1 % that multilayer AR coatings on
spectacle lenses leave per surface (manufacturers' data, SCIENCE.md §9b); a coating's
own spectral curve is not modelled.
"""

from __future__ import annotations

import numpy as np

#: Residual reflectance per AR-coated surface at normal incidence (see the module text).
AR_REFLECTANCE = 0.005
#: Lens coatings eyelab models.
COATINGS = ("none", "ar")


def reflectance(cos_i, cos_t, n1, n2):
    """Unpolarised Fresnel reflectance (n,) for incidence/refraction cosines (n,) from index
    n1 into n2 (floats or (n,))."""
    cos_i = np.asarray(cos_i, float)
    cos_t = np.asarray(cos_t, float)
    rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t)
    rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t)
    return 0.5 * (rs * rs + rp * rp)


def transmittance(cos_i, cos_t, n1, n2, coating: str = "none"):
    """(n,) fraction of unpolarised light transmitted by one surface (see the module text);
    0 where ``cos_t`` is 0 (total internal reflection is flagged by the tracer)."""
    r = reflectance(cos_i, cos_t, n1, n2)
    if coating == "ar":
        r0 = ((n2 - n1) / (n2 + n1)) ** 2
        r = AR_REFLECTANCE * r / r0 if np.all(r0 > 0) else np.zeros_like(r)
    elif coating != "none":
        raise ValueError(f"coating must be one of {COATINGS}, got {coating!r}")
    return np.clip(1.0 - r, 0.0, 1.0)
