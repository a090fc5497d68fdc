"""A generated corpus of bad specs: every field of every table, given values of the wrong
type, out of range, non-finite, huge, unknown; plus unknown keys and tables, bad encodings,
deep nesting and bad files. Each case is (name, bytes, field) where ``field`` is the dotted
name the one-line error must start its message with.

Used by ``tests/test_bad_specs.py``; ``python tests/badspecs.py DIR`` writes the corpus as
files (``DIR/<n>.toml`` + ``DIR/index.json``) to run it against another build.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from eyelab.spec.schema import KEYS, LIMITS, SURFACES

HUGE = 10**400                       # TOML reads it; no float holds it

#: Values that are not numbers at all (bools, strings, numeric strings, arrays, tables).
NOT_NUMBERS = [True, False, "45", "\uff14\uff15", "abc", "", [1.0], {"v": 1.0}]
#: Numbers that no numeric field accepts.
NON_FINITE = [math.nan, -math.inf, HUGE, -HUGE, 1e300, -1e300]
NOT_BOOLS = [1, 0, "true", "yes", 1.0, [True]]
NOT_STRINGS = [1, 2.5, True, ["a"], {"a": 1}]

# The fields come from the schema (eyelab/spec/schema.py, itself checked against the
# validator): every documented key gets the bad values of its kind.
TEXT_KINDS = {"rx": "rx", "material": "material", "scene": "scene", "path": "scene",
              "coefficients": "list"}


def _kind(k):
    if k.key == "field_polar_deg":
        return "polar"
    if k.kind == "text":
        return TEXT_KINDS.get(k.key)
    if k.kind == "triple" and k.integers:
        return "triple_int"
    return {"number": "num", "integer": "int", "boolean": "bool", "choice": "enum",
            "pair": "pair", "triple": "triple"}[k.kind]


FIELDS = [(k.table, k.key, _kind(k), k.lo, k.hi,
           k.base or ({"render": {"renderer": k.renderer}} if k.renderer != "all" else {}))
          for k in KEYS if _kind(k) is not None]
# the surface keys of the other surface, and a table's own keys under a plain sphere
FIELDS += [("lens.back", "conic", "num", *LIMITS["lens.front.conic"], SURFACES),
           ("lens.back", "radius_mm", "num", *LIMITS["lens.front.radius_mm"], SURFACES),
           ("lens.front", "coefficients", "list", *LIMITS["lens.front.coefficients"],
            SURFACES)]


#: Values a field of each kind must refuse: kind -> f(lo, hi) (a field's bounds) -> list.
BAD_VALUES = {
    "num": lambda lo, hi: NOT_NUMBERS + NON_FINITE + [lo - 1 - abs(lo), hi + 1 + abs(hi)],
    "int": lambda lo, hi: NOT_NUMBERS + NON_FINITE + [lo - 1, hi + 1, lo + 0.5, float(lo)],
    "bool": lambda lo, hi: NOT_BOOLS,
    "enum": lambda lo, hi: ["banana", "", " ", "RASTER!"] + NOT_STRINGS,
    "rx": lambda lo, hi: [
        "-2.00 DS banana", "", "x", "-3" + " " * 400 + "!", "+40.00 DS", "-2 -1 x 400",
        "-2 -1 x", "1e400", "-1.00 DC", "-2.00 -1.00 x 90 add 9", "-2.00 -20.00 x 90", 1, True,
        [-2.0], "-3.00 / / -1.00 x 90", "-3.00 /", "/ -3.00", "-1.00 x 90 / -2.00",
        "-2.00° -1.00 x 90", "-1.00,, -0.50 x 180"],
    "pair": lambda lo, hi: [
        [0.0], [0.0, 0.0, 0.0], "0, 0", 0.0, [True, 0.0], [math.nan, 0.0], [0.0, HUGE],
        [hi + 1, 0.0], [0.0, lo - 1], ["1", 0.0]],
    "polar": lambda lo, hi: [
        [0.0], [0.0, 0.0, 0.0], "0, 0", 0.0, [True, 0.0], [math.nan, 0.0], [0.0, HUGE],
        [81.0, 0.0], [-1.0, 0.0], [0.0, 361.0], ["1", 0.0]],
    "triple": lambda lo, hi: [
        [0.0, 0.0], [0.0, 0.0, 0.0, 0.0], "0 0 1", [True, 0.0, 1.0], [math.nan, 0.0, 1.0],
        [0.0, 0.0, HUGE], [hi * 2, 0.0, 1.0], ["1", 0.0, 1.0]],
    "triple_int": lambda lo, hi: [
        [8, 8], [8, 8, 8, 8], "8", [1.5, 8, 8], [True, 8, 8], [8, "8", 8], [hi + 1, 8, 8],
        [8, 8, lo - 1], [8, HUGE, 8], 8],
    "list": lambda lo, hi: ["1e-6", 1e-6, [True], [math.nan], [HUGE], [1e300], ["a"], [[1.0]]],
    "material": lambda lo, hi: [
        "banana", "", "air", 1.5, 1.67, "1.6", 1.55, True, ["cr39"], {"n_d": 1.0}, {"n_d": "1.5"},
        {"n_d": 1.5, "v_d": "40"}, {"n_d": 1.5, "v_d": -10.0}, {"n_d": math.nan},
        {"v_d": 40.0}, {"n_d": 1.5, "colour": "red"}, {"n_d": HUGE}, {"n_d": 1.0001},
        {"n_d": 5.0}],
    "scene": lambda lo, hi: ["banana", "", 1, True, ["room"], {"path": 1},
                             "/nonexistent/mesh.ply"],
}


def _bad_values(kind, lo, hi):
    """Values a field of this kind must refuse (:data:`BAD_VALUES`)."""
    if kind not in BAD_VALUES:
        raise ValueError(kind)
    return BAD_VALUES[kind](lo, hi)


def _merge(base, table, key, value):
    spec = _deep_copy(base)
    node = spec
    for part in table.split("."):
        if part.endswith("]"):
            name, idx = part[:-1].split("[")
            node = node.setdefault(name, [{}])[int(idx)]
        else:
            node = node.setdefault(part, {})
    node[key] = value
    return spec


def _deep_copy(x):
    if isinstance(x, dict):
        return {k: _deep_copy(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_deep_copy(v) for v in x]
    return x


def to_toml(spec: dict) -> str:
    from eyelab.spec import dump_spec

    return dump_spec(spec)


#: Near misses whose one line must also say what was meant: (name, spec, field, hint).
HINTS = [
    ("material as a number", {"lens": {"rx": "-1.00", "material": 1.67}}, "lens.material",
     "did you mean '1.67'"),
    ("material as a short index", {"lens": {"rx": "-1.00", "material": "1.6"}},
     "lens.material", "did you mean '1.60'"),
    ("material as an index alone", {"lens": {"rx": "-1.00", "material": 1.5}},
     "lens.material", "'cr39'"),
    ("material misspelt", {"lens": {"rx": "-1.00", "material": "polycarbonat"}},
     "lens.material", "did you mean 'polycarbonate'"),
    *((f"design {d!r}", {"lens": {"rx": "-1.00 add +2.00", "design": d}}, "lens.design",
       f"did you mean {want!r}") for d, want in (
        ("PAL", "progressive"), ("varifocal", "progressive"), ("Progressive", "progressive"),
        ("single vision", "single-vision"), ("reading", "near"))),
    ("[lens] add", {"lens": {"rx": "-1.00", "add": 2.0}}, "lens.add", "write it in lens.rx"),
    ("[eye] add", {"eye": {"rx": "-1.00", "add": 2.0}}, "eye.add", "lens.rx"),
    ("[lens] sphere", {"lens": {"sphere": -1.0}}, "lens.sphere", "rx = "),
    ("[lens] side", {"lens": {"rx": "-1.00", "side": "L"}}, "lens.side", "rx = \"R -1.00"),
    ("an add in eye.rx without a lens", {"eye": {"rx": "-1.00 add +2.00"}}, "eye.rx",
     "an add belongs to a lens"),
    ("an add in eye.rx beside lens.rx", {"eye": {"rx": "-1.00 add +2.00"},
                                          "lens": {"rx": "-1.00"}}, "eye.rx",
     "write the add there"),
    ("an add in eye.rx with explicit surfaces", {"eye": {"rx": "-1.00 add +2.00"},
                                                  **SURFACES}, "eye.rx", "surface by surface"),
    ("an eye.rx too myopic", {"eye": {"rx": "-29.00"}}, "eye.rx", "−28.73…+15.23 D"),
    ("an eye.rx too much cylinder", {"eye": {"rx": "pl -11.50 x 90"}}, "eye.rx",
     "−11.36…+8.93 D"),
    ("an L progressive on an R eye", {"eye": {"rx": "R -1.00"}, "lens": {
        "rx": "L -1.00 add +2.00", "design": "progressive"}}, "lens.rx", "for the left eye"),
    ("a progressive lens too small for its corridor", {"lens": {
        "rx": "-1.00 add +2.00", "design": "progressive", "diameter_mm": 30}},
     "lens.diameter_mm", "must exceed 2 × 16.2 = 32.4 mm"),
    ("a progressive front too steep for its diameter", {"lens": {
        "rx": "+6.00 add +3.00", "design": "progressive"}}, "lens.diameter_mm",
     "must be under √2 × 41.5 = 58.7 mm"),
    ("a camera with a gaze", {"render": {"renderer": "reference", "camera": "doublet",
                                         "gaze_deg": [10, 0]}}, "render.gaze_deg",
     "no eye to turn"),
    ("a malformed Rx separator", {"eye": {"rx": "-3.00 / / -1.00 x 90"}}, "eye.rx",
     "a misplaced '/'"),
]


def _side_cases() -> list:
    """Every [eye] and [lens] key refused in a side's table ([eye.right], [lens.left], ...)
    naming that table: one wrong type and one value out of range (or the first bad value)
    per key, the sides taken in turn."""
    cases = []
    for n, (table, key, kind, lo, hi, base) in enumerate(
            f for f in FIELDS if f[0] in ("eye", "lens")):
        # the right side is read first: a design is refused there (the shared Rx has an
        # add, so the left lens would be refused first for having no design)
        side = "right" if key == "design" else ("right", "left")[n % 2]
        values = _bad_values(kind, lo, hi)
        for i in (2, len(values) - 1) if kind in ("num", "int") else (0,):
            spec = _deep_copy(base)
            spec.setdefault(table, {}).setdefault(side, {})[key] = values[i]
            cases.append((f"{table}.{side}.{key}#{i}", to_toml(spec).encode(),
                          f"{table}.{side}.{key}"))
    return cases


PAL = {"rx": "-1.00 DS add +2.00", "design": "progressive"}
CAMERA = {"renderer": "reference", "camera": "doublet"}
#: A DIMS-like honeycomb (eyelab.spec.lenslets); a case's None drops a key.
LENSLETS = {"layout": "honeycomb", "add_d": 3.5, "diameter_mm": 1.03, "pitch_mm": 1.43,
            "clear_zone_mm": 9.4, "zone_mm": 33.0}
#: Two eyes, progressive lenses and cameras: the rules between keys and tables.
STRUCTURE = {
    # two eyes
    "an add in a side's eye.rx beside lens.rx": (
        {"eye": {"left": {"rx": "L -1.00 add +2.00"}}, "lens": {"rx": "-1.00"}},
        "eye.left.rx"),
    "an add in eye.rx for two naked eyes": ({"eye": {"rx": "-1.00 add +2.00"},
                                             "binocular": {}}, "eye.rx"),
    "a left lens Rx in [lens.right]": ({"lens": {"rx": "-1.00", "right": {
        "rx": "L -1.00"}}}, "lens.right.rx"),
    "a side's design misspelt": ({"lens": {"rx": "-1.00 add 2", "right": {
        "design": "PAL"}, "left": {"design": "progressive"}}}, "lens.right.design"),
    "a side's corridor without the design": ({"lens": {"rx": "-1.00", "right": {
        "corridor_mm": 14}}}, "lens.right.corridor_mm"),
    "a side's lens too small for its corridor": ({"lens": {**PAL, "left": {
        "diameter_mm": 30}}}, "lens.left.diameter_mm"),
    "[binocular] unknown key": ({"binocular": {"ipd_mm": 64}}, "binocular.ipd_mm"),
    "a side table of [binocular]": ({"binocular": {"right": {"pd_mm": 32}}},
                                    "binocular.right"),
    "monocular pds and pd": ({"binocular": {"monocular_pd_mm": [32, 32], "pd_mm": 64}},
                             "binocular.pd_mm"),
    "a frame pd decentring the left lens too far": (
        {"lens": {"rx": "-1", "left": {"decentration_mm": [15, 0]}},
         "binocular": {"frame_pd_mm": 50}}, "binocular.frame_pd_mm"),
    "a right Rx for the left eye, shared": ({"eye": {"rx": "OD -1.00"},
                                             "binocular": {}}, "eye.rx"),
    # progressive lenses: every design key, and what the design excludes
    **{f"{k} without the design": ({"lens": {"rx": "-1.00 add 2", k: v}}, f"lens.{k}")
       for k, v in (("corridor_mm", 14), ("inset_mm", 2.5), ("softness_mm", 8))},
    **{f"a progressive lens with {k}": ({"lens": {**PAL, k: v}}, f"lens.{k}")
       for k, v in (("base_curve_d", 4.0), ("center_thickness_mm", 3.0), ("torus", "x"))},
    "a progressive lens without an add": ({"lens": {"rx": "-1.00", "design": "progressive"}},
                                          "lens.design"),
    "a progressive add below the design's": ({"lens": {**PAL, "rx": "-1.00 add +0.10"}},
                                             "lens.rx"),
    "a progressive add from eye.rx below the design's": (
        {"eye": {"rx": "-1.00 add +0.10"}, "lens": {"design": "progressive"}}, "eye.rx"),
    "a progressive design on explicit surfaces": (_merge(SURFACES, "lens", "design",
                                                         "progressive"), "lens.design"),
    "a near design without an add": ({"lens": {"rx": "-1.00", "design": "near"}},
                                      "lens.design"),
    "an add with no design": ({"lens": {"rx": "-1.00 add 2"}}, "lens.design"),
    "an R progressive on an L eye": ({"eye": {"rx": "OS -1.00"}, "lens": {
        **PAL, "rx": "OD -1.00 add 2"}}, "lens.rx"),
    "a corridor too long for the lens": ({"lens": {**PAL, "corridor_mm": 22,
                                                   "diameter_mm": 45}}, "lens.diameter_mm"),
    "an inset taking the near point off the lens": (
        {"lens": {**PAL, "corridor_mm": 10, "inset_mm": 5, "diameter_mm": 25}},
        "lens.diameter_mm"),
    # cameras: what a camera excludes, and its keys without it
    **{f"a camera with [{t}]": ({"render": CAMERA, t: v}, "render.camera") for t, v in (
        ("eye", {"age": 40}), ("lens", {"rx": "-1.00"}), ("binocular", {}),
        ("eye", {"right": {"age": 40}}))},
    "a camera with a gaze": ({"render": {**CAMERA, "gaze_deg": [0, 0]}}, "render.gaze_deg"),
    "a camera for the raster renderer": ({"render": {"camera": "doublet"}}, "render.camera"),
    **{f"a camera for {r}, misspelt": ({"render": {"renderer": r, "camera": "Doublet"}},
                                       "render.camera") for r in ("reference", "imagebased")},
    **{f"{k} without a camera ({r})": ({"render": {"renderer": r, k: v}}, f"render.{k}")
       for r in ("reference", "imagebased")
       for k, v in (("camera_focus_m", 2.0), ("camera_f_number", 4.0))},
    "a biconvex stop wider than its full aperture": (
        {"render": {"renderer": "imagebased", "camera": "biconvex", "camera_f_number": 2.0}},
        "render.camera_f_number"),
    "a camera focused inside its first vertex": (
        {"render": {**CAMERA, "camera_focus_m": 0.05}}, "render.camera_focus_m"),
    # lenslet arrays: layouts that overlap, leave the lens, hold nothing, or mix keys
    **{f"lenslets: {name}": ({"lens": {"rx": "-3.00", "lenslets": {
        key: v for key, v in {**LENSLETS, **t}.items() if v is not None}}},
        f"lens.lenslets.{k}")
       for name, t, k in (
           ("a pitch below the diameter", {"pitch_mm": 1.0}, "pitch_mm"),
           ("a zero pitch", {"pitch_mm": 0}, "pitch_mm"),
           ("a zone beyond the lens", {"zone_mm": 70}, "zone_mm"),
           ("a clear zone wider than the zone", {"clear_zone_mm": 34}, "clear_zone_mm"),
           ("an annulus too narrow for a lenslet", {"clear_zone_mm": 32.5}, "zone_mm"),
           ("no add", {"add_d": 0}, "add_d"),
           ("rings keys in a honeycomb", {"per_ring": [3]}, "per_ring"),
           ("rings overlapping", {"layout": "rings", "pitch_mm": None, "clear_zone_mm": None,
                                  "zone_mm": None, "ring_diameters_mm": [10.0, 11.0]},
            "ring_diameters_mm"),
           ("too many on a ring", {"layout": "rings", "pitch_mm": None, "clear_zone_mm": None,
                                   "zone_mm": None, "ring_diameters_mm": [10.0],
                                   "per_ring": [40]}, "per_ring"),
           ("counts for other rings", {"layout": "rings", "pitch_mm": None,
                                       "clear_zone_mm": None, "zone_mm": None,
                                       "ring_diameters_mm": [10.0], "per_ring": [3, 4]},
            "per_ring"),
           ("a ring off the lens", {"layout": "rings", "pitch_mm": None, "clear_zone_mm": None,
                                    "zone_mm": None, "ring_diameters_mm": [60.0]},
            "ring_diameters_mm"),
           ("centres overlapping", {"layout": "list", "pitch_mm": None, "clear_zone_mm": None,
                                    "zone_mm": None, "centres_mm": [[5, 0], [5.5, 0]]},
            "centres_mm"),
           ("a centre off the lens", {"layout": "list", "pitch_mm": None,
                                      "clear_zone_mm": None, "zone_mm": None,
                                      "centres_mm": [[29.8, 0]]}, "centres_mm"),
           ("a centre that is not a pair", {"layout": "list", "pitch_mm": None,
                                            "clear_zone_mm": None, "zone_mm": None,
                                            "centres_mm": [[5, 0, 1]]}, "centres_mm"),
           ("no centres", {"layout": "list", "pitch_mm": None, "clear_zone_mm": None,
                           "zone_mm": None, "centres_mm": []}, "centres_mm"),
           ("no layout", {"layout": None}, "layout"),
           ("a layout misspelt", {"layout": "hexagonal"}, "layout"))},
}


def _maps_argv(spec, out, *flags):
    return ["maps", spec, "-o", out, *flags]


#: ``eyelab maps`` (and render flags) given bad values: (name, spec, argv tail, field the
#: engine names, the flag or field the command's line names).
COMMAND_LINES = [
    *((f"maps --half-angle {v}", {"lens": {"rx": "-1.00"}}, ["maps", "--half-angle", v],
       "maps.half_angle_deg", "--half-angle") for v in ("0", "61", "-5", "nan", "inf")),
    *((f"maps --points {v}", {"lens": {"rx": "-1.00"}}, ["maps", "--points", v], "maps.n",
       "--points") for v in ("2", "202", "0", "-1")),
    *((f"maps {flag} {v}", {"lens": {"rx": "-1.00"}}, ["maps", flag, v], flag, flag)
      for flag, v in (("--points", "3.5"), ("--points", "abc"), ("--half-angle", "abc"))),
    ("maps without a lens", {"eye": {"age": 40}}, ["maps"], "lens", "lens"),
    ("maps of two eyes", {"lens": {"rx": "-1.00"}, "binocular": {}}, ["maps"], "binocular",
     "binocular"),
    ("maps of a camera", {"render": CAMERA, "lens": {"rx": "-1.00"}}, ["maps"],
     "render.camera", "render.camera"),
    ("analyze a camera", {"render": CAMERA}, ["analyze"], "render.camera", "render.camera"),
    ("render -o ''", {}, ["render", "-o", ""], "--output", "--output"),
    ("render --no-lens with a camera", {"render": CAMERA}, ["render", "--no-lens"],
     "--no-lens", "--no-lens"),
    ("maps of a bad spec", {"lens": {"rx": "-3.00 / / -1.00 x 90"}}, ["maps"], "lens.rx",
     "lens.rx"),
    ("maps to a jpeg", {"lens": {"rx": "-1.00"}}, ["maps", "-o", "m.jpg"], "--output",
     "--output"),
    ("render --gaze with a camera", {"render": {**CAMERA, "width": 16, "height": 16}},
     ["render", "--gaze", "10", "0"], "--gaze (render.gaze_deg)", "--gaze (render.gaze_deg)"),
    ("render --binocular with a camera", {"render": CAMERA}, ["render", "--binocular"],
     "render.camera", "render.camera"),
    ("render --renderer raster with a camera", {"render": CAMERA},
     ["render", "--renderer", "raster"], "--renderer (render.renderer)",
     "--renderer (render.renderer)"),
]


def corpus() -> list:
    """[(name, bytes, field)]: the whole corpus."""
    cases = []
    for table, key, kind, lo, hi, base in FIELDS:
        for i, v in enumerate(_bad_values(kind, lo, hi)):
            spec = _merge(base, table, key, v)
            cases.append((f"{table}.{key}#{i}", to_toml(spec).encode(), f"{table}.{key}"))
    # unknown keys (a typo of each key) and unknown tables
    for table, key, _, _, _, base in FIELDS:
        if "renderer" in base.get("render", {}) and key in ("samples",):
            continue
        spec = _merge(base, table, key + "s" if not key.endswith("s") else key[:-1], 1.0)
        typo = key + "s" if not key.endswith("s") else key[:-1]
        cases.append((f"{table}.{typo}(unknown)", to_toml(spec).encode(), f"{table}.{typo}"))
    for name in ("camera", "eyes", "Lens", "render2"):
        cases.append((f"[{name}]", f"[{name}]\nx = 1\n".encode(), f"spec.{name}"))
    for name, text in (("eye = 5", "eye = 5\n"), ("lens = []", "lens = []\n"),
                       ("render = 'x'", "render = 'x'\n"), ("points = {}", "[points]\n"),
                       ("points = []", "points = []\n"), ("analysis = 1", "analysis = 1\n"),
                       ("points = [1]", "points = [1]\n"), ("binocular = 3", "binocular = 3\n"),
                       ("eye.right = 3", "[eye]\nright = 3\n")):
        cases.append((name, text.encode(), name.split(" ")[0]))
    # keys that only take effect with another key, and keys another choice excludes
    only = {
        "amplitude_model without age": ({"eye": {"amplitude_model": "max"}},
                                         "eye.amplitude_model"),
        "kind without rx": ({"eye": {"kind": "axial", "power_min_d": 60}}, "eye.kind"),
        "eye vertex distance without rx": ({"eye": {"vertex_distance_mm": 12}},
                                           "eye.vertex_distance_mm"),
        "torus with explicit surfaces": (_merge(SURFACES, "lens", "torus", "x"),
                                         "lens.torus"),
        "base curve with explicit surfaces": (_merge(SURFACES, "lens", "base_curve_d", 4.0),
                                              "lens.base_curve_d"),
        "rx with explicit surfaces": (_merge(SURFACES, "lens", "rx", "-2.00"), "lens.rx"),
        "front without back": ({"lens": {"front": {"type": "plane"},
                                         "center_thickness_mm": 2.0}}, "lens.back"),
        "age and amplitude": ({"eye": {"age": 40, "accommodation_max_d": 2}}, "eye.age"),
        "pupil and luminance": ({"eye": {"pupil_diameter_mm": 3, "luminance_cd_m2": 100}},
                                "eye.pupil_diameter_mm"),
        "rx and powers": ({"eye": {"rx": "-1.00", "power_min_d": 60}}, "eye.power_min_d"),
        "radius and curvature": (_merge(SURFACES, "lens.front", "curvature", 10.0),
                                 "lens.front.curvature"),
        "zero radius": (_merge(SURFACES, "lens.front", "radius_mm", 0), "lens.front.radius_mm"),
        "far before near": ({"render": {"near_m": 2.0, "far_m": 1.0}}, "render.far_m"),
        "aspect": ({"render": {"width": 16, "height": 4096}}, "render.width"),
        "point at the pupil": ({"points": [{"position_m": [0, 0, 0]}]}, "points[0].position_m"),
        "point twice": ({"points": [{"position_m": [0, 0, -1], "distance_m": 1}]},
                        "points[0].position_m"),
        "rx eye too strong": ({"eye": {"rx": "+25.00 DS"}}, "eye.rx"),
        "rx eye with retina": ({"eye": {"rx": "-2.00", "retina_distance_mm": 15}},
                               "eye.retina_distance_mm"),
        "low-index material for the eye's rx": ({"eye": {"rx": "-12.00"}, "lens": {
            "material": {"n_d": 1.2}}}, "lens.material"),
        "pd and monocular pds": ({"binocular": {"pd_mm": 64, "monocular_pd_mm": [32, 32]}},
                                 "binocular.pd_mm"),
        "a side's accommodation": ({"eye": {"left": {"accommodation_d": 1.0}}},
                                   "eye.left.accommodation_d"),
        "a side that is not a table": ({"eye": {"right": 3}}, "eye.right"),
        "a side's bad key": ({"eye": {"right": {"age": 200}}}, "eye.right.age"),
        "a side's unknown key": ({"lens": {"rx": "-1", "left": {"rxx": "-1"}}},
                                  "lens.left.rxx"),
        "a right Rx for the left eye": ({"eye": {"left": {"rx": "R -1.00"}}}, "eye.left.rx"),
        "a left Rx in the right lens": ({"lens": {"right": {"rx": "OS -1.00"}}},
                                        "lens.right.rx"),
        "frame pd decentres too far": ({"lens": {"rx": "-1", "decentration_mm": [-15, 0]},
                                        "binocular": {"frame_pd_mm": 50}},
                                       "binocular.frame_pd_mm"),
        "steep base curve": ({"lens": {"rx": "-2.00", "base_curve_d": 29, "diameter_mm": 60}},
                             "lens.base_curve_d"),
    }
    for name, (spec, fld) in {**only, **STRUCTURE}.items():
        cases.append((name, to_toml(spec).encode(), fld))
    cases += [(name, to_toml(spec).encode(), fld) for name, spec, fld, _ in HINTS]
    cases += _side_cases()
    # a renderer's key under the other renderer
    cases.append(("reference key on raster", b'[render]\nmodel = "fons"\n', "render.model"))
    cases.append(("raster key on reference",
                  b'[render]\nrenderer = "reference"\nfield_shape = [8, 8, 8]\n',
                  "render.field_shape"))
    # encodings, syntax and nesting
    raw = {
        "latin-1 comment": "# caf\xe9\n[eye]\nage = 40\n".encode("latin-1"),
        "utf-16": "[eye]\nage = 40\n".encode("utf-16"),
        "random bytes": bytes(range(256)) * 4,
        "nul bytes": b"[eye]\x00\nage = 40\n",
        "deep arrays": b"x = " + b"[" * 3000 + b"]" * 3000 + b"\n",
        "deep tables": b"[" + b".".join(b"a" for _ in range(3000)) + b"]\n",
        "deep inline": b"x = " + b"{a = " * 2000 + b"1" + b"}" * 2000 + b"\n",
        "truncated": b'[eye]\nrx = "-2.00',
        "duplicate key": b"[eye]\nage = 40\nage = 41\n",
        "duplicate table": b"[eye]\nage = 40\n[eye]\nage = 41\n",
        "no value": b"[eye]\nage =\n",
        "bare word": b"[eye]\nage = forty\n",
        "binary mesh": b"solid x\n" + bytes([0x80, 0xff]) * 40,
        "ply": b"ply\nformat ascii 1.0\nelement vertex 0\nend_header\n",
    }
    for name, data in raw.items():
        cases.append((name, data, "spec"))
    return cases


def main(out: str) -> None:
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    index = []
    for i, (name, data, fld) in enumerate(corpus()):
        (d / f"{i:04d}.toml").write_bytes(data)
        index.append({"file": f"{i:04d}.toml", "name": name, "field": fld})
    (d / "index.json").write_text(json.dumps(index, indent=1))
    print(f"{len(index)} cases in {d}")


if __name__ == "__main__":
    main(sys.argv[1])
