"""`eyelab psf`'s PSF against independent Fraunhofer computations under eyelab's pixel rule
(:mod:`eyelab.optics.eye.psf`: each pixel holds the light falling on its whole square, in
units of the pupil's whole light), at its default sampling (0.25' pixels, 129 a side) and
the three channels' wavelengths (656.27 / 546.07 / 486.13 nm).

The truths share no code with eyelab's PSF (no FFT, no periodic field, no Fourier-domain
pixel box):

* diffraction-limited 3 mm and 6 mm: the closed-form Airy pattern (2 J1(x) / x)^2,
  x = pi D sin(theta) / lambda (peak pi D^2 / (4 lambda^2) of the light per steradian),
  integrated over each pixel by 16 x 16 Gauss-Legendre points;
* a 4 mm pupil of a 6 mm chromatic measurement (coma and spherical aberration rescaled,
  the eye's chromatic defocus added at 656 and 486 nm, as `eyelab psf` reports the
  coefficients): the Fraunhofer integral of the pupil function as an explicit matrix
  Fourier transform (two matrix products, Soummer et al. 2007, *Opt. Express* 15:15935)
  over a 512-cell pupil grid, its edge cells weighted by their area in the disc (16 x 16
  sub-cells), the phase from the standard's Zernike formula written out here; each pixel
  integrated by 6 x 6 Gauss-Legendre points; the light divided by the disc's area;
* the diffraction-limited MTF: (2 / pi)(acos v - v sqrt(1 - v^2)), v = f lambda / D;
  the 4 mm pupil's: the pupil function's autocorrelation at the shift lambda f, averaged
  over 12 directions.

prysm 0.21.1 (a cross-check once, not a dependency: its matrix DFT of a 1024-cell pupil
with a 4 x 4 supersampled edge, 11 x 11 points a pixel) agrees with the 4 mm truth to
0.03-0.08 % L1 and with the Airy truth to 0.04-0.22 % (its midpoints, on the sharpest).

Measured, L1 over the window at 656 / 546 / 486 nm: Airy 3 mm 0.10 / 0.12 / 0.14 %, 6 mm
0.19 / 0.22 / 0.24 %; the 4 mm pupil 0.13 / 0.14 / 0.17 % (the truth itself moves by
0.005-0.009 % with 768 cells, 24 x 24 sub-cells and 8 x 8 points a pixel). Before the
PSF was divided by the pupil's light counted by area (it was divided by the FFT field's
light, the grey-edged pupil's sum of squared amplitudes, 2 dx / 3 D short of the disc's):
0.56-0.59 %, 0.64-0.69 % and 0.45-0.56 %. Point samples of the same Airy pattern differ
from the pixel-area truth by 5.3 / 7.8 / 9.0 % (3 mm) and 16-43 % (6 mm), of the 4 mm
pupil's by 3.5 / 10.6 / 3.6 %: the rule matters more than any sampling error.

MTF (the closed form for the diffraction-limited pupils; for the 4 mm pupil the pupil
function's autocorrelation, no FFT): from the PSF's fine grid (``mtf_cpd``) within
0.0001-0.0003 at 5-60 c/deg; from the 0.25' image as `eyelab psf` reports it, within
0.0003 wherever the image is unaliased (f < 1 / pitch - D / lambda; a 6 mm pupil's image
at 546 / 486 nm is 0.0024 / 0.017 high at 60 c/deg, 0.0049 at 45 c/deg at 486 nm).
Before, over the window's sum and averaged on rings one frequency step wide: 0.005-0.007
for the diffraction-limited pupils, 0.005-0.013 for the 4 mm one (the chromatic
defocus's steep low frequencies).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import j1

from eyelab.jobs.psf import MTF_FREQUENCIES_CPD, PITCH_ARCMIN, SIZE
from eyelab.optics.eye.psf import ARCMIN, mtf, psf

WAVELENGTHS_NM = (656.27, 546.07, 486.13)
PITCH = PITCH_ARCMIN * ARCMIN
L1_BOUND = 0.005
MTF_BOUND = 0.005


def _pixel_nodes(size: int, pitch: float, q: int) -> tuple:
    """Gauss-Legendre points (rad, ascending: size * q) covering ``size`` pixels of
    ``pitch`` centred on 0, and their weights (each pixel's sum to 1)."""
    u, w = np.polynomial.legendre.leggauss(q)
    centres = (np.arange(size) - size // 2) * pitch
    return ((centres[:, None] + u[None, :] * pitch / 2).ravel(),
            np.tile(w / 2, size))


def _per_pixel(intensity: np.ndarray, weights: np.ndarray, size: int) -> np.ndarray:
    """(size * q)^2 intensities at the Gauss-Legendre points -> (size, size) means."""
    q = len(weights) // size
    wi = intensity * weights[:, None] * weights[None, :]
    return wi.reshape(size, q, size, q).sum(axis=(1, 3))


def airy_pixels(pupil_mm: float, wavelength_nm: float, pitch: float = PITCH,
                size: int = SIZE, q: int = 16) -> np.ndarray:
    """The Airy pattern's light in each pixel (size x size, rows theta_y ascending; of 1
    in all): the closed form integrated over each pixel's area."""
    d, lam = pupil_mm * 1e-3, wavelength_nm * 1e-9
    t, w = _pixel_nodes(size, pitch, q)
    x = math.pi * d * np.sin(np.hypot(t[None, :], t[:, None])) / lam
    safe = np.where(x > 0, x, 1.0)
    amp = np.where(x > 0, 2 * j1(safe) / safe, 1.0)
    per_sr = amp**2 * math.pi * d**2 / (4 * lam**2)
    return _per_pixel(per_sr, w, size) * pitch**2


def zernike(n: int, m: int, rho, theta):
    """Z_n^m of ANSI Z80.28 (unit RMS over the unit disc; m >= 0 cos, m < 0 sin), from the
    radial polynomial's sum."""
    am = abs(m)
    r = sum((-1) ** s * math.factorial(n - s)
            / (math.factorial(s) * math.factorial((n + am) // 2 - s)
               * math.factorial((n - am) // 2 - s)) * rho ** (n - 2 * s)
            for s in range((n - am) // 2 + 1))
    norm = math.sqrt(2 * (n + 1) / (1 + (m == 0)))
    return norm * r * (np.cos(am * theta) if m >= 0 else np.sin(am * theta))


def osa_nm(j: int) -> tuple:
    """OSA single index j -> (n, m)."""
    n = math.ceil((-3 + math.sqrt(9 + 8 * j)) / 2)
    return n, 2 * j - n * (n + 2)


def mft_pixels(coefficients_um, pupil_mm: float, wavelength_nm: float, pitch: float = PITCH,
               size: int = SIZE, cells: int = 512, sub: int = 16, q: int = 6) -> np.ndarray:
    """The Fraunhofer integral of the pupil function (amplitude 1 over the disc of
    ``pupil_mm``, phase 2 pi W / lambda, W from ``coefficients_um`` (OSA order from j = 0,
    x the columns' axis)) at the Gauss-Legendre points of each pixel, as two matrix
    products over ``cells`` x ``cells`` pupil cells (edge cells weighted by the share of
    ``sub`` x ``sub`` sub-cells in the disc); each pixel's light (size x size, rows theta_y
    ascending) over the disc's whole light, pi D^2 / 4."""
    d, lam = pupil_mm * 1e-3, wavelength_nm * 1e-9
    side = d * (1 + 2 / cells)
    cell = side / cells
    x = (np.arange(cells) + 0.5) * cell - side / 2                     # cell centres, m
    s = ((np.arange(sub) + 0.5) / sub - 0.5) * cell
    xs = (x[:, None] + s[None, :]).ravel()
    inside = xs[:, None] ** 2 + xs[None, :] ** 2 <= (d / 2) ** 2       # rows y, columns x
    area = inside.reshape(cells, sub, cells, sub).mean(axis=(1, 3))
    yy, xx = np.meshgrid(x, x, indexing="ij")
    rho, theta = np.hypot(xx, yy) / (d / 2), np.arctan2(yy, xx)
    w_um = sum(c * zernike(*osa_nm(j), rho, theta)
               for j, c in enumerate(coefficients_um) if c != 0)
    field = area * np.exp(2j * np.pi * w_um * 1e-6 / lam) * cell**2
    t, wt = _pixel_nodes(size, pitch, q)
    kernel = np.exp(-2j * np.pi * np.outer(np.sin(t), x) / lam)         # (points, cells)
    e = kernel @ field @ kernel.T                                       # rows theta_y
    per_sr = np.abs(e) ** 2 / lam**2
    return _per_pixel(per_sr, wt, size) * pitch**2 / (math.pi * d**2 / 4)


def autocorrelation_mtf(coefficients_um, pupil_mm: float, wavelength_nm: float, f_cpd,
                        cells: int = 192, angles: int = 12, sub: int = 4) -> np.ndarray:
    """The MTF at ``f_cpd`` (cycles / deg) as the pupil function's autocorrelation over
    its light, |integral P(x) P*(x + lambda nu) dx| / (pi D^2 / 4), averaged over
    ``angles`` directions of nu in [0, pi) (|OTF(-nu)| = |OTF(nu)|): P evaluated anew at
    the shifted points (``cells`` a diameter, edge cells weighted by ``sub`` x ``sub``
    sub-cells), no FFT, no PSF."""
    d, lam = pupil_mm * 1e-3, wavelength_nm * 1e-9
    r = d / 2
    h = d / cells
    xx, yy = np.meshgrid((np.arange(cells) + 0.5) * h - r, (np.arange(cells) + 0.5) * h - r)
    o = ((np.arange(sub) + 0.5) / sub - 0.5) * h

    def pupil(px, py):
        cover = np.mean([np.hypot(px + a, py + b) <= r for a in o for b in o], axis=0)
        rho, theta = np.hypot(px, py) / r, np.arctan2(py, px)
        w_um = sum(c * zernike(*osa_nm(j), rho, theta)
                   for j, c in enumerate(coefficients_um) if c != 0)
        return cover * np.exp(2j * np.pi * w_um * 1e-6 / lam)

    p0 = pupil(xx, yy)
    out = []
    for f in np.asarray(f_cpd, float):
        s = f * math.degrees(1) * lam                                   # shift, m
        vals = []
        for a in (np.arange(angles) + 0.5) * math.pi / angles:
            sx, sy = s * math.cos(a), s * math.sin(a)
            near = np.hypot(xx + sx, yy + sy) <= r + h
            p1 = np.zeros_like(p0)
            p1[near] = pupil(xx[near] + sx, yy[near] + sy)
            vals.append(abs(np.sum(p0 * np.conj(p1))) * h * h / (math.pi * r * r))
        out.append(np.mean(vals))
    return np.array(out)


def diffraction_limited_mtf(f_cpd, pupil_mm: float, wavelength_nm: float) -> np.ndarray:
    """The incoherent MTF of an aberration-free circular pupil at ``f_cpd`` (cycles/deg)."""
    v = np.minimum(np.asarray(f_cpd, float) * math.degrees(1)
                   * wavelength_nm * 1e-9 / (pupil_mm * 1e-3), 1.0)
    return 2 / math.pi * (np.arccos(v) - v * np.sqrt(1 - v * v))


@pytest.mark.parametrize("wavelength_nm", WAVELENGTHS_NM)
@pytest.mark.parametrize("pupil_mm", [3.0, 6.0])
def test_the_diffraction_limited_psf_is_the_airy_pattern_over_each_pixel(pupil_mm,
                                                                         wavelength_nm):
    ours = psf(np.zeros(1), pupil_mm, wavelength_nm, PITCH, SIZE, integrate=True,
               strehl=False)
    truth = airy_pixels(pupil_mm, wavelength_nm)
    img = ours["psf"][::-1]                                            # rows: theta_y up
    assert np.abs(img - truth).sum() < L1_BOUND
    assert ours["outside_window"] == pytest.approx(1 - truth.sum(), abs=0.003)
    # the rule is the pixel's area, not a point sample at its centre
    points = airy_pixels(pupil_mm, wavelength_nm, q=1)
    assert np.abs(img - points).sum() > 0.04


@pytest.mark.parametrize("wavelength_nm", WAVELENGTHS_NM)
@pytest.mark.parametrize("pupil_mm", [3.0, 6.0])
def test_the_diffraction_limited_mtf_is_the_closed_form(pupil_mm, wavelength_nm):
    """At `eyelab psf`'s frequencies: from the PSF's own (alias-free) grid, and from the
    output image where the image's Nyquist frequency leaves the frequency unaliased (f
    below 1 / pitch - D / lambda)."""
    f = np.asarray(MTF_FREQUENCIES_CPD, float)
    out = psf(np.zeros(1), pupil_mm, wavelength_nm, PITCH, SIZE, integrate=True,
              strehl=False, mtf_cpd=f)
    want = diffraction_limited_mtf(f, pupil_mm, wavelength_nm)
    np.testing.assert_allclose(out["mtf"], want, atol=MTF_BOUND)
    from_image = mtf(out["psf"], PITCH, f, integrated=True)
    clean = f < (1 / PITCH - pupil_mm * 1e-3 / (wavelength_nm * 1e-9)) * math.radians(1)
    np.testing.assert_allclose(from_image[clean], want[clean], atol=MTF_BOUND)


@pytest.fixture(scope="module")
def partial_pupil():
    """`eyelab psf` of a 4 mm pupil of a 6 mm measurement (0.05 um of coma, 0.1 um of
    spherical aberration), the eye chromatic: (image (3, 129, 129), report)."""
    from eyelab.jobs.psf import point_psf
    from eyelab.spec.load import parse_spec

    c = [0.0] * 13
    c[7], c[12] = 0.05, 0.1
    spec = parse_spec({"eye": {"pupil_diameter_mm": 4.0, "aberrations": {
        "coefficients_um": c, "pupil_mm": 6.0}}})
    return point_psf(spec, no_lens=True)


@pytest.mark.parametrize("channel", [0, 1, 2])
def test_a_partial_pupil_of_a_chromatic_measurement_is_the_fraunhofer_integral(
        partial_pupil, channel):
    img, rep = partial_pupil
    ch = rep["channels"][channel]
    assert ch["wavelength_nm"] == WAVELENGTHS_NM[channel]
    truth = mft_pixels(ch["coefficients_um"], 4.0, ch["wavelength_nm"])
    assert np.abs(img[channel][::-1] - truth).sum() < L1_BOUND


@pytest.mark.parametrize("channel", [0, 1, 2])
def test_a_partial_pupils_mtf_is_the_pupils_autocorrelation(partial_pupil, channel):
    """The MTF `eyelab psf` reports (from its image) and the PSF's own (``mtf_cpd``)
    against the autocorrelation of the pupil function: the chromatic defocus at 656 and
    486 nm makes the low frequencies steep (0.64 at 5 c/deg)."""
    _, rep = partial_pupil
    ch = rep["channels"][channel]
    f = np.asarray(MTF_FREQUENCIES_CPD, float)
    want = autocorrelation_mtf(ch["coefficients_um"], 4.0, ch["wavelength_nm"], f)
    reported = np.array([ch["mtf"][str(v)] for v in MTF_FREQUENCIES_CPD], float)
    np.testing.assert_allclose(reported, want, atol=MTF_BOUND)
    own = psf(np.asarray(ch["coefficients_um"]), 4.0, ch["wavelength_nm"], PITCH, SIZE,
              integrate=True, strehl=False, mtf_cpd=f)["mtf"]
    np.testing.assert_allclose(own, want, atol=MTF_BOUND)
