import math

import numpy as np
import pytest

from eyelab.core.errors import SpecError
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import (
    GH_P_MIN,
    GH_P_MIN_PAPER,
    Eye,
    hofstetter_amplitude,
    watson_yellott_pupil,
)


def test_default_eye_is_emmetropic_and_table2_inconsistency_is_small():
    eye = Eye()
    assert eye.refraction() == pytest.approx((0.0, 0.0), abs=1e-12)
    assert GH_P_MIN == pytest.approx(58.6351, abs=1e-4)
    assert GH_P_MIN_PAPER - GH_P_MIN == pytest.approx(0.0049, abs=1e-4)


@pytest.mark.parametrize("age, mn, mean, mx", [
    (10, 12.5, 15.5, 21), (30, 7.5, 9.5, 13), (45, 3.75, 5.0, 7.0), (60, 0.0, 0.5, 1.0)])
def test_hofstetter_table(age, mn, mean, mx):  # docs/SCIENCE.md §3 table
    assert hofstetter_amplitude(age, "min") == pytest.approx(mn)
    assert hofstetter_amplitude(age, "mean") == pytest.approx(mean)
    assert hofstetter_amplitude(age, "max") == pytest.approx(mx)


@pytest.mark.parametrize("lum, age, want", [
    (0.01, 30, 7.05), (1, 30, 5.12), (100, 30, 2.89), (1e4, 30, 2.16),
    (0.01, 70, 5.18), (1, 70, 4.00), (100, 70, 2.63), (1e4, 70, 2.19)])
def test_watson_yellott_published_values(lum, age, want):
    # docs/SCIENCE.md §4 (calc), 60 deg binocular field
    assert watson_yellott_pupil(lum, age) == pytest.approx(want, abs=0.006)


@pytest.mark.parametrize("kind", ["refractive", "axial"])
def test_eye_from_rx_far_point_is_vertex_corrected_rx(kind):
    rx = Prescription(-3.0, -1.5, 30)
    eye = Eye.from_rx(rx, vertex_distance=0.012, kind=kind)
    k1, k2 = eye.refraction()
    want = sorted([-3.0 / (1 + 0.036), -4.5 / (1 + 0.054)])
    assert sorted([k1, k2]) == pytest.approx(want, abs=1e-12)
    # the stronger meridian of the eye is the more myopic one: 30 + 90 deg TABO -> wearer 60 deg
    assert eye.astigmatism_axis_deg == pytest.approx(60.0)
    if kind == "axial":
        assert eye.retina_distance > 0.022785


def test_accommodation_rule_eq13():
    eye = Eye(accommodation_max=3.0)
    # wave from 0.5 m (kbar = -2): the emmetrope needs 2 D
    assert eye.accommodation_for(-2.0) == pytest.approx(2.0)
    assert eye.accommodation_for(-5.0) == pytest.approx(3.0)  # limited by Delta_max
    assert eye.accommodation_for(+1.0) == 0.0                 # cannot relax below 0


def test_reduced_eye_near_and_far_points():
    eye = Eye.from_rx(Prescription(-2.0), vertex_distance=0.0, accommodation_max=3.0)
    red = eye.reduced()
    assert red.far_point == pytest.approx((0.5, 0.5))
    assert red.near_point == pytest.approx((0.2, 0.2))
    assert red.in_focus_range(np.array([0.3, 0.6, 0.15])).tolist() == [True, False, False]
    assert Eye().reduced().far_point == (math.inf, math.inf)


def test_bad_eye_parameters_name_the_field():
    with pytest.raises(SpecError, match="eye.pupil_diameter_mm"):
        Eye(pupil_diameter=0.02)
    with pytest.raises(SpecError, match="eye.kind"):
        Eye.from_rx(Prescription(-1.0), kind="lenticular")


def test_power_min_is_the_mean_power_as_the_spec_reference_says():
    """eye.power_min_d is the relaxed eye's mean power and astigmatism_d the meridians'
    difference: a spec eye of 60 D with 2 D has meridians of 61 and 59 D, and its far
    point's mean vergence is what the mean power alone gives."""
    from eyelab.spec.load import parse_spec
    from eyelab.spec.schema import KEYS

    eye = parse_spec({"eye": {"power_min_d": 60.0, "astigmatism_d": 2.0}}).eye
    assert eye.principal_powers() == pytest.approx((61.0, 59.0))
    meaning = next(k.meaning for k in KEYS if (k.table, k.key) == ("eye", "power_min_d"))
    assert "mean power" in meaning
