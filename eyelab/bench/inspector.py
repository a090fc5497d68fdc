"""``eyelab bench inspect``: how fast the inspector answers a change (offscreen).

The built-in default spec at 800 x 600 (the room, a -3.00 / -1.00 x 180 myope of 45 with
their CR-39 lens), target S = the default quality's (8). For each change — the eye's sphere
with the lens off and through the lens, the pupil, the gaze, S, the colour-vision
deficiency — the time from the change to the first updated frame (a one-pass preview on a
coarse field when the change needs new blur fields) and to the target S, the longest single
tick (how long the window is unresponsive at most), the renderer's stage timings of the
frames that did the set-up, and what ``eyelab.render`` of the changed spec costs in a
session warm from the spec before the change (the same run). The model is ticked as the
window's timer would tick it, without a window (the window adds one texture upload per
frame).
"""

from __future__ import annotations

import time
import tomllib
from pathlib import Path

from eyelab.imaging.options import DEFAULT_SAMPLES


def _measure(model, changes: dict) -> dict:
    t0 = time.perf_counter()
    model.apply(changes)
    first = None
    stages = {}
    longest = 0.0
    while True:
        t = time.perf_counter()
        changed = model.tick()
        longest = max(longest, time.perf_counter() - t)
        if model.result is not None and changed and first is None:
            first = time.perf_counter() - t0
        if model.result is not None:
            for k, v in model.result.report["timings_s"].items():
                if k in ("fields", "refine", "setup_naked", "setup_lens", "lens_composite"):
                    stages[k] = max(stages.get(k, 0.0), v)
        if model.done:
            break
    total = time.perf_counter() - t0
    done = 0 if model.result is None else model.result.report["samples"]["done_passes"]
    return {"change": ", ".join(f"{k}={v}" for k, v in changes.items()),
            "first_frame_s": first if first is not None else total,
            "to_target_s": total, "passes_done": done, "longest_tick_s": longest,
            "recomputed": model.recomputed(), "stages_s": stages}


#: The example specs measured beside the default (a lenslet lens, a schematic eye): the
#: repository's examples/ folder (left out where it is not there: an installed wheel).
EXAMPLES = ("dims.toml", "myope.toml")


def _render_warm(before: str, after: str) -> float:
    """Seconds ``eyelab.render`` of the spec ``after`` (TOML) takes in a session warm from
    rendering ``before``: what the inspector's frames to the target S after that change
    compare with (the same renderer open, the change's own work not done yet)."""
    from eyelab.jobs.session import Session

    with Session() as s:
        s.render(tomllib.loads(before))
        t = time.perf_counter()
        s.render(tomllib.loads(after))
        return time.perf_counter() - t


def _example_rows(width, height, samples) -> list:
    """Per example spec: an Rx change and a gaze change, each beside a warm render."""
    from eyelab.jobs.inspector import InspectorModel

    folder = Path(__file__).resolve().parents[2] / "examples"
    rows = []
    for name in EXAMPLES:
        if not (folder / name).is_file():
            continue
        model = InspectorModel(folder / name, size=(width, height), samples=samples)
        try:
            model.run_to_target()
            for change in ({"sphere": -2.5}, {"gaze": (0.0, -15.0)}):
                before = model.dump()
                row = _measure(model, change)
                row["kind"] = name
                row["render_warm_s"] = _render_warm(before, model.dump())
                rows.append(row)
        finally:
            model.close()
    return rows


def run_inspect_bench(width: int = 800, height: int = 600, samples: int = DEFAULT_SAMPLES,
                      examples: bool = True) -> dict:
    from eyelab.jobs.inspector import InspectorModel

    model = InspectorModel(None, size=(width, height), samples=samples)
    try:
        t = time.perf_counter()
        model.run_to_target()
        cold = time.perf_counter() - t
        rows = []
        plan = [
            ("eye, no lens in view", {"lens": False}),
            ("eye, no lens in view", {"sphere": -3.5}),
            ("eye, no lens in view", {"pupil_mm": 5.0}),
            ("lens on", {"lens": True}),
            ("eye, through the lens", {"sphere": -3.0}),
            ("eye, through the lens", {"pupil_mm": 4.0}),
            ("gaze, through the lens", {"gaze": (0.0, -10.0)}),
            ("samples", {"samples": samples // 2}),
            ("samples", {"samples": samples}),
            ("colour vision", {"cvd": "deutan"}),
        ]
        for label, change in plan:
            before = model.dump()
            row = _measure(model, change)
            row["kind"] = label
            row["render_warm_s"] = _render_warm(before, model.dump())
            rows.append(row)
    finally:
        model.close()
    if examples:
        rows += _example_rows(width, height, samples)
    summary = [f"inspect bench, {width}x{height}, target S = {samples}, default spec "
               f"(cold start to S = {samples}: {cold:.2f} s)"]
    for r in rows:
        summary.append(f"  {r['kind']:<24} {r['change']:<22} first frame "
                       f"{r['first_frame_s']:6.3f} s, to S={r['passes_done']} "
                       f"{r['to_target_s']:6.3f} s, longest tick {r['longest_tick_s']:.3f} s "
                       + (f"(eyelab.render warm {r['render_warm_s']:.3f} s: "
                          f"{r['to_target_s'] / r['render_warm_s']:.2f}x) "
                          if "render_warm_s" in r else "") + f"({r['recomputed']})")
    return {"benchmark": "inspect", "size": [width, height], "samples": samples,
            "cold_start_s": cold, "rows": rows, "summary": summary}
