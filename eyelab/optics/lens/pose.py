"""Where a spectacle lens sits in front of the eye (:class:`LensPose`: vertex distance,
pantoscopic tilt, wrap, decentration) and the lens's ranges by spec field (:data:`LIMITS`),
which :mod:`eyelab.optics.lens.spectacle` and the spec's schema read."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eyelab.core.checks import check_in

#: The lens's ranges, by spec field, in the spec's units (mm, deg, D): what the engine
#: accepts, and what the spec's schema documents and checks.
LIMITS = {"lens.vertex_distance_mm": (5.0, 30.0), "lens.pantoscopic_tilt_deg": (-30.0, 30.0),
          "lens.wrap_deg": (-30.0, 30.0), "lens.decentration_mm": (-20.0, 20.0),
          "lens.center_thickness_mm": (0.2, 30.0), "lens.diameter_mm": (10.0, 90.0),
          "lens.base_curve_d": (-20.0, 30.0)}


@dataclass(frozen=True)
class LensPose:
    """Where the lens sits in front of the eye.

    The repr shows the ``[lens]`` spec keys (mm, degrees; :meth:`spec_keys`).

    Parameters
    ----------
    vertex_distance : float
        m, back vertex to corneal vertex, in [0.005, 0.03].
    pantoscopic_tilt_deg : float
        Degrees, in [-30, 30].
    wrap_deg : float
        Degrees, in [-30, 30].
    decentration : (x, y)
        m, optical centre relative to the pupil centre, each at most 0.02 from it.

    Examples
    --------
    >>> import eyelab
    >>> eyelab.LensPose(vertex_distance=0.014, pantoscopic_tilt_deg=8.0)
    LensPose(vertex_distance_mm=14, pantoscopic_tilt_deg=8, wrap_deg=0, decentration_mm=(0, 0))
    >>> eyelab.LensPose(vertex_distance=0.05)
    Traceback (most recent call last):
    ...
    eyelab.core.errors.SpecError: lens.vertex_distance_mm: must be in [5, 30], got 50.0
    """

    vertex_distance: float = 0.012
    pantoscopic_tilt_deg: float = 0.0
    wrap_deg: float = 0.0
    decentration: tuple = (0.0, 0.0)

    def spec_keys(self) -> dict:
        """The ``[lens]`` pose keys that place the lens so, in the spec's units (mm, deg)."""
        return {"vertex_distance_mm": self.vertex_distance * 1e3,
                "pantoscopic_tilt_deg": self.pantoscopic_tilt_deg, "wrap_deg": self.wrap_deg,
                "decentration_mm": tuple(v * 1e3 for v in self.decentration)}

    def __repr__(self) -> str:
        from eyelab.core.reprs import spec_repr

        return spec_repr("LensPose", self.spec_keys())

    def __post_init__(self):
        check_in("lens.vertex_distance_mm", self.vertex_distance * 1e3, LIMITS)
        check_in("lens.pantoscopic_tilt_deg", self.pantoscopic_tilt_deg, LIMITS)
        check_in("lens.wrap_deg", self.wrap_deg, LIMITS)
        for i, v in enumerate(self.decentration):
            check_in(f"lens.decentration_mm[{i}]", v * 1e3, LIMITS)

    @property
    def rotation(self) -> np.ndarray:
        a = -math.radians(self.pantoscopic_tilt_deg)
        b = -math.radians(self.wrap_deg)
        rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
        ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
        return ry @ rx

    @property
    def translation(self) -> np.ndarray:
        return np.array([self.decentration[0], self.decentration[1], -self.vertex_distance])
