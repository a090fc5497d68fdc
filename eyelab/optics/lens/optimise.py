"""As-worn optimisation of a progressive lens's free-form front surface.

Industry designs progressive lenses by optimisation: a free-form surface described by
spline coefficients, and a merit function summing weighted squared differences between
the power the wearer receives and a target power over a grid of gaze directions, with a
model eye in place (J. Alonso, J. A. Gómez-Pedrero & J. A. Quiroga, *Modern Ophthalmic
Optics*, Cambridge 2019, ch. 8; J. Loos, G. Greiner & H.-P. Seidel, "A variational
approach to progressive lens design", *Computer-Aided Design* 30:595 (1998)). Here:

* **Variables**: a tensor-product cubic B-spline correction added to the analytic
  design's front (:mod:`eyelab.optics.lens.progressive`), uniform knots over the lens's square
  (``knots`` intervals a side: (knots + 3)^2 coefficients, 256 by default). Its value and
  slope at the fitting cross are removed (a gauge: they move the lens, not its powers).
  The front, not the back, because the analytic design and its reference points live
  there and the back stays the prescription's sphere or toric, as a semi-finished blank's.
* **Merit**: per gaze k, the as-worn power error E_k = K_k - O_k - (F + add f_k) — the
  vertex-sphere wave's curvature matrix K, the object's vergence O, the distance
  prescription F and the share f_k of the add the design asks for at the point where the
  line of sight leaves the front (the corridor's smoothstep in height) — exactly as the
  maps compute it (:func:`eyelab.optics.chain.analysis.power_error`: real chief rays and
  generalised-Coddington pencils through the worn lens, the eye rotating about its
  centre, the object on the line of sight at vergence 2.5 D x f_k). Residuals:
  sqrt(w_M) x mean(E) and sqrt(w_C) x (E11 - E22) / 2, sqrt(w_C) x E12 (the cylinder's
  power-vector components: unwanted cylinder = 2 |(J0, J45)|) — so the merit is the
  weighted sum of squared mean-power errors plus a quarter of the squared cylinders. The
  weights (:data:`PRESETS`) are 1 in the distance zone, along the corridor and in the
  near zone (reference points x :data:`REFERENCE_WEIGHT`) and fall to the preset's
  periphery weights beside them: a soft design lets the periphery's cylinder count more,
  spreading it; a hard one keeps wider clear zones and lets the periphery take it. A
  smoothness term (second differences of the coefficients) keeps the correction smooth
  where no gaze looks.
* **Solver**: Levenberg-Marquardt on the exact residuals. The Jacobian is a model: a
  change dz of the front changes the wave the eye receives, to first order, by
  (n - 1) x the Hessian of dz at the point where the line of sight crosses the front
  (the thin-prism shift of the path is second order) — a sparse map from the 16 B-spline
  coefficients about each crossing. Steps are taken only when the exact merit falls, so
  it decreases monotonically whatever the model's error (tested against finite
  differences of the exact residuals: ``tests/test_optimise.py``), and the result is
  deterministic (no random starts).
* **Cache**: being deterministic, a design is optimised once per machine
  (:func:`optimised_progressive`): kept in memory, and on disk as its coefficients
  (:mod:`eyelab.core.diskcache`), from which :func:`corrected_lens` rebuilds the lens
  bit for bit in any later process.
"""

from __future__ import annotations

import dataclasses
import threading
import time

import numpy as np
from scipy.interpolate import BSpline

from eyelab.core.errors import SpecError

#: Design presets: periphery weights of the mean-power and cylinder residuals (the zones'
#: are 1), the distance zone's half-width (mm) and the near zone's (mm).
PRESETS = {
    "soft": {"mean_periphery": 0.05, "cylinder_periphery": 0.10, "distance_half_width_mm": 14.0,
             "near_half_width_mm": 5.0},
    "hard": {"mean_periphery": 0.02, "cylinder_periphery": 0.07, "distance_half_width_mm": 22.0,
             "near_half_width_mm": 8.0},
}
#: The spec's ``lens.optimise`` values: the analytic design, or a preset's optimisation.
OPTIMISE_CHOICES = ("none", *PRESETS)

#: Extra weight on gazes within 1.5 mm of the distance and near reference points.
REFERENCE_WEIGHT = 100.0
#: Weight of the lines of sight down the corridor's path (every 1 mm; the grid's gazes
#: cross the 2 mm-wide corridor only here and there).
CORRIDOR_WEIGHT = 40.0
#: The near object's vergence (D) the full add is for (0.4 m), as the maps' model.
NEAR_VERGENCE_D = 2.5
#: Smoothness weight (D per unit second difference of the coefficients, in power units).
SMOOTHNESS = 0.05


@dataclasses.dataclass(frozen=True)
class Settings:
    """The optimiser's grid and stopping rule: gazes on an n x n grid of Fick angles within
    +-half_angle_deg plus lines of sight down the corridor every 1 mm; B-spline knot
    intervals a side; at most max_iterations LM steps; stop when an accepted step lowers
    the merit by less than tolerance (relative)."""

    preset: str = "soft"
    half_angle_deg: float = 40.0
    n: int = 29
    knots: int = 17
    max_iterations: int = 40
    tolerance: float = 1e-4

    def __post_init__(self):
        if self.preset not in PRESETS:
            raise SpecError("lens.optimise", f"must be one of {', '.join(map(repr, PRESETS))}"
                                             f" to optimise, got {self.preset!r}")


def _basis(t, k, x, nu=0):
    """(len(x), n_coefficients) values of the B-spline basis (or its ``nu``-th
    derivative) at x."""
    nc = len(t) - k - 1
    return BSpline(t, np.eye(nc), k, extrapolate=False)(x, nu=nu)


class Correction:
    """The cubic tensor B-spline correction over the square of side ``diameter`` (m):
    coefficients c (nc, nc) in "power units" (a unit coefficient bends the front by
    roughly 1 D: scaled by h^2 / (n - 1), h the knot spacing)."""

    def __init__(self, diameter: float, knots: int, index: float):
        r = diameter / 2
        self.h = diameter / knots
        self.t = np.concatenate([[-r] * 3, np.linspace(-r, r, knots + 1), [r] * 3])
        self.nc = knots + 3
        self.scale = self.h ** 2 / (index - 1.0)
        z0 = [_basis(self.t, 3, np.zeros(1), nu)[0] for nu in (0, 1)]
        self._origin = z0            # basis values and slopes at 0 (the gauge)

    def sag(self, c, gx, gy) -> np.ndarray:
        """The correction's sag (m) on the grid axes gx (nx,), gy (ny,) -> (ny, nx), with
        its value and slope at the origin removed."""
        c = np.asarray(c, float).reshape(self.nc, self.nc) * self.scale   # [j (y), i (x)]
        bx, by = _basis(self.t, 3, gx), _basis(self.t, 3, gy)
        z = by @ c @ bx.T
        (b0, b1) = self._origin
        v = b0 @ c @ b0
        sx, sy = b0 @ c @ b1, b1 @ c @ b0
        return z - v - sx * gx[None, :] - sy * gy[:, None]

    def hessian_rows(self, x, y) -> tuple:
        """(3, m, nc^2) d(z_xx, z_xy, z_yy)/d(coefficient) at points (x, y) (m,), times
        (n - 1): powers (D) per unit coefficient (the gauge has no curvature)."""
        bx = [_basis(self.t, 3, x, nu) for nu in (0, 1, 2)]
        by = [_basis(self.t, 3, y, nu) for nu in (0, 1, 2)]
        f = self.h ** 2               # (n - 1) x scale
        rows = [by[0][:, :, None] * bx[2][:, None, :], by[1][:, :, None] * bx[1][:, None, :],
                by[2][:, :, None] * bx[0][:, None, :]]
        return tuple(np.nan_to_num(r.reshape(len(x), -1)) * f for r in rows)

    def smoothness(self) -> np.ndarray:
        """Rows of second differences of the coefficient grid along x and y."""
        n = self.nc
        d2 = np.diff(np.eye(n), 2, axis=0)                 # (n - 2, n)
        eye = np.eye(n)
        return np.vstack([np.kron(eye, d2), np.kron(d2, eye)])


def _path_x(y_mm, design) -> np.ndarray:
    """The design's corridor x = u(y) (mm) at heights y (mm)."""
    from eyelab.optics.lens.progressive import _path_terms

    return _path_terms(np.asarray(y_mm, float) * 1e-3, design)[1] * 1e3


def add_share(y_mm, design) -> np.ndarray:
    """The share of the add asked for at lens height y (mm): the corridor's smoothstep,
    0 above the fitting cross, 1 from the corridor's foot down."""
    from eyelab.optics.lens.progressive import _smooth

    return _smooth(-np.asarray(y_mm, float) * 1e-3 / design.corridor)


def weights(x_mm, y_mm, design, preset: str) -> tuple:
    """(w_mean, w_cylinder) (m,) for gazes leaving the front at (x, y) (mm): 1 in the
    zones (the distance zone above the fitting cross within the preset's half-width, the
    corridor 1 mm either side of its path widening to the near zone's half-width at its
    foot), the preset's periphery weights elsewhere, smooth in between; x
    REFERENCE_WEIGHT within 1.5 mm of the reference points."""
    p = PRESETS[preset]
    x, y = np.asarray(x_mm, float), np.asarray(y_mm, float)
    up = 1.0 / (1.0 + np.exp(-(y - 1.0) / 1.0))
    dist = up * np.exp(-(x / p["distance_half_width_mm"]) ** 4)
    half = 1.0 + (p["near_half_width_mm"] - 1.0) * add_share(y, design)
    corr = (1.0 - up) * np.exp(-(((x - _path_x(y, design)) / half) ** 4))
    zone = np.maximum(dist, corr)
    ref = np.ones_like(x)
    for px, py in (design.distance_point, design.near_point):
        ref += (REFERENCE_WEIGHT - 1.0) * (np.hypot(x - px * 1e3, y - py * 1e3) < 1.5)
    wm = (p["mean_periphery"] + (1.0 - p["mean_periphery"]) * zone) * ref
    wc = (p["cylinder_periphery"] + (1.0 - p["cylinder_periphery"]) * zone) * ref
    return wm, wc


def _corrected(lens, design, corr: Correction, c):
    """The analytic ``lens`` with the correction ``c`` added to its front's sag grid: the
    one path from coefficients to a lens (the optimiser's and the disk cache's)."""
    from eyelab.optics.lens.progressive import _with_front
    from eyelab.optics.rays.surfaces import FreeForm

    f = lens.front
    front = FreeForm(f.x, f.y, f.z + corr.sag(c, f.x, f.y))
    return _with_front(lens, front, lens.rx, design)


def corrected_lens(lens, design, coefficients, *, knots: int,
                   wavelength_nm: float = 587.56):
    """The analytic progressive ``lens`` of ``design`` with the optimiser's ``coefficients``
    ((knots + 3)^2,) — ``report["coefficients"]`` of :func:`optimise_progressive` run with
    the same ``knots`` and wavelength (nm) — applied: the optimised lens, bit for bit."""
    corr = Correction(lens.diameter, knots, lens.material.n(wavelength_nm))
    return _corrected(lens, design, corr, np.asarray(coefficients, float))


class _Problem:
    """The fixed gazes, targets and weights, and the exact residual of a coefficient
    vector (one lens built and traced per call)."""

    def __init__(self, lens, design, settings: Settings, wavelength_nm: float):
        from eyelab.optics.eye.thin import Eye
        from eyelab.optics.lens import asworn
        from eyelab.optics.lens.figures import front_points

        self.base, self.design, self.wl = lens, design, wavelength_nm
        self.eye = Eye()
        self.n_index = lens.material.n(wavelength_nm)
        front = lens.front
        self.gx, self.gy, self.z0 = front.x, front.y, front.z
        self.corr = Correction(lens.diameter, settings.knots, self.n_index)
        g = np.linspace(-settings.half_angle_deg, settings.half_angle_deg, settings.n)
        ax, ay = np.meshgrid(g, g)
        lines = [asworn.fick_lines(ax, ay)]
        # lines of sight down the corridor, every 1 mm from the distance reference point
        for y in np.arange(design.distance_point[1] * 1e3, design.near_point[1] * 1e3 - 4.0,
                           -1.0):
            pt = (float(_path_x(y, design)) * 1e-3, y * 1e-3)
            lines.append(asworn.line_of_sight_through(self.eye, lens, pt, wavelength_nm)[None])
        lines = np.concatenate(lines)
        fa, fe = asworn.fick_angles(lines)
        fx, fy = front_points(self.eye, lens, fa, fe, wavelength_nm)
        keep = np.isfinite(fx)
        self.lines, self.x_mm, self.y_mm = lines[keep], fx[keep], fy[keep]
        self.n_corridor = int(np.sum(keep[len(ax.ravel()):]))
        self.share = add_share(self.y_mm, design)
        self.vergence = NEAR_VERGENCE_D * self.share
        wm, wc = weights(self.x_mm, self.y_mm, design, settings.preset)
        on_path = np.arange(len(wm)) >= len(wm) - self.n_corridor
        wm, wc = (np.where(on_path, CORRIDOR_WEIGHT * w, w) for w in (wm, wc))
        self.sw = np.sqrt(np.concatenate([wm, wc, wc]))
        self.smooth = SMOOTHNESS * self.corr.smoothness()
        self.evaluations = 0

    def lens(self, c):
        """The lens with the corrected front."""
        return _corrected(self.base, self.design, self.corr, c)

    def errors(self, lens) -> tuple:
        """(E11, E12, E22, front hit x, y (m)) per gaze, the as-worn power error (D) in the
        wave's (eye x, y) frame; NaN where a line of sight has no path."""
        from eyelab.optics.chain.analysis import analyze_points, power_error_matrix
        from eyelab.optics.lens import asworn

        objects, ok = asworn.objects_on_lines_of_sight(self.eye, lens, self.lines,
                                                       self.vergence, self.wl)
        res = analyze_points(self.eye, lens, objects, wavelength_nm=self.wl,
                             fixation="rotating")
        self.evaluations += 1
        e = [np.where(ok, v, np.nan) for v in power_error_matrix(res, lens.rx, objects,
                                                                  self.share)]
        front, _ = lens.placed_surfaces()
        local = (res.chief.entry - np.asarray(front.translation)) @ np.asarray(front.rotation)
        return (*e, local[:, 0], local[:, 1])

    def residual(self, c) -> tuple:
        """(r, lens, hits): the weighted residual vector (mean, J0, J45 blocks, then the
        smoothness rows), the lens, and the front hits (x, y, m) for the model Jacobian."""
        lens = self.lens(c)
        e11, e12, e22, hx, hy = self.errors(lens)
        r = np.concatenate([(e11 + e22) / 2, (e11 - e22) / 2, e12])
        r = np.nan_to_num(r * self.sw, nan=0.0)
        return np.concatenate([r, self.smooth @ c]), lens, (hx, hy)

    def jacobian(self, hits) -> np.ndarray:
        """The model Jacobian (module text): d residual / d coefficient."""
        hxx, hxy, hyy = self.corr.hessian_rows(*hits)
        j = np.vstack([(hxx + hyy) / 2, (hxx - hyy) / 2, hxy]) * self.sw[:, None]
        return np.vstack([j, self.smooth])


def optimise_progressive(lens, design, *, settings: Settings | None = None,
                         wavelength_nm: float = 587.56, progress=None) -> tuple:
    """The as-worn optimised lens from the analytic progressive ``lens`` of ``design``
    (module text). Returns (lens, report): the report has the merit per iteration (exact,
    strictly decreasing over accepted steps), the number of variables, gazes, exact
    evaluations, and the seconds taken."""
    settings = settings or Settings()
    t0 = time.perf_counter()
    prob = _Problem(lens, design, settings, wavelength_nm)
    nv = prob.corr.nc ** 2
    c = np.zeros(nv)
    r, cur, hits = prob.residual(c)
    merit = float(r @ r)
    history = [{"merit": merit, "accepted": True, "damping": None}]
    mu = None
    for _ in range(settings.max_iterations):
        j = prob.jacobian(hits)
        jtj, g = j.T @ j, j.T @ r
        if mu is None:
            mu = 1e-3 * float(np.max(np.diag(jtj)))
        improved = False
        for _ in range(12):
            step = np.linalg.solve(jtj + mu * np.eye(nv), -g)
            r2, lens2, hits2 = prob.residual(c + step)
            m2 = float(r2 @ r2)
            if np.isfinite(m2) and m2 < merit:
                improved = True
                drop = (merit - m2) / merit
                c, r, cur, hits, merit = c + step, r2, lens2, hits2, m2
                mu = max(mu / 3.0, 1e-12)
                history.append({"merit": merit, "accepted": True, "damping": mu})
                break
            mu *= 4.0
            history.append({"merit": m2, "accepted": False, "damping": mu})
        if progress is not None:
            progress(len(history), merit)
        if not improved or drop < settings.tolerance:
            break
    accepted = [h["merit"] for h in history if h["accepted"]]
    report = {"preset": settings.preset, "variables": nv, "gazes": len(prob.lines),
              "corridor_gazes": prob.n_corridor, "knot_spacing_mm": prob.corr.h * 1e3,
              "half_angle_deg": settings.half_angle_deg, "grid": settings.n,
              "iterations": len(accepted) - 1, "evaluations": prob.evaluations,
              "merit_start": accepted[0], "merit_end": accepted[-1], "merit": accepted,
              "history": history, "seconds": time.perf_counter() - t0,
              "coefficients": c}
    return cur, report


_DESIGNS = None
_ORIGINS = None
_CACHES_LOCK = threading.Lock()


def _caches() -> tuple:
    """The process's LRU caches of optimised designs (by the analytic lens's key) and of
    their origins (by the optimised front's), made on first use (under a lock: threads
    share them)."""
    global _DESIGNS, _ORIGINS
    from eyelab.core.cache import LRUCache

    with _CACHES_LOCK:
        if _DESIGNS is None:
            _DESIGNS = LRUCache(8, "optimised designs")
        if _ORIGINS is None:
            _ORIGINS = LRUCache(8, "design origins")
        return _DESIGNS, _ORIGINS


#: The disk cache's namespace of optimised designs (:mod:`eyelab.core.diskcache`).
CACHE_NAMESPACE = "progressive-design"


def optimised_progressive(rx, add: float, preset: str, *, settings: Settings | None = None,
                          **kw) -> tuple:
    """The progressive lens of :func:`eyelab.optics.lens.progressive.progressive_lens` (same
    arguments), optimised as worn with the ``preset``'s weights (``settings``: the
    optimiser's grid and stopping rule, default :class:`Settings`; its preset is
    ``preset``): (lens, design, report).

    The optimiser takes seconds, so its result is kept twice, keyed by the analytic lens's
    content (built first: a tenth of a second), the settings and the wavelength — every
    spec that makes the same lens, whatever its wording, shares one optimisation: in a
    process-wide LRU cache (specs are parsed again by the inspector, the demo and batch
    jobs), and on disk (:mod:`eyelab.core.diskcache`: the coefficients and the report,
    so a new process rebuilds the lens bit for bit through :func:`corrected_lens`).
    ``report["optimised"]["source"]`` says where this call's design came from:
    "computed", "memory" or "disk"; ``["cache"]`` is the disk cache's
    :class:`~eyelab.core.diskcache.Status` (its entry's path, or why it was not used)."""
    from eyelab.core.cache import content_key
    from eyelab.optics.lens.progressive import progressive_lens

    designs, origins = _caches()
    settings = dataclasses.replace(settings or Settings(), preset=preset)
    lens, design, report = progressive_lens(rx, add, **kw)
    wl = kw.get("wavelength_nm", 587.56)
    # every part by its whole content (dataclasses field by field, never a repr: reprs
    # are for reading, rounded — two lenses must not share a design's key)
    parts = dict(front=lens.front.content_key, back=lens.back,
                 thickness=lens.center_thickness, diameter=lens.diameter,
                 material=lens.material, pose=lens.pose,
                 rx=[lens.rx.sphere, lens.rx.cylinder, lens.rx.axis, lens.rx.add],
                 design=design, settings=settings, wavelength_nm=wl)
    key = content_key(**parts)
    hit = designs.get(key)
    if hit is None:
        opt, rep, status = _design_from_disk_or_optimiser(lens, design, settings, wl, parts)
        designs.put(key, (opt, rep, status))
        origins.put(opt.front.content_key, dict(status.to_json(), seconds=rep["seconds"],
                                                 preset=preset))
        source = status.source
    else:
        (opt, rep, status), source = hit, "memory"
    report = dict(report, optimised=dict(rep, source=source, cache=status.to_json()))
    return opt, design, report


def _design_from_disk_or_optimiser(lens, design, settings, wl, parts) -> tuple:
    """(optimised lens, report without history and coefficients, disk cache status)."""
    from pathlib import Path

    import scipy

    from eyelab.core import diskcache

    made = {}

    def compute():
        opt, rep = optimise_progressive(lens, design, settings=settings, wavelength_nm=wl)
        made["lens"] = opt
        return ({"coefficients": rep["coefficients"]},
                {k: v for k, v in rep.items() if k not in ("history", "coefficients")})

    # the code that computes a design: this package and the core (an edited optimiser in
    # an editable install misses); numpy's and scipy's versions (their last bits)
    code = (Path(__file__).parent, Path(diskcache.__file__).parent)
    arrays, rep, status = diskcache.fetch(
        CACHE_NAMESPACE, dict(parts, numpy=np.__version__, scipy=scipy.__version__),
        compute, code=code)
    opt = made.get("lens")
    if opt is None:
        opt = corrected_lens(lens, design, arrays["coefficients"], knots=settings.knots,
                             wavelength_nm=wl)
    return opt, rep, status


def design_origin(lens) -> dict | None:
    """How this process got the optimised ``lens`` (one :func:`optimised_progressive`
    made, matched by its front's content) when it was not in memory: ``source``
    "computed" or "disk", ``path`` of the disk cache's entry, ``note`` (why the cache was
    not used, or what was wrong with its entry), ``seconds`` the optimiser took (then),
    ``preset``. None for a lens it did not make (or one its small cache has forgotten)."""
    if not hasattr(lens.front, "content_key"):
        return None
    return _caches()[1].get(lens.front.content_key)
