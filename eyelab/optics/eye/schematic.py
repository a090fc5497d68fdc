"""A schematic eye of real surfaces: conicoid cornea and lens, dispersive media, the stop at
the lens, a curved retina (the data: :mod:`eyelab.optics.eye.models`).

Frame: the eye's own, in metres, light travelling along +z, the corneal vertex at the
origin, x and y as the thin eye's (the line of sight is the model's optical axis: the
models are centred, as Escudero-Sanz & Navarro 1999 analyse them). The world places it with
a rotation and the corneal vertex's position (:meth:`SchematicEye.placed`).

Paraxial optics (Gaussian, y-nu form, Smith "Modern Optical Engineering" §2.6): at a
surface of curvature c between indices n and n', nu' = nu - y (n' - n) c; over a thickness t
in index n', y' = y + t nu' / n'. The matrix M = [[A, B], [C, D]] from the corneal vertex
plane (in air) to a plane inside the eye maps (y, nu) there. The far point's vergence at the
cornea (the ocular refraction, D) is K = A/B with M taken to the retina; the entrance pupil
lies B/A behind the cornea with the stop's radius A times its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eyelab.core.checks import check_in
from eyelab.core.errors import SpecError
from eyelab.optics.eye.models import (
    MEDIA,
    NAVARRO_MAX_ACCOMMODATION_D,
    SCHEMATIC_MODELS,
    navarro_axial_length,
    navarro_geometry,
    navarro_index,
)
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import EYE_REFERENCE_NM
from eyelab.optics.eye.thin import LIMITS as THIN_LIMITS
from eyelab.optics.rays.surfaces import Asphere
from eyelab.optics.rays.trace import PlacedSurface

#: Axial lengths (mm) a schematic eye takes: the published eye's 23.92 mm +- about 20 D.
AXIAL_LENGTH_RANGE_MM = (16.0, 35.0)
#: The schematic eye's own ranges, by spec field (the others are the thin eye's
#: :data:`~eyelab.optics.eye.thin.LIMITS`).
LIMITS = {"eye.axial_length_mm": AXIAL_LENGTH_RANGE_MM}
#: Names of the surfaces, front to back (the retina last).
SURFACES = ("cornea_front", "cornea_back", "lens_front", "lens_back", "retina")


@dataclass(frozen=True)
class SchematicEye:
    """A schematic eye of real surfaces.

    Parameters
    ----------
    model : str
        One of :data:`~eyelab.optics.eye.models.SCHEMATIC_MODELS`.
    axial_length : float
        Cornea to retina (m); the published eye's by default (emmetropic within the model's
        own precision). Longer is more myopic (the vitreous takes the difference).
    accommodation_max : float
        Largest accommodation (D) of the model's formulas, in [0, 10].
    pupil_diameter : float
        The entrance pupil's diameter (m, what a clinician measures); the stop at the lens
        is smaller by the cornea's pupil magnification.
    rotation_centre : float
        Distance (m) of the centre of rotation behind the cornea.
    """

    model: str = "navarro"
    axial_length: float = navarro_axial_length() * 1e-3
    accommodation_max: float = NAVARRO_MAX_ACCOMMODATION_D
    pupil_diameter: float = 4.0e-3
    rotation_centre: float = 13.5e-3

    def __post_init__(self):
        if not isinstance(self.model, str) or self.model not in SCHEMATIC_MODELS:
            raise SpecError("eye.model", f"must be one of {['thin', *SCHEMATIC_MODELS]}, "
                                         f"got {self.model!r}")
        check_in("eye.axial_length_mm", self.axial_length * 1e3, LIMITS)
        if not (0.0 <= self.accommodation_max <= NAVARRO_MAX_ACCOMMODATION_D):
            raise SpecError("eye.accommodation_max_d", f"must be in [0, "
                            f"{NAVARRO_MAX_ACCOMMODATION_D:g}] D for the {self.model} eye "
                            f"(its formulas' range), got {self.accommodation_max!r}")
        check_in("eye.pupil_diameter_mm", self.pupil_diameter * 1e3, THIN_LIMITS)
        check_in("eye.rotation_centre_mm", self.rotation_centre * 1e3, THIN_LIMITS)

    #: The eye's media disperse (Navarro 1985): renders trace each colour at its own
    #: wavelength, as for a thin eye with ``chromatic = True``.
    chromatic = True
    #: Its aberrations are its surfaces' (traced), not a Zernike set.
    aberrations = None

    # ------------------------------------------------------------------ geometry
    def geometry(self, accommodation: float = 0.0) -> dict:
        """Radii, conics (mm) and thicknesses (mm) at ``accommodation`` (D), with the
        vertex position ``z_mm`` of every surface."""
        g = navarro_geometry(accommodation)
        z = [0.0, g["cornea_thickness"]]
        z.append(z[-1] + g["aqueous"])
        z.append(z[-1] + g["lens_thickness"])
        z.append(self.axial_length * 1e3)
        if z[4] - z[3] < 1.0:
            raise SpecError("eye.axial_length_mm", f"{z[4]:g} mm leaves the vitreous "
                            f"{z[4] - z[3]:.3f} mm: too short for the {self.model} eye")
        g["z_mm"] = tuple(z)
        return g

    def indices(self, wavelength_nm: float = EYE_REFERENCE_NM,
                accommodation: float = 0.0) -> tuple:
        """(air, cornea, aqueous, lens, vitreous) refractive indices."""
        return (1.0, *(float(navarro_index(m, wavelength_nm, accommodation)) for m in MEDIA))

    def surfaces(self, accommodation: float = 0.0) -> list:
        """[(Asphere, z_vertex (m))] front to back, the retina last (curvatures in 1/m)."""
        g = self.geometry(accommodation)
        return [(Asphere(1.0 / (g[name][0] * 1e-3), g[name][1]), g["z_mm"][i] * 1e-3)
                for i, name in enumerate(SURFACES)]

    def stop_z(self, accommodation: float = 0.0) -> float:
        """The stop's (lens front vertex's) distance behind the cornea (m)."""
        return self.geometry(accommodation)["z_mm"][2] * 1e-3

    # ------------------------------------------------------------------ paraxial
    def paraxial_matrix(self, accommodation: float = 0.0,
                        wavelength_nm: float = EYE_REFERENCE_NM, upto: int = 4) -> np.ndarray:
        """(2, 2) matrix from the corneal vertex plane (air) to the vertex plane of surface
        ``upto`` (4: the retina; 2: the stop), just before that surface refracts."""
        surf = self.surfaces(accommodation)
        n = self.indices(wavelength_nm, accommodation)
        m = np.eye(2)
        for i in range(upto):
            c = surf[i][0].curvature
            m = np.array([[1.0, 0.0], [-(n[i + 1] - n[i]) * c, 1.0]]) @ m
            t = surf[i + 1][1] - surf[i][1]
            m = np.array([[1.0, t / n[i + 1]], [0.0, 1.0]]) @ m
        return m

    def refraction(self, accommodation: float = 0.0,
                   wavelength_nm: float = EYE_REFERENCE_NM) -> float:
        """Paraxial ocular refraction (D at the corneal vertex): the far point's vergence,
        negative for a myope."""
        (a, b), _ = self.paraxial_matrix(accommodation, wavelength_nm)
        return a / b

    def power(self, accommodation: float = 0.0,
              wavelength_nm: float = EYE_REFERENCE_NM) -> float:
        """Equivalent power (D): -C of the matrix from the cornea to behind the lens."""
        m = self.paraxial_matrix(accommodation, wavelength_nm, upto=4)
        # the transfer to the retina does not change C
        return -m[1, 0]

    def entrance_pupil(self, accommodation: float = 0.0,
                       wavelength_nm: float = EYE_REFERENCE_NM) -> tuple:
        """(distance of the entrance pupil behind the cornea (m), stop radius / entrance
        pupil radius): the paraxial image of the stop through the cornea."""
        (a, b), _ = self.paraxial_matrix(accommodation, wavelength_nm, upto=2)
        return b / a, a

    def stop_radius(self, accommodation: float = 0.0,
                    wavelength_nm: float = EYE_REFERENCE_NM) -> float:
        """The stop's radius (m) that gives the entrance pupil of ``pupil_diameter``."""
        return 0.5 * self.pupil_diameter * self.entrance_pupil(accommodation,
                                                               wavelength_nm)[1]

    def accommodation_for(self, vergence, wavelength_nm: float = EYE_REFERENCE_NM):
        """The accommodation (D, the model's parameter, in [0, accommodation_max]) whose
        paraxial refraction equals ``vergence`` (D at the cornea: the wave the eye wants to
        focus), clipped at the ends; shaped like ``vergence``."""
        v = np.asarray(vergence, float)
        out = np.empty(v.shape)
        flat = v.ravel()
        res = out.ravel()
        cache = {}
        for i, target in enumerate(flat):
            key = float(target)
            if key not in cache:
                cache[key] = self._solve_accommodation(key, wavelength_nm)
            res[i] = cache[key]
        return out if out.shape else float(out)

    def _solve_accommodation(self, target: float, wavelength_nm: float) -> float:
        if not math.isfinite(target):
            return 0.0
        f = lambda a: self.refraction(a, wavelength_nm) - target  # noqa: E731
        lo, hi = 0.0, self.accommodation_max
        if f(lo) <= 0.0:
            return lo
        if f(hi) >= 0.0:
            return hi
        for _ in range(200):          # bisection on a monotone function, to 1e-13 D
            mid = 0.5 * (lo + hi)
            if f(mid) > 0.0:
                lo = mid
            else:
                hi = mid
            if hi - lo < 1e-13:
                break
        return 0.5 * (lo + hi)

    # ------------------------------------------------------------------ building
    @classmethod
    def from_rx(cls, rx: Prescription | str, *, vertex_distance: float = 0.012,
                wavelength_nm: float = EYE_REFERENCE_NM, **kwargs) -> SchematicEye:
        """The eye whose paraxial far point is corrected by the spherical ``rx`` worn at
        ``vertex_distance`` (m): axial ametropia, the vitreous lengthened or shortened
        (Atchison 2006: myopia is mostly axial). K = F / (1 - d F) at the cornea."""
        if isinstance(rx, str):
            rx = Prescription.parse(rx)
        if abs(rx.cylinder) > 1e-12:
            raise SpecError("eye.rx", "a schematic eye's cornea and lens are rotationally "
                                      "symmetric: its rx takes no cylinder")
        f = rx.sphere
        k = f / (1.0 - vertex_distance * f)
        base = cls(**kwargs)
        lo, hi = (x * 1e-3 for x in AXIAL_LENGTH_RANGE_MM)

        def refr(length):
            return cls(**{**kwargs, "axial_length": length}).refraction(0.0, wavelength_nm)

        if not (refr(hi) <= k <= refr(lo)):
            raise SpecError("eye.rx", f"{f:+.2f} D needs an axial length outside "
                                      f"{AXIAL_LENGTH_RANGE_MM} mm for the {base.model} eye")
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if refr(mid) > k:
                lo = mid
            else:
                hi = mid
            if hi - lo < 1e-15:
                break
        return cls(**{**kwargs, "axial_length": 0.5 * (lo + hi)})

    def placed(self, rotation, vertex, accommodation: float = 0.0,
               wavelength_nm: float = EYE_REFERENCE_NM) -> tuple:
        """The eye in the world: ([PlacedSurface] front to back, the retina last;
        indices (air ... vitreous); the stop's PlacedSurface index (2) and radius (m)).
        ``rotation`` (3, 3) maps the eye's frame to the world's, ``vertex`` (3,) is the
        corneal vertex in the world (m)."""
        rot = np.asarray(rotation, float)
        v = np.asarray(vertex, float)
        placed = [PlacedSurface(s, rot, v + rot @ np.array([0.0, 0.0, z]))
                  for s, z in self.surfaces(accommodation)]
        return placed, self.indices(wavelength_nm, accommodation), \
            self.stop_radius(accommodation, wavelength_nm)

    def spec_keys(self) -> dict:
        """The ``[eye]`` spec keys that make this eye (mm, D)."""
        return {"model": self.model, "axial_length_mm": self.axial_length * 1e3,
                "accommodation_max_d": self.accommodation_max,
                "pupil_diameter_mm": self.pupil_diameter * 1e3,
                "rotation_centre_mm": self.rotation_centre * 1e3}

    def __repr__(self) -> str:
        from eyelab.core.reprs import spec_repr

        return spec_repr("SchematicEye", self.spec_keys())
