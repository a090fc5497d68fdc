"""Reading one TOML table: unknown keys refused with the nearest valid name, moved keys
named, numbers range-checked under their dotted field name, Rx strings parsed."""

from __future__ import annotations

import difflib

from eyelab.core.checks import check_range
from eyelab.core.errors import SpecError
from eyelab.optics.prescription import Prescription

#: Keys that moved: where they are now (an old spec gets an error that says so).
MOVED = {"analysis.accommodation_d": "eye.accommodation_d",
         "render.focus_d": "eye.accommodation_d"}


def check_keys(table, allowed, where):
    if not isinstance(table, dict):
        raise SpecError(where, f"must be a table, got {table!r}")
    for key in table:
        if f"{where}.{key}" in MOVED:
            raise SpecError(f"{where}.{key}", f"moved to {MOVED[f'{where}.{key}']} (one eye "
                            "state for analyze, render, inspect and batch alike)")
    unknown = sorted(set(table) - allowed, key=str)
    if unknown:
        near = difflib.get_close_matches(str(unknown[0]), sorted(allowed), n=1, cutoff=0.6)
        hint = f"did you mean {near[0]!r}? " if near else ""
        raise SpecError(f"{where}.{unknown[0]}", f"unknown key; {hint}allowed keys: "
                                                 f"{', '.join(sorted(allowed))}")


def number(table, key, where, lo, hi, default=None):
    if key not in table:
        return default
    return check_range(f"{where}.{key}", table[key], lo, hi)


def rx_value(value, field):
    if isinstance(value, Prescription):
        return value
    return Prescription.parse(value, field=field)
