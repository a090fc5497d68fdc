"""The spec reference: every table and key with its type, unit, range, default and meaning,
in one list (:data:`KEYS`) that the README's tables are generated from
(``python -m eyelab.spec.docs`` prints them) and that ``tests/test_specdoc.py`` checks against
the validator itself (the same key sets; every numeric key accepted at both ends of its
range and refused just beyond, naming itself), so the documentation cannot drift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from eyelab.core.color import CVD_KINDS
from eyelab.imaging.options import (
    ACCOMMODATION_RULES,
    COP_FITS,
    FIELD_ROUTES,
    MAX_PASSES,
    MODELS,
    RADIOMETRY,
)
from eyelab.optics.analysis import FIXATIONS, VERTEX_SPHERES
from eyelab.optics.eye import AMPLITUDE_MODELS, EYE_KINDS, MAX_ACCOMMODATION_D
from eyelab.optics.fresnel import COATINGS
from eyelab.optics.materials import ALIASES, CATALOGUE
from eyelab.optics.system import full_f_number, get_system
from eyelab.scene.library import SCENE_NAMES
from eyelab.scene.scene import UNITS

RX_EYE = {"eye": {"rx": "-2.00 DS"}}
IB = {"render": {"renderer": "imagebased"}}
#: The doublet's f-number at full aperture (the lower end of render.camera_f_number).
DOUBLET_FULL_F_NUMBER = float(full_f_number(get_system("doublet")))
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
    edges: bool = True
    renderer: str = "all"
    range_text: str = ""
    integers: bool = False

    def range(self) -> str:
        if self.range_text:
            return self.range_text
        if self.choices:
            return ", ".join(f'`"{c}"`' for c in self.choices)
        if self.lo is None:
            return ""
        lo = "" if self.lo_open else _num(self.lo)
        return f"{'> ' + _num(self.lo) + ', ≤ ' if self.lo_open else lo + '–'}{_num(self.hi)}"


def _num(v) -> str:
    if v == 2**63 - 1:
        return "2⁶³ − 1"
    if abs(v) >= 1e5 and math.log10(abs(v)).is_integer():
        return f"{'−' if v < 0 else ''}1e{int(math.log10(abs(v)))}"
    return f"{v:g}".replace("-", "−")


def _choice(values):
    return tuple(values)


KEYS = [
    # ------------------------------------------------------------------- [eye]
    Key("eye", "rx", "text", "", "none (an emmetrope)",
        "the eye's refraction as a clinician's spectacle Rx, at `vertex_distance_mm`",
        range_text="the Rx grammar below; sphere ±30, cylinder ±12, add 0–4 D"),
    Key("eye", "kind", "choice", "", '`"refractive"`', "with `rx`: which part of the eye "
        "carries the error (axial: the length, for the spherical equivalent)",
        choices=EYE_KINDS, base=RX_EYE),
    Key("eye", "vertex_distance_mm", "number", "mm", "12", "with `rx`: where the Rx is "
        "worn", 5, 30, base=RX_EYE),
    Key("eye", "power_min_d", "number", "D", "58.635", "without `rx`: the weaker "
        "meridian's relaxed power", 40, 80),
    Key("eye", "astigmatism_d", "number", "D", "0", "without `rx`: the stronger meridian's "
        "excess", 0, 10),
    Key("eye", "astigmatism_axis_deg", "number", "deg", "0", "without `rx`: the stronger "
        "meridian's direction, counter-clockwise from the wearer's right seen from behind",
        0, 180),
    Key("eye", "age", "number", "years", "none", "accommodation amplitude by Hofstetter's "
        "formula (instead of `accommodation_max_d`)", 0, 120),
    Key("eye", "amplitude_model", "choice", "", '`"mean"`', "with `age`: Hofstetter's "
        "minimum, mean or maximum", choices=_choice(AMPLITUDE_MODELS), base={"eye": {
            "age": 40}}),
    Key("eye", "accommodation_max_d", "number", "D", "11.93", "amplitude of accommodation",
        0, MAX_ACCOMMODATION_D),
    Key("eye", "pupil_diameter_mm", "number", "mm", "4", "entrance pupil", 0.5, 10),
    Key("eye", "luminance_cd_m2", "number", "cd/m²", "none", "the pupil from the "
        "luminance (Watson & Yellott 2012), instead of `pupil_diameter_mm`", 0, 1e7,
        lo_open=True),
    Key("eye", "retina_distance_mm", "number", "mm", "22.785", "thin eye lens to retina",
        15, 35),
    Key("eye", "n_vitreous", "number", "", "1.336", "refractive index behind the eye lens",
        1.2, 1.6),
    Key("eye", "rotation_centre_mm", "number", "mm", "13.5", "pupil to the centre of "
        "rotation", 5, 20),
    Key("eye", "accommodation_d", "number", "D", '`"auto"`', "the eye's accommodation for "
        'every job (analyze, render, inspect, batch): `"auto"` = best effort per point '
        "(Kakimoto Eq. 13), or a fixed value (the eye gives at most its amplitude); was "
        "`analysis.accommodation_d` and `render.focus_d`", 0, MAX_ACCOMMODATION_D),
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
        "the material's index); limited by the diameter's steepness", -20, 30,
        base=RX_LENS, edges=False),
    Key("lens", "center_thickness_mm", "number", "mm", "material minimum (minus), 1 mm "
        "edge (plus)", "centre thickness; a lens is refused (with the thickness or diameter "
        "that would work) unless its surfaces stay apart inside the diameter with an edge "
        "of at least 1 mm, and a minus lens keeps its material's minimum centre",
        0.2, 30, base=RX_LENS, edges=False),
    Key("lens", "diameter_mm", "number", "mm", "60 (less for strong lenses)", "round "
        "lens diameter", 10, 90, base=RX_LENS),
    Key("lens", "vertex_distance_mm", "number", "mm", "12", "back vertex to the cornea",
        5, 30, base=RX_LENS),
    Key("lens", "pantoscopic_tilt_deg", "number", "deg", "0", "lower rim toward the "
        "cheeks", -30, 30, base=RX_LENS),
    Key("lens", "wrap_deg", "number", "deg", "0", "face-form wrap: the +x rim (a "
        "right lens's temporal rim) toward the face", -30, 30, base=RX_LENS),
    Key("lens", "decentration_mm", "pair", "mm", "[0, 0]", "optical centre offset [x, y]",
        -20, 20, base=RX_LENS),
    Key("lens", "torus", "choice", "", '`"y"`', "with `rx`: which torus the toric back "
        'surface is: `"y"` sweeps the circle of the meridian across the cylinder axis (the '
        "steeper one of a minus-cylinder back: a tyre, the usual form), `\"x\"` that of "
        "the meridian along the axis (a barrel)", choices=("x", "y"), base=RX_LENS),
    Key("lens", "coating", "choice", "", '`"none"`', "Fresnel reflection of bare surfaces, "
        'or `"ar"`: 0.5 % residual reflectance per surface', choices=COATINGS,
        base=RX_LENS),
    Key("lens", "design", "choice", "", "required when the Rx has an add", "what the lens "
        "is when the Rx has an add: a progressive addition lens, a single-vision lens for "
        "its distance part, or one for sphere + add (reading glasses); never chosen "
        "silently", choices=("progressive", "single-vision", "near"),
        base={"lens": {"rx": "+0.50 DS add +2.25"}}),
    Key("lens", "corridor_mm", "number", "mm", "14", "progressive: fitting cross to the "
        "foot of the corridor (near reference point 2 mm below)", 10, 22,
        base={"lens": {"rx": "-2.00 DS add +2.00", "design": "progressive"}}),
    Key("lens", "inset_mm", "number", "mm", "2.5", "progressive: nasal shift of the near "
        "zone (nasal: the eye from the Rx's R/L, right by default)", 0, 5,
        base={"lens": {"rx": "-2.00 DS add +2.00", "design": "progressive"}}),
    Key("lens", "softness_mm", "number", "mm", "8", "progressive: lateral half-width over "
        "which the add fades beside the corridor (small: a hard design)", 3, 30,
        base={"lens": {"rx": "-2.00 DS add +2.00", "design": "progressive"}}),
    Key("lens", "front", "text", "", "none", "explicit surfaces instead of `rx`: tables "
        "[lens.front] and [lens.back] (both, with `center_thickness_mm`); a surface steeper "
        "than a hemisphere inside the diameter is refused naming `diameter_mm`",
        range_text="a surface table"),
    Key("lens", "back", "text", "", "none", "see `front`", range_text="a surface table"),
    # ------------------------------------------------ [lens.front] / [lens.back]
    Key("lens.front", "type", "choice", "", '`"sphere"`', "surface shape",
        choices=("sphere", "plane", "asphere", "conic", "toric"), base=SURFACES),
    Key("lens.front", "curvature", "number", "1/m", "0", "vertex curvature (or "
        "`radius_mm`)", -200, 200, base={"lens": {"front": {"type": "sphere"},
                                                  "back": {"type": "plane"},
                                                  "center_thickness_mm": 2.0}}, edges=False),
    Key("lens.front", "radius_mm", "number", "mm", "none", "vertex radius, not 0 (or "
        "`curvature`)", -1e9, 1e9, base=SURFACES, edges=False),
    Key("lens.front", "conic", "number", "", "0", "conic constant", -100, 100,
        base=SURFACES, edges=False),
    Key("lens.front", "coefficients", "text", "1/m³, 1/m⁵, …", "[]", "aspheric "
        "coefficients [A4, A6, …] of the sag polynomial",
        range_text="numbers within ±1e12", base=SURFACES),
    Key("lens.back", "curvature_x", "number", "1/m", "0", "toric: curvature along x "
        "before rotation (or `radius_x_mm`)", -200, 200, base={"lens": {
            "front": {"type": "sphere"}, "back": {"type": "toric"},
            "center_thickness_mm": 2.0}}, edges=False),
    Key("lens.back", "curvature_y", "number", "1/m", "0", "toric: curvature along y (or "
        "`radius_y_mm`)", -200, 200, base={"lens": {
            "front": {"type": "sphere"}, "back": {"type": "toric"},
            "center_thickness_mm": 2.0}}, edges=False),
    Key("lens.back", "radius_x_mm", "number", "mm", "none", "toric: radius along x",
        -1e9, 1e9, base=TORIC, edges=False),
    Key("lens.back", "radius_y_mm", "number", "mm", "none", "toric: radius along y",
        -1e9, 1e9, base=TORIC, edges=False),
    Key("lens.back", "axis_deg", "number", "deg", "0", "toric: rotation of its x axis",
        -360, 360, base=TORIC),
    Key("lens.back", "revolve", "choice", "", '`"y"`', 'toric: `"y"` sweeps the y′ section '
        "(curvature_y) about an axis parallel to y′ through the x′ centre of curvature — a "
        "tyre when curvature_y is the steeper, a barrel when the flatter; `\"x\"` the same "
        "with x′ and y′ exchanged", choices=("x", "y"), base=TORIC),
    # -------------------------------------------------------------- [analysis]
    Key("analysis", "wavelength_nm", "number", "nm", "587.56", "the wavelength `analyze` "
        "traces (renders trace R, G, B at 656.27, 546.07, 486.13 nm)", 380, 780),
    Key("analysis", "fixation", "choice", "", '`"fixed"`', "for `analyze`: pupil fixed at "
        "the origin (Kakimoto), or the eye rotating about its centre of rotation toward each "
        "point (the as-worn model); a render has one eye pose: `render.gaze_deg`",
        choices=FIXATIONS),
    Key("analysis", "vertex_sphere", "choice", "", '`"rotation_centre"`', "the sphere "
        "through the lens's back vertex that `analyze` reports the wave on: centred on the "
        "eye's centre of rotation (radius vertex distance + 13.5 mm: the designer's) or on "
        "the pupil (radius the vertex distance)", choices=VERTEX_SPHERES),
    # ------------------------------------------------------------- [binocular]
    Key("binocular", "pd_mm", "number", "mm", "64", "interpupillary distance (pupil "
        "centres, primary gaze), split evenly about the midline", 40, 80),
    Key("binocular", "monocular_pd_mm", "pair", "mm", "none", "[right, left] pupil centre "
        "to midline instead of `pd_mm`", 20, 40),
    Key("binocular", "frame_pd_mm", "number", "mm", "none (each lens centred on its pupil)",
        "distance between the lenses' optical centres, centred on the midline: a frame PD "
        "under the PD decentres both lenses nasally (induced prism)", 40, 80,
        base={"lens": {"rx": "-2.00 DS"}}),
    Key("binocular", "fixation_distance_m", "number", "m", '`"inf"`', "the fixated point's "
        "distance from the midpoint of the eyes' centres of rotation, along "
        '`render.gaze_deg` (or `"inf"`: parallel lines of sight); both eyes turn to it',
        0.1, 1e7),
    Key("binocular", "output", "choice", "", '`"side-by-side"`', "what `eyelab render` "
        "writes: left eye's view left (parallel viewing), crossed, Dubois red/cyan anaglyph, "
        "or one eye", choices=("side-by-side", "crossed", "anaglyph", "right", "left")),
    # -------------------------------------------------------------- [[points]]
    Key("points[0]", "distance_m", "number", "m", '`"inf"`', 'object distance from the '
        'pupil, or `"inf"`', 0.01, 1e7, base={"points": [{}]}),
    Key("points[0]", "field_deg", "pair", "deg", "[0, 0]", "field angles [x, y]: x > 0 "
        "to the wearer's right, y > 0 up", -80, 80, base={"points": [{}]}),
    Key("points[0]", "field_polar_deg", "pair", "deg", "none", "the field as [θ, φ] instead: "
        "eccentricity from straight ahead (0–80) and azimuth counter-clockwise from the "
        "wearer's right (±360)", 0, 80, range_text="θ 0–80, φ ±360",
        base={"points": [{}]}),
    Key("points[0]", "position_m", "triple", "m", "none", "the point [x, y, z] instead of "
        "distance and field (not [0, 0, 0])", -1e6, 1e6, base={"points": [{}]},
        edges=False),
    # ---------------------------------------------------------------- [render]
    Key("render", "scene", "text", "", '`"room"`', "what is looked at: a built-in scene, a "
        "mesh file, or a table placing a mesh file (below)",
        range_text=", ".join(f'`"{n}"`' for n in SCENE_NAMES) + ", a path, a table"),
    Key("render", "renderer", "choice", "", '`"raster"`', "Kakimoto's blur-field raster "
        "renderer, the distribution ray tracer, or Heidrich's image-based lens model",
        choices=("raster", "reference", "imagebased")),
    Key("render", "background", "triple", "sRGB 0–255", "the scene's (white for a mesh "
        "file)", "colour where no mesh is", 0, 255, integers=True),
    Key("render", "width", "integer", "px", "640", "image width (width / height in "
        "0.05–20)", 16, 4096, base={"render": {"height": 256}}),
    Key("render", "height", "integer", "px", "480", "image height", 16, 4096,
        base={"render": {"width": 256}}),
    Key("render", "fov_y_deg", "number", "deg", "60", "vertical field of view", 1, 150),
    Key("render", "near_m", "number", "m", "0.05", "near clipping depth from the pupil",
        0.001, 10),
    Key("render", "far_m", "number", "m", "100", "far clipping depth (> near_m)", 0.001,
        1e5, edges=False),

    Key("render", "cvd", "choice", "", "none", "colour-vision deficiency (Machado 2009)",
        choices=CVD_KINDS),
    Key("render", "cvd_severity", "number", "", "1", "its severity", 0, 1),
    Key("render", "gaze_deg", "pair", "deg", "[0, 0]", "the eye turned [right, up] about "
        "its centre of rotation behind the head-fixed lens", -60, 60),
    Key("render", "chromatic", "boolean", "", "true", "each colour channel with its own "
        "light paths and blur (C, e, F lines) where the lens disperses or the eye has its "
        "own chromatic aberration; false: one wavelength"),
    Key("render", "samples", "integer", "", "10", "passes S", 1, MAX_PASSES,
        renderer="raster", base={"render": {"renderer": "raster"}}),
    Key("render", "field_shape", "triple", "voxels", "[128, 32, 32]", "blur-field grid "
        "[nz, ny, nx] (integers)", 1, 512, renderer="raster", integers=True,
        base={"render": {"renderer": "raster", "field_shape": [8, 8, 8]}}),
    Key("render", "depth_mode", "choice", "", '`"ndc"`', "slices uniform in NDC z "
        "(dioptres) or in metres", choices=("ndc", "linear"), renderer="raster"),
    Key("render", "refine", "boolean", "", "true", "adaptive tessellation where the field "
        "is not linear along edges", renderer="raster"),
    Key("render", "reconstruct", "boolean", "", "false", "per-pixel blur-shaped Gaussian "
        "reconstruction against ghosting, variance-compensated (the blur's size kept)",
        renderer="raster"),
    Key("render", "antialias", "boolean", "", "true", "a sub-pixel jitter per pass",
        renderer="raster"),
    Key("render", "skip_unneeded", "boolean", "", "true", "skip passes the frame does not "
        "need", renderer="raster"),
    Key("render", "field_route", "choice", "", '`"texture"`', "field sampled in the "
        "vertex shader or per vertex on the CPU", choices=FIELD_ROUTES, renderer="raster"),
    Key("render", "lens_rings", "integer", "", "24", "lens outline mesh: rings", 2, 256,
        renderer="raster"),
    Key("render", "lens_segments", "integer", "", "96", "lens outline mesh: segments", 8,
        1024, renderer="raster"),
    Key("render", "lens_grid_px", "integer", "px", "8", "spacing of the lens mesh that "
        "carries texture coordinates", 1, 64, renderer="raster"),
    Key("render", "env_oversample", "number", "", "1.5", "environment-image density "
        "relative to the eye view's", 0.5, 4, renderer="raster"),
    Key("render", "rim_color", "triple", "sRGB 0–255", "[30, 30, 30]", "the lens rim",
        0, 255, renderer="raster", integers=True),
    Key("render", "invalid_color", "triple", "sRGB 0–255", "[128, 128, 128]", "pixels "
        "whose rays fail in the lens", 0, 255, renderer="raster", integers=True),
    Key("render", "samples", "integer", "", "64", "rays per pixel and colour channel",
        1, 65536, renderer="reference", base={"render": {"renderer": "reference"}}),
    Key("render", "model", "choice", "", '`"thin"`', "Kakimoto's thin toric eye or Fons "
        "et al.'s reduced-eye sampling", choices=MODELS, renderer="reference",
        base={"render": {"renderer": "reference"}}),
    Key("render", "fons_n", "integer", "", "4", "radii of the Fons pupil pattern", 1, 64,
        renderer="reference", base={"render": {"renderer": "reference"}}),
    Key("render", "fons_m", "integer", "", "8", "diameters of the Fons pupil pattern", 1,
        64, renderer="reference", base={"render": {"renderer": "reference"}}),
    Key("render", "seed", "integer", "", "0", "per-pixel rotations and jitter "
        "(deterministic)", 0, 2**63 - 1, renderer="reference",
        base={"render": {"renderer": "reference"}}),
    Key("render", "workers", "integer", "", "every core", "threads", 1, 256,
        renderer="reference", base={"render": {"renderer": "reference"}}),
    Key("render", "accommodation", "choice", "", '`"eq13"`', "per-pixel accommodation: "
        "Eq. 13 (as the blur field) or the real-ray retinal spot's RMS minimum",
        choices=ACCOMMODATION_RULES, renderer="reference",
        base={"render": {"renderer": "reference"}}),
    Key("render", "samples", "integer", "", "10", "lens (pupil) sample points, each a set "
        "of perspective renders", 1, MAX_PASSES, renderer="imagebased", base=IB),
    Key("render", "grid", "integer", "", "10", "film grid quads per side of each "
        "quad-tree cell", 2, 64, renderer="imagebased", base=IB),
    Key("render", "angle_threshold_deg", "number", "deg", "0.05", "split a cell while a "
        "traced ray and its projection's ray part by more", 0.001, 10,
        renderer="imagebased", base=IB),
    Key("render", "max_depth", "integer", "", "3", "deepest quad-tree level", 0, 8,
        renderer="imagebased", base=IB),
    Key("render", "cop", "choice", "", '`"angle"`', "centre of projection: maximum sum "
        "cos² (Heidrich §3.3) or least-squares distance", choices=COP_FITS,
        renderer="imagebased", base=IB),
    Key("render", "oversample", "number", "", "2", "slice pixels per film pixel", 0.5, 4,
        renderer="imagebased", base=IB),
    Key("render", "max_slice", "integer", "px", "2048", "largest slice side", 64, 4096,
        renderer="imagebased", base=IB),
    Key("render", "radiometry", "choice", "", '`"auto"`', "film irradiance (Eq. 3; a "
        "camera's vignetting shows), radiance (Eq. 3 over sum W: what an eye sees), or "
        "auto (irradiance for a camera, radiance for an eye)", choices=RADIOMETRY,
        renderer="imagebased", base=IB),
    *(k for r in ("reference", "imagebased") for k in (
        Key("render", "camera", "choice", "", "none (the eye)", "a camera lens sees the "
            "scene instead of the eye (no [eye], [lens] or [binocular] with it): Thorlabs "
            "AC254-050-A achromatic doublet or LB1471-A biconvex lens, f 50 mm",
            choices=("biconvex", "doublet"), renderer=r, base={"render": {"renderer": r}}),
        Key("render", "camera_focus_m", "number", "m", '`"inf"`', "object distance in "
            "focus, from the first vertex", 0.2, 1e6, renderer=r,
            base={"render": {"renderer": r, "camera": "doublet"}}),
        Key("render", "camera_f_number", "number", "", "full aperture", "the stop closed "
            "to f / this diameter (full aperture: doublet 2.19, biconvex 2.18)",
            DOUBLET_FULL_F_NUMBER, 64, renderer=r, range_text="full aperture–64",
            base={"render": {"renderer": r, "camera": "doublet"}}))),
    # ---------------------------------------------------------- [render.scene]
    Key("render.scene", "path", "text", "", "required", "a mesh file (any format trimesh "
        "reads; relative to the spec) or a built-in scene's name",
        range_text="an existing file or a built-in name"),
    Key("render.scene", "distance_m", "number", "m", "6", 'the built-in chart\'s distance '
        '(path = `"chart"` only)', 0.1, 100, base={"render": {"scene": {"path": "chart"}}}),
    Key("render.scene", "contrast", "number", "", "1", "the built-in chart's Weber "
        "contrast, in linear light (1: black letters)", 0, 1,
        base={"render": {"scene": {"path": "chart"}}}),
    Key("render.scene", "units", "choice", "", '`"m"`', "the file's length unit",
        choices=tuple(UNITS), base={"render": {"scene": {"path": "room"}}}),
    Key("render.scene", "scale", "number", "", "1", "a further scale factor", 0, 1e9,
        lo_open=True, base={"render": {"scene": {"path": "room"}}}),
    Key("render.scene", "rotation_deg", "triple", "deg", "[0, 0, 0]", "rotations about x, "
        "then y, then z (world axes)", -360, 360,
        base={"render": {"scene": {"path": "room"}}}),
    Key("render.scene", "position_m", "triple", "m", "[0, 0, 0]", "where the file's origin "
        "goes (the pupil is at the origin, looking along −z)", -1e4, 1e4,
        base={"render": {"scene": {"path": "room"}}}),
]

#: Headings of the generated tables, in order.
TABLES = {"eye": "`[eye]`", "lens": "`[lens]` (omit for the naked eye)",
          "lens.front": "`[lens.front]`, `[lens.back]` (surfaces; the toric keys below "
          "apply to either)", "lens.back": None,
          "analysis": "`[analysis]`",
          "binocular": "`[binocular]` (two eyes; with it, or alone, `[eye.right]`, "
          "`[eye.left]`, `[lens.right]` and `[lens.left]` hold any key of their table for "
          "one side over the shared `[eye]` / `[lens]` value — `eye.accommodation_d` only "
          "in `[eye]`: accommodation is consensual)",
          "points[0]": "`[[points]]` (one table per point)",
          "render": "`[render]`", "render.scene": "`[render] scene = {…}` (a mesh file "
          "placed in the world: a vertex v goes to R_z R_y R_x (units × scale × v) + "
          "position_m)"}


def materials_markdown() -> list:
    """The material catalogue as a Markdown table (lines): n_d, V_d, n_e, V_e, source."""
    out = ["Materials (`lens.material`; the data as published are exact, the others follow "
           "from the Cauchy model through them):", "",
           "| name | aliases | n_d | V_d | n_e | V_e | source |", "|---|---|---|---|---|---|---|"]
    for name, m in CATALOGUE.items():
        if name == "air":
            continue
        aliases = ", ".join(f"`{a}`" for a, t in ALIASES.items() if t == name)
        out.append(f"| `{name}` | {aliases} | {m.n_d:.4f} | {m.v_d:.1f} | {m.n_e:.4f} | "
                   f"{m.v_e:.1f} | {m.source} |")
    return out


def markdown() -> str:
    """The README's spec reference: one Markdown table per spec table."""
    out = []
    for table, title in TABLES.items():
        rows = [k for k in KEYS if k.table == table]
        if title is not None:
            if out:
                out.append("")
            out.append(title)
            out.append("")
            if table == "render":
                out.append("| key | renderer | type, unit | range | default | meaning |")
                out.append("|---|---|---|---|---|---|")
            else:
                out.append("| key | type, unit | range | default | meaning |")
                out.append("|---|---|---|---|---|")
        for k in rows:
            kind = k.kind if not k.unit else f"{k.kind}, {k.unit}"
            cells = [f"`{k.key}`", kind, k.range(), k.default, k.meaning]
            if table == "render":
                cells.insert(1, k.renderer)
            out.append("| " + " | ".join(cells) + " |")
        if table == "lens":
            out += [""] + materials_markdown()
    return "\n".join(out)


BEGIN = "<!-- spec-reference: begin (generated by python -m eyelab.spec.docs) -->"
END = "<!-- spec-reference: end -->"


def update_readme(path) -> bool:
    """Replace the generated block of the README at ``path``; True if it changed."""
    from pathlib import Path

    p = Path(path)
    text = p.read_text()
    a = text.index(BEGIN) + len(BEGIN) + 1
    b = text.index("\n" + END)
    new = text[:a] + markdown() + text[b:]
    if new != text:
        p.write_text(new)
    return new != text


if __name__ == "__main__":
    import sys

    if sys.argv[1:2] == ["--readme"]:
        print("updated" if update_readme(sys.argv[2]) else "unchanged")
    else:
        print(markdown())
