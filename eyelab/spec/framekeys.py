"""The ``[frame]`` table's rows of the spec's reference (:data:`eyelab.spec.schema.KEYS`),
apart from its parser (:mod:`eyelab.spec.frame`, which reads the schema): the schema
builds them with its own ``Key`` and ranges, so no import runs in a circle."""

from __future__ import annotations

from eyelab.optics.lens.frame import FRAME_SHAPES
from eyelab.optics.lens.frame import LIMITS as FIT_LIMITS

#: The reference's heading of the table (:data:`eyelab.spec.schema.TABLES`).
FRAME_TABLE = ("`[frame]` (the frame the lenses are cut to: renders show its outline, maps "
               "and rays end at it; the lens's fitting point — optical centre, or a "
               "progressive's fitting cross — sits before the pupil; keys written here win "
               "over a trace file's records)")
#: A spec the frame's keys are read in.
FRAME_BASE = {"lens": {"rx": "-2.00 DS"}, "frame": {"shape": "oval", "box_mm": [50.0, 50.0],
                                                    "dbl_mm": 18.0, "monocular_pd_mm": 32.0}}


def frame_keys(key, limits: dict) -> list:
    """The ``[frame]`` rows, made by the schema's ``key`` class (:class:`eyelab.spec.schema.
    Key`) with its ``limits`` (the monocular PD takes ``[binocular]``'s range)."""
    pd = limits["binocular.monocular_pd_mm"]
    return [
        key("frame", "file", "text", "", "none", "a Vision Council DCS (OMA) trace, "
            "relative to the spec: TRCFMT=1;360;E;R;F then R= radii in 0.01 mm (uneven "
            "angles: U and A= records); each eye its own trace, or one mirrored",
            range_text="a DCS file (format 1)"),
        key("frame", "shape", "choice", "", "none", "a built-in shape instead of `file`: a "
            "circle (A = B), the ellipse, a rectangle with corners of radius min(A, B)/4, a "
            "teardrop deepest toward the nose", choices=FRAME_SHAPES, base=FRAME_BASE),
        key("frame", "box_mm", "pair", "mm", "required with `shape`", "[A, B]: the box's "
            "width and height (HBOX, VBOX); a trace's box is its own", base=FRAME_BASE,
            edges=False),
        key("frame", "dbl_mm", "number", "mm", "the file's DBL", "distance between the "
            "lenses' boxes (the bridge)", base=FRAME_BASE),
        key("frame", "monocular_pd_mm", "number", "mm", "the file's IPD", "one eye: its "
            "pupil centre to the bridge's centre line (two eyes: [binocular]'s pupils)",
            lo=pd[0], hi=pd[1], base=FRAME_BASE),
        key("frame", "fitting_height_mm", "number", "mm", "the file's SEGHT "
            "(progressive) or OCHT, else B/2", "the pupil centre — and the lens's fitting "
            "point — above the box's lower edge", base=FRAME_BASE, edges=False),
    ]


__all__ = ["FIT_LIMITS", "FRAME_BASE", "FRAME_TABLE", "frame_keys"]
