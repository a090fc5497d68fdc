"""A progressive lens: distance power and add at its reference points, as worn, measured
by real-ray pencils; Minkwitz's 2:1 astigmatism gradient beside the corridor."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from eyelab.optics.chain.analysis import analyze_points
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.progressive import ProgressiveDesign, gaze_through, progressive_lens
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.reference.bruteforce import extrapolated_vergence

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def pal():
    rx = Prescription(-2.0, add=2.0)
    lens, design, report = progressive_lens(rx, 2.0)
    return rx, lens, design, report


def _pencil_power(lens, point, distance):
    """Mean power delivered along the gaze through lens point ``point`` (object at
    ``distance`` m from the pupil, or infinity), from real-ray pencils on the vertex
    sphere (Richardson-extrapolated fits), less the object's vergence there."""
    eye = Eye()
    cor = np.array([0.0, 0.0, eye.rotation_centre])
    obj = ObjectPoints.along_gazes(gaze_through(lens, point, eye.rotation_centre), distance,
                                   eye.rotation_centre)
    res = analyze_points(eye, lens, obj, fixation="rotating")
    assert res.status[0] == 0
    q, n_out = res.chief.exit[0], res.chief.dir_out[0]
    r_vs = lens.pose.vertex_distance + eye.rotation_centre
    rel = q - cor
    b = rel @ n_out
    vs = q + (-b - math.sqrt(b * b - (rel @ rel - r_vs ** 2))) * n_out
    (kxx, _, kyy), _ = extrapolated_vergence(lens, res.chief.start[0], res.chief.dir_in[0],
                                             not math.isinf(distance), vs, n_out,
                                             res.eye_x[0])
    o = 0.0 if math.isinf(distance) else -1.0 / np.linalg.norm(obj.positions()[0] - vs)
    return 0.5 * (kxx + kyy) - o


def test_distance_power_and_add_at_the_reference_points_as_worn(pal):
    rx, lens, design, _ = pal
    far = _pencil_power(lens, design.distance_point, math.inf)
    near = _pencil_power(lens, design.near_point, 0.4)
    assert far == pytest.approx(rx.sphere + rx.cylinder / 2, abs=0.03)
    assert near - far == pytest.approx(2.0, abs=0.03)


def _surface_power(lens, x, y):
    n = lens.material.n(587.56)
    k1, k2, *_ = lens.front.principal_curvatures(np.array([x]), np.array([y]))
    return (n - 1) * 0.5 * (k1[0] + k2[0]), (n - 1) * abs(k1[0] - k2[0])


def test_minkwitz_astigmatism_gradient_is_twice_the_power_gradient():
    """On the front surface at mid-corridor of a design without inset: the cylinder
    beside the umbilic line rises twice as fast across it as the mean power does along
    it (docs/SCIENCE.md §8), from the surface's principal curvatures by finite differences."""
    rx = Prescription(-2.0, add=2.0)
    lens, design, _ = progressive_lens(rx, 2.0, design=ProgressiveDesign(2.0, inset=0.0))
    y0 = -design.corridor / 2
    h = 2e-4
    assert _surface_power(lens, 0.0, y0)[1] < 0.01                   # an umbilic
    dp_dy = (_surface_power(lens, 0.0, y0 - h)[0]
             - _surface_power(lens, 0.0, y0 + h)[0]) / (2 * h)        # down the corridor
    d = 1e-3
    dc_dx = 0.5 * (_surface_power(lens, d, y0)[1] + _surface_power(lens, -d, y0)[1]) / d
    ratio = dc_dx / abs(dp_dy)
    print(f"Minkwitz: dCyl/dx / dP/dy = {ratio:.3f} at mid-corridor (dP/dy {dp_dy:.0f} D/m)")
    assert ratio == pytest.approx(2.0, abs=0.1)


@pytest.mark.parametrize("inset", [0.0, 0.0025, 0.005])
def test_the_corridor_is_umbilic_with_its_inset(inset):
    """Along the design's corridor x = u(y), down to 8 mm below its foot, the front
    surface's principal curvatures (the FreeForm spline's exact derivatives) agree: the
    corridor profiles keep the Hessian proportional to the metric, not only the second
    derivatives equal (which left 0.1-0.24 D at the foot and below, and 0.9 D with the
    inset's cross term before it was cancelled)."""
    from eyelab.optics.lens.progressive import _path_terms

    rx = Prescription(-2.0, add=2.0)
    lens, design, _ = progressive_lens(rx, 2.0, design=ProgressiveDesign(2.0, inset=inset))
    ys = np.linspace(0.0, -design.corridor - 0.008, 45)
    xs = _path_terms(ys, design)[1]
    n = lens.material.n(587.56)
    k1, k2, *_ = lens.front.principal_curvatures(xs, ys)
    cyl = (n - 1) * np.abs(k1 - k2)
    print(f"inset {inset * 1e3:.1f} mm: surface cylinder along the corridor <= {cyl.max():.4f} D")
    assert cyl.max() < 0.01
    # and it is where the least cylinder is: 1 mm to either side, mid-corridor (y -4.5 to
    # -9 mm), the cylinder has risen by about 2 x 1 mm x dA/dy (Minkwitz), > 0.35 D
    mid = slice(9, 19)
    for dx in (-1e-3, 1e-3):
        k1, k2, *_ = lens.front.principal_curvatures(xs[mid] + dx, ys[mid])
        assert np.all((n - 1) * np.abs(k1 - k2) > cyl[mid] + 0.35)


def test_design_parameters_are_checked():
    from eyelab.core.errors import SpecError

    with pytest.raises(SpecError, match="lens.corridor_mm"):
        ProgressiveDesign(2.0, corridor=0.05)
    with pytest.raises(SpecError, match="lens.add"):
        ProgressiveDesign(6.0)


def test_the_spec_builds_progressive_lenses_and_refuses_misuse():
    from eyelab.core.errors import SpecError
    from eyelab.optics.rays.surfaces import FreeForm
    from eyelab.spec import parse_spec

    spec = parse_spec({"lens": {"rx": "L -2.00 DS add +2.00", "design": "progressive",
                                "corridor_mm": 16, "inset_mm": 2.0}})
    assert isinstance(spec.lens.front, FreeForm) and spec.lens.rx.add == 2.0
    for lens, field in (({"rx": "-2.00", "design": "progressive"}, "lens.design"),
                        ({"rx": "-2.00 add 2", "corridor_mm": 14}, "lens.corridor_mm"),
                        ({"rx": "-2.00 add 2", "design": "progressive",
                          "base_curve_d": 4}, "lens.base_curve_d")):
        with pytest.raises(SpecError) as e:
            parse_spec({"lens": lens})
        assert e.value.field == field


def test_a_one_eye_progressive_lens_is_made_for_the_eyes_side():
    """A one-eye spec's eye has a side only where its Rx names one: a progressive lens is
    made for that side (its near zone nasal), and a lens Rx naming the other is refused."""
    from eyelab.core.errors import SpecError
    from eyelab.spec import parse_spec

    pal = {"rx": "-1.00 add +2.00", "design": "progressive"}
    for eye, lens_rx, side in (("L -1.00", "-1.00 add +2.00", "L"),
                               ("OD -1.00", "-1.00 add +2.00", "R"),
                               ("-1.00", "OS -1.00 add +2.00", "L"),
                               ("OU -1.00", "L -1.00 add +2.00", "L"),
                               ("R -1.00", "OD -1.00 add +2.00", "R")):
        spec = parse_spec({"eye": {"rx": eye}, "lens": {**pal, "rx": lens_rx}})
        assert spec.lens.design.eye == side, (eye, lens_rx)
    assert parse_spec({"eye": {"rx": "L -1.00 add 2"},
                       "lens": {"design": "progressive"}}).lens.design.eye == "L"
    for eye, lens_rx in (("R -1.00", "L -1.00 add +2.00"), ("OS -1.00", "OD -1.00 add 2")):
        with pytest.raises(SpecError) as e:
            parse_spec({"eye": {"rx": eye}, "lens": {**pal, "rx": lens_rx}})
        assert e.value.field == "lens.rx" and "eye.rx" in e.value.message


def test_a_design_that_does_not_fit_its_lens_names_the_spec_key():
    """Never the engine's surface.sag: the near reference point off the lens, a front too
    steep for the square it is sampled over, a line of sight with no path, an add below
    the design's range: each names the key to change and the relation."""
    from eyelab.core.errors import SpecError
    from eyelab.spec import parse_spec

    pal = {"rx": "-1.00 add +2.00", "design": "progressive"}
    for lens, field, says in (
            ({**pal, "diameter_mm": 30}, "lens.diameter_mm", "must exceed 2 × 16.2"),
            ({**pal, "diameter_mm": 40.05, "corridor_mm": 18, "inset_mm": 0},
             "lens.diameter_mm", "larger diameter_mm"),
            ({**pal, "rx": "+6.00 add +3.00"}, "lens.diameter_mm", "under √2 × 41.5"),
            ({**pal, "rx": "-1.00 add +0.10"}, "lens.rx", "[0.25, 4]")):
        with pytest.raises(SpecError) as e:
            parse_spec({"lens": lens})
        assert e.value.field == field and says in e.value.message, e.value
    parse_spec({"lens": {**pal, "diameter_mm": 33}})
    parse_spec({"lens": {**pal, "rx": "+6.00 add +3.00", "diameter_mm": 55}})


def test_the_view_through_the_pal_reproduces_kakimoto_fig_11():
    """A -2.00 D presbyope (amplitude 0.5 D) through her progressive lens: distance sharp
    through the top, 0.4 m sharp through the near reference point, 0.4 m blurred through
    the lower sides and infinity blurred through the near zone (retinal blur, arcmin)."""
    from eyelab.spec import load_spec

    spec = load_spec(str(ROOT / "docs" / "gallery" / "pal.toml"))
    eye, lens = spec.eye, spec.lens

    def blur(point, dist):
        obj = ObjectPoints.along_gazes(gaze_through(lens, point, eye.rotation_centre), dist,
                                       eye.rotation_centre)
        r = analyze_points(eye, lens, obj, fixation="rotating")
        assert r.status[0] == 0
        return float(r.to_arcmin(r.blur_axes()[0])[0])

    design = ProgressiveDesign(2.0)
    xn, yn = design.near_point
    assert blur(design.distance_point, math.inf) < 0.5
    assert blur((xn, yn), 0.4) < 1.5
    assert blur((0.012, yn), 0.4) > 5.0 and blur((-0.015, yn), 0.4) > 5.0
    assert blur((xn, yn), math.inf) > 5.0


def test_the_raster_blur_field_follows_the_gaze_through_the_pal():
    """The raster renderer's through-lens blur field for three gazes of the room
    (docs/gallery/pal_views.png): looking 5 deg up the 6 m chart is sharp; 28 deg down
    (the near zone) the 0.4 m page is nearly sharp while from the top it was blurred; 28
    down and 25 right (the lower side) the page is blurred (major semi-axis, arcmin)."""
    from eyelab.imaging.contract import new_report
    from eyelab.imaging.options import RasterQuality
    from eyelab.jobs.render import build_scene
    from eyelab.render.raster import RasterRenderer
    from eyelab.spec import load_spec

    spec = load_spec(str(ROOT / "docs" / "gallery" / "pal.toml"))
    scene = build_scene("room")
    q = RasterQuality(samples=1, chromatic=False, field_shape=(96, 24, 24))
    a = math.radians(30.0)
    page = np.array([0.0, -math.sin(a) * 0.4, -math.cos(a) * 0.4])   # the room's page
    chart = np.array([0.0, 0.0, -6.0])
    blur = {}
    with RasterRenderer(q) as r:
        for gaze in ((0.0, 5.0), (-5.0, -28.0), (25.0, -28.0)):
            view = spec.render.with_changes(gaze_deg=list(gaze), width=320, height=240).view
            geo = r._geometry(scene, spec.eye, spec.lens, view, q, new_report("raster", view, q))
            f = geo[4][0]
            blur[gaze] = {name: float(f.sample(f.major_arcmin[..., None], p[None])[0, 0])
                          for name, p in (("page", page), ("chart", chart))}
    assert blur[(0.0, 5.0)]["chart"] < 0.5 and blur[(0.0, 5.0)]["page"] > 8.0
    assert blur[(-5.0, -28.0)]["page"] < 3.0
    assert blur[(25.0, -28.0)]["page"] > 3.0
