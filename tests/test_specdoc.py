"""The spec reference (eyelab/spec/docs.py) is the validator's truth: the same keys, every
range accepted at its ends and refused beyond (naming the key), every choice accepted and
a wrong one refused; the README's tables are generated from it."""

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
from eyelab.spec.docs import KEYS, markdown

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()


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
    spec = copy.deepcopy(key.base)
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


def test_the_readme_tables_are_generated():
    begin, end = "<!-- spec-reference: begin", "<!-- spec-reference: end -->"
    block = README[README.index(begin):README.index(end)]
    block = block[block.index("\n") + 1:].strip()
    assert block == markdown().strip(), "run: python -m eyelab.spec.docs --readme README.md"
