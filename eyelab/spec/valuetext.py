"""Values as the spec's reference tables write them: a range's ends, and a renderer
option's default, derived from its options class (:mod:`eyelab.imaging.options`), where
the default is declared once."""

from __future__ import annotations

import math
from dataclasses import MISSING, fields

from eyelab.imaging.registry import QUALITIES


def option_default(renderer: str, name: str) -> str:
    """The default of ``[render] name`` for ``renderer`` as the reference tables write it:
    true / false, a number, ``"text"`` in backticks, or [a, b, c]."""
    value = next((f.default for f in fields(QUALITIES[renderer]) if f.name == name), MISSING)
    if value is MISSING:
        raise KeyError(f"{renderer} has no option {name!r} with a default")
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(f"{v:g}" for v in value) + "]"
    return f"{value:g}"


def number_text(v) -> str:
    """A range's end: a true minus sign, powers of ten >= 1e5 as 1eN, 2^63 - 1 by name."""
    if v == 2**63 - 1:
        return "2⁶³ − 1"
    if abs(v) >= 1e5 and math.log10(abs(v)).is_integer():
        return f"{'−' if v < 0 else ''}1e{int(math.log10(abs(v)))}"
    return f"{v:g}".replace("-", "−")
