"""Progressive addition lenses: a free-form front surface with an umbilic corridor.

The front surface is the single-vision design's sphere (curvature c0, base curve) plus a
progressive term, in lens-local coordinates (x to the wearer's right, y up, metres; the
fitting cross at the origin):

    z(x, y) = sphere(c0; x, y) + g(y) + a(y) q(x - u(y))

* a(y): the added curvature (1/m), add / (n - 1) times a quintic smoothstep s(t) of
  t = -y / corridor (0 at the fitting cross, 1 at the corridor's foot), constant beyond;
* u(y) = -inset s(t) for a right eye (the near zone moves nasally; +inset for a left eye);
* q(x') = the integral of the integral of exp(-x'^2 / (2 w^2)): q(0) = q'(0) = 0,
  q''(x') = exp(-x'^2 / 2w^2), so the added curvature across the corridor is a(y) on the
  umbilic line and fades to 0 beside it over the half-width w — the design's softness
  (a large w: a soft design with wide zones and gentle gradients; a small w: hard);
* g''(y) = a(y): along the line x = u(y) the added curvature is a(y) in both directions
  (an umbilic, to the first order in u'), and beside it the cross derivative
  z_xy = a'(y) q'(x') grows as a'(y) x': the cylinder rises twice as fast across the
  corridor as the power along it (Minkwitz's theorem, docs/SCIENCE.md §8).

The add is set on the as-worn near reference point by a short correction loop: the
power delivered there (the vertex-sphere wave for a near object, as `eyelab maps`
computes it) is compared with distance Rx + add, and a(y) rescaled.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.special import erf

from eyelab.core.checks import check_in
from eyelab.core.errors import SpecError
from eyelab.optics.rays.surfaces import Asphere, FreeForm

#: The design's ranges, by spec field (D; mm).
LIMITS = {"lens.add": (0.25, 4.0), "lens.corridor_mm": (10.0, 22.0), "lens.inset_mm": (0.0, 5.0),
          "lens.softness_mm": (3.0, 30.0)}


@dataclass(frozen=True)
class ProgressiveDesign:
    """The design parameters (lengths in m): add (D), corridor (fitting cross to the top
    of the near zone), inset (nasal shift of the near zone), softness (lateral half-width
    w of the added power), near reference point 2 mm below the corridor's foot, distance
    reference point 4 mm above the fitting cross; eye "R" or "L" (which side is nasal)."""

    add: float
    corridor: float = 0.014
    inset: float = 0.0025
    softness: float = 0.008
    eye: str = "R"

    def __post_init__(self):
        check_in("lens.add", self.add, LIMITS)
        check_in("lens.corridor_mm", self.corridor * 1e3, LIMITS)
        check_in("lens.inset_mm", self.inset * 1e3, LIMITS)
        check_in("lens.softness_mm", self.softness * 1e3, LIMITS)
        if self.eye not in ("R", "L"):
            raise SpecError("lens.eye", f"must be 'R' or 'L', got {self.eye!r}")

    @property
    def near_point(self) -> tuple:
        """(x, y) of the near reference point on the lens, m."""
        return (self.nasal * self.inset, -self.corridor - 0.002)

    @property
    def distance_point(self) -> tuple:
        return (0.0, 0.004)

    @property
    def nasal(self) -> float:
        """+1 if the nose is toward +x (a left eye), -1 for a right eye."""
        return -1.0 if self.eye == "R" else 1.0


def _smooth(t):
    t = np.clip(t, 0.0, 1.0)
    return t ** 3 * (10.0 - 15.0 * t + 6.0 * t * t)


def progressive_sag(c0: float, a_max: float, design: ProgressiveDesign, x, y):
    """The front surface's sag (m) at lens points (x, y), m: the sphere S plus
    g(y) + b(y) x' + a(y) q(x'), x' = x - u(y); g and b make the corridor x = u(y) an
    umbilic of the whole surface (:func:`corridor_profiles`)."""
    y = np.asarray(y, float)
    s = _smooth(-y / design.corridor)
    a = a_max * s
    u = design.nasal * design.inset * s
    w = design.softness
    xp = np.asarray(x, float) - u
    q = xp * w * math.sqrt(math.pi / 2) * erf(xp / (w * math.sqrt(2))) \
        + w * w * (np.exp(-xp ** 2 / (2 * w * w)) - 1.0)
    yy = np.minimum(np.broadcast_to(y, xp.shape), 0.0)
    end = -math.ceil(-float(np.min(yy, initial=0.0)) * 1e3 + 1.0) * 1e-3   # whole mm below
    g, _, b = corridor_profiles(c0, a_max, design, end)(yy.ravel()).reshape(3, *yy.shape)
    return Asphere(c0).sag(x, y) + g + b * xp + a * q


def _path_terms(y, design):
    """(s, u, u', u'') along the corridor at heights y (m): the smoothstep and the
    corridor's x = u(y) with its first two derivatives in y."""
    L, k = design.corridor, design.nasal * design.inset
    t = np.clip(-y / L, 0.0, 1.0)
    inside = (t > 0.0) & (t < 1.0)
    ds = np.where(inside, 30.0 * t * t * (1.0 - t) ** 2, 0.0)
    d2s = np.where(inside, 60.0 * t * (1.0 - t) * (1.0 - 2.0 * t), 0.0)
    return _smooth(t), k * _smooth(t), -k * ds / L, k * d2s / (L * L)


@functools.lru_cache(maxsize=16)
def corridor_profiles(c0: float, a_max: float, design: ProgressiveDesign, end: float = -0.04):
    """g(y), g'(y), b(y) below the fitting cross (``end`` <= y <= 0, m) as one dense solution
    (callable: y -> (3, ...) array) of the ODE that keeps the corridor umbilic.

    The surface's Hessian H must be proportional to its metric G = I + grad z grad z^T
    (the second fundamental form a multiple of the first: equal principal curvatures).
    On x' = 0, with S the sphere's derivatives at (u, y): H_xx = S_xx + a,
    H_xy = S_xy - u' a + b', H_yy = S_yy + u'^2 a - u'' b - 2 u' b' + g'', and the slopes
    z_x = S_x + b, z_y = S_y - u' b + g'. H_xy / H_xx = G_xy / G_xx and
    H_yy / H_xx = G_yy / G_xx give b' and g'' — an exact umbilic, not only to first order
    in the slopes (for u = 0 and no sphere this is g'' = a, b = 0). Integrated downward
    from g = g' = b = 0 at the fitting cross (DOP853, rtol 1e-12), through the corridor
    and on below its foot, where the near zone's centre line stays umbilic too."""
    from scipy.integrate import solve_ivp

    L, k = design.corridor, design.nasal * design.inset

    def rhs(y, state):
        # scalar closed forms (the solver calls this thousands of times): the smoothstep
        # and its derivatives in t; the sphere's slopes c x / q and Hessian
        # c / q + c^3 x x^T / q^3, q = sqrt(1 - c^2 r^2)
        g, gp, b = state
        t = min(max(-y / L, 0.0), 1.0)
        s = t ** 3 * (10.0 - 15.0 * t + 6.0 * t * t)
        up = -k * 30.0 * t * t * (1.0 - t) ** 2 / L
        upp = k * 60.0 * t * (1.0 - t) * (1.0 - 2.0 * t) / (L * L)
        u = k * s
        q = math.sqrt(1.0 - c0 * c0 * (u * u + y * y))
        c3 = c0 ** 3 / q ** 3
        a = a_max * s
        zx = c0 * u / q + b
        zy = c0 * y / q - up * b + gp
        gxx, gxy, gyy = 1.0 + zx * zx, zx * zy, 1.0 + zy * zy
        hxx = c0 / q + c3 * u * u + a
        bp = hxx * gxy / gxx - c3 * u * y + up * a
        gpp = hxx * gyy / gxx - (c0 / q + c3 * y * y) - up * up * a + upp * b + 2.0 * up * bp
        return [gp, gpp, bp]

    if c0 != 0.0:       # no further than the sphere reaches (beyond it the sag is NaN anyway)
        end = max(end, -0.99 / abs(c0) + design.inset)
    sol = solve_ivp(rhs, (0.0, end), [0.0, 0.0, 0.0], method="DOP853", rtol=1e-12,
                    atol=1e-15, dense_output=True)
    if sol.status != 0:                 # e.g. a NaN add scale from a missed line of sight
        raise SpecError("surface.sag", f"the corridor's profiles for added curvature "
                                       f"{a_max!r} /m: {sol.message}")
    return sol.sol


def progressive_lens(rx, add: float, *, material="cr39", design: ProgressiveDesign | None = None,
                     pose=None, diameter: float = 0.060, grid: int = 121, wavelength_nm=587.56,
                     iterations: int = 3):
    """A progressive lens for the distance prescription ``rx`` (its add, if any, must equal
    ``add``): the single-vision design for the distance power (:meth:`SpectacleLens.from_rx`)
    whose spherical front becomes the progressive free-form (sampled on a ``grid`` x
    ``grid`` quintic spline over the lens), with the added curvature rescaled until the
    as-worn power at the near reference point is distance + add. Returns (lens, design,
    report)."""
    from eyelab.optics.lens.spectacle import SpectacleLens

    design = design or ProgressiveDesign(add)
    if abs(design.add - add) > 1e-9:
        raise SpecError("lens.add", "the design's add differs from the prescription's")
    base = SpectacleLens.from_rx(rx.distance(), material=material, diameter=diameter,
                                 pose=pose)
    c0 = base.front.curvature
    n_l = base.material.n(wavelength_nm)
    a_max = add / (n_l - 1.0)
    g = np.linspace(-diameter / 2, diameter / 2, grid)
    gx, gy = np.meshgrid(g, g)
    report = {"iterations": []}
    lens = None
    for _ in range(iterations):
        front = FreeForm(g, g, progressive_sag(c0, a_max, design, gx, gy))
        # thicker where the added power thins the lens: keep the minimum edge
        lens = _with_front(base, front, rx, design)
        got = as_worn_add(lens, design, rx, wavelength_nm)
        report["iterations"].append({"a_max_per_m": a_max, "add_as_worn_d": got})
        if abs(got - add) < 0.005:
            break
        a_max *= add / got
    report["design"] = {"add_d": add, "corridor_mm": design.corridor * 1e3,
                        "inset_mm": design.inset * 1e3, "softness_mm": design.softness * 1e3,
                        "eye": design.eye, "near_point_mm": [v * 1e3 for v in design.near_point],
                        "distance_point_mm": [v * 1e3 for v in design.distance_point]}
    return lens, design, report


def _with_front(base, front, rx, design=None):
    from eyelab.optics.lens.spectacle import MIN_EDGE_THICKNESS, SpectacleLens

    th = np.linspace(0, 2 * np.pi, 181)
    r = base.diameter / 2
    x, y = r * np.cos(th), r * np.sin(th)
    edge = base.center_thickness - front.sag(x, y) + base.back.sag(x, y)
    t = base.center_thickness + max(0.0, MIN_EDGE_THICKNESS - float(np.nanmin(edge)))
    return SpectacleLens(front, base.back, t, base.material, base.diameter, base.pose,
                         rx, base.coating, design)


def gaze_through(lens, point, eye_rotation_centre=0.0135):
    """The unit gaze direction from the centre of rotation toward lens point (x, y) (m,
    on the front surface, lens frame)."""
    front, _ = lens.placed_surfaces()
    x, y = point
    p_local = np.array([x, y, float(front.surface.sag(np.array([x]), np.array([y]))[0])])
    p = np.asarray(front.rotation) @ p_local + np.asarray(front.translation)
    d = p - np.array([0.0, 0.0, eye_rotation_centre])
    return d / np.linalg.norm(d)


def as_worn_add(lens, design, rx, wavelength_nm=587.56, near_distance=0.4):
    """The as-worn add: mean power delivered along the gaze through the near reference
    point (object at ``near_distance`` m from the pupil) minus that through the distance
    reference point (object at infinity), by the maps' power error. The objects lie in
    the directions of the points from the centre of rotation (:func:`gaze_through`), so
    the lines of sight pass near, not through, them (the lens's prism); the maps instead
    aim the eye's line of sight through a point
    (:func:`eyelab.optics.lens.asworn.line_of_sight_through`)."""
    from eyelab.optics.chain.analysis import analyze_points, power_error
    from eyelab.optics.eye.thin import Eye
    from eyelab.optics.rays.paths import ObjectPoints

    eye = Eye()
    out = []
    for point, dist in ((design.distance_point, math.inf), (design.near_point, near_distance)):
        obj = ObjectPoints.along_gazes(gaze_through(lens, point, eye.rotation_centre), dist,
                                       eye.rotation_centre)
        res = analyze_points(eye, lens, obj, wavelength_nm=wavelength_nm, fixation="rotating")
        out.append(float(power_error(res, rx.distance(), obj)["mean_d"][0]))
    return out[1] - out[0]
