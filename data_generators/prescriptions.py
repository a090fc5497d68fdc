"""Sample wearers: named eye + lens specs used by examples, tests and benchmarks.

Each entry is a spec dict in the format of :mod:`eyelab.spec` (docs/reference/spec.md), so it can
be written to TOML with :func:`write_specs` or parsed directly with
``eyelab.spec.parse_spec``. Ages and adds follow docs/SCIENCE.md §3 (typical adds by age).
"""

from __future__ import annotations

import argparse
from pathlib import Path

DEFAULT_POINTS = [
    {"distance_m": "inf", "field_deg": [0.0, 0.0]},
    {"distance_m": 6.0, "field_deg": [15.0, 0.0]},
    {"distance_m": 0.4, "field_deg": [0.0, -25.0]},
]

SAMPLES: dict[str, dict] = {
    "emmetrope-25": {"eye": {"age": 25, "pupil_diameter_mm": 4.0}},
    "myope-3-corrected": {
        "eye": {"rx": "-3.00 DS", "age": 30, "pupil_diameter_mm": 4.0},
        "lens": {"rx": "-3.00 DS", "material": "cr39"}},
    "myope-4-polycarbonate": {
        "eye": {"rx": "-4.00 DS", "age": 35, "pupil_diameter_mm": 4.0},
        "lens": {"rx": "-4.00 DS", "material": "polycarbonate"}},
    "hyperope-3": {
        "eye": {"rx": "+3.00 DS", "age": 40, "pupil_diameter_mm": 4.0},
        "lens": {"rx": "+3.00 DS", "material": "cr39"}},
    "presbyope-55": {
        "eye": {"rx": "+0.50 DS", "age": 55, "pupil_diameter_mm": 3.5},
        "lens": {"rx": "+0.50 DS add +2.25", "design": "single-vision",
                 "material": "cr39"}},
    "oblique-astigmat": {
        "eye": {"rx": "-1.00 -2.00 x 45", "age": 28, "pupil_diameter_mm": 5.0},
        "lens": {"rx": "-1.00 -2.00 x 45", "material": "1.60",
                 "pantoscopic_tilt_deg": 8.0}},
    "high-myope-174": {
        "eye": {"rx": "-9.00 -1.50 x 170", "age": 33, "pupil_diameter_mm": 4.0},
        "lens": {"rx": "-9.00 -1.50 x 170", "material": "1.74"}},
}


def sample_spec(name: str) -> dict:
    """A copy of sample ``name`` with the default points added."""
    import copy

    spec = copy.deepcopy(SAMPLES[name])
    spec["points"] = copy.deepcopy(DEFAULT_POINTS)
    return spec


def to_toml(spec: dict) -> str:
    """Minimal TOML writer for spec dicts (tables of scalars/lists, arrays of tables)."""

    def val(v):
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return repr(float(v)) if isinstance(v, float) else str(v)

    out = []
    for key in ("eye", "lens", "analysis"):
        if key in spec:
            out.append(f"[{key}]")
            out += [f"{k} = {val(v)}" for k, v in spec[key].items()]
            out.append("")
    for p in spec.get("points", []):
        out.append("[[points]]")
        out += [f"{k} = {val(v)}" for k, v in p.items()]
        out.append("")
    return "\n".join(out)


def write_specs(folder: str | Path) -> list[Path]:
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in SAMPLES:
        p = folder / f"{name}.toml"
        p.write_text(to_toml(sample_spec(name)))
        paths.append(p)
    return paths


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description="write the sample wearer specs as TOML files")
    ap.add_argument("folder")
    for p in write_specs(ap.parse_args().folder):
        print(p)
