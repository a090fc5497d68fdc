"""Rays of a camera lens system's film (Heidrich et al. 1997, §2.3): for a film point and a
sample point on the system's image-sided surface, the ray traced exactly through the
:class:`~eyelab.optics.cameralens.system.LensSystem` to the object side. Used by the image-based
renderer's plan and by the reference renderer's camera (its truth).

The sample domain. The film irradiance is Heidrich's Eq. 3 integral over the image-sided
sample plane (the last surface's vertex plane): E(x') = int L W T dA over the points whose
rays from x' pass the whole system — the film point's vignetted *bundle*. Off the axis that
bundle is no longer the film centre's disc: its chief ray crosses the plane off the axis
(the doublet's by 0.9-2.7 mm at 7-25°) and other apertures clip it. A sampler confined to
the film centre's disc misses that light (6-22 % at 7-25° through the doublet), so the
bundles are found once per system and wavelength (:func:`footprint_table`): the system is
rotationally symmetric, so a table over the film radius of each bundle's boundary (radial
bisection from an inner point), its bounding disc (centre offset along the film point's
azimuth, radius) and its lossless irradiance int W dA describes every film point. A
:class:`CameraRays` draws samples from one of two domains:

* ``"bundle"``: each film point's own bounding disc (the reference renderer: random
  samples per film point; the smallest domain that holds the bundle, so the fewest
  samples are wasted on vignetted rays);
* ``"cover"``: one disc about the axis that holds every bundle of the film (the image-based
  renderer, whose lens samples are fixed points shared by the whole film: each is one
  centre of projection, so the domain cannot move with the film point), three quarters
  of the samples in the film centre's disc (:data:`COVER_CORE`), the rest in the annulus.

Either way a ray's weight carries its sample's share of the plane (the jacobian of the
unit disc's map, relative to the film centre's disc), so that the mean of L weight T over
a film point's samples, divided by :meth:`CameraRays.white_level`, is the image value: 1
for the exact unvignetted, lossless irradiance at the film centre. The image-based
renderer divides by the sum of the weights instead and multiplies by the tabulated
int W dA (:meth:`CameraRays.relative_illumination`): with a few fixed samples the
vignetting would otherwise come in steps of one sample.

Pure numpy."""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from eyelab.core.errors import SpecError
from eyelab.optics.rays.trace import FATAL

#: The sample domains of :class:`CameraRays` (see the module docstring).
DOMAINS = ("cover", "bundle")
#: The share of the ``"cover"`` domain's samples (of the unit disc's area) that lands in
#: the film centre's disc (:meth:`CameraRays.sample_points`).
COVER_CORE = 0.75


# ----------------------------------------------------------------------- ray makers
@dataclass
class RaySet:
    """Rays of one grid through one lens sample.

    film : (m, 2) film positions in pixels (x right, y down, pixel edges at integers);
    origins, dirs : (m, 3) the rays leaving the system on the object side (dirs unit,
    into the scene); ok : (m,) the ray passed the system; weight : (m,) W_i(x') in 1/m^2
    (0 where not ok; a camera's is scaled by its sample domain's area over the film
    centre's disc, :class:`CameraRays`); transmittance : (m,) the fraction of the light
    the system passes (Fresnel); site : (m, 2) or None, where each ray crosses a spectacle
    lens's front surface (lens frame x, y, m; the lenslets' membership), None without a
    lens.
    """

    film: np.ndarray
    origins: np.ndarray
    dirs: np.ndarray
    ok: np.ndarray
    weight: np.ndarray
    transmittance: np.ndarray
    site: np.ndarray | None = None


# ----------------------------------------------------------------------- the bundles
@dataclass(frozen=True)
class Footprints:
    """The vignetted bundles of a film in the sample plane, per film radius (a film point
    at radius r and azimuth phi has the bundle of the point (r, 0) turned by phi).

    wavelength_nm : the wavelength traced; radius_m : (K,) film radii of the nodes, m,
    from 0 to beyond the film's corners; centre_m : (K,) the bounding disc's centre, m,
    signed along the film point's azimuth; disc_m : (K,) its radius, m (with a margin:
    every passing ray of the film point crosses the sample plane inside it; 0 where none
    passes); illumination : (K,) int W dA over the bundle (sr): the film irradiance of a
    uniform unit-radiance scene without reflection losses (the natural falloff and the
    vignetting); cover_m : radius, m, of the disc about the axis that holds every node's
    bounding disc. Between nodes the values are interpolated linearly."""

    wavelength_nm: float
    radius_m: np.ndarray
    centre_m: np.ndarray
    disc_m: np.ndarray
    illumination: np.ndarray
    cover_m: float

    def at(self, r):
        """(centre (m,), disc radius (m,), illumination (m,)) at film radii ``r`` (m,), m;
        radii beyond the table take its last node's values."""
        return tuple(np.interp(r, self.radius_m, v)
                     for v in (self.centre_m, self.disc_m, self.illumination))


def _passes(system, film_r, p, wl) -> np.ndarray:
    """(K, J) bool: the ray from the film point (film_r[k], 0) (film_r (K,), m) through the
    sample-plane point p[k, j] (p (K or 1, J, 2), m) passes the whole system."""
    film_r = np.asarray(film_r, float)
    p = np.broadcast_to(p, (len(film_r),) + p.shape[1:])
    fr = np.broadcast_to(film_r[:, None], p.shape[:-1]).ravel()
    x = np.column_stack([fr, np.zeros_like(fr), np.full_like(fr, system.film_z)])
    v = np.column_stack([p.reshape(-1, 2), np.full(len(x), system.exit_z)]) - x
    r = system.trace_reverse(x, v / np.linalg.norm(v, axis=1)[:, None], wl)
    return ((r["status"] & np.uint8(FATAL)) == 0).reshape(p.shape[:-1])


def _bundle_boundary(system, film_r, wl, angles: int, steps: int, scan: int = 401):
    """Each film radius's bundle as a star about an inner point: (q (K,) the inner point's
    x (m; on the meridian, y = 0), theta (J,) directions over [0, pi] (the bundle is
    mirror-symmetric about the meridian), b (K, J) the boundary's distance from q along
    each, m; 0 where no ray passes). q is the middle of the passing stretch of a scan of
    the meridian over twice the last clear aperture; the boundary is found by bisection
    (a bundle is an intersection of the apertures' near-elliptical images: convex)."""
    reach = 2.0 * system.exit_radius
    xs = np.linspace(-reach, reach, scan)
    ok = _passes(system, film_r, np.stack([xs, np.zeros_like(xs)], -1)[None], wl)
    lit = ok.any(axis=1)
    first = np.argmax(ok, axis=1)
    last = scan - 1 - np.argmax(ok[:, ::-1], axis=1)
    q = np.where(lit, 0.5 * (xs[first] + xs[last]), 0.0)
    theta = np.linspace(0.0, math.pi, angles)
    u = np.stack([np.cos(theta), np.sin(theta)], -1)
    lo = np.zeros((len(film_r), angles))
    hi = np.full_like(lo, 2.0 * reach)
    base = np.stack([q, np.zeros_like(q)], -1)[:, None]
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        good = _passes(system, film_r, base + mid[..., None] * u, wl)
        lo, hi = np.where(good, mid, lo), np.where(good, hi, mid)
    return q, theta, np.where(lit[:, None], lo, 0.0)


def _enclosing_disc(q, theta, b, candidates: int = 257):
    """The smallest disc centred on the meridian holding each bundle's boundary points:
    (centre (K,), radius (K,)), m (the centre searched over the bundle's meridional
    extent)."""
    px = q[:, None] + b * np.cos(theta)                 # (K, J) boundary points
    py = b * np.sin(theta)
    lo, hi = px.min(axis=1), px.max(axis=1)
    c = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, candidates)  # (K, C)
    d2 = (px[:, None, :] - c[..., None]) ** 2 + py[:, None, :] ** 2
    reach = np.sqrt(d2.max(axis=2))                     # (K, C)
    best = np.argmin(reach, axis=1)
    k = np.arange(len(q))
    return c[k, best], reach[k, best]


def _bundle_illumination(film_r, dz, q, theta, b, order: int = 12) -> np.ndarray:
    """int W dA over each bundle (K,), sr: W = dz^2 / (dz^2 + |p - x'|^2)^2 in polar
    coordinates about q (Gauss-Legendre of ``order`` along each direction, the trapezoid
    rule over the directions; twice the half over [0, pi])."""
    t, wt = np.polynomial.legendre.leggauss(order)
    t, wt = 0.5 * (t + 1.0), 0.5 * wt                   # on [0, 1]
    rho = b[..., None] * t                              # (K, J, n)
    px = q[:, None, None] + rho * np.cos(theta)[None, :, None] - film_r[:, None, None]
    py = rho * np.sin(theta)[None, :, None]
    w = dz ** 2 / (dz ** 2 + px ** 2 + py ** 2) ** 2
    radial = np.sum(w * rho * wt, axis=2) * b           # int_0^b W rho d rho, (K, J)
    dth = theta[1] - theta[0]
    return 2.0 * dth * (radial.sum(axis=1) - 0.5 * (radial[:, 0] + radial[:, -1]))


def footprint_table(system, film_radius: float, wavelength_nm: float = 587.56, *,
                    nodes: int = 65, angles: int = 49, steps: int = 30,
                    margin: float = 0.01) -> Footprints:
    """The :class:`Footprints` of film points up to ``film_radius`` (m) from the axis:
    ``nodes`` film radii, each bundle's boundary in ``angles`` directions by ``steps``
    bisections, its bounding disc widened by ``margin`` (relative: what lies between the
    directions and the nodes; checked against dense traces in the tests). About 0.2 s."""
    r = np.linspace(0.0, float(film_radius), nodes)
    q, theta, b = _bundle_boundary(system, r, wavelength_nm, angles, steps)
    c, rho = _enclosing_disc(q, theta, b)
    rho = rho * (1.0 + margin)
    g = _bundle_illumination(r, system.film_z - system.exit_z, q, theta, b)
    return Footprints(float(wavelength_nm), r, c, rho, g, float(np.max(np.abs(c) + rho)))


def _cover_map(s, r0: float, rc: float, core: float | None = None):
    """Unit-disc samples s (n, 2) onto the cover disc of radius rc (m) with the film
    centre's disc (radius r0) holding the share ``core`` (default :data:`COVER_CORE`, at
    least (r0 / rc)^2) of the unit disc's area: (points (n, 2), jacobians (n,), m^2).
    Piecewise linear in the area coordinate a = |s|^2 (a sample set's whitening may put
    a few just outside the unit disc: the annulus's map goes on there)."""
    a0 = max(COVER_CORE if core is None else core, (r0 / rc) ** 2)
    a = np.sum(s * s, axis=1)
    inner = a <= a0
    jac = np.where(inner, r0 ** 2 / a0, (rc ** 2 - r0 ** 2) / max(1.0 - a0, 1e-12))
    r2 = np.where(inner, a * jac, r0 ** 2 + (a - a0) * jac)
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(a > 0, np.sqrt(r2 / a), 0.0)
    return s * scale[:, None], jac


class CameraRays:
    """Rays of a :class:`~eyelab.optics.cameralens.system.LensSystem` camera.

    The film is ``height`` pixels high over 2 f tan(fov_y / 2) (f the effective focal
    length: the field of view of the paraxial image; the lens's distortion changes it),
    centred on the axis, and seen upright (the image on the film is turned 180°).
    Samples are unit-disc coordinates of the sample ``domain`` in the image-sided sample
    plane (the last surface's vertex plane): ``"cover"`` one disc about the axis holding
    every film point's vignetted bundle (fixed lens points: the image-based renderer),
    ``"bundle"`` each film point's own bounding disc (the reference renderer); see the
    module docstring. The bundles are tabulated per wavelength on first use
    (:meth:`footprints`). ``radius``: the film centre's bundle, a disc (m; by bisection):
    the normalisation's (:meth:`white_level`)."""

    kind = "camera"

    def __init__(self, system, width: int, height: int, fov_y_deg: float,
                 near: float = 0.05, domain: str = "cover"):
        if domain not in DOMAINS:
            raise SpecError("camera.domain", f"must be one of {DOMAINS}, got {domain!r}")
        self.system = system
        self.width, self.height = width, height
        self.domain = domain
        f = system.cardinal()["efl_m"]
        self.pitch = 2 * f * math.tan(math.radians(fov_y_deg) / 2) / height
        self.dz = system.film_z - system.exit_z
        self.radius = self._pupil_radius()
        self.near = near
        # the film's corners and one pixel more (jittered film positions stay inside)
        self.film_radius = self.pitch * (0.5 * math.hypot(width, height) + 1.0)
        self._tables: dict = {}
        self._lock = threading.Lock()

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

    def footprints(self, wavelength_nm: float = 587.56) -> Footprints:
        """The film's bundles at ``wavelength_nm`` (:func:`footprint_table`, kept per
        wavelength; thread-safe)."""
        key = float(wavelength_nm)
        with self._lock:
            if key not in self._tables:
                self._tables[key] = footprint_table(self.system, self.film_radius, key)
            return self._tables[key]

    def film_points(self, film_px) -> np.ndarray:
        """(m, 3) film-plane points of film pixel positions (upright image)."""
        px = np.asarray(film_px, float)
        u = px[:, 0] - self.width / 2
        v = px[:, 1] - self.height / 2
        return np.column_stack([-u * self.pitch, v * self.pitch,
                                np.full(len(px), self.system.film_z)])

    def sample_points(self, film_px, samples, wavelength_nm: float = 587.56):
        """Sample-plane points of unit-disc samples (n, 2) for film positions (n, 2) px:
        (points (n, 2), m; jacobians (n,), m^2: the domain's area per unit-disc area, so
        that uniform unit-disc samples have the density 1 / (pi jacobian) in the plane).

        ``"bundle"``: c + rho s in the film point's bounding disc (jacobian rho^2).
        ``"cover"``: the map keeps each sample's azimuth and takes the inner
        :data:`COVER_CORE` of the unit disc's area (at least the film centre's share of
        the cover disc's area) onto the film centre's disc of radius R, the rest onto the
        annulus out to the cover radius, each uniformly (area-preserving in |s|^2: the
        stratification of a sample set is kept). The film centre's disc lies in most of
        every bundle, the annulus in a side of the outer film points' bundles only, so the
        denser core leaves every film point more samples than one uniform disc would (the
        quality bench's camera case, the room through the doublet at 16 samples:
        docs/bench/quality_quick_camera.json)."""
        tab = self.footprints(wavelength_nm)
        smp = np.asarray(samples, float)
        if self.domain == "cover":
            return _cover_map(smp, self.radius, tab.cover_m)
        x = self.film_points(film_px)
        r = np.hypot(x[:, 0], x[:, 1])
        c, rho, _ = tab.at(r)
        with np.errstate(invalid="ignore", divide="ignore"):
            az = np.where(r[:, None] > 0, x[:, :2] / r[:, None], 0.0)
        return c[:, None] * az + rho[:, None] * smp, rho ** 2

    def relative_illumination(self, film_px, wavelength_nm: float = 587.56) -> np.ndarray:
        """(m,) the lossless film irradiance of a uniform white scene at film positions
        (m, 2) px, over the film centre's unvignetted value (int W dA over the bundle, from
        :meth:`footprints`, over pi R^2 :meth:`white_level`): the natural falloff with the
        system's vignetting, 1 at the centre."""
        x = self.film_points(film_px)
        g = self.footprints(wavelength_nm).at(np.hypot(x[:, 0], x[:, 1]))[2]
        return g / (math.pi * self.radius ** 2 * self.white_level())

    def rays(self, film_px, sample, wavelength_nm) -> RaySet:
        """Rays from the film positions through one sample (unit-disc coordinates of the
        sample domain), traced back into the scene."""
        px = np.asarray(film_px, float)
        return self.ray_pairs(px, np.broadcast_to(np.asarray(sample, float), px.shape),
                              wavelength_nm)

    def ray_pairs(self, film_px, samples, wavelength_nm) -> RaySet:
        """Rays from film positions (n, 2) through their own samples (n, 2; unit-disc
        coordinates of each film position's sample domain, :meth:`sample_points`). Weight:
        W (1/m^2) times the sample's jacobian over R^2 (its share of the plane relative to
        the film centre's disc pi R^2), so that the mean of L weight T over a film point's
        uniform unit-disc samples, over :meth:`white_level`, is its image value."""
        x = self.film_points(film_px)
        pts, jac = self.sample_points(film_px, samples, wavelength_nm)
        p = np.column_stack([pts, np.full(len(pts), self.system.exit_z)])
        v = p - x
        dist2 = np.sum(v * v, axis=1)
        # start just behind the last surface's apex region: on the film (rays travel -z)
        r = self.system.trace_reverse(x, v / np.sqrt(dist2)[:, None], wavelength_nm)
        ok = (r["status"] & np.uint8(FATAL)) == 0
        w = self.dz ** 2 / dist2 ** 2 * (jac / self.radius ** 2)  # cos th' cos th'' / d^4
        return RaySet(np.asarray(film_px, float), r["points"], r["dirs"], ok,
                      np.where(ok, w, 0.0), r["transmittance"])

    def white_level(self) -> float:
        """The normalisation, 1/m^2: 1 / (dz^2 + R^2) exactly, the mean of W over the film
        centre's disc (radius R = :attr:`radius`; int_0^R 2 pi rho dz^2 / (dz^2 + rho^2)^2
        d rho / (pi R^2)). Times pi R^2 it is the film centre's irradiance of a uniform
        white scene of unit radiance without reflection losses (unvignetted: the whole
        disc passes there); ray weights are expressed per pi R^2 (:meth:`ray_pairs`), so
        mean(L weight T) / white_level is the image value, 1 for that irradiance."""
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
