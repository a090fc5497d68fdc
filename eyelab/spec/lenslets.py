"""``[lens.lenslets]``: the parser of a lenslet array on the lens's front surface (its keys:
:mod:`eyelab.spec.lensletkeys`; the surface: :mod:`eyelab.optics.lens.lenslets`).

A layout whose lenslets overlap, reach beyond the lens, or hold none is refused naming the
key that places them.
"""

from __future__ import annotations

import math

from eyelab.core.checks import check_choice
from eyelab.core.errors import SpecError
from eyelab.optics.lens import lenslets as ll
from eyelab.spec.lensletkeys import ALLOWED, LAYOUT_KEYS, LAYOUTS, LENSLET_LIMITS, WHERE
from eyelab.spec.tables import check_keys, number


def parse_lenslets(t, lens, *, eye=None):
    """``lens`` with the ``[lens.lenslets]`` table ``t`` on its front (designed for
    ``eye``'s centre of rotation; the default eye's when None)."""
    if not isinstance(t, dict):
        raise SpecError(WHERE, f"must be a table, got {type(t).__name__}")
    check_keys(t, ALLOWED, WHERE)
    for key in ("layout", "add_d", "diameter_mm"):
        if key not in t:
            raise SpecError(f"{WHERE}.{key}", "required")
    layout = t["layout"]
    check_choice(f"{WHERE}.layout", layout, LAYOUTS)
    for other, keys in LAYOUT_KEYS.items():
        for key in keys:
            if key in t and other != layout:
                raise SpecError(f"{WHERE}.{key}", f"only with layout = \"{other}\"")
    add = number(t, "add_d", WHERE)
    if add == 0:
        raise SpecError(f"{WHERE}.add_d", "must not be 0 (a lenslet adds power)")
    d = number(t, "diameter_mm", WHERE) * 1e-3
    centres, key = {"honeycomb": _honeycomb, "rings": _rings,
                    "list": _centres}[layout](t, d, lens.diameter)
    ll.check_layout(centres, d, lens.diameter, key)
    return ll.with_lenslets(lens, centres, d, add, number(t, "conic", WHERE) or 0.0, eye=eye)


def _honeycomb(t, d, lens_d) -> tuple:
    if "pitch_mm" not in t:
        raise SpecError(f"{WHERE}.pitch_mm", "required with layout = \"honeycomb\"")
    pitch = number(t, "pitch_mm", WHERE) * 1e-3
    if pitch < d - 1e-12:
        raise SpecError(f"{WHERE}.pitch_mm", f"{pitch * 1e3:g} mm is below the lenslets' "
                        f"{d * 1e3:g} mm diameter: they would overlap")
    clear = (number(t, "clear_zone_mm", WHERE) or 0.0) * 1e-3
    zone = number(t, "zone_mm", WHERE)
    zone = lens_d - 2e-3 if zone is None else zone * 1e-3
    if zone > lens_d + 1e-12:
        raise SpecError(f"{WHERE}.zone_mm", f"{zone * 1e3:g} mm is beyond the "
                        f"{lens_d * 1e3:g} mm lens")
    if clear >= zone:
        raise SpecError(f"{WHERE}.clear_zone_mm", f"{clear * 1e3:g} mm leaves no annulus "
                        f"inside zone_mm = {zone * 1e3:g}")
    centres = ll.honeycomb(pitch, d, clear, zone)     # a lattice of <= 0.3 M points: cheap
    ll.check_count(len(centres), f"{WHERE}.pitch_mm", "a larger pitch or a smaller zone")
    return centres, f"{WHERE}.zone_mm"


def _rings(t, d, lens_d) -> tuple:
    diam = _numbers(t, "ring_diameters_mm")
    counts = None
    if "per_ring" in t:
        counts = _numbers(t, "per_ring", integers=True)
        if len(counts) != len(diam):
            raise SpecError(f"{WHERE}.per_ring", f"{len(counts)} counts for {len(diam)} "
                                                 "rings")
    key = f"{WHERE}.per_ring" if counts is not None else f"{WHERE}.ring_diameters_mm"
    ll.check_count(sum(ll.ring_counts([v * 1e-3 for v in diam], d, counts)), key,
                   "fewer rings or fewer lenslets on each")
    return ll.rings([v * 1e-3 for v in diam], d, counts), key


def _numbers(t, key, *, integers=False) -> list:
    name = f"{WHERE}.{key}"
    lo, hi = LENSLET_LIMITS[name]
    v = t.get(key)
    if v is None:
        raise SpecError(name, "required with this layout")
    if not isinstance(v, list) or not v:
        raise SpecError(name, f"must be a non-empty list, got {v!r}")
    out = []
    for x in v:
        ok = isinstance(x, int) if integers else isinstance(x, (int, float))
        if isinstance(x, bool) or not ok or not math.isfinite(x) or not lo <= x <= hi:
            kind = "integers" if integers else "numbers"
            raise SpecError(name, f"must be {kind} in [{lo:g}, {hi:g}], got {x!r}")
        out.append(x)
    return out


def _centres(t, d=None, lens_d=None) -> tuple:
    name = f"{WHERE}.centres_mm"
    lo, hi = LENSLET_LIMITS[name]
    v = t.get("centres_mm")
    if not isinstance(v, list) or not v:
        raise SpecError(name, f"required with layout = \"list\": a list of [x, y], got {v!r}")
    ll.check_count(len(v), name, "fewer centres")
    out = []
    for p in v:
        if not (isinstance(p, list) and len(p) == 2 and all(
                isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c)
                and lo <= c <= hi for c in p)):
            raise SpecError(name, f"each centre must be [x, y] in [{lo:g}, {hi:g}] mm, got "
                                  f"{p!r}")
        out.append([p[0] * 1e-3, p[1] * 1e-3])
    return out, name


__all__ = ["parse_lenslets"]
