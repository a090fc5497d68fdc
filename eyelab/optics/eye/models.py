"""Published schematic eyes as data: surfaces, media and their dispersion, accommodation.

The wide-angle eye of Escudero-Sanz & Navarro 1999 ("Off-axis aberrations of a wide-angle
schematic eye model", JOSA A 16:1881, Table 1), which is the accommodation-dependent eye of
Navarro, Santamaría & Bescós 1985 (JOSA A 2:1273, Table 1 and Eqs. 6-11) with a vitreous of
16.3203 mm and a retina of radius -12 mm (docs/SCIENCE.md §5):

=================  ==============================  =============  ============
surface            radius R (mm)                   conic Q        then (mm)
=================  ==============================  =============  ============
cornea, front      7.72                            -0.26          0.55 cornea
cornea, back       6.50                            0              3.05 - 0.05u aqueous
stop, lens front   10.2 - 1.75u                    -3.1316 - 0.34u 4.0 + 0.1u lens
lens, back         -6.0 + 0.2294u                  -1 - 0.125u    vitreous
retina             -12.0                           0
=================  ==============================  =============  ============

u = ln(A + 1), A the accommodation (D) of Navarro 1985 (fitted for 0 <= A <= 10 D). The
axial length (cornea to retina, 23.9203 mm relaxed) does not change with accommodation, so
the vitreous is 16.3203 - 0.05u mm. The stop is at the lens's front vertex.

Dispersion, Navarro 1985 Eq. 1-2 (Herzberger's formula): for each medium
n(lambda) = a1 n** + a2 n_F + a3 n_C + a4 n*, with n**, n_F, n_C, n* its indices at 365,
486.1, 656.3 and 1014 nm and a_i = A_i0 + A_i1 lambda^2 + P_i / (lambda^2 - l0^2) + R_i /
(lambda^2 - l0^2)^2 (lambda in um, l0^2 = 0.028 um^2). The lens's four indices rise by
9e-5 (10A + A^2) with accommodation (Navarro 1985 Eq. 11). The formula reproduces the
indices Escudero-Sanz & Navarro list at 458, 543, 589.3 and 632.8 nm to 1e-4 (tested).
"""

from __future__ import annotations

import math

import numpy as np

from eyelab.core.errors import SpecError

#: The schematic eyes eyelab builds, by ``[eye] model`` name (the thin toric eye of
#: Kakimoto 2007 is "thin").
SCHEMATIC_MODELS = ("navarro",)
#: ``eye.model``'s choices: "thin" (Kakimoto 2007's thin toric eye) and the schematic eyes.
EYE_MODELS = ("thin", *SCHEMATIC_MODELS)
#: What each model is, for the spec reference and reports.
MODEL_MEANINGS = {
    "thin": "Kakimoto 2007's thin toric eye (Gullstrand-Helmholtz powers): every line of "
            "sight imaged as the fovea images it",
    "navarro": "the wide-angle schematic eye of Escudero-Sanz & Navarro 1999 (Navarro "
               "1985's accommodation and dispersion): conicoid cornea and lens, the stop "
               "at the lens, a retina of radius 12 mm",
}
#: The media, front to back.
MEDIA = ("cornea", "aqueous", "lens", "vitreous")

#: Navarro 1985 Table 2: indices at 365, 486.1, 656.3, 1014 nm (n**, n_F, n_C, n*).
NAVARRO_REFERENCE_INDICES = {
    "cornea": (1.3975, 1.3807, 1.37405, 1.3668),
    "aqueous": (1.3593, 1.3422, 1.3354, 1.3278),
    "lens": (1.4492, 1.4263, 1.4175, 1.4097),
    "vitreous": (1.3565, 1.3407, 1.3341, 1.3273),
}
#: Herzberger's coefficients (A_i0, A_i1, P_i, R_i), i = 1..4 (Navarro 1985 Eq. 2; the
#: paper's misprinted A_11 and A_40 as Atchison & Smith 2005 correct them: the a_i sum to
#: 1 at every wavelength, tested).
HERZBERGER = np.array([
    [0.66147196, -0.40352796, -0.28046790, 0.03385979],
    [-4.20146383, 2.73508956, 1.50543784, -0.11593235],
    [6.29834237, -4.69409935, -1.57508650, 0.10293038],
    [-1.75835059, 2.36253794, 0.35011657, -0.02085782],
])
HERZBERGER_L0_SQ_UM2 = 0.028
#: Wavelengths (nm) the dispersion formula is meant for (Navarro 1985 fitted 365-1014 nm).
DISPERSION_RANGE_NM = (365.0, 1014.0)
#: The accommodation range (D) the model's formulas were fitted for.
NAVARRO_MAX_ACCOMMODATION_D = 10.0

#: Relaxed geometry, mm (Escudero-Sanz & Navarro 1999 Table 1).
NAVARRO_CORNEA_FRONT = (7.72, -0.26)
NAVARRO_CORNEA_BACK = (6.50, 0.0)
NAVARRO_CORNEA_THICKNESS = 0.55
NAVARRO_AQUEOUS = 3.05
NAVARRO_LENS_THICKNESS = 4.0
NAVARRO_VITREOUS = 16.3203
NAVARRO_RETINA = (-12.0, 0.0)


def herzberger_weights(wavelength_nm):
    """The four a_i(lambda) of Navarro 1985 Eq. 2, shape (4,) + shape of the wavelength."""
    wl = np.asarray(wavelength_nm, float)
    lo, hi = DISPERSION_RANGE_NM
    if np.any(~np.isfinite(wl)) or np.any((wl < lo) | (wl > hi)):
        raise SpecError("wavelength_nm", f"must be in [{lo:g}, {hi:g}] nm for the schematic "
                                         f"eye's media, got {wavelength_nm!r}")
    l2 = (wl * 1e-3) ** 2
    d = l2 - HERZBERGER_L0_SQ_UM2
    c = HERZBERGER
    return (c[:, 0, None] + c[:, 1, None] * l2.ravel() + c[:, 2, None] / d.ravel()
            + c[:, 3, None] / d.ravel() ** 2).reshape((4, *wl.shape))


def navarro_index(medium: str, wavelength_nm, accommodation: float = 0.0):
    """Refractive index of a Navarro medium at ``wavelength_nm`` (nm) and accommodation
    ``accommodation`` (D; only the lens depends on it), shaped like the wavelength.

    >>> round(float(navarro_index("lens", 589.3)), 3)
    1.42
    """
    ref = np.array(NAVARRO_REFERENCE_INDICES[medium], float)
    if medium == "lens":
        ref = ref + 9e-5 * (10.0 * accommodation + accommodation ** 2)
    w = herzberger_weights(wavelength_nm)
    return np.tensordot(ref, w, axes=(0, 0))


def navarro_geometry(accommodation: float) -> dict:
    """The Navarro eye's surfaces at accommodation ``accommodation`` (D, in [0, 10]):
    radii (mm) and conics of cornea front/back, lens front/back, retina, and the
    thicknesses (mm) of cornea, aqueous and lens; the vitreous follows from the fixed
    axial length (module table)."""
    a = float(accommodation)
    if not (0.0 <= a <= NAVARRO_MAX_ACCOMMODATION_D + 1e-12):
        raise SpecError("eye.accommodation_d", f"must be in [0, "
                        f"{NAVARRO_MAX_ACCOMMODATION_D:g}] D for the Navarro eye (the range "
                        f"its formulas were fitted for), got {accommodation!r}")
    u = math.log(a + 1.0)
    aqueous = NAVARRO_AQUEOUS - 0.05 * u
    lens = NAVARRO_LENS_THICKNESS + 0.1 * u
    return {
        "cornea_front": NAVARRO_CORNEA_FRONT,
        "cornea_back": NAVARRO_CORNEA_BACK,
        "lens_front": (10.2 - 1.75 * u, -3.1316 - 0.34 * u),
        "lens_back": (-6.0 + 0.2294 * u, -1.0 - 0.125 * u),
        "retina": NAVARRO_RETINA,
        "cornea_thickness": NAVARRO_CORNEA_THICKNESS,
        "aqueous": aqueous,
        "lens_thickness": lens,
    }


def navarro_axial_length() -> float:
    """Cornea to retina (mm) of the published relaxed eye: 23.9203."""
    return NAVARRO_CORNEA_THICKNESS + NAVARRO_AQUEOUS + NAVARRO_LENS_THICKNESS \
        + NAVARRO_VITREOUS
