"""The ``[frame]`` table: the frame the lenses are cut to (:mod:`eyelab.optics.lens.frame`) —
a DCS trace file or a built-in shape with its box and bridge — and the fitting data that
place each lens's fitting point in front of its pupil.

``file`` (relative to the spec) or ``shape`` + ``box_mm`` [A, B]; ``dbl_mm`` (a file's
``DBL`` record by default); ``monocular_pd_mm`` (one eye: its pupil centre to the bridge's
centre line; a file's ``IPD`` record by default; two eyes: ``[binocular]``'s pupils);
``fitting_height_mm`` (the pupil centre above the box's lower edge; a file's ``SEGHT``
record for a progressive lens, else its ``OCHT``, else half the box height). Keys written
in the table win over the file's records.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from eyelab.core.checks import check_range
from eyelab.core.errors import SpecError
from eyelab.optics.lens.frame import (
    FRAME_SHAPES,
    Frame,
    box_record_notes,
    cut_lens,
    minimum_blank_size,
    read_dcs,
    record_value,
    shape_outline,
)
from eyelab.spec.schema import LIMITS, check
from eyelab.spec.tables import check_keys, choice, number

FRAME_KEYS = {"file", "shape", "box_mm", "dbl_mm", "monocular_pd_mm", "fitting_height_mm"}
#: Other names of the built-in shapes, for "did you mean".
SHAPE_ALIASES = {"ellipse": "oval", "elliptical": "oval", "circle": "round",
                 "circular": "round", "rectangular": "rectangle", "teardrop": "aviator",
                 "pilot": "aviator"}
#: The round blank's steps (mm) when the frame needs more than the default blank.
BLANK_STEP_MM = 5.0


@dataclass(frozen=True)
class FrameSpec:
    """A parsed ``[frame]``: the :class:`~eyelab.optics.lens.frame.Frame`, its table's own
    fitting values (mm, None where not written) and the file's records."""

    frame: Frame
    pd_mm: float | None = None
    height_mm: float | None = None
    records: dict = field(default_factory=dict, compare=False)
    #: warnings about the input (one line each; the spec's ``warnings``)
    notes: tuple = field(default=(), compare=False)

    @property
    def from_file(self) -> bool:
        return self.frame.source != "shape"

    def file_pd_mm(self, side: str) -> float | None:
        """The file's IPD record for ``side`` (mm), if any."""
        return record_value(self.records, "IPD", side)


def parse_frame(t, base: Path | None = None) -> FrameSpec:
    """The ``[frame]`` table -> :class:`FrameSpec`; errors name the key (a trace file's:
    ``frame.file`` and the line)."""
    check_keys(t, FRAME_KEYS, "frame")
    if "shape" in t:
        choice("frame.shape", t["shape"], FRAME_SHAPES, SHAPE_ALIASES)
    if "file" in t and "shape" in t:
        raise SpecError("frame.file", "give either file (a DCS trace) or shape, not both")
    if "box_mm" in t and "shape" not in t:
        raise SpecError("frame.box_mm", "only with shape (a trace file's box is its "
                                        "trace's own)")
    dbl = number(t, "dbl_mm", "frame")
    pd = None if "monocular_pd_mm" not in t else check_pd("frame.monocular_pd_mm",
                                                          t["monocular_pd_mm"])
    height = number(t, "fitting_height_mm", "frame")
    if "file" in t:
        outlines, records = read_dcs(_read(t["file"], base))
        source = str(t["file"])
    elif "shape" in t:
        outlines, records = _shape(t), {}
        source = "shape"
    else:
        raise SpecError("frame", "give the frame's shape: file = \"job.oma\" (a DCS trace) "
                                 f"or shape = one of {', '.join(map(repr, FRAME_SHAPES))} "
                                 "with box_mm and dbl_mm")
    if dbl is None:
        dbl = _record(records, "DBL", None, check, "frame.dbl_mm")
        if dbl is None:
            raise SpecError("frame.dbl_mm", "required (the bridge, mm)"
                            + (": the trace file has no DBL record" if "file" in t else ""))
    frame = Frame(outlines, dbl * 1e-3, source, records)
    return FrameSpec(frame, pd, height, records, tuple(box_record_notes(frame, records)))


def _record(records: dict, label: str, side, checker, field_name: str):
    """A trace file's record (mm) checked as ``field_name`` by ``checker(field, value)``,
    an error naming ``frame.file`` and the record; None where absent."""
    v = record_value(records, label, side)
    if v is None:
        return None
    try:
        return checker(field_name, v)
    except SpecError as e:
        raise SpecError("frame.file", f"the {label} record ({field_name}): "
                                      f"{e.message}") from None


def check_pd(field_name: str, value) -> float:
    """A monocular PD (mm) checked against [binocular]'s range (one range for both)."""
    return check_range(field_name, value, *LIMITS["binocular.monocular_pd_mm"])


def _read(path, base) -> str:
    """The text of the trace file ``path`` (relative to the spec's folder)."""
    if not isinstance(path, str) or not path.strip():
        raise SpecError("frame.file", f"must be a path to a DCS trace file, got {path!r}")
    from eyelab.core.fileio import user_path
    from eyelab.optics.lens.dcs import read_text

    p = user_path("frame.file", path)
    if not p.is_absolute() and base is not None:
        p = Path(base) / p
    return read_text(p, "frame.file").removeprefix("\ufeff")    # a byte-order mark: text


def _shape(t) -> dict:
    """{side: outline} of a built-in shape (the left the right's mirror image)."""
    if "box_mm" not in t:
        raise SpecError("frame.box_mm", "required with shape: [A, B], the box's width and "
                                        "height in mm")
    box = t["box_mm"]
    if not (isinstance(box, list) and len(box) == 2):
        raise SpecError("frame.box_mm", f"must be [A, B] in mm, got {box!r}")
    a, b = (check(f"frame.box_mm[{i}]", v) for i, v in enumerate(box))
    if t["shape"] == "round" and a != b:
        raise SpecError("frame.box_mm", f"a round frame's box is square: A = B, got "
                                        f"[{a:g}, {b:g}]")
    right = shape_outline(t["shape"], a * 1e-3, b * 1e-3)
    return {"right": right, "left": right.mirrored()}


# ------------------------------------------------------------------ fitting
def fitting_height(fs: FrameSpec, side: str, progressive: bool) -> tuple:
    """(fitting height m, the field it came from) for ``side``: the table's key, the
    file's SEGHT (a progressive) or OCHT record, else half the box height."""
    if fs.height_mm is not None:
        return fs.height_mm * 1e-3, "frame.fitting_height_mm"
    order = ("SEGHT", "OCHT") if progressive else ("OCHT", "SEGHT")
    for label in order:
        v = _record(fs.records, label, side, check, "frame.fitting_height_mm")
        if v is not None:
            return v * 1e-3, "frame.file"
    return fs.frame.box(side)[1] / 2, "frame.fitting_height_mm"


def one_eye_pd(fs: FrameSpec, side: str) -> tuple:
    """(monocular PD m, field) of a one-eye spec: the table's key, else the file's IPD."""
    if fs.pd_mm is not None:
        return fs.pd_mm * 1e-3, "frame.monocular_pd_mm"
    v = _record(fs.records, "IPD", side, check_pd, "frame.monocular_pd_mm")
    if v is None:
        raise SpecError("frame.monocular_pd_mm", "required for one eye: its pupil centre's "
                        "distance from the bridge's centre line, mm"
                        + (" (the trace file has no IPD record)" if fs.from_file else ""))
    return v * 1e-3, "frame.file"


def fitted_lens(fs: FrameSpec, side: str, pd: tuple, lens_t: dict, make):
    """The lens ``make(table)`` (a ``[lens]`` table -> lens) cut to ``side``'s outline,
    its fitting point before the pupil. ``pd``: (monocular PD m, the field it came from).
    Without ``diameter_mm`` the blank is the default one, or, where the frame needs more,
    the minimum blank size rounded up to :data:`BLANK_STEP_MM`."""
    progressive = lens_t.get("design") == "progressive"
    height, h_field = fitting_height(fs, side, progressive)
    placed = fs.frame.placed(side, pd[0], height)
    if "diameter_mm" not in lens_t:
        lens_t = _with_blank(lens_t, placed)
    lens = make(lens_t)
    fit = {"side": side, "pd": pd[0], "height": height, "pd_field": pd[1],
           "height_field": h_field, "blank_field": "lens.diameter_mm"}
    return cut_lens(lens, placed, fit)


def _with_blank(lens_t: dict, placed) -> dict:
    """``lens_t`` with the blank the frame needs where the default one is too small: the
    minimum blank size (at the table's decentration) rounded up to :data:`BLANK_STEP_MM`,
    at most the largest diameter (a frame needing more is refused by the cut)."""
    from eyelab.optics.lens.spectacle import LIMITS as LENS_LIMITS
    from eyelab.optics.lens.spectacle import SpectacleLens

    try:
        dx, dy = (float(v) * 1e-3 for v in lens_t.get("decentration_mm", [0.0, 0.0]))
    except (TypeError, ValueError):
        return lens_t                       # refused by the lens's own parser
    need = minimum_blank_size(placed.shifted(-dx, -dy)) * 1e3
    if not need > SpectacleLens.__dataclass_fields__["diameter"].default * 1e3:
        return lens_t
    blank = min(BLANK_STEP_MM * math.ceil(need / BLANK_STEP_MM),
                LENS_LIMITS["lens.diameter_mm"][1])
    return {**lens_t, "diameter_mm": blank}


def binocular_pupils(fs: FrameSpec | None, bt: dict):
    """The pupils' (right, left) monocular PDs (m) a [frame] gives a two-eye spec where
    [binocular] writes none (the file's IPD records), or None; a [frame] key that would
    place them is refused (the pupils are [binocular]'s)."""
    if fs is None:
        return None
    if fs.pd_mm is not None:
        raise SpecError("frame.monocular_pd_mm", "two eyes: their pupils are [binocular]'s "
                                                 "pd_mm or monocular_pd_mm = [right, left]")
    if "frame_pd_mm" in bt:
        raise SpecError("binocular.frame_pd_mm", "with a [frame] the lenses' fitting points "
                        "sit before the pupils (the frame's box and bridge give A + DBL); "
                        "move an optical centre with lens.decentration_mm")
    if "pd_mm" in bt or "monocular_pd_mm" in bt:
        return None
    pds = [_record(fs.records, "IPD", s, check_pd, f"binocular.monocular_pd_mm[{i}]")
           for i, s in enumerate(("right", "left"))]
    if any(v is None for v in pds):
        return None
    return tuple(v * 1e-3 for v in pds)


def frame_for(fs: FrameSpec | None, lens_t) -> None:
    """Refuse a [frame] without a [lens] to cut."""
    if fs is not None and lens_t is None:
        raise SpecError("frame", "a frame holds lenses: give [lens] (or leave the frame out "
                                 "for the naked eye)")


__all__ = ["FRAME_KEYS", "FrameSpec", "binocular_pupils", "check_pd", "fitted_lens",
           "frame_for",
           "one_eye_pd", "parse_frame"]
