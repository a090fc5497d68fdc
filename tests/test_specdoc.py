"""The schema (eyelab/spec/schema.py) is what the validator derives from: the same keys,
every declared range accepted at its ends and refused just beyond (naming the key), every
choice accepted and a wrong one refused, no range written a second time anywhere in the
package; the spec reference's tables (docs/reference/spec.md) are generated from it."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest

from eyelab.core.errors import SpecError
from eyelab.imaging.registry import RENDERERS
from eyelab.spec import (
    ANALYSIS_KEYS,
    BINOCULAR_KEYS,
    EYE_KEYS,
    LENS_KEYS,
    POINT_KEYS,
    SCENE_KEYS,
    SURFACE_KEYS,
    parse_spec,
    renderer_keys,
)
from eyelab.spec.docs import markdown
from eyelab.spec.schema import KEYS

REFERENCE = (Path(__file__).resolve().parents[1] / "docs" / "reference" / "spec.md").read_text()


def _keys(*tables):
    return {k.key for k in KEYS if k.table in tables}


def test_the_reference_has_exactly_the_validators_keys():
    assert _keys("eye") == EYE_KEYS
    assert _keys("lens") == LENS_KEYS
    assert _keys("lens.front", "lens.back") == SURFACE_KEYS
    assert _keys("analysis") == ANALYSIS_KEYS
    assert _keys("binocular") == BINOCULAR_KEYS
    assert _keys("points[0]") == POINT_KEYS
    assert _keys("render.scene") == SCENE_KEYS
    for r in RENDERERS:
        documented = {k.key for k in KEYS if k.table == "render" and k.renderer in (r, "all")}
        assert documented == set(renderer_keys(r)), r


def _spec(key, value):
    spec = copy.deepcopy(key.choice_base.get(value, key.base)
                         if isinstance(value, str) else key.base)
    node = spec
    for part in key.table.split("."):
        if part.endswith("]"):
            name, idx = part[:-1].split("[")
            node = node.setdefault(name, [{}])[int(idx)]
        else:
            node = node.setdefault(part, {})
    n = {"pair": 2, "triple": 3}.get(key.kind)
    node[key.key] = value if n is None else [value] * n
    return spec


def _field_refused(key, value):
    """The field a spec with ``value`` for ``key`` is refused for; None if accepted."""
    try:
        parse_spec(_spec(key, value))
    except SpecError as e:
        return e.field
    return None


def _names(key):
    return f"{key.table}.{key.key}"


RANGED = [k for k in KEYS if k.lo is not None]


@pytest.mark.parametrize("key", RANGED, ids=[f"{k.table}.{k.key}" for k in RANGED])
def test_every_range_holds_at_its_ends_and_not_beyond(key):
    integer = key.kind == "integer" or key.integers
    step = 1 if integer else 1e-6 * max(1.0, abs(key.hi - key.lo))
    if key.edges:
        if not key.lo_open:
            assert _field_refused(key, key.lo) is None
        assert _field_refused(key, key.hi) is None
    below = key.lo if key.lo_open else key.lo - step
    for value in (below, key.hi + step):
        assert (_field_refused(key, value) or "").startswith(_names(key)), value


CHOICES = [k for k in KEYS if k.choices]


@pytest.mark.parametrize("key", CHOICES, ids=[f"{k.table}.{k.key}" for k in CHOICES])
def test_every_choice_is_accepted_and_no_other(key):
    for c in key.choices:
        assert _field_refused(key, c) is None, c
    assert (_field_refused(key, "banana") or "").startswith(_names(key))


BOOLS = [k for k in KEYS if k.kind == "boolean"]


@pytest.mark.parametrize("key", BOOLS, ids=[f"{k.table}.{k.key}" for k in BOOLS])
def test_booleans(key):
    assert _field_refused(key, True) is None and _field_refused(key, False) is None
    assert (_field_refused(key, 1) or "").startswith(_names(key))


def test_the_reference_tables_are_generated():
    begin, end = "<!-- spec-reference: begin", "<!-- spec-reference: end -->"
    block = REFERENCE[REFERENCE.index(begin):REFERENCE.index(end)]
    block = block[block.index("\n") + 1:].strip()
    assert block == markdown().strip(), ("run: python -m eyelab.spec.docs --write "
                                         "docs/reference/spec.md")


def _literal(node):
    """A node's number if it is a numeric literal (signs, powers, differences), else None."""
    import ast

    try:
        v = ast.literal_eval(node)
    except (ValueError, TypeError, SyntaxError, MemoryError, RecursionError):
        return None
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else None


def _field_prefix(node):
    """The field name a validator call names: a string, or an f-string's leading text."""
    import ast

    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.JoinedStr) and node.values and isinstance(node.values[0],
                                                                        ast.Constant):
        return node.values[0].value
    return None


def ranges_written_again(sources):
    """(where, field) of every validator call in ``sources`` ({name: text}) that writes a
    schema field's range as literal numbers instead of taking it from where it is
    declared."""
    import ast

    from eyelab.spec.schema import declared

    fields = {f"{k.table}.{k.key}" for k in KEYS if k.lo is not None}
    bad = []
    for name, text in sources.items():
        for node in ast.walk(ast.parse(text)):
            if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                    and node.func.id in ("check_range", "check_int", "number")):
                continue
            args = node.args
            if node.func.id == "number":          # number(table, key, where, lo, hi)
                field = (f"{_field_prefix(args[2])}.{_field_prefix(args[1])}"
                         if len(args) >= 5 else None)
                nums = args[3:5]
            else:
                field = _field_prefix(args[0]) if args else None
                nums = args[2:4]
            if field is None or len(nums) < 2:
                continue
            if (declared(field.rstrip("[.").split("{")[0].rstrip("[.")) in fields
                    and _literal(nums[0]) is not None and _literal(nums[1]) is not None):
                bad.append(f"{name}:{node.lineno} {field}")
    return bad


def test_every_range_is_declared_once():
    """No validator in the package writes a schema field's range as numbers: each range
    lives where it is declared (an engine module's LIMITS or the schema's SPEC_LIMITS)."""
    root = Path(__file__).resolve().parents[1] / "eyelab"
    sources = {str(p.relative_to(root)): p.read_text() for p in root.rglob("*.py")}
    assert ranges_written_again(sources) == []


def test_the_range_check_sees_a_range_written_again():
    fake = ('def f(t, v):\n    check_range("eye.pupil_diameter_mm", v, 0.5, 10)\n'
            '    number(t, "wrap_deg", "lens", -30, 30)\n'
            '    check_range(f"lens.decentration_mm[{0}]", v, -20, 20)\n'
            '    check_range("eye.pupil_diameter_mm", v, *LIMITS["x"])\n')
    assert len(ranges_written_again({"fake.py": fake})) == 3


@pytest.mark.parametrize("kind, vertex_mm", [("refractive", 12.0), ("axial", 12.0),
                                             ("refractive", 20.0)])
def test_the_eye_rx_range_is_what_the_eye_accepts(kind, vertex_mm):
    """eye.rx's documented powers (derived from the eye's limits by eyelab.spec.eyerx) are
    accepted just inside and refused just outside, naming eye.rx and the range (the Rx
    grammar's own, where that binds first: a -30 D sphere at 20 mm)."""
    from eyelab.optics.eye.prescription import CYLINDER_RANGE, SPHERE_RANGE
    from eyelab.spec.eyerx import dioptres, eye_rx_ranges

    r = eye_rx_ranges(vertex_mm, kind)
    eye = {"kind": kind, "vertex_distance_mm": vertex_mm}
    for name, rx in (("sphere", "{:+.3f} DS"), ("cylinder", "plano {:+.3f} x 90")):
        lo, hi = r[name]
        for inside in (lo + 0.005, hi - 0.005):
            parse_spec({"eye": {**eye, "rx": rx.format(inside)}})
        grammar = SPHERE_RANGE if name == "sphere" else CYLINDER_RANGE
        for outside, end in ((lo - 0.005, lo), (hi + 0.005, hi)):
            with pytest.raises(SpecError) as e:
                parse_spec({"eye": {**eye, "rx": rx.format(outside)}})
            if end in grammar:
                assert e.value.field == f"eye.rx.{name}", e.value
            else:
                assert e.value.field == "eye.rx" and dioptres(lo, hi) in e.value.message


def test_the_reference_states_the_eye_rx_range_it_accepts():
    from eyelab.spec.eyerx import dioptres, eye_rx_ranges
    from eyelab.spec.schema import EYE_VERTEX_MM

    text = next(k for k in KEYS if (k.table, k.key) == ("eye", "rx")).range()
    for kind in ("refractive", "axial"):
        assert dioptres(*eye_rx_ranges(EYE_VERTEX_MM, kind)["sphere"]) in text
    assert dioptres(*eye_rx_ranges(EYE_VERTEX_MM)["cylinder"]) in text
    assert "±30" not in text and "add 0–4" not in text


def test_the_fixation_default_is_declared_once():
    """analysis.fixation defaults to the as-worn model for one eye and two alike, from the
    schema's DEFAULT_FIXATION (the reference shows it)."""
    from eyelab.spec import Spec
    from eyelab.spec.schema import DEFAULT_FIXATION, FIXATION_MEANINGS

    assert DEFAULT_FIXATION == "rotating" and set(FIXATION_MEANINGS) == {"fixed", "rotating"}
    assert parse_spec({}).fixation == DEFAULT_FIXATION
    assert parse_spec({"binocular": {}}).fixation == DEFAULT_FIXATION
    assert Spec.__dataclass_fields__["fixation"].default == DEFAULT_FIXATION
    key = next(k for k in KEYS if (k.table, k.key) == ("analysis", "fixation"))
    assert key.default == f'`"{DEFAULT_FIXATION}"`'


def test_a_camera_excludes_the_gaze():
    from eyelab.spec.schema import NOT_WITH

    assert ("gaze_deg", "camera") == NOT_WITH["render"][0][:2]
    cam = {"renderer": "reference", "camera": "doublet"}
    parse_spec({"render": cam})
    with pytest.raises(SpecError) as e:
        parse_spec({"render": {**cam, "gaze_deg": [0, 0]}})
    assert e.value.field == "render.gaze_deg" and "camera" in e.value.message
    with pytest.raises(SpecError) as e:
        parse_spec({"render": cam}).render.with_changes(gaze_deg=[5, 0])
    assert e.value.field == "render.gaze_deg"
