"""``eyelab psf``: the eye's point-spread function at a point of the spec, per colour
channel, in wave optics (:mod:`eyelab.optics.eye.psf`): the point's defocus and astigmatism
through the lens (real chief ray and generalised-Coddington wavefront, as ``analyze``
traces it, at each channel's wavelength), the lens's real wave beyond them and its
lenslets' zones (:mod:`eyelab.optics.lens.pupilwave`), the eye's higher-order aberrations
and the pupil's diffraction."""

from __future__ import annotations

import numpy as np

from eyelab.core.errors import SpecError

#: Default sampling: arcmin per pixel and pixels a side.
PITCH_ARCMIN = 0.25
SIZE = 129
#: Modulation reported at these spatial frequencies (cycles / degree).
MTF_FREQUENCIES_CPD = (5, 10, 15, 20, 30, 45, 60)


def point_psf(spec, *, point: int = 0, no_lens: bool = False, pitch_arcmin: float = PITCH_ARCMIN,
              size: int = SIZE) -> tuple:
    """(psf (3, size, size) float64, image-oriented rows, each summing to the energy inside
    the square; report dict, its units first: :func:`eyelab.core.fileio.with_units`) for
    ``spec``'s point ``point``."""
    from eyelab.core.fileio import with_units
    from eyelab.imaging.eyepsf import channel_wavelengths
    from eyelab.optics.chain.analysis import analyze_points
    from eyelab.optics.eye import zernike as zk
    from eyelab.optics.eye.aberrations import point_wave
    from eyelab.optics.eye.psf import ARCMIN, mtf, psf
    from eyelab.optics.rays.paths import ObjectPoints
    from eyelab.optics.rays.trace import FATAL
    from eyelab.spec.load import one_eye, thin_eye

    spec = thin_eye(one_eye(spec, "eyelab psf"), "eyelab psf")
    n = len(spec.points)
    if not 0 <= point < n:
        raise SpecError("--point", f"must be in [0, {n - 1}] (the spec's [[points]]), got {point}")
    if not 0.01 <= pitch_arcmin <= 10:
        raise SpecError("--pitch-arcmin", f"must be in [0.01, 10], got {pitch_arcmin:g}")
    if not (3 <= size <= 1025 and size % 2 == 1):
        raise SpecError("--size", f"must be odd, in [3, 1025], got {size}")
    eye, lens = spec.eye, None if no_lens else spec.lens
    lenslets = lens is not None and lens.has_lenslets
    focus = share = None
    if lens is not None:
        # the lens's real wave over the pupil beyond the chief ray's second order
        from eyelab.optics.lens.lenslets import carrier
        from eyelab.optics.lens.pupilwave import lenslet_share, pupil_wave
    pts = spec.points
    one = ObjectPoints(pts.direction[point:point + 1], pts.distance[point:point + 1])
    pupil = eye.pupil_diameter * 1e3
    sc = eye.aberrations is not None and eye.aberrations.stiles_crawford
    images, channels = [], []
    wavelengths = channel_wavelengths()
    for wl in wavelengths:
        res = analyze_points(eye, carrier(lens) if lenslets else lens, one, wavelength_nm=wl,
                             fixation=spec.fixation, accommodation=spec.accommodation,
                             vertex_sphere=spec.vertex_sphere)
        if res.status[0] & np.uint8(FATAL):
            raise SpecError("--point", f"point {point} has no light path at {wl:g} nm")
        c = point_wave(eye, res, 0, wl)
        extra = None if lens is None else pupil_wave(lens, res, 0, wl)
        out = psf(c, pupil, wl, pitch_arcmin * ARCMIN, size, stiles_crawford=sc,
                  field="--pitch-arcmin", integrate=True, extra=extra)
        images.append(out["psf"])
        if lenslets and wl == wavelengths[1]:            # the green channel's (the e line)
            focus = lenslet_focus(lens, c, pupil, wl, extra, sc)
            share = lenslet_share(extra[0], eye.pupil_diameter / 2)
        channels.append({
            "wavelength_nm": wl, "strehl": out["strehl"],
            "rms_um": zk.rms(c, from_order=2), "rms_higher_orders_um": zk.rms(c, from_order=3),
            "energy_inside": float(out["psf"].sum()),
            "outside_window": out["outside_window"],
            "mtf": {str(f): (float(v) if np.isfinite(v) else None) for f, v in zip(
                MTF_FREQUENCIES_CPD, mtf(out["psf"], out["pitch_rad"], MTF_FREQUENCIES_CPD,
                                         integrated=True),
                strict=True)},    # None: beyond the sampling's Nyquist frequency
            "coefficients_um": [float(v) for v in c],
            "fft": out["fft"], "pupil_samples": out["pupil_samples"]})
    rep = {"point": point, "through_lens": lens is not None, "pupil_mm": pupil,
           "pitch_arcmin": pitch_arcmin, "size_px": size,
           "axes": "rows top to bottom (y down), columns left to right, as the wearer sees",
           "coefficients": "OSA/ANSI order from j = 0, um, over the render pupil, eyelab's "
                           "wearer frame (x to the wearer's right): the point's defocus and "
                           "astigmatism plus the eye's higher orders",
           "lens_wave": None if lens is None else "the PSF adds the lens's real wave beyond "
           "the chief ray's second order: forward rays landed on the pupil, their optical "
           "paths less the coefficients' (eyelab.optics.lens.pupilwave.pupil_wave)",
           "lenslets": None if not lenslets else {
               "add_d": lens.front.add_d, "share": share,
               "share_meaning": "of the pupil's light, through lenslets (as analyze counts "
               "it: their rays' footprint on the lens), at the green channel's wavelength",
               "wave": "the coefficients are the carrier's; over "
               "the lenslets' zones of the pupil the field takes the difference of the "
               "forward rays' optical paths through them and through the carrier, and their "
               "light (eyelab.optics.lens.pupilwave.pupil_wave): the PSF holds both images",
               "through_focus": focus},
           "stiles_crawford": sc, "channels": channels,
           "mtf_frequencies_cpd": list(MTF_FREQUENCIES_CPD)}
    return np.stack(images), with_units(rep)


def lenslet_focus(lens, coefficients_um, pupil_mm, wavelength_nm, extra, sc) -> dict:
    """The image through focus behind a lenslet lens (:func:`eyelab.optics.eye.psf.
    through_focus`) from -1.5 D to the add + 1.5 D in 0.05 D steps (as ``analyze`` of a
    schematic eye), with the peaks of both curves (the carrier's image, the lenslets')."""
    from eyelab.jobs.retinal import FOCUS_MARGIN_D, FOCUS_STEP_D
    from eyelab.optics.chain.forward_wave import focus_peaks
    from eyelab.optics.eye.psf import through_focus

    add = lens.front.add_d
    lo, hi = min(0.0, add) - FOCUS_MARGIN_D, max(0.0, add) + FOCUS_MARGIN_D
    vs = np.round(np.arange(lo, hi + FOCUS_STEP_D / 2, FOCUS_STEP_D), 10)
    tf = through_focus(coefficients_um, pupil_mm, wavelength_nm, vs, extra=extra,
                       stiles_crawford=sc)
    return {"wavelength_nm": wavelength_nm, "vergence_d": tf["vergence_d"],
            "axial": tf["axial"], "peak": tf["peak"],
            "axial_peaks": focus_peaks(tf),
            "peak_peaks": focus_peaks({"vergence_d": tf["vergence_d"], "axial": tf["peak"]})}
