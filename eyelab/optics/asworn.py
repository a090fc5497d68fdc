"""As-worn maps of a spectacle lens: what a lens designer reads first.

For the lens in its worn pose, the eye turns about its centre of rotation to look along a
grid of gaze directions (``analysis.fixation = "rotating"``); along each line of sight
the wave on the vertex sphere is compared with the prescription for the object seen in
that direction (:func:`eyelab.optics.analysis.power_error`): the mean power error and the
cylinder (unwanted astigmatism) with its axis, plus the prism. The surfaces' own mean
curvature and cylinder, in dioptres at the lens's index, are mapped at the points where
the lines of sight cross them, for comparison.

Object distances follow a documented model: straight ahead and above, infinity; below,
the object vergence grows linearly with the downward gaze angle to ``near_vergence_d``
at ``near_gaze_deg`` down and stays there (reading below the horizon).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from eyelab.core.checks import check_range
from eyelab.core.errors import SpecError
from eyelab.optics.analysis import analyze_points, chief_prism, power_error
from eyelab.optics.paths import ObjectPoints
from eyelab.optics.prescription import tabo_axis
from eyelab.optics.trace import FATAL

#: The object-distance model's defaults: 2.5 D (0.4 m) reached 25 deg below straight ahead.
NEAR_VERGENCE_D = 2.5
NEAR_GAZE_DEG = 25.0


@dataclass
class AsWornMaps:
    """Maps over gaze angles (ny, nx): gaze_x_deg (nx,) to the wearer's right, gaze_y_deg
    (ny,) up; mean_error_d, cylinder_d (<= 0), axis_tabo_deg, sphere_error_d, prism_d,
    object_vergence_d; front/back surface mean power and cylinder (D) where the line of
    sight crosses them; ok (bool) where a light path exists."""

    gaze_x_deg: np.ndarray
    gaze_y_deg: np.ndarray
    mean_error_d: np.ndarray
    cylinder_d: np.ndarray
    axis_tabo_deg: np.ndarray
    sphere_error_d: np.ndarray
    prism_d: np.ndarray
    object_vergence_d: np.ndarray
    surface: dict = field(default_factory=dict)
    ok: np.ndarray | None = None
    model: dict = field(default_factory=dict)
    #: Reference points as gaze angles (right, up; deg): a progressive lens's fitting
    #: cross, distance and near reference points.
    marks: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        def grid(a):
            return [[None if not np.isfinite(v) else float(v) for v in row] for row in a]

        out = {"gaze_x_deg": self.gaze_x_deg.tolist(), "gaze_y_deg": self.gaze_y_deg.tolist(),
               "object_distance_model": self.model}
        for k in ("mean_error_d", "cylinder_d", "axis_tabo_deg", "sphere_error_d", "prism_d",
                  "object_vergence_d"):
            out[k] = grid(getattr(self, k))
        out["surface"] = {k: grid(v) for k, v in self.surface.items()}
        out["marks_gaze_deg"] = {k: list(v) for k, v in self.marks.items()}
        return out


def object_vergence(gaze_y_deg, near_vergence_d=NEAR_VERGENCE_D,
                    near_gaze_deg=NEAR_GAZE_DEG):
    """The model's object vergence (D, >= 0 here: 1/distance) for a gaze ``gaze_y_deg``
    up (negative: down)."""
    down = np.clip(-np.asarray(gaze_y_deg, float) / near_gaze_deg, 0.0, 1.0)
    return down * near_vergence_d


def as_worn_maps(eye, lens, *, half_angle_deg: float = 30.0, n: int = 31,
                 near_vergence_d: float = NEAR_VERGENCE_D,
                 near_gaze_deg: float = NEAR_GAZE_DEG, wavelength_nm: float = 587.56
                 ) -> AsWornMaps:
    """The as-worn maps of ``lens`` (made for ``lens.rx``) on an n x n grid of gazes within
    +-``half_angle_deg``. Gaze (gx, gy) is the direction unit(tan gx, tan gy, -1) from the
    centre of rotation."""
    if lens is None or lens.rx is None:
        raise SpecError("lens.rx", "as-worn maps compare the lens with its prescription: "
                                   "make the lens from an Rx")
    half = check_range("maps.half_angle_deg", half_angle_deg, 1.0, 60.0)
    if not (isinstance(n, int) and 3 <= n <= 201):
        raise SpecError("maps.n", f"must be an integer in [3, 201], got {n!r}")
    check_range("maps.near_vergence_d", near_vergence_d, 0.0, 10.0)
    check_range("maps.near_gaze_deg", near_gaze_deg, 1.0, 60.0)
    g = np.linspace(-half, half, n)
    gx, gy = np.meshgrid(g, g)
    vg = object_vergence(gy, near_vergence_d, near_gaze_deg).ravel()
    d = np.stack([np.tan(np.radians(gx.ravel())), np.tan(np.radians(gy.ravel())),
                  -np.ones(gx.size)], -1)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    with np.errstate(divide="ignore"):
        dist = np.where(vg > 0, 1.0 / vg, np.inf)          # from the turned pupil
    objects = ObjectPoints.along_gazes(d, dist, eye.rotation_centre)
    res = analyze_points(eye, lens, objects, wavelength_nm=wavelength_nm,
                         fixation="rotating")
    err = power_error(res, lens.rx, objects,
                      add_fraction=vg / near_vergence_d if near_vergence_d > 0 else None)
    ok = (res.status & np.uint8(FATAL)) == 0
    prism = np.where(ok, chief_prism(res)[0], np.nan)
    axis_tabo = tabo_axis(err["axis_wearer_deg"])
    surf = _surface_maps(lens, res, ok, wavelength_nm)
    marks = {}
    if getattr(lens.design, "near_point", None) is not None:
        from eyelab.optics.progressive import gaze_through

        for name, point in (("fitting cross", (0.0, 0.0)),
                            ("distance reference", lens.design.distance_point),
                            ("near reference", lens.design.near_point)):
            v = gaze_through(lens, point, eye.rotation_centre)
            marks[name] = (math.degrees(math.atan2(v[0], -v[2])),
                           math.degrees(math.atan2(v[1], -v[2])))

    def shape(a):
        return np.asarray(a, float).reshape(n, n)

    return AsWornMaps(g.copy(), g.copy(), shape(err["mean_d"]), shape(err["cylinder_d"]),
                      shape(axis_tabo), shape(err["sphere_d"]), shape(prism), shape(vg),
                      {k: shape(v) for k, v in surf.items()}, ok.reshape(n, n),
                      {"above": "infinity", "below": f"vergence rising linearly to "
                       f"{near_vergence_d:g} D at {near_gaze_deg:g} deg down, constant "
                       "below", "near_vergence_d": near_vergence_d,
                       "near_gaze_deg": near_gaze_deg}, marks)


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
