"""Rays of a camera lens system's film (Heidrich et al. 1997, §2.3): for a film point and a
sample point on the system's image-sided surface, the ray traced exactly through the
:class:`~eyelab.optics.system.LensSystem` to the object side. Used by the image-based
renderer's plan and by the reference renderer's camera (its truth).

Pure numpy."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eyelab.core.errors import SpecError
from eyelab.optics.trace import FATAL


# ----------------------------------------------------------------------- ray makers
@dataclass
class RaySet:
    """Rays of one grid through one lens sample.

    film : (m, 2) film positions in pixels (x right, y down, pixel edges at integers);
    origins, dirs : (m, 3) the rays leaving the system on the object side (dirs unit,
    into the scene); ok : (m,) the ray passed the system; weight : (m,) W_i(x') (0 where
    not ok); transmittance : (m,) the fraction of the light the system passes (Fresnel).
    """

    film: np.ndarray
    origins: np.ndarray
    dirs: np.ndarray
    ok: np.ndarray
    weight: np.ndarray
    transmittance: np.ndarray


class CameraRays:
    """Rays of a :class:`~eyelab.optics.system.LensSystem` camera.

    The film is ``height`` pixels high over 2 f tan(fov_y / 2) (f the effective focal
    length: the field of view of the paraxial image; the lens's distortion changes it),
    centred on the axis, and seen upright (the image on the film is turned 180°).
    Samples are points of the image-sided sample plane (the last surface's vertex plane)
    in the disc that the film centre's passing rays cross it in (its radius found by
    bisection: every sample carries light at the film centre; off the axis the system's
    own vignetting is traced)."""

    kind = "camera"

    def __init__(self, system, width: int, height: int, fov_y_deg: float,
                 near: float = 0.05):
        self.system = system
        self.width, self.height = width, height
        f = system.cardinal()["efl_m"]
        self.pitch = 2 * f * math.tan(math.radians(fov_y_deg) / 2) / height
        self.dz = system.film_z - system.exit_z
        self.radius = self._pupil_radius()
        self.near = near

    def _pupil_radius(self, steps: int = 48) -> float:
        """Radius (m) in the sample plane within which rays from the film centre pass the
        whole system (bisection along x; the system is rotationally symmetric)."""
        sys_ = self.system
        x = np.array([[0.0, 0.0, sys_.film_z]])
        lo, hi = 0.0, 2.0 * sys_.exit_radius

        def passes(r):
            v = np.array([r, 0.0, sys_.exit_z]) - x[0]
            res = sys_.trace_reverse(x, (v / np.linalg.norm(v))[None])
            return (res["status"][0] & np.uint8(FATAL)) == 0

        if not passes(0.0):
            raise SpecError("camera", f"{sys_.name}: the axial ray does not pass the system")
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if passes(mid) else (lo, mid)
        return lo

    def film_points(self, film_px) -> np.ndarray:
        """(m, 3) film-plane points of film pixel positions (upright image)."""
        px = np.asarray(film_px, float)
        u = px[:, 0] - self.width / 2
        v = px[:, 1] - self.height / 2
        return np.column_stack([-u * self.pitch, v * self.pitch,
                                np.full(len(px), self.system.film_z)])

    def rays(self, film_px, sample, wavelength_nm) -> RaySet:
        """Rays from the film positions through the sample point (unit-disc coordinates
        times the exit radius), traced back into the scene."""
        px = np.asarray(film_px, float)
        return self.ray_pairs(px, np.broadcast_to(np.asarray(sample, float), px.shape),
                              wavelength_nm)

    def ray_pairs(self, film_px, samples, wavelength_nm) -> RaySet:
        """Rays from film positions (n, 2) through their own sample points (n, 2), unit
        disc."""
        x = self.film_points(film_px)
        smp = np.asarray(samples, float)
        p = np.column_stack([smp[:, 0] * self.radius, smp[:, 1] * self.radius,
                             np.full(len(smp), self.system.exit_z)])
        v = p - x
        dist2 = np.sum(v * v, axis=1)
        # start just behind the last surface's apex region: on the film (rays travel -z)
        r = self.system.trace_reverse(x, v / np.sqrt(dist2)[:, None], wavelength_nm)
        ok = (r["status"] & np.uint8(FATAL)) == 0
        w = self.dz ** 2 / dist2 ** 2                   # cos th' cos th'' / |x'' - x'|^2
        return RaySet(np.asarray(film_px, float), r["points"], r["dirs"], ok,
                      np.where(ok, w, 0.0), r["transmittance"])

    def white_level(self) -> float:
        """Mean of W over the sample disc at the film centre: 1 / (dz^2 + R^2) exactly
        (int_0^R 2 pi rho dz^2 / (dz^2 + rho^2)^2 d rho / (pi R^2)); the irradiance of a
        uniform white scene there, without vignetting or reflection losses, per unit
        radiance and sample-disc area."""
        return 1.0 / (self.dz ** 2 + self.radius ** 2)

    def focus_distance(self) -> float:
        """Object distance in focus (m from the first vertex; inf at the back focal
        point): a near-axis real ray from the film centre, traced back."""
        sys_ = self.system
        h = 1e-5 * self.radius
        x = np.array([[0.0, 0.0, sys_.film_z]])
        v = np.array([h, 0.0, sys_.exit_z]) - x[0]
        r = sys_.trace_reverse(x, (v / np.linalg.norm(v))[None])
        p, d = r["points"][0], r["dirs"][0]
        if abs(d[0]) < 1e-15 or d[0] * p[0] >= 0:
            return math.inf
        return float(sys_.surfaces[0].z - (p[2] - p[0] * d[2] / d[0]))
