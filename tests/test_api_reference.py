"""The Python API reference (docs/reference/api.md): every public name of eyelab has an
entry there, under the name a user types, and an Examples section in its docstring whose
examples run as written (doctest) from a folder holding a copy of the repository's
examples/, at tiny sizes."""

from __future__ import annotations

import doctest
import importlib
import inspect
import re
import shutil
import time
from pathlib import Path

import pytest

import eyelab

ROOT = Path(__file__).resolve().parents[1]
API_PAGE = ROOT / "docs" / "reference" / "api.md"
NAMES = [name for name in eyelab.__all__ if name != "__version__"]
#: The data names: tuples, whose docs are the ``#:`` comments above their definitions.
DATA = [name for name in NAMES if isinstance(getattr(eyelab, name), tuple)]
#: A bound (s) on one name's examples together: tiny renders take a few seconds each.
SECONDS = 60.0


def public(name: str):
    """What ``eyelab.NAME`` documents: for ``eyelab.render`` (a callable that is also the
    GL package) the function it calls, else the object itself."""
    obj = getattr(eyelab, name)
    return obj if isinstance(obj, type) or not callable(obj) else inspect.unwrap(obj)


def doc_comment(name: str) -> tuple:
    """(text, line index) of the ``#:`` comment right above ``NAME = ...`` in the module
    that defines a data name: what Sphinx's autodoc shows for it."""
    lines = inspect.getsource(importlib.import_module(eyelab._API[name])).splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith(f"{name} = "))
    comment = []
    for line in reversed(lines[:at]):
        if not line.startswith("#:"):
            break
        comment.insert(0, line[3:] if line.startswith("#: ") else "")
    return "\n".join(comment), at - len(comment)


def documentation(name: str) -> str:
    return doc_comment(name)[0] if name in DATA else inspect.getdoc(public(name)) or ""


def doctests(name: str) -> list:
    """The doctests of ``eyelab.NAME``: its docstring's (and its methods') or its doc
    comment's."""
    if name in DATA:
        module = importlib.import_module(eyelab._API[name])
        text, line = doc_comment(name)
        test = doctest.DocTestParser().get_doctest(
            text, {}, f"eyelab.{name}", inspect.getsourcefile(module), line)
        tests = [test]
    else:
        tests = doctest.DocTestFinder().find(public(name), f"eyelab.{name}")
    return [t for t in tests if t.examples]


@pytest.mark.parametrize("name", NAMES)
def test_every_public_name_has_examples(name):
    doc = documentation(name)
    assert re.search(r"^Examples\n-{8,}\n", doc, flags=re.M), f"eyelab.{name}: {doc[:200]}"
    assert any(t.name == f"eyelab.{name}" for t in doctests(name)), name


@pytest.mark.parametrize("name", NAMES)
def test_the_examples_run_as_written(name, tmp_path, monkeypatch):
    if name == "NotebookInspector":
        pytest.importorskip("ipywidgets")
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    report = []
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    t0 = time.perf_counter()
    for test in doctests(name):
        test.globs = dict(test.globs)
        runner.run(test, out=report.append)
    took = time.perf_counter() - t0
    assert runner.tries > 0 and runner.failures == 0, "".join(report)
    assert took < SECONDS, f"eyelab.{name}'s examples took {took:.1f} s"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["examples"]   # nothing written


def test_the_reference_page_lists_every_public_name():
    text = API_PAGE.read_text()
    listed = re.findall(r"^ {3}eyelab\.(\w+)$", text, flags=re.M)     # autosummary rows
    assert sorted(listed) == sorted(NAMES), set(listed) ^ set(NAMES)
    assert len(listed) == len(set(listed))


def test_eyelab_render_is_documented_as_the_function():
    """Sphinx's autosummary takes ``eyelab.render`` as the function (its page documents
    ``eyelab.render(spec=None, ...)``), not as the GL package of the same name."""
    autosummary = pytest.importorskip("sphinx.ext.autosummary")
    import eyelab.render.raster  # noqa: F401  (the package imported too: the name must hold)

    name, obj, parent, modname = autosummary.import_by_name("eyelab.render")
    assert (name, modname, parent) == ("eyelab.render", "eyelab", eyelab)
    assert callable(obj) and not inspect.ismodule(obj)
    assert inspect.signature(obj) == inspect.signature(public("render"))
