"""Validators of user-facing values: each returns the value in its canonical type or
raises :class:`~eyelab.core.errors.SpecError` naming the field and the allowed range."""

from __future__ import annotations

import numpy as np

from eyelab.core.errors import SpecError

#: The range of an 8-bit sRGB code.
RGB_RANGE = (0, 255)


def check_int(field_name: str, value, lo: int, hi: int) -> int:
    """``value`` as an int in [lo, hi], or a :class:`SpecError` naming the field (booleans
    and non-integral numbers are refused)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise SpecError(field_name, f"must be an integer in [{lo}, {hi}], got {value!r}")
    if not lo <= int(value) <= hi:          # exact: no float rounding of huge integers
        text = repr(int(value))
        raise SpecError(field_name, f"must be an integer in [{lo}, {hi}], got "
                        f"{text if len(text) <= 40 else text[:20] + '...'}")
    return int(value)


def check_argument(name: str, value, lo: float, hi: float, *, integer: bool = False):
    """A Python argument (the API's): ``value`` as an int (``integer``) or a float in
    [lo, hi]; a ``TypeError`` naming ``name`` for another type (a string, a bool, None, a
    float where an integer is wanted), a :class:`SpecError` naming it out of range."""
    kinds = (int, np.integer) if integer else (int, float, np.integer, np.floating)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, kinds):
        raise TypeError(f"{name} must be {'an integer' if integer else 'a number'} in "
                        f"[{lo:g}, {hi:g}], got {type(value).__name__} {_short(value)}")
    if integer:
        return check_int(name, value, lo, hi)
    return check_range(name, value, lo, hi)


def check_rgb(field_name: str, value) -> tuple:
    """An sRGB colour [r, g, b] of integers 0-255 as a tuple, or a :class:`SpecError`
    naming the field (or the element)."""
    if not (isinstance(value, (tuple, list)) and len(value) == 3):
        raise SpecError(field_name, f"must be [r, g, b] in 0-255, got {value!r}")
    return tuple(check_int(f"{field_name}[{i}]", v, *RGB_RANGE) for i, v in enumerate(value))


def check_bool(field_name: str, value) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise SpecError(field_name, f"must be true or false, got {value!r}")
    return bool(value)


def check_choice(field_name: str, value, choices):
    if value not in choices:
        raise SpecError(field_name, f"must be one of {', '.join(map(repr, choices))}, "
                                    f"got {value!r}")
    return value


def check_range(field: str, value, lo: float, hi: float, *, lo_open=False, hi_open=False):
    """Return ``float(value)`` if it lies in the range, else raise :class:`SpecError`.
    Booleans and strings are not numbers (``"inf"`` excepted: TOML's inf), and an integer
    too large for a float is out of range, not an overflow.

    >>> check_range("eye.age", 40, 0, 100)
    40.0
    """
    if isinstance(value, str) and value.strip().lower() in ("inf", "+inf", "infinity"):
        value = float("inf")                     # TOML's inf, also written as a string
    if isinstance(value, (bool, str, bytes)) or type(value).__name__ == "bool_":
        kind = "a boolean" if not isinstance(value, (str, bytes)) else "a string"
        raise SpecError(field, f"must be a number in {_fmt(lo, hi, lo_open, hi_open)}, "
                               f"got {value!r} ({kind})")
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise SpecError(field, f"must be a number in {_fmt(lo, hi, lo_open, hi_open)}, "
                               f"got {_short(value)}") from None
    bad = (v != v or (v <= lo if lo_open else v < lo) or (v >= hi if hi_open else v > hi))
    if bad:
        raise SpecError(field, f"must be in {_fmt(lo, hi, lo_open, hi_open)}, "
                               f"got {_short(value)}")
    return v


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:20]}... ({len(text)} characters)"


def _fmt(lo, hi, lo_open, hi_open):
    return f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def check_in(field_name: str, value, limits: dict, *, integer: bool = False, **kw):
    """:func:`check_range` (:func:`check_int` with ``integer``) against the range declared
    for ``field_name`` in ``limits`` (a module's or class's ``LIMITS``: field -> (lo, hi)),
    so that a range is written once. ``field_name`` may carry an element index
    (``render.field_shape[2]``): the range is the field's."""
    lo, hi = limits[field_name.split("[")[0]]
    if integer:
        return check_int(field_name, value, lo, hi)
    return check_range(field_name, value, lo, hi, **kw)
