"""The eye's point-spread function in wave optics: the squared Fourier transform of the
pupil function (Fraunhofer diffraction; J. W. Goodman, *Introduction to Fourier Optics*,
ch. 4 and 6).

The pupil function is A(p) exp(i 2 pi W(p) / lambda) over the eye's pupil: amplitude 1
(or the Stiles-Crawford apodisation 10^(-rho r^2 / 2) in amplitude — the luminous
efficiency 10^(-rho r^2) with rho = :data:`STILES_CRAWFORD_RHO` per mm^2, r from the pupil
centre: R. A. Applegate & V. Lakshminarayanan, *J. Opt. Soc. Am. A* 10:1611 (1993)),
and the wave aberration W (Zernike, :mod:`eyelab.optics.eye.zernike`, in eyelab's wearer
frame: x to the wearer's right, y up), the defocus the eye has for the point and the
wavelength included. The PSF is returned over visual angle as the wearer sees it: the
stationary phase of exp(i k (W(p) - p . theta)) puts each pupil ray at theta = grad W(p)
(x right, y up); arrays are image-oriented (row 0 at the top).

Sampling (stated once, here): with a pupil-plane spacing dx and an FFT of N samples, the
PSF's angular pitch is lambda / (N dx) and its field lambda / dx.

* the phase step per pupil sample stays below pi: dx < lambda / (2 max |grad W|), so
  the field lambda / dx exceeds 2 max |grad W| — every geometric ray lands inside it;
* the intensity is sampled at least at Nyquist: N >= 2 D / dx (two focal samples per
  lambda / D), at pitch / k (k odd, the smallest with pitch / k <= lambda / 2D), each
  output pixel centred on a multiple of the pitch.

The pixel rule (`eyelab psf`, ``integrate``): each pixel holds the light falling on its
whole square (pixel area, not a point sample at its centre), in units of the pupil's whole
light — the fine intensity convolved exactly with the pixel's box (:func:`_pixel_integrated`,
exact because the intensity is band-limited to D / lambda and sampled above Nyquist),
then read at the pixel centres. At 0.25' pixels the two rules differ by 5-9 % L1 for a
diffraction-limited 3 mm pupil and 16-43 % for a 6 mm one (486-656 nm). The pupil's light
is its disc's, each edge cell counted by its area (sum of A^2 / coverage): the FFT field's
own light (sum of the grey edge's A^2) is about 2 dx / 3 D short of it — light the grey
edge sends beyond the field — and dividing by it raised every pixel by 0.4-0.5 %. Against
the closed-form Airy pattern integrated over each pixel, and a direct Fraunhofer sum for
a partial pupil, the PSF is within 0.10-0.24 % L1 at 486-656 nm
(tests/test_psf_truth.py). A render's kernel (``integrate`` false) instead sums k x k
samples (point samples where k = 1: the render's own pixels integrate the image), over the
FFT field's light. The MTF is |OTF| averaged over each frequency's circle (cubic splines
of the complex OTF: :func:`_radial`), over the PSF's whole light (an integrated image's,
1; else its zero frequency): from the fine intensity
with ``mtf_cpd`` (the pupil's autocorrelation: no window, no pixel, no aliasing), or by
:func:`mtf` from the output image, which is aliased above 1 / pitch - D / lambda (for a
6 mm pupil at 0.25', above 48 and 25 c/deg at 546 and 486 nm: 0.017 too high at 60 c/deg
at 486 nm). Both are within 0.0003 of the closed form and of a pupil autocorrelation
where unaliased (tests/test_psf_truth.py).

At least :data:`MIN_PUPIL_SAMPLES` pupil samples are taken whatever the slope. For a 6 mm
pupil at 555 nm with 0.15 um of spherical aberration and 0.10 um of coma (max |grad W|
about 0.8 mrad: dx <= 0.35 mm, so the 128-sample minimum rules, dx = 0.047 mm), a 0.25'
pitch takes k = 3 and N = 490 (``eyelab bench psf``); a keratoconus-like eye's slope
(about 12 mrad) takes 248 samples and N = 948. The grid is refused beyond :data:`MAX_GRID`
a side, naming the caller's ``field``.
"""

from __future__ import annotations

import math

import numpy as np

from eyelab.core.errors import SpecError
from eyelab.optics.eye import zernike as zk

#: Stiles-Crawford rho (per mm^2) for the optional apodisation.
STILES_CRAWFORD_RHO = 0.05
#: The largest FFT a side.
MAX_GRID = 4096
#: Diffraction widths (lambda / D) the PSF's field reaches beyond the geometric spread on
#: each side. The light a circular pupil diffracts beyond rho lambda / D is about
#: 1 / (pi^2 rho) of it, and what falls beyond the FFT's field folds back into it: with
#: only 2 max |grad W|, 0.30-0.34 % of a keratoconus-like eye's light (6 mm, 486-546 nm)
#: did, moving the centroid by 0.13'; with 16 widths a 6 mm PSF with 1 D of defocus and
#: 0.3 um of SA was still 1.0-1.07 % (L1) from the converged one; with 64 every case of
#: tests/test_psf_sampling.py is within 0.22-0.38 %.
FIELD_MARGIN = 64
#: Pupil samples across the diameter at least (a smooth wavefront).
MIN_PUPIL_SAMPLES = 128
ARCMIN = math.pi / (180 * 60)


def max_slope(coefficients_um, radius_m: float) -> float:
    """max |grad W| over the pupil of radius ``radius_m`` (dimensionless: W in m per m of
    pupil), on a 129 x 129 grid."""
    g = np.linspace(-1, 1, 129)
    x, y = np.meshgrid(g, g)
    w = zk.wavefront(coefficients_um, x, y) * 1e-6
    gy, gx = np.gradient(w, g[1] - g[0])
    inside = x * x + y * y <= 1.0
    return float(np.max(np.hypot(gx, gy)[inside])) / radius_m if np.any(inside) else 0.0


def psf_grid(slope: float, pupil_mm: float, wavelength_nm: float, pitch_rad: float,
             field: str) -> tuple:
    """(FFT size, block k) of :func:`psf` for a wavefront whose largest slope is ``slope``
    (rad), or a SpecError naming ``field`` beyond :data:`MAX_GRID` — also an estimate
    before the wave is known (a lower bound on the slope gives a lower bound on the
    grid)."""
    lam, d = wavelength_nm * 1e-9, pupil_mm * 1e-3
    # the field spans the geometric spread 2 max |grad W| plus FIELD_MARGIN diffraction
    # widths on each side, so that the light diffracted past the geometric edge is inside
    dx_max = min(lam / (2 * (slope + FIELD_MARGIN * lam / d)), d / MIN_PUPIL_SAMPLES)
    k = max(1, math.ceil(2 * d * pitch_rad / lam))
    k += (k % 2 == 0)                                   # odd: output centred on theta = 0
    n_fft = math.ceil(lam * k / (dx_max * pitch_rad))
    if n_fft > MAX_GRID:
        raise SpecError(field, f"the wavefront's slope ({slope * 1e3:.2f} mrad) at a "
                        f"{pupil_mm:g} mm pupil and a {pitch_rad / ARCMIN:.3g}' pitch needs a "
                        f"{n_fft}-point FFT (at most {MAX_GRID}): a coarser pitch, a smaller "
                        f"pupil or smaller aberrations")
    return n_fft + n_fft % 2, k


def focus_grid(slope: float, pupil_mm: float, wavelength_nm: float, vergence_d: float,
               field: str) -> tuple:
    """(FFT size, pupil-sample spacing dx, m) of :func:`through_focus` for a wavefront of
    largest slope ``slope`` (rad) taken through vergences up to ``vergence_d`` (D) either
    way, or a SpecError naming ``field`` beyond :data:`MAX_GRID` (an estimate too, as
    :func:`psf_grid`)."""
    lam, d = wavelength_nm * 1e-9, pupil_mm * 1e-3
    slope = slope + abs(vergence_d) * d / 2
    dx = min(lam / (2 * (slope + FOCUS_FIELD_MARGIN * lam / d)), d / MIN_PUPIL_SAMPLES)
    n_fft = int(math.ceil(4 * d / dx))
    n_fft += n_fft % 2
    if n_fft > MAX_GRID:
        raise SpecError(field, f"the through-focus range's slope ({slope * 1e3:.2f} mrad: "
                        f"to {abs(vergence_d):g} D over a {pupil_mm:g} mm pupil) needs a "
                        f"{n_fft}-point FFT (at most {MAX_GRID}): a smaller pupil or add")
    return n_fft, dx


def psf(coefficients_um, pupil_mm: float, wavelength_nm: float, pitch_rad: float, size: int,
        *, stiles_crawford: bool = False, field: str = "eye.aberrations",
        integrate: bool = False, strehl: bool = True, extra=None, mtf_cpd=None) -> dict:
    """The PSF (``size`` x ``size``, odd; sums to the energy inside it, of 1 in all) at
    ``pitch_rad`` per pixel for the wave aberration ``coefficients_um`` (OSA order from
    j = 0, wearer frame, over the pupil of ``pupil_mm``), at ``wavelength_nm``. With
    ``integrate``: each pixel the light falling on its whole area over the pupil's light
    (:func:`_pixel_integrated`: what `eyelab psf` shows; the module doc's pixel rule);
    else the sum of k x k samples around its centre over the FFT field's light (the kernel
    a render convolves its own pixel-integrated image with, which must not add a second
    pixel footprint). Returns
    {"psf", "pitch_rad", "strehl" (the PSF's true peak, :func:`peak_intensity`, over the
    diffraction-limited peak; None with ``strehl`` false: a render's kernel), "rms_um"
    (piston removed), "pupil_samples", "fft", "block", "outside_window" (the light beyond
    the window)}. ``extra``: (a function of pupil coordinates (x, y; m) returning the wave
    (m) added to the Zernike one there and an amplitude factor, its largest slope): a
    spectacle lens's real wave beyond second order and its lenslets' zones
    (:func:`eyelab.optics.lens.pupilwave.pupil_wave`). ``mtf_cpd`` (cycles / deg): also
    "mtf", the optics' MTF there (|OTF| averaged over each frequency's circle,
    :func:`_radial`, of the fine, unwindowed intensity over the pupil's light, whatever
    ``integrate``; NaN beyond the fine grid's Nyquist frequency, itself beyond the cut-off
    D / lambda)."""
    if size % 2 == 0 or size < 3:
        raise SpecError("psf.size", f"must be odd and >= 3, got {size}")
    lam = wavelength_nm * 1e-9
    d = pupil_mm * 1e-3
    slope = max_slope(coefficients_um, d / 2) + (0.0 if extra is None else extra[1])
    n_fft, k = psf_grid(slope, pupil_mm, wavelength_nm, pitch_rad, field)
    dx = lam * k / (n_fft * pitch_rad)
    x, y, amp, w, cov = _pupil(coefficients_um, d, dx, n_fft, stiles_crawford, extra)
    field = amp * np.exp(2j * np.pi * w / lam)
    fine = _intensity(field)
    # the true peak's search costs more than the PSF itself: only where it is asked for
    ratio = (peak_intensity(field, x, y, lam, fine, lam / (n_fft * dx))
             / float(amp.sum()) ** 2) if strehl else None
    # the pupil's light, each edge cell's by its area (module doc); a render's kernel is
    # over the FFT field's (normalised to its window by its caller anyway)
    light = n_fft * n_fft * float(np.sum(amp[cov > 0] ** 2 / cov[cov > 0]))
    total = light if integrate else float(fine.sum())
    out = (_blocks(_pixel_integrated(fine / total, k), k, size, centres=True) if integrate
           else _blocks(fine / total, k, size))
    res = {"psf": out[::-1], "pitch_rad": pitch_rad, "strehl": ratio,
           "rms_um": zk.rms(coefficients_um), "pupil_samples": int(round(d / dx)),
           "fft": n_fft, "block": k, "outside_window": max(0.0, 1.0 - float(out.sum()))}
    if mtf_cpd is not None:
        otf = np.fft.fftshift(np.fft.fft2(np.fft.ifftshift(fine))) / light
        res["mtf"] = _radial(otf, pitch_rad / k, mtf_cpd)
    return res


def _pixel_integrated(fine: np.ndarray, k: int) -> np.ndarray:
    """``fine`` (N x N intensities at a pitch of 1 / k output pixel) convolved with the
    output pixel's box, times k^2: each sample is then the light falling in a whole output
    pixel centred there. Exact, not a k x k sum of point samples: the intensity is
    band-limited (its spectrum, the pupil's autocorrelation, fits the N-point grid when
    N >= 2 D / dx, as the sampling rule keeps), so the box is the product of its spectrum
    with sinc(k f) per axis."""
    n = fine.shape[0]
    spec = np.fft.rfft2(np.fft.ifftshift(fine))
    fy, fx = np.fft.fftfreq(n), np.fft.rfftfreq(n)
    spec *= np.sinc(k * fy)[:, None] * np.sinc(k * fx)[None, :]
    return np.fft.fftshift(np.fft.irfft2(spec, s=fine.shape)) * (k * k)


def _pupil(coefficients_um, d: float, dx: float, n_fft: int, stiles_crawford: bool, extra
           ) -> tuple:
    """The pupil function's parts on the n_fft x n_fft grid of spacing ``dx`` (m) over a
    pupil of diameter ``d`` (m): (x, y, amplitude, wave (m), inside) — the anti-aliased
    edge, the Stiles-Crawford apodisation if asked, the Zernike wave and ``extra``'s zones
    (:func:`psf`)."""
    c = (np.arange(n_fft) - n_fft // 2) * dx
    x, y = np.meshgrid(c, c)
    cov = _coverage(x, y, d / 2, dx)
    amp = cov.copy()
    inside = cov > 0
    if stiles_crawford:
        amp = amp * 10.0 ** (-STILES_CRAWFORD_RHO * (x * x + y * y) * 1e6 / 2)
    w = np.where(inside, zk.wavefront(coefficients_um, x / (d / 2), y / (d / 2)), 0.0) * 1e-6
    if extra is not None:
        dw, da = extra[0](x[inside], y[inside])
        w[inside] += dw
        amp[inside] *= da
    return x, y, amp, w, cov


def _coverage(x, y, radius: float, dx: float, sub: int = 8) -> np.ndarray:
    """The share of each pupil-grid cell (centre x, y, side dx) inside the pupil's circle
    (``sub`` x ``sub`` samples in the cells the edge crosses): an anti-aliased edge, so the
    diffraction pattern does not depend on where the grid's samples fall."""
    r = np.hypot(x, y)
    out = (r <= radius).astype(float)
    edge = np.abs(r - radius) < dx
    o = (np.arange(sub) + 0.5) / sub - 0.5
    ox, oy = np.meshgrid(o * dx, o * dx)
    ex, ey = x[edge][:, None], y[edge][:, None]
    out[edge] = np.mean(np.hypot(ex + ox.ravel(), ey + oy.ravel()) <= radius, axis=1)
    return out


def peak_intensity(field, x, y, lam: float, fine, pitch: float) -> float:
    """The largest |sum field e^{-2 pi i (x, y) . theta / lam}|^2 over directions theta: the
    PSF's true peak, not its largest sample. From the largest sample of ``fine`` (the
    FFT's intensities, ``pitch`` rad apart, theta = 0 at N // 2), the direct sum over the
    pupil's samples is maximised in continuous theta (Nelder-Mead, to 1e-4 of a sample).
    The diffraction-limited peak it is divided by for the Strehl ratio is the same sum at
    theta = 0 for the unaberrated pupil, |sum amp|^2, exactly."""
    from scipy.optimize import minimize

    n = fine.shape[0]
    iy, ix = np.unravel_index(int(np.argmax(fine)), fine.shape)
    t0 = np.array([(ix - n // 2) * pitch, (iy - n // 2) * pitch])
    sel = field != 0
    f, xs, ys = field[sel], x[sel] / lam, y[sel] / lam

    def neg(t):
        return -abs(np.sum(f * np.exp(-2j * np.pi * (xs * t[0] + ys * t[1])))) ** 2

    simplex = t0 + pitch * np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5]])
    res = minimize(neg, t0, method="Nelder-Mead",
                   options={"initial_simplex": simplex, "xatol": 1e-4 * pitch,
                            "fatol": 1e-9 * float(fine.max()), "maxiter": 400})
    return max(float(-res.fun), float(fine.max()))


def _intensity(field: np.ndarray) -> np.ndarray:
    """|FFT|^2 with theta = 0 at index N // 2 (rows: theta_y increasing)."""
    f = np.fft.fftshift(np.fft.fft2(np.fft.ifftshift(field)))
    return f.real ** 2 + f.imag ** 2


def _blocks(fine: np.ndarray, k: int, size: int, *, centres: bool = False) -> np.ndarray:
    """Sum ``k`` x ``k`` blocks of ``fine`` into a ``size`` x ``size`` grid centred on the
    fine grid's centre sample (k odd), zero where it runs off the fine grid — or, with
    ``centres``, take each block's centre sample (``fine`` already integrated over the
    pixel: :func:`_pixel_integrated`). Only the blocks the fine grid covers are read
    (memory of the fine grid, whatever ``size``)."""
    n = fine.shape[0]
    c = n // 2
    # coarse index i covers fine samples c + i k - k//2 ... c + i k + k//2
    i_lo = -((c + k // 2) // k)                 # the first block starting at or after 0
    i_lo = i_lo if c + i_lo * k - k // 2 >= 0 else i_lo + 1
    i_hi = (n - 1 - c - k // 2) // k            # the last block ending before n
    m = i_hi - i_lo + 1
    half = size // 2
    if m <= 0:              # the whole fine grid is inside the centre pixel
        out = np.zeros((size, size))
        out[half, half] = fine.sum()
        return out
    start = c + i_lo * k - k // 2
    cut = fine[start:start + m * k, start:start + m * k]
    coarse = (cut.reshape(m, k, m, k)[:, k // 2, :, k // 2] if centres
              else cut.reshape(m, k, m, k).sum(axis=(1, 3)))
    out = np.zeros((size, size))
    a, b = max(i_lo, -half), min(i_hi, half)    # coarse indices kept
    out[a + half:b + half + 1, a + half:b + half + 1] = coarse[a - i_lo:b - i_lo + 1,
                                                               a - i_lo:b - i_lo + 1]
    return out


def mtf(psf_image: np.ndarray, pitch_rad: float, frequencies_cpd, *,
        integrated: bool = False) -> np.ndarray:
    """The optics' modulation transfer, radially averaged, at ``frequencies_cpd`` (cycles
    per degree), up to the pixel grid's Nyquist frequency (NaN beyond): |OTF| of the
    (image-oriented) PSF over its zero-frequency value — or, with ``integrated`` (its
    pixels hold the light over their whole area as fractions of the whole PSF's light:
    :func:`psf`'s ``integrate``), over that whole light, 1, not the window's sum (which
    raised every frequency by the share beyond the window, 0.3-0.9 %), with the pixel's
    own transfer sinc(fx p) sinc(fy p) divided out — averaged over each frequency's circle
    (:func:`_radial`). From the image, frequencies above 1 / p - D / lambda hold
    aliases of those beyond its Nyquist frequency (0.017 at 60 c/deg for a 6 mm pupil at
    486 nm at 0.25'): :func:`psf`'s ``mtf_cpd`` has none."""
    n = psf_image.shape[0]
    otf = np.fft.fftshift(np.fft.fft2(np.fft.ifftshift(psf_image)))
    if integrated:
        cyc = (np.arange(n) - n // 2) / n                              # cycles per pixel
        otf = otf / (np.sinc(cyc)[None, :] * np.sinc(cyc)[:, None])
    else:
        otf = otf / np.abs(otf).max()
    return _radial(otf, pitch_rad, frequencies_cpd)


def _radial(otf: np.ndarray, pitch_rad: float, frequencies_cpd) -> np.ndarray:
    """|OTF| (``otf``: n x n complex, zero frequency at n // 2, of an image of
    ``pitch_rad`` pixels) averaged over the circle of each of ``frequencies_cpd`` (cycles /
    deg; NaN beyond the grid's Nyquist frequency): the complex OTF interpolated by cubic
    splines at max(32, 2 pi r) points of the circle of r frequency steps (1 / (n pitch)).
    Rings one step wide, linear between them, read the defocused eye's steep low
    frequencies up to 0.016 low (a 4 mm pupil at 5 c/deg; 0.0002 so)."""
    from scipy.ndimage import map_coordinates

    n = otf.shape[0]
    step = 1.0 / (n * pitch_rad) * (math.pi / 180)                    # cycles / deg
    f = np.atleast_1d(np.asarray(frequencies_cpd, float))
    r = f / step
    nyq = n // 2
    out = np.full(f.shape, np.nan)
    ok = r <= nyq
    if not np.any(ok):
        return out
    h = min(nyq, int(math.ceil(float(r[ok].max()))) + 4)              # the disc read
    sub = otf[nyq - h:nyq + h + 1, nyq - h:nyq + h + 1]
    parts = [np.asarray(part, float) for part in (sub.real, sub.imag)]
    for i in np.flatnonzero(ok):
        m = max(32, math.ceil(2 * math.pi * r[i]))
        a = (np.arange(m) + 0.5) * (2 * math.pi / m)
        at = [h + r[i] * np.sin(a), h + r[i] * np.cos(a)]
        re, im = (map_coordinates(part, at, order=3, mode="nearest") for part in parts)
        out[i] = float(np.mean(np.hypot(re, im)))
    return out


#: Diffraction widths beyond the geometric spread a through-focus field keeps (its peak
#: only: the light folded back from beyond is far from it).
FOCUS_FIELD_MARGIN = 4


def through_focus(coefficients_um, pupil_mm: float, wavelength_nm: float, vergences_d, *,
                  extra=None, stiles_crawford: bool = False,
                  field: str = "lens.lenslets.add_d") -> dict:
    """The image through focus: for each v of ``vergences_d`` (D) the retina moved to where
    a wave v more converging at the pupil focuses (the wave times exp(-i k v h^2 / 2)),
    the intensity at the image point (theta = 0: "axial") and the PSF's highest wherever it
    lies ("peak": its largest sample at a quarter of lambda / D, within 5 % of the true
    peak), each over the aberration-free peak of the same pupil. ``coefficients_um``,
    ``extra``, ``stiles_crawford`` as :func:`psf`'s; ``field`` the key a grid beyond
    :data:`MAX_GRID` is blamed on."""
    lam = wavelength_nm * 1e-9
    d = pupil_mm * 1e-3
    v = np.asarray(vergences_d, float)
    slope = max_slope(coefficients_um, d / 2) + (0.0 if extra is None else extra[1])
    n_fft, dx = focus_grid(slope, pupil_mm, wavelength_nm, float(np.abs(v).max(initial=0.0)),
                           field)
    x, y, amp, w, cov = _pupil(coefficients_um, d, dx, n_fft, stiles_crawford, extra)
    inside = cov > 0
    norm = float(amp.sum()) ** 2
    h2 = (x * x + y * y)[inside]
    a_in, w_in = amp[inside], w[inside]
    axial, peak = [], []
    field = np.zeros((n_fft, n_fft), complex)
    for vv in v:
        f = a_in * np.exp(2j * np.pi * (w_in - 0.5 * vv * h2) / lam)
        axial.append(abs(f.sum()) ** 2 / norm)
        field[inside] = f
        peak.append(float(_intensity(field).max()) / norm)
    return {"vergence_d": v.tolist(), "axial": axial, "peak": peak,
            "pupil_samples": int(round(d / dx)), "fft": n_fft}
