"""The eye's wave-optics PSF (eyelab/optics/eye/psf.py) and its Zernike bookkeeping
(eyelab/optics/eye/zernike.py) against independent truths: the Fraunhofer integral of the same
pupil function evaluated directly (the standard's closed-form Zernike polynomials, an
anti-aliased aperture, an explicit sum instead of an FFT), the Airy
pattern's first zero, Maréchal's approximation, Thibos et al.'s refraction formulas both
ways, and Schwiegerling's pupil-scaling closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eyelab.optics.eye import zernike as zk
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.psf import psf

LAM_NM, PUPIL_MM = 555.0, 3.0
LAM, D = LAM_NM * 1e-9, PUPIL_MM * 1e-3

CASES = [[(4, 0, 0.10)], [(3, 1, 0.10)], [(3, -1, 0.08)], [(2, 0, 0.15), (4, 0, 0.08)],
         [(2, 0, 0.10), (4, 0, 0.08), (3, 1, 0.07)], [(3, 3, 0.10), (2, -2, 0.05)],
         [(5, 1, 0.05), (6, 0, 0.04), (4, -2, 0.06)]]


def _coefficients(terms, count=28):
    c = np.zeros(count)
    for n, m, v in terms:
        c[zk.j_from_nm(n, m)] = v
    return c


#: The Zernike polynomials of CASES in closed form, as ANSI Z80.28-2017 (Table 1) and Thibos
#: et al. 2002 print them: (n, m) -> Z(rho, theta), unit-RMS over the unit disc, m > 0 the
#: cosines and m < 0 the sines of m theta, theta counter-clockwise from +x.
ANSI_TABLE = {
    (2, -2): lambda r, t: math.sqrt(6) * r**2 * np.sin(2 * t),
    (2, 0): lambda r, t: math.sqrt(3) * (2 * r**2 - 1),
    (3, -1): lambda r, t: math.sqrt(8) * (3 * r**3 - 2 * r) * np.sin(t),
    (3, 1): lambda r, t: math.sqrt(8) * (3 * r**3 - 2 * r) * np.cos(t),
    (3, 3): lambda r, t: math.sqrt(8) * r**3 * np.cos(3 * t),
    (4, -2): lambda r, t: math.sqrt(10) * (4 * r**4 - 3 * r**2) * np.sin(2 * t),
    (4, 0): lambda r, t: math.sqrt(5) * (6 * r**4 - 6 * r**2 + 1),
    (5, 1): lambda r, t: math.sqrt(12) * (10 * r**5 - 12 * r**3 + 3 * r) * np.cos(t),
    (6, 0): lambda r, t: math.sqrt(7) * (20 * r**6 - 30 * r**4 + 12 * r**2 - 1),
}


def _fraunhofer_psf(terms, pitch, n, samples=512, supersample=8):
    """The truth: the Fraunhofer integral of the pupil function, evaluated directly.

    The pupil (a square of side 1.02 D, ``samples`` cells a side) carries the aperture's
    area fraction per cell (``supersample``^2 sub-cells: its edge anti-aliased) and the
    phase 2 pi W / lambda of the ANSI closed forms at the cell centres; the field at the
    image angles (u, v) = (i, j) ``pitch``, i, j = -(n - 1)/2 ... (n - 1)/2, is the
    explicit sum over the cells of E exp(-2 pi i (x u + y v) / lambda) (two matrix
    products: no FFT, no padding, no resampling). Returns (n, n) intensity, row 0 at
    v = -(n - 1)/2 pitch (y up), x along the columns."""
    side = 1.02 * D
    cell = side / samples
    x = (np.arange(samples) + 0.5) * cell - side / 2
    sub = (np.arange(supersample) + 0.5) / supersample * cell - cell / 2
    xs = (x[:, None] + sub[None, :]).ravel()
    inside = (xs[None, :] ** 2 + xs[:, None] ** 2) <= (D / 2) ** 2
    area = inside.reshape(samples, supersample, samples, supersample).mean((1, 3))
    yy, xx = np.meshgrid(x, x, indexing="ij")
    rho, theta = np.hypot(xx, yy) / (D / 2), np.arctan2(yy, xx)
    w_um = sum(v * ANSI_TABLE[(nn, m)](rho, theta) for nn, m, v in terms)
    field = area * np.exp(2j * np.pi * w_um * 1e-6 / LAM)
    u = (np.arange(n) - (n - 1) / 2) * pitch
    kernel = np.exp(-2j * np.pi * np.outer(u, x) / LAM)          # (n, samples)
    amplitude = kernel @ field @ kernel.T                         # rows: v, columns: u
    return np.abs(amplitude) ** 2


@pytest.mark.parametrize("terms", CASES)
def test_the_psf_equals_the_fraunhofer_integral_of_the_same_pupil_function(terms):
    """L1 difference of the normalised PSFs over +-12 lambda/D (at lambda / 4D a pixel) on
    one grid, against the direct Fraunhofer sum of :func:`_fraunhofer_psf` with the
    standard's closed-form polynomials (not eyelab's Zernike code)."""
    pitch, n = LAM / (4 * D), 97
    theirs = _fraunhofer_psf(terms, pitch, n)
    ours = psf(_coefficients(terms), PUPIL_MM, LAM_NM, pitch, n)["psf"][::-1]   # rows: y up
    theirs, ours = theirs / theirs.sum(), ours / ours.sum()
    assert np.abs(ours - theirs).sum() < 0.01
    # the truth is not blind to a mirrored pattern: coma's flare has a side
    if any(m != 0 for _, m, _ in terms):
        assert np.abs(ours[::-1, ::-1] - theirs).sum() > 0.05


def test_a_diffraction_limited_eye_shows_the_airy_pattern():
    """First zero at 1.22 lambda / D within 1 % (parabolic refinement of the minimum on a
    lambda / 20D grid), and Strehl 1."""
    pitch = LAM / (20 * D)
    r = psf(np.zeros(1), PUPIL_MM, LAM_NM, pitch, 61)
    row = r["psf"][30, 30:]
    i = int(np.argmin(row[15:35])) + 15
    a, b, c = row[i - 1], row[i], row[i + 1]
    zero = (i + 0.5 * (a - c) / (a - 2 * b + c)) * pitch
    assert zero / (LAM / D) == pytest.approx(1.2197, rel=0.01)
    assert r["strehl"] == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("j,rms_waves", [(12, 0.04), (7, 0.05), (24, 0.03)])
def test_the_strehl_ratio_of_a_small_aberration_is_marechals(j, rms_waves):
    c = np.zeros(28)
    c[j] = rms_waves * LAM_NM * 1e-3
    r = psf(c, PUPIL_MM, LAM_NM, LAM / (4 * D), 31)
    assert r["rms_um"] == pytest.approx(c[j])
    assert r["strehl"] == pytest.approx(math.exp(-(2 * math.pi * rms_waves) ** 2), rel=0.01)


@pytest.mark.parametrize("rx", ["-3.00 / -1.25 x 30", "+2.50 / -0.75 x 105", "-0.25 DS",
                                "+0.00 / -2.00 x 180", "-8.00 / -3.00 x 67"])
def test_the_rx_and_the_second_order_round_trip(rx):
    p = Prescription.parse(rx)
    c = zk.rx_to_second_order(p, 6.0, 0.012)
    back = zk.second_order_to_rx(*c, 6.0, 0.012)
    np.testing.assert_allclose(back.power_matrix(), p.power_matrix(), atol=1e-9)
    # the ocular refraction of Thibos et al.: M = -4 sqrt(3) c20 / r^2
    m_eye = zk.second_order_to_power_vector(*c, 6.0)[0]
    (fa, _), (fb, _) = p.principal_meridians()
    ka, kb = (f / (1 - 0.012 * f) for f in (fa, fb))
    assert m_eye == pytest.approx((ka + kb) / 2, abs=1e-12)


def test_a_smaller_pupil_keeps_defocus_dioptres_and_scales_spherical_aberration():
    """Schwiegerling 2002: pure defocus keeps its dioptres (c20' = c20 e^2); spherical
    aberration scales as c40' = c40 e^4 and leaks c20' = sqrt(15) c40 (e^4 - e^2) into
    the defocus; coma c31' = c31 e^3 with c11' = 2 sqrt(2) c31 (e^3 - e)."""
    e = 4.0 / 6.0
    c = np.zeros(15)
    c[4] = 0.7
    out = zk.rescale(c, 6.0, 4.0)
    assert zk.second_order_to_power_vector(out[4], 0, 0, 4.0)[0] == pytest.approx(
        zk.second_order_to_power_vector(c[4], 0, 0, 6.0)[0], abs=1e-12)
    c = np.zeros(15)
    c[12] = 0.3
    out = zk.rescale(c, 6.0, 4.0)
    assert out[12] == pytest.approx(0.3 * e ** 4, abs=1e-12)
    assert out[4] == pytest.approx(math.sqrt(15) * 0.3 * (e ** 4 - e ** 2), abs=1e-12)
    c = np.zeros(15)
    c[8] = 0.2
    out = zk.rescale(c, 6.0, 4.0)
    assert out[8] == pytest.approx(0.2 * e ** 3, abs=1e-12)
    assert out[2] == pytest.approx(2 * math.sqrt(2) * 0.2 * (e ** 3 - e), abs=1e-12)
    with pytest.raises(Exception, match="pupil_mm"):
        zk.rescale(c, 4.0, 6.0)


def test_the_mirror_to_the_wearers_frame_flips_the_odd_terms_in_x():
    rng = np.random.default_rng(3)
    c = rng.normal(size=28) * 0.1
    x, y = rng.uniform(-0.6, 0.6, (2, 50))
    np.testing.assert_allclose(zk.wavefront(zk.to_wearer(c), x, y), zk.wavefront(c, -x, y),
                               atol=1e-12)


def test_the_mtf_of_a_diffraction_limited_pupil_is_the_closed_form():
    """|OTF| of a circular pupil: (2/pi)(acos v - v sqrt(1 - v^2)), v = f / (D / lambda),
    within 0.01 from 5 to 60 c/deg; NaN beyond the grid's Nyquist frequency."""
    from eyelab.optics.eye.psf import ARCMIN, mtf

    r = psf(np.zeros(1), PUPIL_MM, LAM_NM, 0.25 * ARCMIN, 129)
    f = np.array([5.0, 10, 20, 30, 45, 60])
    v = f / (D / LAM * math.pi / 180)
    want = 2 / math.pi * (np.arccos(v) - v * np.sqrt(1 - v * v))
    np.testing.assert_allclose(mtf(r["psf"], r["pitch_rad"], f), want, atol=0.01)
    assert np.isnan(mtf(r["psf"], r["pitch_rad"], [200.0])[0])
