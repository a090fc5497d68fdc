"""Merging partial runs of the quality benchmark (``eyelab bench quality --merge``): one
run per configuration on small machines, combined into the benchmark's JSON with its
checks, summary and plot recomputed (:func:`eyelab.bench.quality.summarise`)."""

from __future__ import annotations

import json

from eyelab.bench.quality import summarise
from eyelab.core.errors import SpecError


def merge_results(results, plot_path=None, names=None) -> dict:
    """One benchmark from several partial runs of the same preset, size and ladders (e.g.
    one run per configuration); the converged references may differ in spp (each case
    records its own); raises SpecError naming (``--merge``) the file (``names``: one per
    result) that is not a quality benchmark's JSON, or what else differs."""
    if not results:
        raise SpecError("--merge", "needs at least one result")
    names = names or [f"result {i + 1}" for i in range(len(results))]
    for r, name in zip(results, names, strict=True):
        _check_partial(r, name)
    first = results[0]
    for key in ("benchmark", "preset", "size", "reference_spp"):
        vals = {json.dumps(r.get(key)) for r in results}
        if len(vals) > 1:
            raise SpecError("--merge", f"results differ in {key}: {sorted(vals)}")
    try:
        out = summarise([c for r in results for c in r["cases"]], preset=first["preset"],
                        size=first["size"], plot_path=plot_path,
                        camera_cases=[c for r in results for c in r.get("camera_cases", [])])
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as e:
        raise SpecError("--merge", "a case is not a quality benchmark's row (written by "
                        f"eyelab bench quality): {type(e).__name__} {e}") from None
    out["omitted"] = sorted({o for r in results for o in r.get("omitted", [])})
    return out


def _check_partial(r, name) -> None:
    """``r`` has the shape of ``eyelab bench quality``'s JSON, else SpecError naming
    ``name``."""
    def bad(what):
        raise SpecError("--merge", f"{name} is not eyelab bench quality's JSON: {what}")

    if not isinstance(r, dict):
        bad(f"a JSON {type(r).__name__}, not an object")
    if r.get("benchmark") != "quality":
        bad(f"benchmark is {r.get('benchmark')!r}, not 'quality'")
    size = r.get("size")
    if not (isinstance(size, list) and len(size) == 2
            and all(isinstance(v, int) and not isinstance(v, bool) for v in size)):
        bad(f"size must be [width, height], got {size!r}")
    for key in ("cases", "camera_cases", "omitted"):
        v = r.get(key, [])
        if not isinstance(v, list) or (key != "omitted" and not all(
                isinstance(c, dict) for c in v)):
            bad(f"{key} must be a list of {'names' if key == 'omitted' else 'objects'}")
    if not isinstance(r.get("preset"), str) or not isinstance(r.get("reference_spp"), list):
        bad("needs preset (a name) and reference_spp (a list)")
    if not r.get("cases") and not r.get("camera_cases"):
        bad("no cases")
