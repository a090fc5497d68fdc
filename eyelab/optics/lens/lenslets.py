"""Lenslet arrays on a spectacle lens's front surface: the myopia-control designs (a
single-vision carrier with a treatment zone of small plus lenslets; docs/SCIENCE.md §12).

The surface (:class:`LensletSurface`) is the carrier's surface with, inside each lenslet's
circle of radius a about its centre c (lens x, y), a conicoid sag of curvature dC and conic
k added and lowered to meet the carrier at the circle:

    z(x, y) = f(x, y) + s(rho) - s(a),  rho = |(x, y) - c| < a,  s(r) = dC r^2 / (1 +
    sqrt(1 - (1 + k) dC^2 r^2)),

so each lenslet stands proud of the carrier toward the scene (dC > 0: a plus lenslet) and
the surface is continuous, its slope and curvature jumping at the circles (a ray meets
exactly one piece: the intersection is Newton's on the composite sag,
:func:`eyelab.optics.rays.trace.intersect`, each lenslet's own conicoid inside its circle).
The lenslets' dC are designed (:func:`design_lenslets`) so that each lenslet's add as worn
— the mean power of the wave at the vertex sphere along the line of sight through its
centre, less the carrier's along the same line — is the nominal add.

Layouts: a honeycomb (hexagonal lattice of ``pitch``, one lenslet on the lens's centre
axis's lattice point, kept where the whole lenslet lies between the clear zone and the
zone's outer edge), concentric rings (each of given diameter, its lenslets spaced evenly,
as many as fit contiguously unless counted), or a list of centres.
"""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np
from scipy.spatial import cKDTree

from eyelab.core.errors import SpecError
from eyelab.optics.rays.surfaces import SagDerivatives, Surface
from eyelab.optics.rays.trace import FATAL

#: The layouts, by spec value.
LAYOUTS = ("honeycomb", "rings", "list")
#: Ranges (spec units) of the lenslet keys, one place.
LIMITS = {"lens.lenslets.add_d": (-10.0, 10.0), "lens.lenslets.diameter_mm": (0.2, 5.0),
          "lens.lenslets.pitch_mm": (0.2, 20.0), "lens.lenslets.clear_zone_mm": (0.0, 80.0),
          "lens.lenslets.zone_mm": (1.0, 90.0), "lens.lenslets.conic": (-50.0, 50.0),
          "lens.lenslets.ring_diameters_mm": (1.0, 90.0),
          "lens.lenslets.per_ring": (1, 2000), "lens.lenslets.centres_mm": (-45.0, 45.0)}
#: The most lenslets a lens may hold: 5 x the 1,021 of the densest design in production
#: (HALT, docs/SCIENCE.md §12b). Each lenslet is designed, meshed and traced on its own
#: (``eyelab analyze`` of a default-zone honeycomb: ~2,000 lenslets 10 s, ~6,500 21 s,
#: ~17,000 73 s on 2 cores), so a layout beyond it is refused before it is laid out.
MAX_LENSLETS = 5000
#: Gap (m) two lenslets' circles must keep: touching circles (contiguous rings) are allowed
#: up to this rounding.
TOUCH_TOL = 1e-9
#: Secant iterations of the design and the add's tolerance (D) they stop at.
DESIGN_ITER = 8
DESIGN_TOL = 1e-5


class LensletSurface(Surface):
    """A carrier surface with lenslets (module doc); lengths in m, curvatures in 1/m.

    base : the carrier's :class:`~eyelab.optics.rays.surfaces.Surface`
    centres : (n, 2) lenslet centres (lens x, y)
    radius : (n,) lenslet radii a (or one for all)
    delta_curvature : (n,) each lenslet's added curvature dC (or one for all)
    conic : the added sag's conic constant k (0: spherical lenslets)
    add_d : the nominal add as worn (D) the lenslets were designed for (metadata)
    """

    def __init__(self, base: Surface, centres, radius, delta_curvature, conic: float = 0.0,
                 add_d: float = 0.0):
        self.base = base
        self.centres = np.asarray(centres, float).reshape(-1, 2).copy()
        n = len(self.centres)
        self.radius = np.broadcast_to(np.asarray(radius, float), (n,)).copy()
        self.delta_curvature = np.broadcast_to(np.asarray(delta_curvature, float), (n,)).copy()
        self.conic = float(conic)
        self.add_d = float(add_d)
        for a in (self.centres, self.radius, self.delta_curvature):
            a.flags.writeable = False
        self._tree = cKDTree(self.centres) if n else None

    def with_curvature(self, delta_curvature) -> LensletSurface:
        """The same lenslets with other added curvatures (n,) (1/m)."""
        return LensletSurface(self.base, self.centres, self.radius, delta_curvature,
                              self.conic, self.add_d)

    def __repr__(self) -> str:
        return (f"LensletSurface(base={self.base!r}, lenslets={len(self.centres)}, "
                f"add_d={self.add_d:g}, diameter_mm={2e3 * float(self.radius.max()):g}, "
                f"conic={self.conic:g}, key {self.content_key[:12]})")

    @property
    def content_key(self) -> str:
        """A digest of everything that shapes the surface (for caches)."""
        from eyelab.core.cache import content_key

        return content_key(base=self.base, centres=self.centres, radius=self.radius,
                           delta_curvature=self.delta_curvature, conic=self.conic,
                           add_d=self.add_d)

    @property
    def seed_curvature(self) -> float:
        return float(self.base.seed_curvature)

    def which(self, x, y) -> np.ndarray:
        """(n,) int: the lenslet each point (x, y) (m, lens frame) lies in, or -1."""
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        out = np.full(x.shape, -1, int)
        if self._tree is None:
            return out
        dist, idx = self._tree.query(np.stack([x.ravel(), y.ravel()], -1))
        inside = dist < self.radius[idx]
        out.ravel()[inside] = idx[inside]
        return out

    def near(self, points, reach) -> tuple:
        """(point indices (k,), lenslet indices (k,)): every pair whose centres lie within
        ``reach`` (m; (m,) or one) of ``points`` (m, 2; m, lens frame)."""
        points = np.asarray(points, float).reshape(-1, 2)
        if self._tree is None or not len(points):
            return np.zeros(0, int), np.zeros(0, int)
        reach = np.broadcast_to(np.asarray(reach, float), (len(points),))
        lists = self._tree.query_ball_point(points, reach)
        counts = np.fromiter(map(len, lists), int, len(lists))
        if not counts.sum():
            return np.zeros(0, int), np.zeros(0, int)
        return (np.repeat(np.arange(len(points)), counts),
                np.concatenate([np.asarray(v, int) for v in lists if v]))

    def added_sag(self, x, y) -> np.ndarray:
        """(n,) the lenslets' added sag s(rho) - s(a) at lens points (x, y) (m; 0 outside
        them)."""
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        out = np.zeros(x.shape)
        k = self.which(x, y)
        on = k >= 0
        i = k[on]
        out[on] = _bump(x[on] - self.centres[i, 0], y[on] - self.centres[i, 1],
                        self.delta_curvature[i], self.conic, self.radius[i])[0]
        return out

    def max_added_slope(self) -> float:
        """The steepest slope of the added sag (at the lenslets' rims), dimensionless."""
        dc, a = np.abs(self.delta_curvature), self.radius
        q = np.sqrt(np.maximum(1.0 - (1.0 + self.conic) * dc * dc * a * a, 1e-12))
        return float(np.max(dc * a / q, initial=0.0))

    def derivatives(self, x, y) -> SagDerivatives:
        x = np.asarray(x, float)
        y = np.asarray(y, float)
        d = self.base.derivatives(x, y)
        k = self.which(x, y)
        on = k >= 0
        if not on.any():
            return d
        z, zx, zy, zxx, zxy, zyy = (np.array(v, float, copy=True)
                                    for v in (d.z, d.zx, d.zy, d.zxx, d.zxy, d.zyy))
        valid = np.array(d.valid, copy=True)
        i = k[on]
        u, v = x[on] - self.centres[i, 0], y[on] - self.centres[i, 1]
        b = _bump(u, v, self.delta_curvature[i], self.conic, self.radius[i])
        z[on] += b[0]
        zx[on] += b[1]
        zy[on] += b[2]
        zxx[on] += b[3]
        zxy[on] += b[4]
        zyy[on] += b[5]
        valid[on] &= b[6]
        return SagDerivatives(z, zx, zy, zxx, zxy, zyy, valid)


def _bump(u, v, dc, k, a):
    """The added sag s(rho) - s(a) at offsets (u, v) from each lenslet's centre and its
    derivatives (z, zx, zy, zxx, zxy, zyy, valid), a radial conicoid (as
    :class:`~eyelab.optics.rays.surfaces.Asphere`)."""
    r2 = u * u + v * v
    with np.errstate(invalid="ignore"):
        q = np.sqrt(1.0 - (1.0 + k) * dc * dc * r2)
        qa = np.sqrt(1.0 - (1.0 + k) * dc * dc * a * a)
        z = dc * r2 / (1.0 + q) - dc * a * a / (1.0 + qa)
        g = dc / q                          # s'(r)/r
        h = dc / q ** 3                     # s''(r)
    diff = h - g
    inv = np.where(r2 > 1e-200, 1.0 / np.where(r2 > 1e-200, r2, 1.0), 0.0)
    return (z, g * u, g * v, g + diff * u * u * inv, diff * u * v * inv,
            g + diff * v * v * inv, (q > 0) & (qa > 0))


class ContinuedLenslet(Surface):
    """Lenslet ``i`` of a :class:`LensletSurface` with its added sag continued past its
    rim over the whole carrier: z = f(x, y) + s(rho) - s(a) everywhere (the same surface
    inside the rim). A smooth surface, so that rays through it may be interpolated (the
    image-based renderer's lenslet layers, :mod:`eyelab.render.imagebased.layers`, keep
    only the film points whose rays cross inside the rim)."""

    def __init__(self, surf: LensletSurface, i: int):
        self.base = surf.base
        self.index = int(i)
        self.centre = surf.centres[self.index]
        self.radius = float(surf.radius[self.index])
        # (not ``delta_curvature``: a lens with this front has no lenslets to find)
        self.added_curvature = float(surf.delta_curvature[self.index])
        self.conic = surf.conic
        self._key = f"{surf.content_key}-continued-{self.index}"

    @property
    def content_key(self) -> str:
        return self._key

    @property
    def seed_curvature(self) -> float:
        return float(self.base.seed_curvature)

    def derivatives(self, x, y) -> SagDerivatives:
        x = np.asarray(x, float)
        y = np.asarray(y, float)
        d = self.base.derivatives(x, y)
        b = _bump(x - self.centre[0], y - self.centre[1], self.added_curvature, self.conic,
                  self.radius)
        return SagDerivatives(d.z + b[0], d.zx + b[1], d.zy + b[2], d.zxx + b[3],
                              d.zxy + b[4], d.zyy + b[5], d.valid & b[6])


def continued(lens, i: int):
    """``lens`` with its front's lenslet ``i`` continued over the whole carrier
    (:class:`ContinuedLenslet`): a tracing surface, not a lens to make (far from the
    lenslet its sag leaves the blank's thickness behind, so the lens's checks are not
    run again)."""
    other = copy.copy(lens)
    object.__setattr__(other, "front", ContinuedLenslet(lens.front, i))
    return other


def carrier(lens):
    """``lens`` without its lenslets (the carrier the eye focuses through: the sharp image
    it chooses, the lenslets' images being the defocus), or ``lens`` itself."""
    if lens is None or not lens.has_lenslets:
        return lens
    return dataclasses.replace(lens, front=lens.front.base)


# ---------------------------------------------------------------------------- layouts
def honeycomb(pitch: float, diameter: float, clear_zone: float, zone: float) -> np.ndarray:
    """(n, 2) centres (m) of a hexagonal lattice of ``pitch`` (rows along x, one point at
    the origin) whose lenslets of ``diameter`` lie wholly in the annulus between the
    ``clear_zone`` and ``zone`` diameters."""
    a = diameter / 2
    rows = int(math.ceil(zone / (pitch * math.sqrt(3) / 2))) + 1
    cols = int(math.ceil(zone / pitch)) + 2
    j, i = np.meshgrid(np.arange(-rows, rows + 1), np.arange(-cols, cols + 1), indexing="ij")
    x = (i + 0.5 * (j % 2)) * pitch
    y = j * pitch * math.sqrt(3) / 2
    r = np.hypot(x, y)
    keep = (r - a >= clear_zone / 2 - 1e-12) & (r + a <= zone / 2 + 1e-12)
    return np.stack([x[keep], y[keep]], -1)


def ring_counts(ring_diameters, diameter: float, per_ring=None) -> list:
    """Lenslets on each ring of :func:`rings` (``per_ring``, or as many as fit
    contiguously: chord >= ``diameter``)."""
    if per_ring is not None:
        return [int(n) for n in per_ring]
    return [int(math.floor(math.pi / math.asin(min(1.0, diameter / dr)) + 1e-9))
            if dr / 2 > diameter / 2 else 1 for dr in ring_diameters]


def check_count(n: int, key: str, advice: str) -> None:
    """Refuse, naming ``key``, a layout of more than :data:`MAX_LENSLETS` lenslets
    (``advice``: what to change)."""
    if n > MAX_LENSLETS:
        raise SpecError(key, f"lays {n:,} lenslets; at most {MAX_LENSLETS:,} (5 x the 1,021 "
                        f"of the densest design in production): {advice}")


def rings(ring_diameters, diameter: float, per_ring=None) -> np.ndarray:
    """(n, 2) centres (m) on concentric rings of ``ring_diameters`` (m), each ring's
    lenslets evenly spaced from the +x axis (alternate rings turned by half a step):
    ``per_ring`` counts, or as many as fit contiguously (chord >= ``diameter``)."""
    out = []
    counts = ring_counts(ring_diameters, diameter, per_ring)
    for k, (dr, n) in enumerate(zip(ring_diameters, counts, strict=True)):
        r = dr / 2
        phase = 0.5 * (k % 2)
        t = 2 * math.pi * (np.arange(n) + phase) / n
        out.append(np.stack([r * np.cos(t), r * np.sin(t)], -1))
    return np.concatenate(out) if out else np.zeros((0, 2))


def check_layout(centres, diameter: float, lens_diameter: float, key: str) -> None:
    """Refuse, naming ``key``, lenslets that overlap or reach beyond the lens."""
    centres = np.asarray(centres, float)
    if len(centres) == 0:
        raise SpecError(key, "the layout holds no lenslet: widen the zone or narrow the "
                             "clear zone")
    a = diameter / 2
    far = np.hypot(centres[:, 0], centres[:, 1]) + a
    if far.max() > lens_diameter / 2 + 1e-12:
        raise SpecError(key, f"a lenslet reaches {far.max() * 1e3:.2f} mm from the centre, "
                             f"beyond the {lens_diameter * 1e3:g} mm lens")
    if len(centres) > 1:
        d, _ = cKDTree(centres).query(centres, k=2)
        gap = d[:, 1].min()
        if gap < 2 * a - TOUCH_TOL:
            raise SpecError(key, f"lenslets overlap: centres {gap * 1e3:.3f} mm apart, less "
                                 f"than their {diameter * 1e3:g} mm diameter")


# ---------------------------------------------------------------------------- design
def with_lenslets(lens, centres, diameter: float, add_d: float, conic: float = 0.0, *,
                  eye=None, wavelength_nm: float = 587.56):
    """``lens`` with lenslets of ``diameter`` (m) at ``centres`` (n, 2; m) on its front,
    each designed to add ``add_d`` (D) as worn (:func:`design_lenslets`)."""
    n = lens.material.n(wavelength_nm)
    guess = np.full(len(centres), add_d / (n - 1.0))
    surf = LensletSurface(lens.front, centres, diameter / 2, guess, conic, add_d)
    trial = dataclasses.replace(lens, front=surf)
    return designed(trial, eye, wavelength_nm)


#: The disk cache's namespace of lenslet designs (:mod:`eyelab.core.diskcache`).
DESIGN_NAMESPACE = "lenslet-design"


def designed(trial, eye, wavelength_nm: float):
    """:func:`design_lenslets` of ``trial``, read from the disk cache when this lens, eye
    and wavelength were designed before (the curvatures bit for bit; a HALT-like lens's
    1,021 lenslets take seconds), else designed and stored."""
    from pathlib import Path

    from eyelab.core import diskcache
    from eyelab.core.cache import complete_key

    key = complete_key(lens=trial, eye=eye, wavelength=wavelength_nm)
    if key is None:
        return design_lenslets(trial, eye, wavelength_nm=wavelength_nm)
    arrays, _, _ = diskcache.fetch(
        DESIGN_NAMESPACE, {"lens_eye": key, "numpy": np.__version__},
        lambda: ({"delta_curvature": design_lenslets(
            trial, eye, wavelength_nm=wavelength_nm).front.delta_curvature}, {}),
        code=(Path(__file__).parent, Path(diskcache.__file__).parent))
    return dataclasses.replace(trial, front=trial.front.with_curvature(
        arrays["delta_curvature"]))


def lenslet_adds(lens, eye, wavelength_nm: float = 587.56) -> np.ndarray:
    """(n,) each lenslet's add as worn (D): the mean power of the wave at the vertex
    sphere along the line of sight through its centre, less the carrier's on the same
    line (objects at infinity; the eye turning about its centre of rotation)."""
    from eyelab.optics.chain.analysis import analyze_points
    from eyelab.optics.lens.asworn import lines_of_sight_through, objects_on_lines_of_sight

    surf = lens.front
    lines = lines_of_sight_through(eye, lens, surf.centres, wavelength_nm)
    powers = []
    for ln in (lens, carrier(lens)):
        objects, _ = objects_on_lines_of_sight(eye, ln, lines, 0.0, wavelength_nm)
        res = analyze_points(eye, ln, objects, wavelength_nm=wavelength_nm,
                             fixation="rotating")
        k11, _, k22 = res.wave_vertex_sphere.in_basis(res.eye_x)
        powers.append(0.5 * (k11 + k22))
    return powers[0] - powers[1]


def design_lenslets(lens, eye=None, *, wavelength_nm: float = 587.56):
    """``lens`` (its front a :class:`LensletSurface`) with each lenslet's dC set so that its
    add as worn (:func:`lenslet_adds`) is the surface's ``add_d`` within
    :data:`DESIGN_TOL` (secant iterations, all lenslets at once; ``eye``: a thin eye's
    centre of rotation, the default eye's when None)."""
    from eyelab.optics.eye.thin import Eye

    eye = Eye() if eye is None else eye
    surf = lens.front
    target = surf.add_d
    c0 = surf.delta_curvature.copy()
    a0 = lenslet_adds(lens, eye, wavelength_nm)
    c1 = c0 * (target / np.where(a0 != 0, a0, 1.0))
    for _ in range(DESIGN_ITER):
        lens = dataclasses.replace(lens, front=surf.with_curvature(c1))
        a1 = lenslet_adds(lens, eye, wavelength_nm)
        if np.abs(a1 - target).max() < DESIGN_TOL:
            break
        slope = np.where(np.abs(c1 - c0) > 0, (a1 - a0) / np.where(np.abs(c1 - c0) > 0,
                                                                   c1 - c0, 1.0), 1.0)
        c0, a0, c1 = c1, a1, c1 + (target - a1) / slope
    return lens


# ---------------------------------------------------------------------------- beams
#: Front-surface samples across a beam's footprint (:func:`beam_lenslets`).
BEAM_GRID = 160
#: The footprint's sampled square: this many pupil radii about the chief ray's entry.
BEAM_MARGIN = 1.5


def beam_lenslets(lens, objects, i: int, pupil, axis, pupil_radius: float,
                  wavelength_nm: float = 587.56, grid: int = BEAM_GRID, entry=None) -> dict:
    """Which part of the light from object ``i`` of ``objects``
    (:class:`~eyelab.optics.rays.paths.ObjectPoints`) entering a pupil of ``pupil_radius``
    (m) centred at ``pupil`` (3,) across ``axis`` (3,, into the eye) passes lenslets. The
    light falls evenly on the lens's front (a distant object; a near one's irradiance
    varies by under (footprint / distance)^2 across it): rays from the object to a square
    grid of front-surface points (:data:`BEAM_GRID` across :data:`BEAM_MARGIN` pupil
    radii about the chief ray's entry), traced through the lens; those that enter the
    pupil are the beam's footprint, each carrying the light of its grid cell (so a plus
    lenslet's converging pencil counts all its light, though it fills less of the pupil).

    ``entry`` (3,): where the chief ray meets the front surface (world), when the caller
    has traced it (e.g. through the carrier: the grid's centre only); else found here.

    Returns {"fraction": of the beam's light through lenslets; "lenslets": the indices
    met; "rays": the footprint's samples}."""
    from eyelab.core.vecmath import unit
    from eyelab.optics.rays.paths import ObjectPoints, find_chief_rays

    surf = lens.front
    axis = unit(np.asarray(axis, float)[None])[0]
    pupil = np.asarray(pupil, float)
    one = ObjectPoints(objects.direction[i:i + 1], objects.distance[i:i + 1])
    if entry is None:
        entry = find_chief_rays(lens, pupil, one, wavelength_nm).entry[0]
    front, _ = lens.placed_surfaces()
    centre = (np.asarray(entry, float) - front.translation) @ front.rotation
    half = BEAM_MARGIN * pupil_radius * max(1.0, 1.0 / max(abs(axis[2]), 0.3))
    c = (np.arange(grid) + 0.5) / grid * 2 - 1
    gx, gy = np.meshgrid(centre[0] + half * c, centre[1] + half * c)
    gx, gy = gx.ravel(), gy.ravel()
    local = np.stack([gx, gy, surf.sag(gx, gy)], -1)
    on_front = local @ front.rotation.T + front.translation
    if one.finite[0]:
        start = one.positions()[0]
        d = unit(on_front - start)
        origins = on_front - 1e-3 * d
    else:
        d = np.broadcast_to(-one.direction[0], on_front.shape)
        origins = on_front - 1e-3 * d
    r = lens.trace(origins, np.ascontiguousarray(d), wavelength_nm)
    ok = (r["status"] & np.uint8(FATAL)) == 0
    q, u = r["out_points"], r["out_dirs"]
    s = ((pupil - q) @ axis) / (u @ axis)
    at = q + s[:, None] * u - pupil
    inside = ok & (np.sum(at * at, axis=1) - (at @ axis) ** 2 <= pupil_radius ** 2)
    idx = surf.which(gx, gy)
    through = inside & (idx >= 0)
    return {"fraction": float(through.sum() / max(inside.sum(), 1)),
            "lenslets": sorted(int(v) for v in np.unique(idx[through])),
            "rays": int(inside.sum())}


# ---------------------------------------------------------------------------- areas
def circle_overlap(d, r1, r2) -> np.ndarray:
    """Area (m^2) of the intersection of circles of radii r1, r2 with centres d apart."""
    d, r1, r2 = np.broadcast_arrays(np.asarray(d, float), np.asarray(r1, float),
                                    np.asarray(r2, float))
    out = np.zeros(d.shape)
    inside = d <= np.abs(r1 - r2)
    out[inside] = math.pi * np.minimum(r1, r2)[inside] ** 2
    part = ~inside & (d < r1 + r2)
    dd, a, b = d[part], r1[part], r2[part]
    alpha = np.arccos(np.clip((dd * dd + a * a - b * b) / (2 * dd * a), -1, 1))
    beta = np.arccos(np.clip((dd * dd + b * b - a * a) / (2 * dd * b), -1, 1))
    out[part] = a * a * (alpha - np.sin(2 * alpha) / 2) + b * b * (beta - np.sin(2 * beta) / 2)
    return out


def lenslet_fraction(surf: LensletSurface, centre, radius: float) -> float:
    """The fraction of a disc of ``radius`` (m) about ``centre`` (x, y; m, lens frame) that
    lies in lenslets: the exact area of its overlaps with their circles (they do not
    overlap one another) over its own."""
    c = np.asarray(centre, float)
    d = np.hypot(surf.centres[:, 0] - c[0], surf.centres[:, 1] - c[1])
    return float(circle_overlap(d, radius, surf.radius).sum() / (math.pi * radius ** 2))


__all__ = ["LAYOUTS", "LIMITS", "LensletSurface", "beam_lenslets", "carrier", "check_layout",
           "circle_overlap",
           "design_lenslets", "honeycomb", "lenslet_adds", "lenslet_fraction",
           "rings", "with_lenslets"]
