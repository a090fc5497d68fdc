"""Parse ``[eye.aberrations]`` (keys: :mod:`eyelab.spec.aberrationkeys`) into an
:class:`~eyelab.optics.eye.aberrations.Aberrations`, the second order into the eye's Rx."""

from __future__ import annotations

import csv
import re

import numpy as np

from eyelab.core.errors import SpecError
from eyelab.optics.eye import zernike as zk
from eyelab.optics.eye.aberrations import REPORT_WAVELENGTH_NM, Aberrations
from eyelab.spec.aberrationkeys import ALLOWED, WHERE
from eyelab.spec.tables import check_keys, number


def _number(a: dict, key: str, default=None):
    """``a[key]`` checked against its range (the schema's, from :data:`LIMITS`)."""
    if key not in a and default is None:
        raise SpecError(f"{WHERE}.{key}", "required")
    return number(a, key, WHERE, default)


def _from_table(tab: dict) -> np.ndarray:
    field = f"{WHERE}.coefficients_um"
    out = {}
    for name, v in tab.items():
        m = re.fullmatch(r"Z(\d+)_(-?\d+)", str(name))
        if m is None:
            raise SpecError(field, f"a table's keys are Zn_m (e.g. Z4_0, Z3_-1), got {name!r}")
        n, mm = int(m.group(1)), int(m.group(2))
        if n > zk.MAX_ORDER:
            raise SpecError(field, f"order at most {zk.MAX_ORDER}, got {name}")
        try:
            j = zk.j_from_nm(n, mm)
        except SpecError as e:
            raise SpecError(field, f"{name}: {e.message}") from None
        if j in out:
            raise SpecError(field, f"{name}: Z({n},{mm}) is given twice")
        out[j] = v
    c = np.zeros(max(out, default=0) + 1)
    for j, v in out.items():
        c[j] = _finite(v, field)
    return c


def _finite(v, field) -> float:
    """A coefficient (um): a finite number in the aberrometer's range
    (:data:`~eyelab.spec.aberrationkeys.ABERRATION_LIMITS`)."""
    from eyelab.spec.aberrationkeys import ABERRATION_LIMITS

    lo, hi = ABERRATION_LIMITS[f"{WHERE}.coefficients_um"]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise SpecError(field, f"must be finite numbers (um), each in [{lo:g}, {hi:g}], "
                               f"got {v!r}")
    if not lo <= v <= hi:
        raise SpecError(field, f"a coefficient must be in [{lo:g}, {hi:g}] um (what an "
                               f"aberrometer reports), got {v!r}")
    return float(v)


#: The largest coefficient file read (bytes): the 91 coefficients up to order 12 take under
#: 2 kB as text; a file far larger is not one.
COEFFICIENT_FILE_BYTES = 1_000_000


def _from_file(value) -> np.ndarray:
    from eyelab.spec.surfacefile import spec_file

    field = f"{WHERE}.file"
    path = spec_file(value, field, "a coefficient file's path (text, OSA order)")
    from eyelab.core.fileio import read_input

    try:
        text = read_input(field, path, COEFFICIENT_FILE_BYTES, "coefficient file").decode()
    except UnicodeDecodeError as e:
        raise SpecError(field, f"{path.name} is not a text file (byte {e.start})") from None
    vals = []
    for i, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        for cell in next(csv.reader([line.replace(";", ",")])):
            for tok in cell.split():
                try:
                    vals.append(float(tok))
                except ValueError:
                    raise SpecError(field, f"line {i}: not a number: {tok!r}") from None
    if not vals:
        raise SpecError(field, f"no coefficients in {path}")
    return np.array([_finite(v, field) for v in vals])


def eye_aberrations(t: dict, vertex_distance_mm: float) -> tuple:
    """(the ``[eye]`` table, with ``rx`` from the second order where that gives it, worn
    at ``vertex_distance_mm``; the :class:`Aberrations` or None)."""
    a = t.get("aberrations")
    if a is None:
        return t, None
    check_keys(a, ALLOWED, WHERE)
    if ("coefficients_um" in a) == ("file" in a):
        raise SpecError(f"{WHERE}.coefficients_um", "give the coefficients or a file, one "
                                                    "of them")
    if "file" in a:
        c = _from_file(a["file"])
    elif isinstance(a["coefficients_um"], dict):
        c = _from_table(a["coefficients_um"])
    elif isinstance(a["coefficients_um"], (list, tuple)):
        c = np.array([_finite(v, f"{WHERE}.coefficients_um") for v in a["coefficients_um"]])
    else:
        raise SpecError(f"{WHERE}.coefficients_um", "must be a list in OSA order or a table "
                                                    "of Zn_m = value")
    pupil = _number(a, "pupil_mm")
    wl = _number(a, "wavelength_nm", REPORT_WAVELENGTH_NM)
    sc = a.get("stiles_crawford", False)
    if not isinstance(sc, bool):
        raise SpecError(f"{WHERE}.stiles_crawford", f"must be true or false, got {sc!r}")
    c = np.concatenate([c, np.zeros(max(0, 6 - len(c)))])
    second = c[3:6].copy()                  # c2-2, c20, c22 (j = 3, 4, 5)
    c[:6] = 0.0
    if np.any(second != 0):
        if "rx" in t:
            raise SpecError(f"{WHERE}.coefficients_um", "its second order is a refraction and "
                            "eye.rx gives one too: give the refraction once (drop eye.rx, or "
                            "the second-order terms Z2_-2, Z2_0, Z2_2)")
        t = {**t, "rx": _rx(second, pupil, wl, vertex_distance_mm * 1e-3,
                            t.get("chromatic", True) is not False)}
    return t, Aberrations(tuple(float(v) for v in c), pupil, wl, sc)


def _rx(second, pupil_mm: float, wavelength_nm: float, vertex_distance: float,
        chromatic: bool):
    """The spectacle Rx the second order (c2-2, c20, c22; OSA frame) gives, at the eye's
    reference wavelength: M(ref) = M(measured) - R(measured), R the chromatic difference
    of refraction (:func:`eyelab.optics.eye.thin.ocular_lca`) — for a chromatic eye; an
    achromatic one (``eye.chromatic = false``) has the measured refraction everywhere. A
    refraction out of the Rx's range names the coefficients."""
    from eyelab.optics.eye.prescription import Prescription
    from eyelab.optics.eye.thin import ocular_lca
    m, j0, j45 = zk.second_order_to_power_vector(second[1], second[2], second[0], pupil_mm)
    if chromatic:
        m -= float(ocular_lca(wavelength_nm))
    c20, c22, c2m2 = zk.power_vector_to_second_order(m, j0, j45, pupil_mm)
    try:
        rx = zk.second_order_to_rx(c20, c22, c2m2, pupil_mm, vertex_distance)
        return Prescription(round(rx.sphere, 12), round(rx.cylinder, 12), rx.axis)
    except (SpecError, ZeroDivisionError) as e:
        why = e.message if isinstance(e, SpecError) else "the far point is at the lens"
        raise SpecError(f"{WHERE}.coefficients_um", f"the second order's refraction (M "
                        f"{m:+.2f} D at the eye) is no spectacle Rx: {why}") from None
