"""The spectacle Rx an eye takes (``eye.rx``): the eye's own limits
(:data:`eyelab.optics.eye.thin.LIMITS`) bind before the Rx grammar's
(:data:`eyelab.optics.eye.prescription.SPHERE_RANGE`, ``CYLINDER_RANGE``), so the powers
``eye.rx`` accepts are derived from them here, for the reference table and the errors."""

from __future__ import annotations

from eyelab.optics.eye.prescription import CYLINDER_RANGE, SPHERE_RANGE
from eyelab.optics.eye.thin import GH_N_VITREOUS, GH_RETINA_DISTANCE
from eyelab.optics.eye.thin import LIMITS as EYE_LIMITS


def eye_rx_ranges(vertex_mm: float, kind: str = "refractive", retina_mm: float | None = None,
                  n_vitreous: float | None = None) -> dict:
    """What ``eye.rx`` takes (D): ``"sphere"``, a sphere alone worn at ``vertex_mm`` (a
    refractive eye's power_min_d, an axial eye's retina_distance_mm within range);
    ``"cylinder"``, a cylinder on a plano sphere (astigmatism_d within range). The ocular
    refraction of a spectacle power F is K = F / (1 - d F), so F = K / (1 + d K) at the
    ends of K's range. ``retina_mm``, ``n_vitreous``: the eye's (None: the default eye's).

    >>> [round(v, 2) for v in eye_rx_ranges(12.0)["sphere"]]
    [-28.73, 15.23]
    """
    n_vitreous = GH_N_VITREOUS if n_vitreous is None else n_vitreous
    retina = GH_RETINA_DISTANCE if retina_mm is None else retina_mm * 1e-3
    d, e = vertex_mm * 1e-3, n_vitreous / retina
    if kind == "axial":
        z_lo, z_hi = EYE_LIMITS["eye.retina_distance_mm"]
        k = (n_vitreous / (z_hi * 1e-3) - e, n_vitreous / (z_lo * 1e-3) - e)
    else:
        p_lo, p_hi = EYE_LIMITS["eye.power_min_d"]
        k = (e - p_hi, e - p_lo)
    a = EYE_LIMITS["eye.astigmatism_d"][1]

    def spectacle(ks, grammar):
        return (max(ks[0] / (1 + d * ks[0]), grammar[0]),
                min(ks[1] / (1 + d * ks[1]), grammar[1]))
    return {"sphere": spectacle(k, SPHERE_RANGE), "cylinder": spectacle((-a, a), CYLINDER_RANGE)}


def dioptres(lo: float, hi: float) -> str:
    """A power range as the reference writes it: ``−28.73…+15.23 D``."""
    return f"{lo:+.2f}…{hi:+.2f} D".replace("-", "−")


def _span(field: str) -> str:
    lo, hi = EYE_LIMITS[field]
    return f"{lo:g}–{hi:g}"


def eye_rx_text(vertex_mm: float) -> str:
    """The reference's range of ``eye.rx``, from the eye's limits."""
    r, ax = eye_rx_ranges(vertex_mm), eye_rx_ranges(vertex_mm, "axial")
    return (f"the Rx grammar below, where the eye's limits bind first: at {vertex_mm:g} mm "
            f"a sphere alone {dioptres(*r['sphere'])} (`power_min_d` "
            f"{_span('eye.power_min_d')}; `kind = \"axial\"`: {dioptres(*ax['sphere'])}, "
            f"`retina_distance_mm` {_span('eye.retina_distance_mm')}), a cylinder on a "
            f"plano sphere {dioptres(*r['cylinder'])} (`astigmatism_d` ≤ "
            f"{EYE_LIMITS['eye.astigmatism_d'][1]:g}); an add only where a `[lens]` without "
            "its own `rx` is made from it (an add is the lens's, not the eye's)")
