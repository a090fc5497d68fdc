"""Clinical spectacle prescriptions (Rx): parsing, formatting, transposition, power vectors.

Conventions (see ``shared/docs/SCIENCE.md`` §1):

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

from eyelab.errors import SpecError

SPHERE_RANGE = (-30.0, 30.0)
CYLINDER_RANGE = (-12.0, 12.0)
ADD_RANGE = (0.0, 4.0)

_NUM = r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)"
_RX_RE = re.compile(
    rf"""^\s*
    (?P<sph>{_NUM}|pl(?:ano)?|plan|∞)\s*(?:D?S(?:PH)?\b)?\s*
    (?:/?\s*(?P<cyl>{_NUM})\s*(?:D?C(?:YL)?\b)?\s*
       (?:[x×X@]|AX(?:IS)?)\s*(?P<axis>\d+(?:\.\d*)?)\s*°?)?\s*
    (?:,?\s*ADD\s*(?P<add>{_NUM}))?\s*$""",
    re.IGNORECASE | re.VERBOSE,
)

_ALLOWED = ("allowed forms: '-2.25 -1.00 x 180', '+1.50 DS', 'pl -0.75 x 90 add +2.00', "
            "'+1.00 / -0.50 x 45'; sphere in [-30, 30] D, cylinder in [-12, 12] D, "
            "axis in [0, 180] deg, add in [0, 4] D")


@dataclass(frozen=True)
class Prescription:
    """A spectacle prescription.

    Parameters
    ----------
    sphere, cylinder : float
        Dioptres. Either cylinder sign is accepted (minus- or plus-cylinder form).
    axis : float
        Cylinder axis, degrees, TABO, in (0, 180]; 0 is stored as 180.
    add : float
        Near addition, dioptres, >= 0.
    """

    sphere: float = 0.0
    cylinder: float = 0.0
    axis: float = 180.0
    add: float = 0.0

    def __post_init__(self):
        from eyelab.errors import check_range

        object.__setattr__(self, "sphere", check_range("rx.sphere", self.sphere, *SPHERE_RANGE))
        object.__setattr__(self, "cylinder",
                           check_range("rx.cylinder", self.cylinder, *CYLINDER_RANGE))
        ax = check_range("rx.axis", self.axis, 0.0, 180.0)
        object.__setattr__(self, "axis", 180.0 if ax == 0.0 else ax)
        object.__setattr__(self, "add", check_range("rx.add", self.add, *ADD_RANGE))

    # ------------------------------------------------------------------ parsing
    @classmethod
    def parse(cls, text: str, *, field: str = "rx") -> Prescription:
        """Parse a clinical prescription string.

        >>> Prescription.parse("-2.25 -1.00 x 180")
        Prescription(sphere=-2.25, cylinder=-1.0, axis=180.0, add=0.0)
        >>> Prescription.parse("pl -0.75 x 90 add +2.00").add
        2.0
        """
        if not isinstance(text, str):
            raise SpecError(field, f"expected a prescription string, got {text!r}; {_ALLOWED}")
        m = _RX_RE.match(text.replace("−", "-"))
        if m is None:
            raise SpecError(field, f"cannot parse prescription {text!r}; {_ALLOWED}")
        sph_s = m.group("sph")
        sph = 0.0 if sph_s.lower().startswith("pl") or sph_s == "∞" else float(sph_s)
        cyl = float(m.group("cyl")) if m.group("cyl") else 0.0
        axis = float(m.group("axis")) if m.group("axis") else 180.0
        add = float(m.group("add")) if m.group("add") else 0.0
        try:
            return cls(sph, cyl, axis, add)
        except SpecError as e:
            raise SpecError(field + e.field[2:], f"{e.message} (in prescription {text!r})") \
                from None

    def format(self, *, plus_cylinder: bool | None = None) -> str:
        """Clinical string, e.g. ``'-2.25 / -1.00 x 180'``; ``plus_cylinder`` transposes first.

        >>> Prescription(-2.25, -1.0, 180).format(plus_cylinder=True)
        '-3.25 / +1.00 x 90'
        """
        rx = self
        if plus_cylinder is not None and self.cylinder != 0:
            if (self.cylinder > 0) != plus_cylinder:
                rx = self.transpose()
        sph = "plano" if rx.sphere == 0 else f"{rx.sphere:+.2f}"
        s = f"{sph} DS" if rx.cylinder == 0 else f"{sph} / {rx.cylinder:+.2f} x {rx.axis:g}"
        if rx.add:
            s += f" add {rx.add:+.2f}"
        return s

    __str__ = format

    # ------------------------------------------------------------ transposition
    def transpose(self) -> Prescription:
        """The same correction in the other cylinder form: S+C / -C x A+-90 (in (0, 180])."""
        ax = (self.axis + 90.0) % 180.0
        return Prescription(self.sphere + self.cylinder, -self.cylinder, ax or 180.0, self.add)

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
        """Cylinder axis in the wearer's frame (x right, y up, seen from behind): 180 - A."""
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

    Apply per principal meridian. ``distance_m`` > 0 toward the eye (SCIENCE §2).

    >>> round(float(vertex_effective_power(-6.0, 0.012)), 4)
    -5.597
    """
    power = np.asarray(power, float)
    return power / (1.0 - distance_m * power)
