import pytest

from eyelab.core.errors import SpecError
from eyelab.optics.rays.materials import (
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
    # docs/SCIENCE.md §6 table (calc), 5 significant digits
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


@pytest.mark.parametrize("name, kind, published", [
    # as published, with the source in eyelab/optics/rays/materials.py
    ("cr39", "d", (1.498, 58.0)),            # Duane's Ophthalmology ch. 51C Table 1
    ("crown", "d", (1.523, 58.6)),           # idem
    ("polycarbonate", "d", (1.586, 30.0)),   # idem
    ("trivex", "d", (1.532, 44.0)),          # PPG (docs/SCIENCE.md §6: V_d 43-45)
    ("mr8", "e", (1.60, 41.0)),              # Mitsui Chemicals MR-8: n_e, V_e
    ("mr7", "e", (1.67, 31.0)),              # MR-7
    ("mr174", "e", (1.74, 32.0)),            # MR-174
])
def test_catalogue_matches_its_sources(name, kind, published):
    m = CATALOGUE[name]
    got = (m.n_d, m.v_d) if kind == "d" else (m.n_e, m.v_e)
    assert got == pytest.approx(published, rel=1e-12)
    assert m.source


def test_nominal_names_are_the_thiourethanes_and_nd_is_below_the_nominal_ne():
    """"1.60"/"1.67"/"1.74" name MR-8/MR-7/MR-174; their nominal numbers are n_e, so n_d
    lies below them (by 0.003-0.006: normal dispersion), and MR-8's V_d is 41, not the
    old catalogue's 36 (MR-6)."""
    for alias, name in (("1.60", "mr8"), ("1.67", "mr7"), ("1.74", "mr174")):
        m = get_material(alias)
        assert m is CATALOGUE[name]
        assert 0.002 < float(alias) - m.n_d < 0.007
    assert get_material("MR-8").v_d == pytest.approx(41.2, abs=0.1)


def test_e_line_conversion_round_trips():
    from eyelab.optics.rays.materials import Material

    m = Material.from_e_line("x", 1.6, 41.0)
    back = Material("y", m.n_d, m.v_d)
    assert (back.n_e, back.v_e) == pytest.approx((1.6, 41.0), rel=1e-12)
