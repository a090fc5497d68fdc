import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from eyelab.errors import SpecError
from eyelab.optics.prescription import Prescription, vertex_effective_power


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


def test_format_and_transpose():
    rx = Prescription(-2.25, -1.0, 180)
    assert rx.format() == "-2.25 / -1.00 x 180"
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
    # SCIENCE.md §2 (calc): -6.00 D at 12 mm -> -5.60 D; +10.00 D -> +11.36 D
    assert vertex_effective_power(-6.0, 0.012) == pytest.approx(-5.597, abs=5e-4)
    assert vertex_effective_power(10.0, 0.012) == pytest.approx(11.364, abs=5e-4)
