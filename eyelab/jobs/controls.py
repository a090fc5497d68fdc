"""The inspector's controls: its sliders and toggles, the changes after which a preview
frame comes first, and how a control's value is written into the spec it edits."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from eyelab.core.color import CVD_KINDS
from eyelab.core.errors import SpecError
from eyelab.optics.eye.prescription import Prescription

#: CVD types the inspector cycles through (None: normal colour vision).
CVD_CYCLE = (None, *CVD_KINDS)


#: Eye keys an Rx control replaces (the explicit powers and the Rx exclude each other).
EXPLICIT_EYE = ("power_min_d", "astigmatism_d", "astigmatism_axis_deg")


@dataclass(frozen=True)
class Control:
    """A slider: its label, range, step and default formatting."""

    name: str
    label: str
    lo: float
    hi: float
    step: float
    fmt: str


#: The sliders, in display order. "focus_d" below 0 means best effort per point (Eq. 13).
CONTROLS = (
    Control("sphere", "eye sphere (D)", -10.0, 6.0, 0.25, "%+.2f"),
    Control("cylinder", "eye cylinder (D)", -4.0, 0.0, 0.25, "%+.2f"),
    Control("axis", "eye axis (deg)", 1.0, 180.0, 1.0, "%.0f"),
    Control("pupil_mm", "pupil (mm)", 1.0, 8.0, 0.1, "%.1f"),
    Control("age", "age (years)", 10.0, 70.0, 1.0, "%.0f"),
    Control("focus_d", "focus (D; leftmost: auto)", -0.5, 10.0, 0.25, "%.2f"),
    Control("samples", "samples S", 1.0, 64.0, 1.0, "%.0f"),
    Control("cvd_severity", "CVD severity", 0.0, 1.0, 0.05, "%.2f"),
)


CONTROL_NAMES = tuple(c.name for c in CONTROLS)
#: Each slider by name.
CONTROL = {c.name: c for c in CONTROLS}
#: Each slider's step (the unit its value is snapped to).
STEP = {c.name: c.step for c in CONTROLS}


#: The toggles.
TOGGLES = ("lens", "chromatic", "reconstruct")


#: Changes that need new blur fields or a new reconstruction filter (S sets the filter's
#: compensation): the first frame after one is a preview (one pass on a coarse field, one
#: wavelength, no refinement; its field cached from earlier previews), then the full frames
#: follow.
PREVIEW_AFTER = {"sphere", "cylinder", "axis", "pupil_mm", "age", "focus_d", "gaze", "lens",
                 "lens_rx", "samples", "loaded", "reset"}


#: The preview's blur-field grid (nz, ny, nx).
PREVIEW_FIELD = (32, 16, 16)
#: A schematic eye's preview grid: its columns are fitted to exact rays, four times a thin
#: eye's cost per column (measured, ``examples/myope.toml`` at 800 x 600: the first frame
#: after a sphere change 0.55 s at 16 x 16 columns, 0.37 s at 8 x 8; after a gaze change
#: 0.97 s and 0.58 s).
PREVIEW_FIELD_SCHEMATIC = (32, 8, 8)
#: The preview is drawn this many times coarser on a side than the view (its own renderer,
#: kept warm at that size) and shown enlarged: every per-pixel cost (the passes' fill, the
#: environment image and its blur, the lens grid's rays, the lenslets' moved views) falls
#: to a quarter. Measured on ``examples/dims.toml`` at 800 x 600, workers inline: the
#: first frame after a sphere change 0.92 s at full size, 0.41 s at half; after a gaze
#: change 1.14 s and 0.46 s. The preview's lens grid is also twice as coarse (in the
#: preview's pixels: its rays through the lens and a lenslet lens's offsets a quarter as
#: many; ``dims.toml``'s first frames 0.25-0.37 s -> 0.19-0.26 s with worker threads).
PREVIEW_SCALE = 2
#: The preview's pupil samples through a lenslet lens (at most; equal-area seeds, the
#: disc's moments at any count, each sample's cell spread by its own share of the disc):
#: each is one moved view of the lens (~6 ms at the preview's size). ``dims.toml``, a
#: gaze change's preview with workers inline, median of 11 gazes: 0.263 s at 8, 0.243 s
#: at 4.
PREVIEW_LENSLET_SAMPLES = 4


def snap(value, step):
    """``value`` rounded to a multiple of ``step``."""
    return round(float(value) / step) * step


def _edit_rx(eye: dict, name: str, v) -> None:
    """One part (sphere, cylinder, axis) of an eye table's Rx set to ``v`` (snapped)."""
    rx = Prescription.parse(eye["rx"], field="eye.rx") if "rx" in eye else Prescription()
    rx = dataclasses.replace(rx, **{name: snap(v, STEP[name])})
    for k in EXPLICIT_EYE:
        eye.pop(k, None)
    eye["rx"] = rx.format()


#: Eye controls that write one key: (the key it replaces, the key, its value from the
#: slider's).
EYE_KEY_EDITS = {
    "pupil_mm": ("luminance_cd_m2", "pupil_diameter_mm", lambda v: round(float(v), 2)),
    "age": ("accommodation_max_d", "age", lambda v: int(round(float(v)))),
}


def edit_spec_data(data: dict, name: str, v, sides=None) -> None:
    """Apply one control's value to the spec table ``data`` (in place). ``sides``: the
    eyes a two-eye spec's eye controls edit (their ``[eye.right]`` / ``[eye.left]``
    tables; ``lens_rx`` then a {side: Rx} dict); None for one eye (``[eye]``)."""
    eye = data.setdefault("eye", {})
    render = data.setdefault("render", {})
    tables = [eye] if sides is None else [eye.setdefault(s, {}) for s in sides]
    if name in ("sphere", "cylinder", "axis"):
        for t in tables:
            _edit_rx(t, name, v)
    elif name == "lens_rx":
        lens = data.setdefault("lens", {})
        for side, rx in ({None: v} if sides is None else v).items():
            (lens if side is None else lens.setdefault(side, {}))["rx"] = str(rx)
    elif name in EYE_KEY_EDITS:
        drop, key, value = EYE_KEY_EDITS[name]
        for t in tables:
            t.pop(drop, None)
            t[key] = value(v)
    elif name == "focus_d":           # the eyes' accommodation, one state for both
        if float(v) < 0:
            eye.pop("accommodation_d", None)
        else:
            eye["accommodation_d"] = snap(v, STEP["focus_d"])
    elif name == "samples":
        render["samples"] = int(round(float(v)))
    elif name in ("chromatic", "reconstruct"):
        render[name] = bool(v)
    elif name == "gaze":
        render["gaze_deg"] = [float(v[0]), float(v[1])]
    else:
        raise SpecError("inspector", f"unknown control {name!r}; controls: "
                                     f"{', '.join(CONTROL_NAMES + TOGGLES)}")


def rx_beside_aberrations(t: dict, base, shared: dict | None = None) -> dict:
    """Keys that make an ``[eye]`` table ``t`` whose aberrations carry its refraction (their
    second order) the same eye with that refraction in ``eye.rx`` — what the Rx sliders
    edit — and the higher orders alone, inline ({} when there is nothing to move).
    ``base``: the spec's folder (a coefficient file's path is relative to it);
    ``shared``: a two-eye spec's common ``[eye]`` table (its vertex distance, chromatic)."""
    a = t.get("aberrations") if isinstance(t, dict) else None
    if not isinstance(a, dict) or "rx" in t:
        return {}
    from eyelab.spec.aberrationparse import eye_aberrations
    from eyelab.spec.schema import EYE_VERTEX_MM

    a = dict(a)
    if isinstance(a.get("file"), str) and not Path(a["file"]).is_absolute():
        a["file"] = str(Path(base or ".") / a["file"])
    both = {**(shared or {}), **t}
    made, ab = eye_aberrations({**both, "aberrations": a},
                               float(both.get("vertex_distance_mm", EYE_VERTEX_MM)))
    if "rx" not in made:
        return {}
    rx = made["rx"]
    return {"rx": f"{rx.sphere:+.6f} / {rx.cylinder:+.6f} x {rx.axis:.6f}",
            "aberrations": {"coefficients_um": list(ab.coefficients_um),
                            "pupil_mm": ab.pupil_mm, "wavelength_nm": ab.wavelength_nm,
                            "stiles_crawford": ab.stiles_crawford}}
