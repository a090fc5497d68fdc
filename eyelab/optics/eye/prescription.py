"""Clinical spectacle prescriptions (Rx): parsing, formatting, transposition, power vectors.

Conventions (see docs/SCIENCE.md §1):

* ``S / C x A`` with ``Add``; powers in dioptres (D), the cylinder axis in degrees in the
  TABO / ISO 8429 convention (examiner's view, counter-clockwise, 0 deg written as 180).
* Power vector (Thibos 1997): ``M = S + C/2``, ``J0 = -(C/2) cos 2A``, ``J45 = -(C/2) sin 2A``.
* The wearer's frame used everywhere else in eyelab has x to the wearer's right and y up,
  seen from behind the wearer. An axis ``A`` (TABO) is ``180 - A`` there, and ``J45``
  changes sign; ``J0`` and ``M`` do not.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from eyelab.core.errors import SpecError

SPHERE_RANGE = (-30.0, 30.0)
CYLINDER_RANGE = (-12.0, 12.0)
ADD_RANGE = (0.0, 4.0)

#: Tokens of the clinical grammar, tried in this order at each position (a scanner: linear
#: time whatever the input). Numbers may carry a sign separated by spaces ("Pl + 2.00").
_TOKEN = re.compile(r"""
    (?P<ws>\s+)
  | (?P<num>[+-]?[ ]*(?:\d+(?:\.\d*)?|\.\d+))
  | (?P<kw>ADD:?|AXIS|AX|PLANO|PLAN|PL|SPH|CYL|D\.S\.?|DS\.?|D\.C\.?|DC\.?|D
          |OU|OD|OS|RE|LE|R|L|X|×|@|/|,|:|°|∞)
""", re.IGNORECASE | re.VERBOSE)
_EYES = {"R": "R", "OD": "R", "RE": "R", "L": "L", "OS": "L", "LE": "L", "OU": "OU"}
_SPH_UNITS = {"DS", "D.S", "D.S.", "DS.", "SPH"}
_CYL_UNITS = {"DC", "D.C", "D.C.", "DC.", "CYL"}
_AXIS_MARKS = {"X", "×", "@", "AX", "AXIS"}
_PLANO = {"PL", "PLAN", "PLANO", "∞"}

_ALLOWED = ("allowed: [R|L|OD|OS|OU] sphere [cylinder x axis] [add A], e.g. "
            "'-2.25 / -1.00 x 010', '+1.50 DS', '-0.25 DC x 45' (a cylinder alone), "
            "'pl -0.75 x 90 add +2.00', 'R -1,00 -0,50 x 180'; sphere in [-30, 30] D, "
            "cylinder in [-12, 12] D, axis in [0, 180] deg (0 = 180), add in [0, 4] D")


def _tokens(text: str, field: str) -> list:
    """[(kind, text)] of a prescription string: numbers ('num') and keywords ('kw', upper
    case); whitespace dropped. Unicode minus and plus signs and decimal commas are
    normalised first."""
    t = (text.replace("\u2212", "-").replace("\u2013", "-").replace("\uff0b", "+")
         .replace("\uff0d", "-"))
    t = re.sub(r"(?<=\d),(?=\d)", ".", t)
    out, pos = [], 0
    while pos < len(t):
        m = _TOKEN.match(t, pos)
        if m is None:
            raise SpecError(field, f"cannot read {t[pos:pos + 12]!r} in prescription "
                                   f"{text!r}; {_ALLOWED}")
        pos = m.end()
        if m.lastgroup == "num":
            out.append(("num", m.group("num").replace(" ", "")))
        elif m.lastgroup == "kw":
            out.append(("kw", m.group("kw").upper()))
    return out


#: A unit keyword after a number -> that power's unit.
_UNITS = {**dict.fromkeys(_SPH_UNITS, "sph"), **dict.fromkeys(_CYL_UNITS, "cyl"), "D": "D"}


def _take_eye(toks, err):
    """The eye named by the first and/or the last token (those tokens removed from
    ``toks``), or None; two different eyes are an error."""
    eye = None
    if toks and toks[0][0] == "kw" and toks[0][1] in _EYES:
        eye = _EYES[toks.pop(0)[1]]
    if toks and toks[-1][0] == "kw" and toks[-1][1] in _EYES:
        last = _EYES[toks.pop()[1]]
        if eye is not None and eye != last:
            raise err(f"two eyes ({eye}, {last})")
        eye = last
    return eye


class _TermReader:
    """Reads the powers, the axis and the add of a token list (eyes removed) left to right:
    each term's reader takes the index of its first token and returns the index after it."""

    def __init__(self, toks, err):
        self.toks, self.err = toks, err
        self.powers, self.axis, self.add = [], None, None

    def read(self):
        """([(value, unit)] powers, axis or None, add or None)."""
        i = 0
        while i < len(self.toks):
            kind, v = self.toks[i]
            reader = self._reader(kind, v)
            if reader is None:
                raise self.err(f"unexpected {v!r}")
            i = reader(i)
        return self.powers, self.axis, self.add

    def _reader(self, kind, v):
        """The method reading a term that starts with token (kind, v), or None."""
        if kind == "num":
            return self._power
        if kind != "kw":
            return None
        if v in _PLANO:
            return self._plano
        if v in _AXIS_MARKS:
            return self._axis
        if v.startswith("ADD"):
            return self._add
        return None

    def _plano(self, i):
        """'pl'/'plano', optionally 'DS'/'D': a zero sphere."""
        self.powers.append((0.0, "sph"))
        i += 1
        if i < len(self.toks) and self.toks[i] in (("kw", u) for u in _SPH_UNITS | {"D"}):
            i += 1
        return i

    def _power(self, i):
        """A number, with its unit ('sph', 'cyl', 'D') when a unit keyword follows."""
        unit = None
        if i + 1 < len(self.toks) and self.toks[i + 1][0] == "kw":
            unit = _UNITS.get(self.toks[i + 1][1])
        self.powers.append((float(self.toks[i][1]), unit))
        return i + 2 if unit else i + 1

    def _axis(self, i):
        """An axis mark and an unsigned number of degrees."""
        v = self.toks[i][1]
        if self.axis is not None:
            raise self.err("two axes")
        if i + 1 >= len(self.toks) or self.toks[i + 1][0] != "num" \
                or self.toks[i + 1][1][0] in "+-":
            raise self.err(f"'{v}' not followed by an axis in degrees")
        self.axis = float(self.toks[i + 1][1])
        return i + 2

    def _add(self, i):
        """'add' and a power, optionally 'D'."""
        if self.add is not None:
            raise self.err("two adds")
        if i + 1 >= len(self.toks) or self.toks[i + 1][0] != "num":
            raise self.err("'add' not followed by a power")
        self.add = float(self.toks[i + 1][1])
        i += 2
        if i < len(self.toks) and self.toks[i] == ("kw", "D"):
            i += 1
        return i


#: Separators: read as spaces once each stands where it may (:func:`_check_separators`).
_SEPARATORS = ("/", ",", ":", "°")


def _is_one_power(toks) -> bool:
    """Whether tokens (separators dropped) are one power: a number or plano, with or
    without its sphere unit."""
    if not toks or not (toks[0][0] == "num" or toks[0][1] in _PLANO):
        return False
    return len(toks) == 1 or (len(toks) == 2 and toks[1][1] in _SPH_UNITS | {"D"})


def _misplaced(tokens, i) -> bool:
    """Whether the separator at ``tokens[i]`` stands where none may: first, last (but a
    degree sign), beside another separator, a '/' anywhere but between the sphere and the
    cylinder, a '°' anywhere but after the axis."""
    v = tokens[i][1]
    if i == 0 or tokens[i - 1][1] in _SEPARATORS:
        return True
    if v == "°":
        return not (tokens[i - 1][0] == "num" and i >= 2 and tokens[i - 2][1] in _AXIS_MARKS)
    if i == len(tokens) - 1 or tokens[i + 1][1] in _SEPARATORS:
        return True
    if v == "/":
        head = [t for t in tokens[:i] if t[1] not in _SEPARATORS]
        head = head[1:] if head and head[0][1] in _EYES else head
        return not (_is_one_power(head) and tokens[i + 1][0] == "num")
    return False


def _check_separators(tokens, err) -> None:
    """Each separator where it may stand (:func:`_misplaced`): ``-3.00 / / -1.00 x 90``
    is refused, not read as ``-3.00 / -1.00 x 90``."""
    for i, (_, v) in enumerate(tokens):
        if v in _SEPARATORS and _misplaced(tokens, i):
            raise err(f"a misplaced {v!r} (a '/' stands only between the sphere and the "
                      "cylinder, a '°' after the axis, one separator at a time)")


def _parse_terms(tokens, text, field):
    """(eye, [(value, unit)] powers, axis, add, err) from tokens, per the grammar in
    :meth:`Prescription.parse`; ``err(why)`` makes the error quoting ``text``."""
    def err(why):
        return SpecError(field, f"{why} in prescription {text!r}; {_ALLOWED}")

    _check_separators(tokens, err)
    toks = [t for t in tokens if t[1] not in _SEPARATORS]
    eye = _take_eye(toks, err)
    powers, axis, add = _TermReader(toks, err).read()
    return eye, powers, axis, add, err


def tabo_axis(wearer_deg):
    """Axis directions in the wearer's view (deg, counter-clockwise from the wearer's right
    seen from behind) as TABO axes (the examiner's view), in (0, 180]: 180 - A, 0 -> 180.
    Scalar or array."""
    a = (180.0 - np.asarray(wearer_deg, float)) % 180.0
    a = np.where(a == 0.0, 180.0, a)
    return float(a) if a.ndim == 0 else a


#: Decimals a report gives a power row in: 0.001 D (sphere, cylinder, mean) and 0.1 deg
#: (axis) — finer than any prescription is written or a lensmeter reads (0.01 D, 1 deg).
POWER_DECIMALS, AXIS_DECIMALS = 3, 1


def power_row(sphere_d: float, cylinder_d: float, axis_tabo_deg: float, mean_d: float) -> dict:
    """A sphere / cylinder x axis (TABO) and mean as a report writes them: rounded to
    :data:`POWER_DECIMALS` / :data:`AXIS_DECIMALS` (no float noise: 8.9e-16 D is 0), the
    axis None where the cylinder rounds to zero (it has no axis); NaN (no light path)
    stays NaN, written as null."""
    def d(v):
        return float(v) if not math.isfinite(v) else round(float(v), POWER_DECIMALS) + 0.0

    cyl = d(cylinder_d)
    axis = None if cyl == 0 or not math.isfinite(axis_tabo_deg) else \
        round(float(axis_tabo_deg), AXIS_DECIMALS) or 180.0
    return {"sphere_d": d(sphere_d), "cylinder_d": cyl, "axis_tabo_deg": axis,
            "mean_d": d(mean_d)}


@dataclass(frozen=True)
class Prescription:
    """A spectacle prescription.

    :meth:`parse` reads a prescription as a clinician writes it, :meth:`format` writes
    it back; ``eye.rx`` and ``lens.rx`` in a spec take the same text.

    Parameters
    ----------
    sphere, cylinder : float
        Dioptres. Either cylinder sign is accepted (minus- or plus-cylinder form).
    axis : float
        Cylinder axis, degrees, TABO, in (0, 180]; 0 is stored as 180, and so is any axis
        of a zero cylinder.
    add : float
        Near addition, dioptres, >= 0.
    eye : None, "R", "L" or "OU"
        Which eye the prescription is for, when the text said so (metadata).

    Examples
    --------
    >>> import eyelab
    >>> rx = eyelab.Prescription.parse("-2.50 -0.75 x 90")
    >>> rx
    Prescription(sphere=-2.5, cylinder=-0.75, axis=90, add=0, eye=None)
    >>> rx.format(), rx.format(plus_cylinder=True)
    ('-2.50 / -0.75 x 090', '-3.25 / +0.75 x 180')
    >>> eyelab.Prescription(sphere=1.0, add=2.0).format()
    '+1.00 DS add +2.00'
    """

    sphere: float = 0.0
    cylinder: float = 0.0
    axis: float = 180.0
    add: float = 0.0
    eye: str | None = None

    def __post_init__(self):
        from eyelab.core.checks import check_range

        object.__setattr__(self, "sphere", check_range("rx.sphere", self.sphere, *SPHERE_RANGE))
        object.__setattr__(self, "cylinder",
                           check_range("rx.cylinder", self.cylinder, *CYLINDER_RANGE))
        ax = check_range("rx.axis", self.axis, 0.0, 180.0)
        # 0 is written 180; without a cylinder an axis means nothing and is stored as 180
        object.__setattr__(self, "axis", 180.0 if ax == 0.0 or self.cylinder == 0 else ax)
        object.__setattr__(self, "add", check_range("rx.add", self.add, *ADD_RANGE))
        if self.eye not in (None, "R", "L", "OU"):
            raise SpecError("rx.eye", f"must be None, 'R', 'L' or 'OU', got {self.eye!r}")

    # ------------------------------------------------------------------ parsing
    @classmethod
    def parse(cls, text: str, *, field: str = "rx") -> Prescription:
        """Parse a clinical prescription string, in linear time.

        Grammar: ``[eye] sphere [cylinder axis] [add] [eye]`` where the sphere is a number
        (``+1.50``, ``-3.00D``, ``-2.25 DS``, ``D.S.``, ``sph``) or ``pl``/``plano``; the
        cylinder a number, optionally ``DC``/``D.C.``/``cyl``; the axis ``x``, ``×``,
        ``@``, ``ax`` or ``axis`` and 0-180 degrees (``°`` allowed; 0 means 180); the add
        ``add``/``Add:``/``ADD`` and a power (``D`` allowed); the eye ``R``/``L``/``OD``/
        ``OS``/``OU`` (kept in :attr:`eye`). One power with an axis is a cylinder alone
        (plano sphere: ``-0.25 DC x 45``). Decimal commas, Unicode minus and plus signs,
        and a ``/`` between sphere and cylinder are accepted. Anything else — a cylinder
        without axis, a sphere with one, three powers, two axes — is an error that quotes
        the input; nothing is guessed.

        >>> Prescription.parse("-2.25 -1.00 x 180")
        Prescription(sphere=-2.25, cylinder=-1, axis=180, add=0, eye=None)
        >>> Prescription.parse("-0.25 DC x 45").format()
        'plano / -0.25 x 045'
        >>> Prescription.parse("R -1,00 -0,50 x 180 Add: +2.50").format()
        'R -1.00 / -0.50 x 180 add +2.50'
        """
        if not isinstance(text, str):
            raise SpecError(field, f"expected a prescription string, got {text!r}; {_ALLOWED}")
        if len(text) > 200:
            raise SpecError(field, f"a prescription of {len(text)} characters; at most 200")
        eye, powers, axis, add, err = _parse_terms(_tokens(text, field), text, field)
        if not powers:
            raise err("no power")
        if len(powers) > 2:
            raise err(f"{len(powers)} powers (a sphere and a cylinder at most)")
        if len(powers) == 1:
            (value, unit), = powers
            if axis is not None:       # a cylinder alone: plano sphere (clinical usage)
                if unit == "sph":
                    raise err("a sphere (DS) with an axis")
                sph, cyl = 0.0, value
            else:
                if unit == "cyl":
                    raise err("a cylinder without an axis")
                sph, cyl = value, 0.0
        else:
            (sph, u1), (cyl, u2) = powers
            if u1 == "cyl" or u2 == "sph":
                raise err("the sphere must come before the cylinder")
            if axis is None:
                raise err("a cylinder without an axis")
        try:
            return cls(sph, cyl, 180.0 if axis is None else axis,
                       0.0 if add is None else add, eye)
        except SpecError as e:
            raise SpecError(field + e.field[2:], f"{e.message} (in prescription {text!r})") \
                from None

    def __repr__(self) -> str:
        from eyelab.core.reprs import spec_repr

        return spec_repr("Prescription", {"sphere": self.sphere, "cylinder": self.cylinder,
                                          "axis": self.axis, "add": self.add,
                                          "eye": self.eye})

    def format(self, *, plus_cylinder: bool | None = None) -> str:
        """Clinical string, e.g. ``'-2.25 / -1.00 x 010'`` (axis in three digits);
        ``plus_cylinder`` transposes first.

        >>> Prescription(-2.25, -1.0, 180).format(plus_cylinder=True)
        '-3.25 / +1.00 x 090'
        """
        rx = self
        if plus_cylinder is not None and self.cylinder != 0:
            if (self.cylinder > 0) != plus_cylinder:
                rx = self.transpose()
        sph = "plano" if rx.sphere == 0 else f"{rx.sphere:+.2f}"
        ax = f"{rx.axis:03.0f}" if float(rx.axis).is_integer() else f"{rx.axis:g}"
        s = f"{sph} DS" if rx.cylinder == 0 else f"{sph} / {rx.cylinder:+.2f} x {ax}"
        if rx.add:
            s += f" add {rx.add:+.2f}"
        return s if rx.eye is None else f"{rx.eye} {s}"

    __str__ = format

    # ------------------------------------------------------------ transposition
    def distance(self) -> Prescription:
        """The distance part alone (the add dropped)."""
        return Prescription(self.sphere, self.cylinder, self.axis, 0.0, self.eye)

    def near(self) -> Prescription:
        """The near prescription: the add on the sphere (single-vision reading lenses)."""
        return Prescription(self.sphere + self.add, self.cylinder, self.axis, 0.0, self.eye)

    def transpose(self) -> Prescription:
        """The same correction in the other cylinder form: S+C / -C x A+-90 (in (0, 180])."""
        ax = (self.axis + 90.0) % 180.0
        return Prescription(self.sphere + self.cylinder, -self.cylinder, ax or 180.0, self.add,
                            self.eye)

    def minus_cylinder(self) -> Prescription:
        return self.transpose() if self.cylinder > 0 else self

    def plus_cylinder(self) -> Prescription:
        return self.transpose() if self.cylinder < 0 else self

    # ------------------------------------------------------------ power vectors
    def power_vector(self) -> tuple[float, float, float]:
        """(M, J0, J45) in dioptres (Thibos 1997), TABO frame."""
        a = math.radians(self.axis)
        return (self.sphere + self.cylinder / 2,
                -self.cylinder / 2 * math.cos(2 * a),
                -self.cylinder / 2 * math.sin(2 * a))

    @classmethod
    def from_power_vector(cls, m: float, j0: float, j45: float, add: float = 0.0) -> Prescription:
        """Minus-cylinder prescription from (M, J0, J45); exact inverse of :meth:`power_vector`."""
        j = math.hypot(j0, j45)
        axis = math.degrees(0.5 * math.atan2(j45, j0)) % 180.0
        if j == 0.0:
            axis = 180.0
        return cls(m + j, -2 * j, axis or 180.0, add)

    def meridian_power(self, theta_deg):
        """Power (D) in meridian ``theta_deg`` (TABO): S + C sin^2(theta - A) (sine-squared law)."""
        t = np.radians(np.asarray(theta_deg, float) - self.axis)
        return self.sphere + self.cylinder * np.sin(t) ** 2

    @property
    def axis_wearer_deg(self) -> float:
        """Cylinder axis in the wearer's frame (x right, y up, seen from behind), 180 - A
        (modulo 180)."""
        return (180.0 - self.axis) % 180.0

    def power_matrix(self, add: float = 0.0) -> np.ndarray:
        """(2, 2) dioptric power matrix in the wearer's frame: F = S I + C m m^T.

        ``m`` is the unit vector perpendicular to the cylinder axis; t^T F t is the power
        along direction t. Equals [[M+J0, J45w], [J45w, M-J0]] with J45w = -J45.
        """
        aw = math.radians(self.axis_wearer_deg)
        m = np.array([-math.sin(aw), math.cos(aw)])
        return (self.sphere + add) * np.eye(2) + self.cylinder * np.outer(m, m)

    def principal_meridians(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """((power_1, axis_direction_wearer_rad), (power_2, perpendicular_rad)).

        Power ``S`` acts along the cylinder-axis direction, ``S + C`` perpendicular to it.
        """
        aw = math.radians(self.axis_wearer_deg)
        return (self.sphere, aw), (self.sphere + self.cylinder, aw + math.pi / 2)


def vertex_effective_power(power, distance_m):
    """Effective power after moving a lens by ``distance_m`` toward the eye: F / (1 - d F).

    Apply per principal meridian. ``distance_m`` > 0 toward the eye (docs/SCIENCE.md §2).

    >>> round(float(vertex_effective_power(-6.0, 0.012)), 4)
    -5.597
    """
    power = np.asarray(power, float)
    return power / (1.0 - distance_m * power)
