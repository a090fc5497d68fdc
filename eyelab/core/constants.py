"""Numerical tolerances, gathered in one place, each with the reason for its value.

Lengths are metres, powers dioptres (1/m), angles radians unless a name says otherwise.
"""

import math
from dataclasses import dataclass

#: Radians to minutes of arc.
RAD_TO_ARCMIN = 180.0 * 60.0 / math.pi


@dataclass(frozen=True)
class Tolerances:
    #: Smallest |1 - d*kappa| (per principal meridian) allowed in a wavefront transfer
    #: (Kakimoto Eq. 1). Below it the wave passes through a focal line: the curvature is
    #: clamped to 1/(d*eps) and the ray is flagged FOCAL. 1e-9 keeps curvatures below
    #: ~1e12 1/m for millimetre gaps, far from float overflow, and is reached only
    #: within a nanometre of the focal line.
    focal_eps: float = 1e-9
    #: Smallest cos(refraction angle) used in the refraction of curvatures (Eq. 4 divides
    #: by cos^2). Rays closer to grazing are flagged GRAZING; 1e-6 rad of margin to 90 deg.
    grazing_cos: float = 1e-6
    #: Newton iterations for ray/sag-surface intersection converge quadratically; spectacle
    #: surfaces need 3-5. 30 allows slow starts far off-axis before declaring a miss.
    intersect_max_iter: int = 30
    #: Intersection converged when the sag residual is below this (metres): 1e-13 m is
    #: ~100 float64 ulps of a 50 mm coordinate, well below any optical effect.
    intersect_tol: float = 1e-13
    #: Chief-ray path finding (Fermat path) stops when the angular residual (radians) is
    #: below this. 1e-12 rad at 1 km is 1 nm; the tracer is double precision throughout.
    path_tol: float = 1e-12
    #: Path finding reports failure when the final angular residual exceeds this (radians):
    #: 1e-8 rad = 0.002 arcsec, far below any visual effect, far above round-off.
    path_fail: float = 1e-8
    #: Newton iterations for path finding (quadratic convergence needs ~5 from a straight
    #: line guess; 25 covers strongly prismatic high-power lenses).
    path_max_iter: int = 25
    #: Finite-difference step (radians) for the path-finding Jacobian: central
    #: differences have truncation error ~h^2 and round-off ~1e-16/h; 1e-6 balances them
    #: (~1e-10 relative), which only affects the convergence rate, not the fixed point.
    path_fd_step: float = 1e-6


TOL = Tolerances()
