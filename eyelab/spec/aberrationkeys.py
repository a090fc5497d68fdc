"""``[eye.aberrations]``: an aberrometer's Zernike coefficients for the eye
(:mod:`eyelab.optics.eye.aberrations`): its schema keys and ranges (the parser:
:mod:`eyelab.spec.aberrationparse`).

The second order and the eye's Rx are one thing: coefficients with second-order terms and
no ``eye.rx`` give the eye's refraction (Thibos et al. 2004, at the eye; to the
spectacle plane at ``eye.vertex_distance_mm``; from the measuring wavelength to the eye's
reference by the eye's chromatic model); with ``eye.rx`` the second order must be zero —
both is refused by name, never one silently preferred.
"""

from __future__ import annotations

from eyelab.optics.eye import zernike as zk
from eyelab.optics.eye.aberrations import REPORT_WAVELENGTH_NM

WHERE = "eye.aberrations"
#: The keys' ranges (one place: the schema and the parser take them from here).
#: A coefficient's range (um) is what an aberrometer reports over the pupils it measures:
#: a clinical instrument's range of refraction, +-20 D, is a defocus coefficient
#: c(2, 0) = M r^2 / (4 sqrt 3) of 72 um over a 10 mm pupil (Thibos et al. 2004's
#: M = -4 sqrt(3) c(2, 0) / r^2), and higher orders are far smaller (keratoconic coma is a
#: few um over 6 mm); a coefficient beyond 100 um is a unit or typing error, never an eye.
ABERRATION_LIMITS = {"eye.aberrations.pupil_mm": (1.0, 10.0),
                     "eye.aberrations.wavelength_nm": (400.0, 1100.0),
                     "eye.aberrations.coefficients_um": (-100.0, 100.0)}
ALLOWED = {"coefficients_um", "file", "pupil_mm", "wavelength_nm", "stiles_crawford"}
#: A spec with aberrations (the schema's examples, the tests and the corpus read it).
BASE = {"eye": {"aberrations": {"coefficients_um": [0, 0, 0, 0, 0, 0, 0, 0.05, 0, 0, 0, 0,
                                                    0.1], "pupil_mm": 6.0}}}
ABERRATION_TABLE = ("`[eye.aberrations]` (the eye's higher-order aberrations, an aberrometer's "
         "OSA/ANSI Zernike coefficients; docs/guide/patient-eye.md)")
ABERRATION_KEYS = (
    (("eye", "aberrations", "text", "", "none", "the eye's higher-order aberrations and the "
      "pupil's diffraction in renders, `eyelab psf` and `analyze`: table `[eye.aberrations]`"),
     {"range_text": "a table"}),
    ((WHERE, "coefficients_um", "text", "um", "none", "Zernike coefficients in OSA/ANSI "
      "order from j = 0 (the standard's axes: x to the examiner's right), or a table "
      "`{ Z4_0 = 0.1, Z3_-1 = 0.05 }` by (n, m); orders 0 and 1 are ignored, the second "
      "order is the refraction (without `eye.rx`)"),
     {"range_text": f"up to order {zk.MAX_ORDER}, each in "
                    f"{list(ABERRATION_LIMITS['eye.aberrations.coefficients_um'])}",
      "base": BASE}),
    ((WHERE, "file", "text", "", "none", "instead of `coefficients_um`: a text file of the "
      "coefficients in OSA order (commas, blanks or new lines; `#` comments), relative to "
      "the spec"), {"range_text": "an existing file", "base": BASE}),
    ((WHERE, "pupil_mm", "number", "mm", "required", "the pupil the coefficients were "
      "measured over (the render's `eye.pupil_diameter_mm` must not exceed it: they are "
      "re-expanded over the smaller pupil, Schwiegerling 2002)"),
     {"base": BASE, "edges": False}),
    ((WHERE, "wavelength_nm", "number", "nm", f"{REPORT_WAVELENGTH_NM:g}", "the measuring "
      "wavelength"), {"base": BASE}),
    ((WHERE, "stiles_crawford", "boolean", "", "false", "apodise the pupil by the "
      "Stiles-Crawford effect (rho 0.05 / mm², Applegate & Lakshminarayanan 1993)"),
     {"base": BASE}),
)
