"""The spec's schema: every table and key with its type, unit, range, default, choices and
meaning, in one list (:data:`KEYS`). A range is declared once. Where the engine checks a
value itself — the eye, the lens, a progressive design (``LIMITS`` of
:mod:`eyelab.optics.eye.thin`, ``.lens``, ``.progressive``), the view and each renderer's
options (``LIMITS`` of :class:`~eyelab.imaging.contract.View` and of the quality classes,
whose defaults too) — the schema takes the range from there (``eye.rx``'s powers derived
by :mod:`eyelab.spec.eyerx`); the ranges only the spec knows are :data:`SPEC_LIMITS`. The
parsers (:mod:`eyelab.spec.parse`, ...) check against :data:`LIMITS`, the spec reference's
tables are generated from :data:`KEYS` (:mod:`eyelab.spec.docs`), and so is the bad-spec
corpus (``tests/badspecs.py``); ``tests/test_specdoc.py`` checks that every key is
accepted at both ends of its range and refused just beyond, naming itself.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from eyelab.core.checks import RGB_RANGE, check_range
from eyelab.core.color import CVD_KINDS
from eyelab.imaging.contract import View
from eyelab.imaging.options import (
    ACCOMMODATION_RULES,
    COP_FITS,
    DEPTH_MODES,
    FIELD_ROUTES,
    MODELS,
    RADIOMETRY,
)
from eyelab.imaging.registry import QUALITIES, RENDERERS
from eyelab.imaging.stereo import OUTPUTS
from eyelab.optics.cameralens.system import EXAMPLES, full_f_number, get_system
from eyelab.optics.chain.analysis import FIXATIONS, VERTEX_SPHERES
from eyelab.optics.eye.models import EYE_MODELS, MODEL_MEANINGS
from eyelab.optics.eye.schematic import LIMITS as SCHEMATIC_LIMITS
from eyelab.optics.eye.thin import AMPLITUDE_MODELS, EYE_KINDS, EYE_REFERENCE_NM
from eyelab.optics.eye.thin import LIMITS as EYE_LIMITS
from eyelab.optics.lens.optimise import OPTIMISE_CHOICES
from eyelab.optics.lens.progressive import LIMITS as DESIGN_LIMITS
from eyelab.optics.lens.spectacle import LIMITS as LENS_LIMITS
from eyelab.optics.rays.fresnel import COATINGS
from eyelab.optics.rays.materials import ALIASES, CATALOGUE, RGB_WAVELENGTHS_NM
from eyelab.optics.rays.surfaces import REVOLVE_AXES
from eyelab.scene.library import SCENE_NAMES
from eyelab.spec.aberrationkeys import ABERRATION_KEYS, ABERRATION_LIMITS, ABERRATION_TABLE
from eyelab.spec.eyerx import eye_rx_text
from eyelab.spec.framekeys import FIT_LIMITS, FRAME_TABLE, frame_keys
from eyelab.spec.lensletkeys import LENSLET_KEYS, LENSLET_LIMITS, LENSLET_TABLE
from eyelab.spec.scenekeys import SCENE_LIMITS, SCENE_TABLE, scene_keys
from eyelab.spec.surfacefile import POINTS_BASE, POINTS_KEYS, POINTS_LIMITS, TYPE_BASE
from eyelab.spec.valuetext import number_text, option_default

#: The doublet's f-number at full aperture (the lower end of render.camera_f_number).
DOUBLET_FULL_F_NUMBER = float(full_f_number(get_system("doublet")))
#: Lens designs an Rx with an add can be made into: its distance part, its near
#: prescription (sphere + add: reading glasses), or a progressive addition lens.
LENS_DESIGNS = ("single-vision", "near", "progressive")
#: What each ``analysis.fixation`` means (``analyze`` reports it), and the default: the
#: as-worn model optometrists and lens designers use.
FIXATION_MEANINGS = {
    "fixed": "the pupil stays at the origin and the eye turns about it toward each point "
             "(Kakimoto's model, as a render sees each pixel)",
    "rotating": "the eye turns about its centre of rotation to look at each point, its "
                "pupil moving behind the lens (the as-worn model of lens design)"}
DEFAULT_FIXATION = "rotating"
EYE_VERTEX_MM = 12.0       #: where eye.rx is worn unless eye.vertex_distance_mm says
#: Rotationally symmetric surface types (all parsed as an :class:`Asphere`: a plane has
#: curvature 0; a sphere's conic and coefficients default to 0 and none, and are read).
SYMMETRIC_SURFACES = ("sphere", "plane", "asphere", "conic")
SURFACE_TYPES = (*SYMMETRIC_SURFACES, "toric", "points")   # of [lens.front] / [lens.back]
_CONICOID = ("type", "curvature", "radius_mm", "conic", "coefficients")
#: The keys each surface type reads; a surface table with another type's key is refused
#: (a plane's curvature and conic would change nothing: a plane reads its coefficients).
SURFACE_TYPE_KEYS = {**dict.fromkeys(("sphere", "asphere", "conic"), _CONICOID),
                     "plane": ("type", "coefficients"),
                     "toric": ("type", "curvature_x", "curvature_y", "radius_x_mm",
                               "radius_y_mm", "axis_deg", "revolve"),
                     "points": ("type", "file", "spacing_mm", "first_row")}
#: Ranges only the spec knows (what a user may write where the engine takes another form,
#: or checks nothing), by field, in the spec's units.
SPEC_LIMITS = {
    "eye.vertex_distance_mm": (5.0, 30.0), "eye.astigmatism_axis_deg": (0.0, 180.0),
    "lens.front.curvature": (-200.0, 200.0), "lens.front.radius_mm": (-1e9, 1e9),
    "lens.front.conic": (-100.0, 100.0), "lens.back.curvature_x": (-200.0, 200.0),
    "lens.back.curvature_y": (-200.0, 200.0), "lens.back.radius_x_mm": (-1e9, 1e9),
    "lens.back.radius_y_mm": (-1e9, 1e9), "lens.back.axis_deg": (-360.0, 360.0),
    "analysis.wavelength_nm": (380.0, 780.0),
    "binocular.pd_mm": (40.0, 80.0), "binocular.monocular_pd_mm": (20.0, 40.0),
    "binocular.frame_pd_mm": (40.0, 80.0), "binocular.fixation_distance_m": (0.1, 1e7),
    "points[0].distance_m": (0.01, 1e7), "points[0].field_deg": (-80.0, 80.0),
    "points[0].field_polar_deg": (0.0, 80.0),
    "points[0].field_polar_deg[1]": (-360.0, 360.0), "points[0].position_m": (-1e6, 1e6),
    **dict.fromkeys(("render.background", "render.rim_color", "render.invalid_color"), RGB_RANGE),
    "render.camera_focus_m": (0.2, 1e6),
    "render.camera_f_number": (DOUBLET_FULL_F_NUMBER, 64.0),
    "lens.front.coefficients": (-1e12, 1e12),
}
#: Keys that mean something only with another key of their table: (key, needed key, why).
ONLY_WITH = {"eye": (("amplitude_model", "age", "Hofstetter's amplitude for that age"),
                     ("kind", "rx", "the explicit powers define the eye as written"),
                     ("vertex_distance_mm", "rx",
                      "the explicit powers define the eye as written"))}
#: Pairs of keys of a table that exclude each other (and why, where it is not obvious).
NOT_WITH = {"eye": (("age", "accommodation_max_d"), ("pupil_diameter_mm", "luminance_cd_m2")),
            "binocular": (("pd_mm", "monocular_pd_mm"),),
            "render": (("gaze_deg", "camera", "a camera lens has no eye to turn about its "
                        "centre of rotation"),)}
#: A key that excludes a group of others (the Rx or the explicit powers).
EXCLUSIVE_WITH = {"eye": {"key": "rx", "others": ("power_min_d", "astigmatism_d",
                                                  "astigmatism_axis_deg")}}
#: Every field's range but the renderers' own options (:func:`range_of` has those).
LIMITS = {**EYE_LIMITS, **SCHEMATIC_LIMITS, **LENS_LIMITS, **DESIGN_LIMITS, **FIT_LIMITS,
          **LENSLET_LIMITS, **View.LIMITS, **POINTS_LIMITS, **ABERRATION_LIMITS,
          **SCENE_LIMITS, **SPEC_LIMITS}


def declared(field_name: str) -> str:
    """The schema's name of a field as a parser writes it: an element index, a side's
    table and a point's index dropped (``lens.right.decentration_mm[0]`` ->
    ``lens.decentration_mm``, ``points[3].field_deg[1]`` -> ``points[0].field_deg``), a
    surface key under the surface that declares it."""
    name = re.sub(r"^points\[\d+\]", "points[0]", field_name)
    name = re.sub(r"^(eye|lens)\.(right|left)\.", r"\1.", name)
    if name not in LIMITS:                      # an element's own range, else the field's
        name = re.sub(r"\[\d+\]$", "", name)
    if name.startswith(("lens.front.", "lens.back.")) and name not in LIMITS:
        other = name.replace("lens.front.", "lens.back.") if name.startswith("lens.front.") \
            else name.replace("lens.back.", "lens.front.")
        name = other if other in LIMITS else name
    return name


def check(field_name: str, value, **kw) -> float:
    """``value`` checked against the declared range of ``field_name`` (:func:`declared`),
    the error naming ``field_name`` as written."""
    lo, hi = LIMITS[declared(field_name)]
    return check_range(field_name, value, lo, hi, **kw)


def range_of(field_name: str, renderer: str = "all") -> tuple:
    """(lo, hi) of a field (``"eye.pupil_diameter_mm"``; a ``[render]`` option of one
    renderer with ``renderer``)."""
    if field_name in LIMITS:
        return LIMITS[field_name]
    if renderer != "all":
        return QUALITIES[renderer].LIMITS[field_name]
    raise KeyError(field_name)


RX_EYE = {"eye": {"rx": "-2.00 DS"}}
SCHEMATIC_EYE = {"eye": {"model": "navarro"}}
IB = {"render": {"renderer": "imagebased"}}
RX_LENS = {"eye": {"rx": "-2.00 DS"}, "lens": {"rx": "-2.00 DS"}}
SURFACES = {"lens": {"front": {"type": "sphere", "radius_mm": 100.0},
                     "back": {"type": "sphere", "radius_mm": 80.0},
                     "center_thickness_mm": 2.0}}
TORIC = {"lens": {"front": {"type": "sphere", "radius_mm": 100.0},
                  "back": {"type": "toric", "radius_x_mm": 80.0, "radius_y_mm": 70.0},
                  "center_thickness_mm": 2.0}}


@dataclass(frozen=True)
class Key:
    """One spec key. ``kind``: number, integer, boolean, choice, pair, triple, text;
    ``lo``/``hi``: the range of a number or integer (each element of a pair or triple);
    ``choices``: a choice's values; ``base``: the rest of a spec the key needs to be read;
    ``edges``: False where a value at the range's ends is refused for another reason (a
    too-steep lens), so only values beyond the range are tested; ``renderer`` for
    ``[render]`` keys: "all" (every renderer) or one renderer's name."""

    table: str
    key: str
    kind: str
    unit: str
    default: str
    meaning: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    choices: tuple = ()
    base: dict = field(default_factory=dict)
    #: a choice's own base where it needs other keys than ``base`` gives (choice -> spec)
    choice_base: dict = field(default_factory=dict)
    edges: bool = True
    renderer: str = "all"
    range_text: str = ""
    integers: bool = False

    def __post_init__(self):
        if self.lo is None and not self.choices and self.kind not in ("text", "boolean"):
            lo, hi = range_of(f"{self.table}.{self.key}", self.renderer)
            self.__dict__.update(lo=lo, hi=hi)          # frozen: set once, here
        if self.default is None:                     # a renderer option's: its class's
            self.__dict__.update(default=option_default(self.renderer, self.key))

    def range(self) -> str:
        if self.range_text:
            return self.range_text
        if self.choices:
            return ", ".join(f'`"{c}"`' for c in self.choices)
        if self.lo is None:
            return ""
        lo, hi = number_text(self.lo), number_text(self.hi)
        return f"> {lo}, ≤ {hi}" if self.lo_open else f"{lo}–{hi}"


KEYS = [
    # ------------------------------------------------------------------- [eye]
    Key("eye", "model", "choice", "", '`"thin"`', "the eye: "
        + "; ".join(f'`"{k}"` {v}' for k, v in MODEL_MEANINGS.items()), choices=EYE_MODELS),
    Key("eye", "axial_length_mm", "number", "mm", "23.92 (the published eye)",
        "a schematic eye's cornea to retina (its refractive error is axial), instead of "
        "`rx`", base=SCHEMATIC_EYE),
    Key("eye", "rx", "text", "", "none (an emmetrope)",
        "the eye's refraction as a clinician's spectacle Rx, at `vertex_distance_mm`",
        range_text=eye_rx_text(EYE_VERTEX_MM)),
    Key("eye", "kind", "choice", "", '`"refractive"`', "with `rx`: which part of the eye "
        "carries the error (axial: the length, for the spherical equivalent)",
        choices=EYE_KINDS, base=RX_EYE),
    Key("eye", "vertex_distance_mm", "number", "mm", "12", "with `rx`: where the Rx is "
        "worn", base=RX_EYE),
    Key("eye", "power_min_d", "number", "D", "58.635", "without `rx`: the relaxed eye's "
        "mean power (its meridians: this ± `astigmatism_d` / 2)"),
    Key("eye", "astigmatism_d", "number", "D", "0", "without `rx`: the stronger meridian's "
        "excess over the weaker"),
    Key("eye", "astigmatism_axis_deg", "number", "deg", "0", "without `rx`: the stronger "
        "meridian's direction, counter-clockwise from the wearer's right seen from behind"),
    Key("eye", "age", "number", "years", "none", "accommodation amplitude by Hofstetter's "
        "formula (instead of `accommodation_max_d`)"),
    Key("eye", "amplitude_model", "choice", "", '`"mean"`', "with `age`: Hofstetter's "
        "minimum, mean or maximum", choices=tuple(AMPLITUDE_MODELS), base={"eye": {
            "age": 40}}),
    Key("eye", "accommodation_max_d", "number", "D", "11.93", "amplitude of accommodation"),
    Key("eye", "pupil_diameter_mm", "number", "mm", "4", "entrance pupil"),
    Key("eye", "luminance_cd_m2", "number", "cd/m²", "none", "the pupil from the "
        "luminance (Watson & Yellott 2012), instead of `pupil_diameter_mm`",
        lo_open=True),
    Key("eye", "retina_distance_mm", "number", "mm", "22.785", "thin eye lens to retina"),
    Key("eye", "n_vitreous", "number", "", "1.336", "refractive index behind the eye lens"),
    Key("eye", "rotation_centre_mm", "number", "mm", "13.5", "pupil to the centre of "
        "rotation"),
    Key("eye", "accommodation_d", "number", "D", '`"auto"`', "the eye's accommodation for "
        'every job (analyze, render, inspect, batch): `"auto"` = best effort per point '
        "(Kakimoto Eq. 13), or a fixed value (the eye gives at most its amplitude); was "
        "`analysis.accommodation_d` and `render.focus_d`"),
    Key("eye", "chromatic", "boolean", "", "true", "the eye's own chromatic aberration "
        "(Thibos et al. 1992), refraction at the d line"),
    # ------------------------------------------------------------------ [lens]
    Key("lens", "rx", "text", "", "`eye.rx`", "the prescription the lens is made for",
        range_text="the Rx grammar below"),
    Key("lens", "material", "text", "", '`"cr39"`', "a catalogue name or a table "
        "{n_d, v_d} (a lens from an Rx needs n_d ≥ 1.3; v_d ≥ 5 or inf)",
        range_text=", ".join(f'`"{k}"`' for k in CATALOGUE if k != "air") + " (aliases "
        + ", ".join(f'`"{k}"`' for k in ALIASES if "-" not in k) + "), {n_d, v_d}",
        base=RX_LENS),
    Key("lens", "base_curve_d", "number", "D", "Vogel's rule", "front surface power (at "
        "the material's index); limited by the diameter's steepness",
        base=RX_LENS, edges=False),
    Key("lens", "center_thickness_mm", "number", "mm", "material minimum (minus), 1 mm "
        "edge (plus)", "centre thickness; a lens is refused (with the thickness or diameter "
        "that would work) unless its surfaces stay apart inside the diameter with an edge "
        "of at least 1 mm, and a minus lens keeps its material's minimum centre", base=RX_LENS,
        edges=False),
    Key("lens", "diameter_mm", "number", "mm", "60 (less for strong lenses; a [frame]'s "
        "minimum blank size in 5 mm steps where more)", "round lens (blank) diameter; one "
        "below a [frame]'s minimum blank size is refused", base=RX_LENS),
    Key("lens", "vertex_distance_mm", "number", "mm", "12", "back vertex to the cornea",
        base=RX_LENS),
    Key("lens", "pantoscopic_tilt_deg", "number", "deg", "0", "lower rim toward the "
        "cheeks", base=RX_LENS),
    Key("lens", "wrap_deg", "number", "deg", "0", "face-form wrap: the +x rim (a "
        "right lens's temporal rim) toward the face", base=RX_LENS),
    Key("lens", "decentration_mm", "pair", "mm", "[0, 0]", "optical centre offset [x, y]",
        base=RX_LENS),
    Key("lens", "torus", "choice", "", '`"y"`', "with `rx`: which torus the toric back "
        'surface is: `"y"` sweeps the circle of the meridian across the cylinder axis (the '
        "steeper one of a minus-cylinder back: a tyre, the usual form), `\"x\"` that of "
        "the meridian along the axis (a barrel)", choices=REVOLVE_AXES, base=RX_LENS),
    Key("lens", "coating", "choice", "", '`"none"`', "Fresnel reflection of bare surfaces, "
        'or `"ar"`: 0.5 % residual reflectance per surface', choices=COATINGS,
        base=RX_LENS),
    Key("lens", "design", "choice", "", "required when the Rx has an add", "what the lens "
        "is when the Rx has an add: a progressive addition lens, a single-vision lens for "
        "its distance part, or one for sphere + add (reading glasses); never chosen "
        "silently", choices=LENS_DESIGNS,
        base={"lens": {"rx": "+0.50 DS add +2.25"}}),
    Key("lens", "corridor_mm", "number", "mm", "14", "progressive: fitting cross to the "
        "foot of the corridor (near reference point 2 mm below)",
        base={"lens": {"rx": "-2.00 DS add +2.00", "design": "progressive"}}),
    Key("lens", "inset_mm", "number", "mm", "2.5", "progressive: nasal shift of the near "
        "zone (nasal: the eye from the Rx's R/L, right by default)",
        base={"lens": {"rx": "-2.00 DS add +2.00", "design": "progressive"}}),
    Key("lens", "softness_mm", "number", "mm", "8", "progressive: lateral half-width over "
        "which the add fades beside the corridor (small: a hard design)",
        base={"lens": {"rx": "-2.00 DS add +2.00", "design": "progressive"}}),
    Key("lens", "optimise", "choice", "", '`"none"`', "progressive: optimise the front as "
        'worn with a preset (`"soft"`, `"hard"`; `eyelab/optics/lens/optimise.py`) or keep the '
        "analytic design", choices=OPTIMISE_CHOICES,
        base={"lens": {"rx": "-2.00 DS add +2.00", "design": "progressive"}}),
    Key("lens", "front", "text", "", "none", "explicit surfaces instead of a lens made "
        "from `rx`: tables [lens.front] and [lens.back] (both, with `center_thickness_mm`; "
        "with a points surface `rx` may stay, as what power errors compare with); a "
        "surface steeper than a hemisphere inside the diameter is refused naming "
        "`diameter_mm`",
        range_text="a surface table"),
    Key("lens", "back", "text", "", "none", "see `front`", range_text="a surface table"),
    # ------------------------------------------------ [lens.front] / [lens.back]
    Key("lens.front", "type", "choice", "", '`"sphere"` (`"points"` with `file`)',
        "surface shape; each type reads its own keys (below: `toric:`, `points:`; a plane "
        "only `coefficients`) and refuses the others'", choices=SURFACE_TYPES,
        base=TYPE_BASE, choice_base={"points": POINTS_BASE}),
    Key("lens.front", "curvature", "number", "1/m", "0", "vertex curvature (or "
        "`radius_mm`)", base={"lens": {"front": {"type": "sphere"},
                                                  "back": {"type": "plane"},
                                                  "center_thickness_mm": 2.0}}, edges=False),
    Key("lens.front", "radius_mm", "number", "mm", "none", "vertex radius, not 0 (or "
        "`curvature`)", base=SURFACES, edges=False),
    Key("lens.front", "conic", "number", "", "0", "conic constant",
        base=SURFACES, edges=False),
    Key("lens.front", "coefficients", "text", "1/m³, 1/m⁵, …", "[]", "aspheric "
        "coefficients [A4, A6, …] of the sag polynomial",
        range_text="numbers within ±1e12", base=SURFACES),
    Key("lens.back", "curvature_x", "number", "1/m", "0", "toric: curvature along x "
        "before rotation (or `radius_x_mm`)", base={"lens": {
            "front": {"type": "sphere"}, "back": {"type": "toric"},
            "center_thickness_mm": 2.0}}, edges=False),
    Key("lens.back", "curvature_y", "number", "1/m", "0", "toric: curvature along y (or "
        "`radius_y_mm`)", base={"lens": {
            "front": {"type": "sphere"}, "back": {"type": "toric"},
            "center_thickness_mm": 2.0}}, edges=False),
    Key("lens.back", "radius_x_mm", "number", "mm", "none", "toric: radius along x", base=TORIC,
        edges=False),
    Key("lens.back", "radius_y_mm", "number", "mm", "none", "toric: radius along y", base=TORIC,
        edges=False),
    Key("lens.back", "axis_deg", "number", "deg", "0", "toric: rotation of its x axis", base=TORIC),
    Key("lens.back", "revolve", "choice", "", '`"y"`', 'toric: `"y"` sweeps the y′ section '
        "(curvature_y) about an axis parallel to y′ through the x′ centre of curvature — a "
        "tyre when curvature_y is the steeper, a barrel when the flatter; `\"x\"` the same "
        "with x′ and y′ exchanged", choices=REVOLVE_AXES, base=TORIC),
    # -------------------------------------------------------------- [analysis]
    Key("analysis", "wavelength_nm", "number", "nm", f"{EYE_REFERENCE_NM:g}", "the "
        "wavelength `analyze` traces the lens and the eye at (the eye's own chromatic "
        "aberration included; its accommodation is the reference wavelength's); renders "
        "trace R, G, B at " + ", ".join(f"{w:g}" for w in RGB_WAVELENGTHS_NM) + " nm"),
    Key("analysis", "fixation", "choice", "", f'`"{DEFAULT_FIXATION}"`', "for `analyze` "
        "(which reports the one used): " + "; ".join(f'`"{k}"`: {v}' for k, v in
                                                     FIXATION_MEANINGS.items())
        + "; a render has one eye pose: `render.gaze_deg`", choices=FIXATIONS),
    Key("analysis", "vertex_sphere", "choice", "", '`"rotation_centre"`', "the sphere "
        "through the lens's back vertex that `analyze` reports the wave on: centred on the "
        "eye's centre of rotation (radius vertex distance + 13.5 mm: the designer's) or on "
        "the pupil (radius the vertex distance)", choices=VERTEX_SPHERES),
    # ------------------------------------------------------------- [binocular]
    Key("binocular", "pd_mm", "number", "mm", "64", "interpupillary distance (pupil "
        "centres, primary gaze), split evenly about the midline"),
    Key("binocular", "monocular_pd_mm", "pair", "mm", "none", "[right, left] pupil centre "
        "to midline instead of `pd_mm`"),
    Key("binocular", "frame_pd_mm", "number", "mm", "none (each lens centred on its pupil)",
        "distance between the lenses' optical centres, centred on the midline: a frame PD "
        "under the PD decentres both lenses nasally (induced prism)",
        base={"lens": {"rx": "-2.00 DS"}}),
    Key("binocular", "fixation_distance_m", "number", "m", '`"inf"`', "the fixated point's "
        "distance from the midpoint of the eyes' centres of rotation, along "
        '`render.gaze_deg` (or `"inf"`: parallel lines of sight); both eyes turn to it'),
    Key("binocular", "output", "choice", "", '`"side-by-side"`', "what `eyelab render` "
        "writes: left eye's view left (parallel viewing), crossed, Dubois red/cyan anaglyph, "
        "or one eye", choices=OUTPUTS), *frame_keys(Key, LIMITS),
    # -------------------------------------------------------------- [[points]]
    Key("points[0]", "distance_m", "number", "m", '`"inf"`', 'object distance from the '
        'pupil, or `"inf"`', base={"points": [{}]}),
    Key("points[0]", "field_deg", "pair", "deg", "[0, 0]", "field angles [x, y]: x > 0 "
        "to the wearer's right, y > 0 up", base={"points": [{}]}),
    Key("points[0]", "field_polar_deg", "pair", "deg", "none", "the field as [θ, φ] instead: "
        "eccentricity from straight ahead (0–80) and azimuth counter-clockwise from the "
        "wearer's right (±360)", range_text="θ 0–80, φ ±360",
        base={"points": [{}]}),
    Key("points[0]", "position_m", "triple", "m", "none", "the point [x, y, z] instead of "
        "distance and field (not [0, 0, 0])", base={"points": [{}]},
        edges=False),
    # ---------------------------------------------------------------- [render]
    Key("render", "scene", "text", "", '`"room"`', "what is looked at: a built-in scene, a "
        "mesh file, or a table placing a mesh file (below)",
        range_text=", ".join(f'`"{n}"`' for n in SCENE_NAMES) + ", a path, a table"),
    Key("render", "renderer", "choice", "", '`"raster"`', "Kakimoto's blur-field raster "
        "renderer, the distribution ray tracer, or Heidrich's image-based lens model",
        choices=RENDERERS),
    Key("render", "background", "triple", "sRGB 0–255", "the scene's (white for a mesh "
        "file)", "colour where no mesh is", integers=True),
    Key("render", "width", "integer", "px", "640", "image width (width / height in "
        "0.05–20)", base={"render": {"height": 256}}),
    Key("render", "height", "integer", "px", "480", "image height",
        base={"render": {"width": 256}}),
    Key("render", "fov_y_deg", "number", "deg", "60", "vertical field of view"),
    Key("render", "near_m", "number", "m", "0.05", "near clipping depth from the pupil"),
    Key("render", "far_m", "number", "m", "100", "far clipping depth (> near_m)", edges=False),
    Key("render", "cvd", "choice", "", "none", "colour-vision deficiency (Machado 2009)",
        choices=CVD_KINDS),
    Key("render", "cvd_severity", "number", "", "1", "its severity"),
    Key("render", "gaze_deg", "pair", "deg", "[0, 0]", "the eye turned [right, up] about "
        "its centre of rotation behind the head-fixed lens (not with `camera`: no eye)"),
    Key("render", "chromatic", "boolean", "", "true", "each colour channel with its own "
        "light paths and blur (C, e, F lines) where the lens disperses or the eye has its "
        "own chromatic aberration; false: one wavelength"),
    Key("render", "samples", "integer", "", None, "passes S",
        renderer="raster", base={"render": {"renderer": "raster"}}),
    Key("render", "field_shape", "triple", "voxels", None, "blur-field grid "
        "[nz, ny, nx] (integers)", renderer="raster", integers=True,
        base={"render": {"renderer": "raster", "field_shape": [8, 8, 8]}}),
    Key("render", "depth_mode", "choice", "", None, "slices uniform in NDC z "
        "(dioptres) or in metres", choices=DEPTH_MODES, renderer="raster"),
    Key("render", "refine", "boolean", "", None, "adaptive tessellation where the field "
        "is not linear along edges", renderer="raster"),
    Key("render", "reconstruct", "boolean", "", None, "per-pixel blur-shaped Gaussian "
        "reconstruction against ghosting, variance-compensated (the blur's size kept)",
        renderer="raster"),
    Key("render", "antialias", "boolean", "", None, "a sub-pixel jitter per pass",
        renderer="raster"),
    Key("render", "skip_unneeded", "boolean", "", None, "skip passes the frame does not "
        "need", renderer="raster"),
    Key("render", "field_route", "choice", "", None, "field sampled in the "
        "vertex shader or per vertex on the CPU", choices=FIELD_ROUTES, renderer="raster"),
    *(Key("render", f"lens_{k}", "integer", "", None, f"lens outline mesh: {k}",
          renderer="raster") for k in ("rings", "segments")),
    Key("render", "lens_grid_px", "integer", "px", None, "spacing of the lens mesh that "
        "carries texture coordinates", renderer="raster"),
    Key("render", "env_oversample", "number", "", None, "environment-image pixels per "
        "eye pixel where the lens magnifies most", renderer="raster"),
    Key("render", "lenslet_samples", "integer", "", None, "pupil samples of the view "
        "through a lenslet lens (one lens-view draw each)", renderer="raster"),
    Key("render", "rim_color", "triple", "sRGB 0–255", None, "the lens rim",
        renderer="raster", integers=True),
    Key("render", "invalid_color", "triple", "sRGB 0–255", None, "pixels "
        "whose rays fail in the lens", renderer="raster", integers=True),
    Key("render", "samples", "integer", "", None, "rays per pixel and colour channel",
        renderer="reference", base={"render": {"renderer": "reference"}}),
    Key("render", "model", "choice", "", None, "Kakimoto's thin toric eye or Fons "
        "et al.'s reduced-eye sampling", choices=MODELS, renderer="reference",
        base={"render": {"renderer": "reference"}}),
    Key("render", "fons_n", "integer", "", None, "radii of the Fons pupil pattern",
        renderer="reference", base={"render": {"renderer": "reference"}}),
    Key("render", "fons_m", "integer", "", None, "diameters of the Fons pupil pattern",
        renderer="reference", base={"render": {"renderer": "reference"}}),
    Key("render", "seed", "integer", "", None, "per-pixel rotations and jitter "
        "(deterministic)", renderer="reference",
        base={"render": {"renderer": "reference"}}),
    Key("render", "workers", "integer", "", "every core", "threads",
        renderer="reference", base={"render": {"renderer": "reference"}}),
    Key("render", "accommodation", "choice", "", None, "per-pixel accommodation: "
        "Eq. 13 (as the blur field) or the real-ray retinal spot's RMS minimum",
        choices=ACCOMMODATION_RULES, renderer="reference",
        base={"render": {"renderer": "reference"}}),
    Key("render", "samples", "integer", "", None, "lens (pupil) sample points, each a set "
        "of perspective renders", renderer="imagebased", base=IB),
    Key("render", "grid", "integer", "", None, "film grid quads per side of each "
        "quad-tree cell", renderer="imagebased", base=IB),
    Key("render", "angle_threshold_deg", "number", "deg", None, "split a cell while a "
        "traced ray and its projection's ray part by more",
        renderer="imagebased", base=IB),
    Key("render", "max_depth", "integer", "", None, "deepest quad-tree level",
        renderer="imagebased", base=IB),
    Key("render", "cop", "choice", "", None, "centre of projection: maximum sum "
        "cos² (Heidrich §3.3) or least-squares distance", choices=COP_FITS,
        renderer="imagebased", base=IB),
    Key("render", "oversample", "number", "", None, "slice pixels per film pixel",
        renderer="imagebased", base=IB),
    Key("render", "max_slice", "integer", "px", None, "largest slice side",
        renderer="imagebased", base=IB),
    Key("render", "radiometry", "choice", "", None, "film irradiance (Eq. 3; a "
        "camera's vignetting shows), radiance (Eq. 3 over sum W: what an eye sees), or "
        "auto (irradiance for a camera, radiance for an eye)", choices=RADIOMETRY,
        renderer="imagebased", base=IB),
    *(k for r in ("reference", "imagebased") for k in (
        Key("render", "camera", "choice", "", "none (the eye)", "a camera lens sees the "
            "scene instead of the eye (no [eye], [lens] or [binocular] with it): Thorlabs "
            "AC254-050-A achromatic doublet or LB1471-A biconvex lens, f 50 mm",
            choices=tuple(EXAMPLES), renderer=r, base={"render": {"renderer": r}}),
        Key("render", "camera_focus_m", "number", "m", '`"inf"`', "object distance in "
            "focus, from the first vertex", renderer=r,
            base={"render": {"renderer": r, "camera": "doublet"}}),
        Key("render", "camera_f_number", "number", "", "full aperture", "the stop closed "
            "to f / this diameter (full aperture: doublet 2.19, biconvex 2.18)", renderer=r,
            range_text="full aperture–64",
            base={"render": {"renderer": r, "camera": "doublet"}}))),
    # ---------------------------------------------------------- [render.scene]
    *scene_keys(Key),
] + [Key(*a, **kw) for a, kw in POINTS_KEYS + ABERRATION_KEYS + LENSLET_KEYS]

#: Headings of the generated tables, in order.
TABLES = {"eye": "`[eye]`", "eye.aberrations": ABERRATION_TABLE,
          "lens": "`[lens]` (omit for the naked eye)",
          "lens.front": "`[lens.front]`, `[lens.back]` (surfaces; the toric keys below "
          "apply to either)", "lens.back": None, "lens.lenslets": LENSLET_TABLE,
          "analysis": "`[analysis]`",
          "binocular": "`[binocular]` (two eyes; with it, or alone, `[eye.right]`, "
          "`[eye.left]`, `[lens.right]` and `[lens.left]` hold any key of their table for "
          "one side over the shared `[eye]` / `[lens]` value — `eye.accommodation_d` only "
          "in `[eye]`: accommodation is consensual)", "frame": FRAME_TABLE,
          "points[0]": "`[[points]]` (one table per point)",
          "render": "`[render]`", "render.scene": SCENE_TABLE}
