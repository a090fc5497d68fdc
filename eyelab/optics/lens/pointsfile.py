"""Surfaces from points files, and surfaces out to points files: the sag grids labs exchange.

A lens surface is read from, or written to, a regular grid of sags: a Vision Council DCS
surface points file (``.sdf``: a ``SURFMT`` record, then ``ZZ`` records of sag values), a
plain ``.csv`` grid, or a NumPy ``.npy`` array. The grid becomes the engine's
:class:`~eyelab.optics.rays.surfaces.FreeForm`: the interpolating tensor-product B-spline of
degree 5 (quintic) through the sags. Quintic, not bicubic: the engine refracts wavefronts
with each surface's curvatures (second derivatives), and a quintic's curvature is twice
continuously differentiable and converges as h^4 with the spacing h, a bicubic's only as h^2
(on a 41 x 41 grid over 64 mm the quintic's curvatures are within 4e-7 of a sphere's, the
bicubic's 2e-4: :class:`~eyelab.optics.rays.surfaces.FreeForm`).

Geometry (all formats): rows of sags in mm along the engine's +z (the direction light
travels, toward the eye; a usual meniscus has both sags rising toward the rim), x increasing
along a row (the lens frame's x, the wearer's right), rows stacked along y; the first row is
the bottom (-y) one unless the spec says ``first_row = "top"``. The grid is centred on the
surface's vertex, and the sag is taken relative to the sag there (where the lens's centre
thickness is measured).

The DCS surface points file, as the public implementations read and write it (the
standard's own SURFMT table was not available to check against):

* VisiontechGitHub/SoapClient ``SoapClientService/Writer/SDFWriter.cs`` (commit 8177773,
  2020-12-04), a lens design service writing the file a lab's generator receives:
  ``SURFMT=1;<R|L>;B;<n>;<n>;<w>;<w>;0`` — format type 1 (ASCII), the eye, the surface
  (F front, B back), the number of rows and of values per row, the grid's extents in mm,
  then a field it always writes as 0 (not read here) — followed by one ``ZZ`` record per
  row, the lowest y first, x increasing along it, n = w + 1 (1 mm spacing);
* VisiontechGitHub/Visiontech.Analyzer ``Visiontech.Analyzer/ViewModels/ViewModel.cs``
  (commit b955202, 2019-02-11), a reader: field 2 the eye, field 4 the count; it takes field
  1 as the spacing in mm and puts the first ``ZZ`` row at +y (the top).

Where they disagree both readings are supported, explicitly: the spacing is the extent over
(count - 1) when fields 6-7 are given (field 1 must then be the format type 1, or equal that
spacing), field 1 when the record stops before them; the row order is the spec's
``first_row`` (default "bottom", the writer's). The counts of fields 4 and 5 may come in
either order (the data say which is the rows'), the extents in the order of the counts.
Records of other labels are skipped; a row longer than a record may continue in further
``ZZ`` records (:mod:`eyelab.optics.lens.dcs`), when the grid is square. Files are written in the
writer's layout — ``SURFMT=1;<eye>;<F|B>;<n>;<n>;<w>;<w>``, square (so the order of the
counts and of the extents does not matter), a node on the vertex, rows bottom first — with
sags of :data:`SAG_DECIMALS` decimals in mm (0.1 nm), re-read exactly as written.

Precision: a surface's local power comes from the grid's second differences, so sag
rounding of step q at spacing h gives curvature noise of the order of 4 q / h^2: a file of
4 decimals (0.1 um) at 0.5 mm carries about ±0.8 D of noise in (n - 1) x curvature, one of 7
decimals about ±0.001 D.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from eyelab.core.checks import check_choice, check_range
from eyelab.core.errors import SpecError
from eyelab.optics.lens.dcs import (
    MAX_BYTES,
    format_record,
    lines,
    number,
    parse_records,
    read_text,
)
from eyelab.optics.rays.surfaces import FreeForm

#: The file formats, by extension.
FORMATS = (".sdf", ".csv", ".npy")
#: Which edge of the surface a file's first row of sags is.
FIRST_ROWS = ("bottom", "top")
#: Ranges by field, in the spec's units (mm): a grid's spacing (the spec's ``spacing_mm``
#: of a .csv or .npy grid, a DCS file's own, ``eyelab surface --spacing-mm``) and the side
#: of a written grid (``eyelab surface --size-mm``).
LIMITS = {"lens.front.spacing_mm": (0.05, 10.0), "surface.size_mm": (5.0, 150.0)}
#: Sags are written with this many decimals in mm (0.1 nm).
SAG_DECIMALS = 7
#: Fewest and most points a grid has along each axis (a quintic needs 6).
MIN_POINTS, MAX_POINTS = 6, 2001
#: Margin (mm) a written grid extends beyond the lens's rim on each side by default.
MARGIN_MM = 2.0


@dataclass(frozen=True)
class SagGrid:
    """A regular sag grid: ``z`` (ny, nx) mm at ``x`` (nx,) and ``y`` (ny,) mm (both
    increasing, centred on 0; row 0 the bottom, -y), as read (the numbers as written) or to
    be written. ``side`` ("R"/"L") and ``surface`` ("F"/"B") are a DCS file's (or "")."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    side: str = ""
    surface: str = ""

    def freeform(self) -> FreeForm:
        """The quintic :class:`FreeForm` through the grid (m), its sag taken relative to the
        grid's centre (the vertex)."""
        x, y, z = self.x * 1e-3, self.y * 1e-3, self.z * 1e-3
        z0 = FreeForm(x, y, z).sag(np.zeros(1), np.zeros(1))[0]
        return FreeForm(x, y, z - z0)

    def reach_mm(self) -> tuple:
        """(x, y) half-extents (mm): how far the grid reaches from its centre."""
        return float(min(-self.x[0], self.x[-1])), float(min(-self.y[0], self.y[-1]))


def grid_axes(nx: int, ny: int, sx: float, sy: float) -> tuple:
    """(x (nx,), y (ny,)) mm of a grid of ``nx`` x ``ny`` points at spacings ``sx``, ``sy``
    (mm), centred on 0."""
    return (np.arange(nx) - (nx - 1) / 2) * sx, (np.arange(ny) - (ny - 1) / 2) * sy


def _check_shape(nx: int, ny: int, field: str, name: str) -> None:
    for n, what in ((nx, "values per row"), (ny, "rows")):
        if not MIN_POINTS <= n <= MAX_POINTS:
            raise SpecError(field, f"{name}: {n} {what}; a grid has {MIN_POINTS}-{MAX_POINTS} "
                                   f"(the quintic spline needs {MIN_POINTS})")


def _check_spacing(s: float, field: str, name: str) -> float:
    lo, hi = LIMITS["lens.front.spacing_mm"]
    if not lo <= s <= hi:
        raise SpecError(field, f"{name}: a spacing of {s:g} mm; a grid's spacing is "
                               f"{lo:g}-{hi:g} mm")
    return s


def read_points(path, field: str, *, spacing_mm: float | None = None,
                first_row: str = "bottom") -> SagGrid:
    """The sag grid of the points file at ``path`` (format by extension, :data:`FORMATS`):
    a DCS ``.sdf`` gives its own spacing, a ``.csv`` or ``.npy`` grid takes ``spacing_mm``
    (mm). ``first_row``: "bottom" (-y) or "top". A malformed file raises
    :class:`SpecError` naming ``field`` (e.g. ``lens.front.file``) and the problem."""
    check_choice("first_row", first_row, FIRST_ROWS)
    p = Path(path)
    ext = p.suffix.lower()
    if ext not in FORMATS:
        raise SpecError(field, f"{p.name}: a points file is {', '.join(FORMATS)}; got "
                               f"{ext or 'no extension'!r}")
    if not p.is_file():
        raise SpecError(field, f"{str(path)[:80]!r} is not an existing file")
    if ext == ".sdf":
        x, y, z, side, surface = _read_dcs(p, field)
    else:
        z = _read_csv(p, field) if ext == ".csv" else _read_npy(p, field)
        _check_shape(z.shape[1], z.shape[0], field, p.name)
        if spacing_mm is None:
            raise SpecError(field.rsplit(".", 1)[0] + ".spacing_mm",
                            f"a {ext} grid needs its spacing (mm) to place its sags")
        s = _check_spacing(spacing_mm, field, p.name)
        x, y = grid_axes(z.shape[1], z.shape[0], s, s)
        side = surface = ""
    if first_row == "top":
        z = z[::-1]
    return SagGrid(x, y, np.ascontiguousarray(z), side, surface)


def _finite(z: np.ndarray, field: str, name: str) -> np.ndarray:
    bad = np.argwhere(~np.isfinite(z))
    if len(bad):
        r, c = bad[0]
        raise SpecError(field, f"{name}: row {r + 1}, value {c + 1} is {float(z[r, c])!r}: every "
                               f"sag must be a finite number ({len(bad)} are not)")
    return z


def _read_csv(p: Path, field: str) -> np.ndarray:
    """Rows of numbers separated by commas, semicolons or blanks; ``#`` lines skipped."""
    import re

    text = read_text(p, field)
    rows = []
    for i, line in enumerate(lines(text), start=1):
        line = line.strip().lstrip("\ufeff")
        if not line or line.startswith("#"):
            continue
        vals = [v for v in re.split(r"[,;\s]+", line) if v != ""]
        rows.append([number(v, field, f"{p.name} line {i}, value {k}")
                     for k, v in enumerate(vals, start=1)])
        if len(rows[-1]) != len(rows[0]):
            raise SpecError(field, f"{p.name} line {i}: {len(rows[-1])} values, the first "
                                   f"row {len(rows[0])}: a grid's rows are all as long")
    if not rows:
        raise SpecError(field, f"{p.name}: no rows of sags")
    return np.array(rows, float)


def _read_npy(p: Path, field: str) -> np.ndarray:
    import io

    from eyelab.core.fileio import read_input

    raw = read_input(field, p, MAX_BYTES, "points file")      # its own one-line errors
    try:
        z = np.load(io.BytesIO(raw), allow_pickle=False)
    except (OSError, ValueError, EOFError) as e:
        raise SpecError(field, f"{p.name}: not a NumPy array file ({e})") from None
    if not isinstance(z, np.ndarray) or z.ndim != 2 or z.dtype.kind not in "iuf":
        what = f"a {z.ndim}-D {z.dtype} array" if isinstance(z, np.ndarray) else type(z)
        raise SpecError(field, f"{p.name}: {what}; a sag grid is a 2-D array of real numbers "
                               "(rows, values per row)")
    return _finite(np.asarray(z, float), field, p.name)


def _surfmt(rec, field: str, name: str) -> dict:
    """The SURFMT record's fields (see the module's reading)."""
    v = [s.strip() for s in rec.values]
    where = f"{name} line {rec.line} (SURFMT)"
    if len(v) < 5:
        raise SpecError(field, f"{where}: {len(v)} fields; SURFMT has format type; eye; "
                               "surface; rows; values per row[; extents in mm]")
    out = {"side": v[1].upper(), "surface": v[2].upper()}
    if out["side"] not in ("R", "L"):
        raise SpecError(field, f"{where}: field 2 (the eye) is {v[1]!r}, not R or L")
    if out["surface"] not in ("F", "B"):
        raise SpecError(field, f"{where}: field 3 (the surface) is {v[2]!r}, not F or B")
    counts = [number(v[k], field, f"{where} field {k + 1}") for k in (3, 4)]
    if any(c != int(c) or c < 1 for c in counts):
        raise SpecError(field, f"{where}: fields 4-5 (the counts) must be positive "
                               f"integers, got {v[3]!r}, {v[4]!r}")
    out["counts"] = [int(c) for c in counts]
    first = number(v[0], field, f"{where} field 1")
    if len(v) >= 7 and v[5] and v[6]:
        out["extents"] = [number(v[k], field, f"{where} field {k + 1}") for k in (5, 6)]
        out["field1"] = first
    else:                              # no extents: field 1 is the spacing (Visiontech
        out["spacing"] = first         # Analyzer's reading)
    return out


def _read_dcs(p: Path, field: str) -> tuple:
    """(x, y, z, side, surface) of a DCS surface points file."""
    name = p.name
    recs = parse_records(read_text(p, field), field, name)
    heads = [r for r in recs if r.label == "SURFMT"]
    if len(heads) != 1:
        lines = ", ".join(str(r.line) for r in heads)
        raise SpecError(field, f"{name}: no SURFMT record (format; eye; surface; rows; values "
                               "per row; extents)" if not heads else f"{name}: {len(heads)} "
                               f"SURFMT records (lines {lines}); a points file holds one "
                               "surface")
    head = heads[0]
    fmt = _surfmt(head, field, name)
    before = [r for r in recs if r.label == "ZZ" and r.line < head.line]
    if before:
        raise SpecError(field, f"{name} line {before[0].line}: a ZZ record before SURFMT")
    zz = [r for r in recs if r.label == "ZZ"]
    if not zz:
        raise SpecError(field, f"{name}: no ZZ records (one per row of sags) after SURFMT")
    rows = [[number(s, field, f"{name} line {r.line}, value {k}")
             for k, s in enumerate(_values(r), start=1)] for r in zz]
    z = _finite(_shape_rows(rows, zz, fmt["counts"], field, name), field, name)
    sx, sy = _spacings(fmt, z.shape, field, f"{name} line {head.line} (SURFMT)")
    x, y = grid_axes(z.shape[1], z.shape[0], sx, sy)
    return x, y, z, fmt["side"], fmt["surface"]


def _values(rec) -> tuple:
    """A ZZ record's values, one trailing empty value (a final ``;``) dropped."""
    v = rec.values
    return v[:-1] if len(v) > 1 and not v[-1].strip() else v


def _shape_rows(rows: list, zz: list, counts: list, field: str, name: str) -> np.ndarray:
    """The (rows, values per row) array of the ZZ records: one record per row, or rows
    continued over several records of a square grid; the counts of SURFMT fields 4-5 in
    either order."""
    a, b = counts
    total = sum(len(r) for r in rows)
    if len(rows) in (a, b):
        ncol = b if len(rows) == a else a
        for r, rec in zip(rows, zz, strict=True):
            if len(r) != ncol:
                raise SpecError(field, f"{name} line {rec.line}: {len(r)} values in a ZZ "
                                       f"row; SURFMT gives {len(rows)} rows of {ncol}")
        _check_shape(ncol, len(rows), field, name)
        return np.array(rows, float)
    if a == b and total == a * b:              # rows continued over several records
        _check_shape(a, a, field, name)
        return np.array([v for r in rows for v in r], float).reshape(a, a)
    raise SpecError(field, f"{name}: {len(rows)} ZZ records of {total} values; SURFMT gives "
                           f"{a} x {b} (one ZZ record per row)")


def _spacings(fmt: dict, shape: tuple, field: str, where: str) -> tuple:
    """(x, y) spacings (mm) from SURFMT: extents over (count - 1) in the counts' order, or
    field 1 alone (square cells)."""
    ny, nx = shape
    if "spacing" in fmt:
        s = _check_spacing(fmt["spacing"], field, where)
        return s, s
    (ca, cb), (ea, eb) = fmt["counts"], fmt["extents"]
    if ca == cb and ea != eb:
        raise SpecError(field, f"{where}: equal counts with extents {ea:g} and {eb:g} mm: "
                               "which is along the rows cannot be told")
    ey, ex = (ea, eb) if ca == ny else (eb, ea)
    sx, sy = (_check_spacing(e / (n - 1), field, where) for e, n in ((ex, nx), (ey, ny)))
    f1 = fmt["field1"]
    if f1 != 1 and not (abs(f1 - sx) <= 1e-6 * sx and abs(f1 - sy) <= 1e-6 * sy):
        raise SpecError(field, f"{where}: field 1 is {f1:g}: neither the format type 1 "
                               f"(ASCII) nor the spacing the extents give ({sx:g} mm)")
    return sx, sy


def check_covers(grid: SagGrid, diameter: float, field: str) -> None:
    """Refuse (naming ``field``) a grid that does not reach the rim of a lens of
    ``diameter`` (m) on every side of its centre."""
    rx, ry = grid.reach_mm()
    need = diameter / 2 * 1e3
    if min(rx, ry) < need - 1e-9:
        raise SpecError(field, f"the grid reaches {rx:g} x {ry:g} mm from its centre (x, y);"
                               f" the {diameter * 1e3:g} mm lens (diameter_mm) needs {need:g} "
                               "mm on every side")


# ------------------------------------------------------------------------------ writing
def sample_surface(surface, spacing_mm: float, size_mm: float, field: str = "--size-mm"
                   ) -> SagGrid:
    """``surface``'s sags on the square grid of side at least ``size_mm`` (mm) at
    ``spacing_mm``, a node on the vertex (an odd count). A surface without a sag somewhere
    on the grid (steeper than a hemisphere, or beyond a free-form's own grid) is refused
    naming ``field``, with the largest size that has one."""
    s = check_range("--spacing-mm", spacing_mm, *LIMITS["lens.front.spacing_mm"])
    size = check_range(field, size_mm, *LIMITS["surface.size_mm"])
    half = math.ceil(size / 2 / s - 1e-9)
    n = 2 * half + 1
    if n > MAX_POINTS:
        raise SpecError("--spacing-mm", f"{s:g} mm over {size:g} mm gives {n} points a "
                                        f"side; at most {MAX_POINTS}: a coarser spacing")
    g, _ = grid_axes(n, n, s, s)
    gx, gy = np.meshgrid(g, g)
    xm, ym = gx * 1e-3, gy * 1e-3
    if isinstance(surface, FreeForm):         # on its own grid's edge, not an ulp beyond
        xm, ym = _snap(xm, surface.x), _snap(ym, surface.y)
    with np.errstate(invalid="ignore"):
        z = np.asarray(surface.sag(xm, ym), float) * 1e3
    bad = ~np.isfinite(z)
    if bad.any():
        ring = np.maximum(np.abs(gx), np.abs(gy))[bad].min() / s    # Chebyshev index
        fits = 2 * (round(ring) - 1) * s
        raise SpecError(field, f"the surface has no sag {ring * s:g} mm from its centre "
                               "(steeper than a hemisphere there, or beyond a free-form's "
                               f"own grid): at most {fits:g} mm at {s:g} mm spacing")
    return SagGrid(g, g.copy(), z)


def _snap(v: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """``v`` (m) with values within 1e-12 m of ``axis``'s ends put on them."""
    v = np.where(np.abs(v - axis[0]) < 1e-12, axis[0], v)
    return np.where(np.abs(v - axis[-1]) < 1e-12, axis[-1], v)


def default_size_mm(lens, spacing_mm: float, surface=None) -> float:
    """The side (mm) of a written grid: the lens's diameter and :data:`MARGIN_MM` on each
    side, within what a free-form ``surface`` covers (never less than the diameter)."""
    size = lens.diameter * 1e3 + 2 * MARGIN_MM
    if isinstance(surface, FreeForm):
        reach = 1e3 * min(-surface.x[0], surface.x[-1], -surface.y[0], surface.y[-1])
        fit = 2 * math.floor(reach / spacing_mm + 1e-9) * spacing_mm
        size = max(min(size, fit), lens.diameter * 1e3)
    return size


def _fmt(v: float) -> str:
    return f"{v:.{SAG_DECIMALS}f}"


def _extent(v: float) -> str:
    return f"{v:.6f}".rstrip("0").rstrip(".")


def dcs_lines(grid: SagGrid, side: str, surface: str) -> list:
    """The DCS surface points file of ``grid`` as lines: ``SURFMT=1;side;surface;rows;values
    per row;y extent;x extent`` (mm; counts and extents in the same order), then one ``ZZ``
    record per row, bottom (-y) first."""
    ny, nx = grid.z.shape
    head = format_record("SURFMT", ["1", side, surface, ny, nx,
                                    _extent(grid.y[-1] - grid.y[0]),
                                    _extent(grid.x[-1] - grid.x[0])])
    return [head] + [format_record("ZZ", [_fmt(v) for v in row]) for row in grid.z]


def write_points(path, grid: SagGrid, *, side: str = "R", surface: str = "F") -> str:
    """Write ``grid`` to ``path`` (format by extension, :data:`FORMATS`) whole or not at all
    (:func:`eyelab.core.fileio.atomic_path`); returns the format. ``.sdf``: DCS records,
    CR LF; ``.csv``: ``#`` comment lines, then rows bottom first, comma separated; sags
    with :data:`SAG_DECIMALS` decimals (mm). ``.npy``: the (rows, values per row) float64
    array, mm, bottom row first."""
    from eyelab.core.fileio import atomic_path

    ext = Path(path).suffix.lower()
    if ext not in FORMATS:
        raise SpecError("--output", f"must end in {', '.join(FORMATS)}; got {str(path)!r}")
    with atomic_path(path, suffix=ext) as tmp:
        if ext == ".npy":
            np.save(tmp, np.asarray(grid.z, float))
        elif ext == ".sdf":
            Path(tmp).write_bytes(("\r\n".join(dcs_lines(grid, side, surface)) + "\r\n")
                                  .encode("ascii"))
        else:
            s = float(grid.x[1] - grid.x[0])
            head = [f"# sag (mm) toward the eye; {grid.z.shape[0]} rows of "
                    f"{grid.z.shape[1]}, bottom (-y) first, x to the wearer's right",
                    f"# spacing_mm = {_extent(s)}; eye {side}, surface {surface}"]
            rows = [",".join(_fmt(v) for v in row) for row in grid.z]
            Path(tmp).write_text("\n".join(head + rows) + "\n")
    return ext[1:]


def written_values(grid: SagGrid, fmt: str) -> np.ndarray:
    """The sags (mm) a file of format ``fmt`` ("sdf", "csv", "npy") holds for ``grid``:
    what reading it back gives."""
    if fmt == "npy":
        return np.asarray(grid.z, float)
    return np.vectorize(lambda v: float(_fmt(v)))(grid.z)
