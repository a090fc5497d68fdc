import pytest

from eyelab.errors import SpecError
from eyelab.optics.materials import (
    CATALOGUE,
    LAMBDA_C_NM,
    LAMBDA_D_NM,
    LAMBDA_F_NM,
    get_material,
)


@pytest.mark.parametrize("name", [k for k in CATALOGUE if k != "air"])
def test_cauchy_reproduces_nd_and_abbe(name):
    m = CATALOGUE[name]
    assert m.n(LAMBDA_D_NM) == pytest.approx(m.n_d, abs=1e-12)
    v = (m.n(LAMBDA_D_NM) - 1) / (m.n(LAMBDA_F_NM) - m.n(LAMBDA_C_NM))
    assert v == pytest.approx(m.v_d, rel=1e-12)


@pytest.mark.parametrize("name, a, b, nc, nf", [
    # SCIENCE.md §6 table (calc), 5 significant digits
    ("cr39", 1.48498, 0.004496, 1.4954, 1.5040),
    ("polycarbonate", 1.55637, 0.010229, 1.5801, 1.5997),
    ("trivex", 1.51366, 0.006331, 1.5284, 1.5405),
])
def test_cauchy_coefficients_match_reference_sheet(name, a, b, nc, nf):
    m = CATALOGUE[name]
    assert m.cauchy == pytest.approx((a, b), abs=2e-5)
    assert m.n(LAMBDA_C_NM) == pytest.approx(nc, abs=1e-4)
    assert m.n(LAMBDA_F_NM) == pytest.approx(nf, abs=1e-4)


def test_material_lookup_and_errors():
    assert get_material("CR-39") is CATALOGUE["cr39"]
    assert get_material({"n_d": 1.5}).dispersive is False
    with pytest.raises(SpecError, match="lens.material"):
        get_material("unobtainium")
    with pytest.raises(SpecError, match="n_d"):
        get_material({"n_d": 3.0})
    with pytest.raises(SpecError, match="wavelength"):
        CATALOGUE["cr39"].n(50.0)
