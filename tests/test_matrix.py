"""The capability matrix (eyelab.apps.matrix, docs/guide/matrix.md): every eye with every
lens in every command, run as a user runs it. No cell may be broken (an exception, a
traceback, another exit than 0 or 2, or more than one line); a refusal is one line naming
the field. The page is what the matrix gives (the full run is slow: `-m slow`); a few
cells of each eye run in the default suite."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from eyelab.apps.matrix import COMMANDS, EYES, LENSES, matrix, table

ROOT = Path(__file__).resolve().parents[1]
FIELD = re.compile(r"^[-\w.\[\]\"]+( \([-\w.\[\]\"]+\))?: \S")


def _check(results):
    broken = {k: v for k, v in results.items() if v[0] == "broken"}
    assert not broken, broken
    for k, (outcome, line) in results.items():
        if outcome == "refuses":
            assert FIELD.match(line), (k, line)


@pytest.mark.parametrize("eye", list(EYES))
def test_each_eye_analyzes_and_its_psf_through_a_sphere(eye):
    """analyze works for every eye; psf for one eye, and for two it asks for --eye in one
    line (the page's refusal)."""
    got = matrix(eyes=[eye], lenses=["sphere"], commands=["analyze", "psf"])
    _check(got)
    assert got[eye, "sphere", "analyze"] == ("works", "")
    outcome, line = got[eye, "sphere", "psf"]
    if eye.startswith("two"):
        assert outcome == "refuses" and "--eye right/left" in line.replace("|", "/"), line
    else:
        assert (outcome, line) == ("works", "")


@pytest.mark.slow
def test_the_whole_matrix_has_no_broken_cell_and_is_the_page():
    results = matrix()
    assert len(results) == len(EYES) * len(LENSES) * len(COMMANDS)
    _check(results)
    assert (ROOT / "docs" / "guide" / "matrix.md").read_text() == table(results)


def test_a_schematic_eye_in_the_inspector_and_a_cameras_row():
    """The inspector takes a schematic eye; a camera spec's row: eye-only commands refuse
    naming render.camera (a camera has no eye), surface has no spectacle lens to write."""
    got = matrix(eyes=["Navarro"], lenses=["points file", "camera"],
                 commands=["inspect", "surface", "analyze"])
    _check(got)
    assert got["Navarro", "points file", "inspect"] == ("works", "")
    assert got["Navarro", "points file", "surface"] == ("works", "")
    for cn in ("inspect", "surface", "analyze"):
        outcome, line = got["Navarro", "camera", cn]
        assert outcome == "refuses" and line.startswith("render.camera: "), line


def test_the_api_columns_and_batch_for_two_eyes():
    """The Python API and batch take a two-eye spec: render and analyze work, maps and psf
    ask for the ``eye`` argument by its Python name, batch renders both eyes."""
    got = matrix(eyes=["two thin"], lenses=["sphere"],
                 commands=["API render", "API analyze", "API maps", "API psf", "batch"])
    _check(got)
    for cn in ("API render", "API analyze", "batch"):
        assert got["two thin", "sphere", cn] == ("works", ""), cn
    for cn, what in (("API maps", "eyelab.maps"), ("API psf", "eyelab.psf")):
        outcome, line = got["two thin", "sphere", cn]
        assert outcome == "refuses" and line.startswith(f"binocular: {what} shows one eye")
        assert line.endswith('pick one with eye="right" or eye="left"'), line
