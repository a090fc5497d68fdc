"""The eye: prescriptions (the refractive error's clinical notation), the thin toric eye of
Kakimoto et al. 2007 (:mod:`~eyelab.optics.eye.thin`), its higher-order aberrations
(Zernike polynomials, the wave PSF), and the schematic eyes made of real surfaces and
dispersive media (:mod:`~eyelab.optics.eye.schematic`). Imports only
:mod:`eyelab.optics.rays`."""
