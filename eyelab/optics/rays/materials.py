"""Lens materials: refractive index as a function of wavelength (Cauchy fit from Abbe number).

n(lambda) = A + B / lambda^2 (lambda in micrometres), with
B = ((n_d - 1) / V_d) / (lambda_F^-2 - lambda_C^-2) and A = n_d - B / lambda_d^2
(docs/SCIENCE.md §6), so that n(lambda_d) = n_d and (n_d - 1)/(n_F - n_C) = V_d exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from eyelab.core.checks import check_range
from eyelab.core.errors import SpecError

#: Fraunhofer lines, nanometres.
LAMBDA_F_NM = 486.13
LAMBDA_D_NM = 587.56
LAMBDA_C_NM = 656.27
#: The e line and the F', C' lines that European (and Japanese) data use (V_e).
LAMBDA_E_NM = 546.07
LAMBDA_F_PRIME_NM = 479.99
LAMBDA_C_PRIME_NM = 643.85
#: Design wavelengths for the R, G, B channels (nm): C line, d line... green e line, F line.
RGB_WAVELENGTHS_NM = (656.27, 546.07, 486.13)


@dataclass(frozen=True)
class Material:
    """An optical material.

    Its index at other wavelengths, :meth:`n`, is Cauchy's n(lambda) = A + B / lambda^2
    (lambda in micrometres), fitted so that n(lambda_d) = n_d and (n_d - 1)/(n_F - n_C) =
    V_d exactly. :func:`get_material` names the catalogue's materials.

    Parameters
    ----------
    name : str
        What reports and reprs call it.
    n_d : float
        Refractive index at the helium d line (587.56 nm), in [1, 2.5].
    v_d : float
        Abbe number; ``inf`` means no dispersion (n(lambda) = n_d).
    source : str
        Where the numbers come from (not part of the material's identity).

    Examples
    --------
    >>> import eyelab
    >>> glass = eyelab.Material("my glass", n_d=1.6, v_d=42.0)
    >>> round(glass.n(486.13), 4), round(glass.n(587.56), 4), round(glass.n(656.27), 4)
    (1.61, 1.6, 1.5957)
    >>> eyelab.Material("water", 1.333).dispersive        # no v_d: no dispersion
    False
    """

    name: str
    n_d: float
    v_d: float = float("inf")
    source: str = field(default="", compare=False, repr=False)

    @classmethod
    def from_e_line(cls, name: str, n_e: float, v_e: float, source: str = "") -> Material:
        """A material given as manufacturers in Europe and Japan do: n_e (546.07 nm) and
        V_e = (n_e - 1)/(n_F' - n_C') (F' 479.99, C' 643.85 nm). The same Cauchy model
        n = A + B/lambda^2 through those data gives n_d and V_d (docs/SCIENCE.md §6):
        B = ((n_e - 1)/V_e)/(lambda_F'^-2 - lambda_C'^-2), A = n_e - B/lambda_e^2."""
        lf, lc, le = LAMBDA_F_PRIME_NM / 1e3, LAMBDA_C_PRIME_NM / 1e3, LAMBDA_E_NM / 1e3
        b = ((n_e - 1.0) / v_e) / (lf ** -2 - lc ** -2)
        a = n_e - b / le ** 2

        def n(wl_nm):
            return a + b / (wl_nm / 1e3) ** 2

        n_d = n(LAMBDA_D_NM)
        return cls(name, n_d, (n_d - 1.0) / (n(LAMBDA_F_NM) - n(LAMBDA_C_NM)), source)

    @property
    def n_e(self) -> float:
        return self.n(LAMBDA_E_NM)

    @property
    def v_e(self) -> float:
        """Abbe number at the e line (inf for a non-dispersive material)."""
        dn = self.n(LAMBDA_F_PRIME_NM) - self.n(LAMBDA_C_PRIME_NM)
        return float("inf") if dn == 0 else (self.n_e - 1.0) / dn

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


DUANE = "Duane's Ophthalmology ch. 51C, Table 1 (docs/SCIENCE.md §6): n_d, V_d"
MITSUI = ("Mitsui Chemicals, MR series product data (n_e, V_e; the nominal "
          "1.60/1.67/1.74 are n_e, docs/SCIENCE.md §6); n_d, V_d by Material.from_e_line")
#: Catalogue: the name, the data as published and their source. The high-index
#: thiourethanes are published as n_e / V_e rounded to 0.01 / 1, so their derived n_d is
#: known to about +-0.005.
CATALOGUE: dict[str, Material] = {
    m.name: m
    for m in (
        Material("cr39", 1.498, 58.0, DUANE),
        Material("crown", 1.523, 58.6, DUANE),
        Material("trivex", 1.532, 44.0, "PPG Trivex data (docs/SCIENCE.md §6): n_d 1.532, "
                 "V_d 43-45"),
        Material("polycarbonate", 1.586, 30.0, DUANE),
        Material.from_e_line("mr8", 1.60, 41.0, MITSUI + " (MR-8)"),
        Material.from_e_line("mr7", 1.67, 31.0, MITSUI + " (MR-7)"),
        Material.from_e_line("mr174", 1.74, 32.0, MITSUI + " (MR-174)"),
        Material("air", 1.0),
    )
}
#: Other names of catalogue materials: the nominal indices name the usual thiourethanes.
ALIASES = {"1.60": "mr8", "1.67": "mr7", "1.74": "mr174", "pc": "polycarbonate",
           "mr-8": "mr8", "mr-7": "mr7", "mr-174": "mr174", "cr-39": "cr39"}


def get_material(spec, *, field: str = "lens.material") -> Material:
    """A catalogue name (case-insensitive), a ``Material``, or a mapping {n_d, v_d[, name]}.

    The catalogue (:data:`CATALOGUE`): cr39, crown, trivex, polycarbonate and the
    thiourethanes mr8, mr7 and mr174, also named by their nominal indices 1.60, 1.67 and
    1.74 (:data:`ALIASES`); the names ``lens.material`` takes. A mapping without a name is
    called "custom". Anything else raises :class:`~eyelab.core.errors.SpecError`, naming
    ``field`` and the allowed names.

    Examples
    --------
    >>> import eyelab
    >>> eyelab.get_material("polycarbonate")
    Material(name='polycarbonate', n_d=1.586, v_d=30.0)
    >>> eyelab.get_material("1.67").name
    'mr7'
    >>> eyelab.get_material({"n_d": 1.6, "v_d": 42})
    Material(name='custom', n_d=1.6, v_d=42.0)
    """
    if isinstance(spec, Material):
        return spec
    if isinstance(spec, str):
        key = spec.strip().lower().replace(" ", "")
        key = ALIASES.get(key, key).replace("-", "")
        if key in CATALOGUE and key != "air":
            return CATALOGUE[key]
        names = [k for k in CATALOGUE if k != "air"] + [k for k in ALIASES if "-" not in k]
        raise SpecError(field, f"unknown material {spec!r}; allowed: {', '.join(names)} "
                               "or a table {n_d = ..., v_d = ...}")
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
