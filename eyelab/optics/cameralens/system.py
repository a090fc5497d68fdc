"""General lens systems: an ordered list of surfaces on one axis, their materials and
apertures, an aperture stop and a film plane (a camera, Heidrich et al. 1997 §2.5, the
"geometric lens model"), traced exactly with the engine's ray machinery
(:func:`eyelab.optics.rays.trace.intersect`, :func:`~eyelab.optics.rays.trace.refract`): per-ray
status, per wavelength.

Frame (eyelab's): the optical axis is z, the scene at z < 0, light travels +z; surface i's
vertex is at ``z[i]`` (metres), the film plane at ``film_z``, the image-sided sample plane
(where Heidrich's lens samples p_i and the radiometry of §3.5 live) at the last surface's
vertex. A camera built on it looks along -z like the eye.

Named, sourced examples (:data:`EXAMPLES`): Thorlabs' LB1471-A N-BK7 biconvex lens and
AC254-050-A cemented achromatic doublet.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from eyelab.core.checks import check_range
from eyelab.core.errors import SpecError
from eyelab.optics.rays.fresnel import PolarisedTransmission
from eyelab.optics.rays.materials import Material
from eyelab.optics.rays.surfaces import Asphere, Surface
from eyelab.optics.rays.trace import FATAL, PlacedSurface, Status, intersect, refract

#: Glasses of the examples (Schott data sheets: n_d, V_d).
N_BK7 = Material("N-BK7", 1.51680, 64.17, "Schott N-BK7 data sheet: n_d 1.51680, V_d 64.17")
N_BAF10 = Material("N-BAF10", 1.67003, 47.11, "Schott N-BAF10 data sheet: n_d 1.67003, "
                   "V_d 47.11")
SF10 = Material("SF10", 1.72825, 28.41, "Schott SF10 data sheet: n_d 1.72825, V_d 28.41")
AIR = Material("air", 1.0)


@dataclass(frozen=True)
class SystemSurface:
    """One refracting surface of a :class:`LensSystem`.

    surface : local sag (+z toward the film); z : vertex position on the axis, m;
    after : the material behind it (toward the film); semi_diameter : clear aperture
    radius, m (a ray outside it is MISSED, vignetted)."""

    surface: Surface
    z: float
    after: Material
    semi_diameter: float

    def placed(self) -> PlacedSurface:
        return PlacedSurface(self.surface, np.eye(3), np.array([0.0, 0.0, self.z]),
                             self.semi_diameter)


@dataclass(frozen=True)
class LensSystem:
    """A rotationally symmetric lens system on the z axis (object side at z < 0).

    surfaces : ordered from the object side; stop_z, stop_radius : the aperture stop (a
    circular hole in a plane, m); film_z : the film plane, m (behind the last surface);
    name, source : what it is and where its prescription comes from.
    """

    surfaces: tuple
    stop_z: float
    stop_radius: float
    film_z: float
    name: str = "lens system"
    source: str = field(default="", compare=False)

    def __post_init__(self):
        if not self.surfaces:
            raise SpecError("system.surfaces", "a lens system needs at least one surface")
        zs = [s.z for s in self.surfaces]
        if any(b <= a for a, b in zip(zs, zs[1:], strict=False)):
            raise SpecError("system.surfaces", f"vertices must increase along z, got {zs}")
        if not self.film_z > zs[-1]:
            raise SpecError("system.film_z", f"the film must lie behind the last surface "
                                             f"({zs[-1]} m), got {self.film_z}")
        check_range("system.stop_radius", self.stop_radius, 1e-6, 1.0)

    # ------------------------------------------------------------------ geometry
    @property
    def exit_z(self) -> float:
        """z of the image-sided sample plane (the last surface's vertex), m."""
        return self.surfaces[-1].z

    @property
    def exit_radius(self) -> float:
        """The last surface's clear aperture radius, m (bounds every film point's bundle in the
        image-sided sample plane, :mod:`eyelab.optics.cameralens.film`)."""
        return self.surfaces[-1].semi_diameter

    def with_film(self, film_z: float) -> LensSystem:
        import dataclasses

        return dataclasses.replace(self, film_z=float(film_z))

    def with_stop(self, radius: float) -> LensSystem:
        import dataclasses

        return dataclasses.replace(self, stop_radius=float(radius))

    # ------------------------------------------------------------------ tracing
    def trace_reverse(self, origins, directions, wavelength_nm: float = 587.56) -> dict:
        """Rays from the film side (travelling -z) through every surface and the stop,
        last surface first. Returns dict ``points`` (n, 3) where each ray leaves the first
        surface, ``dirs`` (n, 3) its direction into the scene, ``status`` (n,) uint8
        (MISSED: vignetted by a surface's aperture or the stop; TIR) and
        ``transmittance`` (n,) (uncoated Fresnel of every surface, s and p tracked; 0 for
        failed rays)."""
        o = np.asarray(origins, float)
        d = np.asarray(directions, float)
        n = len(o)
        status = np.zeros(n, np.uint8)
        fresnel = PolarisedTransmission(n)
        stop_done = False
        for i in range(len(self.surfaces) - 1, -1, -1):
            s = self.surfaces[i]
            if not stop_done and self.stop_z > s.z:
                o, d, status = self._through_stop(o, d, status)
                stop_done = True
            hit = intersect(s.placed(), o, d)
            n_behind = s.after.n(wavelength_nm)
            n_front = (self.surfaces[i - 1].after if i > 0 else AIR).n(wavelength_nm)
            d2, _, ci, ct, st = refract(d, hit.normals, n_behind / n_front)
            with np.errstate(invalid="ignore", divide="ignore"):
                fresnel.surface(d, hit.normals, ci, ct, n_behind, n_front)
            status = status | hit.status | st
            o, d = hit.points, d2
        if not stop_done:
            o, d, status = self._through_stop(o, d, status)
        ok = (status & np.uint8(FATAL)) == 0
        return {"points": o, "dirs": d, "status": status,
                "transmittance": np.where(ok, fresnel.transmittance, 0.0)}

    def trace_forward(self, origins, directions, wavelength_nm: float = 587.56) -> dict:
        """Rays from the scene (travelling +z) through the system to the film plane.
        Returns dict ``points`` (n, 3) on the film, ``dirs`` (n, 3), ``status`` (n,)."""
        o = np.asarray(origins, float)
        d = np.asarray(directions, float)
        status = np.zeros(len(o), np.uint8)
        stop_done = False
        for i, s in enumerate(self.surfaces):
            if not stop_done and self.stop_z < s.z:
                o, d, status = self._through_stop(o, d, status)
                stop_done = True
            hit = intersect(s.placed(), o, d)
            n_front = (self.surfaces[i - 1].after if i > 0 else AIR).n(wavelength_nm)
            d2, _, _, _, st = refract(d, hit.normals, n_front / s.after.n(wavelength_nm))
            status = status | hit.status | st
            o, d = hit.points, d2
        if not stop_done:
            o, d, status = self._through_stop(o, d, status)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (self.film_z - o[:, 2]) / d[:, 2]
        return {"points": o + t[:, None] * d, "dirs": d, "status": status}

    def _through_stop(self, o, d, status):
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (self.stop_z - o[:, 2]) / d[:, 2]
        p = o + np.where(np.isfinite(t), t, 0.0)[:, None] * d
        out = (p[:, 0] ** 2 + p[:, 1] ** 2) > self.stop_radius ** 2
        status = status | np.where(out | ~np.isfinite(t), Status.MISSED, 0).astype(np.uint8)
        return o, d, status

    # ------------------------------------------------------------------ first order
    def cardinal(self, wavelength_nm: float = 587.56, height: float = 1e-5) -> dict:
        """Effective focal length and back focal distance (m), by a real ray parallel to
        the axis at ``height`` traced forward (its slope behind the lens gives f, its axis
        crossing the back focal point: first-order values as the ray's height -> 0)."""
        o = np.array([[height, 0.0, self.surfaces[0].z - 0.01]])
        r = self.trace_forward(o, np.array([[0.0, 0.0, 1.0]]), wavelength_nm)
        p, d = r["points"][0], r["dirs"][0]
        slope = d[0] / d[2]
        # where the ray meets the axis
        z_cross = p[2] - p[0] / slope
        return {"efl_m": float(-height / slope), "bfl_m": float(z_cross - self.exit_z),
                "focus_z": float(z_cross)}

    def focused(self, distance_m: float, wavelength_nm: float = 587.56) -> LensSystem:
        """The system with its film moved to where an axial point ``distance_m`` in front
        of the first vertex is sharpest (a near-axis real ray; inf: the back focal point)."""
        if not math.isfinite(distance_m):
            return self.with_film(self.cardinal(wavelength_nm)["focus_z"])
        z0 = self.surfaces[0].z
        h = 1e-5
        d = np.array([[h, 0.0, distance_m]])
        d /= np.linalg.norm(d)
        r = self.trace_forward(np.array([[0.0, 0.0, z0 - distance_m]]), d, wavelength_nm)
        p, dd = r["points"][0], r["dirs"][0]
        z_cross = p[2] - p[0] * dd[2] / dd[0]
        if not z_cross > self.exit_z:
            raise SpecError("camera.focus_m", f"{distance_m} m is inside the focal length: "
                                              "no real image")
        return self.with_film(z_cross)


def _sphere(radius_mm: float) -> Surface:
    return Asphere(0.0 if math.isinf(radius_mm) else 1e3 / radius_mm)


def biconvex_lb1471() -> LensSystem:
    """Thorlabs LB1471-A: N-BK7 biconvex lens, f = 50 mm, Ø 25.4 mm, R1 = 50.6 mm, R2 =
    -50.6 mm, centre thickness 5.24 mm, back focal length 48.2 mm at 587.6 nm (Thorlabs
    catalogue, N-BK7 bi-convex lenses). Stop: the lens's clear aperture (90 % of Ø) at its
    front vertex; film at the back focal point."""
    sd = 0.9 * 25.4e-3 / 2
    s = (SystemSurface(_sphere(50.6), 0.0, N_BK7, sd),
         SystemSurface(_sphere(-50.6), 5.24e-3, AIR, sd))
    sys_ = LensSystem(s, stop_z=-1e-9, stop_radius=sd, film_z=0.06, name="LB1471-A biconvex",
                      source="Thorlabs LB1471-A: R 50.6 / -50.6 mm, CT 5.24 mm, N-BK7, "
                             "f 50 mm, BFL 48.2 mm")
    return sys_.focused(math.inf)


def doublet_ac254_050() -> LensSystem:
    """Thorlabs AC254-050-A: cemented achromatic doublet, f = 50 mm, Ø 25.4 mm, from
    Thorlabs' Zemax file AC254-050-A.zmx: R1 = 33.34 mm (curvature 0.029994 1/mm),
    R2 = -22.28 mm, R3 = -291.07 mm; centre thicknesses 9.0 mm (N-BAF10) and 2.5 mm (SF10);
    published back focal length 43.4 mm (the Zemax file's image plane, 43.22 mm behind the
    last vertex, is not the BFL). Stop: 90 % of the diameter at the
    front vertex; film at the back focal point."""
    sd = 0.9 * 25.4e-3 / 2
    s = (SystemSurface(Asphere(29.99400119976), 0.0, N_BAF10, 25.4e-3 / 2),
         SystemSurface(Asphere(-44.8833034111311), 9.0e-3, SF10, 25.4e-3 / 2),
         SystemSurface(Asphere(-3.4355996839248), 11.5e-3, AIR, 25.4e-3 / 2))
    sys_ = LensSystem(s, stop_z=-1e-9, stop_radius=sd, film_z=0.06,
                      name="AC254-050-A achromatic doublet",
                      source="Thorlabs AC254-050-A.zmx: curvatures 0.029994 / -0.044883 / "
                             "-0.0034356 1/mm, CT 9.0 / 2.5 mm, N-BAF10 / SF10; published "
                             "BFL 43.4 mm")
    return sys_.focused(math.inf)


#: Named lens systems (factories): name -> (factory, published EFL m, published BFL m).
EXAMPLES = {"biconvex": (biconvex_lb1471, 0.050, 0.0482),
            "doublet": (doublet_ac254_050, 0.050, 0.0434)}


def full_f_number(system: LensSystem) -> float:
    """The system's f-number at full aperture: effective focal length / stop diameter."""
    return float(system.cardinal()["efl_m"] / (2 * system.stop_radius))


def get_system(name: str) -> LensSystem:
    if name not in EXAMPLES:
        raise SpecError("camera.system", f"must be one of {', '.join(map(repr, EXAMPLES))}, "
                                         f"got {name!r}")
    return EXAMPLES[name][0]()
