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
        [-2.0]],
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
        "banana", "", "air", 1.5, True, ["cr39"], {"n_d": 1.0}, {"n_d": "1.5"},
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
                       ("points = [1]", "points = [1]\n")):
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
    for name, (spec, fld) in only.items():
        cases.append((name, to_toml(spec).encode(), fld))
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
