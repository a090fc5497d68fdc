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

    >>> check_range("eye.age", 40, 0, 100)
    40.0
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SpecError(field, f"must be a number in {_fmt(lo, hi, lo_open, hi_open)}, "
                               f"got {value!r}") from None
    bad = (v != v or (v <= lo if lo_open else v < lo) or (v >= hi if hi_open else v > hi))
    if bad:
        raise SpecError(field, f"must be in {_fmt(lo, hi, lo_open, hi_open)}, got {value!r}")
    return v


def _fmt(lo, hi, lo_open, hi_open):
    return f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
