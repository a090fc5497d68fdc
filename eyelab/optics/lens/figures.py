"""A lens designer's figures of merit, read off as-worn maps (:mod:`eyelab.optics.lens.asworn`).

Designers compare progressive lenses by a handful of numbers — the powers at the
reference points, the add as worn, the corridor's length and width, the widths of the
distance and near zones, the peak unwanted cylinder, the minimum fitting height — and
single-vision lenses by the field they keep clear. Lengths and widths are on the lens,
so the maps, drawn over eye rotations, are first carried onto the lens (:func:`lens_map`):
each line of sight, traced out from the centre of rotation through the lens, leaves the
lens's front surface at a point; the maps are resampled (bicubic over the eye-rotation
grid, each lens point's eye rotation found by inverting the map to the lens) onto a
regular grid of those points in the front surface's own coordinates (x to the wearer's
right, y up, mm, the fitting cross — the lens centre — at the origin: the frame the
progressive design's reference points are given in). The cylinder is resampled as its
power-vector components J0, J45 (smooth where the cylinder's magnitude has a crease along
the umbilic line; L. N. Thibos, W. Wheeler & D. Horner, "Power vectors", *Optom. Vis.
Sci.* 74:367-375 (1997)). The figures themselves (:func:`progressive_figures`,
:func:`clear_field`) work on plain arrays, so a synthetic map whose answers are known in
closed form can be fed directly (``tests/test_figures.py``).

Powers here are as worn: the mean power of the lens for the object the maps' model puts
on each line of sight (the vertex-sphere vergence less the object's vergence; the
prescription plus the maps' power error), and the unwanted cylinder (the magnitude of the
maps' cylinder error, D).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import interpolate

from eyelab.optics.chain.analysis import analyze_points, power_error
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.lens import asworn
from eyelab.optics.lens.umbilic import corridor_umbilic
from eyelab.optics.rays.trace import FATAL

#: Clear-zone criteria (D): unwanted cylinder below 0.50 D — the criterion of Sheedy's
#: measured comparisons of progressive designs (J. E. Sheedy, "Progressive addition
#: lenses — matching the specific lens to patient needs", *Optometry* 75:83-102 (2004);
#: J. Sheedy, R. F. Hardy & J. R. Hayes, "Progressive addition lenses — measurements and
#: ratings", *Optometry* 77:23-39 (2006)) — and the mean power within 0.25 D of the
#: zone's reference power (a quarter dioptre, the prescription's step).
ZONE_CYLINDER_D = 0.50
POWER_TOLERANCE_D = 0.25
#: The cylinder levels the corridor width is given at (D).
CORRIDOR_CYLINDERS_D = (0.50, 0.75)
#: Sheedy's sections: horizontal, every 1 mm from the fitting cross (2004, 2006).
SECTION_STEP_MM = 1.0
#: The minimum height of a useful reading area below the point where the near power is
#: reached (mm): "fitting height less 4 to 5 mm" (20/20 Magazine, CE Plus, November
#: 2015, "Lenses: customization"); eyelab takes the lower end.
READING_HEIGHT_MM = 4.0
#: The front surface's coordinates, in words (the figures' ``surface``).
SURFACE = ("the lens's front surface, where the line of sight leaves the lens: its own "
           "coordinates, x to the wearer's right, y up, mm, the fitting cross (the lens "
           "centre) at the origin")
#: How far from the path a section's clear interval is looked for (mm).
SECTION_SEARCH_MM = 3.0
_FINE_MM = 0.02          # sampling along a section or the path


@dataclass
class LensMap:
    """As-worn maps on the lens: ``x_mm`` (nx,) and ``y_mm`` (ny,) ascending regular grids
    (mm, x to the wearer's right, y up, the fitting cross at the origin); ``mean_power_d``
    (ny, nx) the mean power as worn (D); ``cylinder_d`` (ny, nx) the unwanted cylinder's
    magnitude (D, >= 0); NaN off the map. ``distance_point_mm``, ``near_point_mm``: the
    reference points (x, y), mm."""

    x_mm: np.ndarray
    y_mm: np.ndarray
    mean_power_d: np.ndarray
    cylinder_d: np.ndarray
    distance_point_mm: tuple = (0.0, 4.0)
    near_point_mm: tuple = (0.0, -16.0)
    surface: str = SURFACE
    _fn: dict = field(default_factory=dict, repr=False)

    def at(self, name: str, x, y) -> np.ndarray:
        """``name`` ("mean_power_d" or "cylinder_d") at lens points (x, y) (mm, any
        broadcastable shapes), bilinear; NaN off the map."""
        if name not in self._fn:
            self._fn[name] = interpolate.RegularGridInterpolator(
                (self.y_mm, self.x_mm), getattr(self, name), bounds_error=False,
                fill_value=np.nan)
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        return self._fn[name](np.stack([y.ravel(), x.ravel()], -1)).reshape(x.shape)


# ------------------------------------------------------------------ the corridor
def corridor_path(lm: LensMap, y) -> np.ndarray:
    """The eye's path down the corridor: x (mm) at heights ``y`` (mm). Above the fitting
    cross x = 0; below the near reference point its x (the inset); between them the
    umbilic line, found as the line of least cylinder: on each section (every 0.05 mm)
    where the cylinder has a clear least value within 6 mm of the straight line from the
    fitting cross to the near reference point (0.05 D higher 1 mm to either side), that
    point; the path runs straight between those points and the two reference points."""
    if "path" not in lm._fn:
        xn, yn = lm.near_point_mm
        rows = np.arange(yn, 0.0, 0.05)[1:]
        off = np.arange(-6.0, 6.0 + 1e-9, 0.05)
        xs = rows[:, None] / yn * xn + off[None, :]
        c = lm.at("cylinder_d", xs, np.broadcast_to(rows[:, None], xs.shape))
        c = np.where(np.isfinite(c), c, 1e9)
        r, k = np.arange(len(rows)), np.argmin(c, axis=1)
        lo, hi = c[r, np.maximum(k - 20, 0)], c[r, np.minimum(k + 20, len(off) - 1)]
        sharp = (k >= 20) & (k < len(off) - 20) & (c[r, k] < 1e9) \
            & (np.minimum(lo, hi) - c[r, k] >= 0.05)
        lm._fn["path"] = (np.concatenate([[yn], rows[sharp], [0.0]]),
                          np.concatenate([[xn], xs[r, k][sharp], [0.0]]))
    return np.interp(np.atleast_1d(np.asarray(y, float)), *lm._fn["path"])


def _crossing(ys, values, level) -> float:
    """The first y (going along ``ys``) where ``values`` reach ``level``, linear; NaN if
    they never do."""
    hit = np.flatnonzero(values >= level)
    if len(hit) == 0:
        return float("nan")
    i = hit[0]
    if i == 0:
        return float(ys[0])
    f = (level - values[i - 1]) / (values[i] - values[i - 1])
    return float(ys[i - 1] + f * (ys[i] - ys[i - 1]))


def corridor(lm: LensMap) -> dict:
    """The add profile down the path (:func:`corridor_path`), from the distance reference
    point to the near reference point: the add as worn A = P(near) - P(distance) (mean
    powers at the reference points), and the heights y (mm) where the path's add
    P(path(y), y) - P(distance) reaches 10 % and 90 % of A (the corridor, length
    y10 - y90: the 10-90 % rise of the add, eyelab's definition; makers measure from the
    umbilic's least to its greatest mean power — D. Meister, "The optics of progressive
    lenses, part 3", 20/20 Magazine (2010) — ends a plateau leaves vague), 0.25 D (the
    bottom of the distance zone) and A - 0.25 D (the top of the near zone: the near power
    within a quarter dioptre). For a logistic profile A / (1 + exp((y - y0) / s)) the 10 %
    and 90 % points lie at y0 +- s ln 9: L = 2 s ln 9."""
    (xd, yd), (xn, yn) = lm.distance_point_mm, lm.near_point_mm
    pd, pn = (float(lm.at("mean_power_d", x, y)) for x, y in ((xd, yd), (xn, yn)))
    add = pn - pd
    ys = np.arange(yd, yn - _FINE_MM / 2, -_FINE_MM)
    a = lm.at("mean_power_d", corridor_path(lm, ys), ys) - pd
    out = {"distance_power_d": pd, "near_power_d": pn, "add_d": add, "ys": ys, "add": a}
    for key, level in (("y10", 0.1 * add), ("y90", 0.9 * add),
                       ("distance_bottom", POWER_TOLERANCE_D),
                       ("near_top", add - POWER_TOLERANCE_D)):
        out[key] = _crossing(ys, a * np.sign(add), level * np.sign(add))
    out["length_mm"] = out["y10"] - out["y90"]
    return out


# ------------------------------------------------------------------ sections
def section(lm: LensMap, y: float, x0: float, cylinder_d: float,
            power_d: float | None = None) -> dict:
    """The clear interval of the horizontal section at height ``y`` (mm) that holds x0 (or
    the clear point nearest to it, within 3 mm): where the cylinder is below
    ``cylinder_d`` (and, given ``power_d``, the mean power is within
    :data:`POWER_TOLERANCE_D` of it), its ends linear between samples 0.02 mm apart.
    Returns left/right (mm), width (mm; 0 if no point there is clear) and open (an end is
    the map's edge: the width is a lower bound)."""
    xs = np.arange(lm.x_mm[0], lm.x_mm[-1] + 1e-9, _FINE_MM)
    yy = np.full_like(xs, y)
    g = lm.at("cylinder_d", xs, yy) - cylinder_d
    if power_d is not None:
        g = np.maximum(g, np.abs(lm.at("mean_power_d", xs, yy) - power_d) - POWER_TOLERANCE_D)
    j = int(np.clip(np.searchsorted(xs, x0), 0, len(xs) - 1))
    near = np.flatnonzero(np.abs(xs - xs[j]) <= SECTION_SEARCH_MM)
    clear = near[g[near] < 0]
    if len(clear):
        j = int(clear[np.argmin(np.abs(clear - j))])
    if not np.isfinite(g[j]) or g[j] >= 0:
        return {"y_mm": y, "left_mm": x0, "right_mm": x0, "width_mm": 0.0, "open": False}
    ends, edge = [], False
    for step in (-1, 1):
        bad = np.flatnonzero(~(g[j::step] < 0))
        if len(bad) == 0 or not np.isfinite(g[j + step * bad[0]]):
            k = j + step * ((bad[0] if len(bad) else len(g[j::step])) - 1)
            ends.append(float(xs[k]))
            edge = True
            continue
        k = j + step * bad[0]
        i = k - step
        ends.append(float(xs[i] + (xs[k] - xs[i]) * (-g[i]) / (g[k] - g[i])))
    return {"y_mm": float(y), "left_mm": ends[0], "right_mm": ends[1],
            "width_mm": ends[1] - ends[0], "open": edge}


def corridor_widths(lm: LensMap, cor: dict) -> dict:
    """The corridor width at each cylinder level of :data:`CORRIDOR_CYLINDERS_D`: the
    width of the interval about the path where the cylinder is below the level, on
    horizontal sections every 0.05 mm between the corridor's 10 % and 90 % points; the
    narrowest and where. Along an umbilic line the cylinder beside it grows as
    C = 2 |x - u| dA/dy (Minkwitz), so the width at level C is C / (dA/dy), least where
    the add rises fastest; for the logistic, dA/dy <= A / (4 s) and with L = 2 s ln 9 the
    narrowest width is 4 s C / A = 2 L C / (A ln 9)."""
    ys = np.arange(cor["y10"], cor["y90"] - 1e-9, -0.05)
    xs = corridor_path(lm, ys)
    out = {}
    for level in CORRIDOR_CYLINDERS_D:
        rows = [section(lm, y, x, level) for y, x in zip(ys, xs, strict=True)]
        w = np.array([r["width_mm"] for r in rows])
        i = int(np.argmin(w))
        out[f"{level:.2f}"] = {"min_width_mm": float(w[i]), "at_y_mm": float(ys[i]),
                               "open": bool(rows[i]["open"])}
    return out


def zone_sections(lm: LensMap, cor: dict, which: str) -> dict:
    """Sheedy's zone widths: horizontal sections every 1 mm (y a whole number of mm from
    the fitting cross) over the distance zone (from the map's top down to where the add
    on the path reaches 0.25 D) or the near zone (from where it is within 0.25 D of the
    add down to the map's bottom); on each, the width of the interval about the path
    where the cylinder is below 0.50 D and the mean power within 0.25 D of the zone's
    reference-point power; and the width on the reference point's own section."""
    if which == "distance":
        top, bottom = lm.y_mm[-1], cor["distance_bottom"]
        ref, power = lm.distance_point_mm, cor["distance_power_d"]
    else:
        top, bottom = cor["near_top"], lm.y_mm[0]
        ref, power = lm.near_point_mm, cor["near_power_d"]
    ys = np.arange(np.floor(top), np.ceil(bottom) - 1e-9, -SECTION_STEP_MM) \
        if np.isfinite(top) and np.isfinite(bottom) else np.zeros(0)
    rows = []
    for y, x in zip(ys, corridor_path(lm, ys), strict=True):
        r = section(lm, float(y), float(x), ZONE_CYLINDER_D, power)
        if np.isfinite(lm.at("cylinder_d", x, y)):
            rows.append({k: r[k] for k in ("y_mm", "width_mm", "left_mm", "right_mm", "open")})
    at_ref = section(lm, ref[1], ref[0], ZONE_CYLINDER_D, power)
    return {"sections": rows, "width_at_reference_mm": at_ref["width_mm"],
            "reference_open": at_ref["open"]}


def add_points(cor: dict, *fractions) -> tuple:
    """The heights y (mm) where the path's add reaches each fraction of the add."""
    sgn = np.sign(cor["add_d"])
    return tuple(_crossing(cor["ys"], cor["add"] * sgn, f * abs(cor["add_d"])) for f in fractions)


def minkwitz(lm: LensMap, cor: dict) -> dict:
    """Minkwitz's ratio along the corridor (G. Minkwitz, *Optica Acta* 10:223-227 (1963);
    measured on commercial lenses by J. E. Sheedy, C. Campbell, E. King-Smith &
    J. R. Hayes, "Progressive powered lenses: the Minkwitz theorem", *Optom. Vis. Sci.*
    82(10) (2005)): the lateral cylinder gradient dC/dx over twice the vertical power
    gradient dP/dy, 1 at Minkwitz's limit, both averaged between the 25 % and 75 % add
    points on the path. dP/dy: the add's rise there over its height (A/2 over y25 - y75);
    dC/dx: on sections every 0.25 mm, from the corridor widths at 0.50 and 0.75 D,
    2 (0.75 - 0.50) / (w75 - w50) (each side of the path the width grows by dC / (dC/dx);
    free of any cylinder floor along the path), averaged."""
    y25, y75 = add_points(cor, 0.25, 0.75)
    lateral = []
    for y in np.arange(y25, y75 - 1e-9, -0.25):
        w = [section(lm, float(y), float(corridor_path(lm, y)[0]), c)
             for c in CORRIDOR_CYLINDERS_D]
        dw = w[1]["width_mm"] - w[0]["width_mm"]
        if dw > 0 and w[0]["width_mm"] > 0 and not (w[0]["open"] or w[1]["open"]):
            lateral.append(2 * (CORRIDOR_CYLINDERS_D[1] - CORRIDOR_CYLINDERS_D[0]) / dw)
    if not lateral or not y25 > y75:
        return {}
    vertical = 0.5 * abs(cor["add_d"]) / (y25 - y75)
    return {"from_y_mm": float(y25), "to_y_mm": float(y75),
            "cylinder_gradient_d_per_mm": float(np.mean(lateral)),
            "power_gradient_d_per_mm": float(vertical),
            "ratio": float(np.mean(lateral)) / (2 * vertical)}


def progressive_figures(lm: LensMap) -> dict:
    """All of a progressive lens's figures from its lens map (see each function): the
    corridor (10-90 % length), its narrowest widths at 0.50 and 0.75 D, the distance and
    near zones' sections, the peak unwanted cylinder (the map's largest; it grows with the
    map's extent) and its ratio to the add, Minkwitz's ratio, and the minimum fitting
    height: the depth of the near zone's top below the fitting cross plus a 4 mm reading
    area (:data:`READING_HEIGHT_MM`) — the least fitting-point height (ISO 13666's
    fitting-point height, from the fitting point to the lower horizontal tangent of the
    glazed lens; M. Jalie, "Progressive power lenses, part 7", *Optician*) that keeps the
    near zone in the lens. Lengths mm, powers D."""
    cor = corridor(lm)
    out = {"surface": lm.surface, "add_as_worn_d": cor["add_d"],
           "distance_reference": {"lens_mm": list(lm.distance_point_mm),
                                  "mean_power_d": cor["distance_power_d"]},
           "near_reference": {"lens_mm": list(lm.near_point_mm),
                              "mean_power_d": cor["near_power_d"]}}
    if not all(np.isfinite(cor[k]) for k in ("add_d", "y10", "y90", "near_top")):
        out["note"] = ("the corridor leaves the mapped lens (beyond the field of eye rotations, "
                       "or outside the frame): no corridor figures")
        return out
    c = np.where(np.isfinite(lm.cylinder_d), lm.cylinder_d, -np.inf)
    j, i = np.unravel_index(int(np.argmax(c)), c.shape)
    out.update({
        "corridor": {"y10_mm": cor["y10"], "y90_mm": cor["y90"],
                     "length_mm": cor["length_mm"],
                     "distance_zone_bottom_mm": cor["distance_bottom"],
                     "near_zone_top_mm": cor["near_top"],
                     "widths": corridor_widths(lm, cor)},
        "distance_zone": zone_sections(lm, cor, "distance"),
        "near_zone": zone_sections(lm, cor, "near"),
        "peak_cylinder": {"d": float(c[j, i]), "lens_mm": [float(lm.x_mm[i]), float(lm.y_mm[j])],
                          "ratio_to_add": float(c[j, i]) / cor["add_d"]},
        "minkwitz": minkwitz(lm, cor), "corridor_umbilic": corridor_umbilic(
            lm, lambda y: corridor_path(lm, y), *add_points(cor, 0.25, 0.75)),
        "minimum_fitting_height_mm": -cor["near_top"] + READING_HEIGHT_MM})
    return out


# ------------------------------------------------------------------ single vision
def clear_field(rot_x_deg, rot_y_deg, mean_error_d, j0_d, j45_d, ok=None,
                tolerance_d: float = POWER_TOLERANCE_D) -> dict:
    """The clear field: the largest radius r (deg of eye rotation) such that at every eye
    rotation within r of straight ahead the mean power error is within ``tolerance_d``
    and the unwanted cylinder 2 sqrt(J0^2 + J45^2) below it — also each criterion alone.
    Maps over a regular eye-rotation grid: ``rot_x_deg`` (nx,), ``rot_y_deg`` (ny,),
    ``mean_error_d``, ``j0_d``, ``j45_d`` (ny, nx), D (power-vector components of the
    cylinder error, Thibos 1997); ``ok`` (ny, nx) where a path exists. Bicubic on the
    grid, along 360 directions in 0.05 deg steps. Returns radius_deg (and open: no
    failure inside the grid's disc), the limiting eye rotation (deg) and what limits."""
    ok = np.ones(np.shape(mean_error_d), bool) if ok is None else np.asarray(ok, bool)
    ok = ok & np.isfinite(mean_error_d) & np.isfinite(j0_d) & np.isfinite(j45_d)
    if not ok.any():
        return {"tolerance_d": tolerance_d, "radius_mean_power_error_deg": 0.0,
                "radius_cylinder_deg": 0.0, "radius_deg": 0.0, "open": False,
                "limit_eye_rotation_deg": [0.0, 0.0], "limited_by": ["no path"]}
    fit = [_grid_spline(rot_x_deg, rot_y_deg, v, ok) for v in (mean_error_d, j0_d, j45_d)]
    good = interpolate.RegularGridInterpolator((rot_y_deg, rot_x_deg), ok.astype(float),
                                               bounds_error=False, fill_value=0.0)
    half = min(abs(rot_x_deg[0]), rot_x_deg[-1], abs(rot_y_deg[0]), rot_y_deg[-1])
    th = np.radians(np.arange(360.0))
    r = np.arange(0.0, half + 1e-9, 0.05)
    px, py = np.cos(th)[:, None] * r, np.sin(th)[:, None] * r
    m, j0, j45 = (f.ev(py.ravel(), px.ravel()).reshape(px.shape) for f in fit)
    fails = {"mean power error": np.abs(m) > tolerance_d,
             "cylinder": 2 * np.hypot(j0, j45) > tolerance_d,
             "no path": good(np.stack([py.ravel(), px.ravel()], -1)).reshape(px.shape) < 0.999}
    out = {"tolerance_d": tolerance_d}
    for name, f in (("mean power error", fails["mean power error"]),
                    ("cylinder", fails["cylinder"]),
                    ("both", fails["mean power error"] | fails["cylinder"] | fails["no path"])):
        first = np.where(f.any(axis=1), np.argmax(f, axis=1), len(r))
        k = int(np.argmin(first))
        key = "radius_deg" if name == "both" else f"radius_{name.replace(' ', '_')}_deg"
        out[key] = float(r[first[k]]) if first[k] < len(r) else float(half)
        if name == "both":
            out["open"] = bool(first[k] == len(r))
            if not out["open"]:
                out["limit_eye_rotation_deg"] = [float(px[k, first[k]]), float(py[k, first[k]])]
                out["limited_by"] = [n for n, g in fails.items() if g[k, first[k]]]
    return out


# ------------------------------------------------------------------ from the maps
def error_vectors(maps) -> tuple:
    """(J0, J45) (D, (ny, nx)) of the maps' cylinder error (power vectors, Thibos 1997)."""
    a = np.radians(maps.axis_tabo_deg)
    return -maps.cylinder_d / 2 * np.cos(2 * a), -maps.cylinder_d / 2 * np.sin(2 * a)


def mean_power(maps, rx) -> np.ndarray:
    """The mean power as worn (D, (ny, nx)): the prescription's mean power plus the share
    of its add the object's vergence calls for (the maps' model) plus the mean error."""
    frac = maps.object_vergence_d / maps.model.get("near_vergence_d", 2.5) \
        if maps.model.get("near_vergence_d") else 0.0
    return maps.mean_error_d + rx.sphere + rx.cylinder / 2 + rx.add * frac


def front_points(eye, lens, rot_x_deg, rot_y_deg, wavelength_nm=587.56) -> tuple:
    """Where the lines of sight for eye rotations (Fick angles, deg, any shape) leave the
    lens's front surface: (x_mm, y_mm) in its own coordinates (the lens frame), NaN where
    the line of sight misses the lens."""
    lines = asworn.fick_lines(rot_x_deg, rot_y_deg)
    cor = np.array([0.0, 0.0, eye.rotation_centre])
    res = lens.trace(np.broadcast_to(cor, lines.shape), lines, wavelength_nm, reverse=True)
    front, _ = lens.placed_surfaces()
    local = (res["out_points"] - np.asarray(front.translation)) @ np.asarray(front.rotation)
    hit = (res["status"] & np.uint8(FATAL)) == 0
    shape = np.shape(rot_x_deg)
    return (np.where(hit, local[:, 0] * 1e3, np.nan).reshape(shape),
            np.where(hit, local[:, 1] * 1e3, np.nan).reshape(shape))


def _grid_spline(ax, ay, v, valid) -> interpolate.RectBivariateSpline:
    """A bicubic spline through ``v`` (ny, nx) on the eye-rotation grid (``ax``, ``ay``),
    the values where ``valid`` is False taken from the nearest valid grid point."""
    from scipy.ndimage import distance_transform_edt

    idx = distance_transform_edt(~valid, return_distances=False, return_indices=True)
    return interpolate.RectBivariateSpline(ay, ax, np.asarray(v, float)[tuple(idx)])


def lens_map(maps, eye, lens, step_mm: float = 0.2, wavelength_nm=587.56) -> LensMap:
    """``maps`` (an :class:`~eyelab.optics.lens.asworn.AsWornMaps` of ``lens`` worn by ``eye``)
    on the lens (see the module text): the mean power as worn and the unwanted cylinder on
    a regular ``step_mm`` grid of front-surface points, NaN outside the points the maps'
    lines of sight cross (or within a grid cell of one without a light path). Each lens
    point's eye rotation: linear between the maps' grid points' front-surface points, then
    one Newton step on their bicubic spline; the maps there: bicubic splines over the
    eye-rotation grid of the mean power and the cylinder's J0, J45."""
    ax, ay = maps.eye_rotation_x_deg, maps.eye_rotation_y_deg
    gx, gy = np.meshgrid(ax, ay)
    fx, fy = front_points(eye, lens, gx, gy, wavelength_nm)
    hit = np.isfinite(fx)
    ok = hit & (maps.ok if maps.ok is not None else True) & np.isfinite(maps.mean_error_d)
    xs = np.arange(np.floor(fx[hit].min()), np.ceil(fx[hit].max()) + 1e-9, step_mm)
    ys = np.arange(np.floor(fy[hit].min()), np.ceil(fy[hit].max()) + 1e-9, step_mm)
    tx, ty = np.meshgrid(xs, ys)
    inv = interpolate.LinearNDInterpolator(np.stack([fx[hit], fy[hit]], -1),
                                           np.stack([gx[hit], gy[hit], ok[hit]], -1))(tx, ty)
    a, e, inside = inv[..., 0], inv[..., 1], inv[..., 2] > 1 - 1e-9
    a, e = np.where(inside, a, 0.0), np.where(inside, e, 0.0)
    sx, sy = _grid_spline(ax, ay, fx, hit), _grid_spline(ax, ay, fy, hit)
    jac = np.stack([[f.ev(e, a, dy=1), f.ev(e, a, dx=1)] for f in (sx, sy)])
    rx, ry = sx.ev(e, a) - tx, sy.ev(e, a) - ty
    det = jac[0, 0] * jac[1, 1] - jac[0, 1] * jac[1, 0]
    a = a - (jac[1, 1] * rx - jac[0, 1] * ry) / det
    e = e - (jac[0, 0] * ry - jac[1, 0] * rx) / det
    j0, j45 = error_vectors(maps)
    p, j0, j45 = (np.where(inside, _grid_spline(ax, ay, v, ok).ev(e, a), np.nan)
                  for v in (mean_power(maps, lens.rx), j0, j45))
    design = lens.design
    kw = {} if design is None else {
        "distance_point_mm": tuple(1e3 * np.asarray(design.distance_point)),
        "near_point_mm": tuple(1e3 * np.asarray(design.near_point))}
    return LensMap(xs, ys, p, 2 * np.hypot(j0, j45), **kw)


def point_powers(eye, lens, rotation_deg, model: dict, wavelength_nm=587.56) -> dict:
    """The powers as worn along one line of sight (eye rotation (right, up), Fick angles,
    deg), traced exactly (not interpolated), for the object the maps' ``model`` puts on
    it: the lens's power as a sphere / cylinder x axis (TABO) and its mean, the object's
    vergence, the power error's mean and cylinder, and the lens point (mm)."""
    line = asworn.fick_lines(*rotation_deg)
    near_v = model.get("near_vergence_d", 2.5)
    vg = asworn.object_vergence(np.array([rotation_deg[1]]), near_v,
                                model.get("near_rotation_deg", 25.0))
    objects, _ = asworn.objects_on_lines_of_sight(eye, lens, line, vg, wavelength_nm)
    res = analyze_points(eye, lens, objects, wavelength_nm=wavelength_nm, fixation="rotating")
    frac = vg / near_v if near_v > 0 else np.zeros(1)
    err = power_error(res, lens.rx, objects, add_fraction=frac)
    e = Prescription.from_power_vector(0.0, 0.0, 0.0)
    s, c, aw = (float(err[k][0]) for k in ("sphere_d", "cylinder_d", "axis_wearer_deg"))
    if np.isfinite(s):
        e = Prescription(s, c, (180.0 - aw) % 180.0 or 180.0)
    m = lens.rx.distance().power_matrix(lens.rx.add * float(frac[0])) + e.power_matrix()
    worn = Prescription.from_power_vector((m[0, 0] + m[1, 1]) / 2, (m[0, 0] - m[1, 1]) / 2,
                                          -m[0, 1])
    x, y = front_points(eye, lens, *(np.array([v]) for v in rotation_deg), wavelength_nm)
    return {"eye_rotation_deg": [float(v) for v in rotation_deg],
            "lens_mm": [float(x[0]), float(y[0])], "object_vergence_d": float(vg[0]),
            "power": f"{worn.sphere:+.2f} / {worn.cylinder:+.2f} x {round(worn.axis) or 180:03d}",
            "sphere_d": worn.sphere, "cylinder_d": worn.cylinder,
            "axis_tabo_deg": worn.axis, "mean_power_d": worn.sphere + worn.cylinder / 2,
            "mean_error_d": float(err["mean_d"][0]), "cylinder_error_d": c}


def map_peak_cylinder(maps, eye, lens, wavelength_nm=587.56) -> dict:
    """The largest unwanted cylinder (D, magnitude) within the maps' extent — found between
    their grid points, traced (:func:`eyelab.optics.lens.asworn.peak_cylinder`) — with its eye
    rotation (deg) and lens point (mm)."""
    from eyelab.optics.lens.asworn import peak_cylinder

    d, rot = peak_cylinder(maps, eye, lens, wavelength_nm=wavelength_nm)
    x, y = front_points(eye, lens, np.array(rot[:1]), np.array(rot[1:]), wavelength_nm)
    return {"d": d, "eye_rotation_deg": list(rot), "lens_mm": [float(x[0]), float(y[0])]}


def as_worn_figures(maps, eye, lens, wavelength_nm=587.56) -> dict:
    """The figures of ``lens`` worn by ``eye`` from its as-worn ``maps``: a progressive
    lens's (:func:`progressive_figures` on :func:`lens_map`, its reference points' powers
    traced exactly at the maps' marks, the peak cylinder the maps' own
    (:func:`map_peak_cylinder`)) or a single-vision lens's (the powers at the lens centre,
    lens point (0, 0), traced exactly; :func:`clear_field`; the peak cylinder)."""
    out = {"kind": "single vision", "surface": SURFACE,
           "grid": {"half_angle_deg": float(maps.eye_rotation_x_deg[-1]),
                    "step_deg": float(np.diff(maps.eye_rotation_x_deg)[0])}}
    peak = map_peak_cylinder(maps, eye, lens, wavelength_nm)
    if getattr(lens.design, "near_point", None) is not None:
        out["kind"] = "progressive"
        out.update(progressive_figures(lens_map(maps, eye, lens, wavelength_nm=wavelength_nm)))
        d, n = (point_powers(eye, lens, maps.marks[k], maps.model, wavelength_nm)
                for k in ("distance reference", "near reference"))
        out.update(distance_reference=d, near_reference=n, add_nominal_d=lens.rx.add,
                   add_as_worn_d=n["mean_power_d"] - d["mean_power_d"])
        if "peak_cylinder" in out:
            out["peak_cylinder"] = dict(peak, ratio_to_add=peak["d"] / out["add_as_worn_d"])
        return out
    centre_line = asworn.line_of_sight_through(eye, lens, (0.0, 0.0), wavelength_nm)
    ax, ay = asworn.fick_angles(centre_line)
    j0, j45 = error_vectors(maps)
    out.update(optical_centre=point_powers(eye, lens, (float(ax[0]), float(ay[0])), maps.model,
                                           wavelength_nm),
               clear_field=clear_field(maps.eye_rotation_x_deg, maps.eye_rotation_y_deg,
                                       maps.mean_error_d, j0, j45, maps.ok),
               peak_cylinder=peak)
    if lens.rx is not None and lens.rx.add > 0:       # a multifocal given surface by surface
        out["note"] = ("the lens's Rx has an add but the lens has no progressive design "
                       "(its surfaces are given, e.g. from points files): its reference "
                       "points are unknown, so the progressive figures are not given; these "
                       "are the single-vision figures")
    return out
