"""The as-worn progressive optimiser: its model Jacobian against finite differences of the
exact residuals, a monotone and deterministic descent, and the optimised designs' figures
(add 2.00 D, distance -2.00 D, corridor 14 mm, inset 2.5 mm, CR-39, the default pose) read
off independent as-worn maps — also after the surface goes through a points file."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.asworn import as_worn_maps
from eyelab.optics.lens.figures import as_worn_figures
from eyelab.optics.lens.optimise import (
    Settings,
    _Problem,
    optimise_progressive,
    optimised_progressive,
)
from eyelab.optics.lens.progressive import progressive_lens

RX = Prescription(-2.0, add=2.0)


@pytest.fixture(scope="module")
def analytic():
    lens, design, _ = progressive_lens(RX, 2.0)
    return lens, design


def test_the_model_jacobian_follows_the_exact_residuals(analytic):
    """A random small change of the coefficients: the exact change of the as-worn errors
    (traced) against the model's (n - 1) x Hessian prediction, per power-vector block."""
    lens, design = analytic
    p = _Problem(lens, design, Settings(n=15, knots=9), 587.56)
    c = np.zeros(p.corr.nc ** 2)
    r0, _, hits = p.residual(c)
    dc = np.random.default_rng(0).normal(size=c.size) * 0.02
    r1, _, _ = p.residual(dc)
    m = len(p.lines)
    exact = (r1 - r0)[:3 * m] / p.sw
    model = (p.jacobian(hits) @ dc)[:3 * m] / p.sw
    for b in range(3):
        e, o = exact[b * m:(b + 1) * m], model[b * m:(b + 1) * m]
        assert np.linalg.norm(e - o) / np.linalg.norm(e) < 0.3
        assert (e @ o) / (o @ o) == pytest.approx(1.0, abs=0.15)


def test_the_merit_falls_monotonically_and_the_result_is_deterministic(analytic):
    lens, design = analytic
    s = Settings(n=13, knots=7, max_iterations=4)
    a = optimise_progressive(lens, design, settings=s)[1]
    b = optimise_progressive(lens, design, settings=s)[1]
    assert np.all(np.diff(a["merit"]) < 0) and a["merit_end"] < 0.6 * a["merit_start"]
    assert a["variables"] == 100 and a["iterations"] >= 1
    np.testing.assert_array_equal(a["coefficients"], b["coefficients"])


def _figures(lens):
    eye = Eye()
    m30 = as_worn_maps(eye, lens, half_angle_deg=30.0, n=31)
    f = as_worn_figures(as_worn_maps(eye, lens, half_angle_deg=40.0, n=41), eye, lens)
    f["peak30_d"] = float(np.nanmax(np.abs(m30.cylinder_d)))
    return f, m30


@pytest.mark.parametrize("preset,peak", [("soft", 1.5), pytest.param(
    "hard", 2.0, marks=pytest.mark.slow)])          # the hard preset: eyelab bench design too
def test_optimised_designs_meet_a_labs_figures(preset, peak, tmp_path):
    lens, design, report = optimised_progressive(RX, 2.0, preset)
    f, m30 = _figures(lens)
    c, um = f["corridor"], f["corridor_umbilic"]
    bound = 2 * c["length_mm"] * 0.5 / (2.0 * math.log(9))          # Alonso: 2LC/(A ln 9)
    print(f"{preset}: DRP {f['distance_reference']['mean_power_d']:+.3f} D, add "
          f"{f['add_as_worn_d']:.3f} D, path cylinder {um['path_cylinder_max_d']:.3f} D, "
          f"width {c['widths']['0.50']['min_width_mm']:.2f} mm (bound {bound:.2f}), peak "
          f"{f['peak30_d'] / 2:.2f} x add, Minkwitz {um['minkwitz_at_path']['ratio']:.2f}, "
          f"{report['optimised']['seconds']:.1f} s")
    assert f["distance_reference"]["mean_power_d"] == pytest.approx(-2.0, abs=0.03)
    assert f["add_as_worn_d"] == pytest.approx(2.0, abs=0.03)
    assert um["path_cylinder_max_d"] <= 0.25
    assert c["widths"]["0.50"]["min_width_mm"] >= 0.8 * bound
    assert f["peak30_d"] <= peak * 2.0
    assert um["minkwitz_at_path"]["ratio"] == pytest.approx(2.0, abs=0.2)
    if preset != "soft":
        return
    # the surface through a points file (7 decimals, 0.5 mm): the same maps within 0.02 D
    from eyelab.optics.lens.pointsfile import sample_surface, write_points
    from eyelab.spec import parse_spec

    path = tmp_path / "front.sdf"
    write_points(path, sample_surface(lens.front, 0.5, 60.0))
    back = lens.back
    spec = parse_spec({"lens": {
        "rx": RX.format(), "material": "cr39", "diameter_mm": lens.diameter * 1e3,
        "center_thickness_mm": lens.center_thickness * 1e3,
        "front": {"file": str(path)},
        "back": {"type": "sphere", "curvature": back.curvature}}})
    again = as_worn_maps(Eye(), spec.lens, half_angle_deg=30.0, n=31)
    for name in ("mean_error_d", "cylinder_d"):
        assert np.nanmax(np.abs(getattr(again, name) - getattr(m30, name))) < 0.02
