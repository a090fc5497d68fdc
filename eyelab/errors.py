"""Errors raised for user mistakes.

Every error names the offending field and the allowed range, so that the apps
can print it and exit with status 2 instead of showing a traceback.
"""


class SpecError(ValueError):
    """Invalid user input: a spec field, a prescription string, a CLI argument.

    Parameters
    ----------
    field : str
        Dotted name of the offending field, e.g. ``"eye.pupil_diameter_mm"``.
    message : str
        What is wrong and what is allowed.
    """

    def __init__(self, field: str, message: str):
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message}")


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
