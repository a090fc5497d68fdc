"""``[lens.front]`` / ``[lens.back]`` ``type = "points"``: a surface from a points file
(:mod:`eyelab.optics.pointsfile`), its spec keys as the schema lists them, and the spec's
folder that relative file paths are read from."""

from __future__ import annotations

import functools
from contextvars import ContextVar
from pathlib import Path

from eyelab.core.errors import SpecError
from eyelab.core.fileio import user_path
from eyelab.optics.pointsfile import FIRST_ROWS, FORMATS
from eyelab.optics.pointsfile import LIMITS as POINTS_LIMITS

__all__ = ["POINTS_KEYS", "POINTS_LIMITS", "TYPE_BASE", "absolute_files", "spec_file",
           "with_spec_folder"]

#: The folder of the spec file being parsed (None: a spec given as a table).
SPEC_FOLDER: ContextVar = ContextVar("eyelab_spec_folder", default=None)
#: A plano points grid shipped with the package (2 mm spacing, 31 x 31; a .csv example):
#: the file the schema's examples read (a key's ``base``, read by the tests and the corpus).
SAMPLE = str(Path(__file__).resolve().parents[1] / "data" / "plano_2mm.csv")
_BASE_FRONT = {"file": SAMPLE, "spacing_mm": 2.0}
#: A spec whose front is the sample grid.
POINTS_BASE = {"lens": {"front": {"type": "points", **_BASE_FRONT},
                        "back": {"type": "plane"}, "center_thickness_mm": 2.0}}
#: The base of ``type``: a spec read whichever the type (each ignores the others' keys).
TYPE_BASE = {"lens": {"front": {"type": "sphere", "radius_mm": 100.0, **_BASE_FRONT},
                      "back": {"type": "sphere", "radius_mm": 80.0},
                      "center_thickness_mm": 2.0}}
_FILES = ", ".join(FORMATS)
#: The schema's keys of a points surface: (positional, keyword) arguments of its ``Key``.
POINTS_KEYS = (
    (("lens.front", "file", "text", "", "none", "the points file of `type = \"points\"`, "
      "relative to the spec: a Vision Council DCS surface file (SURFMT and ZZ records) or a "
      "sag grid in mm (below: surfaces from points)"),
     {"range_text": f"an existing {_FILES} file", "base": POINTS_BASE}),
    (("lens.front", "spacing_mm", "number", "mm", "required for .csv, .npy", "points: the "
      "grid's spacing (a .sdf file gives its own)"), {"base": POINTS_BASE, "edges": False}),
    (("lens.front", "first_row", "choice", "", '`"bottom"`', "points: which edge of the "
      "surface the file's first row of sags lies on: −y (bottom) or +y (top)"),
     {"choices": FIRST_ROWS, "base": POINTS_BASE}),
)


def with_spec_folder(parse):
    """Decorate ``parse(data, source, base)`` (:func:`eyelab.spec.load.parse_spec`) so that
    relative points files are read from ``base``, the spec file's folder, while it runs."""

    @functools.wraps(parse)
    def wrapper(*args, **kw):
        base = kw.get("base", args[2] if len(args) > 2 else None)
        token = SPEC_FOLDER.set(None if base is None else Path(base))
        try:
            return parse(*args, **kw)
        finally:
            SPEC_FOLDER.reset(token)

    return wrapper


def spec_file(value, field: str) -> Path:
    """A ``file`` key's path: absolute as written, or relative to the spec's folder (to
    the working folder for a spec given as a table)."""
    if not isinstance(value, str) or not value.strip():
        raise SpecError(field, f"must be a points file's path ({_FILES}), got {value!r}")
    p = user_path(field, value)
    folder = SPEC_FOLDER.get()
    return p if p.is_absolute() or folder is None else folder / p


def absolute_files(data: dict, folder) -> dict:
    """``data`` (a spec table, changed in place and returned) with every relative points
    file — ``[lens.front]``, ``[lens.back]``, and theirs under ``[lens.right]`` /
    ``[lens.left]`` — and the ``[frame]`` trace file made absolute from ``folder``, the
    spec file's: for a spec table parsed away from its file (a job of ``eyelab batch``)."""
    lens = data.get("lens") if isinstance(data, dict) else None
    tables = [lens] + [lens.get(s) for s in ("right", "left")] if isinstance(lens, dict) \
        else []
    holders = [t.get(side) for t in tables if isinstance(t, dict) for side in ("front", "back")]
    holders.append(data.get("frame") if isinstance(data, dict) else None)
    for s in holders:
        if isinstance(s, dict) and isinstance(s.get("file"), str):
            try:
                p = Path(s["file"]).expanduser()
            except RuntimeError:           # an unknown ~user: the parser names the field
                continue
            if not p.is_absolute():
                s["file"] = str(Path(folder) / p)
    return data
