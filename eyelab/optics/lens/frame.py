"""Spectacle frames: the outline a lens is cut to, where it sits in front of the eye, and
whether a lens blank is big enough for it. Pure numpy.

Coordinates: the wearer's view as in :mod:`eyelab.optics.lens.spectacle` — x to the wearer's right,
y up, metres; an :class:`Outline` lies in the lens's own plane (the frame's plane, as a
tracer measures it). A right eye's nasal side is -x, a left eye's +x.

Boxing (A, B, DBL): the outline's box is the smallest rectangle holding it, A its width
(DCS ``HBOX``), B its height (``VBOX``); DBL the distance between the two boxes (the
bridge); the distance between the box centres, A + DBL, is the frame's "frame PD"
(DBC) [boxing]. The lens's fitting point — its optical centre, or a progressive's
fitting cross, i.e. the lens frame's origin (:class:`~eyelab.optics.lens.spectacle.LensPose`) — is
placed in front of the pupil: the pupil centre lies ``monocular_pd`` from the bridge's
centre line and ``fitting_height`` above the box's lower edge, so the box centre sits
(DBL/2 + A/2 - monocular_pd) temporally and (B/2 - fitting_height) above the pupil.

Frame traces, the Vision Council's Data Communication Standard (DCS, "OMA") [dcs]:
records ``LABEL=v1;v2;...`` one per line; per-eye records hold ``right;left``
(``HBOX``, ``VBOX``, ``IPD`` the monocular distance PD, ``NPD`` near, ``OCHT`` optical
centre height, ``SEGHT`` segment / fitting-cross height, ``PANTO``, ``ZTILT``), ``DBL``
one value [lp-types]. A trace is ``TRCFMT=format;count;E|U;R|L|B;F|P|D`` — format 1:
ASCII radii; E: equal angles, U: uneven, the angles in ``A=`` records (0.01 deg, as a
public parser reads them); the eye; frame, pattern or demo lens — then ``R=`` records of
radii in 0.01 mm, any number per line, ``count`` in all [lp-example, lp-trace]. Equal
angles are k 360/count deg, counter-clockwise from 3 o'clock [lp-trace]. From which side
the sources read here do not say: eyelab takes the front of the frame, as ISO 8429's
TABO angles [tabo], so that a right lens's 0 deg points nasally — which the public
example bears out: its right trace [lp-example] is cut away below its 0 deg side, where
the nose pads sit, and its left trace is the mirror image L(theta) = R(180 - theta) in
one frame of angles. Not read: formats
2-4 (binary and differential encodings, e.g. ``TRCFMT=4;512;E;R;F`` [vc-forum]) are
refused; ``ZFMT`` / ``Z`` / ``ZA`` (3-D traces) are skipped, the outline being the trace's
projection on the frame's plane; ``PANTO`` / ``ZTILT`` are kept in :attr:`Frame.records`,
not applied (the lens's tilt and wrap are the spec's). Where sources differ: one public
parser writes uneven traces with ``A`` in the third field, so ``U`` and ``A`` are both
read as uneven; a ``B`` trace serves both eyes (the left its mirror image).

Minimum blank size [mbs]: the smallest round blank that cuts out is twice the largest
distance from the fitting point to the outline, plus 2 mm for the bevel ("the distance
from the pupil centre to the widest point of the rim of the frame, then doubled ... add
the extra 2 mm"; computed from the tracing, as lab software does [ocuco]). The
classroom rule MBS = ED + total decentration + 2 mm (ED twice the largest radius from
the box centre) bounds it from above: sources differ on whether the decentration added
is per lens or both lenses' sum [mbs]; the sum (twice the per-lens one) is the bound.

Sources:
[dcs] The Vision Council, Data Communication Standard v3.08 (2010) and v3.12 (2018):
  https://cupdf.com/document/dcsv308final.html ,
  https://fdocuments.in/document/dcs-v312-final-fixed-refs-the-vision-council-d-kddhe-dke-d-e-z-x-.html
  (their titles and contents; the record facts here are from [lp-*] and [vc-forum]).
[lp-types] eeng/lens_protocol (a DCS parser), lib/lens_protocol/oma/types.rb.
[lp-trace] eeng/lens_protocol, lib/lens_protocol/oma/types/values/tracing_dataset.rb and
  lib/lens_protocol/oma/type/r.rb (format 1 radii as integers; angle i 2 pi / n).
[lp-example] eeng/lens_protocol, examples/oma/R360_1.oma (TRCFMT=1;360;E;R;F and L, R=
  records of ten radii).
[vc-forum] https://forums.thevisioncouncil.org/topic/5182-how-to-read-trace-information/
[tabo] ISO 8429:1986, https://123docz.net/document/13432353-tieu-chuan-iso-08429-1986-scan.htm
[boxing] https://www.slideshare.net/slideshow/boxing-system/107035333
[mbs] https://askinglot.com/what-is-minimum-blank-size ;
  https://optomcalc.shivan.xyz/minimum_blank_size/ (per-lens decentration);
  https://open-exam-prep.com/study-guides/national-opticianry/prism-lens-math-and-troubleshooting/minimum-blank-size-and-effective-diameter
  (total decentration).
[ocuco] R. Shanbaum, "How Big is Big Enough", Ocuco, 17 Feb 2020,
  https://www.ocuco.com/how-big-is-big-enough/
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from eyelab.core.checks import check_in
from eyelab.core.errors import SpecError

#: The frame's ranges, by spec field, in the spec's units (mm).
LIMITS = {"frame.box_mm": (10.0, 80.0), "frame.dbl_mm": (5.0, 30.0),
          "frame.fitting_height_mm": (0.0, 80.0)}
#: Built-in shapes (:func:`shape_outline`).
FRAME_SHAPES = ("round", "oval", "rectangle", "aviator")
#: Added to twice the largest fitting-point-to-outline distance for the blank (m) [mbs].
BLANK_MARGIN = 2.0e-3
#: Radii a DCS trace may have.
TRACE_COUNT = (8, 20000)
#: Vertices of a built-in shape's outline (equal angles about the box centre).
SHAPE_POINTS = 360
SIDES = ("right", "left")
_TWO_PI = 2.0 * math.pi


def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


def _floats(values) -> tuple:
    return tuple(float(v) for v in np.asarray(values, float).ravel())


@dataclass(frozen=True)
class Outline:
    """A closed polygon, star-shaped about ``centre`` (x, y) m: vertex k at centre +
    radii[k] (cos angles[k], sin angles[k]); angles (rad, tuple) strictly increasing over
    less than a turn, radii (m, tuple) > 0. Wearer's-view coordinates."""

    angles: tuple
    radii: tuple
    centre: tuple = (0.0, 0.0)

    @classmethod
    def from_points(cls, points, centre=(0.0, 0.0), what="the outline",
                    field: str = "frame") -> Outline:
        """The outline through ``points`` (n, 2+) (x, y) m in boundary order (either
        direction); refused (:class:`SpecError` naming ``field``) unless it winds once
        about ``centre`` with every vertex in view of it (each step of angle in (0, pi))."""
        p = np.asarray(points, float)[:, :2] - np.asarray(centre, float)
        a = np.unwrap(np.arctan2(p[:, 1], p[:, 0]))
        if a[-1] < a[0]:
            p, a = p[::-1], a[::-1]
        steps = np.append(np.diff(a), a[0] + _TWO_PI - a[-1])
        if not (len(a) >= 3 and np.all(steps > 0) and np.all(steps < math.pi)):
            raise SpecError(field, f"{what} does not wind once about its centre with "
                                   "every point in view of it")
        return cls(_floats(a), _floats(np.hypot(p[:, 0], p[:, 1])), _floats(centre))

    def vertices(self) -> np.ndarray:
        """(n, 2) m: the polygon's vertices, counter-clockwise."""
        a, r = np.asarray(self.angles), np.asarray(self.radii)
        return np.stack([self.centre[0] + r * np.cos(a), self.centre[1] + r * np.sin(a)], 1)

    def area(self) -> float:
        """Enclosed area (m^2), shoelace formula."""
        v = self.vertices()
        w = np.roll(v, -1, axis=0)
        return 0.5 * float(np.sum(_cross(v[:, 0], v[:, 1], w[:, 0], w[:, 1])))

    def box(self) -> tuple:
        """(x_min, x_max, y_min, y_max) m: the boxing rectangle."""
        v = self.vertices()
        return (float(v[:, 0].min()), float(v[:, 0].max()), float(v[:, 1].min()),
                float(v[:, 1].max()))

    def radius_at(self, phi) -> np.ndarray:
        """The polygon's radius (m) from ``centre`` along directions ``phi`` (rad, any
        shape): where the ray meets the edge between the vertices either side of it."""
        phi = np.asarray(phi, float)
        a = np.asarray(self.angles)
        r = np.asarray(self.radii)
        k = np.searchsorted(a - a[0], np.mod(phi - a[0], _TWO_PI), side="right") - 1
        k1 = (k + 1) % len(a)
        p0x, p0y = r[k] * np.cos(a[k]), r[k] * np.sin(a[k])
        p1x, p1y = r[k1] * np.cos(a[k1]), r[k1] * np.sin(a[k1])
        return _cross(p0x, p0y, p1x, p1y) / _cross(np.cos(phi), np.sin(phi), p1x - p0x,
                                                    p1y - p0y)

    def contains(self, x, y) -> np.ndarray:
        """(shape of x) bool: the points (x, y) m lie inside (or on) the outline."""
        dx = np.asarray(x, float) - self.centre[0]
        dy = np.asarray(y, float) - self.centre[1]
        return np.hypot(dx, dy) <= self.radius_at(np.arctan2(dy, dx))

    def shifted(self, dx: float, dy: float) -> Outline:
        return dataclasses.replace(self, centre=_floats((self.centre[0] + dx,
                                                          self.centre[1] + dy)))

    def scaled(self, factor: float) -> Outline:
        """The outline scaled by ``factor`` about its centre."""
        return dataclasses.replace(self, radii=_floats(np.asarray(self.radii) * factor))

    def mirrored(self) -> Outline:
        """The mirror image in the line x = 0 (a right eye's outline as the left's)."""
        v = self.vertices()
        return Outline.from_points(v[::-1] * np.array([-1.0, 1.0]),
                                   (-self.centre[0], self.centre[1]))

    def resampled(self, n: int, start: float = 0.0) -> Outline:
        """The outline through its points at ``n`` equal angles about its centre."""
        a = start + np.arange(n) * _TWO_PI / n
        return dataclasses.replace(self, angles=_floats(a), radii=_floats(self.radius_at(a)))

    def farthest_from(self, x: float = 0.0, y: float = 0.0) -> float:
        """The largest distance (m) from (x, y) to the outline (a polygon's is a vertex)."""
        v = self.vertices()
        return float(np.max(np.hypot(v[:, 0] - x, v[:, 1] - y)))

    def crossings(self, axis: int, at: float) -> tuple:
        """(lo, hi) m: the extent of the outline along the line x = ``at`` (``axis`` 0:
        its y extent) or y = ``at`` (``axis`` 1: its x extent); None if it misses."""
        v = self.vertices()
        w = np.roll(v, -1, axis=0)
        a, b = v[:, axis] - at, w[:, axis] - at
        hit = (a <= 0) != (b <= 0)
        if not hit.any():
            return None
        s = a[hit] / (a[hit] - b[hit])
        other = 1 - axis
        vals = v[hit, other] + s * (w[hit, other] - v[hit, other])
        return float(vals.min()), float(vals.max())


def box_centred(outline: Outline) -> Outline:
    """``outline`` moved so that its box's centre is the origin."""
    x0, x1, y0, y1 = outline.box()
    return outline.shifted(-0.5 * (x0 + x1), -0.5 * (y0 + y1))


# --------------------------------------------------------------- built-in shapes
def shape_outline(shape: str, a: float, b: float) -> Outline:
    """A built-in shape in an A x B box (m), box-centred, as a right eye's (nasal -x):
    "round" a circle (A = B), "oval" the ellipse, "rectangle" with corners of radius
    min(A, B) / 4, "aviator" a teardrop — in units of the half box, a flat-topped
    superellipse (exponent 4) above the centre line, below it the half ellipse sheared
    nasally by 0.35 v^2 (its lowest point 0.35 nasal, the sides joining smoothly), scaled
    to the box. :data:`SHAPE_POINTS` vertices at equal angles about the box centre."""
    t = np.linspace(0.0, _TWO_PI, 4096, endpoint=False)
    c, s = np.cos(t), np.sin(t)
    if shape in ("round", "oval"):
        u, v = c, s
    elif shape == "rectangle":
        u, v = _rounded_rectangle(a, b, min(a, b) / 4)
    elif shape == "aviator":
        top = s >= 0
        u = np.where(top, np.sign(c) * np.sqrt(np.abs(c)), c - 0.35 * s * s)
        v = np.where(top, np.sqrt(np.abs(s)), s)
    else:
        raise SpecError("frame.shape", f"must be one of {', '.join(map(repr, FRAME_SHAPES))}"
                                       f", got {shape!r}")
    u = (u - 0.5 * (u.max() + u.min())) / (u.max() - u.min()) * a
    v = (v - 0.5 * (v.max() + v.min())) / (v.max() - v.min()) * b
    dense = Outline.from_points(np.stack([u, v], 1), what=f"the {shape} shape")
    return dense.resampled(SHAPE_POINTS)


def _rounded_rectangle(a, b, rc, per_corner=256):
    """(u, v): the boundary of an a x b rectangle with corners of radius rc,
    counter-clockwise: four quarter circles (the straight sides join them)."""
    u, v = [], []
    for k, (sx, sy) in enumerate(((1, 1), (-1, 1), (-1, -1), (1, -1))):
        t = np.linspace(0.0, math.pi / 2, per_corner) + k * math.pi / 2
        u.append(sx * (a / 2 - rc) + rc * np.cos(t))
        v.append(sy * (b / 2 - rc) + rc * np.sin(t))
    return np.concatenate(u), np.concatenate(v)


# ------------------------------------------------------------------ DCS traces
def _records(text: str) -> list:
    """[(line number, label, [values])] of a DCS text (:func:`eyelab.optics.lens.dcs.
    parse_records`: framing characters stripped, lines split at line ends only)."""
    from eyelab.optics.lens.dcs import parse_records

    return [(r.line, r.label, [v.strip() for v in r.values])
            for r in parse_records(text, "frame.file", "the trace")]


def _number(value: str, line: int, what: str) -> float:
    """``value`` as a finite float written as DCS numbers are (:data:`eyelab.optics.lens.dcs.
    NUMBER`), or an error naming ``frame.file`` and the line (0: the record's label)."""
    from eyelab.optics.lens.dcs import NUMBER

    v = float(value) if NUMBER.fullmatch(value.strip()) else math.nan
    if not math.isfinite(v):
        where = f"line {line}: " if line else ""
        raise SpecError("frame.file", f"{where}{what} {value[:20]!r} is not a number")
    return v


def _trace_header(line: int, values: list) -> dict:
    """A TRCFMT record's fields, checked."""
    if len(values) < 4:
        raise SpecError("frame.file", f"line {line}: TRCFMT needs format;count;E|U;R|L|B"
                                      f"[;F|P|D], got {';'.join(values)!r}")
    fmt, count, mode, side = values[:4]
    if fmt != "1":
        raise SpecError("frame.file", f"line {line}: TRCFMT format {fmt!r}: only format 1 "
                                      "(ASCII radii) is read")
    if not count.isdigit() or not TRACE_COUNT[0] <= int(count) <= TRACE_COUNT[1]:
        raise SpecError("frame.file", f"line {line}: TRCFMT count {count!r}: must be an "
                                      f"integer in [{TRACE_COUNT[0]}, {TRACE_COUNT[1]}]")
    if mode.upper() not in ("E", "U", "A") or side.upper() not in ("R", "L", "B"):
        raise SpecError("frame.file", f"line {line}: TRCFMT {';'.join(values)!r}: the "
                                      "angles must be E (equal) or U (uneven, also A) and "
                                      "the eye R, L or B")
    return {"line": line, "count": int(count), "mode": mode.upper(), "side": side.upper(),
            "kind": values[4].upper() if len(values) > 4 else "F", "R": [], "A": []}


def _trace_outline(tr: dict) -> Outline:
    """The box-centred outline (wearer's view, m) of a parsed trace."""
    n = tr["count"]
    radii = np.array([_number(v, ln, "radius") for ln, v in tr["R"]]) * 1e-5
    if len(radii) != n:
        raise SpecError("frame.file", f"line {tr['line']}: TRCFMT says {n} radii, its R= "
                                      f"records hold {len(radii)}")
    if np.any(radii <= 0):
        raise SpecError("frame.file", f"line {tr['line']}: the trace has a radius <= 0")
    if tr["mode"] == "E":
        theta = np.arange(n) * _TWO_PI / n
    else:
        theta = np.radians([_number(v, ln, "angle") for ln, v in tr["A"]]) / 100.0
        if len(theta) != n or not (np.all(np.diff(theta) > 0) and theta[0] >= 0
                                   and theta[-1] < _TWO_PI):
            raise SpecError("frame.file", f"line {tr['line']}: an uneven trace needs {n} "
                                          "increasing A= angles in [0, 36000) (0.01 deg)")
    # counter-clockwise seen from the front -> the wearer's view: x = -r cos, y = r sin
    pts = np.stack([-radii * np.cos(theta), radii * np.sin(theta)], 1)
    return box_centred(Outline.from_points(pts, what=f"the trace of line {tr['line']}",
                                           field="frame.file"))


def read_dcs(text: str) -> tuple:
    """(outlines {side: box-centred Outline}, records {label: [values]}) of a DCS job's
    text: the traces of each eye ("B": both, the left mirrored; one eye's alone: the
    other's its mirror image) and every other record's first occurrence. Errors name
    ``frame.file`` and the line."""
    traces, records = [], {}
    for line, label, values in _records(text):
        if label == "TRCFMT":
            traces.append(_trace_header(line, values))
        elif label in ("R", "A"):
            if not traces:
                raise SpecError("frame.file", f"line {line}: {label}= before any TRCFMT "
                                              "record: no trace format")
            traces[-1][label] += [(line, v) for v in values if v != ""]
        elif label not in ("Z", "ZA", "ZFMT"):
            records.setdefault(label, values)
    if not traces:
        raise SpecError("frame.file", "no TRCFMT record: not a DCS frame trace (TRCFMT="
                                      "1;count;E;R;F then R=radii in 0.01 mm)")
    outlines = {}
    for tr in traces:
        sides = {"R": ("right",), "L": ("left",), "B": SIDES}[tr["side"]]
        if any(s in outlines for s in sides):
            raise SpecError("frame.file", f"line {tr['line']}: a second trace for the "
                                          f"{' and '.join(sides)} eye")
        o = _trace_outline(tr)
        for s in sides:
            outlines[s] = o if s == sides[0] else o.mirrored()
    for s, other in (("right", "left"), ("left", "right")):
        if s not in outlines:
            outlines[s] = outlines[other].mirrored()
    return outlines, records


#: A DCS file's box records (HBOX, VBOX) and its trace's own box may differ by this much
#: (mm) without a word: the trace's resolution (0.01 mm radii) and the box's rounding by
#: the tracer; beyond it the file contradicts itself.
BOX_RECORD_TOL_MM = 0.5


def box_record_notes(frame, records: dict) -> list:
    """Warnings, one line each, where a trace file's HBOX / VBOX records disagree with the
    box of its own radii by more than :data:`BOX_RECORD_TOL_MM` (the radii are used)."""
    notes = []
    for side in SIDES:
        have = [v * 1e3 for v in frame.box(side)]
        said = [record_value(records, label, side) for label in ("HBOX", "VBOX")]
        if all(s is None for s in said):
            continue
        off = [abs(h - s) for h, s in zip(have, said, strict=True) if s is not None]
        if max(off) > BOX_RECORD_TOL_MM:
            rec = " x ".join("?" if s is None else f"{s:.2f}" for s in said)
            notes.append(f"frame.file: the {side} trace's radii span a {have[0]:.2f} x "
                         f"{have[1]:.2f} mm box, its HBOX/VBOX records say {rec} mm: the "
                         "radii are used")
    return notes


def record_value(records: dict, label: str, side: str | None = None) -> float | None:
    """A numeric record's value (mm as written): ``side``'s of a right;left record (one
    value: both), or the first; None where absent or empty ("?")."""
    vals = records.get(label)
    if not vals:
        return None
    v = vals[0] if side != "left" or len(vals) < 2 else vals[1]
    if v in ("", "?"):
        return None
    return _number(v, 0, f"the {label} record's value")


# ----------------------------------------------------------------------- frame
@dataclass(frozen=True)
class Frame:
    """A frame: ``outlines`` {"right", "left"}: box-centred :class:`Outline` (m, wearer's
    view); ``dbl`` (m) the bridge; ``source`` where the shape came from; ``records`` the
    DCS file's other records (informational)."""

    outlines: dict
    dbl: float
    source: str = "shape"
    records: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        check_in("frame.dbl_mm", self.dbl * 1e3, LIMITS)
        for side in SIDES:
            for i, v in enumerate(self.box(side)):
                try:
                    # to the micrometre (a trace's resolution is 10 um): a built-in shape's
                    # outline spans its box to rounding (an oval's 80 mm is 80.00000000000001)
                    check_in(f"frame.box_mm[{i}]", round(v * 1e3, 3), LIMITS)
                except SpecError as e:
                    if self.source == "shape":
                        raise
                    raise SpecError("frame.file", f"the {side} trace's box "
                                    f"{'AB'[i]} {e.message}") from None

    def box(self, side: str) -> tuple:
        """(A, B) m of ``side``'s outline."""
        x0, x1, y0, y1 = self.outlines[side].box()
        return x1 - x0, y1 - y0

    def placed(self, side: str, monocular_pd: float, fitting_height: float) -> Outline:
        """``side``'s outline relative to its pupil centre (m): the pupil ``monocular_pd``
        from the bridge's centre line and ``fitting_height`` above the box's lower edge."""
        check_in("frame.fitting_height_mm", fitting_height * 1e3, LIMITS)
        a, b = self.box(side)
        temporal = 1.0 if side == "right" else -1.0
        return self.outlines[side].shifted(temporal * (self.dbl / 2 + a / 2 - monocular_pd),
                                           b / 2 - fitting_height)


def minimum_blank_size(outline: Outline, x: float = 0.0, y: float = 0.0) -> float:
    """The smallest round blank (diameter, m) that cuts ``outline`` out with its fitting
    point at (x, y) (same frame): 2 x the largest distance from it + :data:`BLANK_MARGIN`
    [mbs]."""
    return 2.0 * outline.farthest_from(x, y) + BLANK_MARGIN


def cut_lens(lens, placed: Outline, fit: dict):
    """``lens`` cut to the frame: its :attr:`~eyelab.optics.lens.spectacle.SpectacleLens.outline`
    is ``placed`` (:meth:`Frame.placed`: relative to the pupil) moved into the lens frame
    (minus the pose's decentration; the trace lies in the lens's plane). ``fit``: the
    side, ``pd`` and ``height`` (m) that placed it and the spec fields to blame
    (``pd_field``, ``height_field``, ``blank_field``). Refused: a blank smaller than the
    minimum blank size; a frame that does not cover the pupil (the straight-ahead line of
    sight misses the cut lens); a progressive whose near reference point is cut away."""
    from eyelab.optics.lens.spectacle import LIMITS as LENS_LIMITS
    from eyelab.optics.rays.trace import FATAL

    if not bool(placed.contains(0.0, 0.0)):
        raise _uncovered(placed, fit)
    dx, dy = lens.pose.decentration
    outline = placed.shifted(-dx, -dy)
    need = minimum_blank_size(outline)
    if need > lens.diameter + 1e-9:
        raise SpecError(fit["blank_field"], f"a {lens.diameter * 1e3:g} mm blank is too "
                        f"small for the frame: the minimum blank size is 2 x "
                        f"{outline.farthest_from() * 1e3:.1f} mm (the outline's farthest "
                        f"point from the fitting point) + {BLANK_MARGIN * 1e3:g} mm = "
                        f"{need * 1e3:.1f} mm; the blank must be >= {need * 1e3:.1f} mm "
                        f"(lens.diameter_mm at most "
                        f"{LENS_LIMITS['lens.diameter_mm'][1]:g})")
    cut = dataclasses.replace(lens, outline=outline)
    res = cut.trace(np.zeros((1, 3)), np.array([[0.0, 0.0, -1.0]]), reverse=True)
    if res["status"][0] & np.uint8(FATAL):
        raise SpecError(fit["height_field"], "the frame does not cover the pupil: the "
                        "straight-ahead line of sight misses the cut lens (it leaves "
                        "through the edge)")
    near = getattr(lens.design, "near_point", None)
    if near is not None and not bool(outline.contains(*near)):
        span = outline.crossings(0, near[0])
        lo = (span[0] - near[1]) * 1e3 if span else math.nan
        raise SpecError(fit["height_field"], f"the progressive's near reference point "
                        f"({near[1] * 1e3:+.1f} mm below, {abs(near[0]) * 1e3:.1f} mm nasal "
                        f"of the fitting cross) is cut away: the frame's lower edge there "
                        f"is {lo:.1f} mm too high; raise the fitting height by that much or "
                        "shorten lens.corridor_mm")
    return cut


def _uncovered(placed: Outline, fit: dict) -> SpecError:
    """The error for an outline (relative to the pupil) that does not hold the pupil:
    the fitting height or monocular PD range that would (at the other's value)."""
    pd, h = fit["pd"] * 1e3, fit["height"] * 1e3
    across, up = placed.crossings(1, 0.0), placed.crossings(0, 0.0)
    head = "the frame does not cover the pupil (the straight-ahead line of sight misses " \
           "the lens): "
    if across is not None:
        lo, hi = (v * 1e3 for v in across)
        lo, hi = (pd + lo, pd + hi) if fit["side"] == "right" else (pd - hi, pd - lo)
        return SpecError(fit["pd_field"], f"{head}at this fitting height the frame spans "
                         f"monocular PDs {lo:.1f}-{hi:.1f} mm, got {pd:g}")
    if up is not None:
        lo, hi = (h + v * 1e3 for v in up)
        return SpecError(fit["height_field"], f"{head}at this PD the frame spans "
                         f"{lo:.1f}-{hi:.1f} mm above the box's lower edge, got {h:g}")
    return SpecError(fit["height_field"], f"{head}the pupil is outside the frame's box at "
                     f"PD {pd:g} mm, fitting height {h:g} mm")
