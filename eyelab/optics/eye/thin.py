"""The eye: Gullstrand-Helmholtz thin toric eye (Kakimoto et al. 2007, §4.4, Table 2).

The eye is a thin toric lens at the corneal vertex (the world origin) with the pupil in
its plane, vitreous of index ``n_vitreous`` behind it and the retina at ``retina_distance``.

Table 2 gives P_min = 58.64 D, z_r = 22.785 mm and n_2 = 1.336; but n_2 / z_r =
58.635 D, so taken literally the "standard" eye is 0.005 D myopic. eyelab keeps z_r and
n_2 and defines the emmetropic relaxed power as n_2 / z_r (58.6351 D): the default eye is
then exactly emmetropic, and every refractive error is a deviation from it.

Accommodation, Eq. 13: dP = clip(n_2/z_r - kbar - P_min, 0, dmax), kbar the mean curvature
of the wavefront arriving at the eye (n_1 = 1); it puts the circle of least confusion on
the retina.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eyelab.core.checks import check_in
from eyelab.core.errors import SpecError
from eyelab.optics.eye.prescription import Prescription

GH_RETINA_DISTANCE = 22.785e-3   # m, Table 2
GH_N_VITREOUS = 1.336            # Table 2
GH_P_MIN_PAPER = 58.64           # D, Table 2 as printed
GH_P_MIN = GH_N_VITREOUS / GH_RETINA_DISTANCE  # D, exactly emmetropic (see module doc)
GH_ACCOMMODATION = 11.93         # D, Table 2

#: Thibos, Ye, Zhang & Bradley 1992, "The chromatic eye: a new reduced-eye model of ocular
#: chromatic aberration in humans", Appl. Opt. 31:3594: the chromatic difference of
#: refraction R(lambda) = p - q / (lambda_um - c), q = 0.63346 D um, c = 0.21410 um. eyelab
#: uses only differences R(lambda) - R(reference), in which the constant p cancels (the
#: published p = 1.68524 puts R = 0 at c + q/p = 589.99 nm, not at the d line, where
#: R = -0.011 D). The same constants are in ISETCam's humanWaveDefocus (docs/SCIENCE.md §9b).
THIBOS_Q = 0.63346
THIBOS_C = 0.21410
#: The wavelength (nm) at which an eye's refraction (its Rx, far point, Eq. 13's
#: accommodation) is defined and which it focuses: the helium d line, where the lens
#: materials' n_d and the analysis default are defined (ISO 7944 allows d or e).
EYE_REFERENCE_NM = 587.56


def ocular_lca(wavelength_nm, reference_nm: float = EYE_REFERENCE_NM):
    """Chromatic difference of refraction of the eye (D): R(lambda) - R(reference), by
    Thibos et al. 1992 (see :data:`THIBOS_Q`). Negative = more myopic than at the
    reference (short wavelengths are refracted more). Valid 400-750 nm (the fitted range;
    the formula is evaluated on 300-1100 nm).

    >>> round(float(ocular_lca(486.13) - ocular_lca(656.27)), 3)   # F - C: about -0.9 D
    -0.896
    """
    wl = np.asarray(wavelength_nm, float)
    if np.any(~np.isfinite(wl)) or np.any((wl < 300) | (wl > 1100)):
        raise SpecError("wavelength_nm", f"must be in [300, 1100] nm, got {wavelength_nm!r}")
    return THIBOS_Q / (reference_nm * 1e-3 - THIBOS_C) - THIBOS_Q / (wl * 1e-3 - THIBOS_C)


#: Largest amplitude of accommodation eyelab takes, D: Hofstetter's maximum at age 0
#: (25 - 0.4 x 0).
MAX_ACCOMMODATION_D = 25.0
#: The eye's parameter ranges, by spec field, in the spec's units (D, deg, mm, years,
#: cd/m²): what the engine accepts, and what the spec's schema documents and checks.
LIMITS = {"eye.power_min_d": (40.0, 80.0), "eye.astigmatism_d": (0.0, 10.0),
          "eye.astigmatism_axis_deg": (-360.0, 360.0),
          "eye.accommodation_max_d": (0.0, MAX_ACCOMMODATION_D),
          "eye.retina_distance_mm": (15.0, 35.0), "eye.n_vitreous": (1.2, 1.6),
          "eye.pupil_diameter_mm": (0.5, 10.0), "eye.rotation_centre_mm": (5.0, 20.0),
          "eye.age": (0.0, 120.0), "eye.luminance_cd_m2": (0.0, 1e7)}
#: Hofstetter's formulas (docs/SCIENCE.md §3) as (a, b) in a - b x age.
AMPLITUDE_MODELS = {"min": (15.0, 0.25), "mean": (18.5, 0.3), "max": (25.0, 0.4)}


#: How eye.rx makes the eye: "refractive" (keeps the axial length) or "axial".
EYE_KINDS = ("refractive", "axial")


def hofstetter_amplitude(age, which: str = "mean"):
    """Amplitude of accommodation (D) by Hofstetter's formulas (docs/SCIENCE.md §3), >= 0.

    ``which``: "min" 15 - 0.25 age, "mean" 18.5 - 0.3 age, "max" 25 - 0.4 age.

    >>> hofstetter_amplitude(40)
    6.5
    """
    if not isinstance(which, str) or which not in AMPLITUDE_MODELS:
        raise SpecError("eye.amplitude_model", f"must be one of {sorted(AMPLITUDE_MODELS)}, "
                                               f"got {which!r}")
    a, b = AMPLITUDE_MODELS[which]
    return max(0.0, a - b * check_in("eye.age", age, LIMITS))


def watson_yellott_pupil(luminance, age=30.0, field_area_deg2=math.pi * 30.0**2, eyes=2):
    """Pupil diameter (mm), Watson & Yellott 2012, Eq. 21 (docs/SCIENCE.md §4).

    luminance : cd/m^2, > 0; age : years (formula fitted for 20-83; clamped to that);
    field_area_deg2 : adapting field area in deg^2 (default: a 60 deg diameter disc);
    eyes : 1 or 2.
    """
    lum = check_in("eye.luminance_cd_m2", luminance, LIMITS,
                      lo_open=True)
    if eyes not in (1, 2):
        raise SpecError("eye.eyes", f"must be 1 or 2, got {eyes!r}")
    y = min(max(check_in("eye.age", age, LIMITS), 20.0), 83.0)
    f = lum * field_area_deg2 * (0.1 if eyes == 1 else 1.0)
    p = (f / 846.0) ** 0.41
    d_sd = 7.75 - 5.75 * (p / (p + 2.0))
    return d_sd + (y - 28.58) * (0.02132 - 0.009562 * d_sd)


@dataclass(frozen=True)
class Eye:
    """Thin toric eye.

    Lengths are in metres and powers in dioptres here; the repr shows the ``[eye]`` spec
    keys (mm, D, degrees; :meth:`spec_keys`). :meth:`from_rx` makes the eye a spectacle
    prescription corrects, :meth:`for_age` one with an age's amplitude of accommodation.

    Parameters
    ----------
    power_min : float
        Mean relaxed power P_min (D), in [40, 80]. Default n_2/z_r (emmetropic).
    astigmatism : float
        A = P1_min - P2_min >= 0 (D), in [0, 10] (Eq. 14).
    astigmatism_axis_deg : float
        omega_1^(e): direction of the stronger meridian P1 (the direction along which the eye
        has power P1), degrees counter-clockwise from the wearer's right, seen from behind
        the wearer.
    accommodation_max : float
        Delta_max (D), in [0, 16].
    retina_distance : float
        z_r (m), cornea to retina, in [0.015, 0.035].
    n_vitreous : float
        n_2, in [1.2, 1.6].
    pupil_diameter : float
        m, in [0.5 mm, 10 mm].
    rotation_centre : float
        Distance (m) of the centre of rotation behind the cornea (docs/SCIENCE.md §2:
        13-14 mm).
    aberrations : Aberrations or None
        The eye's higher-order wave aberrations (:mod:`eyelab.optics.eye.aberrations`): with
        them renders show those and the pupil's diffraction; None (the default): the
        geometric thin toric eye alone.
    chromatic : bool
        The eye's own longitudinal chromatic aberration (:func:`ocular_lca`): at a
        wavelength other than :data:`EYE_REFERENCE_NM` every meridian's power is higher by
        -R(lambda) + R(reference) (about +0.63 D at 486 nm, -0.26 D at 656 nm). Powers,
        refraction and accommodation are defined at the reference wavelength.

    Examples
    --------
    >>> import eyelab
    >>> eye = eyelab.Eye.from_rx("-3.00 / -1.00 x 180")        # worn at 12 mm
    >>> [round(k, 2) for k in eye.refraction()]                # D at the cornea
    [-3.82, -2.9]
    >>> round(eye.astigmatism, 3), eye.astigmatism_axis_deg, eye.pupil_diameter
    (0.921, 90.0, 0.004)
    >>> eyelab.Eye.for_age(45).accommodation_max
    5.0
    """

    power_min: float = GH_P_MIN
    astigmatism: float = 0.0
    astigmatism_axis_deg: float = 0.0
    accommodation_max: float = GH_ACCOMMODATION
    retina_distance: float = GH_RETINA_DISTANCE
    n_vitreous: float = GH_N_VITREOUS
    pupil_diameter: float = 4.0e-3
    rotation_centre: float = 13.5e-3
    chromatic: bool = True
    aberrations: object = None

    def spec_keys(self) -> dict:
        """The ``[eye]`` spec keys that make this eye, in the spec's units (D, degrees, mm;
        its aberrations apart): how reports write an eye, and what its repr shows."""
        return {"power_min_d": self.power_min, "astigmatism_d": self.astigmatism,
                "astigmatism_axis_deg": self.astigmatism_axis_deg,
                "accommodation_max_d": self.accommodation_max,
                "pupil_diameter_mm": self.pupil_diameter * 1e3,
                "retina_distance_mm": self.retina_distance * 1e3,
                "n_vitreous": self.n_vitreous,
                "rotation_centre_mm": self.rotation_centre * 1e3, "chromatic": self.chromatic}

    def __repr__(self) -> str:
        from eyelab.core.reprs import spec_repr

        keys = self.spec_keys()
        if self.aberrations is not None:
            keys["aberrations"] = f"{len(self.aberrations.coefficients_um)} Zernike terms"
        return spec_repr("Eye", keys)

    def __post_init__(self):
        check_in("eye.power_min_d", self.power_min, LIMITS)
        check_in("eye.astigmatism_d", self.astigmatism, LIMITS)
        check_in("eye.astigmatism_axis_deg", self.astigmatism_axis_deg, LIMITS)
        check_in("eye.accommodation_max_d", self.accommodation_max, LIMITS)
        check_in("eye.retina_distance_mm", self.retina_distance * 1e3, LIMITS)
        check_in("eye.n_vitreous", self.n_vitreous, LIMITS)
        check_in("eye.pupil_diameter_mm", self.pupil_diameter * 1e3, LIMITS)
        check_in("eye.rotation_centre_mm", self.rotation_centre * 1e3, LIMITS)
        if not isinstance(self.chromatic, bool):
            raise SpecError("eye.chromatic", f"must be true or false, got {self.chromatic!r}")
        if self.aberrations is not None:
            from eyelab.optics.eye.aberrations import Aberrations

            if not isinstance(self.aberrations, Aberrations):
                raise SpecError("eye.aberrations", "must be an Aberrations or None")
            if self.pupil_diameter * 1e3 > self.aberrations.pupil_mm + 1e-9:
                raise SpecError("eye.pupil_diameter_mm", f"{self.pupil_diameter * 1e3:g} mm "
                                f"exceeds the {self.aberrations.pupil_mm:g} mm the aberrations "
                                f"were measured over (eye.aberrations.pupil_mm): a wavefront "
                                f"is not known beyond its pupil")

    # ---------------------------------------------------------------- builders
    @classmethod
    def from_rx(cls, rx: Prescription | str, *, vertex_distance: float = 0.012,
                kind: str = "refractive", **kwargs) -> Eye:
        """The eye whose far point is corrected by ``rx`` (a :class:`Prescription` or its
        clinical string, e.g. ``"-3.00 / -1.00 x 180"``) worn at ``vertex_distance`` (m).

        Per principal meridian the ocular refraction is K = F / (1 - d F) (docs/SCIENCE.md
        §2) and the eye's relaxed power in that meridian is n_2/z_r - K.
        ``kind="refractive"`` keeps z_r (Table 3: P_min differs); ``kind="axial"`` keeps
        P_min = 58.635 D and changes z_r for the spherical-equivalent error (Table 3); the
        cylinder is refractive either way.
        The add is a lens feature and does not change the eye.
        """
        if not isinstance(kind, str) or kind not in EYE_KINDS:
            raise SpecError("eye.kind", f"must be 'refractive' or 'axial', got {kind!r}")
        if isinstance(rx, str):
            rx = Prescription.parse(rx)
        if not isinstance(rx, Prescription):
            raise TypeError(f"rx must be a Prescription or a prescription string such as "
                            f"'-3.00 / -1.00 x 180', got {type(rx).__name__} {rx!r}"[:200])
        d = vertex_distance
        (f_a, dir_a), (f_b, _) = rx.principal_meridians()
        k_a, k_b = f_a / (1 - d * f_a), f_b / (1 - d * f_b)
        z_r = kwargs.pop("retina_distance", GH_RETINA_DISTANCE)
        n2 = kwargs.get("n_vitreous", GH_N_VITREOUS)
        k_mean = 0.5 * (k_a + k_b)
        if kind == "axial":
            z_r = n2 / (n2 / z_r + k_mean)
        p_a = n2 / z_r - k_a     # eye power along the cylinder axis direction
        p_b = n2 / z_r - k_b     # along the perpendicular direction
        p_mean = 0.5 * (p_a + p_b)
        if p_a >= p_b:
            astig, ax = p_a - p_b, dir_a
        else:
            astig, ax = p_b - p_a, dir_a + math.pi / 2
        return cls(power_min=p_mean, astigmatism=astig,
                   astigmatism_axis_deg=math.degrees(ax) % 180.0, retina_distance=z_r, **kwargs)

    @classmethod
    def for_age(cls, age: float, *, amplitude_model: str = "mean", **kwargs) -> Eye:
        """An eye with Delta_max from Hofstetter's formula for ``age`` (years)."""
        return cls(accommodation_max=hofstetter_amplitude(age, amplitude_model), **kwargs)

    # --------------------------------------------------------------- derived
    @property
    def emmetropic_power(self) -> float:
        """The relaxed power (D) that focuses infinity on the retina, n_2 / z_r."""
        return self.n_vitreous / self.retina_distance

    def power_shift(self, wavelength_nm=EYE_REFERENCE_NM) -> float:
        """Extra power (D) of every meridian at ``wavelength_nm`` from the eye's chromatic
        aberration: -:func:`ocular_lca`; 0 at the reference wavelength or when the eye is
        not ``chromatic``."""
        if not self.chromatic or wavelength_nm == EYE_REFERENCE_NM:
            return 0.0
        return -float(ocular_lca(wavelength_nm))

    def principal_powers(self, accommodation=0.0, wavelength_nm=EYE_REFERENCE_NM):
        """(P1, P2) (D), Eq. 14-15, at ``wavelength_nm`` (:meth:`power_shift`)."""
        base = self.power_min + self.power_shift(wavelength_nm) + accommodation
        return base + self.astigmatism / 2, base - self.astigmatism / 2

    def power_matrix(self, accommodation, wavelength_nm=EYE_REFERENCE_NM):
        """Eye power matrix (pxx, pxy, pyy) in the eye-lens (x, y) frame (Eq. 3 with
        omega = -omega_1^(e) applied to P1, P2) at ``wavelength_nm``, each broadcast like
        ``accommodation``."""
        acc = np.asarray(accommodation, float)
        w = math.radians(self.astigmatism_axis_deg)
        c, s = math.cos(w), math.sin(w)
        p1, p2 = self.principal_powers(acc, wavelength_nm)
        return (p1 * c * c + p2 * s * s, (p1 - p2) * c * s, p1 * s * s + p2 * c * c)

    def accommodation_for(self, mean_curvature):
        """Eq. 13: best accommodation (D) for a wave of mean curvature ``mean_curvature`` (1/m)
        arriving at the eye."""
        want = self.emmetropic_power - np.asarray(mean_curvature, float) - self.power_min
        return np.clip(want, 0.0, self.accommodation_max)

    def refraction(self):
        """Ocular refraction per principal meridian (D at the cornea): the far-point
        vergence n_2/z_r - P_i for the meridians of P1 and P2 (negative for myopia)."""
        p1, p2 = self.principal_powers()
        return self.emmetropic_power - p1, self.emmetropic_power - p2

    def reduced(self) -> ReducedEye:
        """Fons et al. 2023's reduced-eye description of the same eye (§4 of that paper)."""
        k1, k2 = self.refraction()
        return ReducedEye(retina_distance=self.retina_distance, n_vitreous=self.n_vitreous,
                          power_min=self.principal_powers(), far_vergence=(k1, k2),
                          amplitude=self.accommodation_max, pupil_diameter=self.pupil_diameter)


def _dist(vergence):
    """Distance (m) in front of the cornea of a point of vergence V (D) there: -1/V; inf at
    V = 0. Positive = a real point in front of the eye, negative = virtual, behind it."""
    return math.inf if vergence == 0 else -1.0 / vergence


@dataclass(frozen=True)
class ReducedEye:
    """Fons et al. 2023's description: lens plane A, retina plane C at d_i, focus plane P
    limited to the interval between the far point (FP) and the near point (NP).

    With the eye's relaxed powers P_i and the emmetropic power P_e = n_2/d_i, the far-point
    vergence per meridian is FV_i = P_e - P_i (Fons' dP with the sign that makes myopia
    negative) and the near-point vergence NV_i = FV_i - AA. Points at vergence V in
    [NV_i, FV_i] can be focused in that meridian. Fons' astigmatism construction uses the
    meridian of least error for the focus plane and the other at its own far point.
    """

    retina_distance: float
    n_vitreous: float
    power_min: tuple
    far_vergence: tuple
    amplitude: float
    pupil_diameter: float

    @property
    def far_point(self) -> tuple:
        """Far-point distances (m, in front of the eye; negative = virtual) per meridian;
        inf for an emmetrope."""
        return tuple(_dist(v) for v in self.far_vergence)

    @property
    def near_point(self) -> tuple:
        return tuple(_dist(v - self.amplitude) for v in self.far_vergence)

    def in_focus_range(self, distance):
        """True where an object at ``distance`` (m, > 0, in front) can be focused in the
        mean meridian."""
        v = -1.0 / np.asarray(distance, float)
        fv = 0.5 * sum(self.far_vergence)
        return (v <= fv + 1e-12) & (v >= fv - self.amplitude - 1e-12)
