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
#: The ranges of psf's arguments (pitch_arcmin: arcmin per pixel; size: pixels a side,
#: odd).
PSF_LIMITS = {"pitch_arcmin": (0.01, 10.0), "size": (3, 1025)}
#: ``eyelab psf``'s flag of each argument.
PSF_FLAGS = {"point": "--point", "pitch_arcmin": "--pitch-arcmin", "size": "--size"}
#: Modulation reported at these spatial frequencies (cycles / degree).
MTF_FREQUENCIES_CPD = (5, 10, 15, 20, 30, 45, 60)


def check_psf_arguments(point, pitch_arcmin, size) -> None:
    """The arguments' types (``TypeError`` naming the argument) and ranges
    (:data:`PSF_LIMITS`; SpecError naming it), before any work."""
    from eyelab.core.checks import check_argument

    if isinstance(point, (bool, np.bool_)) or not isinstance(point, (int, np.integer)):
        raise TypeError(f"point must be an integer (an index of the spec's [[points]]), got "
                        f"{type(point).__name__} {point!r}"[:200])
    check_argument("pitch_arcmin", pitch_arcmin, *PSF_LIMITS["pitch_arcmin"])
    check_argument("size", size, *PSF_LIMITS["size"], integer=True)
    if size % 2 != 1:
        lo, hi = PSF_LIMITS["size"]
        raise SpecError("size", f"must be odd, in [{lo}, {hi}], got {size}")


def point_psf(spec, *, point: int = 0, no_lens: bool = False, pitch_arcmin: float = PITCH_ARCMIN,
              size: int = SIZE, side: str | None = None, side_flag: str = "--eye") -> tuple:
    """(psf (3, size, size) float64, image-oriented rows, each summing to the energy inside
    the square; report dict, its units first: :func:`eyelab.core.fileio.with_units`) for
    ``spec``'s point ``point``; a two-eye spec's ``side`` ("right" or "left") eye, at the
    accommodation both eyes share there (``side_flag``: what the caller calls the side,
    the CLI's ``--eye`` or Python's ``eye``)."""
    from eyelab.core.fileio import with_units
    from eyelab.imaging.eyepsf import channel_wavelengths
    from eyelab.optics.eye.psf import ARCMIN, psf
    from eyelab.optics.eye.thin import Eye
    from eyelab.optics.rays.paths import ObjectPoints
    from eyelab.spec.load import no_camera, pick_eye

    check_psf_arguments(point, pitch_arcmin, size)
    what = "eyelab psf" if side_flag.startswith("-") else "eyelab.psf"
    spec = pick_eye(no_camera(spec, "psf"), side, what, point=point, no_lens=no_lens,
                    flag=side_flag)
    n = len(spec.points)
    if not 0 <= point < n:
        raise SpecError("point", f"must be in [0, {n - 1}] (the spec's [[points]]), got {point}")
    eye, lens = spec.eye, None if no_lens else spec.lens
    lenslets = lens is not None and lens.has_lenslets
    _check_grids(eye.pupil_diameter * 1e3, pitch_arcmin * ARCMIN, lens if lenslets else None)
    focus = share = None
    pts = spec.points
    one = ObjectPoints(pts.direction[point:point + 1], pts.distance[point:point + 1])
    pupil = eye.pupil_diameter * 1e3
    aberrations = getattr(eye, "aberrations", None)
    sc = aberrations is not None and aberrations.stiles_crawford
    waves = (thin_waves if isinstance(eye, Eye) else schematic_waves)(spec, lens, one, point)
    images, channels = [], []
    wavelengths = channel_wavelengths()
    for wl in wavelengths:
        green = wl == wavelengths[1]                     # the e line: the lenslets' figures
        c, extra, info = waves(wl, share=lenslets and green)
        out = psf(c, pupil, wl, pitch_arcmin * ARCMIN, size, stiles_crawford=sc,
                  field="pitch_arcmin", integrate=True, extra=extra,
                  mtf_cpd=MTF_FREQUENCIES_CPD)
        images.append(out["psf"])
        if lenslets and green:
            focus = lenslet_focus(lens, c, pupil, wl, extra, sc)
            share = info.pop("share")
        channels.append({
            "wavelength_nm": wl, "strehl": out["strehl"], **info,
            "energy_inside": float(out["psf"].sum()),
            "outside_window": out["outside_window"],
            # from the PSF's fine grid (no window, no pixel, no aliasing)
            "mtf": {str(f): (float(v) if np.isfinite(v) else None)
                    for f, v in zip(MTF_FREQUENCIES_CPD, out["mtf"], strict=True)},
            "fft": out["fft"], "pupil_samples": out["pupil_samples"]})
    rep = {"point": point, "eye_model": getattr(eye, "model", "thin"), "side": side,
           "through_lens": lens is not None, "pupil_mm": pupil,
           "pitch_arcmin": pitch_arcmin, "size_px": size,
           "axes": "rows top to bottom (y down), columns left to right, as the wearer sees",
           "wave": WAVE_MEANING[waves.__name__],
           "lens_wave": None if lens is None else "the PSF takes the lens's real wave over "
           "the pupil: forward rays landed on it (thin eye: beyond the coefficients' second "
           "order, eyelab.optics.lens.pupilwave) or the exact paths from the retina "
           "(schematic eye, eyelab.optics.chain.retinal_psf)",
           "lenslets": None if not lenslets else {
               "add_d": lens.front.add_d, "share": share,
               "share_meaning": "of the pupil's light, through lenslets (as analyze counts "
               "it: their rays' footprint on the lens), at the green channel's wavelength",
               "wave": "over the lenslets' zones of the pupil the field takes their rays' "
               "optical paths and their light: the PSF holds both images",
               "through_focus_scale": "intensity over the aberration-free peak of the same "
               "pupil (|sum of its amplitudes|^2: the lenslets' light and dark rims "
               "included), the line of sight the carrier's chief ray (as analyze's)",
               "through_focus": focus},
           "stiles_crawford": sc, "channels": channels,
           "mtf_frequencies_cpd": list(MTF_FREQUENCIES_CPD)}
    return np.stack(images), with_units(rep)


#: What a channel's wave is, by eye model (the report's "wave").
WAVE_MEANING = {
    "thin": "coefficients_um: OSA/ANSI order from j = 0, um, over the render pupil, "
            "eyelab's wearer frame (x to the wearer's right): the point's defocus and "
            "astigmatism through the lens plus the eye's higher orders; the lens's real wave "
            "beyond them is added over the pupil",
    "schematic": "the forward wave by exact rays through lens and eye to the exit pupil's "
                 "reference sphere about the chief ray's retinal point, laid on the pupil as "
                 "the retina's visual angles see it (eyelab.optics.chain.retinal_psf); "
                 "rms_um over the exit pupil's area; the channels share the eye's "
                 "accommodation",
}


def thin_waves(spec, lens, one, point):
    """The thin eye's per-wavelength wave: a function (wl, share) -> (Zernike coefficients
    (um), the lens's pupil field or None, the channel's report entries; with ``share`` also
    "share", the pupil's light through lenslets)."""
    from eyelab.optics.chain.analysis import analyze_points
    from eyelab.optics.eye import zernike as zk
    from eyelab.optics.eye.aberrations import point_wave
    from eyelab.optics.lens.lenslets import carrier
    from eyelab.optics.lens.pupilwave import lenslet_share, pupil_wave
    from eyelab.optics.rays.trace import FATAL

    eye = spec.eye

    def thin(wl, share=False):
        res = analyze_points(eye, carrier(lens), one, wavelength_nm=wl,
                             fixation=spec.fixation, accommodation=spec.accommodation,
                             vertex_sphere=spec.vertex_sphere)
        if res.status[0] & np.uint8(FATAL):
            raise SpecError("point", f"point {point} has no light path at {wl:g} nm")
        c = point_wave(eye, res, 0, wl)
        extra = None if lens is None else pupil_wave(lens, res, 0, wl)
        info = {"rms_um": zk.rms(c, from_order=2), "rms_higher_orders_um": zk.rms(c, from_order=3),
                "coefficients_um": [float(v) for v in c]}
        if share:
            info["share"] = lenslet_share(extra[0], eye.pupil_diameter / 2)
        return c, extra, info

    return thin


def schematic_waves(spec, lens, one, point):
    """A schematic eye's per-wavelength wave (as :func:`thin_waves`): the line of sight
    through the carrier, the eye accommodated once (at its reference wavelength, as the
    spec says), the wave at the retina through the whole lens."""
    from eyelab.jobs.points import lenslet_row, line_of_sight_lens
    from eyelab.optics.chain.retina import eye_in_world, trace_objects
    from eyelab.optics.chain.retinal_psf import retinal_pupil_field, wave_rms
    from eyelab.optics.eye.thin import EYE_REFERENCE_NM

    eye = spec.eye
    traced = line_of_sight_lens(lens)

    def trace(wl, acc):
        r = trace_objects(eye, traced, one, fixation=spec.fixation, accommodation=acc,
                          wavelength_nm=wl)
        if not r.ok[0]:
            raise SpecError("point", f"point {point} has no light path at {wl:g} nm")
        return r

    acc = float(trace(EYE_REFERENCE_NM, spec.accommodation).accommodation[0])

    def schematic(wl, share=False):
        r = trace(wl, acc)
        try:
            field, slope, wave = retinal_pupil_field(eye, lens, r, 0, fixation=spec.fixation,
                                                     wavelength_nm=wl)
        except ValueError as e:         # the chief ray does not reach the retina
            if "does not reach" not in str(e):
                raise
            raise SpecError("point", f"point {point}: {e} at {wl:g} nm") from None
        info = {**wave_rms(wave), "accommodation_d": acc,
                "m_d": float(r.m[0]), "j0_d": float(r.j0[0]), "j45_d": float(r.j45[0])}
        if share:
            rot, vertex = eye_in_world(eye, spec.fixation, r.eye_dir[0])
            z_ep, _ = eye.entrance_pupil(acc, wl)
            info["share"] = lenslet_row(lens, r.object_points, 0,
                                        vertex + rot @ np.array([0.0, 0.0, z_ep]),
                                        r.eye_dir[0], eye.pupil_diameter / 2, wl)["fraction"]
        return np.zeros(6), (field, slope), info

    return schematic


def focus_range(lens) -> tuple:
    """(lowest, highest) vergence (D) of a lenslet lens's through-focus curve: from the
    carrier's image to the lenslets' add, each with a margin."""
    from eyelab.jobs.retinal import FOCUS_MARGIN_D

    add = lens.front.add_d
    return min(0.0, add) - FOCUS_MARGIN_D, max(0.0, add) + FOCUS_MARGIN_D


def _check_grids(pupil_mm, pitch_rad, lens) -> None:
    """Refuse before any ray is traced a PSF (every channel) or a lenslet lens's
    through-focus curve whose FFT exceeds the bound even for a wave without slope: the
    grids only grow with the wave's slope (:func:`eyelab.optics.eye.psf.psf_grid`)."""
    from eyelab.imaging.eyepsf import channel_wavelengths
    from eyelab.optics.eye.psf import focus_grid, psf_grid

    for wl in channel_wavelengths():
        psf_grid(0.0, pupil_mm, wl, pitch_rad, "pitch_arcmin")
    if lens is not None:
        reach = max(abs(v) for v in focus_range(lens))
        focus_grid(0.0, pupil_mm, channel_wavelengths()[1], reach, "lens.lenslets.add_d")


def lenslet_focus(lens, coefficients_um, pupil_mm, wavelength_nm, extra, sc) -> dict:
    """The image through focus behind a lenslet lens (:func:`eyelab.optics.eye.psf.
    through_focus`) from -1.5 D to the add + 1.5 D in 0.05 D steps (as ``analyze`` of a
    schematic eye), with the peaks of both curves (the carrier's image, the lenslets')."""
    from eyelab.jobs.retinal import FOCUS_STEP_D
    from eyelab.optics.chain.forward_wave import focus_peaks
    from eyelab.optics.eye.psf import through_focus

    lo, hi = focus_range(lens)
    vs = np.round(np.arange(lo, hi + FOCUS_STEP_D / 2, FOCUS_STEP_D), 10)
    tf = through_focus(coefficients_um, pupil_mm, wavelength_nm, vs, extra=extra,
                       stiles_crawford=sc)
    return {"wavelength_nm": wavelength_nm, "vergence_d": tf["vergence_d"],
            "axial": tf["axial"], "peak": tf["peak"],
            "axial_peaks": focus_peaks(tf),
            "peak_peaks": focus_peaks({"vergence_d": tf["vergence_d"], "axial": tf["peak"]})}
