"""Zernike wave aberrations of the eye, as aberrometers report them.

Conventions (ANSI Z80.28 / the OSA standard: L. N. Thibos, R. A. Applegate,
J. T. Schwiegerling & R. Webb, "Standards for reporting the optical aberrations of eyes",
*J. Refract. Surg.* 18:S652 (2002)):

* single index j = (n (n + 2) + m) / 2 from j = 0 (piston); Z_n^m normalised to unit RMS
  over the unit disc: N_n^m R_n^|m|(rho) cos(m theta) for m >= 0, sin(|m| theta) for
  m < 0, N = sqrt(2 (n + 1) / (1 + delta_m0));
* coefficients c_n^m in micrometres at a stated pupil diameter; W positive where the
  wavefront leads the reference sphere (a myope's c_2^0 > 0);
* the standard's axes: x horizontal, positive to the examiner's right (the patient's
  left) for both eyes, y up, theta counter-clockwise as the examiner sees it — the sense
  of the TABO cylinder axis. eyelab's eye works seen from behind, x to the wearer's right
  (:mod:`eyelab.optics.eye.thin`): :func:`to_wearer` mirrors x (Z_n^m(-x, y) = s Z_n^m(x, y),
  s = (-1)^m for m >= 0, -(-1)^|m| for m < 0).

The second order and the refraction are one thing (L. N. Thibos, X. Hong, A. Bradley &
R. A. Applegate, "Accuracy and precision of objective refraction from wavefront
aberrations", *J. Vis.* 4:329 (2004), the "Zernike defocus" method): M = -4 sqrt(3)
c_2^0 / r^2, J0 = -2 sqrt(6) c_2^2 / r^2, J45 = -2 sqrt(6) c_2^-2 / r^2 (D, c in um, r
the pupil radius in mm), the refraction at the eye (the pupil plane), as power vectors in
the TABO frame (:func:`rx_to_second_order`, :func:`second_order_to_rx`).

A smaller pupil (J. Schwiegerling, "Scaling Zernike expansion coefficients to different
pupil sizes", *J. Opt. Soc. Am. A* 19:1937 (2002)): the wavefront inside the smaller
pupil is the same function, re-expanded — computed here exactly by evaluating the
original expansion on the smaller disc and projecting on the Zernike basis there
(:func:`rescale`; Schwiegerling's closed form gives the same numbers: tested against his
pure-defocus and spherical-aberration cases).
"""

from __future__ import annotations

import math

import numpy as np

from eyelab.core.errors import SpecError

#: Highest radial order eyelab takes (aberrometers report to 6-10).
MAX_ORDER = 10


def nm_from_j(j: int) -> tuple:
    """(n, m) of the OSA/ANSI single index j >= 0."""
    n = int(math.ceil((-3 + math.sqrt(9 + 8 * j)) / 2))
    m = 2 * j - n * (n + 2)
    return n, m


def j_from_nm(n: int, m: int) -> int:
    """The OSA/ANSI single index of Z_n^m (|m| <= n, n - |m| even)."""
    if abs(m) > n or (n - m) % 2:
        raise SpecError("eye.aberrations", f"no Zernike term Z({n},{m}): need |m| <= n and "
                                           f"n - m even")
    return (n * (n + 2) + m) // 2


def radial(n: int, m: int, rho) -> np.ndarray:
    """R_n^|m|(rho), the Zernike radial polynomial."""
    m = abs(m)
    rho = np.asarray(rho, float)
    out = np.zeros_like(rho)
    for s in range((n - m) // 2 + 1):
        c = (-1) ** s * math.factorial(n - s) / (
            math.factorial(s) * math.factorial((n + m) // 2 - s)
            * math.factorial((n - m) // 2 - s))
        out = out + c * rho ** (n - 2 * s)
    return out


def zernike(n: int, m: int, rho, theta) -> np.ndarray:
    """Z_n^m(rho, theta), unit RMS over the unit disc (OSA normalisation)."""
    norm = math.sqrt(2 * (n + 1) / (1 + (m == 0)))
    ang = np.cos(m * np.asarray(theta)) if m >= 0 else np.sin(-m * np.asarray(theta))
    return norm * radial(n, m, rho) * ang


def wavefront(coefficients, x, y) -> np.ndarray:
    """W (same units as ``coefficients``, OSA order from j = 0) at normalised pupil
    points (x, y) (the unit disc; NaN-free, evaluated anywhere)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    rho, th = np.hypot(x, y), np.arctan2(y, x)
    w = np.zeros(np.broadcast(x, y).shape)
    for j, c in enumerate(np.asarray(coefficients, float)):
        if c != 0.0:
            w = w + c * zernike(*nm_from_j(j), rho, th)
    return w


def mirror_signs(count: int) -> np.ndarray:
    """s_j with Z_j(-x, y) = s_j Z_j(x, y) for j < count."""
    out = np.empty(count)
    for j in range(count):
        n, m = nm_from_j(j)
        out[j] = (-1) ** m if m >= 0 else -((-1) ** -m)
    return out


def to_wearer(coefficients) -> np.ndarray:
    """OSA-frame coefficients (x to the examiner's right) -> eyelab's wearer frame (x to
    the wearer's right, seen from behind): the same wavefront, mirrored in x."""
    c = np.asarray(coefficients, float)
    return c * mirror_signs(len(c))


def rms(coefficients, *, from_order: int = 0) -> float:
    """RMS of the wavefront over the pupil (the orthonormal basis: the root sum of squares
    of the coefficients of order >= ``from_order``, piston excluded)."""
    c = np.asarray(coefficients, float)
    keep = [j for j in range(len(c)) if j > 0 and nm_from_j(j)[0] >= from_order]
    return float(np.sqrt(np.sum(c[keep] ** 2))) if keep else 0.0


# ------------------------------------------------------------------ the second order
def second_order_to_power_vector(c20: float, c22: float, c2m2: float, pupil_mm: float) -> tuple:
    """(M, J0, J45) (D, at the eye, TABO frame) from the second-order coefficients (um) at
    a pupil of diameter ``pupil_mm`` (Thibos et al. 2004)."""
    r2 = (pupil_mm / 2) ** 2
    return (-4 * math.sqrt(3) * c20 / r2, -2 * math.sqrt(6) * c22 / r2,
            -2 * math.sqrt(6) * c2m2 / r2)


def power_vector_to_second_order(m: float, j0: float, j45: float, pupil_mm: float) -> tuple:
    """(c_2^0, c_2^2, c_2^-2) (um) for the refraction (M, J0, J45) at the eye: the exact
    inverse of :func:`second_order_to_power_vector`."""
    r2 = (pupil_mm / 2) ** 2
    return (-m * r2 / (4 * math.sqrt(3)), -j0 * r2 / (2 * math.sqrt(6)),
            -j45 * r2 / (2 * math.sqrt(6)))


def second_order_to_rx(c20: float, c22: float, c2m2: float, pupil_mm: float,
                       vertex_distance: float):
    """The spectacle prescription at ``vertex_distance`` (m) for the eye whose ocular
    refraction the second order gives: per principal meridian F = K / (1 + d K), the
    inverse of :meth:`eyelab.optics.eye.thin.Eye.from_rx`'s K = F / (1 - d F)."""
    from eyelab.optics.eye.prescription import Prescription

    eye_rx = Prescription.from_power_vector(*second_order_to_power_vector(c20, c22, c2m2,
                                                                         pupil_mm))
    (k_a, _), (k_b, _) = eye_rx.principal_meridians()
    f_a, f_b = (float(k / (1 + vertex_distance * k)) for k in (k_a, k_b))
    return Prescription(f_a, f_b - f_a, eye_rx.axis)


def rx_to_second_order(rx, pupil_mm: float, vertex_distance: float) -> tuple:
    """(c_2^0, c_2^2, c_2^-2) (um) of the eye that spectacle ``rx`` at ``vertex_distance``
    (m) corrects: its ocular refraction K = F / (1 - d F) per meridian, as power vectors."""
    from eyelab.optics.eye.prescription import Prescription

    (f_a, _), (f_b, _) = rx.principal_meridians()
    k_a, k_b = (f / (1 - vertex_distance * f) for f in (f_a, f_b))
    eye_rx = Prescription(k_a, k_b - k_a, rx.axis)
    return power_vector_to_second_order(*eye_rx.power_vector(), pupil_mm)


# ------------------------------------------------------------------ pupil scaling
def rescale(coefficients, from_mm: float, to_mm: float, *, samples: int = 96) -> np.ndarray:
    """The coefficients (OSA order) of the same wavefront over a smaller concentric pupil
    of ``to_mm`` (<= ``from_mm``): the original expansion evaluated on the smaller disc
    (radius ratio e = to / from) and projected on the Zernike basis there by Gauss
    quadrature (exact for these polynomials: Gauss-Legendre in rho^2 with ``samples``
    nodes, uniform in theta), so c' = sum_j c_j <Z_j(e rho, theta), Z_k> / pi."""
    c = np.asarray(coefficients, float)
    if not 0 < to_mm <= from_mm * (1 + 1e-12):
        raise SpecError("eye.aberrations.pupil_mm", f"the aberrations were measured over "
                        f"{from_mm:g} mm; the render's pupil ({to_mm:g} mm) must not be "
                        f"larger (a wavefront is not known beyond its pupil)")
    e = to_mm / from_mm
    t, wt = np.polynomial.legendre.leggauss(samples)
    rho = np.sqrt((t + 1) / 2)                       # Gauss-Legendre in u = rho^2
    th = np.linspace(0, 2 * np.pi, 2 * samples + 2, endpoint=False)
    r, a = np.meshgrid(rho, th, indexing="ij")
    # <f, g> = (1/pi) int f g rho drho dtheta = (1 / (2 N_theta)) sum_t sum_theta w_t f g
    weight = wt[:, None] / (2 * len(th))
    w = wavefront(c, e * r * np.cos(a), e * r * np.sin(a))
    return np.array([np.sum(w * zernike(*nm_from_j(k), r, a) * weight) for k in range(len(c))])
