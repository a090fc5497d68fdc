"""Lens materials: refractive index as a function of wavelength (Cauchy fit from Abbe number).

n(lambda) = A + B / lambda^2 (lambda in micrometres), with
B = ((n_d - 1) / V_d) / (lambda_F^-2 - lambda_C^-2) and A = n_d - B / lambda_d^2
(SCIENCE.md §6), so that n(lambda_d) = n_d and (n_d - 1)/(n_F - n_C) = V_d exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eyelab.errors import SpecError, check_range

#: Fraunhofer lines, nanometres.
LAMBDA_F_NM = 486.13
LAMBDA_D_NM = 587.56
LAMBDA_C_NM = 656.27
#: Design wavelengths for the R, G, B channels (nm): C line, d line... green e line, F line.
RGB_WAVELENGTHS_NM = (656.27, 546.07, 486.13)


@dataclass(frozen=True)
class Material:
    """An optical material.

    Parameters
    ----------
    name : str
    n_d : float
        Refractive index at the helium d line (587.56 nm), in [1, 2.5].
    v_d : float
        Abbe number; ``inf`` means no dispersion (n(lambda) = n_d).
    """

    name: str
    n_d: float
    v_d: float = float("inf")

    def __post_init__(self):
        object.__setattr__(self, "n_d", check_range(f"material[{self.name}].n_d", self.n_d,
                                                    1.0, 2.5))
        object.__setattr__(self, "v_d", check_range(f"material[{self.name}].v_d", self.v_d,
                                                    5.0, float("inf")))

    @property
    def cauchy(self) -> tuple[float, float]:
        """(A, B) with B in um^2."""
        if np.isinf(self.v_d):
            return self.n_d, 0.0
        lf, ld, lc = LAMBDA_F_NM / 1e3, LAMBDA_D_NM / 1e3, LAMBDA_C_NM / 1e3
        b = ((self.n_d - 1.0) / self.v_d) / (lf ** -2 - lc ** -2)
        return self.n_d - b / ld ** 2, b

    def n(self, wavelength_nm):
        """Refractive index at ``wavelength_nm`` (scalar or array, 300-1100 nm)."""
        wl = np.asarray(wavelength_nm, float)
        if np.any((wl < 300) | (wl > 1100)):
            raise SpecError("wavelength_nm", f"must be in [300, 1100] nm, got {wavelength_nm!r}")
        a, b = self.cauchy
        out = a + b / (wl / 1e3) ** 2
        return float(out) if out.ndim == 0 else out

    @property
    def dispersive(self) -> bool:
        return not np.isinf(self.v_d)


#: Catalogue (SCIENCE.md §6, Duane's Ophthalmology ch. 51C Table 1 and lens-maker data).
CATALOGUE: dict[str, Material] = {
    m.name: m
    for m in (
        Material("cr39", 1.498, 58.0),
        Material("crown", 1.523, 58.6),
        Material("trivex", 1.532, 44.0),
        Material("polycarbonate", 1.586, 30.0),
        Material("1.60", 1.600, 36.0),
        Material("1.67", 1.670, 32.0),
        Material("1.74", 1.740, 33.0),
        Material("air", 1.0),
    )
}


def get_material(spec, *, field: str = "lens.material") -> Material:
    """A catalogue name (case-insensitive), a ``Material``, or a mapping {n_d, v_d[, name]}."""
    if isinstance(spec, Material):
        return spec
    if isinstance(spec, str):
        key = spec.strip().lower().replace("-", "").replace(" ", "")
        key = {"cr39": "cr39", "pc": "polycarbonate"}.get(key, key)
        if key in CATALOGUE:
            return CATALOGUE[key]
        raise SpecError(field, f"unknown material {spec!r}; allowed: {', '.join(CATALOGUE)} "
                               "or a table {{n_d = ..., v_d = ...}}")
    if isinstance(spec, dict):
        unknown = set(spec) - {"n_d", "v_d", "name"}
        if unknown or "n_d" not in spec:
            raise SpecError(field, f"a material table needs n_d (and optionally v_d, name); "
                                   f"got keys {sorted(spec)}")
        try:
            return Material(str(spec.get("name", "custom")), spec["n_d"],
                            spec.get("v_d", float("inf")))
        except SpecError as e:
            raise SpecError(f"{field}.{e.field.rsplit('.', 1)[-1]}", e.message) from None
    raise SpecError(field, f"expected a material name or table, got {spec!r}")
