"""The inspector's two eyes: a two-eye spec (``[binocular]``, or per-eye tables) inspected
as ``eyelab render`` renders it — each eye posed for the cyclopean gaze with one
accommodative response (:func:`eyelab.imaging.stereo.pose_binocular`), both eyes' frames
run in step and composed in linear light as the spec's ``binocular.output`` (or a red/cyan
anaglyph, toggled). The eye controls edit one eye or both (linked); the state is kept as
a spec whose ``[eye.right]`` and ``[eye.left]`` tables hold each eye's keys in full, so
what one eye's slider writes never moves the other."""

from __future__ import annotations

import copy

from eyelab.imaging.stereo import SIDES, BinocularResult, binocular_report, compose

#: The eyes the controls edit, cycled by the window's ``e`` key.
EDIT_CYCLE = ("both", "right", "left")
#: Keys a two-eye spec's ``[eye]`` keeps for both eyes (one value only).
SHARED_EYE_KEYS = ("accommodation_d",)


def sided_data(data: dict) -> dict:
    """A copy of the two-eye spec table ``data`` whose ``[eye.right]`` / ``[eye.left]``
    hold every eye key of their side (the shared ``[eye]`` keys folded in, only the keys
    both eyes must share left in ``[eye]``), and whose lens on each side keeps that eye's
    Rx as its prescription when the spec designs it from the eye's (as the one-eye
    inspector does), so that moving an eye's sliders leaves the lenses as they are."""
    data = copy.deepcopy(data)
    eye = data.get("eye", {})
    shared = {k: v for k, v in eye.items() if k not in SIDES}
    out = {k: v for k, v in shared.items() if k in SHARED_EYE_KEYS}
    for side in SIDES:
        out[side] = {**{k: v for k, v in shared.items() if k not in SHARED_EYE_KEYS},
                     **eye.get(side, {})}
    data["eye"] = out
    lens = data.get("lens")
    if isinstance(lens, dict):
        for side in SIDES:
            own = lens.get(side, {})
            if not any(k in t for t in (lens, own) for k in ("rx", "front")) \
                    and "rx" in out[side]:
                lens.setdefault(side, {})["rx"] = out[side]["rx"]
    return data


def edited_sides(edit: str) -> tuple:
    """The sides the controls edit for the ``edit`` mode (:data:`EDIT_CYCLE`)."""
    return SIDES if edit == "both" else (edit,)


def binocular_frame(pose, right, left) -> BinocularResult:
    """Both eyes' RenderResults of one step as a BinocularResult with the two-eye report."""
    return BinocularResult(right, left, {"binocular": binocular_report(pose),
                                         "right": right.report, "left": left.report})


def display_linear(result, output: str):
    """(h, w', 3) linear image of a BinocularResult as ``output`` shows it."""
    return compose(result.right.linear, result.left.linear, output)


def readout(result) -> str:
    """The two-eye readout: pupillary and frame PDs, the accommodation and the prism at
    the fixated point (the report's ``binocular`` part)."""
    b = result.report["binocular"]
    r, l_ = b["monocular_pd_mm"]
    fpd = "" if b["frame_pd_mm"] is None else f", frame PD {b['frame_pd_mm']:.1f} mm"
    fix = b["fixation_distance_m"]
    fix_s = "infinity" if fix == "inf" else f"{fix:g} m"
    blur = "  ".join(f"{s[0].upper()} {b['eyes'][s]['blur_at_fixation_arcmin'][0]:.2f}'"
                     for s in SIDES)
    prism = b["prism_at_fixation"]
    prism_s = ("no prism (no lenses, or a line of sight misses one)" if prism is None else
               f"prism {prism['binocular']['horizontal']}, {prism['binocular']['vertical']}")
    return (f"PD {r:.1f} + {l_:.1f} mm{fpd}; fixation {fix_s}: accommodation "
            f"{b['accommodation_d']:.2f} D, blur {blur}; {prism_s}")


def fixation_distance(result) -> float | None:
    """Distance (m) from the eyes' midpoint to the fixated point (None at infinity)."""
    import math

    p = result.report["binocular"]["fixation_point_m"]
    return None if p is None else math.sqrt(sum(float(v) ** 2 for v in p))
