"""The eye's point-spread function in wave optics: the squared Fourier transform of the
pupil function (Fraunhofer diffraction; J. W. Goodman, *Introduction to Fourier Optics*,
ch. 4 and 6).

The pupil function is A(p) exp(i 2 pi W(p) / lambda) over the eye's pupil: amplitude 1
(or the Stiles-Crawford apodisation 10^(-rho r^2 / 2) in amplitude — the luminous
efficiency 10^(-rho r^2) with rho = :data:`STILES_CRAWFORD_RHO` per mm^2, r from the pupil
centre: R. A. Applegate & V. Lakshminarayanan, *J. Opt. Soc. Am. A* 10:1611 (1993)),
and the wave aberration W (Zernike, :mod:`eyelab.optics.zernike`, in eyelab's wearer
frame: x to the wearer's right, y up), the defocus the eye has for the point and the
wavelength included. The PSF is returned over visual angle as the wearer sees it: the
stationary phase of exp(i k (W(p) - p . theta)) puts each pupil ray at theta = grad W(p)
(x right, y up); arrays are image-oriented (row 0 at the top).

Sampling (stated once, here): with a pupil-plane spacing dx and an FFT of N samples, the
PSF's angular pitch is lambda / (N dx) and its field lambda / dx.

* the phase step per pupil sample stays below pi: dx < lambda / (2 max |grad W|), so
  the field lambda / dx exceeds 2 max |grad W| — every geometric ray lands inside it;
* the intensity is sampled at least at Nyquist: N >= 2 D / dx (two focal samples per
  lambda / D); a coarser requested pitch is reached by computing at pitch / k (k odd)
  and summing k x k blocks (each output pixel centred on a multiple of the pitch).

For a 3 mm pupil at 555 nm (lambda / D = 0.64') and 0.3 um of spherical aberration at 6 mm
(max |grad W| about 2.4 mrad on the full pupil), dx <= 0.12 mm; a 0.5' pitch takes k = 3
and N = 128 or so. The sizes grow with the aberration's slope and the pupil; the grid is
refused beyond :data:`MAX_GRID` a side, naming the key.
"""

from __future__ import annotations

import math

import numpy as np

from eyelab.core.errors import SpecError
from eyelab.optics import zernike as zk

#: Stiles-Crawford rho (per mm^2) for the optional apodisation.
STILES_CRAWFORD_RHO = 0.05
#: The largest FFT a side.
MAX_GRID = 4096
#: Pupil samples across the diameter at least (a smooth wavefront).
MIN_PUPIL_SAMPLES = 128
ARCMIN = math.pi / (180 * 60)


def _slope(coefficients_um, radius_m: float) -> float:
    """max |grad W| over the pupil (dimensionless: W in m per m of pupil)."""
    g = np.linspace(-1, 1, 129)
    x, y = np.meshgrid(g, g)
    w = zk.wavefront(coefficients_um, x, y) * 1e-6
    gy, gx = np.gradient(w, g[1] - g[0])
    inside = x * x + y * y <= 1.0
    return float(np.max(np.hypot(gx, gy)[inside])) / radius_m if np.any(inside) else 0.0


def psf(coefficients_um, pupil_mm: float, wavelength_nm: float, pitch_rad: float, size: int,
        *, stiles_crawford: bool = False) -> dict:
    """The PSF (``size`` x ``size``, odd; sums to the energy inside it, of 1 in all) at
    ``pitch_rad`` per pixel for the wave aberration ``coefficients_um`` (OSA order from
    j = 0, wearer frame, over the pupil of ``pupil_mm``), at ``wavelength_nm``. Returns
    {"psf", "pitch_rad", "strehl" (peak over the diffraction-limited peak at the same
    sampling), "rms_um" (piston removed), "pupil_samples", "fft", "block"}."""
    if size % 2 == 0 or size < 3:
        raise SpecError("psf.size", f"must be odd and >= 3, got {size}")
    lam = wavelength_nm * 1e-9
    d = pupil_mm * 1e-3
    slope = _slope(coefficients_um, d / 2)
    dx_max = lam / (2 * slope) if slope > 0 else d / MIN_PUPIL_SAMPLES
    dx_max = min(dx_max, d / MIN_PUPIL_SAMPLES)
    k = max(1, math.ceil(2 * d * pitch_rad / lam))
    k += (k % 2 == 0)                                   # odd: output centred on theta = 0
    n_fft = math.ceil(lam * k / (dx_max * pitch_rad))
    if n_fft > MAX_GRID:
        raise SpecError("eye.aberrations", f"the wavefront's slope ({slope * 1e3:.2f} mrad) "
                        f"at a {pupil_mm:g} mm pupil needs a {n_fft}-point FFT for a "
                        f"{pitch_rad / ARCMIN:.3g}' pitch (at most {MAX_GRID}): a coarser "
                        f"pitch or a smaller pupil")
    n_fft += n_fft % 2
    dx = lam * k / (n_fft * pitch_rad)
    c = (np.arange(n_fft) - n_fft // 2) * dx
    x, y = np.meshgrid(c, c)
    amp = _coverage(x, y, d / 2, dx)
    inside = amp > 0
    if stiles_crawford:
        amp = amp * 10.0 ** (-STILES_CRAWFORD_RHO * (x * x + y * y) * 1e6 / 2)
    w = np.where(inside, zk.wavefront(coefficients_um, x / (d / 2), y / (d / 2)), 0.0) * 1e-6
    field = amp * np.exp(2j * np.pi * w / lam)
    fine = _intensity(field)
    ideal = _intensity(amp.astype(complex))
    strehl = float(fine.max() / ideal.max())
    total = float(fine.sum())
    out = _blocks(fine / total, k, size)
    return {"psf": out[::-1], "pitch_rad": pitch_rad, "strehl": strehl,
            "rms_um": zk.rms(coefficients_um), "pupil_samples": int(round(d / dx)),
            "fft": n_fft, "block": k}


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


def _intensity(field: np.ndarray) -> np.ndarray:
    """|FFT|^2 with theta = 0 at index N // 2 (rows: theta_y increasing)."""
    f = np.fft.fftshift(np.fft.fft2(np.fft.ifftshift(field)))
    return f.real ** 2 + f.imag ** 2


def _blocks(fine: np.ndarray, k: int, size: int) -> np.ndarray:
    """Sum ``k`` x ``k`` blocks of ``fine`` into a ``size`` x ``size`` grid centred on the
    fine grid's centre sample (k odd), zero where it runs off the fine grid."""
    n = fine.shape[0]
    half = size // 2
    lo = n // 2 - (half * k + k // 2)
    pad = max(0, -lo, lo + size * k - n)
    if pad:
        fine = np.pad(fine, pad)
        lo += pad
    cut = fine[lo:lo + size * k, lo:lo + size * k]
    return cut.reshape(size, k, size, k).sum(axis=(1, 3))


def mtf(psf_image: np.ndarray, pitch_rad: float, frequencies_cpd) -> np.ndarray:
    """The modulation transfer, radially averaged, at ``frequencies_cpd`` (cycles per
    degree): |OTF| of the (image-oriented) PSF, normalised to 1 at zero frequency, read on
    rings of the discrete spectrum (linear interpolation in radius)."""
    otf = np.abs(np.fft.fftshift(np.fft.fft2(psf_image)))
    otf = otf / otf.max()
    n = psf_image.shape[0]
    f = (np.arange(n) - n // 2) / (n * pitch_rad) * (math.pi / 180)     # cycles / deg
    fx, fy = np.meshgrid(f, f)
    rad = np.hypot(fx, fy).ravel()
    order = np.argsort(rad)
    edges = np.unique(np.round(rad[order], 9))
    prof = np.array([otf.ravel()[np.isclose(rad, e, atol=1e-9)].mean() for e in edges[:n // 2]])
    return np.interp(frequencies_cpd, edges[:n // 2], prof, right=np.nan)
