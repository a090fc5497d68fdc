"""``[lens.front]`` / ``[lens.back]`` ``type = "points"``: a surface from a points file
(:mod:`eyelab.optics.lens.pointsfile`), its spec keys as the schema lists them, and the spec's
folder that relative file paths are read from."""

from __future__ import annotations

import functools
from contextvars import ContextVar
from pathlib import Path

from eyelab.core.errors import SpecError
from eyelab.core.fileio import user_path
from eyelab.optics.lens.pointsfile import FIRST_ROWS, FORMATS
from eyelab.optics.lens.pointsfile import LIMITS as POINTS_LIMITS

__all__ = ["POINTS_KEYS", "POINTS_LIMITS", "TYPE_BASE", "absolute_files", "file_refs", "spec_file",
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
#: The base of ``type`` (a points surface's is :data:`POINTS_BASE`): a front surface with
#: no key but its type, read by every formula type.
TYPE_BASE = {"lens": {"front": {"type": "sphere"}, "back": {"type": "sphere", "radius_mm": 80.0},
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


def spec_file(value, field: str, what: str | None = None) -> Path:
    """A ``file`` key's path: absolute as written, or relative to the spec's folder (to
    the working folder for a spec given as a table). ``what`` names the kind of file in
    the error (default: a points file)."""
    if not isinstance(value, str) or not value.strip():
        what = what or f"a points file's path ({_FILES})"
        raise SpecError(field, f"must be {what}, got {value!r}")
    p = user_path(field, value)
    folder = SPEC_FOLDER.get()
    return p if p.is_absolute() or folder is None else folder / p


def file_refs(data: dict) -> list:
    """(table, key, scene) for every key of a spec table ``data`` that names a file, as
    written: ``render.scene`` (or its ``path``; ``scene`` True: it may also name a built-in
    scene), each lens surface's ``file`` (also under ``[lens.right]`` / ``[lens.left]``)
    and the ``[frame]``'s ``file``. The one list of where a spec reads files."""
    if not isinstance(data, dict):
        return []
    refs = []
    render = data.get("render")
    if isinstance(render, dict):
        scene = render.get("scene")
        refs.append((scene, "path", True) if isinstance(scene, dict) else
                    (render, "scene", True))
    lens = data.get("lens")
    tables = [lens] + [lens.get(s) for s in ("right", "left")] if isinstance(lens, dict) \
        else []
    refs += [(t[side], "file", False) for t in tables if isinstance(t, dict)
             for side in ("front", "back") if isinstance(t.get(side), dict)]
    if isinstance(data.get("frame"), dict):
        refs.append((data["frame"], "file", False))
    return [r for r in refs if isinstance(r[0].get(r[1]), str)]


def absolute_files(data: dict, folder) -> dict:
    """``data`` (a spec table, changed in place and returned) with every relative file of
    :func:`file_refs` made absolute from ``folder``, the spec file's (a scene only when it
    names a file there, not a built-in scene): for a spec table parsed away from its file
    (a job of ``eyelab batch``)."""
    for t, k, scene in file_refs(data):
        try:
            p = Path(t[k]).expanduser()
        except RuntimeError:               # an unknown ~user: the parser names the field
            continue
        if not p.is_absolute() and not (scene and not (Path(folder) / p).is_file()):
            t[k] = str(Path(folder) / p)
    return data
