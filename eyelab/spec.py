"""Spec files (TOML): the eye, the lens and the object points for ``eyelab analyze``.

Every field is validated; an error names the field (dotted path) and the allowed range.
See ``eyelab/data/default.toml`` and the README for the format. Units: mm for lengths
unless a key ends in ``_m``; D for powers; degrees for angles.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from eyelab.errors import SpecError, check_range
from eyelab.imaging import View, check_bool, check_choice, check_rgb
from eyelab.optics.eye import (
    AMPLITUDE_MODELS,
    EYE_KINDS,
    MAX_ACCOMMODATION_D,
    Eye,
    hofstetter_amplitude,
    watson_yellott_pupil,
)
from eyelab.optics.fresnel import COATINGS
from eyelab.optics.lens import MIN_EDGE_THICKNESS, LensPose, SpectacleLens, check_feasible
from eyelab.optics.materials import get_material
from eyelab.optics.paths import ObjectPoints
from eyelab.optics.prescription import Prescription
from eyelab.optics.surfaces import Asphere, Surface, Toric
from eyelab.options import QUALITIES, RENDERERS, RasterQuality, quality_keys
from eyelab.scene.library import SCENE_NAMES
from eyelab.scene.scene import UNITS, SceneSource

EYE_KEYS = {"rx", "kind", "age", "amplitude_model", "accommodation_max_d", "pupil_diameter_mm",
            "luminance_cd_m2", "power_min_d", "astigmatism_d", "astigmatism_axis_deg",
            "retina_distance_mm", "n_vitreous", "rotation_centre_mm", "vertex_distance_mm",
            "chromatic", "accommodation_d"}
LENS_KEYS = {"rx", "material", "base_curve_d", "center_thickness_mm", "diameter_mm",
             "vertex_distance_mm", "pantoscopic_tilt_deg", "wrap_deg", "decentration_mm",
             "front", "back", "torus", "coating", "design", "corridor_mm", "inset_mm",
             "softness_mm"}
#: Lens designs an Rx with an add can be made into: its distance part, its near
#: prescription (sphere + add: reading glasses), or a progressive addition lens.
LENS_DESIGNS = ("single-vision", "near", "progressive")
#: Keys only a progressive design takes.
PROGRESSIVE_KEYS = ("corridor_mm", "inset_mm", "softness_mm")
SIDES = ("right", "left")
SURFACE_KEYS = {"type", "curvature", "radius_mm", "conic", "coefficients", "curvature_x",
                "curvature_y", "radius_x_mm", "radius_y_mm", "axis_deg", "revolve"}
ANALYSIS_KEYS = {"wavelength_nm", "fixation", "vertex_sphere"}
#: Keys that moved: where they are now (an old spec gets an error that says so).
MOVED = {"analysis.accommodation_d": "eye.accommodation_d",
         "render.focus_d": "eye.accommodation_d"}
POINT_KEYS = {"distance_m", "field_deg", "position_m", "field_polar_deg"}
BINOCULAR_KEYS = {"pd_mm", "monocular_pd_mm", "frame_pd_mm", "fixation_distance_m", "output"}
#: Keys a side's table ([eye.right], [lens.left], ...) may not hold: one value for both.
SHARED_ONLY = {"eye": ("accommodation_d",), "lens": ()}


@dataclass(frozen=True)
class RenderSpec:
    """The ``[render]`` table, validated: the scene (a built-in name or a mesh file path),
    the renderer's name, the :class:`~eyelab.imaging.View` and the renderer's quality
    options (:mod:`eyelab.options`). ``table`` keeps the keys as written, so that
    :meth:`with_changes` can re-validate them for another renderer or with overrides."""

    scene: SceneSource = SceneSource("room")
    renderer: str = "raster"
    view: View = View()
    quality: object = field(default_factory=RasterQuality)
    table: dict = field(default_factory=dict)
    #: A camera lens (:class:`eyelab.optics.system.LensSystem`, focused) that sees the
    #: scene instead of the eye: ``[render] camera`` (renderers in :data:`CAMERA_RENDERERS`).
    camera: object = None

    def with_changes(self, **changes) -> RenderSpec:
        """The same table with some keys replaced (None values are ignored), validated
        again; ``renderer`` may name another renderer (keys only the old one has are then
        dropped, as if never written)."""
        t = dict(self.table)
        t.update({k: v for k, v in changes.items() if v is not None})
        if "camera" in t and t.get("renderer") not in CAMERA_RENDERERS:
            raise SpecError("render.camera", f"a camera lens renders with "
                                             f"{' or '.join(map(repr, CAMERA_RENDERERS))}, not "
                                             f"{t.get('renderer')!r}")
        if "renderer" in changes and changes["renderer"] is not None:
            other = set(renderer_keys(self.renderer)) - set(renderer_keys(t["renderer"]))
            for k in other:
                t.pop(k, None)
        new = parse_render(t, None)
        # the eye's accommodation comes from [eye], not from this table: keep it
        return dataclasses.replace(new, view=dataclasses.replace(
            new.view, focus_d=self.view.focus_d))


#: Keys of ``[render]`` that every renderer takes (the rest are renderers' quality options).
RENDER_VIEW_KEYS = {"width": "width", "height": "height", "fov_y_deg": "fov_y_deg",
                    "near_m": "near", "far_m": "far", "cvd": "cvd",
                    "cvd_severity": "cvd_severity", "gaze_deg": "gaze_deg"}
#: Quality options that are display choices rather than spec keys.
_NOT_SPEC_KEYS = {"progress"}
#: Renderers that can look through a camera lens system instead of the eye, and the keys.
CAMERA_RENDERERS = ("reference", "imagebased")
CAMERA_KEYS = ("camera", "camera_focus_m", "camera_f_number")


@dataclass(frozen=True)
class Spec:
    eye: Eye
    lens: SpectacleLens | None
    points: ObjectPoints
    wavelength_nm: float = 587.56
    fixation: str = "fixed"
    accommodation: float | None = None
    source: str = "<built-in>"
    render: RenderSpec = field(default_factory=RenderSpec)
    vertex_sphere: str = "rotation_centre"
    #: Two eyes (:class:`eyelab.binocular.Binocular`) when the spec has [binocular] or
    #: per-eye tables; ``eye`` and ``lens`` are then the right eye's.
    binocular: object = None


def _check_keys(table, allowed, where):
    if not isinstance(table, dict):
        raise SpecError(where, f"must be a table, got {table!r}")
    for key in table:
        if f"{where}.{key}" in MOVED:
            raise SpecError(f"{where}.{key}", f"moved to {MOVED[f'{where}.{key}']} (one eye "
                            "state for analyze, render, inspect and batch alike)")
    unknown = sorted(set(table) - allowed, key=str)
    if unknown:
        near = difflib.get_close_matches(str(unknown[0]), sorted(allowed), n=1, cutoff=0.6)
        hint = f"did you mean {near[0]!r}? " if near else ""
        raise SpecError(f"{where}.{unknown[0]}", f"unknown key; {hint}allowed keys: "
                                                 f"{', '.join(sorted(allowed))}")


def _num(table, key, where, lo, hi, default=None):
    if key not in table:
        return default
    return check_range(f"{where}.{key}", table[key], lo, hi)


def _rx(value, field):
    if isinstance(value, Prescription):
        return value
    return Prescription.parse(value, field=field)


def parse_eye(t: dict) -> Eye:
    _check_keys(t, EYE_KEYS, "eye")
    # enumerations are checked even where the value would be unused; keys that only
    # take effect with another key are refused without it (never silently ignored)
    if "amplitude_model" in t:
        check_choice("eye.amplitude_model", t["amplitude_model"], tuple(AMPLITUDE_MODELS))
        if "age" not in t:
            raise SpecError("eye.amplitude_model", "only used with eye.age (Hofstetter's "
                                                   "amplitude for that age)")
    if "kind" in t:
        check_choice("eye.kind", t["kind"], EYE_KINDS)
    if "vertex_distance_mm" in t:
        _num(t, "vertex_distance_mm", "eye", 5, 30)          # a bad value first
    for key in ("kind", "vertex_distance_mm"):
        if key in t and "rx" not in t:
            raise SpecError(f"eye.{key}", "only used with eye.rx (the explicit powers "
                                          "define the eye as written)")
    kw = {}
    if "age" in t and "accommodation_max_d" in t:
        raise SpecError("eye.age", "give either age or accommodation_max_d, not both")
    if "age" in t:
        kw["accommodation_max"] = hofstetter_amplitude(
            check_range("eye.age", t["age"], 0, 120), t.get("amplitude_model", "mean"))
    elif "accommodation_max_d" in t:
        kw["accommodation_max"] = _num(t, "accommodation_max_d", "eye", 0, MAX_ACCOMMODATION_D)
    if "pupil_diameter_mm" in t and "luminance_cd_m2" in t:
        raise SpecError("eye.pupil_diameter_mm",
                        "give either pupil_diameter_mm or luminance_cd_m2, not both")
    if "pupil_diameter_mm" in t:
        kw["pupil_diameter"] = _num(t, "pupil_diameter_mm", "eye", 0.5, 10) * 1e-3
    elif "luminance_cd_m2" in t:
        kw["pupil_diameter"] = watson_yellott_pupil(t["luminance_cd_m2"],
                                                    t.get("age", 30.0)) * 1e-3
    if "n_vitreous" in t:
        kw["n_vitreous"] = _num(t, "n_vitreous", "eye", 1.2, 1.6)
    if "rotation_centre_mm" in t:
        kw["rotation_centre"] = _num(t, "rotation_centre_mm", "eye", 5, 20) * 1e-3
    if "chromatic" in t:
        kw["chromatic"] = check_bool("eye.chromatic", t["chromatic"])
    explicit = {"power_min_d", "astigmatism_d", "astigmatism_axis_deg"} & set(t)
    if "rx" in t:
        if explicit:
            raise SpecError(f"eye.{sorted(explicit)[0]}", "give either eye.rx or the explicit "
                            "power_min_d / astigmatism_d / astigmatism_axis_deg, not both")
        rx = _rx(t["rx"], "eye.rx")
        vd = _num(t, "vertex_distance_mm", "eye", 5, 30, 12.0) * 1e-3
        kind = t.get("kind", "refractive")
        if "retina_distance_mm" in t:
            kw["retina_distance"] = _num(t, "retina_distance_mm", "eye", 15, 35) * 1e-3
        try:
            return Eye.from_rx(rx, vertex_distance=vd, kind=kind, **kw)
        except SpecError as e:
            # the eye made from the Rx is out of range: blame what the user wrote
            key = e.field.split(".", 1)[-1]
            blamed = ("eye.retina_distance_mm" if key == "power_min_d"
                      and "retina_distance_mm" in t else f"eye.{key}" if key in t else "eye.rx")
            raise SpecError(blamed, f"with eye.rx = {str(rx)!r} the eye's {key} would be out "
                                    f"of range ({e.message})") from None
    if "power_min_d" in t:
        kw["power_min"] = _num(t, "power_min_d", "eye", 40, 80)
    if "astigmatism_d" in t:
        kw["astigmatism"] = _num(t, "astigmatism_d", "eye", 0, 10)
    if "astigmatism_axis_deg" in t:
        kw["astigmatism_axis_deg"] = _num(t, "astigmatism_axis_deg", "eye", 0, 180)
    if "retina_distance_mm" in t:
        kw["retina_distance"] = _num(t, "retina_distance_mm", "eye", 15, 35) * 1e-3
    return Eye(**kw)


def eye_accommodation(t: dict):
    """``[eye] accommodation_d``: None for "auto" (best effort per point, Kakimoto Eq. 13)
    or a fixed accommodation in D (0-25; an eye gives at most its amplitude)."""
    acc = t.get("accommodation_d", "auto")
    if isinstance(acc, str) and acc.strip().lower() == "auto":
        return None
    return check_range("eye.accommodation_d", acc, 0, MAX_ACCOMMODATION_D)


def _surface(t, where) -> Surface:
    _check_keys(t, SURFACE_KEYS, where)
    kind = t.get("type", "sphere")

    def curv(ck, rk):
        if ck in t and rk in t:
            raise SpecError(f"{where}.{ck}", f"give either {ck} (1/m) or {rk}, not both")
        if rk in t:
            r = check_range(f"{where}.{rk}", t[rk], -1e9, 1e9)
            if r == 0:
                raise SpecError(f"{where}.{rk}", "must be non-zero (use curvature = 0 for a plane)")
            return 1e3 / r
        return check_range(f"{where}.{ck}", t.get(ck, 0.0), -200, 200)

    if kind in ("sphere", "plane", "asphere", "conic"):
        c = 0.0 if kind == "plane" else curv("curvature", "radius_mm")
        k = check_range(f"{where}.conic", t.get("conic", 0.0), -100, 100)
        coeffs = t.get("coefficients", [])
        if not isinstance(coeffs, list):
            raise SpecError(f"{where}.coefficients", "must be a list of numbers [A4, A6, ...]")
        coeffs = tuple(check_range(f"{where}.coefficients[{i}]", v, -1e12, 1e12)
                       for i, v in enumerate(coeffs))
        return Asphere(c, k, coeffs)
    if kind == "toric":
        cx = curv("curvature_x", "radius_x_mm")
        cy = curv("curvature_y", "radius_y_mm")
        ax = math.radians(check_range(f"{where}.axis_deg", t.get("axis_deg", 0.0), -360, 360))
        rev = t.get("revolve", "y")
        if rev not in ("x", "y"):
            raise SpecError(f"{where}.revolve", f"must be 'x' or 'y', got {rev!r}")
        return Toric(cx, cy, ax, rev)
    raise SpecError(f"{where}.type", f"must be one of sphere, plane, asphere, toric; got {kind!r}")


def parse_lens(t: dict, eye_rx=None, side: str | None = None) -> SpectacleLens:
    """The [lens] table -> :class:`SpectacleLens` (``eye_rx``: the eye's Rx, the lens's
    when it has none; ``side``: "R"/"L", the eye a progressive design is made for when the
    Rx does not say)."""
    _check_keys(t, LENS_KEYS, "lens")
    dec = t.get("decentration_mm", [0.0, 0.0])
    if not (isinstance(dec, list) and len(dec) == 2):
        raise SpecError("lens.decentration_mm", f"must be [x, y] in mm, got {dec!r}")
    pose = LensPose(
        vertex_distance=_num(t, "vertex_distance_mm", "lens", 5, 30, 12.0) * 1e-3,
        pantoscopic_tilt_deg=_num(t, "pantoscopic_tilt_deg", "lens", -30, 30, 0.0),
        wrap_deg=_num(t, "wrap_deg", "lens", -30, 30, 0.0),
        decentration=tuple(check_range(f"lens.decentration_mm[{i}]", v, -20, 20) * 1e-3
                           for i, v in enumerate(dec)))
    material = get_material(t.get("material", "cr39"), field="lens.material")
    ct = _num(t, "center_thickness_mm", "lens", 0.2, 30)
    diam = _num(t, "diameter_mm", "lens", 10, 90)
    if "coating" in t:
        check_choice("lens.coating", t["coating"], COATINGS)
    if "design" in t:
        check_choice("lens.design", t["design"], LENS_DESIGNS)
    for key in PROGRESSIVE_KEYS:
        if key in t and t.get("design") != "progressive":
            raise SpecError(f"lens.{key}", "only with design = \"progressive\"")
    if "front" in t or "back" in t:
        for key in ("rx", "base_curve_d", "torus", "design"):
            if key in t:
                raise SpecError(f"lens.{key}", "not allowed with explicit front/back surfaces")
        for key in ("front", "back"):
            if key not in t:
                raise SpecError(f"lens.{key}", "an explicit lens needs both front and back")
        if ct is None:
            raise SpecError("lens.center_thickness_mm", "required with explicit surfaces")
        front, back = _surface(t["front"], "lens.front"), _surface(t["back"], "lens.back")
        check_feasible(front, back, ct * 1e-3, (diam or 60.0) * 1e-3,
                       min_edge=MIN_EDGE_THICKNESS)
        return SpectacleLens(front, back, ct * 1e-3, material, (diam or 60.0) * 1e-3, pose,
                             coating=t.get("coating", "none"))
    if "torus" in t:
        check_choice("lens.torus", t["torus"], ("x", "y"))
    if "rx" in t:
        rx = _rx(t["rx"], "lens.rx")
    elif eye_rx is not None:
        rx = eye_rx
    else:
        raise SpecError("lens.rx", "give the lens prescription (or explicit front/back surfaces)")
    if t.get("design") == "progressive":
        return _progressive(t, rx, material, pose, diam, side)
    rx = _design_rx(rx, t.get("design"), "lens.rx" if "rx" in t else "eye.rx")
    try:
        return SpectacleLens.from_rx(
            rx, material=material, base_curve=_num(t, "base_curve_d", "lens", -20, 30),
            center_thickness=None if ct is None else ct * 1e-3,
            diameter=None if diam is None else diam * 1e-3, pose=pose,
            torus=t.get("torus", "y"), coating=t.get("coating", "none"))
    except SpecError as e:
        if e.field == "lens.rx" and "rx" not in t:     # the lens took the eye's Rx
            raise SpecError("eye.rx", f"(the lens is made for it) {e.message}") from None
        raise


def _progressive(t, rx, material, pose, diam, side=None) -> SpectacleLens:
    """A progressive lens for the Rx's distance part and add (:mod:`eyelab.optics.
    progressive`); the design's lengths from the spec."""
    from eyelab.optics.progressive import ProgressiveDesign, progressive_lens

    if rx.add <= 0:
        raise SpecError("lens.design", f"a progressive lens needs an add in the Rx; "
                                       f"{rx.format()!r} has none")
    for key in ("base_curve_d", "center_thickness_mm", "torus"):
        if key in t:
            raise SpecError(f"lens.{key}", "not used by the progressive design (its front "
                                           "is the free-form, its thickness automatic)")
    design = ProgressiveDesign(
        rx.add, corridor=_num(t, "corridor_mm", "lens", 10, 22, 14.0) * 1e-3,
        inset=_num(t, "inset_mm", "lens", 0, 5, 2.5) * 1e-3,
        softness=_num(t, "softness_mm", "lens", 3, 30, 8.0) * 1e-3,
        eye=side or ("L" if rx.eye == "L" else "R"))
    lens, _, _ = progressive_lens(rx, rx.add, material=material, design=design, pose=pose,
                                  diameter=(diam or 60.0) * 1e-3)
    return lens


def _design_rx(rx: Prescription, design, where: str) -> Prescription:
    """The single-vision Rx a lens is made for: an add is never ignored silently."""
    if design is None:
        if rx.add > 0:
            raise SpecError("lens.design", f"{where} = {rx.format()!r} has an add: say "
                            "design = \"progressive\", \"single-vision\" (its distance "
                            f"part) or \"near\" (sphere + add = {rx.sphere + rx.add:+.2f}: "
                            "reading glasses)")
        return rx
    if design == "near":
        if rx.add == 0:
            raise SpecError("lens.design", f"\"near\" needs an add in {where}, which "
                                           f"{rx.format()!r} has not")
        return rx.near()
    return rx.distance()


def parse_points(items) -> ObjectPoints:
    if not isinstance(items, list) or not items:
        raise SpecError("points", "must be a non-empty array of tables [[points]]")
    dirs, dists = [], []
    for i, p in enumerate(items):
        where = f"points[{i}]"
        _check_keys(p, POINT_KEYS, where)
        if "position_m" in p:
            if "distance_m" in p or "field_deg" in p or "field_polar_deg" in p:
                raise SpecError(f"{where}.position_m", "give position_m or distance_m + "
                                                       "field_deg, not both")
            pos = p["position_m"]
            if not (isinstance(pos, list) and len(pos) == 3):
                raise SpecError(f"{where}.position_m", f"must be [x, y, z] in m, got {pos!r}")
            pos = np.array([check_range(f"{where}.position_m[{k}]", v, -1e6, 1e6)
                            for k, v in enumerate(pos)])
            d = float(np.linalg.norm(pos))
            if d == 0:
                raise SpecError(f"{where}.position_m", "must not be the pupil centre [0, 0, 0]")
            dirs.append(pos / d)
            dists.append(d)
            continue
        dist = p.get("distance_m", "inf")
        if isinstance(dist, str) and dist.strip().lower() in ("inf", "infinity"):
            dist = math.inf
        else:
            dist = check_range(f"{where}.distance_m", dist, 0.01, 1e7)
        if "field_polar_deg" in p:
            if "field_deg" in p:
                raise SpecError(f"{where}.field_polar_deg", "give field_deg or "
                                                            "field_polar_deg, not both")
            f = p["field_polar_deg"]
            if not (isinstance(f, list) and len(f) == 2):
                raise SpecError(f"{where}.field_polar_deg", f"must be [theta, phi] in degrees "
                                                            f"(eccentricity, azimuth), got {f!r}")
            th = math.radians(check_range(f"{where}.field_polar_deg[0]", f[0], 0, 80))
            ph = math.radians(check_range(f"{where}.field_polar_deg[1]", f[1], -360, 360))
            dirs.append(np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph),
                                  -math.cos(th)]))
            dists.append(dist)
            continue
        f = p.get("field_deg", [0.0, 0.0])
        if not (isinstance(f, list) and len(f) == 2):
            raise SpecError(f"{where}.field_deg", f"must be [x, y] in degrees, got {f!r}")
        fx, fy = (check_range(f"{where}.field_deg[{k}]", v, -80, 80) for k, v in enumerate(f))
        op = ObjectPoints.from_angles(dist, fx, fy)
        dirs.append(op.direction[0])
        dists.append(dist)
    return ObjectPoints(np.array(dirs), np.array(dists, float))


def renderer_keys(renderer: str) -> tuple:
    """The ``[render]`` keys a renderer takes: scene, renderer, the view's and its quality
    options'."""
    return ("scene", "renderer", "background", *RENDER_VIEW_KEYS,
            *(CAMERA_KEYS if renderer in CAMERA_RENDERERS else ()),
            *(k for k in quality_keys(renderer) if k not in _NOT_SPEC_KEYS))


def parse_render(t: dict, base: Path | None = None) -> RenderSpec:
    """The [render] table -> :class:`RenderSpec` (every key checked; a key another renderer
    takes is refused with the renderer it belongs to)."""
    if not isinstance(t, dict):
        raise SpecError("render", f"must be a table, got {t!r}")
    renderer = t.get("renderer", "raster")
    if renderer not in RENDERERS:
        raise SpecError("render.renderer", f"must be one of {', '.join(map(repr, RENDERERS))}, "
                                           f"got {renderer!r}")
    allowed = set(renderer_keys(renderer))
    every = {k for r in RENDERERS for k in renderer_keys(r)}
    for key in t:
        if key not in allowed and key in every:
            owners = [r for r in RENDERERS if key in renderer_keys(r)]
            raise SpecError(f"render.{key}", f"only for renderer = {' or '.join(map(repr, owners))}"
                                             f" (this spec uses {renderer!r})")
    _check_keys(t, allowed, "render")
    scene, written = parse_scene(t.get("scene", "room"), t.get("background"), base)
    view = View(**{attr: t[key] for key, attr in RENDER_VIEW_KEYS.items() if key in t})
    qkw = {k: t[k] for k in quality_keys(renderer) if k in t}
    for key in ("field_shape", "rim_color", "invalid_color"):
        if key in qkw and isinstance(qkw[key], list):
            qkw[key] = tuple(qkw[key])
    quality = QUALITIES[renderer](**qkw)
    table = dict(t, scene=written, renderer=renderer)
    return RenderSpec(scene, renderer, view, quality, table, parse_camera(t))


def parse_camera(t: dict):
    """``[render] camera`` (a named lens system of :data:`eyelab.optics.system.EXAMPLES`),
    ``camera_focus_m`` (object distance in focus from the first vertex, m, or "inf"; default
    "inf") and ``camera_f_number`` (the stop made smaller: f / stop diameter; default the
    lens's full aperture) -> the focused :class:`~eyelab.optics.system.LensSystem`, or None
    without ``camera``."""
    from eyelab.optics.system import EXAMPLES, full_f_number, get_system

    if "camera" not in t:
        for key in CAMERA_KEYS[1:]:
            if key in t:
                raise SpecError(f"render.{key}", "only with render.camera")
        return None
    name = check_choice("render.camera", t["camera"], tuple(EXAMPLES))
    system = get_system(name)
    focus = t.get("camera_focus_m", "inf")
    if isinstance(focus, str) and focus.strip().lower() in ("inf", "infinity"):
        focus = math.inf
    else:
        focus = check_range("render.camera_focus_m", focus, 0.2, 1e6)
    full = full_f_number(system)
    if "camera_f_number" in t:
        fnum = check_range("render.camera_f_number", t["camera_f_number"], full, 64)
        system = system.with_stop(system.cardinal()["efl_m"] / (2 * fnum))
    return system.focused(focus)


#: Keys of a ``[render] scene`` table (a mesh file placed in the world).
SCENE_KEYS = {"path", "position_m", "scale", "rotation_deg", "units", "distance_m",
              "contrast"}


def parse_scene(value, background, base: Path | None) -> tuple:
    """``[render] scene`` (a built-in name, a mesh path, or a table {path, position_m,
    scale, rotation_deg, units; distance_m, contrast for the built-in chart}) and
    ``[render] background`` -> (:class:`SceneSource`,
    the value with its path resolved, as the spec table keeps it)."""
    table = value if isinstance(value, dict) else {"path": value}
    if not isinstance(value, (str, dict)):
        raise SpecError("render.scene", f"must be one of {SCENE_NAMES}, a mesh file path or "
                                        "a table {path, position_m, scale, rotation_deg, "
                                        f"units}}, got {value!r}")
    where = "render.scene" if isinstance(value, str) else "render.scene.path"
    if isinstance(value, dict):
        _check_keys(value, SCENE_KEYS, "render.scene")
        if "path" not in value:
            raise SpecError("render.scene.path", "a scene table needs the mesh file's path")
    name = table["path"]
    if not isinstance(name, str):
        raise SpecError(where, f"must be a built-in scene name or a mesh file path, "
                               f"got {name!r}")
    if name not in SCENE_NAMES:
        p = Path(name) if base is None or Path(name).is_absolute() else base / name
        try:
            ok = p.is_file()
        except OSError:
            ok = False
        if not ok:
            raise SpecError(where, f"{name[:80]!r} is neither a built-in scene "
                                   f"({', '.join(SCENE_NAMES)}) nor an existing mesh file")
        name = str(p)

    def triple(key, lo, hi):
        v = table.get(key, [0.0, 0.0, 0.0])
        if not (isinstance(v, list) and len(v) == 3):
            raise SpecError(f"render.scene.{key}", f"must be [x, y, z], got {v!r}")
        return tuple(check_range(f"render.scene.{key}[{i}]", x, lo, hi)
                     for i, x in enumerate(v))

    units = table.get("units", "m")
    check_choice("render.scene.units", units, tuple(UNITS))
    bg = None if background is None else check_rgb("render.background", background)
    chart = {}
    for key, lo, hi in (("distance_m", 0.1, 100.0), ("contrast", 0.0, 1.0)):
        if key in table:
            if name != "chart":
                raise SpecError(f"render.scene.{key}", "only for the built-in chart "
                                                       "(path = \"chart\")")
            chart[key] = check_range(f"render.scene.{key}", table[key], lo, hi)
    src = SceneSource(name, chart_distance_m=chart.get("distance_m"),
                      chart_contrast=chart.get("contrast"),
                      position_m=triple("position_m", -1e4, 1e4),
                      scale=check_range("render.scene.scale", table.get("scale", 1.0), 1e-9,
                                        1e9, lo_open=True),
                      rotation_deg=triple("rotation_deg", -360, 360), units=units,
                      background=bg)
    return src, (dict(value, path=name) if isinstance(value, dict) else name)


def parse_spec(data: dict, source: str = "<dict>", base: Path | None = None) -> Spec:
    _check_keys(data, {"eye", "lens", "analysis", "points", "render", "binocular"}, "spec")
    eye_t = data.get("eye", {})
    bino = None
    if "binocular" in data or _has_sides(eye_t) or _has_sides(data.get("lens")):
        bino = parse_binocular(data)
        eye, lens = bino.right, bino.right_lens
        eye_t = {k: v for k, v in eye_t.items() if k not in SIDES}
    else:
        eye = parse_eye(eye_t)
        lens = None
        if "lens" in data:
            eye_rx = _rx(eye_t["rx"], "eye.rx") if "rx" in eye_t else None
            lens = parse_lens(data["lens"], eye_rx)
    an = data.get("analysis", {})
    _check_keys(an, ANALYSIS_KEYS, "analysis")
    wl = _num(an, "wavelength_nm", "analysis", 380, 780, 587.56)
    # two eyes fixate each point (vergence) unless the spec says otherwise
    fix = an.get("fixation", "fixed" if bino is None else "rotating")
    if fix not in ("fixed", "rotating"):
        raise SpecError("analysis.fixation", f"must be 'fixed' or 'rotating', got {fix!r}")
    acc = eye_accommodation(eye_t) if isinstance(eye_t, dict) else None
    vsph = check_choice("analysis.vertex_sphere", an.get("vertex_sphere", "rotation_centre"),
                        ("rotation_centre", "pupil"))
    points = parse_points(data.get("points", [{"distance_m": "inf"}]))
    render = parse_render(data.get("render", {}), base)
    if render.camera is not None:
        for table in ("lens", "binocular"):
            if table in data:
                raise SpecError("render.camera", f"a camera lens sees the scene; [{table}] "
                                                 "has no meaning with it")
        if data.get("eye"):
            raise SpecError("render.camera", "a camera lens sees the scene; [eye] has no "
                                             "meaning with it")
    render = dataclasses.replace(render, view=dataclasses.replace(render.view, focus_d=acc))
    return Spec(eye, lens, points, wl, fix, acc, source, render, vsph, bino)


def one_eye(spec: Spec, what: str) -> Spec:
    """``spec``, or a one-line error naming ``[binocular]`` when it has two eyes and
    ``what`` (the inspector, batch, maps) shows one."""
    if spec.binocular is not None:
        raise SpecError("binocular", f"{what} shows one eye; this spec has two ([binocular] "
                                     "or per-eye tables): use eyelab render, demo or analyze")
    return spec


def _has_sides(t) -> bool:
    return isinstance(t, dict) and any(s in t for s in SIDES)


def _split_sides(t, where) -> tuple:
    """(shared keys, {side: that side's table}) of an [eye] or [lens] table."""
    if t is None:
        return None, {}
    if not isinstance(t, dict):
        raise SpecError(where, f"must be a table, got {t!r}")
    sides = {}
    for side in SIDES:
        st = t.get(side, {})
        if not isinstance(st, dict):
            raise SpecError(f"{where}.{side}", f"must be a table of {where} keys, got {st!r}")
        for key in SHARED_ONLY[where]:
            if key in st:
                raise SpecError(f"{where}.{side}.{key}", f"one value for both eyes: give it "
                                                         f"in [{where}]")
        sides[side] = st
    return {k: v for k, v in t.items() if k not in SIDES}, sides


def _for_side(where, side, own, fn):
    """``fn()``, with an error in a key the side's own table holds renamed to it."""
    try:
        return fn()
    except SpecError as e:
        head, _, rest = e.field.partition(".")
        key = rest.split("[")[0].split(".")[0]
        if head == where and key in own:
            raise SpecError(f"{where}.{side}.{rest}", e.message) from None
        raise


def parse_binocular(data: dict):
    """A spec with two eyes -> :class:`eyelab.binocular.Binocular`.

    ``[eye]`` and ``[lens]`` hold what both sides share; ``[eye.right]``, ``[eye.left]``,
    ``[lens.right]``, ``[lens.left]`` any key of their table for one side (over the
    shared value); ``[binocular]`` the pupillary distances, the frame PD, the fixation
    distance and the output. Each lens's optical centre goes ``frame_pd_mm`` / 2 from the
    midline (in front of its pupil without it), plus any ``decentration_mm`` written
    (world frame: x to the wearer's right); ``wrap_deg`` is face-form for both lenses (the
    left lens's pose takes its mirror image); a progressive design gets its side's inset.
    """
    from eyelab.binocular import OUTPUTS, Binocular

    bt = data.get("binocular", {})
    _check_keys(bt, BINOCULAR_KEYS, "binocular")
    if "pd_mm" in bt and "monocular_pd_mm" in bt:
        raise SpecError("binocular.pd_mm", "give either pd_mm or monocular_pd_mm, not both")
    if "monocular_pd_mm" in bt:
        m = bt["monocular_pd_mm"]
        if not (isinstance(m, list) and len(m) == 2):
            raise SpecError("binocular.monocular_pd_mm", f"must be [right, left] in mm, "
                                                         f"got {m!r}")
        mpd = tuple(check_range(f"binocular.monocular_pd_mm[{i}]", v, 20, 40) * 1e-3
                    for i, v in enumerate(m))
    else:
        pd = _num(bt, "pd_mm", "binocular", 40, 80, 64.0) * 1e-3
        mpd = (pd / 2, pd / 2)
    fpd = _num(bt, "frame_pd_mm", "binocular", 40, 80)
    fix = bt.get("fixation_distance_m", "inf")
    if isinstance(fix, str) and fix.strip().lower() in ("inf", "infinity"):
        fix = math.inf
    else:
        fix = check_range("binocular.fixation_distance_m", fix, 0.1, 1e7)
    output = check_choice("binocular.output", bt.get("output", "side-by-side"), OUTPUTS)
    eye_shared, eye_sides = _split_sides(data.get("eye", {}), "eye")
    lens_shared, lens_sides = _split_sides(data.get("lens"), "lens")
    eyes, lenses = {}, {}
    for side in SIDES:
        letter = side[0].upper()
        et = {**eye_shared, **eye_sides[side]}
        eyes[side] = _for_side("eye", side, eye_sides[side], lambda et=et: parse_eye(et))
        eye_rx = None
        if "rx" in et:
            where = _written("eye", side, eye_sides[side], "rx")
            eye_rx = _rx(et["rx"], where)
            _check_side(eye_rx, side, where)
        if lens_shared is None:
            lenses[side] = None
            continue
        own = lens_sides[side]
        lt = {**lens_shared, **own}
        if "rx" in lt:
            where = _written("lens", side, own, "rx")
            _check_side(_rx(lt["rx"], where), side, where)
        dec = lt.get("decentration_mm", [0.0, 0.0])
        where = _written("lens", side, own, "decentration_mm")
        if not (isinstance(dec, list) and len(dec) == 2):
            raise SpecError(where, f"must be [x, y] in mm, got {dec!r}")
        dec = [check_range(f"{where}[{i}]", v, -20, 20) for i, v in enumerate(dec)]
        if fpd is not None:
            sign = 1.0 if side == "right" else -1.0
            dec[0] += sign * (fpd / 2 - mpd[0 if side == "right" else 1] * 1e3)
            if abs(dec[0]) > 20:
                raise SpecError("binocular.frame_pd_mm", f"puts the {side} lens's optical "
                                f"centre {dec[0]:+.1f} mm from its pupil; at most 20 mm")
        lt["decentration_mm"] = dec
        if "wrap_deg" in lt and side == "left":
            lt["wrap_deg"] = -check_range(_written("lens", side, own, "wrap_deg"),
                                          lt["wrap_deg"], -30, 30)
        lenses[side] = _for_side("lens", side, own, lambda lt=lt, rx=eye_rx, s=letter:
                                 parse_lens(lt, rx, side=s))
    return Binocular(eyes["right"], eyes["left"], lenses["right"], lenses["left"], mpd,
                     None if fpd is None else fpd * 1e-3, fix, output)


def _written(table: str, side: str, own: dict, key: str) -> str:
    """The field a binocular value came from: the side's table where it holds the key,
    else the shared one."""
    return f"{table}.{side}.{key}" if key in own else f"{table}.{key}"


def _check_side(rx: Prescription, side: str, where: str) -> None:
    """An Rx that names an eye (R/L/OD/OS) must be the side it is given for."""
    if rx.eye in ("R", "L") and rx.eye != side[0].upper():
        eye = "right" if rx.eye == "R" else "left"
        raise SpecError(where, f"{rx.format()!r} is for the {eye} eye, given for the {side}")


def load_spec(path: str | Path | None = None) -> Spec:
    """Load a TOML spec; ``None`` loads the built-in default scene."""
    data, source, base = read_spec_data(path)
    return parse_spec(data, source, base)


def read_spec_data(path: str | Path | None = None) -> tuple:
    """(table, source, base folder) of a TOML spec file, unvalidated (:func:`parse_spec`
    checks it); ``None``: the built-in default."""
    if path is None:
        text = resources.files("eyelab").joinpath("data/default.toml").read_text()
        source = "<built-in default>"
        base = None
    else:
        p = Path(path)
        shown = str(p) if len(str(p)) <= 80 else f"{str(p)[:40]}... ({len(str(p))} characters)"
        try:
            if not p.is_file():
                raise SpecError("spec", f"file not found (or not a file): {shown!r}")
            raw = p.read_bytes()
        except OSError as e:
            raise SpecError("spec", f"cannot read {shown!r}: {e.strerror}") from None
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as e:
            raise SpecError("spec", f"{shown} is not a UTF-8 text file (byte {e.start}): a "
                                    "spec is TOML text; a mesh goes in [render] scene") from None
        source = str(p)
        base = p.parent
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SpecError("spec", f"{source} is not valid TOML: {e}") from None
    except RecursionError:
        raise SpecError("spec", f"{source}: nesting too deep") from None
    return data, source, base


def dump_spec(data: dict) -> str:
    """A spec table as TOML text that :func:`tomllib.loads` reads back equal: tables of
    scalars, strings, lists of scalars, nested tables ([lens.front]) and arrays of tables
    ([[points]]); floats written exactly (``repr``), infinities as ``inf``.

    >>> import tomllib
    >>> d = {"eye": {"rx": "-2.00 DS", "age": 40}, "points": [{"distance_m": "inf"}]}
    >>> tomllib.loads(dump_spec(d)) == d
    True
    """
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, int):
            return str(v)
        if isinstance(v, float):
            return ("inf" if v > 0 else "-inf") if math.isinf(v) else \
                ("nan" if math.isnan(v) else repr(v))
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + "}"
        raise SpecError("spec", f"cannot write {v!r} as TOML")

    def table(name, t, lines):
        scalars = {k: v for k, v in t.items() if not isinstance(v, dict)
                   and not (isinstance(v, list) and v and all(isinstance(x, dict) for x in v))}
        lines.append(f"[{name}]")
        lines.extend(f"{k} = {value(v)}" for k, v in scalars.items())
        lines.append("")
        for k, v in t.items():
            if isinstance(v, dict):
                table(f"{name}.{k}", v, lines)
            elif k not in scalars:
                for item in v:
                    lines.append(f"[[{name}.{k}]]")
                    lines.extend(f"{kk} = {value(vv)}" for kk, vv in item.items())
                    lines.append("")

    lines = []
    for name, t in data.items():
        if isinstance(t, dict):
            table(name, t, lines)
        elif isinstance(t, list):
            for item in t:
                lines.append(f"[[{name}]]")
                lines.extend(f"{k} = {value(v)}" for k, v in item.items())
                lines.append("")
        else:
            raise SpecError(f"spec.{name}", "top-level entries must be tables")
    return "\n".join(lines)
