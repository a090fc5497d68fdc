import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from eyelab.core.errors import SpecError
from eyelab.optics.eye.prescription import Prescription, vertex_effective_power


@pytest.mark.parametrize("text, expect", [
    ("-2.25 -1.00 x 180", (-2.25, -1.0, 180.0, 0.0)),
    ("+1.50 DS", (1.5, 0.0, 180.0, 0.0)),
    ("pl -0.75 x 90 add +2.00", (0.0, -0.75, 90.0, 2.0)),
    ("plano", (0.0, 0.0, 180.0, 0.0)),
    ("+1.00 / -0.50 x 45", (1.0, -0.5, 45.0, 0.0)),
    ("-3.00 +1.25 × 10", (-3.0, 1.25, 10.0, 0.0)),
    ("+0.50 -0.25 X 0", (0.5, -0.25, 180.0, 0.0)),
    ("-4.00 DS -1.00 DC x 30", (-4.0, -1.0, 30.0, 0.0)),
    ("−1.25", (-1.25, 0.0, 180.0, 0.0)),
])
def test_parse_clinical_forms(text, expect):
    rx = Prescription.parse(text)
    assert (rx.sphere, rx.cylinder, rx.axis, rx.add) == expect


@pytest.mark.parametrize("text, field", [
    ("abc", "rx"), ("-2.00 -1.00", "rx"), ("-45 DS", "rx.sphere"),
    ("-2 -1 x 200", "rx.axis"), ("+1 add 7", "rx.add"), ("", "rx"),
])
def test_parse_errors_quote_input_and_name_field(text, field):
    with pytest.raises(SpecError) as ei:
        Prescription.parse(text)
    assert ei.value.field == field
    assert repr(text) in str(ei.value) or "allowed" in str(ei.value)


@pytest.mark.parametrize("text, expect", [
    # a cylinder alone is plano / cylinder x axis (these were misread as S + 5.00 C)
    ("-0.25 DC x 45", (0.0, -0.25, 45.0, 0.0)),
    ("-1.25 DC x 180", (0.0, -1.25, 180.0, 0.0)),
    ("-0.75 x 180", (0.0, -0.75, 180.0, 0.0)),
    ("-0.50 DC x 180", (0.0, -0.5, 180.0, 0.0)),
    ("-1.00 x 90", (0.0, -1.0, 90.0, 0.0)),
    ("-0.25DCx45", (0.0, -0.25, 45.0, 0.0)),
    # common clinical spellings
    ("+1.50 D.S.", (1.5, 0.0, 180.0, 0.0)), ("+1.50 DS.", (1.5, 0.0, 180.0, 0.0)),
    ("+1.50 D", (1.5, 0.0, 180.0, 0.0)), ("+1.50D", (1.5, 0.0, 180.0, 0.0)),
    ("-3.00D", (-3.0, 0.0, 180.0, 0.0)),
    ("+1.00 Add: +2.50", (1.0, 0.0, 180.0, 2.5)),
    ("-1.00 add 2.00 D", (-1.0, 0.0, 180.0, 2.0)),
    ("+0.75 ADD +2.50D", (0.75, 0.0, 180.0, 2.5)),
    ("-1,00 -0,50 x 180", (-1.0, -0.5, 180.0, 0.0)),
    ("Pl + 2.00 x 30", (0.0, 2.0, 30.0, 0.0)),
    ("OD -2.00 sph -0.50 cyl axis 90°", (-2.0, -0.5, 90.0, 0.0)),
    ("-2.00 -0.50 @ 45", (-2.0, -0.5, 45.0, 0.0)),
    ("+2.00 -1.00 ax 120", (2.0, -1.0, 120.0, 0.0)),
    ("\uff0b1.25 \u2212 0.50 x 60", (1.25, -0.5, 60.0, 0.0)),
])
def test_clinical_spellings_and_pure_cylinders(text, expect):
    rx = Prescription.parse(text)
    assert (rx.sphere, rx.cylinder, rx.axis, rx.add) == expect


@pytest.mark.parametrize("text, eye", [("R -1.00", "R"), ("L -1.00 DS", "L"),
                                       ("OD +1.00", "R"), ("OS plano", "L"),
                                       ("-1.00 OU", "OU"), ("-1.00", None)])
def test_eye_prefix_and_suffix_are_kept(text, eye):
    rx = Prescription.parse(text)
    assert rx.eye == eye
    assert Prescription.parse(rx.format()) == rx


@pytest.mark.parametrize("text", [
    "-2.00 DC",                 # a cylinder without axis
    "+1.00 DS x 90",            # a sphere with an axis
    "-1.00 -0.50 -0.25 x 90",   # three powers
    "-1.00 -0.50 x 90 x 45",    # two axes
    "-1.00 -0.50 x -45",        # a signed axis
    "R -1.00 L",                # two eyes
    "-0.50 DC -1.00 DS x 90",   # cylinder before sphere
    "Add: +2.50",               # no distance power
    "-1.00 add",                # an add without power
])
def test_ambiguous_or_incomplete_is_an_error_quoting_the_input(text):
    with pytest.raises(SpecError) as ei:
        Prescription.parse(text)
    assert repr(text) in str(ei.value)


def test_parsing_is_linear_time():
    import time

    for text in ("-3" + " " * 400 + "!", "-3 " * 5000, "x" * 10_000, "-" + "1" * 10_000):
        t = time.perf_counter()
        with pytest.raises(SpecError):
            Prescription.parse(text)
        assert time.perf_counter() - t < 0.05


def _spellings(rx):
    """Clinically valid spellings of a grid Rx (signs, units, separators, axis markers,
    zero-padding, decimal commas, eye prefixes, add forms)."""
    import itertools

    def num(v, comma=False):
        t = f"{v:+.2f}"
        return t.replace(".", ",") if comma else t

    out = []
    for sph_u, cyl_u, sep, ax_m, pad, comma, eye, add_f in itertools.islice(
            itertools.product(["", " DS", "D", " sph"], ["", " DC", " cyl"], [" ", " / "],
                              [" x ", " × ", " @ ", "ax"], [False, True], [False, True],
                              ["", "R ", "OS "], ["add {}", "Add: {}", "ADD {}D"]), 0, None,
            37):
        if rx.sphere == 0:
            sph = "pl" if sph_u == "" else "plano"
        else:
            sph = num(rx.sphere, comma) + sph_u
        if rx.cylinder == 0:
            body = sph if sph_u or rx.sphere == 0 else sph + " DS"
        else:
            ax = f"{rx.axis:03.0f}" if pad else f"{rx.axis:g}"
            body = f"{sph}{sep}{num(rx.cylinder, comma)}{cyl_u}{ax_m}{ax}"
        if rx.add:
            body += " " + add_f.format(num(rx.add, comma))
        out.append((eye + body, {"": None, "R ": "R", "OS ": "L"}[eye]))
    return out


@given(st.integers(-80, 80), st.integers(-32, 32), st.integers(1, 180),
       st.sampled_from([0.0, 0.75, 1.0, 1.5, 2.0, 2.25, 2.5, 3.0, 3.5]))
def test_every_spelling_of_every_grid_rx_parses_to_it(s4, c4, axis, add):
    """The quarter-dioptre grid (sphere +-20, cylinder +-8, every axis, adds): format()
    round-trips, and every accepted spelling parses to the intended Rx (a property test:
    misreads are impossible by construction, not by luck)."""
    rx = Prescription(s4 / 4, c4 / 4, float(axis), add)
    assert Prescription.parse(rx.format()) == rx
    assert Prescription.parse(rx.format(plus_cylinder=True)).power_vector() == \
        pytest.approx(rx.power_vector(), abs=1e-12)
    for text, eye in _spellings(rx):
        got = Prescription.parse(text)
        want = rx if rx.cylinder else Prescription(rx.sphere, 0.0, 180.0, rx.add)
        assert got == Prescription(want.sphere, want.cylinder, want.axis, want.add, eye), text


def test_format_and_transpose():
    rx = Prescription(-2.25, -1.0, 180)
    assert rx.format() == "-2.25 / -1.00 x 180"
    assert Prescription(-2.25, -1.0, 10).format() == "-2.25 / -1.00 x 010"
    t = rx.transpose()
    assert (t.sphere, t.cylinder, t.axis) == (-3.25, 1.0, 90.0)
    assert t.transpose() == rx
    assert Prescription.parse(rx.format()) == rx
    assert Prescription(1.5).format() == "+1.50 DS"


def test_power_vector_published_example():
    # Thibos 1997 definitions: -2.00 -1.00 x 90 -> M = -2.5, J0 = -0.5, J45 = 0 (calc)
    m, j0, j45 = Prescription(-2.0, -1.0, 90).power_vector()
    assert (m, j0) == pytest.approx((-2.5, -0.5))
    assert abs(j45) < 1e-15


rx_strategy = st.builds(
    Prescription,
    st.floats(-20, 20), st.floats(-8, 8), st.floats(1, 180), st.floats(0, 3.5))


@given(rx_strategy)
def test_power_vector_round_trip_and_transposition_invariance(rx):
    back = Prescription.from_power_vector(*rx.power_vector(), add=rx.add)
    np.testing.assert_allclose(back.power_matrix(), rx.power_matrix(), atol=1e-9)
    np.testing.assert_allclose(rx.transpose().power_vector(), rx.power_vector(), atol=1e-9)


@given(rx_strategy, st.floats(0, 180))
def test_sine_squared_law_matches_power_matrix(rx, theta):
    # meridian theta (TABO) is direction 180 - theta in the wearer's frame
    w = math.radians(180.0 - theta)
    t = np.array([math.cos(w), math.sin(w)])
    assert t @ rx.power_matrix() @ t == pytest.approx(float(rx.meridian_power(theta)), abs=1e-9)


def test_power_matrix_wearer_frame_j45_flips():
    rx = Prescription(0.0, -2.0, 45)
    m, j0, j45 = rx.power_vector()
    f = rx.power_matrix()
    np.testing.assert_allclose(f, [[m + j0, -j45], [-j45, m - j0]], atol=1e-12)


def test_vertex_effective_power_published_numbers():
    # docs/SCIENCE.md §2 (calc): -6.00 D at 12 mm -> -5.60 D; +10.00 D -> +11.36 D
    assert vertex_effective_power(-6.0, 0.012) == pytest.approx(-5.597, abs=5e-4)
    assert vertex_effective_power(10.0, 0.012) == pytest.approx(11.364, abs=5e-4)


@pytest.mark.slow
def test_format_round_trips_over_the_whole_grid():
    """Every quarter-dioptre sphere (+-20) and cylinder (+-8) at every whole axis, with and
    without an add: parse(format(rx)) == rx in both cylinder forms (~1.9 M cases)."""
    for s4 in range(-80, 81):
        for c4 in range(-32, 33):
            for axis in range(1, 181):
                for add in (0.0, 2.25):
                    rx = Prescription(s4 / 4, c4 / 4, float(axis), add)
                    assert Prescription.parse(rx.format()) == rx


@pytest.mark.parametrize("text", [
    "-3.00 / / -1.00 x 90", "-3.00 /", "/ -3.00", "-3.00 / -1.00 / x 90",
    "-1.00 x 90 / -2.00", "R / -1.00", "-2.00° -1.00 x 90", "-1.00,, -0.50 x 180",
    "-1.00 -0.50 x 90 /", "-2.00 / +1.00 x 90 add / 2",
])
def test_a_misplaced_separator_is_an_error_quoting_the_input(text):
    with pytest.raises(SpecError) as ei:
        Prescription.parse(text, field="eye.rx")
    assert ei.value.field == "eye.rx" and "misplaced" in str(ei.value)
    assert repr(text) in str(ei.value)


@pytest.mark.parametrize("text, expect", [
    ("-3.00 / -1.00 x 90", (-3.0, -1.0, 90.0)), ("R -1.00 / -0.50 x 180", (-1.0, -0.5, 180.0)),
    ("pl / -0.50 x 90", (0.0, -0.5, 90.0)), ("-2.00 DS / -1.00 DC x 30", (-2.0, -1.0, 30.0)),
    ("-2.00 -1.00 x 90°", (-2.0, -1.0, 90.0)), ("OD: -2.00 / -1.00 x 180", (-2.0, -1.0, 180.0)),
    ("-2.00 / -1.00 x 180, add +2.00", (-2.0, -1.0, 180.0)),
])
def test_separators_where_clinicians_write_them(text, expect):
    rx = Prescription.parse(text)
    assert (rx.sphere, rx.cylinder, rx.axis) == expect
