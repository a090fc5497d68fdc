"""A schematic eye from a spec: ``eyelab analyze`` and ``eyelab maps --kind peripheral``,
the refusals of what takes the thin eye only, and the published trends of peripheral
refraction."""

from __future__ import annotations

import json

import numpy as np
import pytest

from eyelab.apps.cli import main
from eyelab.core.errors import SpecError
from eyelab.spec import parse_spec

MYOPE = """[eye]
model = "navarro"
rx = "-3.00"
{extra}
[lens]
rx = "-3.00"
"""
EMMETROPE = """[eye]
model = "navarro"
{extra}"""


def _maps(tmp_path, text, name):
    spec = tmp_path / f"{name}.toml"
    spec.write_text(text.format(extra=""))
    out, js = tmp_path / f"{name}.png", tmp_path / f"{name}.json"
    assert main(["maps", str(spec), "-o", str(out), "--json", str(js), "--half-angle", "40",
                 "--points", "9"]) == 0
    assert out.stat().st_size > 20000
    return json.loads(js.read_text())


@pytest.mark.parametrize("name, text", [("emmetrope", EMMETROPE), ("myope", MYOPE)])
def test_the_map_equals_analysis_at_its_eccentricities(tmp_path, name, text):
    """The acceptance: every value on the map's horizontal and vertical profiles equals
    ``eyelab analyze``'s for the same object (<= 1e-6 D), naked and through the lens, each
    with its default accommodation (the fixation's)."""
    rep = _maps(tmp_path, text, name)
    for part in ("naked", "lens"):
        if rep[part] is None:
            continue
        rows = [p for meridian in ("horizontal", "vertical")
                for p in rep[part]["profiles"][meridian]["points"]][::5]
        points = "".join(f"\n[[points]]\nfield_deg = [{p['object_field_deg'][0]!r}, "
                         f"{p['object_field_deg'][1]!r}]\n" for p in rows)
        spec = tmp_path / f"{name}-{part}.toml"
        spec.write_text(text.format(extra="")
                        + '\n[analysis]\nfixation = "fixed"\n' + points)
        out = tmp_path / f"{name}-{part}-analyze.json"
        flags = ["--no-lens"] if part == "naked" else []
        assert main(["analyze", str(spec), "--json", "-o", str(out), *flags]) == 0
        got = json.loads(out.read_text())["points"]
        assert len(got) == len(rows)
        for p, q in zip(rows, got, strict=True):
            for key in ("m_d", "j0_d", "j45_d", "tangential_d", "sagittal_d"):
                assert abs(p[key] - q[key]) <= 1e-6, (part, key, p[key], q[key])
            assert abs(p["eccentricity_deg"] - q["eccentricity_deg"]) <= 1e-9
            assert q["accommodation_d"] == pytest.approx(rep[part]["accommodation_d"],
                                                         abs=1e-12)


def test_single_vision_correction_leaves_peripheral_hyperopia(tmp_path):
    """Published trends, as signs and ranges (a schematic eye is one eye, not a
    population): an axial myope's periphery is relatively hyperopic along the horizontal
    meridian (Atchison, Pritchard & Schmid 2006, Vision Res 46:1450), the single-vision
    lens that corrects its fovea makes it more so (Lin et al. 2010, Optom Vis Sci 87:4:
    the rationale of myopia-control lenses), and the emmetropic eye's oblique astigmatism
    at 30 deg is in the 1.5-3 D that measured eyes show there (Gustafsson et al. 2001,
    Ophthalmic Physiol Opt 21:393)."""
    myope = _maps(tmp_path, MYOPE, "m")
    emm = _maps(tmp_path, EMMETROPE, "e")

    def at(part, deg):
        prof = part["profiles"]["horizontal"]
        return prof["points"][prof["field_deg"].index(deg)]

    for deg in (-30.0, 30.0):
        naked, lens = at(myope["naked"], deg)["rpr_d"], at(myope["lens"], deg)["rpr_d"]
        assert 0.2 < naked < 1.5 and lens > naked
        row = at(emm["naked"], deg)
        assert 1.5 < row["sagittal_d"] - row["tangential_d"] < 3.0
    assert abs(myope["lens"]["m_on_axis_d"]) < 0.01


@pytest.mark.parametrize("eye, field, words", [
    ({"model": "navarro", "chromatic": False}, "eye.chromatic", "not read by the navarro"),
    ({"model": "navarro", "power_min_d": 60}, "eye.power_min_d", "not read by the navarro"),
    ({"axial_length_mm": 24}, "eye.axial_length_mm", "only read by a schematic eye"),
    ({"model": "navarro", "axial_length_mm": 15}, "eye.axial_length_mm", "16"),
    ({"model": "navarro", "rx": "-2.00 / -1.00 x 90"}, "eye.rx", "no cylinder"),
    ({"model": "navarro", "age": 10}, "eye.age", "0-10 D"),
    ({"model": "navarro", "rx": "-3", "axial_length_mm": 24}, "eye.axial_length_mm",
     "either"),
    ({"model": "gullstrand"}, "eye.model", "'thin', 'navarro'"),
])
def test_bad_schematic_eyes_are_refused_by_name(eye, field, words):
    with pytest.raises(SpecError) as e:
        parse_spec({"eye": eye})
    assert e.value.field == field and words in str(e.value)


def test_a_peripheral_map_needs_a_schematic_eye(tmp_path, capsys):
    assert main(["maps", "--kind", "peripheral", "-o", str(tmp_path / "m.png")]) == 2
    assert "eye.model" in capsys.readouterr().err
    assert not (tmp_path / "m.png").exists()


def test_analyze_text_of_a_schematic_eye(tmp_path, capsys):
    spec = tmp_path / "s.toml"
    spec.write_text(MYOPE.format(extra="") + '\n[analysis]\nfixation = "fixed"\n'
                    "[[points]]\nfield_deg = [25, 0]\n")
    assert main(["analyze", str(spec)]) == 0
    text = capsys.readouterr().out
    assert "navarro schematic eye" in text and "refraction M +" in text
    assert np.isfinite(float(text.split("refraction M ")[1].split(" D")[0]))


def test_the_guides_numbers_are_the_maps(tmp_path):
    """docs/guide/schematic-eye.md quotes the example's RPR at +-30 deg, naked and through
    the lens, from this command's output."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    guide = (root / "docs" / "guide" / "schematic-eye.md").read_text()
    js = tmp_path / "m.json"
    assert main(["maps", str(root / "examples" / "myope.toml"), "-o", str(tmp_path / "m.png"),
                 "--json", str(js)]) == 0
    rep = json.loads(js.read_text())
    for part in ("naked", "lens"):
        prof = rep[part]["profiles"]["horizontal"]
        rpr = prof["points"][prof["field_deg"].index(30.0)]["rpr_d"]
        assert f"{rpr:+.2f} D" in guide, (part, rpr)
    assert (root / "docs" / "gallery" / "myope-periphery.png").is_file()


def test_the_demo_shows_a_schematic_eye_and_its_emmetrope(tmp_path):
    """``eyelab demo`` of a Navarro myope: uncorrected, with its lens, and the emmetrope of
    the same model (its axial length shortened by about 0.37 mm per dioptre of the
    myope's ocular refraction, SCIENCE.md §5), each panel the image a renderer draws of
    that eye alone."""
    import json

    from PIL import Image

    from eyelab.imaging.contract import View
    from eyelab.imaging.options import RasterQuality
    from eyelab.optics.eye.schematic import SchematicEye
    from eyelab.render.raster import RasterRenderer
    from eyelab.scene.library import room_scene

    spec = tmp_path / "s.toml"
    spec.write_text(MYOPE.format(extra="") + "[render]\nwidth = 64\nheight = 48\n"
                    "samples = 4\nscene = \"room\"\n")
    out = tmp_path / "d.png"
    assert main(["demo", str(spec), "-o", str(out)]) == 0
    rep = json.loads(out.with_suffix(".json").read_text())
    assert list(rep["panels"]) == ["uncorrected", "with the lens", "emmetrope"]
    myope, emm = rep["eye"], rep["emmetrope"]
    assert myope["model"] == emm["model"] == "navarro"
    ocular = 3.0 / (1 + 0.012 * 3.0)                          # -3.00 at 12 mm, at the eye
    assert myope["axial_length_mm"] - emm["axial_length_mm"] == pytest.approx(
        0.37 * ocular, rel=0.1)
    with RasterRenderer(RasterQuality(samples=4)) as r:
        alone = r.render(room_scene(), SchematicEye(axial_length=emm["axial_length_mm"] / 1e3),
                         None, View(width=64, height=48)).srgb
    with Image.open(out) as im:
        fig = np.asarray(im.convert("RGB"))
    # the emmetrope's panel (the third, under its label band) is the image of that eye
    # alone, inside the panel's frame
    h, w = alone.shape[:2]
    panel = fig[fig.shape[0] - h:, 2 * w:3 * w]
    np.testing.assert_array_equal(panel[2:-2, 2:-2], alone[2:-2, 2:-2])


def test_as_worn_maps_of_a_schematic_wearer_are_its_lenss(tmp_path, capsys):
    """As-worn maps are the lens's, about the wearer's centre of rotation: a schematic
    eye's spec maps its lens as a thin eye with that centre and pupil does; a two-eye spec
    maps the side --eye names."""
    import eyelab

    m = eyelab.maps("examples/myope.toml", n=5)
    t = eyelab.maps({"eye": {"rx": "-3.00", "rotation_centre_mm": 13.5,
                             "pupil_diameter_mm": 4}, "lens": {"rx": "-3.00"}}, n=5)
    np.testing.assert_array_equal(m.mean_error_d, t.mean_error_d)
    assert abs(m.mean_error_d[2, 2]) < 0.01                  # straight ahead: the Rx
    two = tmp_path / "two.toml"
    two.write_text('[eye.right]\nrx = "-3.00"\n[eye.left]\nrx = "-2.00"\n[lens]\n')
    left = eyelab.maps(str(two), n=5, eye="left")
    assert main(["maps", str(two), "--eye", "left", "--points", "5",
                 "-o", str(tmp_path / "l.png")]) == 0
    assert (tmp_path / "l.png").exists() and np.isfinite(left.mean_error_d).all()
    assert main(["maps", str(two), "--points", "5", "-o", str(tmp_path / "x.png")]) == 2
    assert "--eye right|left" in capsys.readouterr().err
