"""Impossible lenses are refused when built, naming the field and saying what would make
them feasible; the suggested fixes are feasible."""

from __future__ import annotations

import re

import pytest

from eyelab.core.errors import SpecError
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.lens.spectacle import MIN_EDGE_THICKNESS, SpectacleLens
from eyelab.optics.rays.surfaces import Sphere
from eyelab.spec import parse_spec


@pytest.mark.parametrize("lens", [
    {"rx": "+6.00", "center_thickness_mm": 2.0},                      # plus lens, no edge
    {"rx": "+4.00 -1.00 x 90", "center_thickness_mm": 3.0, "diameter_mm": 70},
    {"rx": "+8.00", "center_thickness_mm": 4.0, "material": "mr174"},
    {"front": {"radius_mm": 50}, "back": {"radius_mm": 200}, "center_thickness_mm": 1.0},
])
def test_infeasible_lenses_name_the_field_and_the_fixes_work(lens):
    with pytest.raises(SpecError) as e:
        parse_spec({"lens": lens})
    assert e.value.field == "lens.center_thickness_mm"
    msg = e.value.message
    t = float(re.search(r"center_thickness_mm to >= ([\d.]+)", msg).group(1))
    parse_spec({"lens": dict(lens, center_thickness_mm=t + 0.01)})      # the fix is enough
    d = re.search(r"diameter_mm to <= (\d+)", msg)
    if d:
        parse_spec({"lens": dict(lens, diameter_mm=float(d.group(1)))})


def test_minus_lens_below_the_material_minimum_and_thin_edges():
    with pytest.raises(SpecError, match="minimum for a minus lens") as e:
        parse_spec({"lens": {"rx": "-4.00", "center_thickness_mm": 0.5}})
    assert e.value.field == "lens.center_thickness_mm"
    # automatic thickness: always feasible, with at least the minimum edge
    for rx in ("+6.00", "+4.00 -2.00 x 30", "-8.00 -3.00 x 170", "+10.00"):
        lens = SpectacleLens.from_rx(Prescription.parse(rx))
        assert lens.edge_thickness()[0] >= MIN_EDGE_THICKNESS - 1e-9


def test_crossing_surfaces_are_refused_in_the_library_too():
    from eyelab.optics.rays.materials import CATALOGUE

    with pytest.raises(SpecError, match="surfaces cross"):
        SpectacleLens(Sphere(20.0), Sphere(-5.0), 0.002, CATALOGUE["cr39"], 0.06)
