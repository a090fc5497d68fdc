import numpy as np
import pytest

from eyelab.core.color import MACHADO, linear_to_srgb, machado_matrix, simulate_cvd, srgb_to_linear
from eyelab.core.errors import SpecError


def test_severity_one_matches_the_reference_sheet():
    # docs/SCIENCE.md §9 (Machado 2009, severity 1.0)
    np.testing.assert_array_equal(machado_matrix("protan", 1.0)[0],
                                  [0.152286, 1.052583, -0.204868])
    np.testing.assert_array_equal(machado_matrix("tritan", 1.0)[2], [0.004733, 0.691367, 0.3039])


@pytest.mark.parametrize("kind", ["protan", "deutan", "tritan"])
def test_interpolation_between_tables(kind):
    tab = MACHADO[kind]
    # halfway between 0.2 and 0.3 — the weights neither reversed, extrapolated nor unscaled
    np.testing.assert_allclose(machado_matrix(kind, 0.25), 0.5 * (tab[2] + tab[3]), atol=1e-12)
    np.testing.assert_allclose(machado_matrix(kind, 0.21), 0.9 * tab[2] + 0.1 * tab[3],
                               atol=1e-12)
    np.testing.assert_allclose(machado_matrix(kind, 0.3), tab[3], atol=1e-12)
    np.testing.assert_allclose(machado_matrix(kind, 0.0), np.eye(3), atol=1e-12)
    # rows sum to 1: greys stay grey (docs/SCIENCE.md §9, calc)
    np.testing.assert_allclose(machado_matrix(kind, 0.37).sum(1), 1.0, atol=2e-6)


def test_applied_in_linear_rgb_and_greys_unchanged():
    img = np.array([[[200, 30, 30], [128, 128, 128]]], np.uint8)
    out = simulate_cvd(img, "deutan", 1.0)
    lin = srgb_to_linear(img[0, 0] / 255.0)
    want = np.round(linear_to_srgb(machado_matrix("deutan", 1.0) @ lin) * 255)
    np.testing.assert_array_equal(out[0, 0], want)
    assert np.abs(out[0, 1].astype(int) - 128).max() <= 1
    grey = simulate_cvd(img, "achromat", 1.0)
    assert grey[0, 0, 0] == grey[0, 0, 1] == grey[0, 0, 2]


def test_srgb_round_trip_and_threshold():
    c = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(linear_to_srgb(srgb_to_linear(c)), c, atol=1e-12)
    assert srgb_to_linear(0.04045) == pytest.approx(0.04045 / 12.92)


def test_bad_cvd_arguments():
    with pytest.raises(SpecError, match="cvd"):
        machado_matrix("purple", 0.5)
    with pytest.raises(SpecError, match="cvd_severity"):
        machado_matrix("protan", 1.5)
