"""Reading one TOML table: unknown keys refused with the nearest valid name, moved keys
named, numbers range-checked under their dotted field name, Rx strings parsed."""

from __future__ import annotations

import difflib

from eyelab.core.errors import SpecError
from eyelab.optics.eye.prescription import Prescription
from eyelab.spec.schema import EXCLUSIVE_WITH, NOT_WITH, ONLY_WITH, SURFACE_TYPE_KEYS, check

#: Keys that moved: where they are now (an old spec gets an error that says so).
MOVED = {"analysis.accommodation_d": "eye.accommodation_d",
         "render.focus_d": "eye.accommodation_d"}
_RX = "a prescription is one string: rx = \"-2.00 / -0.50 x 180\""
_ADD = ("an add is part of the lens's prescription: write it in lens.rx, e.g. rx = "
        "\"-1.00 DS add +2.00\", with lens.design = \"progressive\", \"near\" or "
        "\"single-vision\"")
_SIDE = ("an eye's side is written in its Rx (rx = \"R -1.00 DS\", or OD / L / OS), or as "
         "[eye.right] / [lens.left] tables for two eyes")
#: Keys people reach for that the spec spells another way: what to write instead.
HINTS = {**{f"{t}.{k}": _RX for t in ("eye", "lens") for k in ("sphere", "cylinder", "axis")},
         **{f"{t}.{k}": _SIDE for t in ("eye", "lens") for k in ("side", "eye")},
         "lens.add": _ADD, "eye.add": _ADD,
         "lens.index": "a material's index goes in lens.material: a catalogue name or "
                       "{n_d = 1.6, v_d = 42}"}


def check_keys(table, allowed, where):
    if not isinstance(table, dict):
        raise SpecError(where, f"must be a table, got {table!r}")
    for key in table:
        if f"{where}.{key}" in MOVED:
            raise SpecError(f"{where}.{key}", f"moved to {MOVED[f'{where}.{key}']} (one eye "
                            "state for analyze, render, inspect and batch alike)")
    unknown = sorted(set(table) - allowed, key=str)
    if unknown:
        name = f"{where}.{unknown[0]}"
        near = difflib.get_close_matches(str(unknown[0]), sorted(allowed), n=1, cutoff=0.6)
        hint = (f"{HINTS[name]}; " if name in HINTS else
                f"did you mean {near[0]!r}? " if near else "")
        raise SpecError(name, f"unknown key; {hint}allowed keys: {', '.join(sorted(allowed))}")


def choice(field: str, value, choices: tuple, aliases: dict | None = None):
    """``value`` if it is one of ``choices``, else an error naming them, with "did you
    mean" the choice an alias stands for (``aliases``: other names, lower case) or the
    nearest spelling."""
    if isinstance(value, str) and value in choices:
        return value
    hint = ""
    if isinstance(value, str):
        key = " ".join(value.strip().lower().replace("_", " ").replace("-", " ").split())
        near = [(aliases or {}).get(key)] if key in (aliases or {}) else \
            difflib.get_close_matches(value.strip().lower(), choices, n=1, cutoff=0.6)
        hint = f"; did you mean {near[0]!r}?" if near else ""
    raise SpecError(field, f"must be one of {', '.join(map(repr, choices))}, got {value!r}"
                    + hint)


def number(table, key, where, default=None):
    """``table[key]`` checked against the schema's range of ``where.key``, or ``default``
    when the key is not written."""
    if key not in table:
        return default
    return check(f"{where}.{key}", table[key])


def rx_value(value, field):
    if isinstance(value, Prescription):
        return value
    return Prescription.parse(value, field=field)


def check_rules(table: dict, where: str) -> None:
    """The schema's "only with" and "not with" rules of a table (:data:`ONLY_WITH`,
    :data:`NOT_WITH` of :mod:`eyelab.spec.schema`), in their declared order."""
    for key, needs, why in ONLY_WITH.get(where, ()):
        if key in table and needs not in table:
            raise SpecError(f"{where}.{key}", f"only used with {where}.{needs} ({why})")
    for a, b, *why in NOT_WITH.get(where, ()):
        if a in table and b in table:
            raise SpecError(f"{where}.{a}", f"give either {a} or {b}, not both"
                            + "".join(f" ({w})" for w in why))
    mutex = [k for k in EXCLUSIVE_WITH.get(where, {}).get("others", ()) if k in table]
    anchor = EXCLUSIVE_WITH.get(where, {}).get("key")
    if anchor in table and mutex:
        raise SpecError(f"{where}.{sorted(mutex)[0]}", f"give either {where}.{anchor} or the "
                        f"explicit {' / '.join(EXCLUSIVE_WITH[where]['others'])}, not both")


def check_surface_type_keys(t: dict, kind, where: str) -> None:
    """Refuse a key of surface table ``t`` that its type ``kind`` does not read
    (:data:`~eyelab.spec.schema.SURFACE_TYPE_KEYS`), by name, with the keys it does; an
    unknown type is left to the type's own check."""
    if not isinstance(kind, str) or kind not in SURFACE_TYPE_KEYS:
        return
    other = sorted(set(t) - set(SURFACE_TYPE_KEYS[kind]))
    if other:
        raise SpecError(f"{where}.{other[0]}", f"not read by a type = {kind!r} surface "
                        f"(its keys: {', '.join(SURFACE_TYPE_KEYS[kind])})")
