"""Every JSON report eyelab writes declares its units first (``"units"``:
:data:`eyelab.core.fileio.REPORT_UNITS`) and keeps them: the eye in the demo's report is
written as the spec's keys (mm, D), not the engine's SI values. The demo's panels are framed
and their labels fit their panels."""

import json

import numpy as np
import pytest

from eyelab.apps.cli import main
from eyelab.core.fileio import REPORT_UNITS

TINY = ["--samples", "1", "--width", "48", "--height", "36", "--quiet"]
#: A spec whose eye values are not the defaults, so a report that echoes the defaults (or
#: the engine's metres) cannot pass.
SPEC = ('[eye]\nrx = "-2.00 -0.50 x 90"\npupil_diameter_mm = 3.3\nrotation_centre_mm = 12.0\n'
        '[lens]\nrx = "-2.00 -0.50 x 90"\n[render]\nscene = "chart"\nfield_shape = [8, 8, 8]\n')


def _pairs(text: str) -> list:
    """The top-level (key, value) pairs of a JSON text, in the order written."""
    return json.loads(text, object_pairs_hook=lambda kv: kv)


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """Each report writer of the command line, run once on small inputs: {name: JSON text}."""
    d = tmp_path_factory.mktemp("reports")
    spec = d / "s.toml"
    spec.write_text(SPEC)
    runs = {"analyze file": (["analyze", str(spec), "-o", str(d / "a.json")], d / "a.json"),
            "render": (["render", str(spec), "-o", str(d / "r.png"), "--report",
                        str(d / "r.json"), *TINY], d / "r.json"),
            "demo": (["demo", str(spec), "-o", str(d / "d.png"), *TINY], d / "d.json"),
            "maps": (["maps", str(spec), "-o", str(d / "m.png"), "--json", str(d / "m.json"),
                      "--points", "5"], d / "m.json"),
            "psf": (["psf", str(spec), "-o", str(d / "p.npy"), "--json", str(d / "p.json"),
                     "--size", "9"], d / "p.json")}
    out = {}
    for name, (argv, path) in runs.items():
        assert main(argv) == 0, name
        out[name] = path.read_text()
    return out


def test_every_report_starts_with_its_units(written, capsys):
    capsys.readouterr()
    assert main(["analyze", "--json"]) == 0
    texts = dict(written, **{"analyze --json": capsys.readouterr().out})
    for name, text in texts.items():
        first = _pairs(text)[0]
        assert first == ("units", REPORT_UNITS), name


def test_the_demo_writes_the_eye_in_the_specs_units(written):
    """The spec says pupil 3.3 mm and centre of rotation 12 mm: so does the demo's JSON
    (the engine holds 0.0033 m and 0.012 m), for the eye and its emmetrope, under the spec's
    key names; the engine's SI names are gone."""
    rep = json.loads(written["demo"])
    for who in ("eye", "emmetrope"):
        eye = rep[who]
        assert eye["pupil_diameter_mm"] == pytest.approx(3.3, abs=1e-12)
        assert eye["rotation_centre_mm"] == pytest.approx(12.0, abs=1e-12)
        assert eye["retina_distance_mm"] == pytest.approx(22.785, abs=1e-9)
        assert not {"pupil_diameter", "retina_distance", "rotation_centre",
                    "power_min"} & set(eye)
    assert rep["emmetrope"]["astigmatism_d"] == 0.0
    # the Rx's cylinder at the cornea: ocular refraction K = F / (1 - d F), d = 12 mm
    k = [f / (1 - 0.012 * f) for f in (-2.0, -2.5)]
    assert rep["eye"]["astigmatism_d"] == pytest.approx(k[0] - k[1], abs=1e-9)
    assert json.loads(written["analyze file"])["eye"]["pupil_diameter_mm"] == \
        pytest.approx(3.3, abs=1e-12)


def test_eye_table_is_the_spec_that_makes_the_eye():
    """The spec's own parser, given the table a report writes, makes the same eye (the
    aberrations included): the table is in the spec's units and names."""
    from eyelab.jobs.analyze import eye_table
    from eyelab.spec.parse import parse_eye

    eye = parse_eye({"rx": "+1.25 -0.75 x 30", "pupil_diameter_mm": 5.0, "age": 30,
                     "rotation_centre_mm": 14.0, "chromatic": False,
                     "aberrations": {"coefficients_um": [0] * 7 + [0.05, 0, 0, 0, 0, 0.1],
                                     "pupil_mm": 6.0}})
    again = parse_eye(json.loads(json.dumps(eye_table(eye))))
    for field in ("power_min", "astigmatism", "astigmatism_axis_deg", "accommodation_max",
                  "retina_distance", "n_vitreous", "pupil_diameter", "rotation_centre"):
        assert getattr(again, field) == pytest.approx(getattr(eye, field), rel=1e-12), field
    assert again.chromatic is False
    assert again.aberrations == eye.aberrations


def test_demo_panels_are_framed_and_labels_fit():
    """A white and a black panel: the pixels on each panel's edge are the frame's grey (a
    white panel's interior stays white); long labels stay inside their own column."""
    from eyelab.jobs.render import LABEL_BAND_PX, panel_figure

    h, w = 60, 100
    white = np.full((h, w, 3), 255, np.uint8)
    black = np.zeros((h, w, 3), np.uint8)
    label = "right eye, with the lenses"       # wider than the panel at the largest size
    img = panel_figure([[(label, white), (label, black), (label, white)]])
    assert img.shape == (h + LABEL_BAND_PX, 3 * w, 3)
    top, mid = LABEL_BAND_PX, LABEL_BAND_PX + h // 2
    for i, bg in enumerate((255, 0, 255)):
        x0 = i * w
        edges = [img[mid, x0], img[mid, x0 + w - 1], img[top, x0 + w // 2],
                 img[top + h - 1, x0 + w // 2]]
        for px in edges:
            assert 64 <= int(px[0]) <= 192 and abs(int(px[0]) - bg) >= 60, (i, px)
        np.testing.assert_array_equal(img[mid, x0 + w // 2], [bg] * 3)
    ink = img[:LABEL_BAND_PX].min(axis=2) < 128          # the labels' dark pixels
    cols = np.flatnonzero(ink.any(axis=0))
    assert ink.any(axis=1).sum() >= 15                   # legible: a real height of text
    for i in range(3):
        mine = cols[(cols >= i * w) & (cols < (i + 1) * w)]
        assert mine.size and mine.min() >= i * w + 2 and mine.max() <= (i + 1) * w - 3, i


def test_binocular_demo_prints_a_line_per_eye(tmp_path, capsys):
    out = tmp_path / "b.png"
    assert main(["demo", "-o", str(out), "--binocular", *TINY]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1:] == [f"  {side} eye: uncorrected | with the lenses | emmetropes"
                         for side in ("right", "left")]
    rep = json.loads(out.with_suffix(".json").read_text())
    assert next(iter(rep)) == "units"
    assert rep["eye"]["right"]["pupil_diameter_mm"] == pytest.approx(4.0, abs=1e-12)
    assert set(rep["panels"]) == {f"{s} eye, {c}" for s in ("right", "left")
                                  for c in rep["rows"][f"{s} eye"]}
