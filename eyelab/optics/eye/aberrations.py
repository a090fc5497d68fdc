"""The eye's own higher-order aberrations, as measured by an aberrometer, and what the
renderers take from them.

An :class:`Aberrations` holds the measured Zernike expansion's orders n >= 3 (OSA/ANSI,
micrometres, at ``pupil_mm`` and ``wavelength_nm``; :mod:`eyelab.optics.eye.zernike`): the
second order is the eye's refraction (its Rx, Thibos et al. 2004), the first a prism
(no blur) and the piston nothing. Their optical path difference is taken as the same at
every wavelength (the higher orders change little across the visible; the defocus's
change with wavelength is the eye's chromatic model, :func:`eyelab.optics.eye.thin.ocular_lca`).
For a render's pupil (at most the measured one) the expansion is re-expanded over the
smaller disc (:func:`eyelab.optics.eye.zernike.rescale`): spherical aberration then also
leaks into the second order — the pupil-dependent refraction it causes — which stays in
the kernel, not in the Rx.

What the renderers use (eyelab/imaging/eyepsf.py):

* :meth:`Aberrations.kernel` — the wave-optics PSF of these aberrations and the pupil's
  diffraction, without the low-order blur (the raster renders that exactly and spatially
  varying, then convolves its image with this kernel per colour channel);
* :meth:`Aberrations.slopes` — grad W at pupil points (the reference renderer bends each
  pupil ray by it: geometric) with :func:`diffraction_kernel`, the diffraction-limited PSF
  of the pupil (wave).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from eyelab.core.errors import SpecError
from eyelab.optics.eye import zernike as zk
from eyelab.optics.eye.psf import max_slope, psf

#: The reporting wavelength of ANSI Z80.28 (nm): the default of ``wavelength_nm``.
REPORT_WAVELENGTH_NM = 555.0
#: Energy a kernel keeps inside its square (the rest is the far tails).
KERNEL_ENERGY = 0.995
#: The largest kernel a side (px).
MAX_KERNEL = 255


@dataclass(frozen=True)
class Aberrations:
    """The eye's higher-order wave aberration: ``coefficients_um`` (tuple, OSA/ANSI order
    from j = 0, the standard's frame: x to the examiner's right; orders < 3 zero),
    measured over ``pupil_mm`` at ``wavelength_nm``; ``stiles_crawford`` apodises the
    pupil (:data:`eyelab.optics.eye.psf.STILES_CRAWFORD_RHO`)."""

    coefficients_um: tuple
    pupil_mm: float
    wavelength_nm: float = REPORT_WAVELENGTH_NM
    stiles_crawford: bool = False

    def __post_init__(self):
        c = np.asarray(self.coefficients_um, float)
        if c.ndim != 1 or not np.all(np.isfinite(c)):
            raise SpecError("eye.aberrations.coefficients_um", "must be finite numbers")
        if len(c) > zk.j_from_nm(zk.MAX_ORDER, zk.MAX_ORDER) + 1:
            raise SpecError("eye.aberrations.coefficients_um", f"at most order "
                            f"{zk.MAX_ORDER} ({zk.j_from_nm(zk.MAX_ORDER, zk.MAX_ORDER) + 1} "
                            f"terms), got {len(c)}")
        if np.any(c[:6] != 0):
            raise SpecError("eye.aberrations.coefficients_um", "orders 0-2 belong to the "
                            "refraction (eye.rx), not to the higher orders")

    def wearer(self, pupil_mm: float) -> np.ndarray:
        """The coefficients (um) over a render pupil of ``pupil_mm`` (<= the measured one),
        in eyelab's wearer frame (x to the wearer's right)."""
        return _wearer(self.coefficients_um, self.pupil_mm, round(float(pupil_mm), 12)).copy()

    def rms_um(self, pupil_mm: float) -> float:
        """RMS wavefront error (um) of the measured higher orders as they read over
        ``pupil_mm``: from the second order up, so what they leak into defocus and
        astigmatism over a smaller pupil counts, and the tilt coma leaks into does not (it
        moves the image without blurring it) — the same rule as ``eyelab analyze``'s
        ``rms_um``."""
        return zk.rms(self.wearer(pupil_mm), from_order=2)

    def slopes(self, x_m, y_m, pupil_mm: float) -> tuple:
        """(dW/dx, dW/dy) (dimensionless) at pupil points (m, wearer frame) of a render
        pupil of ``pupil_mm``: central differences of the expansion (step 1e-6 of the
        radius; exact to ~1e-12 for these polynomials)."""
        c = self.wearer(pupil_mm)
        r = pupil_mm * 1e-3 / 2
        x, y = np.asarray(x_m, float) / r, np.asarray(y_m, float) / r
        h = 1e-6
        gx = (zk.wavefront(c, x + h, y) - zk.wavefront(c, x - h, y)) / (2 * h)
        gy = (zk.wavefront(c, x, y + h) - zk.wavefront(c, x, y - h)) / (2 * h)
        return gx * 1e-6 / r, gy * 1e-6 / r

    def kernel(self, wavelength_nm: float, pupil_mm: float, pitch_rad: float,
               *, waves: bool = True) -> np.ndarray:
        """The image-oriented PSF kernel (odd square, sums to 1) at ``pitch_rad`` per pixel:
        the higher orders over the render pupil and its diffraction (``waves``), or the
        diffraction alone (``waves=False``: the reference traces the higher orders)."""
        c = self.wearer(pupil_mm) if waves else np.zeros(1)
        return psf_kernel(c, pupil_mm, wavelength_nm, pitch_rad, self.stiles_crawford)


@functools.lru_cache(maxsize=64)
def _wearer(coefficients: tuple, measured_mm: float, pupil_mm: float) -> np.ndarray:
    """:meth:`Aberrations.wearer`, kept (the reference renderer asks for every ray block)."""
    c = np.asarray(coefficients, float)
    if abs(pupil_mm - measured_mm) > 1e-9:
        c = zk.rescale(c, measured_mm, pupil_mm)
    return zk.to_wearer(c)


def diffraction_kernel(pupil_mm: float, wavelength_nm: float, pitch_rad: float,
                       stiles_crawford: bool = False) -> np.ndarray:
    """The diffraction-limited PSF of the pupil as an image kernel (sums to 1)."""
    return psf_kernel(np.zeros(1), pupil_mm, wavelength_nm, pitch_rad, stiles_crawford)


def psf_kernel(c, pupil_mm, wavelength_nm, pitch_rad, stiles_crawford) -> np.ndarray:
    """A kernel (read-only, odd square, sums to 1) wide enough for :data:`KERNEL_ENERGY` of
    the PSF of ``c``: the geometric reach max |grad W| plus 3 Airy radii, grown until the
    energy is in (at most MAX_KERNEL). Kept between frames (the inspector's, a batch's)
    in a bounded cache keyed by the values."""
    c = tuple(float(v) for v in np.round(np.asarray(c, float), 12))
    return _psf_kernel(c, float(pupil_mm), float(wavelength_nm), float(pitch_rad),
                       bool(stiles_crawford))


@functools.lru_cache(maxsize=96)
def _psf_kernel(c: tuple, pupil_mm, wavelength_nm, pitch_rad, stiles_crawford):
    lam = wavelength_nm * 1e-9
    d = pupil_mm * 1e-3
    half = math.ceil((max_slope(c, d / 2) + 3 * 1.22 * lam / d) / pitch_rad) + 1
    while True:
        size = min(2 * half + 1, MAX_KERNEL)
        out = psf(c, pupil_mm, wavelength_nm, pitch_rad, size, stiles_crawford=stiles_crawford,
                  strehl=False)
        k = out["psf"]
        if k.sum() >= KERNEL_ENERGY or size == MAX_KERNEL:
            k = k / k.sum()
            k.flags.writeable = False
            return k
        half *= 2


def second_order(mxx: float, mxy: float, myy: float, pupil_mm: float) -> tuple:
    """(c_2^0, c_2^2, c_2^-2) (um, wearer frame) of the wave W = p^T M p / 2 (p in m over
    the pupil, M in D: the eye's power plus the arriving wave's curvature less n2 / z_r —
    0 when the point is in focus): c20 = R^2 (Mxx + Myy) / (8 sqrt 3), c22 = R^2 (Mxx -
    Myy) / (4 sqrt 6), c2-2 = R^2 Mxy / (2 sqrt 6), R the pupil radius (m), times 1e6 —
    for a sphere M = (Mxx + Myy) / 2 this is Thibos et al.'s c20 = -M_refraction r^2 /
    (4 sqrt 3) with M = -M_refraction."""
    r2 = (pupil_mm * 1e-3 / 2) ** 2 * 1e6
    return (r2 * (mxx + myy) / (8 * math.sqrt(3)), r2 * (mxx - myy) / (4 * math.sqrt(6)),
            r2 * mxy / (2 * math.sqrt(6)))


def point_power_matrix(eye, res, i: int, wavelength_nm: float) -> tuple:
    """(Mxx, Mxy, Myy) (D, the eye's (x, y) frame) of point ``i`` of a
    :class:`~eyelab.optics.chain.analysis.PointAnalysis`: M = P_eye(acc, lambda) + K -
    n2/z_r, the eye's power with the point's accommodation plus the arriving wave's
    curvature less the emmetropic power — the image's defocus and astigmatism (0 in focus;
    its mean > 0: the image lies before the retina, myopic)."""
    k11, k12, k22 = res.wave_eye.in_basis(res.eye_x)
    pxx, pxy, pyy = eye.power_matrix(float(res.accommodation[i]), wavelength_nm)
    e = eye.emmetropic_power
    return float(pxx + k11[i] - e), float(pxy + k12[i]), float(pyy + k22[i] - e)


def point_wave(eye, res, i: int, wavelength_nm: float) -> np.ndarray:
    """The eye's wave aberration (um, OSA order from j = 0, wearer frame, over its pupil)
    for point ``i`` of a :class:`~eyelab.optics.chain.analysis.PointAnalysis` traced at
    ``wavelength_nm``: the second order of M = P_eye(acc, lambda) + K - n2/z_r (the
    eye's power with the point's accommodation plus the arriving wave's curvature, in the
    eye's (x, y) frame: :func:`second_order`) and the higher orders of ``eye.aberrations``
    (none without them)."""
    pupil = eye.pupil_diameter * 1e3
    c20, c22, c2m2 = second_order(*point_power_matrix(eye, res, i, wavelength_nm), pupil)
    hoa = np.zeros(6) if eye.aberrations is None else eye.aberrations.wearer(pupil)
    out = np.zeros(max(len(hoa), 6))
    out[:len(hoa)] = hoa
    out[3] += c2m2
    out[4] += c20
    out[5] += c22
    return out


def point_strehl(eye, coefficients_um, wavelength_nm: float) -> float | None:
    """The Strehl ratio of the wave ``coefficients_um`` over the eye's pupil (sampled at
    Nyquist); None when its slope needs a larger FFT than the PSF allows."""
    pupil = eye.pupil_diameter * 1e3
    pitch = wavelength_nm * 1e-9 / (2 * pupil * 1e-3)
    st = eye.aberrations is not None and eye.aberrations.stiles_crawford
    try:
        return psf(coefficients_um, pupil, wavelength_nm, pitch, 3, stiles_crawford=st)["strehl"]
    except SpecError:
        return None
