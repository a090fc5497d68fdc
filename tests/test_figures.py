"""The designer's figures of merit (eyelab/optics/lens/figures.py): on synthetic maps whose
answers are known in closed form, on the built-in progressive and single-vision lenses,
and in `eyelab maps`."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from eyelab.apps.cli import main
from eyelab.jobs.maps import FIGURES_GRID, maps_figures
from eyelab.optics.lens.asworn import as_worn_maps
from eyelab.optics.lens.figures import (
    LensMap,
    as_worn_figures,
    clear_field,
    lens_map,
    point_powers,
    progressive_figures,
)
from eyelab.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]
PAL = ROOT / "docs" / "gallery" / "pal_analytic.toml"


def logistic_lens(add, s, y0, inset, step=0.05):
    """A synthetic progressive lens map (mm, D): the add along the corridor rises as a
    logistic A / (1 + exp((y - y0) / s)) (y up, so the add grows downward), the umbilic
    line x = u(y) = inset A(y) / A moves nasally with it, the mean power is -2 D + A(y)
    across each section, and beside the umbilic the cylinder grows as Minkwitz's theorem
    says, C = 2 |x - u(y)| dA/dy. Returns the LensMap and the closed forms."""
    x = np.arange(-15.0, 15.0 + 1e-9, step)
    y = np.arange(-25.0, 10.0 + 1e-9, step)
    gx, gy = np.meshgrid(x, y)

    def a(v):
        return add / (1.0 + np.exp((v - y0) / s))

    def da(v):
        e = np.exp((v - y0) / s)
        return add / s * e / (1.0 + e) ** 2

    u = inset * a(gy) / add
    lm = LensMap(x, y, -2.0 + a(gy), 2.0 * np.abs(gx - u) * da(gy), (0.0, 4.0),
                 (inset, -16.0))
    return lm, a, da


@pytest.mark.parametrize("add, s, y0, inset", [(2.0, 1.2, -8.0, -2.5), (1.0, 1.5, -6.0, 0.0)])
def test_a_logistic_corridor_has_its_closed_form_figures(add, s, y0, inset):
    """On the logistic corridor with Minkwitz's cylinder the figures are, in closed form
    (L: the 10-90 % corridor length; the 10 % and 90 % points lie at y0 -+ s ln 9):
    L = 2 s ln 9; the narrowest corridor width at cylinder C is C / max(dA/dy) =
    4 s C / A = 2 L C / (A ln 9), at y0; Minkwitz's ratio 1; each zone section's width
    0.5 / (dA/dy) (cylinder 0.50 D); the near zone's top where A(y) = A - 0.25 D, y0 +
    s ln(0.25 / (A - 0.25)), and the minimum fitting height 4 mm below it; the peak
    cylinder the map's largest 2 |x - u| dA/dy. All within 2 % (most to 0.3 %)."""
    lm, a, da = logistic_lens(add, s, y0, inset)
    f = progressive_figures(lm)
    c = f["corridor"]
    length = 2 * s * math.log(9)
    assert f["add_as_worn_d"] == pytest.approx(add, rel=0.01)
    assert c["length_mm"] == pytest.approx(length, rel=0.01)
    assert c["y10_mm"] == pytest.approx(y0 + s * math.log(9), abs=0.05)
    for level in (0.50, 0.75):
        w = c["widths"][f"{level:.2f}"]
        assert w["min_width_mm"] == pytest.approx(2 * length * level / (add * math.log(9)),
                                                  rel=0.02)
        assert w["at_y_mm"] == pytest.approx(y0, abs=0.1) and not w["open"]
    assert f["minkwitz"]["ratio"] == pytest.approx(1.0, rel=0.02)
    assert f["minkwitz"]["cylinder_gradient_d_per_mm"] == pytest.approx(
        2 * f["minkwitz"]["power_gradient_d_per_mm"], rel=0.02)
    top = y0 + s * math.log(0.25 / (add - 0.25))
    assert c["near_zone_top_mm"] == pytest.approx(top, abs=0.05)
    assert f["minimum_fitting_height_mm"] == pytest.approx(4.0 - top, rel=0.01)
    for zone in ("distance_zone", "near_zone"):
        closed = [r for r in f[zone]["sections"] if not r["open"] and r["width_mm"] > 0]
        assert len(closed) >= 2
        for r in closed:
            assert r["width_mm"] == pytest.approx(0.5 / da(r["y_mm"]), rel=0.02), r
    ys = np.arange(-25.0, 10.0, 0.01)
    u = inset * a(ys) / add
    peak = np.max(2 * np.maximum(15.0 - u, u + 15.0) * da(ys))
    assert f["peak_cylinder"]["d"] == pytest.approx(peak, rel=0.01)


def test_a_quadratic_field_has_its_closed_form_clear_field():
    """Mean power error k r^2 and cylinder q r^2 (J0, J45 = q r^2 / 2 (cos, sin) 2 phi)
    over eye rotations: clear to sqrt(0.25 / k) for the power, sqrt(0.25 / q) for the
    cylinder, the smaller for both, limited by the cylinder here (0.05 deg steps); a field
    cut off where no light path exists ends within a grid cell of the cut."""
    g = np.arange(-30.0, 30.0 + 1e-9, 1.0)
    gx, gy = np.meshgrid(g, g)
    r2, phi = gx ** 2 + gy ** 2, np.arctan2(gy, gx)
    k, q = 0.25 / 20.0 ** 2, 0.25 / 15.0 ** 2
    f = clear_field(g, g, k * r2, q * r2 / 2 * np.cos(2 * phi), q * r2 / 2 * np.sin(2 * phi))
    assert f["radius_mean_power_error_deg"] == pytest.approx(20.0, abs=0.06)
    assert f["radius_cylinder_deg"] == pytest.approx(15.0, abs=0.06)
    assert f["radius_deg"] == f["radius_cylinder_deg"] and f["limited_by"] == ["cylinder"]
    assert not f["open"]
    # without a path beyond 12 deg: clear up to the first grid cell touching such a point
    ok = np.hypot(gx, gy) < 12.0
    assert 12.0 - math.sqrt(2) <= clear_field(g, g, 0 * r2, 0 * r2, 0 * r2, ok)["radius_deg"] \
        <= 12.0


@pytest.fixture(scope="module")
def pal():
    spec = load_spec(PAL)
    maps = as_worn_maps(spec.eye, spec.lens, **FIGURES_GRID)
    return spec, maps, as_worn_figures(maps, spec.eye, spec.lens)


def test_the_built_in_progressive_lens_has_sensible_figures(pal):
    """docs/gallery/pal_analytic.toml (-2.00 D, add +2.00, 14 mm corridor, 2.5 mm inset): the add
    as worn within 0.25 D of the nominal; the reference points' powers those of the Rx;
    the 10-90 % corridor length within 1.5 mm of the design's own (its smoothstep add
    rises from 10 % to 90 % over 0.54 x 14 mm = 7.6 mm) and the full add (within 0.25 D)
    reached within the 14 mm corridor; finite corridor widths; Minkwitz's ratio near 1
    (the design is umbilic along its corridor); the peak cylinder several times the add."""
    spec, _, f = pal
    design = spec.lens.design
    assert f["kind"] == "progressive"
    assert f["add_as_worn_d"] == pytest.approx(spec.lens.rx.add, abs=0.25)
    assert f["distance_reference"]["mean_power_d"] == pytest.approx(-2.0, abs=0.1)
    assert f["near_reference"]["mean_power_d"] == pytest.approx(0.0, abs=0.1)
    assert f["near_reference"]["lens_mm"] == pytest.approx([v * 1e3 for v in design.near_point],
                                                           abs=1e-4)

    def smooth(t):
        return t ** 3 * (10 - 15 * t + 6 * t * t)

    t10, t90 = (brentq(lambda t, v=v: smooth(t) - v, 0, 1) for v in (0.1, 0.9))
    corridor_mm = design.corridor * 1e3
    c = f["corridor"]
    assert c["length_mm"] == pytest.approx((t90 - t10) * corridor_mm, abs=1.5)
    assert 0.5 * corridor_mm < -c["near_zone_top_mm"] < corridor_mm
    w50, w75 = (c["widths"][k]["min_width_mm"] for k in ("0.50", "0.75"))
    assert 0.5 < w50 < w75 < 5.0
    assert 0.8 < f["minkwitz"]["ratio"] < 1.25
    # the corridor umbilic as worn too: little cylinder along the eye's path, and at the
    # path the cylinder rises at Minkwitz's 2 x dP/dy
    um = f["corridor_umbilic"]
    assert um["path_cylinder_max_d"] < 0.15
    assert um["minkwitz_at_path"]["ratio"] == pytest.approx(2.0, abs=0.1)
    assert 3.0 < f["peak_cylinder"]["ratio_to_add"] < 8.0
    assert f["minimum_fitting_height_mm"] == pytest.approx(4.0 - c["near_zone_top_mm"])
    assert f["near_zone"]["width_at_reference_mm"] > 5.0
    assert all(r["width_mm"] >= 0 for r in f["distance_zone"]["sections"])


def test_the_lens_map_holds_the_traced_powers(pal):
    """The maps carried onto the lens (resampled over front-surface points) give, at the
    reference points, the mean powers traced there exactly, to 0.005 D."""
    spec, maps, _ = pal
    lm = lens_map(maps, spec.eye, spec.lens)
    for mark, point in (("distance reference", lm.distance_point_mm),
                        ("near reference", lm.near_point_mm)):
        exact = point_powers(spec.eye, spec.lens, maps.marks[mark], maps.model)
        assert exact["lens_mm"] == pytest.approx(list(point), abs=1e-4)
        assert float(lm.at("mean_power_d", *point)) == pytest.approx(exact["mean_power_d"],
                                                                    abs=0.005)


def test_the_default_single_vision_lens_has_its_subset():
    """The default spec (-3.00 / -1.00 x 180, 8 deg tilt): its power at the lens centre is
    the Rx within 0.1 D; the clear field is the smaller of the power's and the cylinder's,
    every grid point inside it is within 0.25 D (to 0.01 D), and one within a grid step
    beyond it is not."""
    spec = load_spec(None)
    maps = as_worn_maps(spec.eye, spec.lens, **FIGURES_GRID)
    f = maps_figures(spec.eye, spec.lens, maps=maps)
    oc, cf = f["optical_centre"], f["clear_field"]
    assert f["kind"] == "single vision"
    assert (oc["sphere_d"], oc["cylinder_d"]) == pytest.approx((-3.0, -1.0), abs=0.1)
    assert oc["lens_mm"] == pytest.approx([0.0, 0.0], abs=1e-4)
    r = cf["radius_deg"]
    assert r == min(cf["radius_mean_power_error_deg"], cf["radius_cylinder_deg"])
    gx, gy = np.meshgrid(maps.eye_rotation_x_deg, maps.eye_rotation_y_deg)
    rad = np.hypot(gx, gy)
    worst = np.maximum(np.abs(maps.mean_error_d), np.abs(maps.cylinder_d))
    assert worst[rad <= r].max() <= 0.26
    assert worst[rad <= r + 2.0 * math.sqrt(2)].max() > 0.25


def test_maps_prints_and_writes_the_figures(tmp_path, capsys, monkeypatch):
    """`eyelab maps` prints the figures and writes them under "figures" in its JSON (no
    NaN: JSON has none)."""
    monkeypatch.setitem(FIGURES_GRID, "n", 21)
    png, js = tmp_path / "m.png", tmp_path / "m.json"
    assert main(["maps", str(PAL), "-o", str(png), "--json", str(js), "--points", "9"]) == 0
    out = capsys.readouterr().out
    assert "corridor" in out and "Minkwitz" in out and "minimum fitting height" in out

    def no_nan(v):
        raise ValueError(v)

    f = json.loads(js.read_text(), parse_constant=no_nan)["figures"]
    assert f["kind"] == "progressive" and f["grid"] == {"half_angle_deg": 40.0, "step_deg": 4.0}
    assert {"corridor", "distance_zone", "near_zone", "minkwitz", "peak_cylinder",
            "minimum_fitting_height_mm", "surface"} <= set(f)
