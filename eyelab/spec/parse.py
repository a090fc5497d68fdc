"""Spec files (TOML): the eye, the lens and the object points for ``eyelab analyze``.

Every field is validated; an error names the field (dotted path) and the allowed range.
See ``eyelab/data/default.toml`` and docs/reference/spec.md for the format. Units: mm for
lengths unless a key ends in ``_m``; D for powers; degrees for angles.
"""

from __future__ import annotations

import difflib
import math

import numpy as np

from eyelab.core.checks import check_choice
from eyelab.core.errors import SpecError
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import (
    AMPLITUDE_MODELS,
    EYE_KINDS,
    Eye,
)
from eyelab.optics.lens.pointsfile import FIRST_ROWS, check_covers, read_points
from eyelab.optics.lens.spectacle import MIN_EDGE_THICKNESS, LensPose, SpectacleLens, check_feasible
from eyelab.optics.rays.fresnel import COATINGS
from eyelab.optics.rays.materials import get_material
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.optics.rays.surfaces import REVOLVE_AXES, Asphere, Surface, Toric
from eyelab.spec import tables
from eyelab.spec.aberrationparse import eye_aberrations
from eyelab.spec.eyemodel import eye_model, eye_options, parse_schematic
from eyelab.spec.eyerx import dioptres, eye_rx_ranges
from eyelab.spec.schema import (
    EYE_VERTEX_MM,
    LENS_DESIGNS,
    SURFACE_TYPE_KEYS,
    SURFACE_TYPES,
    SYMMETRIC_SURFACES,
    check,
)
from eyelab.spec.surfacefile import spec_file
from eyelab.spec.tables import check_keys, check_rules, choice, number, rx_value

EYE_KEYS = {"rx", "kind", "age", "amplitude_model", "accommodation_max_d", "pupil_diameter_mm",
            "luminance_cd_m2", "power_min_d", "astigmatism_d", "astigmatism_axis_deg",
            "retina_distance_mm", "n_vitreous", "rotation_centre_mm", "vertex_distance_mm",
            "chromatic", "accommodation_d", "aberrations", "model", "axial_length_mm"}
LENS_KEYS = {"rx", "material", "base_curve_d", "center_thickness_mm", "diameter_mm",
             "vertex_distance_mm", "pantoscopic_tilt_deg", "wrap_deg", "decentration_mm",
             "front", "back", "torus", "coating", "design", "corridor_mm", "inset_mm",
             "softness_mm", "optimise", "lenslets"}
#: Keys only a progressive design takes.
PROGRESSIVE_KEYS = ("corridor_mm", "inset_mm", "softness_mm", "optimise")
SURFACE_KEYS = {k for keys in SURFACE_TYPE_KEYS.values() for k in keys}
ANALYSIS_KEYS = {"wavelength_nm", "fixation", "vertex_sphere"}
POINT_KEYS = {"distance_m", "field_deg", "position_m", "field_polar_deg"}
BINOCULAR_KEYS = {"pd_mm", "monocular_pd_mm", "frame_pd_mm", "fixation_distance_m", "output"}
#: Other names of the lens designs (:data:`~eyelab.spec.schema.LENS_DESIGNS`), for "did you
#: mean".
DESIGN_ALIASES = {"pal": "progressive", "varifocal": "progressive", "varifocals": "progressive",
                  "multifocal": "progressive", "progressive addition": "progressive",
                  "sv": "single-vision", "single vision": "single-vision",
                  "distance": "single-vision", "reading": "near", "readers": "near"}
#: A DCS file's surface letters (SURFMT field 3).
_FACES = {"F": "front", "B": "back"}


def parse_eye(t: dict):
    """The ``[eye]`` table -> :class:`~eyelab.optics.eye.thin.Eye`: from ``rx`` (the eye its
    spectacle Rx corrects) or from the explicit powers; with ``model`` a schematic eye
    (:func:`~eyelab.spec.eyemodel.parse_schematic`)."""
    check_keys(t, EYE_KEYS, "eye")
    model = eye_model(t)
    if model != "thin":
        return parse_schematic(t, model, number(t, "vertex_distance_mm", "eye",
                                                EYE_VERTEX_MM))
    # enumerations are checked even where the value would be unused; keys that only
    # take effect with another key are refused without it (never silently ignored)
    if "amplitude_model" in t:
        check_choice("eye.amplitude_model", t["amplitude_model"], tuple(AMPLITUDE_MODELS))
    if "kind" in t:
        check_choice("eye.kind", t["kind"], EYE_KINDS)
    if "vertex_distance_mm" in t:
        number(t, "vertex_distance_mm", "eye")          # a bad value first
    t, aberrations = eye_aberrations(t, number(t, "vertex_distance_mm", "eye", EYE_VERTEX_MM))
    check_rules(t, "eye")      # the aberrations' Rx is eye.rx here (its vertex distance, kind)
    kw = dict(eye_options(t), aberrations=aberrations)
    if "rx" in t:
        return _eye_from_rx(t, kw)
    for key, attr in (("power_min_d", "power_min"), ("astigmatism_d", "astigmatism"),
                      ("astigmatism_axis_deg", "astigmatism_axis_deg")):
        if key in t:
            kw[attr] = number(t, key, "eye")
    if "retina_distance_mm" in t:
        kw["retina_distance"] = number(t, "retina_distance_mm", "eye") * 1e-3
    return Eye(**kw)


def _eye_from_rx(t: dict, kw: dict) -> Eye:
    """The eye ``eye.rx`` corrects; an eye out of range blames the key that made it so."""
    rx = rx_value(t["rx"], "eye.rx")
    vd = number(t, "vertex_distance_mm", "eye", EYE_VERTEX_MM) * 1e-3
    if "retina_distance_mm" in t:
        kw["retina_distance"] = number(t, "retina_distance_mm", "eye") * 1e-3
    kind = t.get("kind", "refractive")
    try:
        return Eye.from_rx(rx, vertex_distance=vd, kind=kind, **kw)
    except SpecError as e:
        key = e.field.split(".", 1)[-1]
        blamed = ("eye.retina_distance_mm" if key == "power_min_d"
                  and "retina_distance_mm" in t else f"eye.{key}" if key in t else "eye.rx")
        retina = kw.get("retina_distance")
        takes = eye_rx_ranges(vd * 1e3, kind, None if retina is None else retina * 1e3,
                              kw.get("n_vitreous"))
        raise SpecError(blamed, f"with eye.rx = {str(rx)!r} the eye's {key} would be out "
                        f"of range ({e.message}); at {vd * 1e3:g} mm this {kind} eye takes a "
                        f"sphere alone {dioptres(*takes['sphere'])}, a cylinder on a plano "
                        f"sphere {dioptres(*takes['cylinder'])}") from None


def eye_accommodation(t: dict):
    """``[eye] accommodation_d``: None for "auto" (best effort per point, Kakimoto Eq. 13)
    or a fixed accommodation in D (0-25; an eye gives at most its amplitude)."""
    acc = t.get("accommodation_d", "auto")
    if isinstance(acc, str) and acc.strip().lower() == "auto":
        return None
    return check("eye.accommodation_d", acc)


def _surface(t, where, diameter: float = 0.06, side=None) -> Surface:
    """A surface table ([lens.front], [lens.back]) of a lens of ``diameter`` (m) for the
    eye ``side`` ("R"/"L"/None)."""
    check_keys(t, SURFACE_KEYS, where)
    kind = t.get("type", "points" if "file" in t else "sphere")
    tables.check_surface_type_keys(t, kind, where)
    if kind == "points":
        return _points(t, where, diameter, side)

    def curv(ck, rk):
        if ck in t and rk in t:
            raise SpecError(f"{where}.{ck}", f"give either {ck} (1/m) or {rk}, not both")
        if rk in t:
            r = check(f"{where}.{rk}", t[rk])
            if r == 0:
                raise SpecError(f"{where}.{rk}", "must be non-zero (use curvature = 0 for a plane)")
            return 1e3 / r
        return check(f"{where}.{ck}", t.get(ck, 0.0))

    if kind in SYMMETRIC_SURFACES:
        c = 0.0 if kind == "plane" else curv("curvature", "radius_mm")
        k = check(f"{where}.conic", t.get("conic", 0.0))
        coeffs = t.get("coefficients", [])
        if not isinstance(coeffs, list):
            raise SpecError(f"{where}.coefficients", "must be a list of numbers [A4, A6, ...]")
        coeffs = tuple(check(f"{where}.coefficients[{i}]", v)
                       for i, v in enumerate(coeffs))
        return Asphere(c, k, coeffs)
    if kind == "toric":
        cx = curv("curvature_x", "radius_x_mm")
        cy = curv("curvature_y", "radius_y_mm")
        ax = math.radians(check(f"{where}.axis_deg", t.get("axis_deg", 0.0)))
        rev = t.get("revolve", "y")
        if rev not in REVOLVE_AXES:
            raise SpecError(f"{where}.revolve", f"must be 'x' or 'y', got {rev!r}")
        return Toric(cx, cy, ax, rev)
    raise SpecError(f"{where}.type", f"must be one of {', '.join(SURFACE_TYPES)}; got {kind!r}")


def _points(t, where, diameter, side=None):
    """A ``type = "points"`` surface (:mod:`eyelab.spec.surfacefile`): its keys checked
    before its file is read, the file's grid reaching the rim of a lens of ``diameter``."""
    first = check_choice(f"{where}.first_row", t.get("first_row", "bottom"), FIRST_ROWS)
    spacing = number(t, "spacing_mm", where)
    if "file" not in t:
        raise SpecError(f"{where}.file", 'type = "points" reads the surface from a file: '
                                         'file = "surface.sdf" (or .csv, .npy)')
    path = spec_file(t["file"], f"{where}.file")
    if spacing is not None and path.suffix.lower() == ".sdf":
        raise SpecError(f"{where}.spacing_mm", "a .sdf file gives its own spacing (SURFMT)")
    grid = read_points(path, f"{where}.file", spacing_mm=spacing, first_row=first)
    face = "F" if where.endswith("front") else "B"
    if grid.surface and grid.surface != face:
        raise SpecError(f"{where}.file", f"{path.name} is the {_FACES[grid.surface]} surface "
                                         f"(SURFMT field 3: {grid.surface}), given as "
                                         f"[{where}]")
    if grid.side and side in ("R", "L") and grid.side != side:
        eyes = {"R": "right", "L": "left"}
        raise SpecError(f"{where}.file", f"{path.name} is a {eyes[grid.side]} lens's surface "
                                         f"(SURFMT field 2: {grid.side}), given for the "
                                         f"{eyes[side]} eye (a mirrored surface is another "
                                         f"surface: write the {eyes[side]} one)")
    check_covers(grid, diameter, f"{where}.file")
    return grid.freeform()


def parse_lens(t: dict, eye_rx=None, side: str | None = None) -> SpectacleLens:
    """The [lens] table -> :class:`SpectacleLens` (``eye_rx``: the eye's Rx, the lens's
    when it has none; ``side``: "R"/"L", the eye a progressive design is made for when the
    Rx does not say), with its ``[lens.lenslets]`` on the front."""
    lens = _lens(t, eye_rx, side)
    if "lenslets" in t:
        from eyelab.spec.lenslets import parse_lenslets
        lens = parse_lenslets(t["lenslets"], lens)
    return lens


def _lens(t: dict, eye_rx, side) -> SpectacleLens:
    check_keys(t, LENS_KEYS, "lens")
    pose = _lens_pose(t)
    material = _material(t.get("material", "cr39"))
    ct = number(t, "center_thickness_mm", "lens")
    diam = number(t, "diameter_mm", "lens")
    if "coating" in t:
        check_choice("lens.coating", t["coating"], COATINGS)
    if "design" in t:
        choice("lens.design", t["design"], LENS_DESIGNS, DESIGN_ALIASES)
    for key in PROGRESSIVE_KEYS:
        if key in t and t.get("design") != "progressive":
            raise SpecError(f"lens.{key}", "only with design = \"progressive\"")
    if "front" in t or "back" in t:
        return _explicit_lens(t, material, pose, ct, diam, side)
    if "torus" in t:
        check_choice("lens.torus", t["torus"], REVOLVE_AXES)
    rx = _lens_rx(t, eye_rx)
    where = "lens.rx" if "rx" in t else "eye.rx"
    if t.get("design") == "progressive":
        return _progressive(t, rx, where, material, pose, (diam or 60.0) * 1e-3, side)
    rx = _design_rx(rx, t.get("design"), where)
    try:
        return SpectacleLens.from_rx(
            rx, material=material, base_curve=number(t, "base_curve_d", "lens"),
            center_thickness=None if ct is None else ct * 1e-3,
            diameter=None if diam is None else diam * 1e-3, pose=pose,
            torus=t.get("torus", "y"), coating=t.get("coating", "none"))
    except SpecError as e:
        if e.field == "lens.rx" and "rx" not in t:     # the lens took the eye's Rx
            raise SpecError("eye.rx", f"(the lens is made for it) {e.message}") from None
        raise


def _material(value):
    """``lens.material`` (:func:`~eyelab.optics.rays.materials.get_material`); a number, or a
    name no material has, gets "did you mean" the catalogue name it may stand for."""
    try:
        return get_material(value, field="lens.material")
    except SpecError as e:
        if e.field != "lens.material":
            raise
        hint = _material_hint(value)
        raise SpecError(e.field, e.message + (f"; {hint}" if hint else "")) from None


def _material_hint(value) -> str:
    """What a refused material may have meant: a nominal index written as a number or
    without its last digit ("1.6": "1.60"), the catalogue material of the nearest index,
    or a name spelt nearly so."""
    from eyelab.optics.rays.materials import ALIASES, CATALOGUE

    names = [k for k in CATALOGUE if k != "air"] + [k for k in ALIASES if "-" not in k]
    try:
        n = float(value) if isinstance(value, (int, float, str)) \
            and not isinstance(value, bool) else None
    except (ValueError, OverflowError):
        n = None
    if n is None or not math.isfinite(n):
        near = difflib.get_close_matches(str(value).strip().lower(), names, n=1, cutoff=0.6)
        return f"did you mean {near[0]!r}?" if near and isinstance(value, str) else ""
    named = [k for k in ALIASES if k[:1].isdigit() and float(k) == n]
    closest = min((m for k, m in CATALOGUE.items() if k != "air"),
                  key=lambda m: abs(m.n_d - n))
    if named:
        return f"did you mean {named[0]!r} (a name, in quotes)?"
    return (f"an index alone is not a material: the catalogue's nearest is "
            f"{closest.name!r} (n_d {closest.n_d:.3f}), or write {{n_d = {n:g}, v_d = ...}}")


def _lens_pose(t: dict) -> LensPose:
    """The lens's pose from ``[lens]``: vertex distance, tilt, wrap, decentration."""
    dec = t.get("decentration_mm", [0.0, 0.0])
    if not (isinstance(dec, list) and len(dec) == 2):
        raise SpecError("lens.decentration_mm", f"must be [x, y] in mm, got {dec!r}")
    return LensPose(
        vertex_distance=number(t, "vertex_distance_mm", "lens", 12.0) * 1e-3,
        pantoscopic_tilt_deg=number(t, "pantoscopic_tilt_deg", "lens", 0.0),
        wrap_deg=number(t, "wrap_deg", "lens", 0.0),
        decentration=tuple(check(f"lens.decentration_mm[{i}]", v) * 1e-3
                           for i, v in enumerate(dec)))


def _lens_rx(t: dict, eye_rx):
    """The Rx a lens is made for: its own, else the eye's."""
    if "rx" in t:
        return rx_value(t["rx"], "lens.rx")
    if eye_rx is not None:
        return eye_rx
    raise SpecError("lens.rx", "give the lens prescription (or explicit front/back surfaces)")


def _explicit_lens(t: dict, material, pose, ct, diam, side=None) -> SpectacleLens:
    """A lens given surface by surface ([lens.front], [lens.back], centre thickness);
    ``side`` ("R"/"L", or None: the lens Rx's, if it names one): the eye it is for, which
    a points file's own eye must match."""
    points = [k for k in ("front", "back") if _is_points(t.get(k))]
    for key in ("rx", "base_curve_d", "torus", "design")[bool(points):]:
        if key in t:
            raise SpecError(f"lens.{key}", "not allowed with explicit front/back surfaces")
    for key in ("front", "back"):
        if key not in t:
            raise SpecError(f"lens.{key}", "an explicit lens needs both front and back")
    if ct is None:
        raise SpecError("lens.center_thickness_mm", "required with explicit surfaces")
    # with a points surface, rx is what the lens was made for: analyze's power errors and
    # the as-worn maps compare the lens with it
    rx = rx_value(t["rx"], "lens.rx") if "rx" in t else None
    if side is None and rx is not None and rx.eye in ("R", "L"):
        side = rx.eye
    d = (diam or 60.0) * 1e-3
    front = _surface(t["front"], "lens.front", d, side)
    back = _surface(t["back"], "lens.back", d, side)
    check_feasible(front, back, ct * 1e-3, d, min_edge=MIN_EDGE_THICKNESS)
    return SpectacleLens(front, back, ct * 1e-3, material, d, pose, rx,
                         coating=t.get("coating", "none"))


def _is_points(t) -> bool:
    """Whether a surface table is ``type = "points"`` (the default where it has a file)."""
    return isinstance(t, dict) and t.get("type", "points" if "file" in t else None) == "points"


def _progressive(t, rx, where, material, pose, diameter, side=None) -> SpectacleLens:
    """A progressive lens for the Rx's distance part and add (:mod:`eyelab.optics.
    progressive`); the design's lengths from the spec, its side the eye's (``side``), else
    the Rx's, else right. A design that does not fit the lens is refused naming the key
    to change (:func:`_progressive_misfit`), never the engine's surface."""
    from eyelab.optics.lens.optimise import optimised_progressive
    from eyelab.optics.lens.progressive import ProgressiveDesign, progressive_lens

    if rx.add <= 0:
        raise SpecError("lens.design", f"a progressive lens needs an add in the Rx; "
                                       f"{rx.format()!r} has none")
    for key in ("base_curve_d", "center_thickness_mm", "torus"):
        if key in t:
            raise SpecError(f"lens.{key}", "not used by the progressive design (its front "
                                           "is the free-form, its thickness automatic)")
    try:
        design = ProgressiveDesign(
            rx.add, corridor=number(t, "corridor_mm", "lens", 14.0) * 1e-3,
            inset=number(t, "inset_mm", "lens", 2.5) * 1e-3,
            softness=number(t, "softness_mm", "lens", 8.0) * 1e-3,
            eye=side or ("L" if rx.eye == "L" else "R"))
    except SpecError as e:
        if e.field != "lens.add":
            raise
        raise SpecError(where, f"the add of {rx.format()!r}, for a progressive design: "
                               f"{e.message}") from None
    _check_near_point(t, design, diameter)
    preset = _optimise(t.get("optimise", "none"))
    try:
        if preset == "none":
            lens, _, _ = progressive_lens(rx, rx.add, material=material, design=design,
                                          pose=pose, diameter=diameter)
        else:
            lens, _, _ = optimised_progressive(rx, rx.add, preset, material=material,
                                               design=design, pose=pose, diameter=diameter)
    except SpecError as e:
        if not e.field.startswith("surface."):
            raise
        raise _progressive_misfit(t, rx, material, pose, design, diameter) from None
    return lens


def _optimise(v) -> str:
    """``lens.optimise``: "none" (the analytic design) or a preset's name."""
    from eyelab.optics.lens.optimise import OPTIMISE_CHOICES

    return choice("lens.optimise", v, OPTIMISE_CHOICES)


def _near_field(t) -> str:
    """The key that places a progressive design's near zone beyond the lens: the diameter
    where it is written, else the corridor."""
    return "lens.diameter_mm" if "diameter_mm" in t else "lens.corridor_mm"


def _check_near_point(t, design, diameter) -> None:
    """The design's near reference point must lie on the lens."""
    x, y = design.near_point
    r = math.hypot(x, y) * 1e3
    if r < diameter / 2 * 1e3:
        return
    raise SpecError(_near_field(t), f"the progressive design's near reference point "
                    f"({-y * 1e3:g} mm down: corridor_mm {design.corridor * 1e3:g} + "
                    f"{(-y - design.corridor) * 1e3:g}; {abs(x) * 1e3:g} mm nasal: inset_mm) "
                    f"is {r:.1f} mm from the lens centre, off a {diameter * 1e3:g} mm lens: "
                    f"diameter_mm must exceed 2 × {r:.1f} = {2 * r:.1f} mm (more for plus "
                    "powers), or corridor_mm be shorter")


def _progressive_misfit(t, rx, material, pose, design, diameter) -> SpecError:
    """Why the progressive front could not be built, naming the key to change: a distance
    front too steep for the square the free-form is sampled over (diameter_mm), or a line
    of sight to the near reference point that leaves the lens (diameter_mm or
    corridor_mm)."""
    base = SpectacleLens.from_rx(rx.distance(), material=material, diameter=diameter,
                                 pose=pose)
    c = abs(base.front.curvature)
    if c * diameter / math.sqrt(2) >= 1.0:
        return SpecError("lens.diameter_mm", f"a progressive front for {rx.format()!r} (its "
                         f"distance front: radius {1e3 / c:.1f} mm) is sampled over the "
                         f"square of the lens's {diameter * 1e3:g} mm diameter, whose corners "
                         "must lie on that sphere: diameter_mm must be under √2 × "
                         f"{1e3 / c:.1f} = {math.sqrt(2) * 1e3 / c:.1f} mm")
    r = math.hypot(*design.near_point) * 1e3
    return SpecError(_near_field(t), f"the line of sight through the progressive design's "
                     f"near reference point ({r:.1f} mm from the lens centre) finds no path "
                     f"through the {diameter * 1e3:g} mm lens of {rx.format()!r} (its prism "
                     "turns it toward the rim): give a larger diameter_mm or a shorter "
                     "corridor_mm")


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
        check_keys(p, POINT_KEYS, where)
        if "position_m" in p:
            if "distance_m" in p or "field_deg" in p or "field_polar_deg" in p:
                raise SpecError(f"{where}.position_m", "give position_m or distance_m + "
                                                       "field_deg, not both")
            pos = p["position_m"]
            if not (isinstance(pos, list) and len(pos) == 3):
                raise SpecError(f"{where}.position_m", f"must be [x, y, z] in m, got {pos!r}")
            pos = np.array([check(f"{where}.position_m[{k}]", v)
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
            dist = check(f"{where}.distance_m", dist)
        if "field_polar_deg" in p:
            if "field_deg" in p:
                raise SpecError(f"{where}.field_polar_deg", "give field_deg or "
                                                            "field_polar_deg, not both")
            f = p["field_polar_deg"]
            if not (isinstance(f, list) and len(f) == 2):
                raise SpecError(f"{where}.field_polar_deg", f"must be [theta, phi] in degrees "
                                                            f"(eccentricity, azimuth), got {f!r}")
            th = math.radians(check(f"{where}.field_polar_deg[0]", f[0]))
            ph = math.radians(check(f"{where}.field_polar_deg[1]", f[1]))
            dirs.append(np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph),
                                  -math.cos(th)]))
            dists.append(dist)
            continue
        f = p.get("field_deg", [0.0, 0.0])
        if not (isinstance(f, list) and len(f) == 2):
            raise SpecError(f"{where}.field_deg", f"must be [x, y] in degrees, got {f!r}")
        fx, fy = (check(f"{where}.field_deg[{k}]", v) for k, v in enumerate(f))
        op = ObjectPoints.from_angles(dist, fx, fy)
        dirs.append(op.direction[0])
        dists.append(dist)
    return ObjectPoints(np.array(dirs), np.array(dists, float))
