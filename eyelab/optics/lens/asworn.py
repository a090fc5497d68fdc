"""As-worn maps of a spectacle lens: what a lens designer reads first.

The maps are drawn over eye rotations, as lens designers draw them: the eye turns about
its centre of rotation behind the worn lens (Fick angles: azimuth to the wearer's right,
then elevation up, as ``render.gaze_deg``), so the grid point (a, e) is the line of sight
f = (cos e sin a, sin e, -cos e cos a) leaving the centre of rotation. That line is traced
out through the lens (exact Snell refraction) to find the object the eye then looks at:
through a -6 D lens the eye turned 30 deg up looks at a distant object 35.2 deg up, the
lens's prism there (9.17 prism dioptres, 5.2 deg) bending the line of sight away from its
optical centre. Along each line of sight (``analysis.fixation = "rotating"``) the wave on
the vertex sphere is compared with the prescription for that object
(:func:`eyelab.optics.chain.analysis.power_error`): the mean power error and the cylinder
(unwanted astigmatism) with its axis, plus the prism. The surfaces' own mean curvature and
cylinder, in dioptres at the lens's index, are mapped at the points where the lines of
sight cross them, for comparison.

Object distances follow a documented model: for the eye looking straight ahead and up,
infinity; looking down, the object vergence grows linearly with the eye's downward rotation
to ``near_vergence_d`` at ``near_rotation_deg`` down and stays there (reading below the
horizon); the object lies on the traced line of sight at 1/vergence from the turned pupil.

A lenslet lens (:mod:`eyelab.optics.lens.lenslets`) is mapped by its carrier, as the model
says: its lenslets, each smaller than the grid's spacing, would be hit or missed at random.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from eyelab.core.checks import check_range
from eyelab.core.errors import SpecError
from eyelab.optics.chain.analysis import analyze_points, chief_prism, power_error
from eyelab.optics.eye.prescription import tabo_axis
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.optics.rays.trace import FATAL

#: The object-distance model's defaults: 2.5 D (0.4 m) reached with the eye turned 25 deg
#: down.
NEAR_VERGENCE_D = 2.5
NEAR_ROTATION_DEG = 25.0
#: What the maps' grid is, in words (the JSON's ``grid``).
GRID = ("eye rotation about the centre of rotation, Fick angles in deg: azimuth to the "
        "wearer's right (x), then elevation up (y); the line of sight leaves the centre of "
        "rotation along (cos y sin x, sin y, -cos y cos x)")


@dataclass(repr=False)
class AsWornMaps:
    """Maps over eye rotations (ny, nx): eye_rotation_x_deg (nx,) to the wearer's right
    (Fick azimuth), eye_rotation_y_deg (ny,) up (Fick elevation), the line of sight turning
    about the eye's centre of rotation; mean_error_d, cylinder_d (<= 0), axis_tabo_deg,
    sphere_error_d, prism_d, object_vergence_d; object_x_deg, object_y_deg: Fick angles of
    the direction from the centre of rotation to the object seen along each line of sight
    (where the lens's prism sends it); front/back surface mean power and cylinder (D) where the
    line of sight crosses them; ok (bool) where a light path exists; objects: the object
    points, rows in grid order (x fastest)."""

    eye_rotation_x_deg: np.ndarray
    eye_rotation_y_deg: np.ndarray
    mean_error_d: np.ndarray
    cylinder_d: np.ndarray
    axis_tabo_deg: np.ndarray
    sphere_error_d: np.ndarray
    prism_d: np.ndarray
    object_vergence_d: np.ndarray
    surface: dict = field(default_factory=dict)
    ok: np.ndarray | None = None
    model: dict = field(default_factory=dict)
    #: Reference points as eye rotations (right, up; Fick angles, deg): a progressive
    #: lens's fitting cross, distance and near reference points.
    marks: dict = field(default_factory=dict)
    object_x_deg: np.ndarray | None = None
    object_y_deg: np.ndarray | None = None

    objects: ObjectPoints | None = None

    def __repr__(self) -> str:
        """One line: the grid, the rotations it spans and the maps' extremes (D)."""
        ny, nx = self.mean_error_d.shape
        x, y = self.eye_rotation_x_deg, self.eye_rotation_y_deg

        def span(a):
            a = np.asarray(a, float)
            a = a[np.isfinite(a)]
            return "none" if not a.size else f"{a.min():+.2f} to {a.max():+.2f} D"

        return (f"<AsWornMaps {ny}x{nx}: right {x[0]:+.0f} to {x[-1]:+.0f} deg, up "
                f"{y[0]:+.0f} to {y[-1]:+.0f} deg; mean error {span(self.mean_error_d)}, "
                f"cylinder {span(self.cylinder_d)}>")

    def to_json(self) -> dict:
        def grid(a):
            return [[None if not np.isfinite(v) else float(v) for v in row] for row in a]

        out = {"grid": GRID, "eye_rotation_x_deg": self.eye_rotation_x_deg.tolist(),
               "eye_rotation_y_deg": self.eye_rotation_y_deg.tolist(),
               "object_distance_model": self.model}
        for k in ("mean_error_d", "cylinder_d", "axis_tabo_deg", "sphere_error_d", "prism_d",
                  "object_vergence_d", "object_x_deg", "object_y_deg"):
            if getattr(self, k) is not None:
                out[k] = grid(getattr(self, k))
        out["surface"] = {k: grid(v) for k, v in self.surface.items()}
        out["marks_eye_rotation_deg"] = {k: list(v) for k, v in self.marks.items()}
        return out


def object_vergence(rotation_y_deg, near_vergence_d=NEAR_VERGENCE_D,
                    near_rotation_deg=NEAR_ROTATION_DEG):
    """The model's object vergence (D, >= 0 here: 1/distance) for the eye turned
    ``rotation_y_deg`` up (negative: down)."""
    down = np.clip(-np.asarray(rotation_y_deg, float) / near_rotation_deg, 0.0, 1.0)
    return down * near_vergence_d


def fick_lines(rotation_x_deg, rotation_y_deg) -> np.ndarray:
    """(n, 3) unit lines of sight for eye rotations by Fick angles (azimuth right, then
    elevation up; deg): (cos e sin a, sin e, -cos e cos a), as
    :func:`eyelab.optics.rays.camera.gaze_camera`."""
    a = np.radians(np.asarray(rotation_x_deg, float)).ravel()
    e = np.radians(np.asarray(rotation_y_deg, float)).ravel()
    return np.stack([np.cos(e) * np.sin(a), np.sin(e), -np.cos(e) * np.cos(a)], -1)


def fick_angles(v) -> tuple:
    """Fick angles (azimuth right, elevation up; deg) of directions ``v`` (n, 3)."""
    v = np.atleast_2d(np.asarray(v, float))
    v = v / np.linalg.norm(v, axis=1, keepdims=True)
    return (np.degrees(np.arctan2(v[:, 0], -v[:, 2])),
            np.degrees(np.arcsin(np.clip(v[:, 1], -1.0, 1.0))))


def objects_on_lines_of_sight(eye, lens, lines, vergence_d,
                              wavelength_nm: float = 587.56) -> tuple:
    """The objects the eye looks at along ``lines`` (n, 3) of sight from its centre of
    rotation: each line traced out through ``lens`` (eye -> scene), the object on the ray
    leaving the lens at 1/``vergence_d`` (n,) from the turned pupil (at infinity along it
    where the vergence is 0). Returns (ObjectPoints, ok (n,): the line passes the lens)."""
    lines = np.atleast_2d(np.asarray(lines, float))
    vg = np.broadcast_to(np.asarray(vergence_d, float), (len(lines),))
    cor = np.array([0.0, 0.0, eye.rotation_centre])
    res = lens.trace(np.broadcast_to(cor, lines.shape), lines, wavelength_nm, reverse=True)
    ok = (res["status"] & np.uint8(FATAL)) == 0
    q = np.where(ok[:, None], res["out_points"], cor)
    u = np.where(ok[:, None], res["out_dirs"], lines)
    u = u / np.linalg.norm(u, axis=1, keepdims=True)
    dist = np.where(vg > 0, 1.0 / np.where(vg > 0, vg, 1.0), np.inf)
    # |q + t u - pupil| = dist, the pupil rotation_centre before the centre on the line
    rel = q - (cor + eye.rotation_centre * lines)
    b = np.sum(rel * u, axis=1)
    fin = np.isfinite(dist)
    t = -b + np.sqrt(np.maximum(b * b - np.sum(rel * rel, axis=1)
                                + np.where(fin, dist, 0.0) ** 2, 0.0))
    pos = q + t[:, None] * u
    norm = np.linalg.norm(pos, axis=1, keepdims=True)
    direction = np.where(fin[:, None], pos / np.where(norm > 0, norm, 1.0), u)
    return ObjectPoints(direction, np.where(fin, norm[:, 0], np.inf)), ok


def line_of_sight_through(eye, lens, point, wavelength_nm: float = 587.56,
                          iterations: int = 20) -> np.ndarray:
    """(3,) :func:`lines_of_sight_through` one lens point ``point`` = (x, y)."""
    return lines_of_sight_through(eye, lens, [point], wavelength_nm, iterations)[0]


def lines_of_sight_through(eye, lens, points, wavelength_nm: float = 587.56,
                           iterations: int = 20) -> np.ndarray:
    """(n, 3) unit lines of sight from the eye's centre of rotation whose rays, traced out
    through ``lens``, leave the front surface at lens points ``points`` (n, 2; m, lens
    frame): the eye rotations that look through them (fixed-point iteration on the aim,
    from the straight line to each point, until every ray leaves within 1e-9 m of it; a
    row whose ray fails keeps the straight line)."""
    front, _ = lens.placed_surfaces()
    cor = np.array([0.0, 0.0, eye.rotation_centre])
    pts = np.atleast_2d(np.asarray(points, float))
    local = np.stack([pts[:, 0], pts[:, 1], front.surface.sag(pts[:, 0], pts[:, 1])], -1)
    p = local @ np.asarray(front.rotation).T + np.asarray(front.translation)
    straight = (p - cor) / np.linalg.norm(p - cor, axis=1, keepdims=True)
    aim, f = p.copy(), straight.copy()
    for _ in range(iterations):
        res = lens.trace(np.broadcast_to(cor, f.shape), f, wavelength_nm, reverse=True)
        failed = (res["status"] & np.uint8(FATAL)) != 0
        miss = np.where(failed[:, None], 0.0, p - res["out_points"])
        if np.linalg.norm(miss, axis=1).max() < 1e-9:
            break
        aim = aim + miss
        f = (aim - cor) / np.linalg.norm(aim - cor, axis=1, keepdims=True)
    return np.where(failed[:, None], straight, f)


def as_worn_maps(eye, lens, *, half_angle_deg: float = 30.0, n: int = 31,
                 near_vergence_d: float = NEAR_VERGENCE_D,
                 near_rotation_deg: float = NEAR_ROTATION_DEG,
                 wavelength_nm: float = 587.56) -> AsWornMaps:
    """The as-worn maps of ``lens`` (made for ``lens.rx``) on an n x n grid of eye
    rotations within +-``half_angle_deg`` (Fick angles: azimuth right, then elevation up).
    At grid point (a, e) the eye, turned about its centre of rotation, looks along
    (cos e sin a, sin e, -cos e cos a); the object it sees there is found by tracing that
    line of sight out through the lens (:func:`objects_on_lines_of_sight`)."""
    if lens is None or lens.rx is None:
        raise SpecError("lens.rx", "as-worn maps compare the lens with its prescription: "
                                   "make the lens from an Rx")
    lenslets = None
    if lens.has_lenslets:      # the carrier's maps (module doc)
        lenslets = (f"the carrier's maps: the {len(lens.front.centres)} lenslets of "
                    f"{lens.front.add_d:+.2f} D add, each smaller than the grid's spacing, "
                    "are left out (eyelab analyze gives a beam's share through them)")
        lens = dataclasses.replace(lens, front=lens.front.base)
    half = check_range("maps.half_angle_deg", half_angle_deg, 1.0, 60.0)
    if not (isinstance(n, int) and 3 <= n <= 201):
        raise SpecError("maps.n", f"must be an integer in [3, 201], got {n!r}")
    check_range("maps.near_vergence_d", near_vergence_d, 0.0, 10.0)
    check_range("maps.near_rotation_deg", near_rotation_deg, 1.0, 60.0)
    g = np.linspace(-half, half, n)
    gx, gy = np.meshgrid(g, g)
    objects, vg, res, err, ok = _errors_at(eye, lens, gx.ravel(), gy.ravel(), near_vergence_d,
                                           near_rotation_deg, wavelength_nm)
    prism = np.where(ok, chief_prism(res)[0], np.nan)
    axis_tabo = tabo_axis(err["axis_wearer_deg"])
    surf = _surface_maps(lens, res, ok, wavelength_nm)
    cor = np.array([0.0, 0.0, eye.rotation_centre])
    ox, oy = fick_angles(np.where(objects.finite[:, None], objects.positions() - cor,
                                  objects.direction))
    marks = {}
    if getattr(lens.design, "near_point", None) is not None:
        for name, point in (("fitting cross", (0.0, 0.0)),
                            ("distance reference", lens.design.distance_point),
                            ("near reference", lens.design.near_point)):
            ax, ay = fick_angles(line_of_sight_through(eye, lens, point, wavelength_nm))
            marks[name] = (float(ax[0]), float(ay[0]))

    def shape(a):
        return np.asarray(a, float).reshape(n, n)

    return AsWornMaps(g.copy(), g.copy(), shape(err["mean_d"]), shape(err["cylinder_d"]),
                      shape(axis_tabo), shape(err["sphere_d"]), shape(prism), shape(vg),
                      {k: shape(v) for k, v in surf.items()}, ok.reshape(n, n),
                      {"grid": "eye rotation (Fick angles, deg)",
                       "up": "infinity", "down": f"vergence rising linearly to "
                       f"{near_vergence_d:g} D with the eye turned {near_rotation_deg:g} deg "
                       "down, constant below; the object on the line of sight traced out "
                       "through the lens, at 1/vergence from the turned pupil",
                       "near_vergence_d": near_vergence_d,
                       "near_rotation_deg": near_rotation_deg,
                       **({} if lenslets is None else {"lenslets": lenslets})},
                      marks, np.where(ok, ox, np.nan).reshape(n, n),
                      np.where(ok, oy, np.nan).reshape(n, n), objects)


def _errors_at(eye, lens, rotation_x_deg, rotation_y_deg, near_vergence_d,
               near_rotation_deg, wavelength_nm) -> tuple:
    """(objects, vergences, analysis, power errors (NaN where no path), passes) of the
    lens worn by the eye turned to the Fick angles (n,) (deg) — the maps' points, or any
    others (:func:`peak_cylinder`)."""
    vg = object_vergence(rotation_y_deg, near_vergence_d, near_rotation_deg)
    objects, passes = objects_on_lines_of_sight(eye, lens, fick_lines(rotation_x_deg,
                                                                      rotation_y_deg),
                                                vg, wavelength_nm)
    res = analyze_points(eye, lens, objects, wavelength_nm=wavelength_nm,
                         fixation="rotating")
    err = power_error(res, lens.rx, objects,
                      add_fraction=vg / near_vergence_d if near_vergence_d > 0 else None)
    ok = passes & ((res.status & np.uint8(FATAL)) == 0)
    for v in err.values():
        v[~ok] = np.nan
    return objects, vg, res, err, ok


def peak_cylinder(maps: AsWornMaps, eye, lens, *, half_angle_deg: float | None = None,
                  starts: int = 6, wavelength_nm: float = 587.56) -> tuple:
    """(D, (rotation x, y) deg): the largest unwanted cylinder of the lens as worn within
    +-``half_angle_deg`` (default: the maps' extent) — found, not sampled: from each of the
    ``starts`` largest local maxima of ``maps``' grid, a patch of rotations a quarter grid
    step apart is traced, and the best point is refined in continuous rotation
    (Nelder-Mead to 0.005 deg), each traced as the maps are (their vergence model) and kept
    in the square — so a peak between grid points is not read low."""
    from scipy.optimize import minimize

    gx, gy = maps.eye_rotation_x_deg, maps.eye_rotation_y_deg
    half = float(max(abs(gx[0]), abs(gx[-1]))) if half_angle_deg is None else half_angle_deg
    prog = (maps.model["near_vergence_d"], maps.model["near_rotation_deg"])
    xx, yy = np.meshgrid(gx, gy)
    c = np.abs(maps.cylinder_d)
    c = np.where(np.isfinite(c) & (np.abs(xx) <= half + 1e-9) & (np.abs(yy) <= half + 1e-9),
                 c, -np.inf)
    from scipy.ndimage import maximum_filter

    local = np.isfinite(c) & (c >= maximum_filter(c, size=3, mode="nearest"))
    order = [k for k in np.argsort(c.ravel())[::-1] if local.ravel()[k]][:starts]
    step = float(gx[1] - gx[0]) if len(gx) > 1 else 1.0

    def cyl(rx, ry):
        rx, ry = np.clip(rx, -half, half), np.clip(ry, -half, half)
        e = np.abs(_errors_at(eye, lens, rx, ry, *prog, wavelength_nm)[3]["cylinder_d"])
        return np.where(np.isfinite(e), e, -np.inf), rx, ry

    # around each of the largest local maxima, a 9 x 9 patch a quarter step apart (one
    # trace each), then the best point refined in continuous rotation
    o = np.linspace(-step, step, 9)
    best = (-np.inf, np.array([np.nan, np.nan]))
    for k in order:
        px, py = np.meshgrid(xx.ravel()[k] + o, yy.ravel()[k] + o)
        v, rx, ry = cyl(px.ravel(), py.ravel())
        m = int(np.argmax(v))
        if v[m] > best[0]:
            best = (float(v[m]), np.array([rx[m], ry[m]]))
    if not np.isfinite(best[0]):
        return best[0], (float("nan"), float("nan"))
    r0 = best[1]
    simplex = r0 + step / 8 * np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    res = minimize(lambda r: -float(cyl(r[:1], r[1:])[0][0]), r0, method="Nelder-Mead",
                   options={"initial_simplex": simplex, "xatol": 0.005, "fatol": 1e-6,
                            "maxiter": 100})
    if -res.fun > best[0]:
        best = (float(-res.fun), np.clip(res.x, -half, half))
    return best[0], (float(best[1][0]), float(best[1][1]))


def _surface_maps(lens, res, ok, wavelength_nm) -> dict:
    """Each surface's mean power and cylinder (D, (n - 1) x curvature at the lens index)
    where the lines of sight cross it."""
    n_l = lens.material.n(wavelength_nm)
    out = {}
    front, back = lens.placed_surfaces()
    for name, ps, hit in (("front", front, res.chief.entry), ("back", back, res.chief.exit)):
        local = (hit - np.asarray(ps.translation)) @ np.asarray(ps.rotation)
        k1, k2, *_ = ps.surface.principal_curvatures(local[:, 0], local[:, 1])
        scale = (n_l - 1.0) * (1.0 if name == "front" else -1.0)
        p1, p2 = k1 * scale, k2 * scale
        out[f"{name}_mean_power_d"] = np.where(ok, 0.5 * (p1 + p2), np.nan)
        out[f"{name}_cylinder_d"] = np.where(ok, -np.abs(p1 - p2), np.nan)
    return out
