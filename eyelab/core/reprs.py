"""Reprs in the spec's units: what a notebook shows for an eye, a lens or a pose is the
spec's keys (mm, D, degrees), each number rounded to what the spec's grammar and a
clinician read (:data:`REPR_DECIMALS`), not a float's 16 digits in metres."""

from __future__ import annotations

import math

#: Decimals a repr shows: 0.001 D, 0.001 mm, 0.001 degree (a repr is for reading; the
#: object keeps every digit, and reports write them all).
REPR_DECIMALS = 3


class Raw(str):
    """Text that a repr shows as it is (a nested repr already rounded), not quoted."""

    def __repr__(self) -> str:
        return str(self)


def number(x) -> str:
    """``x`` rounded to :data:`REPR_DECIMALS`, trailing zeros dropped (``-0`` is ``0``)."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return repr(x)
    if not math.isfinite(x):
        return repr(float(x))
    s = f"{x:.{REPR_DECIMALS}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def value(v) -> str:
    """A repr of ``v`` with its numbers (also inside tuples and lists) rounded."""
    if isinstance(v, (tuple, list)):
        inner = ", ".join(value(x) for x in v)
        return f"({inner}{',' if len(v) == 1 else ''})" if isinstance(v, tuple) else f"[{inner}]"
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return number(v)
    return repr(v)


def spec_repr(name: str, keys: dict) -> str:
    """``name(key=value, ...)`` with every value rounded by :func:`value`."""
    return f"{name}({', '.join(f'{k}={value(v)}' for k, v in keys.items())})"
